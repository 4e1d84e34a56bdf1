"""`simulate` on faulty systems: it stops with a clear error instead of hanging.

Drake's error control answers a NaN error estimate by shrinking the step forever (the
minimum-step check is skipped on that branch), so before the guard a NaN initial state never
completed a step and a derivative that turns NaN at some t* stalled the run just before t*.
Each case here raises within milliseconds; the acceptance bound asserted is 1 s of wall time
(generous for a loaded machine).  A finite run must stay bit-for-bit what a bare Drake
Simulator computes with the same integrator settings.
"""

import math
import time

import numpy as np
import pytest
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import RevoluteJoint, SpatialInertia, UnitInertia
from pydrake.systems.analysis import ResetIntegratorFromFlags, Simulator
from pydrake.systems.framework import DiagramBuilder, EventStatus, LeafSystem
from pydrake.systems.primitives import ConstantVectorSource, Integrator, LogVectorOutput, ZeroOrderHold

import sobolev_drake
from sobolev_drake import simulation
from sobolev_drake.simulation import SimulationDiverged, SimulationStalled, SimulationTimeout, simulate

ERROR_WITHIN_S = 1.0   # acceptance: a faulty run stops within 1 s of wall time
T_STAR = 0.5


class Dynamics(LeafSystem):
    """xdot = f(t, x) on a continuous state of size n."""

    def __init__(self, f, n=1):
        super().__init__()
        self.f, self.calls = f, 0
        self.DeclareContinuousState(n)
        self.DeclareVectorOutputPort("x", n, lambda c, out: out.SetFromVector(
            c.get_continuous_state_vector().CopyToVector()))

    def DoCalcTimeDerivatives(self, context, derivatives):
        self.calls += 1
        x = context.get_continuous_state_vector().CopyToVector()
        derivatives.get_mutable_vector().SetFromVector(self.f(context.get_time(), x))


def nan_after(t_star):
    """xdot = -x until t_star, NaN from then on."""
    return lambda t, x: -x if t < t_star else np.full_like(x, np.nan)


def one_system(f, x0, name="faulty"):
    b = DiagramBuilder()
    sys_ = b.AddSystem(Dynamics(f, len(x0)))
    sys_.set_name(name)
    d = b.Build()
    ctx = d.CreateDefaultContext()
    ctx.SetContinuousState(x0)
    return d, ctx, sys_


def timed(call):
    t0 = time.perf_counter()
    try:
        call()
    except Exception as exc:  # noqa: BLE001 - returned to the test, which checks its type
        return exc, time.perf_counter() - t0
    return None, time.perf_counter() - t0


# ------------------------------------------------------------------- non-finite initial state

def test_nan_initial_state_is_refused_naming_state_and_subsystem():
    b = DiagramBuilder()
    good = b.AddSystem(Integrator(2))
    good.set_name("good")
    b.Connect(b.AddSystem(ConstantVectorSource([1.0, 1.0])).get_output_port(), good.get_input_port())
    bad = b.AddSystem(Dynamics(nan_after(math.inf), 2))
    bad.set_name("faulty")
    d = b.Build()
    ctx = d.CreateDefaultContext()
    ctx.SetContinuousState([0.0, 0.0, 1.0, np.nan])   # good's two states, then faulty's
    # wall_time_limit did not stop this before: the integrator never finished a step
    err, wall = timed(lambda: simulate(d, ctx, 1.0, progress=False, wall_time_limit=0.5))
    assert isinstance(err, ValueError), err
    assert wall < ERROR_WITHIN_S
    msg = str(err)
    assert "continuous state must be finite" in msg
    assert "x[3] = nan (subsystem 'faulty', its continuous state 1)" in msg
    assert "'good'" not in msg and "t = 0 s" in msg
    assert bad.calls == 0                      # refused before any evaluation
    assert ctx.get_time() == 0.0


