"""MechanicalModel.from_plant on ordinary plants: built in code (default model instance, no
parser), inside a diagram (the plant's context taken from the diagram's), and the plants and
contexts it must refuse with a message naming the fix (no actuators, constraints, a context of
another system, a non-double or unfinalized plant, a floating base)."""

import numpy as np
import pytest
from pydrake.math import RigidTransform
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import AddMultibodyPlantSceneGraph, MultibodyPlant
from pydrake.multibody.tree import FixedOffsetFrame, RevoluteJoint, SpatialInertia
from pydrake.systems.framework import DiagramBuilder

from sobolev_drake.models.base import MechanicalModel

LINKS = ((1.0, 0.8), (0.6, 0.5))             # (mass kg, length m) of the two links
EPS = np.finfo(float).eps
N_STATES = 20


def add_pendulum(plant, actuated=True, instance=None, prefix=""):
    """Two capsule-like links hanging along −z from the world, pivoting about y, added in code
    (no parser) to ``instance`` (the plant's default model instance when None)."""
    parent = plant.world_frame()
    joints = []
    for k, (mass, length) in enumerate(LINKS):
        inertia = SpatialInertia.SolidCylinderWithMassAboutEnd(mass, 0.03, length, [0.0, 0.0, -1.0])
        link = (plant.AddRigidBody(f"{prefix}link{k}", inertia) if instance is None
                else plant.AddRigidBody(f"{prefix}link{k}", instance, inertia))
        joint = plant.AddJoint(RevoluteJoint(f"{prefix}joint{k}", parent, link.body_frame(),
                                             [0.0, 1.0, 0.0]))
        if actuated:
            plant.AddJointActuator(f"{prefix}motor{k}", joint)
        joints.append(joint)
        parent = plant.AddFrame(FixedOffsetFrame(f"{prefix}tip{k}", link.body_frame(),
                                                 RigidTransform([0.0, 0.0, -length])))
    return joints


def pendulum(time_step=0.0, actuated=True):
    plant = MultibodyPlant(time_step)
    add_pendulum(plant, actuated)
    plant.Finalize()
    return plant


def pendulum_in_diagram(time_step=0.0):
    """(diagram, plant, diagram context) with the plant added by AddMultibodyPlantSceneGraph."""
    builder = DiagramBuilder()
    plant, _ = AddMultibodyPlantSceneGraph(builder, time_step)
    add_pendulum(plant)
    plant.Finalize()
    diagram = builder.Build()
    return diagram, plant, diagram.CreateDefaultContext()


def drake_terms(plant, context, q, v):
    """Drake's own M(q), C(q, v) v and gravity generalized forces at (q, v)."""
    plant.SetPositions(context, q)
    plant.SetVelocities(context, v)
    return (plant.CalcMassMatrix(context), plant.CalcBiasTerm(context),
            plant.CalcGravityGeneralizedForces(context))


def rounding_tol(reference, n):
    """Bound on the rounding of the model's T^T A T (T = I here, so in fact exact): each of the
    two n-term products adds at most γ_n |T^T||A||T| ≤ n (ε/2) max|A| per entry (Higham,
    Accuracy and Stability, §3.5); 2 n ε max|A| is that sum with a factor-2 margin."""
    return 2 * n * EPS * float(np.abs(reference).max())


def random_states(n, seed):
    rng = np.random.default_rng(seed)
    return [(rng.uniform(-np.pi, np.pi, n), rng.uniform(-3.0, 3.0, n)) for _ in range(N_STATES)]


@pytest.mark.parametrize("time_step", [0.0, 1e-3])
def test_a_pendulum_built_in_code_matches_drake_without_a_name(time_step):
    plant = pendulum(time_step)
    model = MechanicalModel.from_plant(plant)          # raised AttributeError before
    assert model.name == "DefaultModelInstance"
    assert model.dof_names == ["joint0", "joint1"]
    assert model.n == 2 and model.num_inputs == 2
    np.testing.assert_array_equal(model.B(np.zeros(2)), np.eye(2))
    reference = plant.CreateDefaultContext()
    worst = 0.0
    for q, v in random_states(2, seed=10):
        M, bias, gravity = drake_terms(plant, reference, q, v)
        for ours, theirs in ((model.M(q), M), (model.Cqdot(q, v), bias), (model.g(q), -gravity)):
            err = float(np.abs(ours - theirs).max())
            assert err <= rounding_tol(theirs, model.n), (q, v, err)
            worst = max(worst, err)
    assert worst == 0.0   # measured: the same Drake calls on the same numbers, bit for bit


