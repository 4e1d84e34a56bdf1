"""Scalar conversion of FloatingBaseState (issue #32): the AutoDiffXd and Expression systems
give the double system's outputs, AutoDiffXd differentiates the chart, and a state beyond the
model's max_pitch stops the evaluation by name."""

import numpy as np
import pytest
from pydrake.autodiffutils import ExtractGradient, InitializeAutoDiff
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant, PropellerInfo

from sobolev_drake.models import MechanicalModel
from sobolev_drake.systems.floating_state import FloatingBaseState

SDF = """<sdf version="1.7"><model name="drone"><link name="body"><inertial><mass>1.0</mass>
<inertia><ixx>0.01</ixx><iyy>0.01</iyy><izz>0.02</izz><ixy>0</ixy><ixz>0</ixz><iyz>0</iyz>
</inertia></inertial></link></model></sdf>"""


@pytest.fixture(scope="module")
def model():
    plant = MultibodyPlant(0.0)
    Parser(plant).AddModelsFromString(SDF, "sdf")
    plant.Finalize()
    return MechanicalModel.from_plant(plant, propellers=[PropellerInfo(plant.GetBodyByName("body").index())])


def test_floating_base_state_converts_and_matches_the_double_system(model):
    system = FloatingBaseState(model)
    q, qdot = np.array([0.1, 0.2, 0.3, 1, 2, 3.0]), np.array([0.3, -0.2, 0.1, 0, 1, 2.0])
    x = np.concatenate(model.to_drake_state(q, qdot))
    expected = np.r_[q, qdot]
    ctx = system.CreateDefaultContext()
    system.get_input_port(0).FixValue(ctx, x)
    np.testing.assert_allclose(system.get_output_port(0).Eval(ctx), expected, atol=1e-12)
    ad = system.ToAutoDiffXd()
    ctx = ad.CreateDefaultContext()
    ad.get_input_port(0).FixValue(ctx, InitializeAutoDiff(x))
    out = ad.get_output_port(0).Eval(ctx)
    np.testing.assert_allclose([v.value() for v in out], expected, atol=1e-12)
    # the chart's Jacobian: ∂x_e/∂x_d then ∂x_d/∂x_e (the model's to_drake_state) is the identity
    # on the 12 model coordinates; central differences of to_drake_state, error ≈ 1e-9
    P = ExtractGradient(out)
    h = 1e-6
    Q = np.column_stack([(np.concatenate(model.to_drake_state(*np.split(expected + h * e, 2)))
                          - np.concatenate(model.to_drake_state(*np.split(expected - h * e, 2)))) / (2 * h)
                         for e in np.eye(12)])
    np.testing.assert_allclose(P @ Q, np.eye(12), atol=1e-7)
    sym = system.ToSymbolic()
    ctx = sym.CreateDefaultContext()
    sym.get_input_port(0).FixValue(ctx, x)
    np.testing.assert_allclose([v.Evaluate() for v in sym.get_output_port(0).Eval(ctx)], expected,
                               atol=1e-12)


def test_floating_base_state_refuses_the_singular_attitude(model):
    system = FloatingBaseState(model)
    ctx = system.CreateDefaultContext()
    qd = np.r_[np.cos(0.76), 0.0, np.sin(0.76), 0.0, 0, 0, 0]     # pitch 1.52 rad (87°)
    system.get_input_port(0).FixValue(ctx, np.r_[qd, np.zeros(6)])
    with pytest.raises(ValueError, match=r"pitch θ = 1.52 rad \(87.1°\).*at state"):
        system.get_output_port(0).Eval(ctx)
    with pytest.raises(TypeError, match="FloatingBaseModel"):
        FloatingBaseState(object())


def test_multirotor_controller_is_double_only_and_says_what_to_use_instead(model):
    from sobolev_drake.synthesis.mechanical import controlled_gains, regulated_gains
    from sobolev_drake.systems.mechanical_law import SobolevLaw
    from sobolev_drake.systems.multirotor_control import MultirotorController

    inner = SobolevLaw(controlled_gains(1.0, 1.0, 1.0, 1.0), regulated=regulated_gains(1.0, 1.0, 1.0))
    system = MultirotorController(model, SobolevLaw(controlled_gains([1.0] * 4, 1.0, 1.0, 1.0),
                                                    regulated=regulated_gains([1.0] * 2, 1.0, 1.0)))
    for convert, scalar in ((system.ToAutoDiffXd, "AutoDiffXd"), (system.ToSymbolic, "Expression")):
        with pytest.raises(RuntimeError, match=rf"MultirotorController does not convert to {scalar}: "
                                               r".*linearize_hover.* instead"):
            convert()
    with pytest.raises(ValueError, match="gains are for 1 DOF"):
        MultirotorController(model, inner)


def test_force_allocation_is_double_only_inverts_speeds_and_holds_a_hexarotor():
    from pydrake.math import RigidTransform
    from sobolev_drake.systems.rotor_allocation import ForceAllocation

    plant = MultibodyPlant(0.0)
    Parser(plant).AddModelsFromString(SDF, "sdf")
    plant.Finalize()
    body = plant.GetBodyByName("body").index()
    infos = [PropellerInfo(body, RigidTransform([0.2 * np.cos(a), 0.2 * np.sin(a), 0.0]), 1.0,
                           0.02 * (-1) ** i) for i, a in enumerate(np.arange(6) * np.pi / 3)]
    hexa = MechanicalModel.from_plant(plant, propellers=infos, command_upper=5.0)
    q = np.zeros(6)
    system = ForceAllocation(hexa, speed_constants=2.0)
    ctx = system.CreateDefaultContext()
    system.get_input_port(0).FixValue(ctx, hexa.g(q))
    system.get_input_port(1).FixValue(ctx, np.zeros(12))
    speeds = system.get_output_port(0).Eval(ctx)
    # the six thrusts 2 Ω² hold the weight with no torque (residual at solver rounding)
    np.testing.assert_allclose(hexa.B(q) @ (2.0 * speeds ** 2), hexa.g(q), atol=1e-9)
    assert system.get_output_port(1).Eval(ctx)[0] < 1e-9
    system.get_input_port(0).FixValue(ctx, 10 * hexa.g(q))          # beyond 6 × 5 N: saturated
    np.testing.assert_allclose(2.0 * system.get_output_port(0).Eval(ctx) ** 2, np.full(6, 5.0))
    for convert, scalar in ((system.ToAutoDiffXd, "AutoDiffXd"), (system.ToSymbolic, "Expression")):
        with pytest.raises(RuntimeError, match=rf"ForceAllocation does not convert to {scalar}: .*instead"):
            convert()
    with pytest.raises(ValueError, match="speed_constants must be > 0"):
        ForceAllocation(hexa, speed_constants=-1.0)
