"""Drake-native sources (#31): references, disturbances and wind convert scalar type, keep their
numbers in the Context, document their ports, and accept Drake Trajectories.

Tolerances: the float system and its AutoDiffXd/symbolic conversion evaluate the same formula
in double arithmetic; they may differ by the libm routine (``math.sin`` vs ``std::sin`` through
``pydrake.math``) and by the order of a few roundings (symbolic constant folding), so values
agree to a few ulps of the output's magnitude: ``ULPS`` units of eps·max(1, |y|).
"""

from __future__ import annotations

import inspect
import math
import re

import numpy as np
import pytest
from pydrake.autodiffutils import AutoDiffXd
from pydrake.math import RigidTransform
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import FixedOffsetFrame, RevoluteJoint, SpatialInertia, UnitInertia
from pydrake.symbolic import Expression, Variable
from pydrake.systems.analysis import Simulator, Simulator_
from pydrake.systems.framework import DiagramBuilder
from pydrake.trajectories import PiecewisePolynomial

from sobolev_drake.models.base import MechanicalModel
from sobolev_drake.systems import disturbances as dist
from sobolev_drake.systems import references as refs
from sobolev_drake.systems import wind
from sobolev_drake.systems.reference_catalogue import trajectory
from sobolev_drake.systems.scalar_time import (interval_indicator, piecewise, scalar_value,
                                               smooth_window)

EPS = np.finfo(float).eps
ULPS = 4.0   # measured: at most 0.62 ulps (the filter's float matmul vs the object-array sum)


def close(a, b, ulps=ULPS):
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return np.all(np.abs(a - b) <= ulps * EPS * np.maximum(1.0, np.abs(b)))


def values(y):
    """Float values of an output vector of any scalar type (constant expressions evaluated)."""
    return np.array([scalar_value(v, "output") for v in y])


def arm():
    """Two revolute joints with non-parallel axes, thesis order swapped and scaled."""
    plant = MultibodyPlant(0.0)
    M = SpatialInertia.MakeFromCentralInertia(1.0, [0.2, 0, 0], UnitInertia.SolidBox(0.4, 0.1, 0.1))
    parent = plant.world_body()
    for i, axis in enumerate(([0, 0, 1], [0, 1, 0])):
        body = plant.AddRigidBody(f"b{i}", M)
        F = plant.AddFrame(FixedOffsetFrame(f"F{i}", parent.body_frame(), RigidTransform([0.4 * i, 0.1, 0])))
        plant.AddJoint(RevoluteJoint(f"j{i}", F, body.body_frame(), axis))
        parent = body
    plant.Finalize()
    return MechanicalModel(plant, coordinate_map=[[0.0, 1.0], [2.0, 0.0]], dof_names=["a", "b"])


def cubic():
    """Two-row cubic spline on [0, 3] (continuous second derivative)."""
    return PiecewisePolynomial.CubicWithContinuousSecondDerivatives(
        [0.0, 1.0, 2.0, 3.0], [[0.0, 1.0, 0.0, 2.0], [1.0, 0.0, 1.5, 0.0]], np.zeros((2, 1)), np.zeros((2, 1)))


PULSES = [{"index": 0, "value": 40.0, "from": 10.0, "to": 20.0},
          {"index": 1, "value": lambda t: -40 * np.sin(2 * np.pi * t / 10), "from": 25.0, "to": 35.0}]
GUSTS = [{"axis": "y", "value": 5.0, "from": 20.0, "to": 23.0},
         {"axis": "z", "value": -3.0, "from": 21.0, "to": 25.0}]


def turbulence_context(system, context):
    system.seed(context, 3, stationary=True)


