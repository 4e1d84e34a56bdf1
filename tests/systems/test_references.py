"""Reference trajectories: analytic derivatives, continuity at phase boundaries, ports."""

import numpy as np
import pytest

from sobolev_drake.systems import reference_catalogue as catalogue
from sobolev_drake.systems.reference_catalogue import TRAJECTORIES, trajectory
from sobolev_drake.systems.references import Coordinate, PiecewiseTrajectory, const, poly, sine

HORIZON = {"table_5_2": 40.0, "table_5_5": 30.0, "table_5_8": 60.0, "table_6_3": 60.0,
           "table_7_1": 220.0, "envelope_mission": 300.0}


def sample_times(tr, horizon, n=400, margin=1e-3):
    """Times away from breakpoints (central differences must not straddle a switch)."""
    t = np.linspace(0.01, horizon, n)
    for b in tr.breakpoints:
        t = t[np.abs(t - b) > margin]
    return t


@pytest.mark.parametrize("name", sorted(TRAJECTORIES))
def test_derivatives_match_finite_differences(name):
    tr = trajectory(name)
    t = sample_times(tr, HORIZON[name])
    h = 1e-5
    q, qd, qdd = tr.evaluate(t)
    qp, qdp, _ = tr.evaluate(t + h)
    qm, qdm, _ = tr.evaluate(t - h)
    scale = 1.0 + np.abs(q).max()
    np.testing.assert_allclose((qp - qm) / (2 * h), qd, atol=1e-6 * scale)
    np.testing.assert_allclose((qdp - qdm) / (2 * h), qdd, atol=1e-6 * (1 + np.abs(qd).max()))
    assert q.shape == (t.size, tr.m)


def classes(tr):
    return {(r["t"], r["name"]): r["class"] for r in tr.smoothness(tol=1e-3)}


def test_envelope_mission_geometry_and_continuity():
    tr = trajectory("envelope_mission")
    np.testing.assert_allclose(tr.breakpoints, [66, 86, 146, 166, 232])
    # positions continuous everywhere, horizontal velocity continuous everywhere
    for j in tr.jumps():
        np.testing.assert_allclose(j["q"], 0.0, atol=1e-9)
        np.testing.assert_allclose(j["qd"][:2], 0.0, atol=1e-9)
    c = classes(tr)
    assert c[(66.0, "z")] == "C0" and c[(166.0, "z")] == "C0" and c[(232.0, "z")] == "C1"
    assert c[(86.0, "psi")] == "C0" and c[(146.0, "psi")] == "C0"
    # speed 33 m/s in cruise and in the turn; yaw = heading in the turn
    for t in (70.0, 100.0, 130.0, 150.0):
        _, qd, _ = tr.evaluate(t)
        assert np.hypot(qd[0], qd[1]) == pytest.approx(33.0)
    _, qd, _ = tr.evaluate(120.0)
    q, _, _ = tr.evaluate(120.0)
    assert np.arctan2(qd[1], qd[0]) % (2 * np.pi) == pytest.approx(q[3] % (2 * np.pi))
    # three quarters of a circle: heading −y afterwards, 2.59 m/s² centripetal in the turn
    _, qd, qdd = tr.evaluate(150.0)
    np.testing.assert_allclose(qd[:2], [0, -33.0], atol=1e-9)
    _, _, qdd = tr.evaluate(100.0)
    assert np.hypot(qdd[0], qdd[1]) == pytest.approx(33.0 * 2 * np.pi / 80)
    # at rest at the hold point, 2 m high
    q, qd, _ = tr.evaluate(250.0)
    np.testing.assert_allclose(qd, 0.0, atol=1e-12)
    assert q[2] == pytest.approx(2.0)


