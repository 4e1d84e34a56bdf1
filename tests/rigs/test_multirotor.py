"""Your own drone (issue #32): a quadrotor and a hexarotor described as drone packages
describe them (one free body → Drake's quaternion floating joint, rotors as Drake
``Propeller``s), written here, flown by the nonlinear W2/W∞ law with allocation and by Drake's
LQR around hover — the same code for both vehicles.  Short horizons (smoke versions of
diagrams/multirotor_figure8.py)."""

from functools import partial

import numpy as np
import pytest
from pydrake.math import RigidTransform
from pydrake.multibody.plant import PropellerInfo
from pydrake.systems.controllers import LinearQuadraticRegulator

from sobolev_drake.rigs.multirotor import (add_hover_winf, add_state_feedback, add_w_controller, fly_multirotor,
                                           linearize_hover)
from sobolev_drake.synthesis.mechanical import controlled_gains, regulated_gains
from sobolev_drake.systems.disturbances import TimeProfiledForce
from sobolev_drake.systems.mechanical_law import SobolevLaw
from sobolev_drake.systems.references import PiecewiseTrajectory, TrajectoryReference, const, sine

QUADROTOR = """<sdf version="1.7"><model name="quadrotor"><link name="body"><inertial>
<mass>0.775</mass><inertia><ixx>0.0015</ixx><iyy>0.0025</iyy><izz>0.0035</izz><ixy>0</ixy>
<ixz>0</ixz><iyz>0</iyz></inertia></inertial></link></model></sdf>"""
HEXAROTOR = """<sdf version="1.7"><model name="hexarotor"><link name="body"><inertial>
<mass>1.6</mass><inertia><ixx>0.021</ixx><iyy>0.021</iyy><izz>0.04</izz><ixy>0</ixy>
<ixz>0</ixz><iyz>0</iyz></inertia></inertial></link></model></sdf>"""


def rotors(count, arm, plant):
    """Rotors evenly spaced on a circle, spinning alternately (thrust = command N, drag torque
    = ±0.0245 m · command)."""
    body = plant.GetBodyByName("body").index()
    return [PropellerInfo(body, RigidTransform([arm * np.cos(2 * np.pi * i / count),
                                                arm * np.sin(2 * np.pi * i / count), 0.0]),
                          1.0, 0.0245 * (-1) ** i) for i in range(count)]


VEHICLES = {"quadrotor": (QUADROTOR, partial(rotors, 4, 0.15), 6.0),
            "hexarotor": (HEXAROTOR, partial(rotors, 6, 0.25), 8.0)}
INNER = SobolevLaw(controlled_gains([1.0, 30, 30, 30], [5.0, 60, 60, 60], [3.0, 20, 20, 20], [0.2, 1, 1, 1]),
                   regulated=regulated_gains([50625.0] * 2, [126.0] * 2, [1.0] * 2))
HOVER = PiecewiseTrajectory(["psi", "x", "y", "z"], [[const(0.0), const(0.0), const(0.0), const(1.0)]])
# figure-8 x = 2 sin(0.7 t), y = sin(1.4 t): speed 2 m/s at the crossing
FIGURE8 = PiecewiseTrajectory(["psi", "x", "y", "z"], [[const(0.0), sine(2.0, 0.7), sine(1.0, 1.4), const(1.0)]])


def w_law(builder, handles, reference_port):
    return add_w_controller(builder, handles, INNER, reference_port)


def drake_lqr(builder, handles, reference_port):
    lin = linearize_hover(handles)
    K, _ = LinearQuadraticRegulator(lin.A, lin.B, np.diag([10.0] * 6 + [1.0] * 6), np.eye(len(lin.u0)))
    return add_state_feedback(builder, handles, K, lin.u0, reference_port)


def fly(vehicle, controller, trajectory, pushes, duration):
    description, propellers, upper = VEHICLES[vehicle]
    run = fly_multirotor(description, propellers, TrajectoryReference(trajectory),
                         TimeProfiledForce(6, pushes), duration, controller=controller,
                         command_upper=upper)
    run["e"] = run["x"][:, 3:6] - run["ref"][:, 1:4]
    return run