# (name, factory, times, {input port: value}, context setup)
CASES = [
    ("table_7_1", lambda: refs.TrajectoryReference(trajectory("table_7_1")),
     (0.3, 105.0, 110.0, 125.0, 150.0, 200.0), {}, None),
    ("table_5_5", lambda: refs.TrajectoryReference(trajectory("table_5_5")), (1.0, 8.0, 8.5, 29.0), {}, None),
    ("envelope", lambda: refs.TrajectoryReference(trajectory("envelope_mission")), (10.0, 100.0, 200.0), {}, None),
    ("piecewise_polynomial", lambda: refs.TrajectoryReference(cubic(), ["u", "v"]), (0.4, 1.0, 2.9, 4.0), {},
     None),
    ("time_profiled_force", lambda: dist.TimeProfiledForce(
        2, PULSES, function=lambda t: np.array([0.5 * t, np.cos(t)])), (5.0, 10.0, 20.0, 27.5), {}, None),
    ("cartesian_force", lambda: dist.CartesianForceAtBody(arm(), "b1", p_BQ=[0.3, 0.0, 0.1]), (0.0,),
     {"x": [0.4, -0.7, 0.0, 0.0], "force": [1.0, -2.0, 0.5]}, None),
    ("cartesian_wrench", lambda: dist.CartesianForceAtBody(arm(), "b1", with_torque=True, order="drake"),
     (0.0,), {"x": [0.4, -0.7, 0.0, 0.0], "force": [0.3, 0.1, -1.0, 1.0, -2.0, 0.5]}, None),
    ("held_noise", lambda: dist.HeldGaussianNoise(3, 0.01, seed=12), (0.0, 0.37), {},
     lambda s, c: s.set_seed(c, 99)),
    ("von_karman_filter", lambda: wind.VonKarmanFilter_[None](wind.VonKarmanParameters(t_on=1.0, t_off=2.0)),
     (0.5, 1.5), {"noise": [0.3, -1.0, 2.0]},
     lambda s, c: c.SetContinuousState(np.linspace(-1.0, 1.0, 8))),
    ("von_karman_turbulence", lambda: wind.VonKarmanTurbulence(offset=(-3.0, 0.5, 0.0)), (0.0, 0.5), {},
     turbulence_context),
    ("constant_wind", lambda: wind.ConstantWind([0.0, 3.0, -1.0]), (0.0,), {}, None),
    ("gust_profile", lambda: wind.GustProfile(GUSTS), (20.0, 21.5, 23.0, 30.0), {}, None),
    ("gust_profile_ramps", lambda: wind.GustProfile(GUSTS, rise_time=1.0), (19.6, 20.0, 21.2, 24.9), {}, None),
    ("wind_sum", lambda: wind.WindSum(2), (0.0,), {"wind_0": [1.0, 2.0, 3.0], "wind_1": [0.5, -2.0, 0.25]},
     None),
]


def make_context(system, t, inputs, setup, base=None):
    ctx = system.CreateDefaultContext()
    if base is not None:
        ctx.SetTimeStateAndParametersFrom(base)
    for name, value in inputs.items():
        system.GetInputPort(name).FixValue(ctx, np.asarray(value, dtype=float))
    if setup is not None and base is None:
        setup(system, ctx)
    ctx.SetTime(t)
    return ctx


@pytest.mark.parametrize("name, factory, times, inputs, setup", CASES, ids=[c[0] for c in CASES])
def test_converted_outputs_equal_the_double_outputs(name, factory, times, inputs, setup):
    system = factory()
    converted = {"AutoDiffXd": system.ToAutoDiffXd(), "Expression": system.ToSymbolic()}
    for t in times:
        ctx = make_context(system, t, inputs, setup)
        for kind, other in converted.items():
            # seeds, states and parameters carried over from the double context
            octx = make_context(other, t, inputs, setup, base=ctx)
            for i in range(system.num_output_ports()):
                y = system.get_output_port(i).Eval(ctx)
                y_other = other.get_output_port(i).Eval(octx)
                assert close(values(y_other), y), (name, kind, t, system.get_output_port(i).get_name(),
                                                   values(y_other) - y)


