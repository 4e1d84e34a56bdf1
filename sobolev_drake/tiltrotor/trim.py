"""Trim, tilt schedule and linearization of the tilt-rotor (thesis 7.3.1, (7.57)).

* :func:`trim_hover` — q̇ = 0 equilibrium; unknowns [αR αL φ θ nR nL τsR τsL], surfaces at 0.
* :func:`trim_level_flight` — constant forward velocity V along inertial x, ψ = 0, same unknowns
  with δ = 0 (the surfaces are not needed: the thrust line and the pitch attitude balance the
  moments); hover is V = 0.
* :func:`tilt_schedule` — α(V) over 0–34 m/s from level-flight trims, beside the mission file's
  polynomial ``tilt_reference_vs_forward_speed``; :func:`write_tilt_schedule_report` writes a
  markdown/JSON table and a PNG plot.
* :func:`linearize` — (A, B, D) of (7.57) in thesis state order [Δq; Δq̇; ∫Δψ ∫Δx ∫Δy ∫Δz]
  with inputs Δu = [ΔnR ΔnL ΔτsR ΔτsL] and wind Δζ.  Drake's ``Linearize`` needs AutoDiff, which
  the Python force systems do not provide, so the Jacobians are central differences of the
  *Drake diagram's* ``CalcTimeDerivatives`` (plant + force system), step 1e-6 (truncation error
  ~1e-10 relative).

Residuals are the generalized-force balance ϑ(q, q̇, τ, ζ) − C(q, q̇) q̇ − g(q) (N, N m).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import least_squares

from sobolev_drake.tiltrotor.plant import TiltrotorModel, add_tiltrotor
from sobolev_drake.tiltrotor.params import TiltrotorParams
from sobolev_drake.tiltrotor.input_affine import generalized_force

__all__ = [
    "THESIS_HOVER", "tiltrotor_model", "Trim", "balance", "trim_level_flight", "trim_hover",
    "HoverWindLimit", "hover_wind_limit", "tilt_reference_polynomial", "tilt_schedule",
    "write_tilt_schedule_report", "Linearization", "linearize",
]

#: thesis hover trim [θ, αR, αL, n, τs] (7.3.1)
THESIS_HOVER = {"theta": 0.137, "alpha_R": -0.137, "alpha_L": -0.137, "n": 51.9, "tau_s": -0.127}

_MODELS: dict = {}


def _params_key(params: TiltrotorParams) -> tuple:
    """Value of ``params`` as a hashable key (the dataclass holds numpy arrays)."""
    from dataclasses import fields
    return tuple((f.name, v if isinstance(v, str) else np.asarray(v, dtype=float).tobytes())
                 for f in fields(params) for v in (getattr(params, f.name),))


def tiltrotor_model(params: TiltrotorParams | None = None) -> TiltrotorModel:
    """The :class:`TiltrotorModel` of ``params`` (default Table B.1), one per parameter value."""
    params = TiltrotorParams() if params is None else params
    key = _params_key(params)
    if key not in _MODELS:
        _MODELS[key] = TiltrotorModel(params)
    return _MODELS[key]


def _model(model):
    return tiltrotor_model() if model is None else model


@dataclass
class Trim:
    """A trimmed operating point (thesis order)."""

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
        return float(np.max(np.abs(self.residual)))

    @property
    def u(self) -> np.ndarray:
        """Thesis τ = [nPR nPL τsR τsL δWR δWL δTR δTL]."""
        return np.concatenate([self.n, self.tau_s, self.delta])

    @property
    def thrust(self) -> np.ndarray:
        from sobolev_drake.tiltrotor.input_affine import thrust_inputs
        return thrust_inputs(self.info["model"].params, self.q, self.qdot, self.zeta, self.n)


def balance(model, q, qdot, zeta, n, tau_s, delta) -> np.ndarray:
    """ϑ − C(q, q̇) q̇ − g(q): zero at a trim (q̈ = 0)."""
    model = _model(model)
    return (generalized_force(model, q, qdot, zeta, n, tau_s, delta)
            - model.Cqdot(q, qdot) - model.g(q))


def trim_level_flight(V: float, model=None, guess=None, zeta=None, tol=1e-13, alpha=None,
                      restarts=True) -> Trim:
    """Trim at constant inertial velocity [V, 0, 0] (V ≥ 0, m/s) with wind ``zeta``.

    Default: δ = 0, unknowns z = [αR αL φ θ nR nL τsR τsL].  With ``alpha`` given (tilt angle,
    rad, both sides) the tilt is prescribed and the ruddervators become unknowns instead:
    z = [δTR δTL φ θ nR nL τsR τsL].  Solved by ``scipy.optimize.least_squares`` (trust-region
    reflective, xtol = ftol = gtol = ``tol``); ``guess`` is a previous z.  If that start fails
    and ``restarts`` is true, a coarse grid of starts is tried and the best solution returned.
    ``Trim.success`` means max |residual| < 1e-8 with n > 0.
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


