"""Floating bases in ``from_plant`` (issue #32): Euler-angle model of a quaternion or
roll-pitch-yaw floating body driven by Drake ``Propeller``s, checked against Drake."""

import numpy as np
import pytest
from pydrake.common import FindResourceOrThrow
from pydrake.common.eigen_geometry import Quaternion
from pydrake.math import RigidTransform, RollPitchYaw, RotationMatrix
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant, Propeller, PropellerInfo
from pydrake.multibody.tree import RpyFloatingJoint, SpatialInertia, UnitInertia
from pydrake.systems.framework import DiagramBuilder

from sobolev_drake.models import FloatingBaseModel, MechanicalModel
from sobolev_drake.models.euler_chart import euler_rates, quaternion_to_euler
from sobolev_drake.models.euler_zyx import euler_rate_matrix_dot

# an off-centre, non-diagonal inertia so every term of M, C q̇ and g is exercised
SDF = """<sdf version="1.7"><model name="drone"><link name="body"><inertial>
<pose>0.01 -0.02 0.03 0 0 0</pose><mass>1.5</mass><inertia><ixx>0.02</ixx><iyy>0.03</iyy>
<izz>0.04</izz><ixy>0.001</ixy><ixz>0</ixz><iyz>0.002</iyz></inertia></inertial></link>
</model></sdf>"""


def propellers(body_index, count=4, arm=0.2, tilt=0.0):
    infos = []
    for i in range(count):
        a = 2 * np.pi * i / count
        R = RotationMatrix.MakeZRotation(a) @ RotationMatrix.MakeYRotation(tilt)
        infos.append(PropellerInfo(body_index, RigidTransform(R, [arm * np.cos(a), arm * np.sin(a), 0]),
                                   1.0, 0.02 * (-1) ** i))
    return infos


def quaternion_drone(tilt=0.3):
    builder = DiagramBuilder()
    plant = builder.AddSystem(MultibodyPlant(0.0))
    Parser(plant).AddModelsFromString(SDF, "sdf")
    plant.Finalize()
    infos = propellers(plant.GetBodyByName("body").index(), tilt=tilt)
    prop = builder.AddSystem(Propeller(infos))
    builder.Connect(plant.get_body_poses_output_port(), prop.get_body_poses_input_port())
    builder.Connect(prop.get_spatial_forces_output_port(), plant.get_applied_spatial_force_input_port())
    builder.ExportInput(prop.get_command_input_port(), "command")
    return builder.Build(), plant, infos


def rpy_drone():
    plant = MultibodyPlant(0.0)
    body = plant.AddRigidBody("body", SpatialInertia(1.2, [0.0, 0.01, 0.0],
                                                     UnitInertia(0.02, 0.03, 0.05)))
    plant.AddJoint(RpyFloatingJoint("base", plant.world_frame(), body.body_frame()))
    plant.Finalize()
    return plant, propellers(body.index(), 6)


def test_euler_model_reproduces_drakes_accelerations_with_propellers():
    diagram, plant, infos = quaternion_drone()
    model = MechanicalModel.from_plant(plant, propellers=infos)
    assert isinstance(model, FloatingBaseModel) and model.n == 6 and model.num_inputs == 4
    assert model.dof_names == ["phi", "theta", "psi", "x", "y", "z"]
    context = diagram.CreateDefaultContext()
    rng = np.random.default_rng(0)
    for _ in range(5):
        q, qdot, u = rng.uniform(-1, 1, 6), rng.uniform(-2, 2, 6), rng.uniform(0, 10, 4)
        qd, vd = model.to_drake_state(q, qdot)
        np.testing.assert_allclose(np.r_[model.from_drake_state(qd, vd)], np.r_[q, qdot], atol=1e-12)
        # Drake's RollPitchYaw is the same chart
        np.testing.assert_allclose(RollPitchYaw(RotationMatrix(Quaternion(qd[:4]))).vector(),
                                   q[:3], atol=1e-12)
        plant.SetPositionsAndVelocities(plant.GetMyMutableContextFromRoot(context), np.r_[qd, vd])
        diagram.get_input_port(0).FixValue(context, u)
        vdot = diagram.EvalTimeDerivatives(context).CopyToVector()[7:]
        M = model.M(q)
        qddot = np.linalg.solve(M, model.B(q) @ u - model.Cqdot(q, qdot) - model.g(q))
        J = model.velocity_jacobian(q)
        R = RollPitchYaw(q[:3]).ToRotationMatrix().matrix()
        jdot_qdot = np.r_[R @ euler_rate_matrix_dot(q[0], q[1], qdot[0], qdot[1]) @ qdot[:3], np.zeros(3)]
        # v̇ = J q̈ + J̇ q̇; the solve loses cond(M) digits of the forces' scale
        scale = np.linalg.norm(model.B(q) @ u) + np.linalg.norm(model.g(q)) + np.linalg.norm(M) * 4
        tol = 100 * np.linalg.cond(M) * np.finfo(float).eps * scale
        np.testing.assert_allclose(J @ qddot + jdot_qdot, vdot, rtol=0, atol=tol)


