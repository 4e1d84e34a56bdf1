"""Per-sample helpers of the tilt-rotor W∞ law: the cheap finite-vector check and the
actuator saturation flags (re-exported by :mod:`sobolev_drake.tiltrotor.controller`)."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sobolev_drake.models.base import check_vector
from sobolev_drake.native import kernel

__all__ = ["checked_vector", "saturation_flags", "saturation_flag_list"]

#: actuator inputs τ̄ of the tilt-rotor (the compiled kernel's size)
N_TAU = 8


def checked_vector(name: str, value: ArrayLike, size: int) -> tuple[NDArray[np.float64], list[float]]:
    """A finite vector of length ``size`` as an array and as a list of floats; otherwise
    ``check_vector``'s descriptive error (the cheap form of the check, run once per sample).

    Parameters
    ----------
    name, value, size
        Argument name (for the error message), the vector and its required length.

    Returns
    -------
    tuple
        (float64 array, list of its floats).
    """
    arr = value if type(value) is np.ndarray and value.dtype == np.float64 else np.asarray(value, dtype=float)
    if arr.shape == (size,):
        lst = arr.tolist()
        # a float sum is finite only if every term is (NaN, ±inf propagate); the term-by-term
        # check decides only when the sum is not (a non-finite entry, or an overflow)
        if math.isfinite(sum(lst)) or all(map(math.isfinite, lst)):
            return arr, lst
    return check_vector(name, value, size), None        # raises


def saturation_flags(tau: ArrayLike, lo: ArrayLike, up: ArrayLike, rel_tol: float = 1e-3,
                     min_width: float = 1e-3) -> NDArray[np.float64]:
    """+1 where τ̄ sits on its upper bound, −1 on its lower bound, 0 inside (relative tolerance
    of the bound width).  A box narrower than ``min_width`` (e.g. the surfaces at low air speed,
    whose range sigmf(V) shrinks to ~0 (7.87)–(7.89)) means the actuator is switched off, not
    saturated, and counts as inside.

    The numpy form at the end is the reference (any shape); 8-vectors go to the compiled kernel
    when it is built, other vectors to the float loop, kept because ``benchmarks/speed_tiers.py``
    measures it ≈ 2.5× faster than the numpy form per sample.  All three make the same
    comparisons on the same floats, so the flags are identical (tested).

    Parameters
    ----------
    tau, lo, up : array_like
        Actuator values and their bounds (same shape).
    rel_tol : float, default 1e-3
        Tolerance relative to the bound width.
    min_width : float, default 1e-3
        Narrower boxes count as switched off.

    Returns
    -------
    ndarray
        +1, −1 or 0 per entry.
    """
    tau, lo, up = np.asarray(tau, dtype=float), np.asarray(lo, dtype=float), np.asarray(up, dtype=float)
    if tau.shape == lo.shape == up.shape == (N_TAU,):
        k = kernel("forces")
        if k is not None:                 # the same comparisons in C (per-sample path)
            return np.array(k.saturation_flags(tau, lo, up, rel_tol, min_width))
    if tau.ndim == 1 and tau.shape == lo.shape == up.shape:     # plain floats: per-sample path
        out = []
        for t, lw, uw in zip(tau.tolist(), lo.tolist(), up.tolist()):
            w = uw - lw
            if w > min_width:                    # then max(w, 0) = w
                tol = rel_tol * w
                out.append(1.0 if t >= uw - tol else (-1.0 if t <= lw + tol else 0.0))
            else:
                out.append(0.0)
        return np.array(out)
    tol = rel_tol * np.maximum(up - lo, 0.0)
    width_ok = (up - lo) > min_width
    return np.where(width_ok & (tau >= up - tol), 1.0,
                    np.where(width_ok & (tau <= lo + tol), -1.0, 0.0))


def saturation_flag_list(tau: ArrayLike, lo: ArrayLike, up: ArrayLike) -> list[float]:
    """:func:`saturation_flags` with its default tolerances, as a list of floats: for 8-vectors
    the compiled kernel called directly (the controller's per-sample path; the same comparisons
    on the same floats, so the same flags — tested), else :func:`saturation_flags`.

    Parameters
    ----------
    tau, lo, up : array_like, shape (n,)
        Actuator values and their bounds (float64 arrays are read without a copy).

    Returns
    -------
    list of float
        +1.0, −1.0 or 0.0 per entry.

    Examples
    --------
    >>> saturation_flag_list([1.0, 0.0, -1.0], [-1.0, -1.0, -1.0], [1.0, 1.0, 1.0])
    [1.0, 0.0, -1.0]
    """
    k = kernel("forces")
    if k is not None and len(tau) == len(lo) == len(up) == N_TAU:
        return k.saturation_flags(tau, lo, up, 1e-3, 1e-3)
    return saturation_flags(tau, lo, up).tolist()