def test_table_7_1_reconstruction():
    tr = trajectory("table_7_1")
    c = classes(tr)
    q, qd, _ = tr.evaluate(125.0)
    np.testing.assert_allclose(q[:3], [35.9, 20.0, 43.0])
    assert qd[0] == pytest.approx(0.0, abs=1e-12)  # x stops exactly at 125 s
    for j in tr.jumps():
        np.testing.assert_allclose(j["q"], 0.0, atol=2e-3)  # 35.9 vs 20 sin(6π) etc.
    # x velocity at 105: 40π/35 vs the thesis' rounded 3.59 → only a 4e-4 m/s jump
    assert abs(tr.jumps()[0]["qd"][0]) < 1e-3
    assert c[(105.0, "z")] == "C0" and c[(125.0, "z")] == "C0"
    assert tr.evaluate(300.0)[0][2] == 0.0
    full = trajectory("table_7_1", full_state=True)
    assert full.names == ["alpha_R", "alpha_L", "phi", "theta", "psi", "x", "y", "z"]
    np.testing.assert_allclose(full.evaluate(50.0)[0][5:], tr.evaluate(50.0)[0][:3])
    np.testing.assert_allclose(full.evaluate(50.0)[0][:4], [-0.137, -0.137, 0.0, 0.137])


def test_table_5_5_and_5_8_values():
    tr = trajectory("table_5_5")
    q, _, _ = tr.evaluate(2.0)
    np.testing.assert_allclose(q, [5 - np.sin(np.pi / 2) / 2] + [np.pi / 4 * np.sin(0.8 * np.pi)] * 3)
    q, _, _ = tr.evaluate(10.0)
    np.testing.assert_allclose(q, [5, 0, np.pi / 4 * np.sin(4 * np.pi), 2 * np.pi * np.sin(np.pi / 2)], atol=1e-12)
    assert classes(tr)[(8.0, "theta")] == "C2+"
    f8 = trajectory("table_5_8")
    q, _, _ = f8.evaluate(0.0)
    np.testing.assert_allclose(q, [8, 0, 2, 0], atol=1e-12)
    np.testing.assert_allclose(trajectory("table_6_3").evaluate(7.0)[0], f8.evaluate(7.0)[0][:3])
    sub = f8.subset(["psi", "x", "y", "z"])
    np.testing.assert_allclose(sub.evaluate(3.0)[1], f8.evaluate(3.0)[1][[3, 0, 1, 2]])


def test_piece_convention_right_closed():
    tr = PiecewiseTrajectory(["a"], [[const(1.0)], [const(2.0)]], [5.0])
    assert tr.evaluate(5.0)[0][0] == 1.0  # t ≤ 5 → first piece
    assert tr.evaluate(5.0 + 1e-9)[0][0] == 2.0


def test_leaf_system_ports_match_evaluate():
    ref = catalogue.table_7_1()
    ctx = ref.CreateDefaultContext()
    for t in (0.0, 110.0, 150.0):
        ctx.SetTime(t)
        q, qd, qdd = ref.evaluate(t)
        np.testing.assert_allclose(ref.GetOutputPort("q_r").Eval(ctx), q)
        np.testing.assert_allclose(ref.GetOutputPort("qdot_r").Eval(ctx), qd)
        np.testing.assert_allclose(ref.GetOutputPort("qddot_r").Eval(ctx), qdd)
        np.testing.assert_allclose(ref.GetOutputPort("reference").Eval(ctx), np.concatenate([q, qd, qdd]))
    assert ref.names == ["x", "y", "z", "psi"]
    assert ref.num_input_ports() == 0


def test_bad_definitions():
    with pytest.raises(ValueError, match="breakpoints must have 1"):
        PiecewiseTrajectory(["a"], [[const(1)], [const(2)]])
    with pytest.raises(ValueError, match="pieces\\[0\\] has 2"):
        PiecewiseTrajectory(["a"], [[const(1), const(2)]])
    with pytest.raises(ValueError, match="strictly increasing"):
        PiecewiseTrajectory(["a"], [[const(1)], [const(2)], [const(3)]], [2.0, 1.0])
    with pytest.raises(TypeError, match="Coordinate"):
        PiecewiseTrajectory(["a"], [[1.0]])
    with pytest.raises(KeyError, match="known"):
        trajectory("table_9_9")
    with pytest.raises(KeyError, match="coordinates are"):
        trajectory("table_5_8").subset(["w"])
    with pytest.raises(ValueError, match="finite"):
        trajectory("table_5_2").evaluate(np.nan)
    with pytest.raises(ValueError, match="ascending"):
        poly([])
    assert sine(2.0, 1.0, t0=1.0)(1.0)[0] == 0.0