def test_coriolis_is_the_christoffel_term_of_the_euler_mass_matrix():
    _, plant, infos = quaternion_drone()
    model = MechanicalModel.from_plant(plant, propellers=infos)
    q, qdot = np.array([0.3, -0.5, 1.0, 1, 2, 3.0]), np.array([0.7, -0.4, 0.9, 1, -1, 0.5])
    h = 1e-6        # central differences: error O(h²)·‖∂³M‖ ≈ 1e-12, rounding eps/h ≈ 1e-10
    dM = [(model.M(q + h * e) - model.M(q - h * e)) / (2 * h) for e in np.eye(6)]
    christoffel = sum(dM[k] * qdot[k] for k in range(6)) @ qdot - 0.5 * np.array(
        [qdot @ dM[k] @ qdot for k in range(6)])
    np.testing.assert_allclose(model.Cqdot(q, qdot), christoffel, atol=1e-8)


def test_rpy_floating_joint_and_hexarotor_hover_trim():
    plant, infos = rpy_drone()
    model = MechanicalModel.from_plant(plant, propellers=infos, command_upper=20.0)
    u0 = model.hover_input()
    np.testing.assert_allclose(model.B(np.zeros(6)) @ u0, model.g(np.zeros(6)), atol=1e-9)
    assert u0.shape == (6,) and np.all(u0 >= 0) and np.all(model.input_upper == 20.0)
    # the RPY joint's positions are the Euler angles themselves
    q = np.array([0.2, -0.1, 0.4, 1, 2, 3.0])
    qdot = np.array([0.4, 0.1, -0.7, 1.0, 2.0, 3.0])
    qd, vd = model.to_drake_state(q, qdot)
    np.testing.assert_allclose(qd, q)
    context = plant.CreateDefaultContext()       # and Drake maps v back to the same rates
    plant.SetPositions(context, qd)
    np.testing.assert_allclose(plant.MapVelocityToQDot(context, vd), qdot, atol=1e-12)
    with pytest.raises(ValueError, match="cannot hold"):
        model.hover_input(upper=np.full(6, 0.1))


def test_singular_attitude_is_refused_by_name():
    _, plant, infos = quaternion_drone()
    model = MechanicalModel.from_plant(plant, propellers=infos)
    with pytest.raises(ValueError, match=r"pitch θ = 1.5 rad .*max_pitch.*singular at θ = ±90°"):
        model.M(np.array([0.0, 1.5, 0, 0, 0, 0]))
    with pytest.raises(ValueError, match="max_pitch must be in"):
        MechanicalModel.from_plant(plant, propellers=infos, max_pitch=2.0)
    with pytest.raises(TypeError, match="only a floating-base plant"):
        MechanicalModel.from_plant(_arm(), max_pitch=1.0)
    with pytest.raises(TypeError, match="PropellerInfo"):
        MechanicalModel.from_plant(plant, propellers=[1.0])


def _arm():
    plant = MultibodyPlant(0.0)
    Parser(plant).AddModels(FindResourceOrThrow("drake/examples/acrobot/Acrobot.urdf"))
    plant.Finalize()
    return plant


