"""Disturbance sources: pulse profiles and the Jacobian-transpose map checked by virtual work."""

import numpy as np
import pytest
from pydrake.multibody.plant import MultibodyPlant
from pydrake.math import RigidTransform
from pydrake.multibody.tree import FixedOffsetFrame, RevoluteJoint, SpatialInertia, UnitInertia
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource

from sobolev_drake.data import load
from sobolev_drake.models.base import MechanicalModel
from sobolev_drake.systems.disturbances import CartesianForceAtBody, TimeProfiledForce, pulses_from_mission


def spatial_pendulum():
    """A 3-joint arm with non-parallel axes (z, y, x) and offsets: a genuinely 3-D Jacobian."""
    plant = MultibodyPlant(0.0)
    M = SpatialInertia.MakeFromCentralInertia(1.0, [0.2, 0, 0], UnitInertia.SolidBox(0.4, 0.1, 0.1))
    parent = plant.world_body()
    for i, axis in enumerate(([0, 0, 1], [0, 1, 0], [1, 0, 0])):
        body = plant.AddRigidBody(f"b{i}", M)
        X = RigidTransform([0.4, 0.1 * i, 0.05] if i else [0, 0, 0])
        F = plant.AddFrame(FixedOffsetFrame(f"F{i}", parent.body_frame(), X))
        plant.AddJoint(RevoluteJoint(f"j{i}", F, body.body_frame(), axis))
        parent = body
    plant.Finalize()
    # a non-trivial thesis ordering with scales: q_thesis = [j2, 2·j0, j1]
    T = np.zeros((3, 3))
    T[2, 0], T[0, 1], T[1, 2] = 1.0, 0.5, 1.0
    return MechanicalModel(plant, coordinate_map=T, dof_names=["a", "b", "c"])


def models():
    from sobolev_drake.models.arm import make_arm_model
    from sobolev_drake.models.quadrotor import make_quadrotor_model
    from sobolev_drake.models.two_wheeled import make_two_wheeled_model
    return [(spatial_pendulum(), "b2", [0.1, 0.2, -0.05]),
            (make_arm_model(), "link2", [0.3, 0.0, 0.0]),
            (make_two_wheeled_model(), "body", [0.0, 0.0, 0.2]),
            (make_quadrotor_model(), "body", [0.2, -0.1, 0.05])]


@pytest.mark.parametrize("case", range(4))
def test_jacobian_transpose_virtual_work(case):
    model, body, p = models()[case]
    src = CartesianForceAtBody(model, body, p_BQ=p)
    rng = np.random.default_rng(case)
    ctx = model.plant.CreateDefaultContext()
    frame = src.frame

    def point(q_th):
        model.plant.SetPositions(ctx, model.to_drake(q_th))
        return model.plant.CalcPointsPositions(ctx, frame, np.reshape(p, (3, 1)), model.plant.world_frame())[:, 0]

    for _ in range(3):
        q = rng.uniform(-1, 1, model.n)
        dq = rng.normal(size=model.n)
        F = rng.normal(size=3)
        h = 1e-6
        dp = (point(q + h * dq) - point(q - h * dq)) / (2 * h)
        tau = src.generalized_force(q, F)
        # τ·δq = F·δp  (virtual work, (3.41))
        assert tau @ dq == pytest.approx(F @ dp, rel=1e-6, abs=1e-9)


def test_torque_mapping_virtual_work():
    model = spatial_pendulum()
    src = CartesianForceAtBody(model, "b2", with_torque=True)
    ctx = model.plant.CreateDefaultContext()
    q = np.array([0.3, -0.4, 0.7])
    dq = np.array([0.2, 0.5, -0.1])
    torque = np.array([0.3, -1.0, 2.0])
    # angular velocity of the body for q̇ = dq, by the plant (independent of the Jacobian code)
    model.plant.SetPositions(ctx, model.to_drake(q))
    model.plant.SetVelocities(ctx, model.to_drake(dq))
    w = model.plant.EvalBodySpatialVelocityInWorld(ctx, model.plant.GetBodyByName("b2")).rotational()
    tau = src.generalized_force(q, np.zeros(3), torque)
    assert tau @ dq == pytest.approx(torque @ w, rel=1e-10)