def test_the_default_name_is_the_instances_holding_the_actuated_joints():
    plant = MultibodyPlant(0.0)
    add_pendulum(plant)                  # Drake wants the default instance filled in first
    fixture = plant.AddModelInstance("fixture")     # instance 2: holds no actuated joint
    plant.WeldFrames(plant.world_frame(), plant.AddRigidBody(
        "table", fixture, SpatialInertia.SolidBoxWithMass(5.0, 1.0, 1.0, 0.1)).body_frame())
    add_pendulum(plant, instance=plant.AddModelInstance("second"), prefix="b_")
    plant.Finalize()
    assert MechanicalModel.from_plant(plant).name == "DefaultModelInstance + second"
    assert MechanicalModel.from_plant(plant, name="two arms").name == "two arms"


@pytest.mark.parametrize("time_step", [0.0, 1e-3])
@pytest.mark.parametrize("getter", ["GetMyContextFromRoot", "GetMyMutableContextFromRoot"])
def test_the_plants_context_inside_a_diagram_is_accepted_and_read(time_step, getter):
    diagram, plant, root = pendulum_in_diagram(time_step)
    q0 = np.array([0.4, -1.1])
    plant.SetPositions(plant.GetMyMutableContextFromRoot(root), q0)
    context = getattr(plant, getter)(root)
    model = MechanicalModel.from_plant(plant, context=context)  # "non-root Context" before
    # with the diagram's (default) parameters it is the model of the plant's default context
    default = MechanicalModel.from_plant(plant)
    for q, v in random_states(2, seed=11):
        np.testing.assert_array_equal(model.M(q), default.M(q))
        np.testing.assert_array_equal(model.Cqdot(q, v), default.Cqdot(q, v))
        np.testing.assert_array_equal(model.g(q), default.g(q))
    np.testing.assert_array_equal(model.M(q0), plant.CalcMassMatrix(context))

    # parameters set in the diagram's context are the model's; the context is left as it was
    mutable = plant.GetMyMutableContextFromRoot(root)
    plant.GetBodyByName("link1").SetMass(mutable, 2.5)
    plant.GetJointByName("joint0").SetDampingVector(mutable, [0.3])
    model = MechanicalModel.from_plant(plant, context=getattr(plant, getter)(root))
    np.testing.assert_array_equal(model.damping, [0.3, 0.0])
    reference = plant.CreateDefaultContext()
    plant.GetBodyByName("link1").SetMass(reference, 2.5)
    for q, v in random_states(2, seed=12):
        M, bias, gravity = drake_terms(plant, reference, q, v)
        np.testing.assert_array_equal(model.M(q), M)
        np.testing.assert_array_equal(model.Cqdot(q, v), bias)
        np.testing.assert_array_equal(model.g(q), -gravity)
    assert plant.GetJointByName("joint0").GetDampingVector(mutable) == [0.3]
    np.testing.assert_array_equal(plant.GetPositions(mutable), q0)


def test_a_context_of_another_system_is_refused_naming_the_argument():
    diagram, plant, root = pendulum_in_diagram()
    with pytest.raises(ValueError, match=r"context is not a context of plant .*root Diagram.*"
                                         r"pass plant\.GetMyContextFromRoot\(context\)"):
        MechanicalModel.from_plant(plant, context=root)
    twin = pendulum()                                  # the same plant, another system
    with pytest.raises(ValueError, match=r"context is not a context of plant .*"
                                         r"plant\.CreateDefaultContext\(\).*GetMyContextFromRoot"):
        MechanicalModel.from_plant(plant, context=twin.CreateDefaultContext())
    scene_graph = diagram.GetSubsystemByName("scene_graph")
    with pytest.raises(ValueError, match="context is not a context of plant .*scene_graph"):
        MechanicalModel.from_plant(plant, context=scene_graph.GetMyContextFromRoot(root))
    with pytest.raises(TypeError, match="context must be a double Context .*got ndarray"):
        MechanicalModel.from_plant(plant, context=np.zeros(4))
    autodiff = plant.ToAutoDiffXd()
    with pytest.raises(TypeError, match="context must be a double Context"):
        MechanicalModel.from_plant(plant, context=autodiff.CreateDefaultContext())


def test_a_plant_without_actuators_is_refused_naming_the_fix():
    with pytest.raises(ValueError, match=r"no joint actuators.*plant\.AddJointActuator.*"
                                         r"<transmission>.*Propeller.*propellers="):
        MechanicalModel.from_plant(pendulum(actuated=False))