def test_autodiff_time_derivative_is_the_reference_rate():
    """d q_r/dt through AutoDiffXd time equals q̇_r, and d q̇_r/dt equals q̈_r (away from the
    breakpoints), for analytic pieces and for a PiecewisePolynomial (chain rule)."""
    for system, times in ((refs.TrajectoryReference(trajectory("table_7_1")), (0.3, 110.0, 150.0)),
                          (refs.TrajectoryReference(trajectory("envelope_mission")), (10.0, 100.0, 200.0)),
                          (refs.TrajectoryReference(cubic()), (0.4, 1.5, 2.9))):
        ad = system.ToAutoDiffXd()
        ctx = ad.CreateDefaultContext()
        for t in times:
            ctx.SetTime(AutoDiffXd(t, [1.0]))
            q, qd, qdd = (ad.GetOutputPort(p).Eval(ctx) for p in ("q_r", "qdot_r", "qddot_r"))
            d = [np.array([v.derivatives()[0] if v.derivatives().size else 0.0 for v in y]) for y in (q, qd)]
            # the chain rule multiplies ω and the closed form's factors in another order: a
            # rounding or two (measured ≤ 0.56 ulps)
            assert close(d[0], values(qd)) and close(d[1], values(qdd)), (t, d, values(qd), values(qdd))


def test_gust_ramp_derivative_through_autodiff():
    """GustProfile with ramps: the AutoDiffXd time derivative is the analytic ramp slope
    value·(π/2rise)·sin(π(x/rise + 1/2)), x = t − t0 (and 0 on the flat parts)."""
    g = wind.GustProfile(GUSTS[:1], rise_time=1.0).ToAutoDiffXd()
    ctx = g.CreateDefaultContext()
    for t in (19.4, 19.6, 20.0, 20.3, 21.0, 22.8, 23.2):
        ctx.SetTime(AutoDiffXd(t, [1.0]))
        dy = g.GetOutputPort("wind").Eval(ctx)[1].derivatives()
        slope = 0.0
        for c, sign in ((20.0, 1.0), (23.0, -1.0)):
            if abs(t - c) < 0.5:
                slope += sign * 5.0 * (math.pi / 2.0) * math.sin(math.pi * ((t - c) / 1.0 + 0.5))
        assert (dy[0] if dy.size else 0.0) == pytest.approx(slope, rel=1e-13, abs=1e-13)


def test_symbolic_time_gives_the_piecewise_expression():
    """With t a symbolic Variable the outputs are if-then-else expressions in t; substituting
    values gives the double outputs (to a few ulps: same operations)."""
    t = Variable("t")
    for system, times in ((refs.TrajectoryReference(trajectory("table_7_1")), (0.3, 105.0, 110.0, 190.0)),
                          (dist.TimeProfiledForce(2, PULSES), (5.0, 12.0, 27.5)),
                          (wind.GustProfile(GUSTS, rise_time=1.0), (19.2, 20.1, 22.0, 24.9))):
        sym = system.ToSymbolic()
        sctx = sym.CreateDefaultContext()
        sctx.SetTime(Expression(t))
        port = sym.get_output_port(0)
        exprs = port.Eval(sctx)
        assert any(not e.GetVariables().empty() for e in exprs)
        ctx = system.CreateDefaultContext()
        for tv in times:
            ctx.SetTime(tv)
            got = np.array([e.Evaluate({t: tv}) for e in exprs])
            assert close(got, system.get_output_port(0).Eval(ctx)), (system, tv)


def test_piecewise_polynomial_reference_matches_the_polynomial():
    """Value and first two derivatives equal pp.value / pp.EvalDerivative (MakeDerivative
    polynomials vs derivatives evaluated on the fly: same coefficients up to rounding,
    hence 1e-12 relative); outside [start, end] the end value is held with zero rates."""
    pp = cubic()
    ref = refs.TrajectoryReference(pp, names=["u", "v"])
    assert ref.names == ["u", "v"] and ref.num_input_ports() == 0
    ctx = ref.CreateDefaultContext()
    scale = 1.0 + max(np.abs(pp.EvalDerivative(t, k)).max() for t in np.linspace(0, 3, 31) for k in range(3))
    for t in (0.0, 0.25, 1.0, 1.7, 2.0, 2.99, 3.0):
        ctx.SetTime(t)
        for port, k in (("q_r", 0), ("qdot_r", 1), ("qddot_r", 2)):
            expected = pp.EvalDerivative(t, k)[:, 0]
            np.testing.assert_allclose(ref.GetOutputPort(port).Eval(ctx), expected, rtol=1e-12, atol=1e-12 * scale)
        np.testing.assert_allclose(ref.evaluate(t)[1], pp.EvalDerivative(t, 1)[:, 0], rtol=1e-12, atol=1e-12 * scale)
    for t in (-1.0, 5.0):
        ctx.SetTime(t)
        np.testing.assert_array_equal(ref.GetOutputPort("q_r").Eval(ctx), pp.value(t)[:, 0])
        np.testing.assert_array_equal(ref.GetOutputPort("reference").Eval(ctx)[2:], 0.0)
    q, qd, qdd = ref.evaluate(np.array([0.5, 1.5]))
    assert q.shape == qd.shape == qdd.shape == (2, 2)
    assert inspect.signature(refs.TrajectoryReference) == inspect.signature(lambda trajectory, names=None: None)


