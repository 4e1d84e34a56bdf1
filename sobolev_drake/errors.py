"""The package's exception hierarchy: one base, one subclass per area.

Every exception the package raises on purpose derives from :class:`SobolevDrakeError`, and every
warning it emits from :class:`SobolevDrakeWarning`, so ``except sd.SobolevDrakeError`` catches
the package's own failures and nothing else.  The area bases below are subclassed where the
errors are raised (``synthesis.lmi.InfeasibleLMIError``, ``simulation_errors.SimulationTimeout``,
``campaign.errors.CampaignLockedError``, ...); each keeps the built-in base it had before
(``RuntimeError``, ``ValueError``, ``KeyError``, ``TimeoutError``, ``TypeError``) as a second
base, so code catching those still catches them::

    SobolevDrakeError
    ├── SynthesisError (RuntimeError)     a design failed or did not pass its certificate
    │   ├── InfeasibleLMIError ── GammaNotReachable
    │   ├── RiccatiInfeasible, BudgetExceeded
    │   ├── GalerkinDivergenceError, GalerkinConvergenceError
    │   └── AdmissibilityError, SaddlePointError (also ValueError)
    ├── ModelError                         a model or user function cannot be used as asked
    │   └── UnreachableThrustError (ValueError), Unsupported (ValueError),
    │       ObjectEvaluationError (TypeError)
    ├── SimulationError                    a simulation could not be finished
    │   └── SimulationTimeout (TimeoutError), SimulationDiverged, SimulationStalled (RuntimeError)
    ├── CampaignError                      a campaign cannot start or go on
    │   └── CampaignFolderError (ValueError) ── CorruptRecordsError, CampaignLockedError,
    │       ClusterUnavailableError, ClusterLostError, DesignFailed, UnknownCampaignError (KeyError)
    ├── DataFileError (ValueError)         a data file is damaged or of another schema
    ├── UnknownExperimentError (KeyError)
    └── UsageError                         the command line was misused
    SobolevDrakeWarning (UserWarning)
    └── SynthesisWarning

Examples
--------
>>> import sobolev_drake as sd
>>> issubclass(sd.InfeasibleLMIError, sd.SobolevDrakeError), issubclass(sd.SynthesisError, RuntimeError)
(True, True)
"""

from __future__ import annotations

__all__ = ["SobolevDrakeError", "SobolevDrakeWarning", "SynthesisError", "ModelError",
           "SimulationError", "CampaignError"]


class SobolevDrakeError(Exception):
    """Base of every exception the package raises on purpose."""


class SobolevDrakeWarning(UserWarning):
    """Base of every warning the package emits."""


class SynthesisError(SobolevDrakeError, RuntimeError):
    """A synthesis failed or its result did not pass an independent check."""


class ModelError(SobolevDrakeError):
    """A model (plant, user function, actuator layout) cannot be used as asked."""


class SimulationError(SobolevDrakeError):
    """A simulation could not be finished (time limit, divergence, stall)."""


class CampaignError(SobolevDrakeError):
    """Base of the campaign errors."""
