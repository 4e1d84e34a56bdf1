"""The ZYX Euler-angle chart of a floating body, for any scalar type (float, AutoDiffXd,
Expression).

A floating body's attitude R_FM (Drake's quaternion or roll-pitch-yaw floating joint) is written
η = [ϕ θ ψ] with R = Rz(ψ) Ry(θ) Rx(ϕ) — Drake's ``RollPitchYaw`` and the thesis quadrotor's
convention (:mod:`~sobolev_drake.models.euler_zyx`).  Drake's generalized velocity of either
floating joint is v = [ω_F; ṗ_F] (angular velocity and translational velocity, both in the
parent frame F), so

    ω_F = R W(ϕ, θ) η̇,    η̇ = W⁻¹ Rᵀ ω_F,

with W the matrix of :func:`~sobolev_drake.models.euler_zyx.euler_rate_matrix` (ω_B = W η̇).
det W = cos θ: the chart is singular at θ = ±90° (pitch straight up or down), where the rates
η̇ are not defined; :data:`DEFAULT_MAX_PITCH` is where the library stops trusting it.

Functions here use only arithmetic, ``sqrt``, ``arctan2`` and ``arcsin`` so the state
conversion system (:class:`~sobolev_drake.systems.floating_state.FloatingBaseState`) converts to
AutoDiffXd and Expression unchanged.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["DEFAULT_MAX_PITCH", "quaternion_to_euler", "euler_to_quaternion", "rotation_of_euler",
           "euler_rates", "check_pitch"]

#: |θ| beyond which a floating-base model refuses to compute (80°: cond(W) = 1/cos θ ≈ 5.8)
DEFAULT_MAX_PITCH = float(np.deg2rad(80.0))


def _sin_cos(angle):
    return np.sin(angle), np.cos(angle)


def quaternion_to_euler(quaternion: ArrayLike) -> np.ndarray:
    """[ϕ θ ψ] of a unit quaternion [w x y z] (normalized here), R = Rz(ψ) Ry(θ) Rx(ϕ).

    Parameters
    ----------
    quaternion : array_like, shape (4,)
        [w x y z], any non-zero norm (Drake's quaternion joint does not keep it unit between
        projections).

    Returns
    -------
    ndarray, shape (3,)
        [ϕ θ ψ] in (−π, π] × [−π/2, π/2] × (−π, π].

    Examples
    --------
    >>> import numpy as np
    >>> from sobolev_drake.models.euler_chart import euler_to_quaternion, quaternion_to_euler
    >>> np.round(quaternion_to_euler(euler_to_quaternion([0.1, -0.2, 0.3])), 12).tolist()
    [0.1, -0.2, 0.3]
    """
    w, x, y, z = np.asarray(quaternion).ravel()
    norm2 = w * w + x * x + y * y + z * z
    w, x, y, z = (c / np.sqrt(norm2) for c in (w, x, y, z))
    s = 2.0 * (w * y - z * x)
    if isinstance(s, float) or np.isscalar(s):
        s = min(1.0, max(-1.0, float(s)))           # rounding may put |s| a hair above 1
    return np.array([np.arctan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y)),
                     np.arcsin(s),
                     np.arctan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))])


def euler_to_quaternion(eta: ArrayLike) -> np.ndarray:
    """Unit quaternion [w x y z] of R = Rz(ψ) Ry(θ) Rx(ϕ).

    Parameters
    ----------
    eta : array_like, shape (3,)
        [ϕ θ ψ] (rad).

    Returns
    -------
    ndarray, shape (4,)
    """
    (sr, cr), (sp, cp), (sy, cy) = (_sin_cos(0.5 * a) for a in np.asarray(eta).ravel())
    return np.array([cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy,
                     cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy])


def rotation_of_euler(eta: ArrayLike) -> np.ndarray:
    """R = Rz(ψ) Ry(θ) Rx(ϕ) (child → parent).

    Parameters
    ----------
    eta : array_like, shape (3,)
        [ϕ θ ψ] (rad).

    Returns
    -------
    ndarray, shape (3, 3)
    """
    (sf, cf), (st, ct), (sp, cp) = (_sin_cos(a) for a in np.asarray(eta).ravel())
    return np.array([[cp * ct, cp * st * sf - sp * cf, cp * st * cf + sp * sf],
                     [sp * ct, sp * st * sf + cp * cf, sp * st * cf - cp * sf],
                     [-st, ct * sf, ct * cf]])


def euler_rates(eta: ArrayLike, omega_parent: ArrayLike) -> np.ndarray:
    """η̇ = W⁻¹ Rᵀ ω_F: Euler-angle rates of a body turning at ω_F (parent frame).

    Parameters
    ----------
    eta : array_like, shape (3,)
        [ϕ θ ψ] (rad), |θ| < π/2.
    omega_parent : array_like, shape (3,)
        Angular velocity in the parent frame (Drake's floating-joint w_FM).

    Returns
    -------
    ndarray, shape (3,)
        [ϕ̇ θ̇ ψ̇].
    """
    eta = np.asarray(eta).ravel()
    w_b = rotation_of_euler(eta).T @ np.asarray(omega_parent).ravel()
    (sf, cf), (st, ct) = _sin_cos(eta[0]), _sin_cos(eta[1])
    # W⁻¹ of ω_B = W η̇ (det W = cos θ)
    return np.array([w_b[0] + (sf * w_b[1] + cf * w_b[2]) * st / ct,
                     cf * w_b[1] - sf * w_b[2],
                     (sf * w_b[1] + cf * w_b[2]) / ct])


def check_pitch(eta: ArrayLike, max_pitch: float, state: ArrayLike | None = None) -> None:
    """Raise ``ValueError`` when |θ| ≥ ``max_pitch``: the ZYX chart is near its singularity.

    Parameters
    ----------
    eta : array_like, shape (3,)
        [ϕ θ ψ] (float values).
    max_pitch : float
        Largest |θ| trusted (rad).
    state : array_like, optional
        The full state, quoted in the message.

    Raises
    ------
    ValueError
        Naming θ, the limit and the state.
    """
    theta = float(np.asarray(eta, dtype=float)[1])
    if not abs(theta) < max_pitch:
        where = "" if state is None else f" at state {np.array2string(np.asarray(state, float), precision=3)}"
        raise ValueError(
            f"pitch θ = {theta:.4g} rad ({np.rad2deg(theta):.1f}°) is beyond max_pitch = "
            f"{max_pitch:.4g} rad ({np.rad2deg(max_pitch):.0f}°){where}: the ZYX Euler-angle "
            "chart of the floating base is singular at θ = ±90° (det W = cos θ), so the "
            "model's M, C q̇ and rates are not trusted there; the vehicle has lost attitude, or "
            "raise max_pitch if this attitude is intended")
