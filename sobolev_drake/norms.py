"""Weighted Sobolev norms and the performance indices of the thesis tables, on logged signals.

All functions take a time vector ``t`` (strictly increasing, possibly non-uniform, e.g. the
sample times of a Drake ``VectorLogSink`` driven by an error-controlled integrator) and signals
sampled at those times, shaped ``(N,)`` (one channel) or ``(N, p)`` (p channels).

Integrals use the trapezoid rule on the given (non-uniform) grid.  Derivatives of logged signals
should be supplied from the model whenever possible (e.g. q̈ from the plant's state
derivatives, or the error ė = q̇ − q̇_r which is logged anyway); otherwise they are computed by
the second-order finite difference of :func:`numpy.gradient` with ``edge_order=2`` on the
non-uniform grid (repeated for higher orders).  On a smooth signal sampled with step h the
relative error of the resulting norm is O(h²) (see ``tests/test_norms.py`` for measured values).

Indices
-------
* :func:`sobolev_norm`   ‖z‖_{W^{m,2,σ}} of (3.4) with p = 2:
  ‖z‖² = Σ_{α=0..m} ∫ (d^α z/dt^α)ᵀ σ_α (d^α z/dt^α) dt.
* :func:`ise`            ∫ e² dt per channel (integral of the square error).
* :func:`iae`            ∫ |e| dt per channel.
* :func:`iadu`           ∫ |du/dt| dt per channel = total variation of u.  Computed as
  Σ_k |u_{k+1} − u_k|, which is *exact* for the piecewise-linear interpolant of the samples and
  needs no derivative estimate (a finite-difference du/dt followed by a quadrature would smear
  steps and add noise).  Note that the total variation of a sampled signal is a lower bound of
  the variation of the continuous signal and converges to it as the logging rate grows.
* :func:`l2_norm`        ‖w‖_{L2} = (∫ wᵀw dt)^{1/2}.
* :func:`empirical_gain` ‖z‖_{W}/‖w‖_{L2}, the quantity bounded by γ in the W∞ theorems
  (up to the initial-condition term 2V(x0)).
"""

from __future__ import annotations

import math
import numbers
from typing import Sequence

import numpy as np
from numpy.typing import ArrayLike

from sobolev_drake.validation import (bounds_pair, describe, one_of, positive_scalar, real_array,
                                      real_scalar, real_vector, sequence)

__all__ = [
    "check_time",
    "finite_difference",
    "trapezoid",
    "sobolev_norm",
    "sobolev_norm_terms",
    "ise",
    "iae",
    "iadu",
    "l2_norm",
    "empirical_gain",
    "settling_time",
    "fraction_at_bounds",
]


def check_time(t: ArrayLike) -> np.ndarray:
    """Return ``t`` as a float vector after checking it is 1-D, finite, strictly increasing.

    Parameters
    ----------
    t : array_like, shape (N,)
        Sample times; at least 2.

    Returns
    -------
    ndarray, shape (N,)
        ``t`` as floats.

    Raises
    ------
    ValueError
        If ``t`` is not 1-D, has fewer than 2 samples, is not finite or not strictly
        increasing.
    """
    t = real_array("t", t)
    if t.ndim != 1:
        raise ValueError(f"t must be a 1-D array of sample times, got shape {t.shape}")
    if t.size < 2:
        raise ValueError(f"t needs at least 2 samples, got {t.size}")
    if not np.all(np.isfinite(t)):
        raise ValueError("t must be finite")
    dt = np.diff(t)
    if np.any(dt <= 0):
        k = int(np.argmax(dt <= 0))
        raise ValueError(f"t must be strictly increasing; t[{k}] = {t[k]!r} >= t[{k + 1}] = {t[k + 1]!r}")
    return t


def _signal(name: str, z, n: int) -> tuple[np.ndarray, bool]:
    """Return (z as (N, p) float array, was_1d) after checking its length against t."""
    z = real_array(name, z)
    was_1d = z.ndim == 1
    if was_1d:
        z = z[:, None]
    if z.ndim != 2:
        raise ValueError(f"{name} must have shape (N,) or (N, p), got {z.shape}")
    if z.shape[0] != n:
        if z.shape[1] == n and z.shape[0] != n:
            raise ValueError(f"{name} has shape {z.shape} but t has {n} samples; "
                             f"signals are (N, p) with time along axis 0 (transpose Drake's log data)")
        raise ValueError(f"{name} has {z.shape[0]} samples but t has {n}")
    if z.shape[1] == 0:
        raise ValueError(f"{name} must have at least one channel, got shape {z.shape}")
    if not np.all(np.isfinite(z)):
        raise ValueError(f"{name} must be finite")
    return z, was_1d