def trim_hover(model=None, zeta=None) -> Trim:
    """Hover trim (V = 0); compare with ``THESIS_HOVER``."""
    return trim_level_flight(0.0, model=model, zeta=zeta)


@dataclass
class HoverWindLimit:
    """Result of :func:`hover_wind_limit`.

    ``speeds``/``trims``: the continuation samples that trimmed within the attitude limit;
    ``limit``: wind speed (m/s) at which the trim leaves it (bisected to ``tol``), ``inf`` if
    it never does up to ``max_speed``; ``reason``: what happened at the limit."""

    direction_deg: float
    attitude_limit_deg: float
    speeds: np.ndarray
    trims: list
    limit: float
    reason: str

    def attitude_deg(self) -> np.ndarray:
        """max(|φ|, |θ|) of each trim, degrees."""
        return np.array([np.degrees(np.max(np.abs(t.q[2:4]))) for t in self.trims])


def hover_wind_limit(direction_deg: float = 90.0, *, attitude_limit_deg: float = 60.0,
                     max_speed: float = 25.0, step: float = 0.5, tol: float = 0.02,
                     model=None) -> HoverWindLimit:
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


def tilt_reference_polynomial(V) -> np.ndarray:
    """The mission file's α_ref(Ub) (coefficients of Ub⁵…Ub⁰, Ub clamped to [0, 33.99])."""
    from sobolev_drake.data import load
    c = load("tiltrotor_missions")["scenario_2_full_envelope"]["tilt_reference_vs_forward_speed"]["coefficients"]
    return np.polyval(np.asarray(c, dtype=float), np.clip(np.asarray(V, dtype=float), 0.0, 33.99))


def tilt_schedule(speeds=None, model=None):
    """Level-flight trims over ``speeds`` (default 0, 1, …, 34 m/s), continuation from hover.

    Returns a list of :class:`Trim` (one per speed)."""
    model = _model(model)
    speeds = np.arange(0.0, 34.5, 1.0) if speeds is None else np.asarray(speeds, dtype=float)
    trims, guess = [], None
    for V in speeds:
        t = trim_level_flight(V, model=model, guess=guess)
        trims.append(t)
        guess = t.info["z"]
    return trims