MIMIC_URDF = """<robot name="mimic">
  <link name="l0"><inertial><mass value="1"/>
    <inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="l1"><inertial><mass value="1"/>
    <inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="j0" type="continuous"><parent link="world"/><child link="l0"/>
    <axis xyz="0 1 0"/></joint>
  <joint name="j1" type="continuous"><parent link="l0"/><child link="l1"/>
    <origin xyz="0 0 -1"/><axis xyz="0 1 0"/><mimic joint="j0" multiplier="2"/></joint>
  <transmission type="SimpleTransmission" name="t0"><actuator name="a0"/><joint name="j0"/>
    <mechanicalReduction>1</mechanicalReduction></transmission>
</robot>"""


def constrained(kind):
    plant = MultibodyPlant(1e-3)                       # constraints need a discrete plant
    if kind == "mimic":
        Parser(plant).AddModelsFromString(MIMIC_URDF, "urdf")
    else:
        j0, j1 = add_pendulum(plant)
        link0, link1 = j0.child_body(), j1.child_body()
        if kind == "coupler":
            plant.AddCouplerConstraint(j0, j1, 2.0)
        elif kind == "distance":
            plant.AddDistanceConstraint(link1, [0.0, 0.0, -0.5], plant.world_body(),
                                        [0.5, 0.0, -1.0], 0.3)
        elif kind == "ball":
            plant.AddBallConstraint(link1, [0.0, 0.0, -0.5], plant.world_body())
        else:
            plant.AddWeldConstraint(link0, RigidTransform(), link1, RigidTransform())
    plant.Finalize()
    return plant


@pytest.mark.parametrize("kind, named", [
    ("mimic", "1 coupler"), ("coupler", "1 coupler"), ("distance", "1 distance"),
    ("ball", "1 coupler .*, ball or weld"), ("weld", "1 coupler .*, ball or weld")])
def test_a_plant_with_constraints_is_refused_naming_them_and_the_fix(kind, named):
    plant = constrained(kind)
    assert plant.num_constraints() == 1
    with pytest.raises(ValueError, match=rf"1 constraint\(s\) \({named}.*without constraint "
                                         r"forces.*<mimic>.*Add\*Constraint"):
        MechanicalModel.from_plant(plant)


def test_unfinalized_non_double_and_diagram_plants_are_refused_naming_the_fix():
    plant = MultibodyPlant(0.0)
    add_pendulum(plant)
    with pytest.raises(ValueError, match=r"must be finalized .*plant\.Finalize\(\)"):
        MechanicalModel.from_plant(plant)
    plant.Finalize()
    with pytest.raises(TypeError, match=r"scalar type float, got MultibodyPlant_\[AutoDiffXd\]"
                                        r".*the double plant \(the one ToAutoDiffXd"):
        MechanicalModel.from_plant(plant.ToAutoDiffXd())
    with pytest.raises(TypeError, match=r"MultibodyPlant_\[Expression\]"):
        MechanicalModel.from_plant(plant.ToSymbolic())
    diagram, _, _ = pendulum_in_diagram()
    with pytest.raises(TypeError, match="got Diagram: .*for a Diagram, the plant inside it"):
        MechanicalModel.from_plant(diagram)


def test_a_floating_base_built_in_code_is_converted_to_euler_angles():
    plant = MultibodyPlant(0.0)
    base = plant.AddRigidBody("base", SpatialInertia.SolidBoxWithMass(2.0, 0.3, 0.3, 0.1))
    arm = plant.AddRigidBody("arm", SpatialInertia.SolidCylinderWithMassAboutEnd(
        0.5, 0.02, 0.4, [0.0, 0.0, -1.0]))
    plant.AddJointActuator("motor", plant.AddJoint(RevoluteJoint(
        "shoulder", base.body_frame(), arm.body_frame(), [0.0, 1.0, 0.0])))
    plant.Finalize()
    # issue #32: the quaternion base becomes [ϕ θ ψ x y z], the arm joint follows, the
    # joint actuator is the one input (its column of Drake's actuation matrix, mapped by Jᵀ)
    model = MechanicalModel.from_plant(plant)
    assert model.n == 7 and model.num_inputs == 1
    assert model.dof_names == ["phi", "theta", "psi", "x", "y", "z", "shoulder"]
    q = np.array([0.1, -0.2, 0.3, 0.0, 0.0, 1.0, 0.4])
    np.testing.assert_allclose(model.B(q), model.velocity_jacobian(q).T @ plant.MakeActuationMatrix())