def test_nan_initial_state_refused_on_reused_simulator_with_inf():
    d, ctx, _ = one_system(nan_after(math.inf), [1.0, 2.0])
    sim = Simulator(d, ctx)
    sim.get_mutable_context().SetContinuousState([-math.inf, 2.0])
    sim.get_mutable_context().SetTime(3.0)
    with pytest.raises(ValueError, match=r"x\[0\] = -inf \(subsystem 'faulty', its continuous state 0\) "
                                         r"at t = 3 s"):
        simulate(None, None, 1.0, progress=False, simulator=sim)


def test_nan_initial_state_names_the_multibody_state():
    b = DiagramBuilder()
    plant = b.AddSystem(MultibodyPlant(0.0))
    plant.set_name("pendulum")
    body = plant.AddRigidBody("arm", SpatialInertia(1.0, np.zeros(3), UnitInertia(0.1, 0.1, 0.1)))
    plant.AddJoint(RevoluteJoint("hinge", plant.world_frame(), body.body_frame(), [0.0, 0.0, 1.0]))
    plant.Finalize()
    d = b.Build()
    ctx = d.CreateDefaultContext()
    ctx.SetContinuousState([0.1, np.nan])
    with pytest.raises(ValueError, match=r"x\[1\] = nan \(subsystem 'pendulum', its continuous state 1 "
                                         r"'hinge_w'\)"):
        simulate(d, ctx, 1.0, progress=False)


def test_state_index_and_path_inside_nested_diagrams():
    inner_b = DiagramBuilder()
    inner_b.AddSystem(Integrator(1)).set_name("i1")
    inner_b.AddSystem(Dynamics(nan_after(math.inf), 2)).set_name("faulty")
    inner = inner_b.Build()
    inner.set_name("inner")
    b = DiagramBuilder()
    b.AddSystem(Integrator(3)).set_name("i3")
    b.AddSystem(inner)
    d = b.Build()
    ctx = d.CreateDefaultContext()
    x = np.arange(6.0)
    x[5] = np.nan                         # i3: 0..2, inner::i1: 3, inner::faulty: 4..5
    ctx.SetContinuousState(x)
    with pytest.raises(ValueError, match=r"x\[5\] = nan \(subsystem 'inner::faulty', its continuous state 1\)"):
        simulate(d, ctx, 1.0, progress=False)


# ---------------------------------------------------------------- non-finite derivative mid-run

@pytest.mark.parametrize("integrator", ["runge_kutta3", "runge_kutta5", "bogacki_shampine3"])
def test_derivative_turning_nan_mid_run_stops_near_t_star(integrator):
    d, ctx, sys_ = one_system(nan_after(T_STAR), [1.0])
    err, wall = timed(lambda: simulate(d, ctx, 2.0, progress=False, integrator=integrator))
    assert isinstance(err, SimulationDiverged), err
    assert isinstance(err, RuntimeError)
    assert wall < ERROR_WITHIN_S
    assert err.subsystem == "faulty"
    assert err.simulated == pytest.approx(T_STAR, abs=1e-9)
    assert ctx.get_time() == err.simulated         # the context keeps the state reached
    assert ctx.get_continuous_state_vector().GetAtIndex(0) == pytest.approx(math.exp(-T_STAR), rel=1e-3)
    msg = str(err)
    assert "turns non-finite just after t = 0.5 s" in msg
    assert "xdot[0] = nan (subsystem 'faulty', its continuous state 0)" in msg


@pytest.mark.parametrize("integrator", ["explicit_euler", "runge_kutta2"])
def test_fixed_step_integrators_stop_within_one_step_of_t_star(integrator):
    d, ctx, _ = one_system(nan_after(T_STAR), [1.0])
    max_step = 0.01
    err, wall = timed(lambda: simulate(d, ctx, 2.0, progress=False, integrator=integrator, max_step=max_step))
    assert isinstance(err, SimulationDiverged), err
    assert wall < ERROR_WITHIN_S
    assert err.subsystem == "faulty"
    assert T_STAR <= err.simulated <= T_STAR + 1.01 * max_step
    assert "subsystem 'faulty'" in str(err) and f"t = {err.simulated:.9g} s" in str(err)