def test_chart_functions_match_drake_and_invert():
    rng = np.random.default_rng(3)
    for _ in range(10):
        eta = rng.uniform([-3, -1.5, -3], [3, 1.5, 3])
        quat = RollPitchYaw(eta).ToQuaternion().wxyz()
        np.testing.assert_allclose(quaternion_to_euler(-2.0 * quat), eta, atol=1e-12)  # any norm, sign
        w_F = rng.normal(size=3)
        # η̇ from ω_F agrees with Drake's RollPitchYaw rate map
        rates = RollPitchYaw(eta).CalcRpyDtFromAngularVelocityInParent(w_F)
        np.testing.assert_allclose(euler_rates(eta, w_F), rates, rtol=1e-9, atol=1e-9)


def test_propeller_on_a_tilting_mount_follows_the_mount_joint():
    """A tilt-rotor-like vehicle: a propeller on a nacelle hinged to the floating base (a joint
    with an actuator); B(q) = Jᵀ [propeller wrench, joint actuation] reproduces Drake's
    accelerations with the Propeller system and the actuation port in the diagram."""
    from pydrake.multibody.tree import FixedOffsetFrame, RevoluteJoint

    builder = DiagramBuilder()
    plant = builder.AddSystem(MultibodyPlant(0.0))
    base = plant.AddRigidBody("body", SpatialInertia(1.0, np.zeros(3), UnitInertia(0.02, 0.03, 0.04)))
    nacelle = plant.AddRigidBody("nacelle", SpatialInertia(0.2, [0.0, 0.0, 0.05],
                                                           UnitInertia(0.01, 0.01, 0.005)))
    X = RigidTransform([0.3, 0.0, 0.0])
    mount = plant.AddFrame(FixedOffsetFrame("mount", base.body_frame(), X))
    plant.AddJoint(RevoluteJoint("tilt", mount, nacelle.body_frame(), [0.0, 1.0, 0.0]))
    plant.AddJointActuator("tilt_servo", plant.GetJointByName("tilt"))
    plant.Finalize()
    infos = [PropellerInfo(nacelle.index(), RigidTransform([0.0, 0.0, 0.1]), 2.0, 0.05)]
    prop = builder.AddSystem(Propeller(infos))
    builder.Connect(plant.get_body_poses_output_port(), prop.get_body_poses_input_port())
    builder.Connect(prop.get_spatial_forces_output_port(), plant.get_applied_spatial_force_input_port())
    builder.ExportInput(prop.get_command_input_port(), "command")
    builder.ExportInput(plant.get_actuation_input_port(), "servo")
    diagram = builder.Build()
    model = MechanicalModel.from_plant(plant, propellers=infos)
    assert model.n == 7 and model.num_inputs == 2 and model.dof_names[6] == "tilt"
    context = diagram.CreateDefaultContext()
    rng = np.random.default_rng(5)
    for _ in range(3):
        q, qdot, u = rng.uniform(-1, 1, 7), rng.uniform(-1, 1, 7), rng.uniform(0, 5, 2)
        qd, vd = model.to_drake_state(q, qdot)
        plant.SetPositionsAndVelocities(plant.GetMyMutableContextFromRoot(context), np.r_[qd, vd])
        diagram.get_input_port(0).FixValue(context, u[:1])
        diagram.get_input_port(1).FixValue(context, u[1:])
        vdot = diagram.EvalTimeDerivatives(context).CopyToVector()[plant.num_positions():]
        M = model.M(q)
        qddot = np.linalg.solve(M, model.B(q) @ u - model.Cqdot(q, qdot) - model.g(q))
        h = 1e-6     # J̇ q̇ by central differences of J along q̇ (error ≈ 1e-10 ≪ tol)
        jdot_qdot = (model.velocity_jacobian(q + h * qdot) - model.velocity_jacobian(q - h * qdot)) @ qdot / (2 * h)
        tol = 1e-8 * np.linalg.cond(M)
        np.testing.assert_allclose(model.velocity_jacobian(q) @ qddot + jdot_qdot, vdot, atol=tol)
