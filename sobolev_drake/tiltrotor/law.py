"""Composition of the tilt-rotor W∞ law with the plant model, the allocation and the propeller
data (thesis §7.3.2): :func:`make_law` builds a :class:`~sobolev_drake.tiltrotor.
controller.TiltrotorWInfLaw` from a ``TiltrotorModel``; the tilt reference schedule
from the plant's own level-flight trims (:func:`plant_trim_schedule`) and the warm-started
Newton inversion of the thrust (7.90) (:func:`newton_speed_for_thrust`) live here too.

With the compiled kernels (``sobolev_drake.native``) the law also gets a fused per-sample path
that calls them directly; it computes the same numbers as the composed callables.  The
controller's whole update in one compiled call is ``tiltrotor.compiled_sample``.
"""

from __future__ import annotations

import math
from bisect import bisect_right
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sobolev_drake.systems.mechanical_controller import MechanicalLaw, SobolevLaw
from sobolev_drake.tiltrotor.controller import (N_Q, PARTITION, ControlStep, TiltrotorWInfLaw,
                                                       TiltSchedule, checked_vector, thesis_inner_law,
                                                       tilt_schedule_polynomial)

if TYPE_CHECKING:
    from sobolev_drake.tiltrotor.gain_schedule import EnvelopeSchedule
    from sobolev_drake.tiltrotor.plant import TiltrotorModel
    from sobolev_drake.tiltrotor.propeller import PropellerCoefficients

__all__ = ["DESIGNS", "make_law", "newton_speed_for_thrust", "plant_trim_schedule",
           "plant_pitch_schedule"]

#: the law's weightings: the thesis' one tuning for every flight mode, or the envelope schedule
DESIGNS = {"thesis": "thesis tuning, §7.3.2", "scheduled": "scheduled W∞ over air speed"}