@pytest.mark.parametrize("integrator", ["implicit_euler", "radau3"])
def test_implicit_integrators_giving_up_are_named_too(integrator):
    """Implicit schemes do not hang (Drake throws at its minimum step size), but Drake's
    message names neither the time nor the subsystem: simulate adds both."""
    d, ctx, _ = one_system(nan_after(T_STAR), [1.0])
    err, wall = timed(lambda: simulate(d, ctx, 2.0, progress=False, integrator=integrator))
    assert isinstance(err, SimulationDiverged), err
    assert wall < ERROR_WITHIN_S
    assert err.subsystem == "faulty" and err.simulated == pytest.approx(T_STAR, abs=1e-9)
    assert "turns non-finite just after t = 0.5 s" in str(err)
    assert "Drake's integrator gave up: Error control wants to select step smaller" in str(err)
    assert isinstance(err.__cause__, RuntimeError)


def test_drake_giving_up_without_anything_non_finite_keeps_drakes_error():
    """x' = 1e20 x: finite, but no step above Drake's minimum meets the accuracy; Drake's own
    error is raised unchanged."""
    d, ctx, _ = one_system(lambda t, x: 1e20 * x, [1.0], name="fast")
    with pytest.raises(RuntimeError, match="^Error control wants to select step smaller") as info:
        simulate(d, ctx, 1.0, progress=False)
    assert not isinstance(info.value, SimulationDiverged)


def test_errors_raised_by_a_system_pass_through_unchanged():
    def boom(t, x):
        if t > 0.2:
            raise RuntimeError("diverged: the model's own check")
        return -x

    d, ctx, _ = one_system(boom, [1.0], name="checked")
    with pytest.raises(RuntimeError, match="^diverged: the model's own check$"):
        simulate(d, ctx, 1.0, progress=False)


def test_nan_mid_run_is_not_a_timeout_when_a_wall_time_limit_is_set():
    d, ctx, _ = one_system(nan_after(T_STAR), [1.0])
    err, wall = timed(lambda: simulate(d, ctx, 2.0, progress=False, wall_time_limit=30.0))
    assert isinstance(err, SimulationDiverged) and not isinstance(err, SimulationTimeout), err
    assert wall < ERROR_WITHIN_S


def test_infinite_derivative_mid_run_is_caught_too():
    d, ctx, _ = one_system(lambda t, x: -x if t < 0.3 else np.full_like(x, np.inf), [1.0], name="blows")
    with pytest.raises(SimulationDiverged, match=r"t = 0.3 s .*xdot\[0\] = inf \(subsystem 'blows'") as info:
        simulate(d, ctx, 1.0, progress=False)
    assert info.value.subsystem == "blows"


def test_state_dependent_nan_at_an_accepted_state_is_caught():
    """x' = -sqrt(x) reaches x = 0 at t = 2 with zero slope; the RK3 endpoint lands at a
    slightly negative x, whose derivative is NaN: the next step would retry forever."""
    d, ctx, _ = one_system(lambda t, x: -np.sqrt(x), [1.0], name="root")
    with np.errstate(invalid="ignore"):
        err, wall = timed(lambda: simulate(d, ctx, 5.0, progress=False))
    assert isinstance(err, SimulationDiverged), err
    assert wall < ERROR_WITHIN_S
    assert err.subsystem == "root" and err.simulated == pytest.approx(2.0, abs=0.05)


