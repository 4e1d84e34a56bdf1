"""Tilt schedule α(V) of the tilt-rotor from level-flight trims (thesis 7.3.1).

:func:`tilt_schedule` trims level flight over 0–34 m/s; :func:`tilt_reference_polynomial` is the
mission file's polynomial ``tilt_reference_vs_forward_speed`` it is compared with;
:func:`write_tilt_schedule_report` writes the comparison as a markdown/JSON table and a PNG plot
(``python -m sobolev_drake.tiltrotor.tilt_schedule OUT_DIR``).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sobolev_drake.tiltrotor.trim import THESIS_HOVER, Trim, tiltrotor_model, trim_level_flight

if TYPE_CHECKING:
    from sobolev_drake.tiltrotor.plant import TiltrotorModel

__all__ = ["tilt_reference_polynomial", "tilt_schedule", "write_tilt_schedule_report"]


def tilt_reference_polynomial(V: ArrayLike) -> NDArray[np.float64]:
    """The mission file's α_ref(Ub) (coefficients of Ub⁵…Ub⁰, Ub clamped to [0, 33.99]).

    Parameters
    ----------
    V : float or array_like
        Forward speed Ub (m/s); clamped to [0, 33.99].

    Returns
    -------
    ndarray
        Reference tilt angle α_ref (rad), shape of ``V``, from the quintic
        ``tilt_reference_vs_forward_speed`` of the ``tiltrotor_missions`` data file.
    """
    from sobolev_drake.data import load
    c = load("tiltrotor_missions")["scenario_2_full_envelope"]["tilt_reference_vs_forward_speed"]["coefficients"]
    return np.polyval(np.asarray(c, dtype=float), np.clip(np.asarray(V, dtype=float), 0.0, 33.99))


def tilt_schedule(speeds: ArrayLike | None = None, model: TiltrotorModel | None = None) -> list[Trim]:
    """Level-flight trims over ``speeds`` (default 0, 1, …, 34 m/s), continuation from hover.

    Returns a list of :class:`Trim` (one per speed).

    Parameters
    ----------
    speeds : array_like, optional
        Forward speeds V (m/s), in continuation order (each trim starts from the previous
        solution); default 0, 1, …, 34.
    model : TiltrotorModel, optional
        The model (None: :func:`tiltrotor_model` of Table B.1).

    Returns
    -------
    list of Trim
        One :func:`trim_level_flight` result per speed; the tilt angle q[0] gives α(V).
    """
    model = tiltrotor_model() if model is None else model
    speeds = np.arange(0.0, 34.5, 1.0) if speeds is None else np.asarray(speeds, dtype=float)
    trims, guess = [], None
    for V in speeds:
        t = trim_level_flight(V, model=model, guess=guess)
        trims.append(t)
        guess = t.info["z"]
    return trims


def write_tilt_schedule_report(out_dir: str | os.PathLike,
                               trims: list[Trim] | None = None) -> tuple[Path, Path, Path]:
    """Markdown + JSON table and PNG plot of the trim tilt schedule vs the mission polynomial.

    Returns (md_path, json_path, png_path).

    Parameters
    ----------
    out_dir : str or Path
        Directory for ``tilt_schedule.md``, ``.json`` and ``.png`` (created if missing).
    trims : list of Trim, optional
        Level-flight trims to report (default :func:`tilt_schedule`); each speed V > 0 is
        also trimmed with the tilt prescribed by :func:`tilt_reference_polynomial`.

    Returns
    -------
    tuple of Path
        (md_path, json_path, png_path) of the files written.
    """
    import json

    from matplotlib.figure import Figure   # no pyplot: the user's backend is left alone

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
    fig = Figure(figsize=(10, 4))
    ax = fig.subplots(1, 2)
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
    return md_path, json_path, png_path


if __name__ == "__main__":  # python -m sobolev_drake.tiltrotor.tilt_schedule OUT_DIR
    import sys

    _trims = tilt_schedule()
    _h = _trims[0]
    print(f"hover trim: θ = {_h.q[3]:.5f}, αR = αL = {_h.q[0]:.5f}, n = {_h.n[0]:.3f} rev/s, "
          f"τs = {_h.tau_s[0]:.5f} N m, residual {_h.residual_norm:.1e}  (thesis {THESIS_HOVER})")
    for path in write_tilt_schedule_report(sys.argv[1] if len(sys.argv) > 1 else "tiltrotor_trim_out", _trims):
        print("wrote", path)
