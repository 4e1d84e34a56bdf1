"""References of the tilt-rotor W∞ law's regulated DOF (thesis §7.3.2): the tilt-angle schedule
α(U) over the reference's forward air speed U and the stacked reference of the partition.

Re-exported by :mod:`sobolev_drake.tiltrotor.controller` (their historical home).  A schedule
made here or by ``tiltrotor.law.plant_trim_schedule`` carries ``compiled_form``, the constants
from which the compiled per-sample path (``native/fused.c``) evaluates it with the same
operations.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["TiltSchedule", "tilt_schedule_polynomial", "forward_air_speed", "regulated_reference",
           "regulated_values", "tracked_reference"]

#: a tilt reference schedule ``U -> (α, dα/dU, d²α/dU²)`` (forward air speed U in m/s, α in rad)
TiltSchedule = Callable[[float], tuple[float, float, float]]

def tilt_schedule_polynomial(coefficients: ArrayLike,
                             speed_range: tuple[float, float] = (0.0, 33.99)) -> TiltSchedule:
    """Tilt-angle reference α(U_b) from a polynomial in forward air speed.

    U is clamped to ``speed_range`` (derivatives are zero outside it), as in the mission data
    file's trim-derived schedule.

    Parameters
    ----------
    coefficients : sequence of float
        Polynomial coefficients, highest power first.
    speed_range : tuple of 2 floats, default (0.0, 33.99)
        Range of U (m/s) where the polynomial applies.

    Returns
    -------
    callable
        ``f(U) -> (α, dα/dU, d²α/dU²)``.
    """
    c = np.asarray(coefficients, dtype=float)
    if c.ndim != 1 or c.size < 1:
        raise ValueError("coefficients must be a non-empty 1-D sequence (highest power first)")
    d1, d2 = np.polyder(c, 1), np.polyder(c, 2)
    lo, hi = speed_range

    def schedule(U):
        inside = lo <= U <= hi
        Uc = min(max(U, lo), hi)
        if not inside:
            return float(np.polyval(c, Uc)), 0.0, 0.0
        return float(np.polyval(c, Uc)), float(np.polyval(d1, Uc)), float(np.polyval(d2, Uc))

    # the same evaluation (np.polyval's Horner loop from 0) in native/fused.c
    schedule.compiled_form = {"schedule": 1, "poly": c.tolist(),
                              "poly_d1": np.atleast_1d(d1).astype(float).tolist(),
                              "poly_d2": np.atleast_1d(d2).astype(float).tolist(),
                              "lo": float(lo), "hi": float(hi)}
    return schedule


def forward_air_speed(vel_ref: Sequence[float] | np.ndarray, acc_ref: Sequence[float] | np.ndarray, psi: float, psidot: float,
                      wind: Sequence[float] | np.ndarray) -> tuple[float, float]:
    """Forward air speed U_b of the *reference* motion in the heading frame and its rate.

    U_b = [cos ψ, sin ψ]·(ṗ_r − ζ)_xy with the measured wind ζ taken constant over a sample;
    using the reference (not the measured velocity) keeps α_r smooth with known derivatives.

    Parameters
    ----------
    vel_ref, acc_ref, wind : sequence of float
        Reference velocity and acceleration, measured wind (x, y first).
    psi, psidot : float
        Heading reference and its rate.

    Returns
    -------
    U, Udot : float
        Forward air speed and its rate.
    """
    psi, psidot = float(psi), float(psidot)
    c, s = math.cos(psi), math.sin(psi)
    vx, vy = float(vel_ref[0]) - float(wind[0]), float(vel_ref[1]) - float(wind[1])
    U = c * vx + s * vy
    Udot = c * float(acc_ref[0]) + s * float(acc_ref[1]) + psidot * (-s * vx + c * vy)
    return U, Udot


def regulated_reference(schedule: TiltSchedule, vel_ref: Sequence[float] | np.ndarray, acc_ref: Sequence[float] | np.ndarray,
                        psi_ref: Sequence[float] | np.ndarray, wind: Sequence[float] | np.ndarray
                        ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """(q_rr, q̇_rr, q̈_rr) of the regulated DOF [αR αL ψ] (tilt from the trim schedule).

    q̈ of the tilt uses α''U̇² (the jerk term α'Ü is dropped: the mission references are
    piecewise constant-acceleration).

    Parameters
    ----------
    schedule : callable
        ``U -> (α, α', α'')`` tilt schedule.
    vel_ref, acc_ref, wind : sequence of float
        Reference velocity and acceleration, measured wind (x, y first).
    psi_ref : sequence of 3 floats
        (ψ_r, ψ̇_r, ψ̈_r) from the mission.

    Returns
    -------
    tuple of 3 ndarrays, shape (3,)
        (q_rr, q̇_rr, q̈_rr) of [αR αL ψ].
    """
    a, qd_a, qdd_a, psi, psid, psidd = regulated_values(schedule, vel_ref, acc_ref, psi_ref, wind)
    return (np.array([a, a, psi]), np.array([qd_a, qd_a, psid]), np.array([qdd_a, qdd_a, psidd]))


def regulated_values(schedule: TiltSchedule, vel_ref: Sequence[float] | np.ndarray,
                     acc_ref: Sequence[float] | np.ndarray, psi_ref: Sequence[float] | np.ndarray,
                     wind: Sequence[float] | np.ndarray) -> tuple[float, ...]:
    """(α, α̇, α̈, ψ, ψ̇, ψ̈) as floats: the one implementation behind
    :func:`regulated_reference` (as arrays) and the law's per-sample step (as floats).

    Parameters
    ----------
    schedule, vel_ref, acc_ref, psi_ref, wind
        As in :func:`regulated_reference`.

    Returns
    -------
    tuple of 6 floats
        Tilt reference α and its first two time derivatives, heading ψ and its derivatives.

    Examples
    --------
    >>> sched = tilt_schedule_polynomial([0.01, 0.0])          # α = 0.01 U
    >>> regulated_values(sched, [10.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0] * 3)
    (0.1, 0.01, 0.0, 0.0, 0.0, 0.0)
    """
    psi, psid, psidd = (float(v) for v in psi_ref)
    U, Udot = forward_air_speed(vel_ref, acc_ref, psi, psid, wind)
    a, da, dda = schedule(U)
    return a, da * Udot, dda * Udot**2, psi, psid, psidd


def tracked_reference(ref_c: Sequence[ArrayLike], ref_r: Sequence[ArrayLike]) -> np.ndarray:
    """Stack (q, q̇, q̈) of [x y z] and [αR αL ψ] in the tracked order of the partition (7.63)
    (``tiltrotor.controller.PARTITION``).

    Parameters
    ----------
    ref_c, ref_r : tuple of 3 arrays, shape (3,)
        (q, q̇, q̈) references of [x y z] and of [αR αL ψ].

    Returns
    -------
    ndarray, shape (18,)
        The stacked reference of ``MechanicalLaw``.
    """
    return np.concatenate([np.concatenate([c, r]) for c, r in zip(ref_c, ref_r)])