def test_cartesian_force_in_a_diagram_both_orders():
    model = spatial_pendulum()
    builder = DiagramBuilder()
    th = builder.AddSystem(CartesianForceAtBody(model, "b1", order="thesis"))
    dr = builder.AddSystem(CartesianForceAtBody(model, "b1", order="drake"))
    q = np.array([0.1, 0.2, 0.3])
    F = np.array([1.0, -2.0, 0.5])
    x_th = np.concatenate([q, np.zeros(3)])
    x_dr = np.concatenate([model.to_drake(q), np.zeros(3)])
    for sys_, x in ((th, x_th), (dr, x_dr)):
        builder.Connect(builder.AddSystem(ConstantVectorSource(x)).get_output_port(), sys_.GetInputPort("x"))
        builder.Connect(builder.AddSystem(ConstantVectorSource(F)).get_output_port(), sys_.GetInputPort("force"))
    diagram = builder.Build()
    ctx = diagram.CreateDefaultContext()
    out_th = th.GetOutputPort("generalized_force").Eval(th.GetMyContextFromRoot(ctx))
    out_dr = dr.GetOutputPort("generalized_force").Eval(dr.GetMyContextFromRoot(ctx))
    np.testing.assert_allclose(out_th, model.force_to_thesis(out_dr), atol=1e-12)
    with pytest.raises(ValueError, match="neither a body nor a frame"):
        CartesianForceAtBody(model, "nope")
    with pytest.raises(ValueError, match="order"):
        CartesianForceAtBody(model, "b1", order="xyz")


def test_time_profiled_force_manipulator_profile():
    w = TimeProfiledForce(2, [
        {"index": 0, "value": 40.0, "from": 10.0, "to": 20.0},
        {"index": 1, "value": lambda t: -40 * np.sin(2 * np.pi * t / 10), "from": 25.0, "to": 35.0},
    ])
    np.testing.assert_allclose(w.value(5.0), [0, 0])
    np.testing.assert_allclose(w.value(10.0), [40, 0])
    np.testing.assert_allclose(w.value(20.0), [0, 0])
    np.testing.assert_allclose(w.value(27.5), [0, -40 * np.sin(2 * np.pi * 2.75)])
    assert w.switch_times == [10.0, 20.0, 25.0, 35.0]
    ctx = w.CreateDefaultContext()
    ctx.SetTime(12.0)
    np.testing.assert_allclose(w.GetOutputPort("generalized_force").Eval(ctx), [40, 0])


def test_pulses_from_mission_json():
    names = ["alpha_R", "alpha_L", "phi", "theta", "psi", "x", "y", "z"]
    entries = load("tiltrotor_missions")["scenario_1_helicopter_mode"]["force_disturbances"]
    w = TimeProfiledForce(8, pulses_from_mission(entries, names))
    np.testing.assert_allclose(w.value(25.0), [0] * 6 + [-15, 0])
    np.testing.assert_allclose(w.value(45.0), [0] * 7 + [-15])
    with pytest.raises(ValueError, match="not a coordinate"):
        pulses_from_mission([{"axis": "w", "value": 1, "from": 0, "to": 1}], names)


@pytest.mark.parametrize("pulse, msg", [
    ({"index": 3, "value": 1.0}, "index"),
    ({"index": 0}, "needs 'index' and 'value'"),
    ({"index": 0, "value": 1.0, "from": 2.0, "to": 1.0}, "from < to"),
    ({"index": 0, "value": float("nan")}, "finite"),
    ({"index": 0, "value": 1.0, "when": 3}, "unknown keys"),
])
def test_bad_pulses(pulse, msg):
    with pytest.raises(ValueError, match=msg):
        TimeProfiledForce(2, [pulse])


def test_bad_function_shape():
    with pytest.raises(ValueError, match="shape \\(2,\\)"):
        TimeProfiledForce(2, function=lambda t: np.zeros(3))
