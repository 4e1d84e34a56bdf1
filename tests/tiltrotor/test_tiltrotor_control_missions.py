"""Tilt-rotor W∞ + allocation on the real model: u* identity, allocation optimality, thrust
round trip, and 10-second smoke versions of both missions (thesis §7.3.2)."""

import json

import numpy as np
import pytest

from sobolev_drake.tiltrotor.plant import TiltrotorModel
from sobolev_drake.tiltrotor import controller as tc
from sobolev_drake.tiltrotor import law as tl
from sobolev_drake.tiltrotor.input_affine import input_affine, thrust_inputs

from test_tiltrotor_control import thesis_gains_by_care


@pytest.fixture(scope="module")
def law():
    return tl.make_law(TiltrotorModel())


def _random_case(rng):
    q = np.r_[rng.uniform(-0.3, 0.3, 5), rng.normal(size=3)]
    qd = np.r_[rng.normal(scale=0.2, size=5), rng.normal(scale=2.0, size=3)]
    q[:2] -= 0.137
    ref = np.r_[rng.normal(size=3), 0.1, rng.normal(size=3) * 2, 0.05, rng.normal(size=3) * 0.3, 0.0]
    wind = np.r_[rng.normal(size=2) * 3, 0.0]
    return q, qd, ref, wind, rng.normal(size=3)


def test_u_star_is_inverse_dynamics_minus_passive(law):
    """u* = M q̈_des + C q̇ + g − ϑ_passive (7.81), recomputed from scratch."""
    rng = np.random.default_rng(1)
    g = thesis_gains_by_care()
    model = TiltrotorModel()
    for _ in range(3):
        q, qd, ref, wind, ie = _random_case(rng)
        n_prev = np.array([50.0, 53.0])
        st = law.step(q, qd, ref, wind, ie, n_prev=n_prev)
        qrr, qdrr, qddrr = st.ref_r
        qdd = np.zeros(8)
        qdd[[2, 3]] = -g.Ks @ qd[[2, 3]]
        qdd[[0, 1, 4]] = qddrr - g.Kr @ np.r_[qd[[0, 1, 4]] - qdrr, q[[0, 1, 4]] - qrr]
        qdd[5:] = ref[8:11] - g.Kc @ np.r_[qd[5:] - ref[4:7], q[5:] - ref[0:3], ie]
        B, theta = input_affine(model, q, qd, wind, n=n_prev)
        u = model.M(q) @ qdd + model.Cqdot(q, qd) + model.g(q) - theta
        assert np.allclose(st.qdd_des, qdd, rtol=1e-9, atol=1e-9)
        assert np.allclose(st.u_star, u, rtol=1e-9, atol=1e-8)
        assert np.allclose(st.B, B)
        # regulated references: ψ from the mission, tilt from the schedule (same for both)
        assert qrr[2] == ref[3] and qrr[0] == qrr[1]


def test_allocation_is_box_constrained_least_squares_optimum(law):
    """KKT conditions of (7.84): gradient Bᵀ(Bτ̄ − u*) is ≥ 0 on lower bounds, ≤ 0 on upper
    bounds and ≈ 0 on free variables; the reported residual is ‖u* − Bτ̄‖."""
    rng = np.random.default_rng(2)
    for _ in range(3):
        q, qd, ref, wind, ie = _random_case(rng)
        st = law.step(q, qd, ref, wind, ie)
        tau, lo, up = st.tau_bar, st.lo, st.up
        assert np.all(tau >= lo - 1e-12) and np.all(tau <= up + 1e-12)
        grad = st.B.T @ (st.B @ tau - st.u_star)
        scale = 1e-6 * (1 + np.linalg.norm(st.B.T @ st.u_star))
        width = up - lo
        free = (tau > lo + 1e-9 * (1 + width)) & (tau < up - 1e-9 * (1 + width)) & (width > 1e-9)
        assert np.all(np.abs(grad[free]) <= scale)
        assert np.all(grad[(tau <= lo + 1e-12) & (width > 1e-9)] >= -scale)
        assert np.all(grad[(tau >= up - 1e-12) & (width > 1e-9)] <= scale)
        assert np.isclose(st.residual, np.linalg.norm(st.u_star - st.B @ tau))


