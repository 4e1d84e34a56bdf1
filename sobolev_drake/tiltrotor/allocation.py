"""Control allocation (thesis (7.84)–(7.89)) and thrust → propeller-speed inversion (7.90).

* :func:`bounded_least_squares` — min ‖u − Bτ̄‖² s.t. lo ≤ τ̄ ≤ hi (7.84)–(7.86), solved by a
  primal–dual active-set method (fallbacks: primal active set, scipy BVLS) on the small box QP.
  Chosen by measurement (``benchmarks/allocation.py``): it matches a tight Clarabel reference
  to ~1e-9, is faster than scipy ``lsq_linear`` (bvls/trf), OSQP and Clarabel called directly,
  and warm-started from the previous active set needs a single linear solve.  Raw Drake OSQP
  is faster cold (~2×) but returns no exact active-set solution; ``method="osqp"`` uses it
  followed by the exact re-solve and KKT check.
* :func:`tiltrotor_bounds` — thrust 0–100 N, servo torque ±2 N m, surfaces
  ±(5π/36)·sigmf(V_air; s = 2, c = 12) (7.87)–(7.89) (``tiltrotor_missions.json``).
* :class:`ControlAllocator` — LeafSystem wrapping the two.
* :func:`propeller_speed_for_thrust` — solve f = ρd⁴n²Ct(J, φ), J = V_xz/(n d) for n (7.90);
  :func:`rotor_inflow` gives (V_xz, φ) from the rotor-frame air-relative velocity.

The bounded least-squares solver lives in :mod:`sobolev_drake.systems.bounded_ls` (rank
deficiency handling described there) and is re-exported here.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import LeafSystem, ValueProducer

from sobolev_drake.data import load
from sobolev_drake.errors import ModelError
from sobolev_drake.native import kernel
from sobolev_drake.systems.bounded_ls import check_problem, bounded_least_squares
from sobolev_drake.tiltrotor.scalars import DoubleOnly
from sobolev_drake.validation import bounds_pair, one_of, real_scalar

if TYPE_CHECKING:
    from pydrake.systems.framework import Context

    from sobolev_drake.tiltrotor.propeller import PropellerCoefficients

__all__ = [
    "sigmf", "tiltrotor_bounds", "ControlAllocator", "UnreachableThrustError", "rotor_inflow",
    "propeller_speed_for_thrust", "bounded_least_squares", "thesis_bounds_constants",
]

# --------------------------------------------------------------------------------------------
# tilt-rotor bounds (7.85)–(7.89)
# --------------------------------------------------------------------------------------------


def sigmf(v: ArrayLike, s: float = 2.0, c: float = 12.0) -> NDArray[np.float64]:
    """Sigmoid 1 / (1 + exp(−s(v − c))) (7.89), overflow-safe, vectorized.

    Parameters
    ----------
    v : float or array_like
        Relative airspeed V_air (m/s) of the surface.
    s : float, default 2.0
        Slope of the sigmoid (s/m).
    c : float, default 12.0
        Airspeed (m/s) at which the sigmoid is ½.

    Returns
    -------
    ndarray
        sigmf(v; s, c) in [0, 1], shape of ``v``: the fraction of the full deflection range
        ±δ_max the control surfaces get at that airspeed (7.89).
    """
    v = np.asarray(v, dtype=float)
    z = -s * (v - c)
    return np.where(z >= 0, np.exp(-np.abs(z)) / (1.0 + np.exp(-np.abs(z))), 1.0 / (1.0 + np.exp(-np.abs(z))))


_THESIS_LIMITS: dict = {}


def _thesis_limits() -> dict:
    """``controller_limits_thesis`` of ``tiltrotor_missions.json`` (parsed once per process)."""
    if not _THESIS_LIMITS:
        _THESIS_LIMITS.update(load("tiltrotor_missions")["controller_limits_thesis"])
    return _THESIS_LIMITS


def thesis_bounds_constants() -> tuple[float, float, float, float, float, float, float, float]:
    """(s, c, f_lo, f_hi, t_lo, t_hi, δ_lo, δ_hi) of the thesis limits, parsed once.

    Returns
    -------
    tuple of float
        From ``controller_limits_thesis`` of ``tiltrotor_missions.json`` (7.85)–(7.89): the
        sigmoid slope s (s/m) and centre c (m/s), the thrust bounds f_lo, f_hi (N), the servo
        torque bounds t_lo, t_hi (N m) and the full surface deflection bounds δ_lo, δ_hi
        (rad).
    """
    if "_parsed" not in _THESIS_LIMITS:
        _thesis_limits()
        _THESIS_LIMITS["_parsed"] = _parse_limits(_THESIS_LIMITS)
    return _THESIS_LIMITS["_parsed"]


def tiltrotor_bounds(v_air: ArrayLike, *, limits: dict | None = None
                     ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(lo, hi) of τ̄ = [fPR fPL τsR τsL δWR δWL δTR δTL] (7.85)–(7.89).

    ``v_air`` : relative airspeed magnitude V_air (m/s), a scalar used for all four surfaces or
    a 4-vector [V_WR, V_WL, V_TR, V_TL] (thesis: one V_air per surface A; a size-1 array counts
    as a scalar).  ``limits`` defaults
    to ``controller_limits_thesis`` of ``tiltrotor_missions.json`` (thrust [0, 100] N, servo
    [−2, 2] N m, δ ∈ ±5π/36 rad, s = 2, c = 12 m/s).  Below ≈ 8 m/s the surface range is
    < 0.03 % of δ_max: the surfaces are effectively removed from the allocation.

    Parameters
    ----------
    v_air : float or array_like, shape (4,)
        Relative airspeed V_air (m/s, ≥ 0): one value for all four surfaces, or
        [V_WR, V_WL, V_TR, V_TL].
    limits : dict, optional
        Limits in the layout of ``controller_limits_thesis`` (keys ``thrust_N``,
        ``servo_torque_Nm``, ``surface_deflection_rad`` as [lower, upper] pairs,
        ``sigmoid_s``, ``sigmoid_c_m_s``); default the thesis values.

    Returns
    -------
    lo, hi : ndarray, shape (8,)
        Lower and upper bounds of τ̄: thrusts (N), servo torques (N m), then the surface
        deflections (rad) scaled by sigmf(V_air) (7.89).
    """
    if limits is None:
        s, c, f_lo, f_hi, t_lo, t_hi, d_lo, d_hi = thesis_bounds_constants()
    else:
        s, c, f_lo, f_hi, t_lo, t_hi, d_lo, d_hi = _parse_limits(limits)
    v = np.asarray(v_air, dtype=float)
    if v.size == 1:  # scalar or a size-1 port value: the same airspeed for all surfaces
        v = np.full(4, float(v.ravel()[0]))
    if v.shape != (4,):
        raise ValueError(f"v_air must be a non-negative scalar or a 4-vector [WR, WL, TR, TL], got {v_air!r}")
    k = kernel("forces")
    if k is not None:             # the same floats in C (the controller calls this per sample)
        try:
            lo, hi = k.surface_bounds(v, s, c, f_lo, f_hi, t_lo, t_hi, d_lo, d_hi)
        except ValueError:
            raise ValueError("v_air must be a non-negative scalar or a 4-vector [WR, WL, TR, TL], "
                             f"got {v_air!r}") from None
        return np.array(lo), np.array(hi)
    # sigmf (7.89) per surface in plain floats (same overflow-safe form as :func:`sigmf`)
    lo, hi = [f_lo, f_lo, t_lo, t_lo], [f_hi, f_hi, t_hi, t_hi]
    for x in v.tolist():
        if not (x >= 0 and math.isfinite(x)):
            raise ValueError(f"v_air must be a non-negative scalar or a 4-vector [WR, WL, TR, TL], got {v_air!r}")
        z = -s * (x - c)
        e = math.exp(-abs(z))
        g = e / (1.0 + e) if z >= 0 else 1.0 / (1.0 + e)
        lo.append(d_lo * g)
        hi.append(d_hi * g)
    return np.array(lo), np.array(hi)


