"""Rotational terms of a rigid body in ZYX Euler angles η = [ϕ θ ψ], in two readings.

With W the map from Euler-angle rates to body angular velocity (ω_B = W η̇), the physical
Euler–Lagrange terms are M_η = Wᵀ I W (kinetic energy ½ ωᵀ I ω) and the torque map Wᵀ
(generalized force of a body torque τ_B).  The thesis' (5.123) prints M = W′_η I W_η and
B = blockdiag(W′_η, R) B₀ and displays the matrix it calls W′_η — which is W itself.  Read
literally (``reading="thesis-printed"``), the displayed matrix is W′ (the thesis' ′ is a
transpose), so M_η = W I Wᵀ and the torque map is W: a positive-definite metric, but not the
kinetic energy of a rigid body.  Both readings have their Christoffel C computed here from the
partial derivatives of M_η, so either is a consistent Lagrangian system.

The physical reading is what :class:`~sobolev_drake.models.quadrotor.QuadrotorModel` uses by
default; its closed forms (Wᵀ(I Ẇ η̇ + ω × I ω)) are checked against :func:`angular_coriolis`
in the tests.  Both readings are one formula: with A = W (physical) or A = Wᵀ (thesis-printed),
M_η = Aᵀ I A and body torques enter through Aᵀ.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["EULER_READINGS", "euler_rate_matrix", "euler_rate_matrix_dot", "euler_rate_matrix_partials",
           "angular_inertia", "angular_coriolis", "torque_map"]

#: "physical": M_η = Wᵀ I W, torques through Wᵀ; "thesis-printed": (5.123)'s W′_η read
#: literally, M_η = W I Wᵀ, torques through W
EULER_READINGS = ("physical", "thesis-printed")


def euler_rate_matrix(phi: float, theta: float) -> np.ndarray:
    """W with ω_B = W [ϕ̇ θ̇ ψ̇] (ZYX angles; the matrix printed in (5.123)).

    Parameters
    ----------
    phi, theta : float
        Roll and pitch (rad).

    Returns
    -------
    ndarray, shape (3, 3)
    """
    sp, cp, st, ct = np.sin(phi), np.cos(phi), np.sin(theta), np.cos(theta)
    return np.array([[1.0, 0.0, -st], [0.0, cp, sp * ct], [0.0, -sp, cp * ct]])


def euler_rate_matrix_partials(phi: float, theta: float) -> tuple[np.ndarray, np.ndarray]:
    """(∂W/∂ϕ, ∂W/∂θ); W does not depend on ψ.

    Parameters
    ----------
    phi, theta : float
        Roll and pitch (rad).

    Returns
    -------
    (ndarray, ndarray)
        Two 3×3 matrices.
    """
    sp, cp, st, ct = np.sin(phi), np.cos(phi), np.sin(theta), np.cos(theta)
    d_phi = np.array([[0.0, 0.0, 0.0], [0.0, -sp, cp * ct], [0.0, -cp, -sp * ct]])
    d_theta = np.array([[0.0, 0.0, -ct], [0.0, 0.0, -sp * st], [0.0, 0.0, -cp * st]])
    return d_phi, d_theta


def euler_rate_matrix_dot(phi: float, theta: float, phidot: float, thetadot: float) -> np.ndarray:
    """Ẇ = (∂W/∂ϕ) ϕ̇ + (∂W/∂θ) θ̇.

    Parameters
    ----------
    phi, theta : float
        Roll and pitch (rad).
    phidot, thetadot : float
        Their rates (rad/s).

    Returns
    -------
    ndarray, shape (3, 3)
    """
    d_phi, d_theta = euler_rate_matrix_partials(phi, theta)
    return d_phi * phidot + d_theta * thetadot


def _rate_map(phi, theta, reading):
    """(A, ∂A/∂ϕ, ∂A/∂θ) with A = W (physical) or Wᵀ (thesis-printed): M_η = Aᵀ I A."""
    if reading not in EULER_READINGS:
        raise ValueError(f"reading must be one of {EULER_READINGS}, got {reading!r}")
    W = euler_rate_matrix(phi, theta)
    d_phi, d_theta = euler_rate_matrix_partials(phi, theta)
    return (W, d_phi, d_theta) if reading == "physical" else (W.T, d_phi.T, d_theta.T)


def angular_inertia(inertia: ArrayLike, phi: float, theta: float,
                    reading: str = "physical") -> np.ndarray:
    """M_η: Wᵀ I W (physical) or W I Wᵀ (thesis-printed).

    Parameters
    ----------
    inertia : array_like, shape (3, 3)
        Body inertia I.
    phi, theta : float
        Roll and pitch (rad).
    reading : str, default "physical"
        One of :data:`EULER_READINGS`.

    Returns
    -------
    ndarray, shape (3, 3)
    """
    A = _rate_map(phi, theta, reading)[0]
    return A.T @ np.asarray(inertia, dtype=float) @ A


def angular_coriolis(inertia: ArrayLike, eta: ArrayLike, eta_dot: ArrayLike,
                     reading: str = "physical") -> np.ndarray:
    """C(η, η̇) η̇ of M_η by the Christoffel symbols of the first kind:
    Ṁ_η η̇ − ½ [η̇ᵀ (∂M_η/∂η_k) η̇]_k.

    Parameters
    ----------
    inertia : array_like, shape (3, 3)
        Body inertia I.
    eta, eta_dot : array_like, shape (3,)
        [ϕ θ ψ] and its rates.
    reading : str, default "physical"
        One of :data:`EULER_READINGS`.

    Returns
    -------
    ndarray, shape (3,)
    """
    I = np.asarray(inertia, dtype=float)
    v = np.asarray(eta_dot, dtype=float)
    A, *dA = _rate_map(float(eta[0]), float(eta[1]), reading)
    partials = [d.T @ I @ A + A.T @ I @ d for d in dA]          # ∂(Aᵀ I A)/∂ϕ, ∂/∂θ
    m_dot = partials[0] * v[0] + partials[1] * v[1]
    grad = np.array([v @ partials[0] @ v, v @ partials[1] @ v, 0.0])
    return m_dot @ v - 0.5 * grad


def torque_map(phi: float, theta: float, reading: str = "physical") -> np.ndarray:
    """The matrix taking a body torque τ_B to the generalized force on η: Wᵀ or W.

    Parameters
    ----------
    phi, theta : float
        Roll and pitch (rad).
    reading : str, default "physical"
        One of :data:`EULER_READINGS`.

    Returns
    -------
    ndarray, shape (3, 3)
    """
    return _rate_map(phi, theta, reading)[0].T