def test_drake_trajectory_refusals_name_the_problem():
    pp = cubic()
    with pytest.raises(ValueError, match=r"names must be 2 strings"):
        refs.TrajectoryReference(pp, ["u"])
    with pytest.raises(ValueError, match=r"one column"):
        refs.TrajectoryReference(PiecewisePolynomial(np.ones((2, 2))))
    with pytest.raises(ValueError, match=r"names must be None for a PiecewiseTrajectory"):
        refs.TrajectoryReference(trajectory("table_5_2"), ["a", "b"])
    sym = refs.TrajectoryReference(pp).ToSymbolic()
    ctx = sym.CreateDefaultContext()
    ctx.SetTime(Expression(Variable("t")))
    with pytest.raises(ValueError, match=r"time must be a constant.*PiecewiseTrajectory"):
        sym.GetOutputPort("q_r").Eval(ctx)


def test_callable_pulses_that_only_take_floats_are_refused_at_conversion():
    ok = dist.TimeProfiledForce(1, [{"index": 0, "value": lambda t: np.sin(t), "from": 0.0}])
    ok.ToAutoDiffXd(), ok.ToSymbolic()
    bad = dist.TimeProfiledForce(1, [{"index": 0, "value": lambda t: math.sin(t), "from": 0.0}])
    for convert in (bad.ToAutoDiffXd, bad.ToSymbolic):
        with pytest.raises(TypeError, match=r"TimeProfiledForce cannot be converted.*pulses\[0\]\['value'\]"
                                            r".*numpy or pydrake.math"):
            convert()


def test_two_contexts_are_independent():
    """Parameters (wind, gust values, amplitudes, seed) and the Jacobian's plant context live
    in each Context: changing or evaluating one leaves the other as it was."""
    c_wind = wind.ConstantWind([0.0, 3.0, 0.0])
    a, b = c_wind.CreateDefaultContext(), c_wind.CreateDefaultContext()
    a.get_mutable_numeric_parameter(0).SetFromVector([1.0, 2.0, 3.0])
    np.testing.assert_array_equal(c_wind.get_output_port(0).Eval(a), [1, 2, 3])
    np.testing.assert_array_equal(c_wind.get_output_port(0).Eval(b), [0, 3, 0])

    force = dist.TimeProfiledForce(2, PULSES)
    a, b = force.CreateDefaultContext(), force.CreateDefaultContext()
    a.SetTime(12.0), b.SetTime(12.0)
    a.get_mutable_numeric_parameter(0).SetAtIndex(0, -7.0)
    np.testing.assert_array_equal(force.get_output_port(0).Eval(a), [-7, 0])
    np.testing.assert_array_equal(force.get_output_port(0).Eval(b), [40, 0])
    assert force.pulses[0]["value"] == 40.0 and force.value(12.0)[0] == 40.0

    gust = wind.GustProfile(GUSTS)
    a, b = gust.CreateDefaultContext(), gust.CreateDefaultContext()
    a.SetTime(21.5), b.SetTime(21.5)
    a.get_mutable_numeric_parameter(0).SetFromVector([1.0, 1.0])
    np.testing.assert_array_equal(gust.get_output_port(0).Eval(a), [0, 1, 1])
    np.testing.assert_array_equal(gust.get_output_port(0).Eval(b), [0, 5, -3])

    noise = dist.HeldGaussianNoise(3, 0.01, seed=4)
    a, b = noise.CreateDefaultContext(), noise.CreateDefaultContext()
    noise.set_seed(a, 5)
    np.testing.assert_array_equal(noise.get_output_port(0).Eval(a), dist.gaussian_samples(5, 0, 3))
    np.testing.assert_array_equal(noise.get_output_port(0).Eval(b), dist.gaussian_samples(4, 0, 3))

    model = arm()
    cart = dist.CartesianForceAtBody(model, "b1", p_BQ=[0.3, 0.0, 0.1])
    F = np.array([1.0, -2.0, 0.5])
    qs = (np.array([0.4, -0.7]), np.array([-1.1, 0.2]))
    ctxs = [cart.CreateDefaultContext() for _ in qs]
    for ctx, q in zip(ctxs, qs):
        cart.GetInputPort("x").FixValue(ctx, np.concatenate([q, np.zeros(2)]))
        cart.GetInputPort("force").FixValue(ctx, F)
    for _ in range(2):   # interleaved: each context's cached plant context keeps its own q
        for ctx, q in zip(ctxs, qs):
            np.testing.assert_allclose(cart.get_output_port(0).Eval(ctx), cart.generalized_force(q, F),
                                       rtol=1e-14, atol=1e-14)
    clone = ctxs[0].Clone()
    cart.GetInputPort("x").FixValue(clone, np.concatenate([qs[1], np.zeros(2)]))
    np.testing.assert_allclose(cart.get_output_port(0).Eval(ctxs[0]), cart.generalized_force(qs[0], F),
                               rtol=1e-14, atol=1e-14)