def trapezoid(t: ArrayLike, y: ArrayLike) -> np.ndarray | float:
    """∫ y dt by the trapezoid rule on the (non-uniform) grid ``t``; per channel for 2-D ``y``.

    Parameters
    ----------
    t : array_like, shape (N,)
        Strictly increasing sample times.
    y : array_like, shape (N,) or (N, p)
        Signal sampled at ``t``.

    Returns
    -------
    float or ndarray, shape (p,)
        The integral (a float for 1-D ``y``, one value per channel otherwise).
    """
    t = check_time(t)
    y2, was_1d = _signal("y", y, t.size)
    out = np.trapezoid(y2, t, axis=0)
    return float(out[0]) if was_1d else out


def finite_difference(t: ArrayLike, z: ArrayLike, order: int = 1) -> np.ndarray:
    """d^order z / dt^order by repeated second-order ``numpy.gradient`` (edge_order=2).

    Second order in the interior and at the ends on non-uniform grids.  Each repetition loses
    accuracy near discontinuities; prefer derivatives from the model.

    Parameters
    ----------
    t : array_like, shape (N,)
        Strictly increasing sample times (at least 3 when ``order > 0``).
    z : array_like, shape (N,) or (N, p)
        Signal sampled at ``t``.
    order : int, default 1
        Derivative order (non-negative; 0 returns ``z`` as floats).

    Returns
    -------
    ndarray
        The derivative, shaped like ``z``.
    """
    t = check_time(t)
    if not isinstance(order, numbers.Real):
        raise TypeError(f"order must be a non-negative integer, got {describe(order)} "
                        f"({type(order).__name__})")
    if isinstance(order, (bool, np.bool_)) or not math.isfinite(order) or int(order) != order \
            or order < 0:
        raise ValueError(f"order must be a non-negative integer, got {order!r}")
    z2, was_1d = _signal("z", z, t.size)
    if order > 0 and t.size < 3:
        raise ValueError("finite differences need at least 3 samples")
    d = z2
    for _ in range(int(order)):
        d = np.gradient(d, t, axis=0, edge_order=2)
    return d[:, 0] if was_1d else d


def _weight(name: str, sigma, p: int) -> np.ndarray:
    """σ as a (p, p) symmetric PSD matrix from a scalar, a length-p diagonal, or a matrix."""
    s = real_array(name, sigma)
    if s.ndim == 0:
        W = float(s) * np.eye(p)
    elif s.ndim == 1:
        if s.size != p:
            raise ValueError(f"{name} as a diagonal must have {p} entries, got {s.size}")
        W = np.diag(s)
    elif s.shape == (p, p):
        W = s
    else:
        raise ValueError(f"{name} must be a scalar, a length-{p} vector or a {p}x{p} matrix, got shape {s.shape}")
    if not np.all(np.isfinite(W)):
        raise ValueError(f"{name} must be finite, got {describe(sigma)}")
    if not np.allclose(W, W.T, atol=1e-12 * max(1.0, np.abs(W).max())):
        raise ValueError(f"{name} must be symmetric, got {describe(sigma)}")
    if np.linalg.eigvalsh(W).min() < -1e-12 * max(1.0, np.abs(W).max()):
        raise ValueError(f"{name} must be positive semidefinite, got {describe(sigma)}")
    return W


def sobolev_norm_terms(t: ArrayLike, z: ArrayLike, sigmas: Sequence,
                       derivatives: Sequence | None = None) -> np.ndarray:
    """The m+1 terms ∫ (d^α z)ᵀ σ_α (d^α z) dt, α = 0..m, of the squared norm (3.4).

    Parameters
    ----------
    t : array_like, shape (N,)
        Strictly increasing sample times.
    z : array_like, shape (N,) or (N, p)
        Signal sampled at ``t``.
    sigmas : sequence
        σ_0..σ_m; each a scalar (σ I), a length-p vector (diagonal) or a (p, p) positive
        semidefinite matrix.  ``len(sigmas) - 1`` is the order m.
    derivatives : sequence or None, optional
        The m derivatives d^α z/dt^α, α = 1..m, each shaped like ``z`` (preferred: from the
        model).  ``None`` entries (or ``derivatives=None``) are computed by
        :func:`finite_difference`.

    Returns
    -------
    ndarray, shape (m + 1,)
        The terms, α = 0..m; their sum is ‖z‖²_{W^{m,2,σ}}.
    """
    return _norm_terms(t, z, sigmas, derivatives)