def test_thrust_inversion_round_trip(law):
    """Propeller speeds from the controller reproduce the allocated thrusts through the plant's
    own thrust model f = ρ d⁴ n² Ct(J, φ) (7.90), with and without a warm start."""
    rng = np.random.default_rng(3)
    model = TiltrotorModel()
    for k in range(4):
        q, qd, ref, wind, ie = _random_case(rng)
        qd[5] += 10.0 * k                       # include fast forward flight
        st = law.step(q, qd, ref, wind, ie, n_prev=None if k % 2 else np.array([55.0, 55.0]))
        f = thrust_inputs(model, q, qd, wind, st.propeller_speed)
        pos = st.tau_bar[:2] > 1e-9
        assert np.allclose(f[pos], st.tau_bar[:2][pos], rtol=1e-6, atol=1e-6)


def test_newton_speed_matches_bracketing_solver():
    from sobolev_drake.tiltrotor.allocation import propeller_speed_for_thrust
    from sobolev_drake.tiltrotor.propeller import PropellerCoefficients
    c = PropellerCoefficients()
    f, v, phi = np.array([20.0, 45.0]), np.array([3.0, 15.0]), np.array([0.2, 1.2])
    n_ref = propeller_speed_for_thrust(f, v, phi, coefficients=c)
    n = tl.newton_speed_for_thrust(c, f, v, phi, n_ref * 1.05)
    assert n is not None and np.allclose(n, n_ref, rtol=1e-6)
    assert tl.newton_speed_for_thrust(c, f, v, phi, np.zeros(2)) is None


def test_envelope_is_the_flagship():
    from sobolev_drake.experiments import REGISTRY
    from sobolev_drake.experiments import tiltrotor_missions  # noqa: F401
    assert REGISTRY["tiltrotor-envelope"].flagship == 10


def test_phase_bookkeeping_and_pulses():
    from sobolev_drake.tiltrotor import mission as tm
    from sobolev_drake.tiltrotor.mission_metrics import phase_metrics
    ph = tm.scenario_2_phases(250.0)
    assert [p[0] for p in ph] == ["accelerate_climb", "cruise_1", "turn", "cruise_2",
                                  "decelerate_descend", "hold"]
    assert [p[1] for p in ph] == [0, 66, 86, 146, 166, 232] and ph[-1][2] == 250.0
    assert [p[0] for p in tm.scenario_2_phases(10.0)] == ["accelerate_climb"]
    t, v = tm.pulses([{"axis": "y", "value": 5.0, "from": 2.0, "to": 3.0},
                      {"axis": "y", "value": 1.0, "from": 2.5, "to": 4.0}], 10.0)
    assert list(t) == [0, 2, 2.5, 3, 4, 10]
    assert list(v[1]) == [0, 5, 6, 1, 0, 0] and not v[[0, 2]].any()
    tt = np.linspace(0, 10, 101)
    pos = np.zeros((3, 101))
    ref = np.zeros((3, 101))
    pos[0, tt >= 5] = 0.5
    rows = phase_metrics(tt, pos, ref, [("a", 0, 5, "hover"), ("b", 5, 10, "cruise")])
    assert rows[0]["rms_m"] == 0 and rows[1]["rms_m"] == pytest.approx(0.5)
    assert rows[0]["goal_met"] and rows[1]["goal_met"]


def test_law_rejects_bad_inputs(law):
    q = np.zeros(8)
    with pytest.raises(ValueError, match="reference"):
        law.step(q, q, np.zeros(8), np.zeros(3), np.zeros(3))
    with pytest.raises(ValueError, match="wind"):
        law.step(q, q, np.zeros(12), np.zeros(2), np.zeros(3))
    with pytest.raises(ValueError, match="period"):
        tc.TiltrotorWInfController(law, period=0.0)
    with pytest.raises(ValueError, match="schedule"):
        tl.make_law(TiltrotorModel(), schedule="nope")


@pytest.fixture(scope="module", params=["tiltrotor-hover", "tiltrotor-envelope"])
def smoke(request, tmp_path_factory):
    from sobolev_drake.experiments import REGISTRY
    from sobolev_drake.experiments import tiltrotor_missions  # noqa: F401  (registers both)
    out = tmp_path_factory.mktemp(request.param)
    return REGISTRY[request.param].run(out, duration=None, record=False, smoke=True), out


def test_smoke_mission_flies(smoke):
    res, out = smoke
    m = res.metrics
    assert m["finite"] and abs(m["duration_s"] - 10.0) < 0.1
    assert m["max_abs_roll_deg"] < 60 and m["max_abs_pitch_deg"] < 60
    assert -100 < m["tilt_range_deg"][0] and m["tilt_range_deg"][1] < 100
    saved = json.loads((out / f"{res.name}_metrics.json").read_text())
    assert saved["phases"][0]["rms_m"] == pytest.approx(m["phases"][0]["rms_m"])
    for key in ("report", "phases_md", "effort_json", "path_3d", "actuators", "errors"):
        assert res.outputs[key].exists(), key
    assert "RMS" in res.table_markdown