def make_law(model: TiltrotorModel, inner: SobolevLaw | None = None, *,
             schedule: str | TiltSchedule = "plant",
             allocate: Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray], ArrayLike] | None = None,
             design: str = "thesis", gain_schedule: EnvelopeSchedule | None = None) -> TiltrotorWInfLaw:
    """Compose :class:`TiltrotorWInfLaw` from the tilt-rotor model and the library pieces.

    ``inner``: :class:`SobolevLaw` (default :func:`thesis_inner_law`, the thesis tuning).
    ``schedule``: ``"plant"`` (default) — spline through the plant model's level-flight trims
    (:func:`plant_trim_schedule`); ``"data"`` — tilt polynomial of ``tiltrotor_missions.json``
    (the thesis author's simulator; it rises much faster above 24 m/s than our trims); or a
    callable ``U -> (α, α', α'')``.  ``allocate`` defaults to
    ``tiltrotor.allocation.bounded_least_squares`` warm-started from the previous sample's active
    set (same solution, fewer iterations).

    Bounds (7.85)–(7.89) use the air speed of each surface [WR WL TR TL] from the aerodynamic
    model (measured wind ζ); the thrust inversion (7.90) uses each hub's rotor-frame inflow.
    B, ϑ_passive, these air speeds and the inflow come from one scalar pass of the force model
    per sample (``input_affine.input_affine_terms``), shared by the composed callables.

    Parameters
    ----------
    model : TiltrotorModel
        The plant model (thesis order q = [αR αL φ θ ψ x y z]) whose parameters define the
        force model, B(q, q̇, ζ) and ϑ_passive of (7.62) and the inverse dynamics.
    inner : SobolevLaw, optional
        Inner W∞ law of the regulated partition (default :func:`thesis_inner_law`).
    schedule : {"plant", "data"} or callable, default "plant"
        Tilt reference α(U) as described above; a callable maps forward air speed U (m/s)
        to (α (rad), dα/dU, d²α/dU²).
    allocate : callable, optional
        ``allocate(B, u, lo, up) -> τ̄``: bounded allocation (7.84)–(7.86) of the desired
        generalized input u (N, N m) over the actuators within [lo, up].
    design : {"thesis", "scheduled"}, default "thesis"
        :data:`DESIGNS`: ``"scheduled"`` computes q̈_des with the envelope gain schedule
        (:class:`~sobolev_drake.tiltrotor.gain_schedule.EnvelopeSchedule`, trim pitch from the
        plant's level-flight trims) instead of ``inner``'s constant gains.
    gain_schedule : EnvelopeSchedule, optional
        With ``design="scheduled"``: this schedule instead of the default one.

    Returns
    -------
    TiltrotorWInfLaw
        The composed law (with ``propulsion`` and ``aero`` cores attached, a fused per-sample
        path when the compiled kernels are built, and ``compiled_sample``, the controller's
        one-call update (``tiltrotor.compiled_sample``), for either design with the default
        allocation).
    """
    from sobolev_drake.data import load
    from sobolev_drake.tiltrotor.allocation import (bounded_least_squares, propeller_speed_for_thrust,
                                                  tiltrotor_bounds)
    from sobolev_drake.tiltrotor.compiled_sample import (NEWTON_ITERATIONS, NEWTON_RTOL,
                                                         compiled_sample)
    from sobolev_drake.tiltrotor.input_affine import (N_REF, native_core, affine_terms_scalar, cores,
                                                    input_affine)

    if design not in DESIGNS:
        raise ValueError(f"design must be one of {tuple(DESIGNS)}, got {design!r}")
    if gain_schedule is not None and design != "scheduled":
        raise ValueError(f"gain_schedule is only used with design='scheduled', got design={design!r}")
    prop, aero = cores(model.params)
    if callable(schedule):
        sched = schedule
    elif schedule == "data":
        spec = load("tiltrotor_missions")["scenario_2_full_envelope"]["tilt_reference_vs_forward_speed"]
        sched = tilt_schedule_polynomial(spec["coefficients"])
    elif schedule == "plant":
        sched = plant_trim_schedule(model)
    else:
        raise ValueError(f"schedule must be 'data', 'plant' or a callable, got {schedule!r}")
    default_allocation = allocate is None
    if allocate is None:
        # The previous sample's active set warm-starts the solver: one linear solve when it
        # is unchanged; the solution is the same (KKT-certified), only the iterations differ.
        last = {"active": None}

        def allocate(B, u, lo, up):
            tau, info = bounded_least_squares(B, u, lo, up, warm_start=last["active"],
                                              return_info=True)
            last["active"] = info["active"]
            return tau
        # the controller keeps the active set in its Context and passes it through here
        allocate.warm_start = last

    # One scalar pass of the force model per sample serves B, ϑ_passive, the surface air
    # speeds of the bounds and the rotor inflow of the thrust inversion (all at (q, q̇, ζ)).
    shared = {"key": None, "terms": None}

    def terms(q, qdot, wind, n=None, reuse=True):
        nd = np.ndarray
        if reuse and type(q) is nd and type(qdot) is nd and type(wind) is nd:
            # same contents as the last (validated) call: no need to check them again
            key = (q.dtype.str, q.shape, q.tobytes(), qdot.dtype.str, qdot.shape,
                   qdot.tobytes(), wind.dtype.str, wind.shape, wind.tobytes())
            if shared["key"] == key:
                return shared["terms"]
        q, ql = checked_vector("q", q, N_Q)
        qdot, qdl = checked_vector("qdot", qdot, N_Q)
        wind, wl = checked_vector("zeta", wind, 3)
        key = (q.dtype.str, q.shape, q.tobytes(), qdot.dtype.str, qdot.shape, qdot.tobytes(),
               wind.dtype.str, wind.shape, wind.tobytes())
        nl = [N_REF, N_REF] if n is None else checked_vector("n", n, 2)[1]
        t = affine_terms_scalar(model.params, ql, qdl, wl, nl)
        shared["key"], shared["terms"] = key, t   # speeds and inflow do not depend on n
        return t

    def affine(model_, q, qdot, zeta, n=None):
        if model_ is not model:
            return input_affine(model_, q, qdot, zeta, n)
        t = terms(q, qdot, zeta, n, reuse=False)
        return t.B, t.passive

    def bounds(q, qdot, wind):
        V = terms(q, qdot, wind).surface_speed
        return tiltrotor_bounds(V[1:5])          # surfaces F, WR, WL, TR, TL, I → [WR WL TR TL]

    native = native_core(model.params)      # compiled Newton solve (same floats) if built

    def speeds(f, v_xz, phi, n_guess):
        """(7.90) inverted: warm Newton from ``n_guess`` if given, else (or if it fails) the
        bracketing solver, saturating unreachable thrusts."""
        if n_guess is not None:
            if native is not None and np.size(f) == 2 and np.size(n_guess) == 2:
                n = native[0].newton_speed(native[1], np.asarray(f, float), v_xz, phi,
                                           np.asarray(n_guess, float), NEWTON_ITERATIONS,
                                           NEWTON_RTOL)
                n = None if n is None else np.array(n)
            else:
                n = newton_speed_for_thrust(prop.coef, f, v_xz, phi, n_guess)
            if n is not None:
                return n
        return propeller_speed_for_thrust(f, v_xz, phi, coefficients=prop.coef,
                                          on_unreachable="clip")

    def thrust_to_speed(f, q, qdot, wind, n_guess=None):
        t = terms(q, qdot, wind)
        return speeds(f, t.rotor_vxz, t.rotor_phi, n_guess)

    inner = thesis_inner_law() if inner is None else inner
    mech = MechanicalLaw(model, PARTITION, inner, allocation=lambda u, q, qd: u)
    law = TiltrotorWInfLaw(mech, input_affine=affine, allocate=allocate, bounds=bounds,
                           thrust_to_speed=thrust_to_speed, tilt_schedule=sched)
    law.propulsion, law.aero = prop, aero
    if design == "scheduled":
        from sobolev_drake.tiltrotor.gain_schedule import EnvelopeSchedule
        law.desired_acceleration = (EnvelopeSchedule(plant_pitch_schedule(model))
                                    if gain_schedule is None else gain_schedule)
    law.design = design
    if native is not None:
        law.fused_sample = _fused_sample(law, native, speeds,
                                         (affine, bounds, allocate, thrust_to_speed))
    law.compiled_sample = compiled_sample(law, None if native is None else native[1],
                                          default_allocation=default_allocation)
    return law