def _norm_terms(t, z, sigmas, derivatives, *, z_name="z", sigma_names=None):
    """:func:`sobolev_norm_terms` with the argument names of the caller (for the messages)."""
    t = check_time(t)
    z2, _ = _signal(z_name, z, t.size)
    p = z2.shape[1]
    if isinstance(sigmas, (int, float, np.ndarray)) and np.ndim(sigmas) == 0:
        raise ValueError("sigmas must be a sequence (σ_0, ..., σ_m), e.g. [1.0] for the L2 norm, "
                         f"got {describe(sigmas)}")
    sigmas = sequence("sigmas", sigmas, "weights (σ_0, ..., σ_m), e.g. [1.0] for the L2 norm")
    if not sigmas:
        raise ValueError("sigmas must contain at least σ_0")
    m = len(sigmas) - 1
    derivs = [None] * m if derivatives is None else sequence(
        "derivatives", derivatives, f"the {m} derivatives of orders 1..{m} (or None)")
    if len(derivs) != m:
        raise ValueError(f"derivatives must list the {m} derivatives of orders 1..{m}, got {len(derivs)}")
    terms = np.empty(m + 1)
    for alpha in range(m + 1):
        W = _weight(f"sigmas[{alpha}]" if sigma_names is None else sigma_names[alpha],
                    sigmas[alpha], p)
        if alpha == 0:
            d = z2
        elif derivs[alpha - 1] is not None:
            d, _ = _signal(f"derivatives[{alpha - 1}]", derivs[alpha - 1], t.size)
            if d.shape[1] != p:
                raise ValueError(f"derivatives[{alpha - 1}] has {d.shape[1]} channels, z has {p}")
        else:
            d = finite_difference(t, z2, alpha)
        integrand = np.einsum("ni,ij,nj->n", d, W, d)
        terms[alpha] = np.trapezoid(integrand, t)
    return terms


def sobolev_norm(t: ArrayLike, z: ArrayLike, sigmas: Sequence, derivatives: Sequence | None = None, *,
                 squared: bool = False) -> float:
    """Weighted Sobolev norm ‖z‖_{W^{m,2,σ}} of (3.4) (p = 2) on a logged signal.

    With ``sigmas=[σ0]`` this is the weighted L2 norm.

    Parameters
    ----------
    t, z, sigmas, derivatives
        As in :func:`sobolev_norm_terms`.
    squared : bool, default False
        Return ‖z‖² instead of ‖z‖.

    Returns
    -------
    float
        ‖z‖_{W^{m,2,σ}} (or its square).

    Examples
    --------
    ‖sin‖ in W^{1,2} on [0, π] with unit weights is (∫ sin² + cos²)^{1/2} = √π:

    >>> import numpy as np
    >>> from sobolev_drake import norms
    >>> t = np.linspace(0.0, np.pi, 501)
    >>> round(norms.sobolev_norm(t, np.sin(t), [1.0, 1.0], [np.cos(t)]), 6)
    1.772454
    >>> round(norms.sobolev_norm(t, np.sin(t), [1.0, 1.0]), 3)   # ż by finite differences
    1.772
    """
    s = float(np.sum(sobolev_norm_terms(t, z, sigmas, derivatives)))
    return s if squared else float(np.sqrt(max(s, 0.0)))


def ise(t: ArrayLike, e: ArrayLike) -> float | np.ndarray:
    """Integral of the square error ∫ e(t)² dt per channel (float for 1-D ``e``).

    Parameters
    ----------
    t : array_like, shape (N,)
        Strictly increasing sample times.
    e : array_like, shape (N,) or (N, p)
        Error signal sampled at ``t``.

    Returns
    -------
    float or ndarray, shape (p,)
        The ISE (trapezoid rule), per channel.

    Examples
    --------
    >>> import numpy as np
    >>> from sobolev_drake import norms
    >>> t = np.linspace(0.0, 1.0, 1001)
    >>> round(norms.ise(t, np.sin(2 * np.pi * t)), 6)      # ∫ sin² over a period = 1/2
    0.5
    """
    return _channel_integral(t, e, np.square)