def write_tilt_schedule_report(out_dir, trims=None):
    """Markdown + JSON table and PNG plot of the trim tilt schedule vs the mission polynomial.

    Returns (md_path, json_path, png_path)."""
    import json
    from pathlib import Path

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    trims = tilt_schedule() if trims is None else trims
    rows, guess = [], None
    for t in trims:
        a_poly = float(tilt_reference_polynomial(t.V))
        # the same speed with the tilt prescribed by the polynomial: ruddervators trim pitch
        tp = trim_level_flight(t.V, model=t.info["model"], alpha=a_poly, guess=guess) if t.V > 0 else None
        guess = tp.info["z"] if tp is not None and tp.success else None
        rows.append({"V": t.V, "alpha_trim": float(t.q[0]), "alpha_poly": a_poly,
                     "theta": float(t.q[3]), "n": float(t.n[0]), "tau_s": float(t.tau_s[0]),
                     "thrust": float(t.thrust[0]), "residual": t.residual_norm, "success": t.success,
                     "poly_trim_success": bool(tp is not None and tp.success),
                     "poly_trim_delta_e": float(tp.delta[2]) if tp is not None and tp.success else None,
                     "poly_trim_theta": float(tp.q[3]) if tp is not None and tp.success else None,
                     "poly_trim_n": float(tp.n[0]) if tp is not None and tp.success else None})

    def fmt(v, f):
        return "–" if v is None else format(v, f)
    md = ["| V [m/s] | α trim [rad] | θ [rad] | n [rev/s] | τs [N m] | f [N] | residual "
          "| α polynomial [rad] | δe on polynomial tilt [rad] | θ there | n there |",
          "|---|---|---|---|---|---|---|---|---|---|---|"]
    md += [f"| {r['V']:.0f} | {r['alpha_trim']:.4f} | {r['theta']:.4f} | {r['n']:.2f} | {r['tau_s']:.4f} | "
           f"{r['thrust']:.2f} | {r['residual']:.1e} | {r['alpha_poly']:.4f} | "
           f"{fmt(r['poly_trim_delta_e'], '.3f')} | {fmt(r['poly_trim_theta'], '.3f')} | "
           f"{fmt(r['poly_trim_n'], '.1f')} |" for r in rows]
    md_path, json_path, png_path = out / "tilt_schedule.md", out / "tilt_schedule.json", out / "tilt_schedule.png"
    md_path.write_text("# Tilt-rotor level-flight trims vs the mission tilt polynomial\n\n"
                       "Left: trims with δ = 0 (unknowns α, φ, θ, n, τs). Right: trims with the tilt "
                       "prescribed by `tilt_reference_vs_forward_speed` (unknowns δTR, δTL, φ, θ, n, τs); "
                       "the ruddervator limit is ±0.436 rad.\n\n" + "\n".join(md) + "\n")
    json_path.write_text(json.dumps(rows, indent=1))
    fig, ax = plt.subplots(1, 2, figsize=(10, 4))
    V = np.array([r["V"] for r in rows])
    ax[0].plot(V, [r["alpha_trim"] for r in rows], "o-", label="α trim (ours)")
    ax[0].plot(V, [r["alpha_poly"] for r in rows], "--", label="mission polynomial")
    ax[0].plot(V, [r["theta"] for r in rows], ":", label="θ trim")
    ax[0].plot(V, [np.nan if r["poly_trim_delta_e"] is None else r["poly_trim_delta_e"] for r in rows],
               "s-", ms=3, label="δe needed on polynomial tilt")
    ax[0].axhline(-0.4363, color="grey", lw=0.8)
    ax[0].set_xlabel("forward speed V [m/s]")
    ax[0].set_ylabel("angle [rad]")
    ax[0].legend()
    ax[0].grid(True)
    ax[1].plot(V, [r["n"] for r in rows], "o-")
    ax[1].set_xlabel("forward speed V [m/s]")
    ax[1].set_ylabel("propeller speed n [rev/s]")
    ax[1].grid(True)
    fig.tight_layout()
    fig.savefig(png_path, dpi=110)
    plt.close(fig)
    return md_path, json_path, png_path


@dataclass
class Linearization:
    """ẋ = A Δx + B Δu + D Δζ of (7.57), thesis order.

    Δx = [Δq (8); Δq̇ (8); ∫Δψ ∫Δx ∫Δy ∫Δz], Δu = [ΔnR ΔnL ΔτsR ΔτsL] (+ [Δδ] with
    ``include_surfaces``), Δζ = wind (inertial, m/s)."""

    A: np.ndarray
    B: np.ndarray
    D: np.ndarray
    trim: Trim
    state_names: list
    input_names: list

    def __iter__(self):
        """``A, B, D = linearize(...)`` unpacks the matrices."""
        return iter((self.A, self.B, self.D))


