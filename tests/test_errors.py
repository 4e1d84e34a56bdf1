"""One exception hierarchy: every exception class of the package derives from
``SobolevDrakeError`` (warnings from ``SobolevDrakeWarning``) and keeps its former built-in base."""

import importlib
import inspect
import pkgutil

import pytest

import sobolev_drake as sd
from sobolev_drake import errors


def package_exceptions():
    found = {}
    for info in pkgutil.walk_packages(sd.__path__, "sobolev_drake."):
        if info.name.endswith("__main__"):
            continue
        module = importlib.import_module(info.name)
        for obj in vars(module).values():
            if (inspect.isclass(obj) and issubclass(obj, BaseException)
                    and obj.__module__.startswith("sobolev_drake")):
                found[f"{obj.__module__}.{obj.__name__}"] = obj
    return found


def test_every_exception_of_the_package_shares_the_base():
    found = package_exceptions()
    assert len(found) >= 27   # the classes that existed when the hierarchy was introduced
    stray = sorted(name for name, cls in found.items()
                   if not issubclass(cls, (errors.SobolevDrakeError, errors.SobolevDrakeWarning)))
    assert stray == []
    warnings_outside = sorted(name for name, cls in found.items()
                              if issubclass(cls, Warning)
                              and not issubclass(cls, errors.SobolevDrakeWarning))
    assert warnings_outside == []


@pytest.mark.parametrize("name, area, builtin", [
    ("sobolev_drake.synthesis.lmi.SynthesisError", errors.SynthesisError, RuntimeError),
    ("sobolev_drake.synthesis.lmi.InfeasibleLMIError", errors.SynthesisError, RuntimeError),
    ("sobolev_drake.synthesis.hinf_riccati.GammaNotReachable", errors.SynthesisError, RuntimeError),
    ("sobolev_drake.synthesis.riccati.RiccatiInfeasible", errors.SynthesisError, Exception),
    ("sobolev_drake.synthesis.riccati.BudgetExceeded", errors.SynthesisError, Exception),
    ("sobolev_drake.synthesis.galerkin_problem.GalerkinDivergenceError", errors.SynthesisError,
     RuntimeError),
    ("sobolev_drake.synthesis.galerkin_problem.GalerkinConvergenceError", errors.SynthesisError,
     RuntimeError),
    ("sobolev_drake.synthesis.galerkin_problem.AdmissibilityError", errors.SynthesisError,
     ValueError),
    ("sobolev_drake.synthesis.galerkin_problem.SaddlePointError", errors.SynthesisError,
     ValueError),
    ("sobolev_drake.synthesis.galerkin_basis.ObjectEvaluationError", errors.ModelError, TypeError),
    ("sobolev_drake.tiltrotor.allocation.UnreachableThrustError", errors.ModelError, ValueError),
    ("sobolev_drake.native.rnea.Unsupported", errors.ModelError, ValueError),
    ("sobolev_drake.simulation_errors.SimulationTimeout", errors.SimulationError, TimeoutError),
    ("sobolev_drake.simulation_errors.SimulationDiverged", errors.SimulationError, RuntimeError),
    ("sobolev_drake.simulation_errors.SimulationStalled", errors.SimulationError, RuntimeError),
    ("sobolev_drake.campaign.errors.CampaignError", errors.CampaignError, Exception),
    ("sobolev_drake.campaign.errors.CampaignFolderError", errors.CampaignError, ValueError),
    ("sobolev_drake.campaign.errors.CorruptRecordsError", errors.CampaignError, ValueError),
    ("sobolev_drake.campaign.case.DesignFailed", errors.CampaignError, Exception),
    ("sobolev_drake.campaign.registry.UnknownCampaignError", errors.CampaignError, KeyError),
    ("sobolev_drake.experiments.UnknownExperimentError", errors.SobolevDrakeError, KeyError),
    ("sobolev_drake.datafile.DataFileError", errors.SobolevDrakeError, ValueError),
    ("sobolev_drake.cli.UsageError", errors.SobolevDrakeError, Exception),
    ("sobolev_drake.synthesis.problem.SynthesisWarning", errors.SobolevDrakeWarning, UserWarning),
])
def test_old_names_still_import_and_keep_their_builtin_base(name, area, builtin):
    module, cls_name = name.rsplit(".", 1)
    cls = getattr(importlib.import_module(module), cls_name)
    assert issubclass(cls, area) and issubclass(cls, builtin)


def test_one_class_per_name_across_the_reexports():
    # the old import locations re-export the same class, not a copy
    assert sd.SynthesisError is errors.SynthesisError
    assert importlib.import_module("sobolev_drake.synthesis").SynthesisError is errors.SynthesisError
    assert importlib.import_module("sobolev_drake.campaign.errors").CampaignError \
        is errors.CampaignError


def test_catching_the_base_catches_a_synthesis_failure():
    # an unreachable gamma on a regular problem: the Riccati conditions fail
    P = sd.GeneralizedPlant.make([[0, 1], [-1, -0.5]], B1=[[0], [1]], B2=[[0], [1]],
                                 C1=[[1, 0], [0, 0]], D12=[[0], [1]])
    with pytest.raises(sd.SobolevDrakeError, match="gamma"):
        sd.hinf_state_feedback(P, gamma=0.1)
