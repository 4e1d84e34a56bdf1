"""Trim of the tilt-rotor (thesis 7.3.1).

* :func:`trim_hover` — q̇ = 0 equilibrium; unknowns [αR αL φ θ nR nL τsR τsL], surfaces at 0.
* :func:`trim_level_flight` — constant forward velocity V along inertial x, ψ = 0, same unknowns
  with δ = 0 (the surfaces are not needed: the thrust line and the pitch attitude balance the
  moments); hover is V = 0.
* the tilt schedule α(V) built from level-flight trims is in
  :mod:`sobolev_drake.tiltrotor.tilt_schedule`.
* the linearization (7.57) about a trim is in :mod:`sobolev_drake.tiltrotor.linearization`.

Residuals are the generalized-force balance ϑ(q, q̇, τ, ζ) − C(q, q̇) q̇ − g(q) (N, N m).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike
from scipy.optimize import least_squares

from sobolev_drake.tiltrotor.plant import TiltrotorModel
from sobolev_drake.tiltrotor.params import TiltrotorParams, params_key
from sobolev_drake.tiltrotor.input_affine import generalized_force

__all__ = [
    "THESIS_HOVER", "tiltrotor_model", "Trim", "balance", "trim_level_flight", "trim_hover",
    "HoverWindLimit", "hover_wind_limit",
]

#: thesis hover trim [θ, αR, αL, n, τs] (7.3.1)
THESIS_HOVER = {"theta": 0.137, "alpha_R": -0.137, "alpha_L": -0.137, "n": 51.9, "tau_s": -0.127}

_MODELS: dict = {}


def tiltrotor_model(params: TiltrotorParams | None = None) -> TiltrotorModel:
    """The :class:`TiltrotorModel` of ``params`` (default Table B.1), one per parameter value.

    Parameters
    ----------
    params : TiltrotorParams, optional
        Vehicle parameters; None uses Table B.1 (``TiltrotorParams()``).

    Returns
    -------
    TiltrotorModel
        The Euler–Lagrange model (7.14) of ``params``, cached: equal parameter values return
        the same instance.
    """
    params = TiltrotorParams() if params is None else params
    key = params_key(params)
    if key not in _MODELS:
        _MODELS[key] = TiltrotorModel(params)
    return _MODELS[key]


def _model(model):
    return tiltrotor_model() if model is None else model


@dataclass
class Trim:
    """A trimmed operating point (thesis order).

    Attributes
    ----------
    V : float
        Forward speed (m/s) along inertial x (0 for hover).
    q : ndarray, shape (8,)
        Trim coordinates [αR αL φ θ ψ x y z] (rad, m); x, y, z are 0.
    qdot : ndarray, shape (8,)
        Generalized velocities (rad/s, m/s): [0, …, 0, V, 0, 0].
    n : ndarray, shape (2,)
        Propeller speeds [nR, nL] (rev/s).
    tau_s : ndarray, shape (2,)
        Servo torques [τsR, τsL] (N m).
    delta : ndarray, shape (4,)
        Control surface deflections [δWR δWL δTR δTL] (rad).
    zeta : ndarray, shape (3,)
        Wind velocity ζ, inertial axes (m/s).
    residual : ndarray, shape (8,)
        Generalized-force balance ϑ − C(q, q̇) q̇ − g(q) at the solution (N m on the angles,
        N on x, y, z); see :func:`balance`.
    success : bool
        True when max |residual| < 1e-8 and both propeller speeds are positive.
    info : dict
        Solver details: ``nfev``, ``status``, ``message``, the unknown vector ``z`` (usable
        as a continuation ``guess``) and the ``model`` the trim was computed on.
    """

    V: float
    q: np.ndarray
    qdot: np.ndarray
    n: np.ndarray
    tau_s: np.ndarray
    delta: np.ndarray
    zeta: np.ndarray
    residual: np.ndarray
    success: bool
    info: dict = field(default_factory=dict)

    @property
    def residual_norm(self) -> float:
        """max |residual| (N, N m): the size of the generalized-force imbalance."""
        return float(np.max(np.abs(self.residual)))

    @property
    def u(self) -> np.ndarray:
        """Thesis τ = [nPR nPL τsR τsL δWR δWL δTR δTL]."""
        return np.concatenate([self.n, self.tau_s, self.delta])

    @property
    def thrust(self) -> np.ndarray:
        """Propeller thrusts [fR, fL] (N) at the trim, f = ρ d⁴ n² Ct(J, φ) (7.25), (7.27)."""
        from sobolev_drake.tiltrotor.input_affine import thrust_inputs
        return thrust_inputs(self.info["model"].params, self.q, self.qdot, self.zeta, self.n)


def balance(model: TiltrotorModel | None, q: ArrayLike, qdot: ArrayLike, zeta: ArrayLike,
            n: ArrayLike, tau_s: ArrayLike, delta: ArrayLike) -> np.ndarray:
    """ϑ − C(q, q̇) q̇ − g(q): zero at a trim (q̈ = 0).

    Parameters
    ----------
    model : TiltrotorModel or None
        The model (None: :func:`tiltrotor_model` of Table B.1).
    q : array_like, shape (8,)
        Generalized coordinates [αR αL φ θ ψ x y z] (rad, m).
    qdot : array_like, shape (8,)
        Generalized velocities (rad/s, m/s), same order.
    zeta : array_like, shape (3,)
        Wind velocity ζ, inertial axes (m/s).
    n : array_like, shape (2,)
        Propeller speeds [nR, nL] (rev/s).
    tau_s : array_like, shape (2,)
        Servo torques [τsR, τsL] (N m).
    delta : array_like, shape (4,)
        Control surface deflections [δWR δWL δTR δTL] (rad).

    Returns
    -------
    ndarray, shape (8,)
        Generalized force ϑ (7.18) minus the Coriolis/centripetal and gravity terms of
        (7.14), thesis order (N m on the angles, N on x, y, z); it equals M(q) q̈.
    """
    model = _model(model)
    return (generalized_force(model, q, qdot, zeta, n, tau_s, delta)
            - model.Cqdot(q, qdot) - model.g(q))


def trim_level_flight(V: float, model: TiltrotorModel | None = None, guess: ArrayLike | None = None,
                      zeta: ArrayLike | None = None, tol: float = 1e-13, alpha: float | None = None,
                      restarts: bool = True) -> Trim:
    """Trim at constant inertial velocity [V, 0, 0] (V ≥ 0, m/s) with wind ``zeta``.

    Default: δ = 0, unknowns z = [αR αL φ θ nR nL τsR τsL].  With ``alpha`` given (tilt angle,
    rad, both sides) the tilt is prescribed and the ruddervators become unknowns instead:
    z = [δTR δTL φ θ nR nL τsR τsL].  Solved by ``scipy.optimize.least_squares`` (trust-region
    reflective, xtol = ftol = gtol = ``tol``); ``guess`` is a previous z.  If that start fails
    and ``restarts`` is true, a coarse grid of starts is tried and the best solution returned.
    ``Trim.success`` means max |residual| < 1e-8 with n > 0.

    Parameters
    ----------
    V : float
        Forward speed (m/s) along inertial x, finite and ≥ 0 (0 is hover).
    model : TiltrotorModel, optional
        The model (None: :func:`tiltrotor_model` of Table B.1).
    guess : array_like, shape (8,), optional
        Starting unknown vector z (e.g. ``Trim.info["z"]`` of a neighbouring trim); None
        starts at the thesis hover trim.
    zeta : array_like, shape (3,), optional
        Wind velocity ζ, inertial axes (m/s); default zero.
    tol : float, default 1e-13
        ``xtol``, ``ftol`` and ``gtol`` of ``least_squares``.
    alpha : float, optional
        Prescribed tilt angle (rad) of both thruster groups; the ruddervators δTR, δTL are
        then unknowns instead of αR, αL.
    restarts : bool, default True
        Try a coarse grid of starts when the first solve fails.

    Returns
    -------
    Trim
        The operating point (check ``success``); ``info["z"]`` is the solved unknown vector.
    """
    model = _model(model)
    V = float(V)
    if not np.isfinite(V) or V < 0:
        raise ValueError(f"V must be a finite non-negative speed, got {V}")
    zeta = np.zeros(3) if zeta is None else np.asarray(zeta, dtype=float)
    qdot = np.zeros(8)
    qdot[5] = V
    delta = np.zeros(4)
    z0 = np.array([-0.137, -0.137, 0, 0.137, 51.9, 51.9, -0.127, -0.127])
    if alpha is not None:
        z0[0:2] = 0.0
    z0 = z0 if guess is None else np.asarray(guess, dtype=float)

    def unpack(z):
        q = np.zeros(8)
        q[0:4] = z[0:4]
        d = delta.copy()
        if alpha is not None:
            q[0:2] = float(alpha)
            d[2:4] = z[0:2]
        return q, z[4:6], z[6:8], d

    def fun(z):
        q, n, ts, d = unpack(z)
        return balance(model, q, qdot, zeta, n, ts, d)

    def solve(z_init):
        return least_squares(fun, z_init, method="trf", xtol=tol, ftol=tol, gtol=tol,
                             x_scale=np.array([0.1, 0.1, 0.1, 0.1, 10, 10, 0.1, 0.1]), max_nfev=400)

    def ok(sol):
        return np.max(np.abs(sol.fun)) < 1e-8 and np.all(sol.x[4:6] > 0)

    sol = solve(z0)
    if not ok(sol) and restarts:
        # multi-start over a coarse grid (the airplane-mode branch needs n ≈ 80 rev/s and a
        # nose-up attitude, far from the hover guess)
        for n0 in (40.0, 60.0, 80.0):
            for th0 in (-0.15, 0.05):
                for a0 in ((-0.3, 0.3) if alpha is not None else (0.0, 0.6, 1.2)):
                    cand = solve(np.array([a0, a0, 0.0, th0, n0, n0, -0.1, -0.1]))
                    if ok(cand) or np.max(np.abs(cand.fun)) < np.max(np.abs(sol.fun)):
                        sol = cand
                    if ok(sol):
                        break
                if ok(sol):
                    break
            if ok(sol):
                break
    q, n, ts, delta = unpack(sol.x)
    res = fun(sol.x)
    return Trim(V=V, q=q, qdot=qdot, n=n, tau_s=ts, delta=delta, zeta=zeta, residual=res,
                success=bool(np.max(np.abs(res)) < 1e-8 and np.all(n > 0)),
                info={"nfev": sol.nfev, "status": sol.status, "message": sol.message, "z": sol.x,
                      "model": model})


def trim_hover(model: TiltrotorModel | None = None, zeta: ArrayLike | None = None) -> Trim:
    """Hover trim (V = 0); compare with ``THESIS_HOVER``.

    Parameters
    ----------
    model : TiltrotorModel, optional
        The model (None: :func:`tiltrotor_model` of Table B.1).
    zeta : array_like, shape (3,), optional
        Wind velocity ζ, inertial axes (m/s); default zero (still air).

    Returns
    -------
    Trim
        The hover trim of :func:`trim_level_flight` at V = 0 (thesis 7.3.1: θ = 0.137 rad,
        αR = αL = −0.137 rad, n = 51.9 rev/s, τs = −0.127 N m).
    """
    return trim_level_flight(0.0, model=model, zeta=zeta)


@dataclass
class HoverWindLimit:
    """Result of :func:`hover_wind_limit`.

    ``speeds``/``trims``: the continuation samples that trimmed within the attitude limit;
    ``limit``: wind speed (m/s) at which the trim leaves it (bisected to ``tol``), ``inf`` if
    it never does up to ``max_speed``; ``reason``: what happened at the limit.

    Attributes
    ----------
    direction_deg : float
        Wind direction χ (degrees from inertial x, the direction the air moves).
    attitude_limit_deg : float
        Bound (degrees) on max(|φ|, |θ|) a trim may reach.
    speeds : ndarray, shape (k,)
        Wind speeds (m/s) of the continuation samples that trimmed within the bound, from 0.
    trims : list of Trim
        The hover trims at ``speeds``.
    limit : float
        Wind speed (m/s) at which the trim leaves the bound or stops existing (bisected);
        ``inf`` if it never does up to ``max_speed``.
    reason : str
        What happened at the limit (attitude bound passed, or continuation lost).
    """

    direction_deg: float
    attitude_limit_deg: float
    speeds: np.ndarray
    trims: list
    limit: float
    reason: str

    def attitude_deg(self) -> np.ndarray:
        """max(|φ|, |θ|) of each trim, degrees.

        Returns
        -------
        ndarray, shape (k,)
            max(|φ|, |θ|) (degrees) of each of ``trims``, in ``speeds`` order.
        """
        return np.array([np.degrees(np.max(np.abs(t.q[2:4]))) for t in self.trims])


def hover_wind_limit(direction_deg: float = 90.0, *, attitude_limit_deg: float = 60.0,
                     max_speed: float = 25.0, step: float = 0.5, tol: float = 0.02,
                     model: TiltrotorModel | None = None) -> HoverWindLimit:
    """Strongest steady horizontal wind in which the aircraft can hover with its heading held.

    Hover trims (q̇ = 0, ψ = 0, surfaces at 0; unknowns [αR αL φ θ nR nL τsR τsL]) in the
    wind ζ = V [cos χ, sin χ, 0] (χ = ``direction_deg``, the direction the air moves, from
    inertial x), continued from V = 0 in steps of ``step`` and bisected to ``tol`` where the
    trim stops existing or max(|φ|, |θ|) passes ``attitude_limit_deg``.  The heading-hold
    matters: in a crosswind the weathercock yaw moment has to be held by differential nacelle
    tilt, which for this airframe drags roll and pitch along (measured: 12 m/s lateral wind
    needs φ ≈ 39°, θ ≈ −49°).  A quasi-steady bound, not a proof: a gust shorter than the
    aircraft's response can exceed it briefly.  "No trim beyond" means the continuation lost
    the branch, which a Newton failure does not prove; with a tail component in the wind the
    α of (7.39) is discontinuous (flow from behind) and the continuation stops early.

    Parameters
    ----------
    direction_deg : float, default 90.0
        Wind direction χ (degrees from inertial x, the direction the air moves); 90 is a
        crosswind toward inertial y.
    attitude_limit_deg : float, default 60.0
        Bound (degrees, in (0, 90)) on max(|φ|, |θ|) of an acceptable trim.
    max_speed : float, default 25.0
        Largest wind speed (m/s) tried.
    step : float, default 0.5
        Continuation step (m/s) in wind speed.
    tol : float, default 0.02
        Bisection tolerance (m/s) on the limit speed.
    model : TiltrotorModel, optional
        The model (None: :func:`tiltrotor_model` of Table B.1).

    Returns
    -------
    HoverWindLimit
        The limit wind speed (m/s), the trims below it and the reason it ends.
    """
    if not np.isfinite(direction_deg):
        raise ValueError(f"direction_deg must be finite, got {direction_deg}")
    for name, v in (("attitude_limit_deg", attitude_limit_deg), ("max_speed", max_speed),
                    ("step", step), ("tol", tol)):
        if not (np.isfinite(v) and v > 0):
            raise ValueError(f"{name} must be finite and positive, got {v}")
    if not 0 < attitude_limit_deg < 90:
        raise ValueError(f"attitude_limit_deg must lie in (0, 90), got {attitude_limit_deg}")
    model = _model(model)
    chi = np.radians(direction_deg)
    unit = np.array([np.cos(chi), np.sin(chi), 0.0])
    bound = np.radians(attitude_limit_deg)

    def trim_at(V, guess):
        t = trim_level_flight(0.0, model=model, zeta=V * unit, guess=guess, restarts=False)
        return t if t.success and np.max(np.abs(t.q[2:4])) <= bound else None

    speeds, trims = [0.0], [trim_hover(model)]
    V = step
    while V <= max_speed + 1e-12:
        t = trim_at(V, trims[-1].info["z"])
        if t is None:
            break
        speeds.append(V)
        trims.append(t)
        V += step
    else:
        return HoverWindLimit(float(direction_deg), float(attitude_limit_deg), np.array(speeds), trims,
                              np.inf, f"trimmed within ±{attitude_limit_deg:g}° up to {speeds[-1]:g} m/s")
    lo, hi, last = speeds[-1], V, trims[-1]
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        t = trim_at(mid, last.info["z"])
        if t is None:
            hi = mid
        else:
            lo, last = mid, t
    t = trim_level_flight(0.0, model=model, zeta=hi * unit, guess=last.info["z"], restarts=False)
    reason = (f"max(|φ|, |θ|) passes {attitude_limit_deg:g}° (trim at {hi:.2f} m/s: "
              f"{np.degrees(np.max(np.abs(t.q[2:4]))):.1f}°)" if t.success else
              f"no trim beyond {lo:.2f} m/s (continuation lost, residual {t.residual_norm:.1e})")
    if lo > speeds[-1]:
        speeds, trims = speeds + [lo], trims + [last]
    return HoverWindLimit(float(direction_deg), float(attitude_limit_deg), np.array(speeds), trims,
                          0.5 * (lo + hi), reason)
