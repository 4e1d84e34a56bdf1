"""Tables, plots and thesis claims of :mod:`sobolev_drake.experiments.tiltrotor_hover_linear`
(Table 7.2).

See docs/experiments/tiltrotor-hover-linear.md.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from sobolev_drake.experiments import Claim
from sobolev_drake.experiments._tiltrotor_linear_designs import DESIGN_SPECS

THESIS_TABLE_7_2 = {"W∞": (21.4, 2182.0), "W∞-D": (10.9, 1541.8), "W∞-O.F.": (60.7, 1376.2),
                    "W∞-O.F.D": (39.2, 1317.3)}


def plot_flights(all_data, out_dir):
    """3-D paths, tracking errors / tilt / propeller speed, and the wind of the first flight
    (PNG files in ``out_dir``); returns {name: path}."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from sobolev_drake.viz import save_figure

    out = {}
    fig = plt.figure(figsize=(7, 6))
    ax = fig.add_subplot(projection="3d")
    first = next(iter(all_data.values()))
    r = first["reference"]
    ax.plot(r[0], r[1], r[2], "k--", lw=1, label="reference")
    for i, (name, d) in enumerate(all_data.items()):
        ax.plot(d["x"][5], d["x"][6], d["x"][7], f"C{i}", lw=1, label=name)
    ax.legend()
    ax.set_xlabel("x [m]"), ax.set_ylabel("y [m]"), ax.set_zlabel("z [m]")
    out["path_3d"] = save_figure(fig, Path(out_dir) / "tiltrotor-hover-linear_path3d.png")
    fig, axes = plt.subplots(5, 1, figsize=(8, 11), sharex=True)
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
    fig, ax = plt.subplots(figsize=(8, 3))
    w = first["wind"]
    for k, a in enumerate("xyz"):
        ax.plot(first["t"], w[k], f"C{k}", lw=0.8, label=f"ζ{a}")
    ax.set_xlabel("time [s]"), ax.set_ylabel("wind [m/s]"), ax.legend()
    fig.tight_layout()
    out["wind"] = save_figure(fig, Path(out_dir) / "tiltrotor-hover-linear_wind.png")
    return out


COLUMNS = ["design", "γ (✓ certified)", "‖T_ζz‖∞", "‖T_vz‖∞", "delay margin [ms]", "synthesis [s]", "ISE", "IADU",
            "ISE (thesis)", "IADU (thesis)", "notes"]


def table_title(duration):
    """Caption of the main table."""
    return (f"Table 7.2 beside ours (duration {duration:g} s; ‖T_ζz‖∞: wind → W∞ channel, "
            f"‖T_vz‖∞: von Kármán noise → W∞ channel; delay margin: uniform delay on the four "
            f"inputs that destabilizes the linear loop)")


def gamma_cell(ctrl):
    """γ column: value, ✓ when certified, or why it is not a bound."""
    if ctrl.get("certified") is None:
        return f"{ctrl['gamma']:.4g} (solver value, not a bound)"
    if ctrl["certified"]:
        return f"{ctrl['gamma']:.4g} ✓"
    return f"{ctrl['gamma']:.4g} ✗ (‖T‖∞ = {ctrl['achieved']:.4g})"


def design_cells(name, ctrl):
    """The first columns of a synthesized design's row of :data:`COLUMNS` (design … synthesis)."""
    tau = ctrl.get("delay_margin_s")
    margin = "-" if tau is None else ("∞" if np.isinf(tau) else f"{1e3 * tau:.3g}")
    return [name, gamma_cell(ctrl), f"{ctrl['gamma_wind']:.4g}", f"{ctrl['gamma_common']:.4g}", margin,
            f"{ctrl['solve_s']:.1f}"]


SENS_COLUMNS = ["design", "flight", "RMS position [m]", "final [m]", "max |φ|,|θ| [°]",
                 "max tilt [°]", "ISE", "IADU"]


def sensitivity_row(name, m):
    """Row of the literal-noise table (:data:`SENS_COLUMNS`)."""
    if "sim_error" in m:
        return [name, "sim failed: " + m["sim_error"][:120], *["-"] * 6]
    return [name, m["stopped"] or "flies to the end", f"{m['rms_pos_m']:.2f}", f"{m['final_pos_err_m']:.2f}",
            f"{m['max_attitude_deg']:.1f}", f"{m['max_tilt_deg']:.1f}", f"{m['ise']:.1f}", f"{m['iadu']:.1f}"]


def add_claims(res, metrics, smoke):
    """Thesis claims of §7.3.1 checked on our runs (only with the full duration)."""
    base = {k: m for k, m in metrics.items() if "ise" in m}
    th = THESIS_TABLE_7_2
    def tracks(m):  # held?, measured detail
        wind = m.get("max_lateral_wind_m_s")
        return (m["finite"] and m["max_attitude_deg"] < 60 and not m.get("stopped"),
                f"RMS position {m['rms_pos_m']:.2f} m, final {m['final_pos_err_m']:.2f} m, "
                f"max |φ|,|θ| {m['max_attitude_deg']:.1f}°"
                + ("" if wind is None else f", peak lateral wind {wind:.1f} m/s"))

    for name, m in base.items():
        res.claims.append(Claim(
            f"{name}: tracks the Table 7.1 path on the nonlinear plant (finite, |φ|, |θ| < 60°)",
            *tracks(m)))
        lit = m.get("literal_noise")
        if lit and "ise" in lit:
            held, detail = tracks(lit)
            res.claims.append(Claim(
                f"{name}: tracks the path with the noise read literally (gusts ≈ 6 % of σ)", held,
                detail + (f"; {lit['stopped']}" if lit.get("stopped") else "")))
    if smoke:
        return
    for ref, dm in (("W∞", "W∞-D"), ("W∞", "W∞-D (thesis LMI)"),
                    ("W∞-O.F.", "W∞-O.F.D"), ("W∞-O.F.", "W∞-O.F.D (thesis LMI)")):
        if ref in base and dm in base and not (base[ref]["stopped"] or base[dm]["stopped"]):
            col = DESIGN_SPECS[dm][1]
            ri, ru = base[dm]["ise"] / base[ref]["ise"], base[dm]["iadu"] / base[ref]["iadu"]
            res.claims.append(Claim(
                f"{dm} has smaller ISE and IADU than {ref} (thesis {th[col][0] / th[ref][0]:.0%} / "
                f"{th[col][1] / th[ref][1]:.0%})", ri < 1 and ru < 1, f"ours {ri:.0%} / {ru:.0%}"))
    if "W∞" in base and "W∞-O.F." in base and not (base["W∞"]["stopped"] or base["W∞-O.F."]["stopped"]):
        a, b = base["W∞"], base["W∞-O.F."]
        res.claims.append(Claim("W∞-O.F. has larger ISE but smaller IADU than W∞ (thesis 60.7 vs "
                                "21.4, 1376 vs 2182)", b["ise"] > a["ise"] and b["iadu"] < a["iadu"],
                                f"ours ISE {b['ise']:.1f} vs {a['ise']:.1f}, IADU {b['iadu']:.0f} vs "
                                f"{a['iadu']:.0f}"))


