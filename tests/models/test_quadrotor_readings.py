"""The quadrotor's thesis-printed reading of (5.123)'s W′_η: Christoffel terms checked by finite
differences, the reading coincides with the physical one at level attitude, the simulated plant
follows the printed equations, bad input."""

import numpy as np
import pytest
from pydrake.systems.framework import DiagramBuilder
from scipy.integrate import solve_ivp

from sobolev_drake.models.euler_zyx import (EULER_READINGS, angular_coriolis, angular_inertia,
                                            euler_rate_matrix, euler_rate_matrix_dot,
                                            euler_rate_matrix_partials, torque_map)
from sobolev_drake.models.quadrotor import (QuadrotorModel, ThesisPrintedQuadrotorModel, add_quadrotor,
                                            make_quadrotor_model)
from sobolev_drake.systems.plant_dynamics import PlantDynamics

I_BODY = np.diag([0.0363, 0.0363, 0.0615])
STATES = [(np.array([0.3, -0.4, 0.5]), np.array([0.7, -0.2, 0.9])),
          (np.array([-1.1, 0.9, -2.0]), np.array([-1.5, 2.0, 0.3]))]


def christoffel_by_differences(reading, eta, v, h=1e-5):
    """C(η, η̇) η̇ = Σ_l (∂M/∂η_l) v_l v − ½ [vᵀ (∂M/∂η_k) v]_k with central differences of M."""
    d = []
    for k in range(3):
        e = np.zeros(3)
        e[k] = h
        d.append((angular_inertia(I_BODY, *(eta + e)[:2], reading)
                  - angular_inertia(I_BODY, *(eta - e)[:2], reading)) / (2 * h))
    return sum(d[k] * v[k] for k in range(3)) @ v - 0.5 * np.array([v @ d[k] @ v for k in range(3)])


@pytest.mark.parametrize("reading", EULER_READINGS)
@pytest.mark.parametrize("eta, v", STATES)
def test_coriolis_is_the_christoffel_term_of_the_metric(reading, eta, v):
    # central differences of M (entries ~0.06, third derivatives of the same size) err by
    # ~h²·0.06 ≈ 6e-12 plus rounding ~eps·0.06/h ≈ 1e-12, on terms of size ~0.05
    np.testing.assert_allclose(angular_coriolis(I_BODY, eta, v, reading),
                               christoffel_by_differences(reading, eta, v), atol=1e-9)
    # the power identity of a Christoffel C: η̇ᵀ(Ṁ η̇ − 2 C η̇) = 0
    m_dot = sum(p * r for p, r in zip(euler_rate_matrix_partials(*eta[:2]), v[:2]))
    W = euler_rate_matrix(*eta[:2])
    if reading == "physical":
        m_dot = m_dot.T @ I_BODY @ W + W.T @ I_BODY @ m_dot
    else:
        m_dot = m_dot @ I_BODY @ W.T + W @ I_BODY @ m_dot.T
    assert abs(v @ (m_dot @ v - 2 * angular_coriolis(I_BODY, eta, v, reading))) < 1e-14


@pytest.mark.parametrize("eta, v", STATES)
def test_physical_terms_are_the_rigid_body_closed_forms(eta, v):
    """The generic Christoffel term equals Wᵀ(I Ẇ η̇ + ω × I ω), derived from ω = W η̇."""
    W = euler_rate_matrix(*eta[:2])
    omega = W @ v
    closed = W.T @ (I_BODY @ euler_rate_matrix_dot(*eta[:2], *v[:2]) @ v + np.cross(omega, I_BODY @ omega))
    np.testing.assert_allclose(angular_coriolis(I_BODY, eta, v), closed, atol=1e-15)
    np.testing.assert_allclose(angular_inertia(I_BODY, *eta[:2]), W.T @ I_BODY @ W, rtol=1e-15)
    np.testing.assert_array_equal(torque_map(*eta[:2]), W.T)


def test_printed_model_differs_only_off_level_attitude():
    printed, physical = make_quadrotor_model(euler_matrix="thesis-printed"), make_quadrotor_model()
    assert isinstance(printed, ThesisPrintedQuadrotorModel) and type(physical) is QuadrotorModel
    level = np.array([0.0, 0.0, 0.8, 1.0, -2.0, 3.0])
    np.testing.assert_allclose(printed.M(level), physical.M(level), atol=1e-15)
    np.testing.assert_allclose(printed.B(level), physical.B(level), atol=1e-15)
    tilted = np.array([0.5, -0.4, 0.8, 1.0, -2.0, 3.0])
    W = euler_rate_matrix(0.5, -0.4)
    np.testing.assert_allclose(printed.M(tilted)[:3, :3], W @ I_BODY @ W.T, rtol=1e-14)
    assert np.abs(printed.M(tilted)[:3, :3] - physical.M(tilted)[:3, :3]).max() > 1e-3
    # translation and the rotor forces are the plant's; torques go through W instead of Wᵀ
    np.testing.assert_allclose(printed.B(tilted)[3:], physical.B(tilted)[3:], rtol=1e-14)
    np.testing.assert_allclose(printed.B(tilted)[:3], W @ np.linalg.solve(W.T, physical.B(tilted)[:3]),
                               rtol=1e-10, atol=1e-14)
    # the controller's dynamics use the model's own M, not the plant's fast path
    assert not PlantDynamics(printed).fast and PlantDynamics(physical).fast


def test_printed_plant_follows_the_printed_equations(fly_constant):
    """The MultibodyPlant driven through the adapter integrates the printed equations; compared
    with scipy's integration of the printed closed forms.  Both integrators run at ~1e-10
    relative accuracy over 1 s (errors ~1e-9 rad), so 1e-6 rad leaves a wide margin for error
    growth; the physical plant ends measurably elsewhere (checked too)."""
    printed = make_quadrotor_model(euler_matrix="thesis-printed")
    hover = printed.params.hover_input()
    tau = hover * np.array([1.05, 0.97, 1.0, 1.02])          # a tumbling, climbing command
    w = np.array([0.02, -0.01, 0.0, 0.0, 0.0, 0.0])
    q0, qd0 = np.array([0.6, -0.5, 0.3, 0.0, 0.0, 1.0]), np.array([0.5, -0.3, 0.8, 0.0, 0.0, 0.0])
    finals = {r: fly_constant(lambda b, r=r: add_quadrotor(b, euler_matrix=r), q0, qd0, tau, w, 1.0)
              for r in EULER_READINGS}

    def rhs(_, x):
        q, qd = x[:6], x[6:]
        return np.r_[qd, np.linalg.solve(printed.M(q), printed.B(q) @ tau + w - printed.Cqdot(q, qd)
                                         - printed.g_closed_form(q))]

    ref = solve_ivp(rhs, (0.0, 1.0), np.r_[q0, qd0], method="DOP853", rtol=1e-11, atol=1e-12).y[:, -1]
    np.testing.assert_allclose(finals["thesis-printed"][:6], ref[:6], atol=1e-6)
    assert np.abs(finals["physical"][:3] - ref[:3]).max() > 1e-3


def test_unknown_euler_reading_is_refused():
    with pytest.raises(ValueError, match="euler_matrix must be one of .*'printed'"):
        make_quadrotor_model(euler_matrix="printed")
    with pytest.raises(ValueError, match="euler_matrix must be one of"):
        add_quadrotor(DiagramBuilder(), euler_matrix="W'")
    with pytest.raises(ValueError, match="reading must be one of"):
        angular_inertia(I_BODY, 0.1, 0.2, reading="literal")