def iae(t: ArrayLike, e: ArrayLike) -> float | np.ndarray:
    """Integral of the absolute error ∫ |e(t)| dt per channel (trapezoid on the samples).

    Parameters
    ----------
    t : array_like, shape (N,)
        Strictly increasing sample times.
    e : array_like, shape (N,) or (N, p)
        Error signal sampled at ``t``.

    Returns
    -------
    float or ndarray, shape (p,)
        The IAE per channel (a float for 1-D ``e``).
    """
    return _channel_integral(t, e, np.abs)


def _channel_integral(t, e, integrand):
    """∫ integrand(e(t)) dt per channel by the trapezoid rule; a float for 1-D ``e``."""
    t = check_time(t)
    e2, was_1d = _signal("e", e, t.size)
    out = np.trapezoid(integrand(e2), t, axis=0)
    return float(out[0]) if was_1d else out


def iadu(t: ArrayLike, u: ArrayLike) -> float | np.ndarray:
    """∫ |du/dt| dt per channel, computed exactly for the sampled signal as Σ |Δu|.

    The thesis tables report the sum over channels, ``iadu(t, u).sum()``.  ``t`` is only
    checked (the total variation does not depend on the sample times).

    Parameters
    ----------
    t : array_like, shape (N,)
        Strictly increasing sample times.
    u : array_like, shape (N,) or (N, p)
        Control signal sampled at ``t``.

    Returns
    -------
    float or ndarray, shape (p,)
        Σ_k |u_{k+1} − u_k| per channel (a float for 1-D ``u``).

    Examples
    --------
    >>> import numpy as np
    >>> from sobolev_drake import norms
    >>> t = np.linspace(0.0, 1.0, 101)
    >>> u = np.where(t < 0.5, 0.0, 2.0)                      # one step of height 2
    >>> norms.iadu(t, u), norms.iadu(t, np.column_stack([u, np.sin(2 * np.pi * t)])).round(3)
    (2.0, array([2., 4.]))
    """
    t = check_time(t)
    u2, was_1d = _signal("u", u, t.size)
    out = np.sum(np.abs(np.diff(u2, axis=0)), axis=0)
    return float(out[0]) if was_1d else out


def l2_norm(t: ArrayLike, w: ArrayLike, sigma: ArrayLike = 1.0) -> float:
    """‖w‖_{L2,σ} = (∫ wᵀ σ w dt)^{1/2} over all channels.

    Parameters
    ----------
    t : array_like, shape (N,)
        Strictly increasing sample times.
    w : array_like, shape (N,) or (N, p)
        Signal sampled at ``t``.
    sigma : float, array_like (p,) or (p, p), default 1.0
        Weight σ: a scalar (σ I), a diagonal or a positive semidefinite matrix.

    Returns
    -------
    float
        The weighted L2 norm.
    """
    return _l2_norm(t, w, sigma, "sigma")


def _l2_norm(t, w, sigma, sigma_name):
    s = float(np.sum(_norm_terms(t, w, [sigma], None, z_name="w", sigma_names=[sigma_name])))
    return float(np.sqrt(max(s, 0.0)))


def empirical_gain(t: ArrayLike, z: ArrayLike, w: ArrayLike, sigmas: Sequence = (1.0,),
                   derivatives: Sequence | None = None, *, w_sigma: ArrayLike = 1.0,
                   initial_term: float = 0.0) -> float:
    """Empirical gain ‖z‖_{W^{m,2,σ}} / ‖w‖_{L2} of a simulated run.

    ``initial_term`` (e.g. 2V(x0)) is subtracted from ‖z‖² before the square root, so the
    result can be compared directly with γ of the dissipation inequality
    ‖z‖²_W ≤ γ²‖w‖² + 2V(x0).  Raises ``ValueError`` if ‖w‖ = 0 (gain undefined).

    Parameters
    ----------
    t : array_like, shape (N,)
        Strictly increasing sample times.
    z : array_like, shape (N,) or (N, p)
        Performance signal.
    w : array_like, shape (N,) or (N, q)
        Disturbance signal.
    sigmas : sequence, default (1.0,)
        Weights σ_0..σ_m of ‖z‖_W (see :func:`sobolev_norm_terms`).
    derivatives : sequence or None, optional
        Derivatives of ``z`` of orders 1..m (see :func:`sobolev_norm_terms`).
    w_sigma : float or array_like, default 1.0
        Weight of ‖w‖_{L2,σ} (see :func:`l2_norm`).
    initial_term : float, default 0.0
        Non-negative term subtracted from ‖z‖²_W (negative differences are clipped to 0).

    Returns
    -------
    float
        (max(‖z‖²_W − initial_term, 0))^{1/2} / ‖w‖_{L2,σ}.

    Examples
    --------
    >>> import numpy as np
    >>> from sobolev_drake import norms
    >>> t = np.linspace(0.0, 1.0, 201)
    >>> w = np.sin(2 * np.pi * t)
    >>> round(norms.empirical_gain(t, 2.0 * w, w), 6)         # z = 2 w: gain 2
    2.0
    """
    t = check_time(t)
    initial_term = real_scalar("initial_term", initial_term, low=0.0)
    nz2 = sobolev_norm(t, z, sigmas, derivatives, squared=True) - initial_term
    nw = _l2_norm(t, w, w_sigma, "w_sigma")
    if nw <= 0.0:
        raise ValueError("w has zero L2 norm: the empirical gain is undefined")
    return float(np.sqrt(max(nz2, 0.0)) / nw)


