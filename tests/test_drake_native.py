"""Every LeafSystem of the package converts scalar type or refuses by name (issue #31).

The conversions themselves are tested per family, each converted system's outputs against the
double system's: tests/systems/test_drake_native_sources.py (wind, disturbances, references),
tests/systems/test_drake_native_linear.py (linear and Galerkin controllers),
tests/systems/test_drake_native_mechanical.py (mechanical controller, force adapter, and
Drake's Linearize of the README's arm loop against the design poles),
tests/tiltrotor/test_drake_native_tiltrotor.py (tilt-rotor forces, linear hover controller).
This module finds every LeafSystem class the package defines and checks that one of those
modules exercises it, so a new system cannot ship unconverted and untested; and it checks the
documented refusals of the double-only systems here.
"""

import importlib
import inspect
import pkgutil
import re
from pathlib import Path

import pytest
from pydrake.systems.framework import DiagramBuilder, LeafSystem_
from pydrake.systems.scalar_conversion import TemplateSystem

import sobolev_drake

ROOT = Path(__file__).resolve().parents[1]
CONVERSION_TESTS = sorted(ROOT.glob("tests/*/test_drake_native_*.py")) + [Path(__file__)]


def leaf_system_classes() -> dict:
    """{class name (without the template suffix): class} of every LeafSystem defined here."""
    found = {}
    for info in pkgutil.walk_packages(sobolev_drake.__path__, "sobolev_drake."):
        if info.name.endswith("__main__"):
            continue
        module = importlib.import_module(info.name)
        for obj in list(vars(module).values()):
            if isinstance(obj, TemplateSystem) and obj.get_module_name() == module.__name__:
                obj = obj[float]               # instantiated now: discovery must not depend on
            if inspect.isclass(obj) and obj.__module__ == module.__name__ and any(   # test order
                    issubclass(obj, LeafSystem_[T]) for (T,) in LeafSystem_.param_list):
                found[re.sub(r"_?(𝓣.*𝓤)?$", "", obj.__name__)] = obj
    return found


def test_every_leaf_system_is_exercised_by_a_conversion_test():
    systems = leaf_system_classes()
    assert len(systems) >= 18, sorted(systems)
    text = "\n".join(p.read_text(encoding="utf-8") for p in CONVERSION_TESTS)
    missing = sorted(name for name in systems if not re.search(rf"\b{name}_?\b", text))
    assert missing == [], f"LeafSystems without a scalar-conversion test: {missing}"
    # and each documents its ports the pydrake way, naming itself
    undocumented = sorted(name for name, cls in systems.items()
                          if not re.search(r"\.\. pydrake_system::\s+name: \w+", cls.__doc__ or ""))
    assert undocumented == [], f"LeafSystems without a .. pydrake_system:: block: {undocumented}"


def _tiltrotor_controller():
    from sobolev_drake.tiltrotor.mission import build_mission

    return build_mission(2, 1.0)["controller"]


def _allocator():
    from sobolev_drake.tiltrotor.allocation import ControlAllocator
    return ControlAllocator()


@pytest.mark.parametrize("make, name", [(_tiltrotor_controller, "TiltrotorWInfController"),
                                        (_allocator, "ControlAllocator")])
def test_double_only_systems_refuse_naming_themselves_and_the_alternative(make, name):
    system = make()
    for convert, scalar in ((system.ToAutoDiffXd, "AutoDiffXd"), (system.ToSymbolic, "Expression")):
        with pytest.raises(RuntimeError, match=rf"{name}.* does not convert to {scalar}: .*instead"):
            convert()
    # a diagram holding one does not convert either, and Drake's message names the class
    builder = DiagramBuilder()
    builder.AddSystem(_allocator())
    diagram = builder.Build()
    assert diagram.ToAutoDiffXdMaybe() is None


def test_the_tiltrotor_controller_takes_its_first_sample_at_initialization():
    """No hold-at-zero start: after Initialize the outputs are the first sample, and the
    periodic event at the same time leaves it (the samples are those of an offset-0 schedule)."""
    import numpy as np
    from pydrake.systems.analysis import Simulator

    from sobolev_drake.tiltrotor.mission import build_mission

    built = build_mission(2, 1.0)
    ctrl = built["controller"]
    simulator = Simulator(built["diagram"])
    ctx = ctrl.GetMyContextFromRoot(simulator.get_context())
    before = ctrl.GetOutputPort("propeller_speed").Eval(ctx).copy()
    assert np.all(before == 0.0)                      # a context not yet initialized
    simulator.Initialize()
    first = ctrl.GetOutputPort("sample_record").Eval(ctx).copy()
    assert np.all(ctrl.GetOutputPort("propeller_speed").Eval(ctx) > 0)
    simulator.AdvanceTo(0.5 * ctrl.period)            # the t = 0 periodic event ran: no change
    np.testing.assert_array_equal(ctrl.GetOutputPort("sample_record").Eval(ctx), first)
    simulator.AdvanceTo(1.5 * ctrl.period)            # the next sample integrates the error
    assert not np.array_equal(ctrl.GetOutputPort("sample_record").Eval(ctx), first)


def test_the_tiltrotor_controller_models_a_one_sample_computation_delay():
    import numpy as np
    from pydrake.systems.analysis import Simulator

    from sobolev_drake.tiltrotor.controller import TiltrotorWInfController
    from sobolev_drake.tiltrotor.mission import build_mission

    built = build_mission(2, 1.0)
    mission_ctx = built["diagram"].CreateDefaultContext()
    source = built["controller"]
    inputs = [source.get_input_port(i).Eval(source.GetMyContextFromRoot(mission_ctx)).copy()
              for i in range(source.num_input_ports())]
    inputs[1] = inputs[1] + np.r_[1.0, -0.5, 0.3, np.zeros(9)]   # a tracking error: ∫e grows
    runs = {}
    for delay in (False, True):
        ctrl = TiltrotorWInfController(source.law, period=source.period, computation_delay=delay)
        ctx = ctrl.CreateDefaultContext()
        for i, value in enumerate(inputs):
            ctrl.get_input_port(i).FixValue(ctx, value)
        sim = Simulator(ctrl, ctx)
        sim.Initialize()
        out = []
        for k in range(3):                             # after samples 0, 1, 2
            sim.AdvanceTo((k + 0.5) * ctrl.period)
            out.append(ctrl.GetOutputPort("propeller_speed").Eval(ctx).copy())
        runs[delay] = out
    now, late = runs[False], runs[True]
    assert not np.array_equal(now[0], now[1])         # the samples differ
    np.testing.assert_array_equal(late[0], now[0])    # the first sample goes out at once
    np.testing.assert_array_equal(late[1], now[0])    # then each one a period late
    np.testing.assert_array_equal(late[2], now[1])