def test_nonfinite_derivative_at_the_start_is_reported_at_the_start_time():
    d, ctx, sys_ = one_system(nan_after(0.0), [1.0])   # finite state, NaN derivative from t = 0
    ctx.SetTime(1.5)
    err, wall = timed(lambda: simulate(d, ctx, 1.0, progress=False))
    assert isinstance(err, SimulationDiverged), err
    assert wall < ERROR_WITHIN_S
    assert err.simulated == 1.5 and err.subsystem == "faulty"
    assert "time derivative is not finite at t = 1.5 s: xdot[0] = nan" in str(err)


# ------------------------------------------------------------------------------- step budget

def stiff(t, x):
    """Finite, smooth, but stiff for an explicit integrator (RK3 steps of ~2.5 µs)."""
    return -1e6 * (x - np.cos(t))


def test_step_budget_stops_a_stiff_system():
    d, ctx, _ = one_system(stiff, [1.0], name="stiff")
    with pytest.raises(SimulationStalled, match=r"max_steps=2000 steps used up at simulated t = ") as info:
        simulate(d, ctx, 1.0, progress=False, max_steps=2000)
    assert info.value.steps == 2000
    assert 0.0 < info.value.simulated < 0.05          # ~2000 steps of ~2.5 µs
    assert ctx.get_time() == info.value.simulated


def test_default_step_budget_is_derived_from_duration_and_max_step(monkeypatch):
    monkeypatch.setattr(simulation, "STEPS_PER_MAX_STEP", 10)
    monkeypatch.setattr(simulation, "MIN_STEP_BUDGET", 100)
    d, ctx, _ = one_system(stiff, [1.0], name="stiff")
    with pytest.raises(SimulationStalled, match=r"max_steps=400 steps"):     # 10 * 2 s / 0.05 s
        simulate(d, ctx, 2.0, progress=False)
    d, ctx, _ = one_system(stiff, [1.0], name="stiff")
    with pytest.raises(SimulationStalled, match=r"max_steps=100 steps"):     # the floor
        simulate(d, ctx, 0.1, progress=False)


def test_default_budget_leaves_ordinary_runs_alone():
    d, ctx, _ = one_system(lambda t, x: np.array([x[1], -x[0] - 0.1 * x[1]]), [1.0, 0.0], name="osc")
    sim = simulate(d, ctx, 20.0, progress=False, max_step=0.01)
    assert sim.get_num_steps_taken() < 2 * 20.0 / 0.01      # budget: 1000 × that


def test_wall_time_limit_stops_a_run_within_its_step_budget():
    d, ctx, _ = one_system(stiff, [1.0], name="stiff")
    with pytest.raises(SimulationTimeout, match="wall_time_limit=0.2 s reached") as info:
        simulate(d, ctx, 1.0, progress=False, wall_time_limit=0.2, max_steps=10**9)
    assert 0.0 < info.value.simulated < 1.0 and ctx.get_time() == info.value.simulated


@pytest.mark.parametrize("bad, kind", [(0, ValueError), (-3, ValueError), (2.5, TypeError), (True, TypeError),
                                       ("10", TypeError)])
def test_max_steps_must_be_a_positive_integer(bad, kind):
    d, ctx, _ = one_system(nan_after(math.inf), [1.0])
    with pytest.raises(kind, match=rf"max_steps must be a positive integer or None, got {bad!r}"):
        simulate(d, ctx, 1.0, progress=False, max_steps=bad)
    assert simulate(d, ctx, 0.1, progress=False, max_steps=np.int64(50)).get_num_steps_taken() <= 50


# -------------------------------------------------------------------- normal runs are unchanged

def reference_run(build, duration, integrator, accuracy, max_step):
    """The same run on a bare Drake Simulator: no monitor, same integrator settings."""
    d, ctx, logger = build()
    sim = Simulator(d, ctx)
    ResetIntegratorFromFlags(sim, integrator, max_step * (1.0 + simulation.MAX_STEP_SLACK))
    if integrator not in ("explicit_euler", "runge_kutta2"):
        sim.get_mutable_integrator().set_target_accuracy(accuracy)
    sim.Initialize()
    sim.AdvanceTo(duration)
    return ctx, sim, logger


