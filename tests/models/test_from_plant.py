"""MechanicalModel.from_plant on models Drake ships, and partitions that refuse what the
inputs cannot do."""

import numpy as np
import pytest
from pydrake.common import FindResourceOrThrow
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import RevoluteSpring, SpatialInertia
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import LogVectorOutput

from sobolev_drake.models.base import MechanicalModel
from sobolev_drake.simulation import simulate
from sobolev_drake.synthesis.mechanical import controlled_gains, stabilized_gains
from sobolev_drake.systems.mechanical_controller import MechanicalController, MechanicalLaw, SobolevLaw
from sobolev_drake.systems.partition import Partition
from sobolev_drake.systems.references import PiecewiseTrajectory, TrajectoryReference, sine

GRIPPER = "drake/examples/planar_gripper/planar_gripper.sdf"
ACROBOT = "drake/examples/acrobot/Acrobot.urdf"
CART_POLE = "drake/examples/multibody/cart_pole/cart_pole.sdf"


def load(resource, time_step=0.0, finalize=True):
    plant = MultibodyPlant(time_step)
    Parser(plant).AddModels(FindResourceOrThrow(resource))
    if resource == GRIPPER:
        for k in (1, 2, 3):
            plant.WeldFrames(plant.world_frame(), plant.GetFrameByName(f"finger{k}_base"))
    if finalize:
        plant.Finalize()
    return plant


def test_from_plant_reads_actuation_damping_and_reflected_inertia():
    plant = load(GRIPPER, 1e-3)                     # a discrete plant is modelled the same way
    model = MechanicalModel.from_plant(plant)
    assert model.n == 6 and model.num_inputs == 6
    np.testing.assert_array_equal(model.B(np.zeros(6)), plant.MakeActuationMatrix())
    np.testing.assert_array_equal(model.damping, np.full(6, 0.1))        # the SDF's <damping>
    qdot = np.linspace(-1.0, 1.0, 6)
    np.testing.assert_array_equal(model.friction(qdot), 0.1 * qdot)
    np.testing.assert_array_equal(model.input_upper, np.full(6, 75.0))   # <effort> limits
    assert model.dof_names[0] == "finger1_BaseJoint"

    acrobot = load(ACROBOT, finalize=False)
    actuator = acrobot.get_joint_actuator(acrobot.GetJointActuatorIndices()[0])
    actuator.set_default_rotor_inertia(0.01)
    actuator.set_default_gear_ratio(10.0)
    acrobot.Finalize()
    bare = MechanicalModel.from_plant(load(ACROBOT))
    q = np.array([0.3, -0.7])
    # reflected inertia ρ N² = 0.01 · 10² on the elbow's diagonal, nothing else changes
    np.testing.assert_allclose(MechanicalModel.from_plant(acrobot).M(q) - bare.M(q),
                               np.diag([0.0, 1.0]), atol=1e-12)


def test_from_plant_refuses_what_it_cannot_model():
    floating = MultibodyPlant(0.0)
    floating.AddRigidBody("ball", SpatialInertia.SolidSphereWithMass(1.0, 0.1))
    floating.Finalize()
    # a floating base is converted to Euler angles, but without propellers it has no input
    with pytest.raises(ValueError, match="no inputs: pass propellers="):
        MechanicalModel.from_plant(floating)
    sprung = load(ACROBOT, finalize=False)
    sprung.AddForceElement(RevoluteSpring(sprung.GetJointByName("elbow"), 0.0, 1.0))
    sprung.Finalize()
    with pytest.raises(ValueError, match="RevoluteSpring"):
        MechanicalModel.from_plant(sprung)
    with pytest.raises(ValueError, match="finalized"):
        MechanicalModel.from_plant(load(ACROBOT, finalize=False))
    with pytest.raises(TypeError, match="MultibodyPlant"):
        MechanicalModel.from_plant("Acrobot.urdf")


def without_damping(plant):
    context = plant.CreateDefaultContext()
    for index in plant.GetJointIndices():
        joint = plant.get_joint(index)
        if joint.num_velocities():
            joint.SetDampingVector(context, np.zeros(joint.num_velocities()))
    return context