def test_hover_linearization_is_minimal_and_has_the_gravity_tilt_coupling():
    description, propellers, upper = VEHICLES["quadrotor"]
    from pydrake.systems.framework import DiagramBuilder
    from sobolev_drake.rigs.multirotor import add_multirotor
    handles = add_multirotor(DiagramBuilder(), description, propellers, command_upper=upper)
    lin = linearize_hover(handles)
    assert lin.A.shape == (12, 12) and lin.B.shape == (12, 4)
    # ẍ = g θ, ÿ = −g ϕ at hover (R ẑ ≈ [θ, −ϕ, 1]); rounding of Linearize's AutoDiffXd only
    np.testing.assert_allclose(lin.A[9, 1], 9.81, rtol=1e-12)
    np.testing.assert_allclose(lin.A[10, 0], -9.81, rtol=1e-12)
    np.testing.assert_allclose(lin.A[:6, 6:], np.eye(6), atol=1e-12)
    ctrb = np.hstack([np.linalg.matrix_power(lin.A, k) @ lin.B for k in range(12)])
    assert np.linalg.matrix_rank(ctrb) == 12          # no quaternion-norm direction left
    np.testing.assert_allclose(lin.u0, np.full(4, 0.775 * 9.81 / 4), rtol=1e-9)


@pytest.mark.parametrize("vehicle", sorted(VEHICLES))
def test_w_law_hovers_and_recovers_from_a_push_no_worse_than_lqr(vehicle):
    push = [{"index": 3, "value": 2.0, "from": 0.2, "to": 0.7}]        # 2 N × 0.5 s along x
    w, lqr = (fly(vehicle, c, HOVER, push, 2.0) for c in (w_law, drake_lqr))
    before = w["t"] < 0.2
    assert np.abs(w["e"][before]).max() < 1e-6                         # hovers on the trim
    peak_w, peak_lqr = (np.abs(r["e"][:, 0]).max() for r in (w, lqr))
    assert peak_w <= peak_lqr, (peak_w, peak_lqr)
    assert np.all(w["u"] >= -1e-9) and np.all(w["u"] <= VEHICLES[vehicle][2] + 1e-9)


@pytest.mark.parametrize("vehicle", sorted(VEHICLES))
def test_w_law_tracks_a_2_m_per_s_figure8_with_lower_rms_than_lqr(vehicle):
    w, lqr = (fly(vehicle, c, FIGURE8, [], 3.0) for c in (w_law, drake_lqr))
    rms = [np.sqrt(np.trapezoid((r["e"] ** 2).sum(axis=1), r["t"]) / r["t"][-1]) for r in (w, lqr)]
    assert rms[0] < rms[1], rms
    assert np.abs(w["x"][:, :2]).max() < 0.6                           # within max_tilt


def test_linear_winf_path_in_one_call_holds_the_hover_against_the_push():
    designs = []

    def winf(builder, handles, reference_port):
        system, result = add_hover_winf(builder, handles, reference_port,
                                        Gamma0=[1, 1, 1, 10, 10, 10, 0.1, 0.1, 0.1, 1, 1, 1],
                                        Gamma1=[0.01] * 12)
        designs.append(result)
        return system

    run = fly("quadrotor", winf, HOVER, [{"index": 3, "value": 2.0, "from": 0.2, "to": 0.7}], 3.0)
    (result,) = designs
    assert result.certificate.ok
    # the 2 N push moves it (measured peak 0.37 m, LQR 0.34 m) and the loop brings it back
    peak = np.abs(run["e"][:, 0]).max()
    assert 0.05 < peak < 1.0 and abs(run["e"][-1, 0]) < 0.5 * peak


def test_attitude_reference_points_the_thrust_along_the_force_and_caps_the_tilt():
    from sobolev_drake.models.generic_quadrotor import make_generic_quadrotor_model
    from sobolev_drake.systems.multirotor_control import MultirotorLaw

    law = MultirotorLaw(make_generic_quadrotor_model(), INNER, max_tilt=0.5)
    np.testing.assert_allclose(law.lower, 0.0)
    assert np.all(np.isinf(law.upper))
    for phi, theta, psi in ((0.1, -0.2, 0.7), (-0.3, 0.25, -2.0)):
        # the body z axis of R = Rz(ψ) Ry(θ) Rx(ϕ), scaled: its attitude is given back
        force = 20.0 * np.array([np.cos(psi) * np.sin(theta) * np.cos(phi) + np.sin(psi) * np.sin(phi),
                                 np.sin(psi) * np.sin(theta) * np.cos(phi) - np.cos(psi) * np.sin(phi),
                                 np.cos(theta) * np.cos(phi)])
        np.testing.assert_allclose(law.attitude_reference(force, psi), [phi, theta], atol=1e-12)
    # a force 80° off vertical (or pointing down) is capped at max_tilt, keeping its heading
    capped = law.attitude_reference([np.sin(1.4), 0.0, np.cos(1.4)], 0.0)
    np.testing.assert_allclose(capped, [0.0, 0.5], atol=1e-12)
    np.testing.assert_allclose(law.attitude_reference([0.0, 1.0, -1.0], 0.0), [-0.5, 0.0], atol=1e-12)
    with pytest.raises(ValueError, match="max_tilt must be in"):
        MultirotorLaw(make_generic_quadrotor_model(), INNER, max_tilt=2.0)