def test_noise_is_a_reproducible_function_of_seed_and_sample():
    """Sample k is held on [kΔt, (k+1)Δt) in a simulation and equals gaussian_samples(seed, k),
    in every scalar type; the draws are unit Gaussian and uncorrelated."""
    dt, seed = 0.01, 21
    noise = dist.HeldGaussianNoise(2, dt, seed=seed)
    sim = Simulator(noise)
    ctx = sim.get_mutable_context()
    for k in (0, 1, 2, 7, 600):   # 600 crosses a memo block (512 samples)
        sim.AdvanceTo((k + 0.5) * dt)
        np.testing.assert_array_equal(noise.get_output_port(0).Eval(ctx), dist.gaussian_samples(seed, k, 2))
    draws = np.array([dist.gaussian_samples(7, k, 3) for k in range(20000)])
    n = draws.size
    # standard errors: mean 1/√n, variance √(2/n), lag-1 correlation 1/√(n−3); 5 of each
    assert abs(draws.mean()) < 5 / math.sqrt(n)
    assert abs(draws.var() - 1.0) < 5 * math.sqrt(2 / n)
    flat = draws[:, 0]
    assert abs(np.corrcoef(flat[:-1], flat[1:])[0, 1]) < 5 / math.sqrt(flat.size)
    assert abs(np.corrcoef(draws[:, 0], draws[:, 1])[0, 1]) < 5 / math.sqrt(flat.size)
    assert not np.array_equal(dist.gaussian_samples(7, 3, 3), dist.gaussian_samples(8, 3, 3))
    with pytest.raises(ValueError, match=r"seed must be an integer in \[0, 2\*\*53\), got -1"):
        dist.HeldGaussianNoise(3, 0.01, seed=-1)
    with pytest.raises(ValueError, match=r"sample_time \(s\) must be > 0, got 0.0"):
        dist.HeldGaussianNoise(3, 0)
    with pytest.raises(ValueError, match=r"size must be a positive integer, got 0"):
        dist.HeldGaussianNoise(0, 0.01)


