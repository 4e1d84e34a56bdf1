"""Figures of the tilt-rotor flights: a mission (§7.3.2) and the linear hover designs (§7.3.1).

See docs/experiments/tiltrotor-hover.md, docs/experiments/tiltrotor-envelope.md and
docs/experiments/tiltrotor-hover-linear.md.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["plot_mission", "plot_hover_flights"]


def _shade_phases(axis, phases, label=False):
    """Alternate light bands over the mission phases (names on top when ``label``)."""
    for k, (name, a, b, _kind) in enumerate(phases):
        axis.axvspan(a, b, color="0.85" if k % 2 else "0.93", lw=0, zorder=0)
        if label:
            axis.text(0.5 * (a + b), 1.02, name.replace("_", " "), transform=axis.get_xaxis_transform(),
                      ha="center", va="bottom", fontsize=6.5)


def plot_mission(data: dict[str, np.ndarray], out_dir: str | os.PathLike[str], stem: str, *,
                 scenario: int | None = None, duration: float | None = None) -> dict[str, Path]:
    """PNG figures of a mission flight: 3-D path, positions, attitude, tilt angles, actuators
    with their bounds, time on bounds per actuator, wind, tracking errors and allocation
    residual; the mission's phases shaded on every time axis.

    Actuators carry one name each (:data:`~sobolev_drake.tiltrotor.mission_metrics.
    ACTUATOR_LABELS`, as in the effort table): the four surfaces are δ_WR, δ_WL (wings) and
    δ_TR, δ_TL (tail), each drawn with its full deflection range (the air-speed dependent bound
    (7.87)–(7.89) is at most that; samples on a bound are marked).

    Parameters
    ----------
    data : dict
        Logs of :func:`~sobolev_drake.tiltrotor.mission.simulate_mission`.
    out_dir : path-like
        Folder of the PNG files.
    stem : str
        File-name prefix.
    scenario : {1, 2}, optional
        The mission, for the phase bands (none without it).
    duration : float, optional
        Mission duration (s) of the phases (default: the last log time).

    Returns
    -------
    dict
        {label: path}.
    """
    from matplotlib.figure import Figure   # no pyplot: the user's backend is left alone

    from sobolev_drake.plots import save_figure
    from sobolev_drake.tiltrotor.allocation import thesis_bounds_constants
    from sobolev_drake.tiltrotor.mission import mission_phases
    from sobolev_drake.tiltrotor.mission_metrics import ACTUATOR_LABELS, ACTUATORS, effort_metrics

    t, x, ref = data["t"], data["x"], data["reference"]
    q, pr = x[:8], ref[0:4]
    tau, sat = data["tau_bar"], data["saturation"]
    phases = [] if scenario is None else mission_phases(scenario, duration or float(t[-1]))
    out = {}
    fig = Figure(figsize=(7, 6))
    ax = fig.add_subplot(projection="3d")
    ax.plot(pr[0], pr[1], pr[2], "k--", lw=1, label="reference")
    ax.plot(q[5], q[6], q[7], "C0", lw=1.5, label="W∞ + allocation")
    ax.set_xlabel("x [m]"), ax.set_ylabel("y [m]"), ax.set_zlabel("z [m]")
    ax.legend()
    out["path_3d"] = save_figure(fig, Path(out_dir) / f"{stem}_path3d.png")

    def panel(rows, title, fname):
        fig = Figure(figsize=(8, 1.9 * len(rows) + 0.8))
        axes = fig.subplots(len(rows), 1, sharex=True)
        axes = np.atleast_1d(axes)
        for k, (axis, (lab, curves)) in enumerate(zip(axes, rows)):
            _shade_phases(axis, phases, label=k == 0)
            for y, style, name in curves:
                if style == "bound":          # a bound: dashed red, no legend entry
                    axis.axhline(y, color="C3", ls=":", lw=0.9)
                else:
                    axis.plot(t, y, style, lw=1, label=name)
            axis.set_ylabel(lab)
            axis.grid(alpha=0.3)
            if sum(s != "bound" for _, s, _ in curves) > 1:
                axis.legend(fontsize=7, loc="upper right")
        axes[-1].set_xlabel("time [s]")
        axes[-1].set_xlim(t[0], t[-1])
        fig.suptitle(title + ("  (phases shaded)" if phases else ""))
        fig.tight_layout()
        return save_figure(fig, Path(out_dir) / f"{stem}_{fname}.png")

    deg = 180 / np.pi
    out["positions"] = panel([(n, [(q[5 + i], "C0", "q"), (pr[i], "k--", "ref")])
                              for i, n in enumerate(["x [m]", "y [m]", "z [m]"])],
                             "position", "positions")
    out["attitude"] = panel([("φ [deg]", [(q[2] * deg, "C0", "φ")]),
                             ("θ [deg]", [(q[3] * deg, "C0", "θ")]),
                             ("ψ [deg]", [(q[4] * deg, "C0", "ψ"), (pr[3] * deg, "k--", "ψ_r")])],
                            "attitude", "attitude")
    out["tilt"] = panel([("αR [deg]", [(q[0] * deg, "C0", "αR")]),
                         ("αL [deg]", [(q[1] * deg, "C1", "αL")])], "tilt angles", "tilt")
    _s, _c, f_lo, f_hi, t_lo, t_hi, d_lo, d_hi = thesis_bounds_constants()
    name = {k: v[0] for k, v in ACTUATOR_LABELS.items()}

    def on_bound(i, scale=1.0):      # the actuator's value where it sat on a bound, else NaN
        return np.where(np.abs(sat[i]) > 0.5, tau[i] * scale, np.nan)

    sp = data["propeller_speed"]
    rows = [("n [rev/s]", [(sp[0], "C0", name["nPR"]), (sp[1], "C1", name["nPL"])]),
            ("f [N]", [(tau[0], "C0", name["fPR"]), (tau[1], "C1", name["fPL"]),
                       (f_lo, "bound", ""), (f_hi, "bound", "")]),
            ("τs [N m]", [(tau[2], "C0", name["tauSR"]), (tau[3], "C1", name["tauSL"]),
                          (t_lo, "bound", ""), (t_hi, "bound", "")])]
    for pair in (("dWR", "dWL"), ("dTR", "dTL")):
        curves = []
        for j, key in enumerate(pair):
            i = ACTUATORS.index(key)
            curves += [(tau[i] * deg, f"C{j}", name[key]),
                       (on_bound(i, deg), f"C{j}.", f"{name[key]} on bound")]
        rows.append(("δ [deg]", curves + [(d_lo * deg, "bound", ""), (d_hi * deg, "bound", "")]))
    out["actuators"] = panel(rows, "actuators (dotted red: bounds)", "actuators")
    eff = effort_metrics(t, tau, sp, sat)
    fig = Figure(figsize=(7, 3))
    ax = fig.subplots()
    secs = [eff[k]["time_on_bound_s"] for k in ACTUATORS]
    ax.bar([name[k] for k in ACTUATORS], secs, color="C3")
    for k, v in enumerate(secs):
        ax.text(k, v, f"{v:.0f}", ha="center", va="bottom", fontsize=7)
    ax.set_ylabel("time on a bound [s]")
    ax.set_title(f"saturation time per actuator (of {t[-1] - t[0]:.0f} s)")
    fig.tight_layout()
    out["saturation"] = save_figure(fig, Path(out_dir) / f"{stem}_saturation.png")
    w, f = data["wind"], data["force"]
    out["disturbances"] = panel([("wind [m/s]", [(w[i], f"C{i}", f"ζ{a}") for i, a in enumerate("xyz")]),
                                 ("force [N]", [(f[i], f"C{i}", f"f{a}") for i, a in enumerate("xyz")])],
                                "wind and force disturbances", "disturbances")
    err = q[5:8] - pr[:3]
    out["errors"] = panel([("e [m]", [(err[i], f"C{i}", f"e{a}") for i, a in enumerate("xyz")]),
                           ("‖u*−Bτ̄‖ [N, N m]", [(data["allocation_residual"][0], "C3", "residual")])],
                          "tracking error and allocation residual", "errors")
    return out


def plot_hover_flights(all_data: dict[str, dict[str, Any]],
                       out_dir: str | os.PathLike[str]) -> dict[str, Path]:
    """3-D paths, tracking errors / tilt / propeller speed of the linear hover flights, and the
    wind of the first flight (PNG files ``tiltrotor-hover-linear_*.png``).

    Parameters
    ----------
    all_data : dict
        {design label: logs of :func:`~sobolev_drake.tiltrotor.hover_flight.simulate_design`}.
    out_dir : path-like
        Folder of the PNG files.

    Returns
    -------
    dict
        {label: path}.
    """
    from matplotlib.figure import Figure   # no pyplot: the user's backend is left alone
    from sobolev_drake.plots import save_figure

    out = {}
    fig = Figure(figsize=(7, 6))
    ax = fig.add_subplot(projection="3d")
    first = next(iter(all_data.values()))
    r = first["reference"]
    ax.plot(r[0], r[1], r[2], "k--", lw=1, label="reference")
    for i, (name, d) in enumerate(all_data.items()):
        ax.plot(d["x"][5], d["x"][6], d["x"][7], f"C{i}", lw=1, label=name)
    ax.legend()
    ax.set_xlabel("x [m]"), ax.set_ylabel("y [m]"), ax.set_zlabel("z [m]")
    out["path_3d"] = save_figure(fig, Path(out_dir) / "tiltrotor-hover-linear_path3d.png")
    fig = Figure(figsize=(8, 11))
    axes = fig.subplots(5, 1, sharex=True)
    for i, (name, d) in enumerate(all_data.items()):
        t, x, r = d["t"], d["x"], d["reference"]
        for k in range(3):
            axes[k].plot(t, x[5 + k] - r[k], f"C{i}", lw=1, label=name)
        axes[3].plot(t, np.degrees(x[0]), f"C{i}", lw=1)
        axes[4].plot(t, d["n"][0], f"C{i}", lw=1)
    for k, lab in enumerate(["e_x [m]", "e_y [m]", "e_z [m]", "αR [deg]", "nR [rev/s]"]):
        axes[k].set_ylabel(lab)
        axes[k].grid(alpha=0.3)
    axes[0].legend(fontsize=7)
    axes[-1].set_xlabel("time [s]")
    fig.tight_layout()
    out["errors"] = save_figure(fig, Path(out_dir) / "tiltrotor-hover-linear_errors.png")
    fig = Figure(figsize=(8, 3))
    ax = fig.subplots()
    w = first["wind"]
    for k, a in enumerate("xyz"):
        ax.plot(first["t"], w[k], f"C{k}", lw=0.8, label=f"ζ{a}")
    ax.set_xlabel("time [s]"), ax.set_ylabel("wind [m/s]"), ax.legend()
    fig.tight_layout()
    out["wind"] = save_figure(fig, Path(out_dir) / "tiltrotor-hover-linear_wind.png")
    return out