def track_gripper(model_damping=True, duration=2.0, accuracy=1e-6):
    """Planar gripper (6 damped joints) on a smooth reference, started on it; max |error|."""
    builder = DiagramBuilder()
    plant = builder.AddSystem(load(GRIPPER))
    model = MechanicalModel.from_plant(plant, context=None if model_damping else without_damping(plant))
    names = model.dof_names
    trajectory = PiecewiseTrajectory(names, [[sine(0.3, 2.0 + k, offset=0.1 * k) for k in range(6)]])
    ref = builder.AddSystem(TrajectoryReference(trajectory))
    gains = controlled_gains(Y0=[100.0] * 6, Y1=[200.0] * 6, Y2=[20.0] * 6, Y3=[0.05] * 6)
    ctrl = builder.AddSystem(MechanicalController(model, Partition(controlled=range(6)),
                                                  SobolevLaw(gains)))
    builder.Connect(plant.get_state_output_port(), ctrl.GetInputPort("x"))
    builder.Connect(ref.GetOutputPort("reference"), ctrl.GetInputPort("reference"))
    builder.Connect(ctrl.GetOutputPort("u"), plant.get_actuation_input_port())
    log = LogVectorOutput(plant.get_state_output_port(), builder)
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    q0, qd0, _ = trajectory.evaluate(0.0)
    plant.SetPositionsAndVelocities(plant.GetMyMutableContextFromRoot(context),
                                    np.concatenate([np.ravel(q0), np.ravel(qd0)]))
    simulate(diagram, context, duration, progress=False, accuracy=accuracy, max_step=0.01)
    data = log.FindLog(context)
    q_ref = trajectory.evaluate(data.sample_times())[0]
    return float(np.abs(data.data()[:6].T - q_ref).max())


def test_damped_arm_started_on_its_reference_stays_on_it():
    # The model is exact (damping included), so the error obeys ë = −K[ė; e; ∫e] from zero
    # initial conditions: e ≡ 0 up to the integrator.  The error-controlled RK3 keeps each
    # step's local error below accuracy × (|x| + 1) (here |x| ~ 1), and the stable error
    # dynamics do not accumulate it, so 10 × accuracy bounds the error.
    accuracy = 1e-6
    err = track_gripper(accuracy=accuracy)
    assert err <= 10 * accuracy
    # the same controller with the damping left out of its model is visibly off the
    # reference: the damping force is an unmodelled disturbance of ~0.1 · q̇ ~ 0.1 N·m
    err = track_gripper(model_damping=False, accuracy=accuracy)
    assert err > 1000 * accuracy


@pytest.mark.parametrize("resource, actuated, passive", [(ACROBOT, 1, 0), (CART_POLE, 0, 1)])
def test_a_stabilized_dof_no_input_reaches_is_refused(resource, actuated, passive):
    model = MechanicalModel.from_plant(load(resource))
    law = SobolevLaw(controlled_gains(Y0=[1.0], Y1=[2.0], Y2=[1.0], Y3=[0.1]),
                     stabilized=stabilized_gains(U0=[1.0], U1=[1.0]))
    with pytest.raises(ValueError, match=f"DOF {passive} .*receive no input.*uncontrolled"):
        MechanicalLaw(model, Partition(controlled=[actuated], stabilized=[passive]), law)
    with pytest.raises(ValueError, match="square and invertible"):
        MechanicalLaw(model, Partition(controlled=[0, 1]), SobolevLaw(
            controlled_gains(Y0=[1.0] * 2, Y1=[2.0] * 2, Y2=[1.0] * 2, Y3=[0.1] * 2)))
    # the reduced model (passive joint uncontrolled) satisfies Assumption 5
    MechanicalLaw(model, Partition(controlled=[actuated], uncontrolled=[passive]),
                  SobolevLaw(controlled_gains(Y0=[1.0], Y1=[2.0], Y2=[1.0], Y3=[0.1])))


def test_operating_points_check_rank_along_the_range():
    model = MechanicalModel.from_plant(load(ACROBOT))
    gains = SobolevLaw(controlled_gains(Y0=[1.0], Y1=[2.0], Y2=[1.0], Y3=[0.1]))
    # controlled shoulder, elbow left to itself: B̄ = −M12/M22 vanishes nowhere on this range
    MechanicalLaw(model, Partition(controlled=[0], uncontrolled=[1]), gains,
                  operating_points=[[0.0, 0.0], [1.0, 2.0], [-1.0, -2.5]])
    with pytest.raises(ValueError, match="operating_points"):
        MechanicalLaw(model, Partition(controlled=[0], uncontrolled=[1]), gains,
                      operating_points=[[0.0, 0.0, 0.0]])


def test_hinf_law_refuses_regulated_dof_at_construction():
    from sobolev_drake.synthesis.mechanical import hinf_mechanical_gains
    from sobolev_drake.systems.mechanical_controller import HinfLaw
    model = MechanicalModel.from_plant(load(GRIPPER))
    law = HinfLaw(hinf_mechanical_gains(1.0, 2.0, 1.0, 1.0, gamma=2.0))
    with pytest.raises(ValueError, match="no regulated-DOF form"):
        MechanicalLaw(model, Partition(controlled=[0, 1, 2, 3, 4], regulated=[5]), law)


def test_a_subclass_that_would_ignore_joint_damping_is_refused():
    class Bare(MechanicalModel):
        pass
    with pytest.raises(ValueError, match="damping .*would ignore.*from_plant"):
        Bare(load(GRIPPER))