class _DerivativeEvaluator:
    """Time derivatives of the Drake diagram (plant + TiltrotorForces) at thesis-ordered inputs."""

    def __init__(self, params=None):
        from pydrake.systems.framework import DiagramBuilder
        b = DiagramBuilder()
        self.h = add_tiltrotor(b, params)
        self.diagram = b.Build()
        self.ctx = self.diagram.CreateDefaultContext()
        self.fctx = self.h.forces.GetMyMutableContextFromRoot(self.ctx)
        self.deriv = self.diagram.AllocateTimeDerivatives()

    def __call__(self, x, n, tau_s, delta, zeta):
        m = self.h.model
        self.h.set_state(self.ctx, self.diagram, x[:8], x[8:16])
        self.h.propeller_speed.FixValue(self.fctx, n)
        self.h.servo_torque.FixValue(self.fctx, tau_s)
        self.h.surface_deflection.FixValue(self.fctx, delta)
        self.h.wind.FixValue(self.fctx, zeta)
        self.diagram.CalcTimeDerivatives(self.ctx, self.deriv)
        d = self.deriv.CopyToVector()
        return np.concatenate([m.to_thesis(d[:8]), m.to_thesis(d[8:])])


_EVALUATORS: dict = {}


def linearize(trim: Trim | None = None, *, params=None, include_surfaces=False, eps=1e-6) -> Linearization:
    """Linearize the Drake diagram about ``trim`` (default: hover trim) with the integral states
    of (7.57).  Central differences of ``CalcTimeDerivatives`` (see module docstring).
    ``params``: default the parameters of the model the trim was computed on."""
    trim = trim_hover() if trim is None else trim
    params = trim.info["model"].params if params is None else params
    key = _params_key(params)           # one Drake diagram per parameter value
    if key not in _EVALUATORS:
        _EVALUATORS[key] = _DerivativeEvaluator(params)
    f = _EVALUATORS[key]
    x0 = np.concatenate([trim.q, trim.qdot])
    u0 = trim.u if include_surfaces else trim.u[:4]
    nu = u0.size

    def call(x, u, zeta):
        delta = u[4:8] if include_surfaces else trim.delta
        return f(x, u[0:2], u[2:4], delta, zeta)

    A16 = np.zeros((16, 16))
    B16 = np.zeros((16, nu))
    D16 = np.zeros((16, 3))
    for j in range(16):
        e = np.zeros(16)
        e[j] = eps
        A16[:, j] = (call(x0 + e, u0, trim.zeta) - call(x0 - e, u0, trim.zeta)) / (2 * eps)
    for j in range(nu):
        e = np.zeros(nu)
        e[j] = eps * max(1.0, abs(u0[j]))
        B16[:, j] = (call(x0, u0 + e, trim.zeta) - call(x0, u0 - e, trim.zeta)) / (2 * e[j])
    for j in range(3):
        e = np.zeros(3)
        e[j] = eps
        D16[:, j] = (call(x0, u0, trim.zeta + e) - call(x0, u0, trim.zeta - e)) / (2 * eps)
    A = np.zeros((20, 20))
    A[:16, :16] = A16
    A[16:20, [4, 5, 6, 7]] = np.eye(4)       # d/dt ∫Δψ, ∫Δx, ∫Δy, ∫Δz
    B = np.zeros((20, nu))
    B[:16] = B16
    D = np.zeros((20, 3))
    D[:16] = D16
    from sobolev_drake.tiltrotor.params import ACTUATOR_NAMES, DOF_NAMES
    states = list(DOF_NAMES) + [f"d{n}" for n in DOF_NAMES] + ["int_psi", "int_x", "int_y", "int_z"]
    inputs = ["n_PR", "n_PL", "tau_sR", "tau_sL"] + (list(ACTUATOR_NAMES[4:]) if include_surfaces else [])
    return Linearization(A=A, B=B, D=D, trim=trim, state_names=states, input_names=inputs)


if __name__ == "__main__":  # python -m sobolev_drake.tiltrotor.trim OUT_DIR
    import sys

    _trims = tilt_schedule()
    _h = _trims[0]
    print(f"hover trim: θ = {_h.q[3]:.5f}, αR = αL = {_h.q[0]:.5f}, n = {_h.n[0]:.3f} rev/s, "
          f"τs = {_h.tau_s[0]:.5f} N m, residual {_h.residual_norm:.1e}  (thesis {THESIS_HOVER})")
    for path in write_tilt_schedule_report(sys.argv[1] if len(sys.argv) > 1 else "tiltrotor_trim_out", _trims):
        print("wrote", path)