SETTLING_CROSSINGS = ("interpolated", "next_sample")


def settling_time(t: ArrayLike, y: ArrayLike, *, fraction: float, reference: float | None = None,
                  until: float | None = None, crossing: str = "interpolated") -> float:
    """Time after which |y| stays within ``fraction`` × ``reference``.

    Parameters
    ----------
    t : array_like, shape (N,)
        Strictly increasing sample times.
    y : array_like, shape (N,)
        The signal, e.g. an angle converging to 0.
    fraction : float
        Band half-width relative to ``reference`` (0.02 for the 2 % criterion).
    reference : float, optional
        Scale of the band; ``|y(t[0])|`` by default.
    until : float, optional
        Only samples with t ≤ ``until`` count (e.g. before a disturbance starts).
    crossing : {"interpolated", "next_sample"}
        How the last exit from the band is timed: the linear interpolation of the crossing
        between the last sample outside and the next one, or the time of the next sample
        (the first sample back inside).

    Returns
    -------
    float
        The settling time; ``t[0]`` if |y| is never outside the band, the last time considered
        if it never returns inside.
    """
    t = check_time(t)
    y = real_vector("y", y, t.size)
    fraction = positive_scalar("fraction", fraction)
    one_of("crossing", crossing, SETTLING_CROSSINGS)
    scale = abs(y[0]) if reference is None else abs(real_scalar("reference", reference))
    if until is not None:
        keep = t <= real_scalar("until", until)
        t, y = t[keep], y[keep]
    excess = np.abs(y) - fraction * scale
    outside = np.flatnonzero(excess > 0)
    if not outside.size:
        return float(t[0]) if t.size else 0.0
    k = outside[-1]
    if k + 1 >= t.size:
        return float(t[k])
    if crossing == "next_sample":
        return float(t[k + 1])
    return float(t[k] + (t[k + 1] - t[k]) * excess[k] / (excess[k] - excess[k + 1]))


def fraction_at_bounds(u: ArrayLike, lo: ArrayLike, hi: ArrayLike, *, rtol: float = 1e-6) -> float:
    """Share of samples at which some input is on (or beyond) a bound of the box [lo, hi].

    "On" means within ``rtol`` × max(|lo|, |hi|) of it: a saturated actuator, or a command the
    actuator cannot produce.

    Parameters
    ----------
    u : array_like
        (N,) or (N, m) logged inputs, one row per sample.
    lo, hi : float or array_like
        Lower and upper bounds (broadcast over the columns).
    rtol : float
        Relative closeness to a bound that counts as "on" it.

    Returns
    -------
    float
        In [0, 1].
    """
    u = real_array("u", u)
    u = u[:, None] if u.ndim == 1 else u
    if u.ndim != 2 or u.shape[0] == 0:
        raise ValueError(f"u must have shape (N,) or (N, m) with N >= 1 samples, got {u.shape}")
    lo, hi = bounds_pair("lo", lo, "hi", hi, u.shape[1])
    rtol = real_scalar("rtol", rtol, low=0.0)
    tol = rtol * np.maximum(np.abs(lo), np.abs(hi))
    return float(np.mean(np.any((u <= lo + tol) | (u >= hi - tol), axis=1)))