def test_smoke_inputs_within_bounds(smoke):
    res, _ = smoke
    e = res.metrics["effort"]
    assert 0 <= e["fPR"]["rms"] <= 100 and 0 <= e["fPL"]["rms"] <= 100
    assert e["tauSR"]["rms"] <= 2 + 1e-9 and e["tauSL"]["rms"] <= 2 + 1e-9
    assert e["nPR"]["max"] < 200 and e["nPL"]["max"] < 200
    b = res.metrics["bounds_check"]
    assert b["tau_within_bounds"] and b["speeds_nonnegative"]


def test_per_sample_paths_equal_general_ones(law):
    """The law's float q̈_des and recursive-Newton–Euler u* (per-sample paths) equal
    MechanicalLaw.desired_acceleration and M q̈ + C q̇ + g to rounding."""
    rng = np.random.default_rng(7)
    mech = law.mech_law
    for _ in range(5):
        q, qd, ref, wind, ie = _random_case(rng)
        tracked = rng.normal(size=18)
        a = mech.desired_acceleration(q, qd, ie, tracked)
        b = mech.desired_acceleration_scalar(q.tolist(), qd.tolist(), ie.tolist(), tracked.tolist())
        np.testing.assert_allclose(b, a, rtol=1e-13, atol=1e-12)
        acc = rng.normal(size=8)
        u1 = mech.dynamics.inverse_dynamics(q, qd, acc)
        u2 = mech.dynamics.recursive_inverse_dynamics(q, qd, acc)
        np.testing.assert_allclose(u2, u1, rtol=1e-12, atol=1e-11 * np.max(np.abs(u1)))


def test_fused_sample_equals_composed_callables(monkeypatch):
    """make_law's fused per-sample path (direct kernel calls) gives the same ControlStep as the
    composed callables, sample after sample (warm starts included); replacing a callable
    switches the fused path off."""
    import sobolev_drake.native as native
    monkeypatch.setattr(native, "_ENABLED", True)    # a kernel feature: on even under =0
    fused, composed = tl.make_law(TiltrotorModel()), tl.make_law(TiltrotorModel())
    assert fused.fused_sample is not None
    composed.fused_sample = None
    rng = np.random.default_rng(21)
    n_prev = None
    for k in range(60):
        q, qd, ref, wind, ie = _random_case(rng)
        if k % 3 == 0:
            qd[5] += 25.0                        # forward flight: the surfaces get authority
        a = fused.step(q, qd, ref, wind, ie, n_prev=n_prev)
        b = composed.step(q, qd, ref, wind, ie, n_prev=n_prev)
        for field in ("qdd_des", "u_star", "B", "theta_passive", "tau_bar", "lo", "up",
                      "propeller_speed"):
            assert np.array_equal(getattr(a, field), getattr(b, field)), (k, field)
        assert a.residual == b.residual
        n_prev = None if k % 5 == 4 else a.propeller_speed
    calls = []
    fused.allocate = lambda B, u, lo, up: calls.append(1) or composed.allocate(B, u, lo, up)
    fused.step(q, qd, ref, wind, ie, n_prev=n_prev)
    assert calls == [1]


def test_mission_steps_once_per_sample_and_record_splits():
    """The mission integrates one RK3 step per controller sample (no ulp-sized extra steps from
    max_step = period or from log events a rounding apart), and the one C++ log of the
    controller's sample record splits into the named signals of its output ports."""
    from sobolev_drake.tiltrotor.mission import simulate_mission

    built, data = simulate_mission(2, 1.0)
    sim, ctrl = built["simulator"], built["controller"]
    assert sim.get_num_steps_taken() <= 1.0 / ctrl.period + 3
    assert data["t"][1] - data["t"][0] == pytest.approx(ctrl.period)
    ctx = ctrl.GetMyContextFromRoot(sim.get_context())
    for name, sl in tc.TiltrotorWInfController.RECORD_FIELDS.items():
        np.testing.assert_array_equal(data[name][:, -1], ctrl.GetOutputPort(name).Eval(ctx))
        assert data[name].shape == (sl.stop - sl.start, data["t"].size)
    with pytest.raises(ValueError, match="30 rows"):
        tc.TiltrotorWInfController.split_record(np.zeros((29, 4)))


def test_frictionless_flag_is_truthful(law):
    """The tilt-rotor model declares K(q̇) ≡ 0, which lets the per-sample u* skip adding it."""
    model = law.mech_law.model
    assert model.frictionless
    rng = np.random.default_rng(3)
    for _ in range(5):
        np.testing.assert_array_equal(model.friction(rng.normal(size=8)), np.zeros(8))