def _fused_sample(law, native, speeds, parts):
    """The per-sample work of :meth:`TiltrotorWInfLaw.step` after q̈_des — B and ϑ_passive,
    u*, the bounds, the allocation and the thrust inversion — with the compiled force kernel
    called directly instead of through the composed callables' shared-term cache, argument
    checks and array conversions (which cost more than the arithmetic).  The allocation is the
    law's own ``allocate`` and the inversion make_law's ``speeds``, so the numbers are the same
    (tested against the composed path)."""
    from sobolev_drake.tiltrotor.allocation import thesis_bounds_constants
    from sobolev_drake.tiltrotor.input_affine import N_REF

    forces, capsule = native
    limits = thesis_bounds_constants()
    rnea = law.mech_law.dynamics.recursive_inverse_dynamics
    allocate = parts[2]

    def sample(q, qdot, ql, qdl, wl, n_prev, qdd, ref_r):
        nl = None            # B's Cq/Ct at the last speeds, at the hover speed without them
        if n_prev is not None and not min(np.asarray(n_prev, dtype=float).tolist()) <= 0:
            nl = checked_vector("n", n_prev, 2)[1]
        Bl, passive, V, vxz, phi = forces.affine_terms(capsule, ql, qdl, wl,
                                                       [N_REF, N_REF] if nl is None else nl, True)
        B, theta = np.array(Bl).reshape(8, 8), checked_vector("theta_passive", passive, N_Q)[0]
        u = rnea(q, qdot, qdd) - theta
        lo, up = forces.surface_bounds(V[1:5], *limits)
        lo, up = np.array(lo), np.array(up)
        tau = np.asarray(allocate(B, u, lo, up), dtype=float)
        n = speeds(tau[:2], np.array(vxz), np.array(phi), nl)
        r = u - B @ tau
        return ControlStep(qdd, u, B, theta, tau, lo, up, n, math.sqrt(float(r @ r)), ref_r)

    sample.parts = parts
    return sample