def test_turbulence_diagram_converts_with_the_same_realization():
    """The seeded turbulence, converted to AutoDiffXd, simulates to the same wind (same noise
    constants, same filter; the integrators see the same numbers, so equal to a few ulps)."""
    vk = wind.VonKarmanTurbulence(seed=2)
    ad = vk.ToAutoDiffXd()
    results = []
    for system, simulator in ((vk, Simulator), (ad, Simulator_[AutoDiffXd])):
        sim = simulator(system)
        ctx = sim.get_mutable_context()
        if system is vk:
            vk.seed(ctx, 5)
            seeded = ctx.Clone()
        else:
            ctx.SetTimeStateAndParametersFrom(seeded)
        sim.AdvanceTo(0.05)
        results.append(values(system.GetOutputPort("wind").Eval(ctx)))
    assert np.allclose(results[1], results[0], rtol=1e-12, atol=1e-12), results


def test_mission_wind_diagram_converts():
    sources = wind.mission_wind_sources("scenario_2_full_envelope", turbulence=wind.VonKarmanParameters())
    b = DiagramBuilder()
    b.ExportOutput(wind.add_wind(b, *sources), "wind")
    d = b.Build()
    ctx = d.CreateDefaultContext()
    ctx.SetTime(21.0)
    for conv in (d.ToAutoDiffXd(), d.ToSymbolic()):
        cctx = conv.CreateDefaultContext()
        cctx.SetTimeStateAndParametersFrom(ctx)
        assert close(values(conv.GetOutputPort("wind").Eval(cctx)), d.GetOutputPort("wind").Eval(ctx))


def test_float_fast_paths_equal_the_generic_code():
    """The float branches of the scalar helpers and Coordinates equal their generic branches
    evaluated on AutoDiffXd at the same times, including the breakpoints themselves."""
    for t in (-1.0, 0.0, 0.5, 1.0, 1.25, 2.0, 2.5, 3.0, 4.0):
        ad = AutoDiffXd(t, [1.0])
        assert interval_indicator(t, 0.0, 2.0, (True, False)) == interval_indicator(ad, 0.0, 2.0, (True, False))
        assert smooth_window(t, 1.0, 3.0, 1.0) == pytest.approx(scalar_value(smooth_window(ad, 1.0, 3.0, 1.0)),
                                                                rel=4 * EPS, abs=4 * EPS)
        assert piecewise(t, [0.0, 2.0], ["a", "b", "c"]) == piecewise(ad, [0.0, 2.0], ["a", "b", "c"])
        for coord in (refs.const(1.5), refs.sine(2.0, 0.7, phase=0.3, offset=1.0, t0=0.2),
                      refs.poly([1.0, -2.0, 0.5, 0.25], t0=1.0)):
            assert close([scalar_value(v) for v in coord.at(ad)], coord.scalar(t))


def test_every_leaf_system_documents_its_ports():
    """Each class docstring has a ``.. pydrake_system::`` block naming the system and listing
    exactly its ports (WindSum's ``...`` stands for wind_1 … wind_{N−2})."""
    systems = [refs.TrajectoryReference(trajectory("table_5_2")), dist.TimeProfiledForce(2, PULSES),
               dist.CartesianForceAtBody(arm(), "b1"), dist.HeldGaussianNoise(3, 0.01),
               wind.VonKarmanFilter_[None](wind.VonKarmanParameters()), wind.ConstantWind([0, 0, 0]),
               wind.GustProfile(GUSTS), wind.WindSum(2), wind.VonKarmanTurbulence()]
    for system in systems:
        doc = inspect.getdoc(type(system))
        block = re.search(r"\.\. pydrake_system::\n\n((?:    .*\n?)+)", doc)
        assert block, type(system)
        text = block.group(1)
        lists = {key: re.findall(r"- (\S+)", part) for key, part in
                 re.findall(r"(input_ports|output_ports):\n((?:    - .*\n?)+)", text)}
        name = re.search(r"name: (\w+)", text).group(1)
        assert name in type(system).__name__
        for key, count, port in (("input_ports", system.num_input_ports(), system.get_input_port),
                                 ("output_ports", system.num_output_ports(), system.get_output_port)):
            actual = [port(i).get_name() for i in range(count)]
            listed = [p for p in lists.get(key, []) if p not in ("...", "wind_{N-1}")]
            assert set(listed) <= set(actual) and (actual[:len(listed)] == listed or name == "WindSum"), (
                name, key, listed, actual)
            assert len(lists.get(key, [])) >= min(count, 1) or count == 0