def test_reference_in_simulated_diagram_integrates_consistently():
    """∫ q̇_r dt from q_r(0), integrated by Drake, reproduces q_r(T) (figure-8, 10 s)."""
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.framework import DiagramBuilder
    from pydrake.systems.primitives import Integrator

    builder = DiagramBuilder()
    ref = builder.AddSystem(catalogue.table_5_8())
    integ = builder.AddSystem(Integrator(4))
    builder.Connect(ref.GetOutputPort("qdot_r"), integ.get_input_port())
    diagram = builder.Build()
    ctx = diagram.CreateDefaultContext()
    integ.set_integral_value(integ.GetMyMutableContextFromRoot(ctx), ref.evaluate(0.0)[0])
    sim = Simulator(diagram, ctx)
    sim.get_mutable_integrator().set_target_accuracy(1e-8)
    sim.AdvanceTo(10.0)
    q_int = integ.get_output_port().Eval(integ.GetMyContextFromRoot(ctx))
    np.testing.assert_allclose(q_int, ref.evaluate(10.0)[0], atol=1e-5)


def test_scalar_evaluation_equals_vectorized():
    """The per-sample scalar path (used by the LeafSystem) equals the vectorized evaluation on
    every piece of every catalogue trajectory, including the breakpoints themselves."""
    from sobolev_drake.systems.reference_catalogue import TRAJECTORIES
    for name, make in TRAJECTORIES.items():
        tr = make()
        ts = np.concatenate([np.linspace(-1.0, 260.0, 97), tr.breakpoints, tr.breakpoints + 1e-9])
        for t in ts:
            q, qd, qdd = tr.evaluate_scalar(float(t))
            q0, qd0, qdd0 = tr.evaluate(float(t))
            for a, b in ((q, q0), (qd, qd0), (qdd, qdd0)):
                np.testing.assert_allclose(a, b, rtol=1e-13, atol=1e-12, err_msg=f"{name} t={t}")
    # a user Coordinate without a scalar form falls back to the vectorized function
    tr = PiecewiseTrajectory(["a"], [[Coordinate(lambda t: (t * t, 2 * t, 2 + 0 * t))]])
    assert tr.evaluate_scalar(3.0) == ([9.0], [6.0], [2.0])


def test_table_5_5_continuous_psi_reading():
    """psi="continuous" keeps ψ_r = (π/4) sin(2πt/5) after 8 s (no 6.44 rad jump); the other
    coordinates are the printed ones; an unknown reading is refused."""
    from sobolev_drake.systems.reference_catalogue import table_5_5
    printed, cont = table_5_5(), table_5_5(psi="continuous")
    for t in (1.0, 7.9, 8.1, 12.3, 29.0):
        q_p, qd_p, _ = printed.evaluate(t)
        q_c, qd_c, _ = cont.evaluate(t)
        np.testing.assert_array_equal(q_c[:3], q_p[:3])
        assert q_c[3] == pytest.approx(np.pi / 4 * np.sin(2 * np.pi * t / 5), abs=1e-12)
    before, after = cont.evaluate(8.0 - 1e-9)[0][3], cont.evaluate(8.0 + 1e-9)[0][3]
    assert abs(after - before) < 1e-6 and abs(printed.evaluate(8.0 + 1e-9)[0][3] - before) > 6.0
    with pytest.raises(ValueError, match="psi must be"):
        table_5_5(psi="wrapped")