def _parse_limits(lim):
    pairs = []
    for key in ("thrust_N", "servo_torque_Nm", "surface_deflection_rad"):
        lo, hi = bounds_pair(f"limits[{key!r}] lower", lim[key][0], f"limits[{key!r}] upper", lim[key][1], 1)
        pairs.append((lo[0], hi[0]))
    (f_lo, f_hi), (t_lo, t_hi), (d_lo, d_hi) = pairs
    return tuple(float(x) for x in (lim["sigmoid_s"], lim["sigmoid_c_m_s"], f_lo, f_hi, t_lo, t_hi,
                                    d_lo, d_hi))


# --------------------------------------------------------------------------------------------
# LeafSystem
# --------------------------------------------------------------------------------------------


class ControlAllocator(DoubleOnly, LeafSystem):
    """Bounded least-squares allocation (7.84) as a LeafSystem.

    Inputs: ``u_star`` (n) — desired generalized input; ``B`` (n·m) — input matrix flattened
    **row-major** (``B.ravel()`` / ``B.reshape(n, m)``); then, depending on ``bounds``:

    * callable ``bounds(airspeed) -> (lo, hi)`` → input ``airspeed`` (size ``airspeed_size``),
      e.g. :func:`tiltrotor_bounds` (the default, n = m = 8);
    * ``"input"`` → input ``bounds`` (2m) = [lo; hi];
    * a pair (lo, hi) of constant vectors → no further input.

    Outputs: ``tau`` (m) and ``residual`` (1) = ‖u* − Bτ̄‖, both from one cached solve.
    The outputs depend on the inputs (direct feedthrough).  ``regularization`` and ``method``
    are passed to :func:`bounded_least_squares`.

    .. pydrake_system::

        name: ControlAllocator
        input_ports:
        - u_star
        - B
        - airspeed (with callable bounds)
        - bounds (with bounds="input")
        output_ports:
        - tau
        - residual

    Double only: ``ToAutoDiffXd()`` and ``ToSymbolic()`` raise (:class:`DoubleOnly`), and a
    diagram holding the allocator does not convert either.  The active-set solution is
    piecewise in (u*, B, bounds) and not differentiable where a bound becomes active or
    inactive; to linearize or run LQR on a loop, put the unbounded allocation in its place
    (``MatrixGain(np.linalg.pinv(B))``, which it equals while no bound is active) or
    differentiate the plant at its actuator inputs.

    Parameters
    ----------
    n : int, default 8
        Size of the desired generalized input u* (rows of B; 8 generalized coordinates).
    m : int, default 8
        Number of actuator inputs τ̄ (columns of B; 8 = ``ACTUATOR_NAMES``).
    bounds : callable, "input" or (lo, hi), default tiltrotor_bounds
        Actuator bounds: ``bounds(airspeed) -> (lo, hi)`` fed by the ``airspeed`` port, the
        ``bounds`` input port, or a constant pair of length-m vectors (units of τ̄).
    airspeed_size : int, default 1
        Size of the ``airspeed`` port (m/s) when ``bounds`` is callable (1, or 4 for one
        airspeed per surface with :func:`tiltrotor_bounds`).
    regularization : float, default 1e-12
        Relative Tikhonov weight ε (≥ 0) of :func:`bounded_least_squares`.
    method : {"pdas", "osqp"}, default "pdas"
        Solver of :func:`bounded_least_squares`.
    """

    def __init__(self, n: int = 8, m: int = 8,
                 bounds: Callable[[np.ndarray], tuple[ArrayLike, ArrayLike]] | str
                 | tuple[ArrayLike, ArrayLike] = tiltrotor_bounds, *, airspeed_size: int = 1,
                 regularization: float = 1e-12, method: str = "pdas") -> None:
        super().__init__()
        one_of("method", method, ("pdas", "osqp"))
        real_scalar("regularization", regularization, low=0.0)
        self._method, self._last_active = method, None
        for name, val in (("n", n), ("m", m), ("airspeed_size", airspeed_size)):
            if not isinstance(val, (int, np.integer)) or val < 1:
                raise ValueError(f"{name} must be a positive integer, got {val!r}")
        self._n, self._m, self._reg = int(n), int(m), float(regularization)
        self._u = self.DeclareVectorInputPort("u_star", self._n)
        self._B = self.DeclareVectorInputPort("B", self._n * self._m)
        self._bounds_fn, self._const = None, None
        if callable(bounds):
            self._bounds_fn = bounds
            self._air = self.DeclareVectorInputPort("airspeed", int(airspeed_size))
        elif isinstance(bounds, str) and bounds == "input":
            self._bnd = self.DeclareVectorInputPort("bounds", 2 * self._m)
        else:
            try:
                lo, hi = bounds
            except (TypeError, ValueError):
                raise ValueError("bounds must be a callable bounds(airspeed) -> (lo, hi), "
                                 "'input', or a pair (lo, hi) of length-m vectors") from None
            self._const = check_problem(np.zeros((1, self._m)), np.zeros(1), lo, hi)[2:]
        self._cache = self.DeclareCacheEntry(
            "allocation", ValueProducer(allocate=lambda: AbstractValue.Make(np.zeros(self._m + 1)),
                                        calc=self._solve),
            prerequisites_of_calc={self.all_input_ports_ticket()})
        self.DeclareVectorOutputPort("tau", self._m, self._calc_tau,
                                     prerequisites_of_calc={self._cache.ticket()})
        self.DeclareVectorOutputPort("residual", 1, self._calc_residual,
                                     prerequisites_of_calc={self._cache.ticket()})

    conversion_refusal = (
        "the bounded least-squares allocation (7.84) is an active-set solution, piecewise in u*, "
        "B and the bounds and not differentiable where a bound becomes active; in the diagram to "
        "linearize (Linearize, LinearQuadraticRegulator), use the unbounded allocation "
        "MatrixGain(np.linalg.pinv(B)) (equal while no bound is active) or the plant's actuator "
        "inputs instead")

    def bounds(self, context: Context) -> tuple[np.ndarray, np.ndarray]:
        """(lo, hi) used in ``context``.

        Parameters
        ----------
        context : Context
            This system's context (the ``airspeed`` or ``bounds`` port is read if declared).

        Returns
        -------
        lo, hi : ndarray, shape (m,)
            Lower and upper bounds of τ̄ (units of τ̄: N, N m, rad for the tilt-rotor).
        """
        if self._bounds_fn is not None:
            lo, hi = self._bounds_fn(self._air.Eval(context))
            return np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
        if self._const is not None:
            return self._const
        v = self._bnd.Eval(context)
        return v[:self._m], v[self._m:]

    def _solve(self, context, abstract_value):
        B = self._B.Eval(context).reshape(self._n, self._m)
        lo, hi = self.bounds(context)
        # The previous active set warm-starts the solver: it changes speed, not the result.
        tau, info = bounded_least_squares(B, self._u.Eval(context), lo, hi, regularization=self._reg,
                                          warm_start=self._last_active, method=self._method,
                                          return_info=True)
        self._last_active = info["active"]
        abstract_value.set_value(np.concatenate([tau, [info["residual"]]]))

    def _calc_tau(self, context, output):
        output.SetFromVector(self._cache.Eval(context)[:self._m])

    def _calc_residual(self, context, output):
        output.SetFromVector(self._cache.Eval(context)[self._m:])


