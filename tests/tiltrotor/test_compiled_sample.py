"""The controller's compiled per-sample update (``tiltrotor.compiled_sample``, ``native/fused.c``)
against the Python path (``TiltrotorWInfLaw.step`` and the controller's record assembly), on
the states of a mission flown by the Python path.

Tolerances.  Every record entry except the residual comes from the same compiled kernels on the
same floats in both paths (q̈_des, inverse dynamics, B and ϑ_passive, bounds, allocation,
Newton, saturation flags; the tilt schedule and the error integral in the same operation
order), so those must be equal to the bit, and so must a whole mission's logs.  The residual
‖u* − Bτ̄‖ is a numpy (BLAS) product in the Python path and a plain loop in C: each component
of u* − Bτ̄ is computed with an error ≤ γ_{m+1}(|u*| + |B||τ̄|)_i (γ_k = k·eps/(1 − k·eps)) in
any summation order, and the norm adds ≤ (n + 1)·eps relative, so the two residuals differ by
at most 2γ_{m+1}‖|u*| + |B||τ̄|‖ + 2(n + 1)·eps·‖u* − Bτ̄‖ (m = n = 8).

Both designs: the thesis law (q̈_des compiled) and the scheduled one (q̈_des by its Python
``EnvelopeSchedule``, which the kernel calls with the Python path's arguments).
"""

import numpy as np
import pytest

import sobolev_drake.native as native
from sobolev_drake.tiltrotor import controller as tc
from sobolev_drake.tiltrotor.compiled_sample import CompiledSample
from sobolev_drake.tiltrotor.input_affine import affine_terms_scalar
from sobolev_drake.tiltrotor.law import make_law, newton_speed_for_thrust
from sobolev_drake.tiltrotor.mission import simulate_mission
from sobolev_drake.tiltrotor.plant import TiltrotorModel
from sobolev_drake.tiltrotor.references import tilt_schedule_polynomial

pytest.importorskip("sobolev_drake.native._fused")      # CI has gcc: built there
bls_kernel = pytest.importorskip("sobolev_drake.native._bls")

EPS = np.finfo(float).eps
#: scenario 2 saturates its surfaces from t ≈ 11.1 s on
SECONDS = 11.5
RES = tc.TiltrotorWInfController.RECORD_FIELDS["allocation_residual"].start


def _fly(monkeypatch, compiled, design="thesis"):
    """(built, logs, samples) of scenario 2; samples: (x, reference, wind, old record, new
    record, old active set, new active set) of every update the controller took."""
    samples = []
    update = tc.TiltrotorWInfController._update

    def spy(self, context, discrete_state):
        ins = [p.Eval(context).copy() for p in (self.x_port, self.reference_port, self.wind_port)]
        old = context.get_discrete_state(self._state).value().copy()
        book = context.get_discrete_state(self._book).value()      # [stamp | active set]
        old_active, taken = book[1:].copy(), book[0] != context.get_time()
        update(self, context, discrete_state)
        if taken:
            samples.append((*ins, old, discrete_state.get_value(int(self._state)).copy(),
                            old_active, discrete_state.get_value(int(self._book))[1:].copy()))
    with monkeypatch.context() as m:
        m.setattr(native, "_ENABLED", True)
        m.setattr(tc.TiltrotorWInfController, "_update", spy)
        if not compiled:
            m.setattr(CompiledSample, "kernel", lambda self, period: None)
        built, logs = simulate_mission(2, SECONDS, design=design)
    assert (built["controller"]._sample is not None) == compiled
    return built, logs, samples


_FLIGHTS: dict = {}


def _python_flight(design):
    """The Python path's flight of ``design`` (flown once per test module run)."""
    if design not in _FLIGHTS:
        with pytest.MonkeyPatch.context() as m:
            _FLIGHTS[design] = (*_fly(m, compiled=False, design=design), design)
    return _FLIGHTS[design]


@pytest.fixture(scope="module", params=["thesis", "scheduled"])
def python_flight(request):
    return _python_flight(request.param)