def sampled_loop():
    """Damped oscillator driven through a 10 ms zero-order hold (discrete events), logged."""
    b = DiagramBuilder()
    plant = b.AddSystem(Dynamics(lambda t, x: np.array([x[1], -4.0 * x[0] - 0.3 * x[1] + np.sin(3 * t)]), 2))
    zoh = b.AddSystem(ZeroOrderHold(0.01, 2))
    b.Connect(plant.get_output_port(), zoh.get_input_port())
    logger = LogVectorOutput(zoh.get_output_port(), b, 0.02)
    d = b.Build()
    ctx = d.CreateDefaultContext()
    ctx.SetContinuousState([1.0, 0.0])
    return d, ctx, logger


@pytest.mark.parametrize("integrator", ["runge_kutta3", "runge_kutta5", "explicit_euler"])
def test_finite_run_is_bit_for_bit_the_bare_simulator(integrator):
    accuracy, max_step, duration = 1e-5, 0.02, 3.0
    ref_ctx, ref_sim, ref_log = reference_run(sampled_loop, duration, integrator, accuracy, max_step)
    d, ctx, logger = sampled_loop()
    sim = simulate(d, ctx, duration, progress=False, integrator=integrator, accuracy=accuracy,
                   max_step=max_step)
    assert sim.get_num_steps_taken() == ref_sim.get_num_steps_taken()
    assert ctx.get_time() == ref_ctx.get_time() == duration
    x, x_ref = (c.get_continuous_state_vector().CopyToVector() for c in (ctx, ref_ctx))
    assert x.tobytes() == x_ref.tobytes()
    log, log_ref = logger.FindLog(ctx), ref_log.FindLog(ref_ctx)
    assert log.data().tobytes() == log_ref.data().tobytes()
    assert sim.get_monitor() is None                  # the guard is removed afterwards


def test_a_monitor_already_on_the_simulator_keeps_working_and_is_restored():
    d, ctx, _ = one_system(lambda t, x: -x, [1.0])
    sim = Simulator(d, ctx)
    seen = []

    def stop_after_half_a_second(context):
        seen.append(context.get_time())
        if context.get_time() > 0.5:
            return EventStatus.ReachedTermination(None, "caller's own stop")
        return EventStatus.Succeeded()

    sim.set_monitor(stop_after_half_a_second)
    simulate(None, None, 2.0, progress=False, simulator=sim)     # the caller's stop is no error
    assert 0.5 < ctx.get_time() < 0.5 + 0.06 and len(seen) > 3
    assert sim.get_monitor() is not None
    n = len(seen)
    sim.AdvanceTo(ctx.get_time() + 0.1)                          # still installed after the call
    assert len(seen) > n


def test_exported_from_the_package():
    assert sobolev_drake.SimulationDiverged is SimulationDiverged
    assert sobolev_drake.SimulationStalled is SimulationStalled
    assert {"SimulationDiverged", "SimulationStalled"} <= set(sobolev_drake.__all__)


@pytest.mark.parametrize("size", [1, 16, 64, 65, 300])
def test_the_guards_finiteness_check_equals_numpys(size):
    """The guard's per-step check (a float sum first) agrees with np.isfinite(x).all() on NaN,
    ±inf, +inf next to −inf (the sum is NaN) and finite entries whose sum overflows (finite:
    the exact check must then say so), short and long vectors."""
    rng = np.random.default_rng(size)
    big = np.finfo(float).max
    for bad in (None, math.nan, math.inf, -math.inf, "inf-inf", "overflow"):
        x = rng.normal(size=size)
        if bad == "inf-inf" and size > 1:
            x[0], x[-1] = math.inf, -math.inf
        elif bad == "overflow":
            x[:] = big                                   # every entry finite, the sum is not
        elif isinstance(bad, float):
            x[rng.integers(size)] = bad
        assert simulation._all_finite(x) is bool(np.isfinite(x).all())