# --------------------------------------------------------------------------------------------
# thrust → propeller speed (7.90)
# --------------------------------------------------------------------------------------------


class UnreachableThrustError(ModelError, ValueError):
    """The requested thrust is outside [0, f(n_max)] for the given inflow."""


def _thrust(coef, n, v_xz, phi):
    """ρ d⁴ n² Ct(J, φ) with J = clip(V_xz/(n d), 0, J_max); 0 at n = 0."""
    d = coef.diameter
    with np.errstate(divide="ignore", invalid="ignore"):
        J = np.where(n > 0, v_xz / np.where(n > 0, n * d, 1.0), coef.J_max)
    J = np.clip(J, 0.0, coef.J_max)
    return coef.rho * d ** 4 * n ** 2 * coef.ct(J, phi)


def rotor_inflow(v_rel_rotor_frame: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(V_xz, φ) of (7.90) from the rotor-frame air-relative velocity (..., 3) = (u, v, w).

    Same conventions as ``PropellerCoefficients.advance_ratio_and_inflow``: V_xz = ‖(u, w)‖,
    φ = |clip(atan2(u, w), −π/2, π/2)|.

    Parameters
    ----------
    v_rel_rotor_frame : array_like, shape (..., 3)
        Air-relative velocity (u, v, w) of the propeller hub in the rotor frame (m/s), w
        along the rotor axis.

    Returns
    -------
    v_xz : ndarray, shape (...)
        Air-relative speed in the rotor's x–z plane, ‖(u, w)‖ (m/s).
    phi : ndarray, shape (...)
        Inflow angle φ (rad, in [0, π/2]) between the rotor axis and that velocity.
    """
    v = np.asarray(v_rel_rotor_frame, dtype=float)
    if v.shape[-1:] != (3,):
        raise ValueError(f"v_rel_rotor_frame must have shape (..., 3), got {v.shape}")
    return np.hypot(v[..., 0], v[..., 2]), np.abs(np.clip(np.arctan2(v[..., 0], v[..., 2]), -np.pi / 2, np.pi / 2))


def propeller_speed_for_thrust(thrust: ArrayLike, v_xz: ArrayLike = 0.0, phi: ArrayLike = 0.0, *,
                               coefficients: PropellerCoefficients | None = None,
                               n_max: float | None = None, on_unreachable: str = "raise",
                               grid: int = 16, tol: float = 1e-10) -> NDArray[np.float64]:
    """Propeller speed n ≥ 0 (rev/s) with f = ρ d⁴ n² Ct(J, φ), J = V_xz/(n d) (7.90).

    ``thrust``, ``v_xz`` (air-relative speed in the rotor's x–z plane, m/s) and ``phi``
    (inflow angle, rad) broadcast (vectorized over the rotors); :func:`rotor_inflow` computes
    them from the rotor-frame air-relative velocity.  J depends on n, so this is a 1-D
    root search: a grid on [0, n_max] (n_max from the json ``n_range_rev_s``) brackets the
    smallest n where the thrust reaches f, then safeguarded regula falsi (Illinois) refines it to
    |f(n) − f| ≤ tol·max(1, f).  Thrust outside [0, f(n_max)] raises
    :class:`UnreachableThrustError` (``on_unreachable="raise"``) or is saturated to n = 0 /
    n_max (``"clip"``).

    Parameters
    ----------
    thrust : float or array_like
        Required thrust f (N), ≥ 0.
    v_xz : float or array_like, default 0.0
        Air-relative speed in the rotor's x–z plane (m/s), ≥ 0.
    phi : float or array_like, default 0.0
        Inflow angle φ (rad).
    coefficients : PropellerCoefficients, optional
        Propeller model (diameter d, air density ρ, Ct tables); default
        ``PropellerCoefficients()``.
    n_max : float, optional
        Largest propeller speed (rev/s); default the upper end of ``n_range_rev_s`` in the
        ``propeller_coefficients`` data file.
    on_unreachable : {"raise", "clip"}, default "raise"
        What to do with a thrust outside [0, f(n_max)].
    grid : int, default 16
        Number of intervals of the bracketing grid on [0, n_max].
    tol : float, default 1e-10
        Relative thrust tolerance (> 0): |f(n) − f| ≤ tol·max(1, f).

    Returns
    -------
    ndarray
        Propeller speed n (rev/s), broadcast shape of ``thrust``, ``v_xz`` and ``phi``.
    """
    from sobolev_drake.tiltrotor.propeller import PropellerCoefficients

    real_scalar("tol", tol, low=0.0, low_open=True)
    coef = coefficients if coefficients is not None else PropellerCoefficients()
    if on_unreachable not in ("raise", "clip"):
        raise ValueError(f"on_unreachable must be 'raise' or 'clip', got {on_unreachable!r}")
    if n_max is None:
        n_max = float(load("propeller_coefficients")["n_range_rev_s"][1])
    if not (np.isfinite(n_max) and n_max > 0):
        raise ValueError(f"n_max must be positive, got {n_max}")
    f, V, ph = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (thrust, v_xz, phi)))
    shape = f.shape
    f, V, ph = f.ravel(), V.ravel(), ph.ravel()
    if not (np.all(np.isfinite(f)) and np.all(np.isfinite(V)) and np.all(np.isfinite(ph))):
        raise ValueError("thrust, v_xz and phi must be finite")
    if np.any(V < 0):
        raise ValueError("v_xz is a speed magnitude and must be >= 0")
    ns = np.linspace(0.0, n_max, grid + 1)
    G = _thrust(coef, ns[None, :], V[:, None], ph[:, None])          # (k, grid+1)
    ftol = tol * np.maximum(1.0, np.abs(f))
    f_max = G[:, -1]
    bad = (f < -ftol) | (f > f_max + ftol)
    if np.any(bad):
        if on_unreachable == "raise":
            i = int(np.flatnonzero(bad)[0])
            raise UnreachableThrustError(
                f"thrust {f[i]:.6g} N is unreachable for v_xz = {V[i]:.4g} m/s, phi = {ph[i]:.4g} rad: "
                f"achievable range is [0, {f_max[i]:.6g}] N for n in [0, {n_max:g}] rev/s")
    ft = np.clip(f, 0.0, f_max)
    # Smallest grid interval [ns[k-1], ns[k]] where the thrust reaches ft.
    k = np.argmax(G >= ft[:, None] - ftol[:, None], axis=1)
    a = ns[np.maximum(k - 1, 0)]
    b = ns[k]
    ga = _thrust(coef, a, V, ph) - ft
    gb = _thrust(coef, b, V, ph) - ft
    n = np.where(np.abs(ga) <= ftol, a, b)
    done = (np.abs(ga) <= ftol) | (np.abs(gb) <= ftol)
    side = np.zeros_like(a)
    for _ in range(100):
        if np.all(done):
            break
        # Illinois regula falsi; fall back to bisection if the secant leaves the bracket.
        c = np.where(gb != ga, b - gb * (b - a) / np.where(gb != ga, gb - ga, 1.0), 0.5 * (a + b))
        c = np.where((c <= np.minimum(a, b)) | (c >= np.maximum(a, b)), 0.5 * (a + b), c)
        gc = _thrust(coef, c, V, ph) - ft
        n = np.where(done, n, c)
        done = done | (np.abs(gc) <= ftol) | (np.abs(b - a) <= 1e-14 * n_max)
        left = np.sign(gc) == np.sign(ga)
        a, ga, b, gb = (np.where(left, c, a), np.where(left, gc, ga),
                        np.where(left, b, c), np.where(left, gb, gc))
        gb = np.where(left & (side == 1), 0.5 * gb, gb)
        ga = np.where(~left & (side == -1), 0.5 * ga, ga)
        side = np.where(left, 1, -1)
    return n.reshape(shape)