def _residual_tolerance(law, x, wind, record):
    """The bound of the module docstring at this sample (B re-evaluated by the law's own
    input_affine at the speeds the sample started from)."""
    fields = tc.TiltrotorWInfController.split_record(record[1])
    old_n = tc.TiltrotorWInfController.split_record(record[0])["propeller_speed"]
    B, _ = law.input_affine(law.model, x[:8], x[8:], wind, n=old_n)
    u, tau = fields["u_star"], fields["tau_bar"]
    gamma = 9 * EPS / (1 - 9 * EPS)
    return (2 * gamma * np.linalg.norm(np.abs(u) + np.abs(B) @ np.abs(tau))
            + 18 * EPS * float(fields["allocation_residual"][0]))


def test_compiled_record_equals_python_path_on_mission_states(python_flight, monkeypatch):
    """Every sample of the Python path's flight, replayed through the compiled call with the
    same warm start (the active set the controller kept): declined where the Python path takes
    the bracketing thrust solver (the first sample, no last speeds), else the same record (bits;
    residual to the derived bound) and active set.  The states include saturated surfaces."""
    monkeypatch.setattr(native, "_ENABLED", True)    # a kernel feature: on even under =0
    built, _, samples, _ = python_flight
    law = built["law"]
    sample = law.compiled_sample.kernel(built["controller"].period)
    assert len(samples) > 1000
    declined, saturated = [], 0
    for k, (x, ref, wind, old, new, old_active, new_active) in enumerate(samples):
        rec, act = np.full(30, np.nan), np.full(8, np.nan)
        if not sample(x, ref, wind, old, old_active, rec, act):
            declined.append(k)
            assert np.isnan(rec).all() and np.isnan(act).all()       # nothing written
            continue
        keep = np.arange(30) != RES
        np.testing.assert_array_equal(rec[keep], new[keep], err_msg=f"sample {k}")
        assert abs(rec[RES] - new[RES]) <= _residual_tolerance(law, x, wind, (old, new)), k
        np.testing.assert_array_equal(act, new_active)
        saturated += bool(np.any(new[22:30]))
    assert declined == [0]
    assert np.isnan(samples[0][5]).all() and not np.isnan(samples[1][5]).any()
    assert saturated > 20


def test_declines_where_the_python_path_decides(python_flight, monkeypatch):
    """Newton failing (last speeds ≤ 1 rev/s: the bracketing solver), non-finite inputs (the
    Python path raises its error): declined, nothing written; the Python path still answers the
    first and raises on the second."""
    monkeypatch.setattr(native, "_ENABLED", True)
    built, _, samples, _ = python_flight
    law = built["law"]
    sample = law.compiled_sample.kernel(0.01)
    x, ref, wind, old, *_ = samples[500]
    slow = old.copy()
    slow[11:13] = 1.0
    rec = np.full(30, np.nan)
    assert not sample(x, ref, wind, slow, np.zeros(8), rec, np.zeros(8))
    assert np.isnan(rec).all()
    step = law.step(x[:8], x[8:], ref, wind, old[:3], n_prev=slow[11:13])
    assert np.all(np.isfinite(step.propeller_speed)) and np.all(step.propeller_speed > 1.0)
    bad = x.copy()
    bad[3] = np.nan
    assert not sample(bad, ref, wind, old, np.zeros(8), rec, np.zeros(8))
    assert np.isnan(rec).all()
    with pytest.raises(ValueError, match="q"):
        law.step(bad[:8], bad[8:], ref, wind, old[:3], n_prev=old[11:13])


def test_mission_logs_match_the_python_path(python_flight, monkeypatch):
    """The same mission flown with the compiled update: identical state, reference and record
    logs (residual to the derived bound), with fewer Python-path samples (the first only)."""
    _, py_logs, py_samples, design = python_flight
    built, logs, samples = _fly(monkeypatch, compiled=True, design=design)
    assert logs.keys() == py_logs.keys()
    for key in logs:
        if key != "allocation_residual":
            np.testing.assert_array_equal(logs[key], py_logs[key], err_msg=key)
    law = built["law"]
    for (x, _, wind, old, new, *_), (*_, py_new, _, _) in zip(samples, py_samples):
        assert abs(new[RES] - py_new[RES]) <= _residual_tolerance(law, x, wind, (old, py_new))