def newton_speed_for_thrust(coef: PropellerCoefficients, f: ArrayLike, v_xz: ArrayLike, phi: ArrayLike,
                            n_guess: ArrayLike, iterations: int = 4,
                            rtol: float = 1e-9) -> NDArray[np.float64] | None:
    """Warm-started Newton solve of ρ d⁴ n² Ct(V_xz / (n d), φ) = f (7.90); None if it fails.

    The previous sample's speeds are an excellent start (the demand changes little over one
    sample), so 2–3 Newton steps reach machine-level thrust residuals; the caller falls back to
    the bracketing solver of ``tiltrotor.allocation`` when this returns None (no warm start,
    zero thrust, non-increasing thrust, or no convergence).  All rotors iterate together
    (Python floats: a handful of scalars is far cheaper than numpy calls).

    Parameters
    ----------
    coef : PropellerCoefficients
        Propeller model: air density ρ (kg/m³), diameter d (m), J_max and the Ct(J, φ)
        polynomial.
    f : array_like, shape (k,)
        Required thrusts (N), one per rotor.
    v_xz : array_like, shape (k,)
        Air-relative speed in each rotor's x–z plane (m/s).
    phi : array_like, shape (k,)
        Inflow angle φ of each rotor (rad).
    n_guess : array_like, shape (k,)
        Starting propeller speeds (rev/s), e.g. the previous sample's.
    iterations : int, default 4
        Maximum number of Newton steps.
    rtol : float, default 1e-9
        Relative thrust tolerance of convergence, |f(n) − f| ≤ rtol·(1 + f).

    Returns
    -------
    ndarray, shape (k,) or None
        Propeller speeds n (rev/s), or None when the warm start is unusable or the solve
        does not converge (the caller then uses the bracketing solver).
    """
    f, n, vx, ph = (np.asarray(a, dtype=float).ravel().tolist() for a in (f, n_guess, v_xz, phi))
    if any(x <= 0 for x in f) or any(x <= 1.0 for x in n):
        return None
    k = coef.rho * coef.diameter ** 4
    d, Jmax = coef.diameter, coef.J_max
    idx = range(len(f))
    # φ is fixed during the solve: Ct(J, φ) is a quartic in J per rotor (Horner coefficients)
    cj = [coef.ct_in_J(p) for p in ph]

    def g(nn, i):  # thrust − f, J clamped to the table range as in the plant's propeller model
        J = vx[i] / (nn * d)
        J = J if J < Jmax else Jmax
        c4, c3, c2, c1, c0 = cj[i]
        return k * nn * nn * ((((c4 * J + c3) * J + c2) * J + c1) * J + c0) - f[i]

    for _ in range(iterations):
        g0 = [g(n[i], i) for i in idx]
        if all(abs(g0[i]) <= rtol * (1.0 + f[i]) for i in idx):
            return np.array(n)
        hs = [1e-6 * x for x in n]
        dg = [(g(n[i] + hs[i], i) - g0[i]) / hs[i] for i in idx]
        if any(x <= 0 for x in dg):
            return None
        n = [n[i] - g0[i] / dg[i] for i in idx]
        if any(x <= 0 for x in n):
            return None
    return np.array(n) if all(abs(g(n[i], i)) <= 1e-6 * (1.0 + f[i]) for i in idx) else None