def test_mission_params_reach_plant_and_controller_model():
    from sobolev_drake.tiltrotor.mission import build_mission
    from sobolev_drake.tiltrotor.params import TiltrotorParams

    built = build_mission(1, 1.0, params=TiltrotorParams(reverse_flow="clipped"))
    assert built["handles"].model.params.reverse_flow == "clipped"
    assert not built["handles"].forces.aero.mirrored
    assert built["law"].mech_law.model.params.reverse_flow == "clipped"


@pytest.mark.parametrize("delay", [False, True])
def test_actuator_command_joins_the_three_split_outputs(law, delay):
    """``actuator_command`` is [propeller_speed, servo_torque, surface_deflection] — the plant's
    ``u`` order — before initialization and after every sample, with and without the
    computation delay (which holds the previous sample's commands)."""
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.framework import DiagramBuilder
    from pydrake.systems.primitives import ConstantVectorSource

    rng = np.random.default_rng(11)
    builder = DiagramBuilder()
    ctrl = builder.AddSystem(tc.TiltrotorWInfController(law, period=0.01, computation_delay=delay,
                                                        initial_speed=[40.0, 41.0]))
    q, qd, ref, wind, _ = _random_case(rng)
    for name, value in (("x", np.r_[q, qd]), ("reference", ref), ("wind_measured", wind)):
        source = builder.AddSystem(ConstantVectorSource(value))
        builder.Connect(source.get_output_port(), ctrl.GetInputPort(name))
    diagram = builder.Build()

    def check(context):
        c = ctrl.GetMyContextFromRoot(context)
        split = np.concatenate([ctrl.GetOutputPort(n).Eval(c) for n in
                                ("propeller_speed", "servo_torque", "surface_deflection")])
        command = ctrl.GetOutputPort("actuator_command").Eval(c)
        np.testing.assert_array_equal(command, split)
        record = ctrl.GetOutputPort("sample_record").Eval(c)
        return command, np.r_[record[11:13], record[5:7], record[7:11]]

    simulator = Simulator(diagram)
    command, _ = check(simulator.get_context())     # before initialization: the initial values
    assert command[:2].tolist() == [40.0, 41.0]
    simulator.Initialize()
    seen = [check(simulator.get_context())]        # the first sample is applied at once
    np.testing.assert_array_equal(*seen[0])
    for k in range(1, 6):
        simulator.AdvanceTo(0.01 * k)
        seen.append(check(simulator.get_context()))
    for (command, _), (_, previous), (_, current) in zip(seen[1:], seen[:-1], seen[1:]):
        # with the delay, the commands applied lag the record by one sample
        np.testing.assert_array_equal(command, previous if delay else current)
    assert any(np.any(a != b) for (_, a), (_, b) in zip(seen[:-1], seen[1:]))


def test_drake_hands_discrete_updates_the_current_state():
    """The controller's update reads its old record, stamp and active set from the buffer it
    writes (``TiltrotorWInfController._update``): Drake must fill that buffer with the current
    discrete state before every handler — also a state set from outside between samples, and
    after a sample that wrote nothing (a buffer that merely kept the handler's last writes, or
    a fresh one, would fail here)."""
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.framework import LeafSystem

    seen = []

    class Counter(LeafSystem):
        def __init__(self):
            super().__init__()
            self.group = int(self.DeclareDiscreteState(2))
            self.DeclarePeriodicDiscreteUpdateEvent(0.1, 0.0, self.update)

        def update(self, context, discrete_state):
            current = context.get_discrete_state(self.group).value().copy()
            buffer = discrete_state.get_mutable_value(self.group)
            seen.append((current, buffer.copy()))
            if context.get_time() < 0.25:          # later samples write nothing
                buffer[:] = current + [1.0, 2.0]

    simulator = Simulator(Counter())
    context = simulator.get_mutable_context()
    context.SetDiscreteState(0, [5.0, 7.0])        # not the default
    simulator.AdvanceTo(0.15)
    context.SetDiscreteState(0, [-3.0, 11.0])      # set between samples
    simulator.AdvanceTo(0.45)
    assert len(seen) == 5
    for current, buffer in seen:
        np.testing.assert_array_equal(buffer, current)
    assert [c.tolist() for c, _ in seen] == [[5.0, 7.0], [6.0, 9.0], [-3.0, 11.0], [-2.0, 13.0],
                                             [-2.0, 13.0]]