def test_compiled_path_only_for_the_law_it_was_made_for(monkeypatch):
    """Not for a user allocation or with the kernels off; a controller whose law's pieces were
    replaced after construction (its q̈_des hook too) takes the Python path."""
    model = TiltrotorModel()
    monkeypatch.setattr(native, "_ENABLED", True)
    scheduled = make_law(model, design="scheduled")
    assert scheduled.compiled_sample.matches(scheduled)
    scheduled.desired_acceleration = lambda *a: [0.0] * 8
    assert not scheduled.compiled_sample.matches(scheduled)
    assert make_law(model, allocate=lambda B, u, lo, up: np.clip(np.zeros(8), lo, up)
                    ).compiled_sample is None
    with native.disabled():
        assert make_law(model).compiled_sample is None
    monkeypatch.setattr(native, "_ENABLED", True)
    law = make_law(model)
    ctrl = tc.TiltrotorWInfController(law)
    assert ctrl._sample is not None
    calls = []
    allocate = law.allocate
    law.allocate = lambda *a: calls.append(1) or allocate(*a)
    ctx = ctrl.CreateDefaultContext()
    ctrl.get_input_port(0).FixValue(ctx, np.zeros(16))
    ctrl.get_input_port(1).FixValue(ctx, np.zeros(12))
    ctrl.get_input_port(2).FixValue(ctx, np.zeros(3))
    for t in (0.0, 0.01):
        ctx.SetTime(t)
        ctx.SetDiscreteState(ctrl.EvalUniquePeriodicDiscreteUpdate(ctx))
    assert calls == [1, 1]


@pytest.mark.parametrize("schedule", ["plant", "data", "linear", "constant"])
def test_compiled_record_equals_law_step_on_random_states(schedule, monkeypatch):
    """Off the mission (any heading, wind, forward speed; both schedule forms, and polynomial
    schedules whose derivatives vanish identically): the compiled record equals the one
    assembled from ``law.step`` (bits; residual to the derived bound)."""
    monkeypatch.setattr(native, "_ENABLED", True)
    polynomial = {"linear": [0.004, -0.1], "constant": [0.2]}
    law = make_law(TiltrotorModel(), schedule=tilt_schedule_polynomial(polynomial[schedule])
                   if schedule in polynomial else schedule)
    sample = law.compiled_sample.kernel(0.01)
    assert sample is not None
    rng = np.random.default_rng(5)
    accepted = 0
    for k in range(40):
        q = np.r_[rng.uniform(-0.3, 0.3, 5) - [0.137, 0.137, 0, 0, 0], rng.normal(size=3)]
        qd = np.r_[rng.normal(scale=0.2, size=5), rng.normal(scale=2.0, size=3)]
        qd[5] += 25.0 * (k % 2)                  # forward flight: the surfaces get authority
        ref = np.r_[rng.normal(size=3), rng.uniform(-3, 3), rng.normal(size=3) * 8,
                    rng.normal(scale=0.1), rng.normal(size=3), rng.normal(scale=0.05)]
        wind = np.r_[rng.normal(size=2) * 3, 0.0]
        old = np.zeros(30)
        old[:3] = rng.normal(size=3)
        # last speeds near the ones this state needs (a far start may fail Newton: declined)
        old[11:13] = law.step(q, qd, ref, wind, old[:3]).propeller_speed * rng.uniform(0.97, 1.03)
        x = np.r_[q, qd]
        rec = np.empty(30)
        ok = sample(x, ref, wind, old, np.full(8, np.nan), rec, np.empty(8))      # cold start
        law.allocate.warm_start["active"] = None                               # cold start
        st = law.step(q, qd, ref, wind, old[:3], n_prev=old[11:13])
        if not ok:
            # declined exactly where the Python path leaves the kernels: no last speeds, the
            # allocation kernel's None (the general solver), Newton's None (bracketing)
            t = affine_terms_scalar(law.model.params, q.tolist(), qd.tolist(), wind.tolist(),
                                    old[11:13].tolist())
            assert (min(old[11:13]) <= 0
                    or bls_kernel.solve(st.B, st.u_star, st.lo, st.up, 1e-12, None, 25) is None
                    or newton_speed_for_thrust(law.propulsion.coef, st.tau_bar[:2], t.rotor_vxz,
                                               t.rotor_phi, old[11:13]) is None), k
            continue
        accepted += 1
        want = np.r_[old[:3] + 0.01 * (q[5:] - ref[:3]), st.tau_bar, st.propeller_speed,
                     st.u_star, st.residual, tc.saturation_flags(st.tau_bar, st.lo, st.up)]
        keep = np.arange(30) != RES
        np.testing.assert_array_equal(rec[keep], want[keep], err_msg=f"case {k}")
        assert abs(rec[RES] - want[RES]) <= _residual_tolerance(law, x, wind, (old, want)), k
    assert accepted >= 15