_TRIM_SCHEDULES: dict = {}
_LEVEL_TRIMS: dict = {}


def _level_trims(model):
    """(V, α, θ) of the plant's level-flight trims, computed once per parameter value."""
    from sobolev_drake.tiltrotor.tilt_schedule import tilt_schedule

    key = repr(getattr(model, "params", None))      # parameter values, not object identity
    if key not in _LEVEL_TRIMS:
        trims = tilt_schedule(model=model)
        _LEVEL_TRIMS[key] = (np.array([t.V for t in trims]),
                             np.array([0.5 * (t.q[0] + t.q[1]) for t in trims]),
                             np.array([t.q[3] for t in trims]))
    return _LEVEL_TRIMS[key]


def plant_pitch_schedule(model: TiltrotorModel | None = None) -> Callable[[float], float]:
    """θ_trim(U): pitch of the plant's level-flight trims (0–34 m/s, linear interpolation,
    clamped), the attitude reference of the envelope gain schedule.

    Parameters
    ----------
    model : TiltrotorModel, optional
        The plant model whose trims are used (None: Table B.1); cached per parameter value.

    Returns
    -------
    callable
        ``f(U) -> θ`` (rad) at forward air speed U (m/s).
    """
    V, _, theta = _level_trims(model)
    xs, ys = V.tolist(), theta.tolist()
    last = len(xs) - 2

    def pitch(U):
        U = min(max(float(U), xs[0]), xs[-1])
        i = min(max(bisect_right(xs, U) - 1, 0), last)
        w = (U - xs[i]) / (xs[i + 1] - xs[i])
        return ys[i] + w * (ys[i + 1] - ys[i])
    return pitch


def plant_trim_schedule(model: TiltrotorModel | None = None) -> TiltSchedule:
    """α(U) from the plant's level-flight trims (``tiltrotor.tilt_schedule.tilt_schedule``,
    0–34 m/s every 1 m/s) as a cubic spline ``U -> (α, α', α'')``, clamped like the polynomial.

    The trims are computed once per process (a few seconds) and cached.

    Parameters
    ----------
    model : TiltrotorModel, optional
        The plant model whose trims are used (None: Table B.1); cached per parameter value.

    Returns
    -------
    callable
        ``sched(U) -> (α, α', α'')``: mean trim tilt angle α (rad) at forward speed U (m/s)
        and its first and second derivatives in U (rad·s/m, rad·s²/m²); outside 0–34 m/s U
        is clamped and the derivatives are 0.
    """
    from scipy.interpolate import CubicSpline

    key = repr(getattr(model, "params", None))      # parameter values, not object identity
    if key not in _TRIM_SCHEDULES:
        V, a, _ = _level_trims(model)
        _TRIM_SCHEDULES[key] = (CubicSpline(V, a), V[0], V[-1])
    spline, lo, hi = _TRIM_SCHEDULES[key]
    # plain-float evaluation of the spline's pieces (scipy's call costs ~10 µs per derivative)
    xs = spline.x.tolist()
    coefs = spline.c.T.tolist()            # per interval: highest power first
    last = len(xs) - 2

    def sched(U):
        U = float(U)
        inside = lo <= U <= hi
        U = min(max(U, lo), hi)
        i = min(max(bisect_right(xs, U) - 1, 0), last)
        c3, c2, c1, c0 = coefs[i]
        x = U - xs[i]
        val = ((c3 * x + c2) * x + c1) * x + c0
        if not inside:
            return val, 0.0, 0.0
        return val, (3.0 * c3 * x + 2.0 * c2) * x + c1, 6.0 * c3 * x + 2.0 * c2
    # the same evaluation in native/fused.c (the compiled per-sample path)
    sched.compiled_form = {"schedule": 0, "knots": xs, "coefficients": [v for c in coefs for v in c],
                           "lo": float(lo), "hi": float(hi)}
    return sched