def test_mission_with_every_kernel_off_agrees(python_flight):
    """``SOBOLEV_DRAKE_NATIVE=0``: the same mission on the Python tiers and Drake's inverse
    dynamics.  Each kernel agrees with its reference to rounding (≤ 1e-9 relative on
    well-conditioned problems, tests/native), and the loop is stable over this window, so the
    logs agree to that level (measured: ≤ 2e-13 relative)."""
    _, logs, _, design = python_flight
    with native.disabled():
        built, off = simulate_mission(2, SECONDS, design=design)
    assert built["law"].compiled_sample is None
    for key in ("x", "tau_bar", "propeller_speed", "u_star", "allocation_residual"):
        scale = np.abs(off[key]).max()
        np.testing.assert_allclose(logs[key], off[key], rtol=0, atol=1e-9 * (1 + scale),
                                   err_msg=key)


def test_schedule_the_kernel_refuses_runs_the_python_path(monkeypatch):
    """A schedule whose constants the compiled update does not take (a reversed speed range)
    still builds a controller: it updates through the Python path, equal to ``law.step``."""
    monkeypatch.setattr(native, "_ENABLED", True)
    law = make_law(TiltrotorModel(), schedule=tilt_schedule_polynomial([0.01, 0.2],
                                                                       speed_range=(34.0, 0.0)))
    assert law.compiled_sample is None or law.compiled_sample.kernel(0.01) is None
    ctrl = tc.TiltrotorWInfController(law, initial_speed=[60.0, 60.0])
    ctx = ctrl.CreateDefaultContext()
    x = np.r_[-0.137, -0.137, np.zeros(14)]
    for port, value in ((0, x), (1, np.zeros(12)), (2, np.zeros(3))):
        ctrl.get_input_port(port).FixValue(ctx, value)
    record = ctrl.EvalUniquePeriodicDiscreteUpdate(ctx).get_vector(0).CopyToVector()
    law.allocate.warm_start["active"] = None
    st = law.step(x[:8], x[8:], np.zeros(12), np.zeros(3), np.zeros(3), n_prev=[60.0, 60.0])
    np.testing.assert_array_equal(record[3:11], st.tau_bar)


def test_scheduled_callback_errors_and_bad_results(monkeypatch):
    """The kernel calls the law's q̈_des hook as the Python path does: an exception it raises
    propagates unchanged; a result that is not 8 numbers declines (nothing written) and the
    Python path then reports it; a hook that is not callable is refused by name."""
    monkeypatch.setattr(native, "_ENABLED", True)
    fused = pytest.importorskip("sobolev_drake.native._fused")
    built, _, samples, _ = _python_flight("scheduled")
    law = built["law"]
    x, ref, wind, old, new, old_active, _ = samples[300]
    seen = []

    def spy(*args):
        seen.append([list(a) for a in args])
        return law.desired_acceleration(*args)
    constants = {**law.compiled_sample.constants, "period": 0.01, "qdd_callback": spy}
    rec, act = np.full(30, np.nan), np.full(8, np.nan)
    assert fused.sample(fused.make_sample(constants), x, ref, wind, old, old_active, rec, act)
    np.testing.assert_array_equal(rec[:RES], new[:RES])
    q, qd, e_int, tracked, r, w = seen[0]
    assert (q, qd, e_int, r, w) == (x[:8].tolist(), x[8:].tolist(), old[:3].tolist(),
                                    ref.tolist(), wind.tolist())
    assert len(tracked) == 18 and tracked[:3] == ref[:3].tolist()

    def raises(*args):
        raise ZeroDivisionError("from the hook")
    bad = fused.make_sample({**constants, "qdd_callback": raises})
    with pytest.raises(ZeroDivisionError, match="from the hook"):
        fused.sample(bad, x, ref, wind, old, old_active, rec, act)
    rec[:] = np.nan
    short = fused.make_sample({**constants, "qdd_callback": lambda *a: [0.0] * 7})
    assert not fused.sample(short, x, ref, wind, old, old_active, rec, act)
    assert np.isnan(rec).all()
    with pytest.raises(TypeError, match="qdd_callback must be callable"):
        fused.make_sample({**constants, "qdd_callback": 3.0})
