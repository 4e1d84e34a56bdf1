"""Report pieces of ``balance-linear`` (Table 6.2): figures and the evaluated claims.

See docs/experiments/balance-linear.md.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from sobolev_drake.report import ExperimentResult

from sobolev_drake.experiments._balance_linear_designs import DESIGNS, LOWER, THESIS_TABLE_6_2
from sobolev_drake.rigs.balance_linear import DISTURBANCE_START, SETTLE_FRACTION, THETA0


def plot_runs(runs: dict[str, dict[str, Any]], out_dir: str | Path) -> dict[str, Path]:
    """State/input time series (cf. Figure 6.3) and the θ settling plot (cf. Figure 6.2)."""
    from matplotlib.figure import Figure   # no pyplot: the user's backend is left alone
    from sobolev_drake.plots import save_figure
    out = {}
    fig = Figure(figsize=(11, 8))
    axes = fig.subplots(3, 2, sharex=True)
    for col, pair in enumerate((("H∞", "W∞"), ("H∞-O.F.", "W∞-O.F."))):
        for i, name in enumerate(pair):
            if name not in runs:
                continue
            d = runs[name]
            axes[0, col].plot(d["t"], d["x"][1], f"C{i}", lw=1, label=name)
            axes[1, col].plot(d["t"], d["x"][2], f"C{i}", lw=1)
            axes[2, col].plot(d["t"], d["u"][0], f"C{i}", lw=1)
        axes[0, col].legend()
        for k, lab in enumerate(("θ [rad]", "ϕ̇ [rad/s]", "u [N m]")):
            axes[k, col].set_ylabel(lab)
            axes[k, col].grid(alpha=0.3)
        axes[2, col].set_xlabel("t [s]")
    fig.suptitle("balance-linear: nonlinear two-wheeled vehicle (cf. Figure 6.3)")
    out["time_series"] = save_figure(fig, Path(out_dir) / "balance-linear_states.png", tight=True)
    fig = Figure(figsize=(7, 3.5))
    ax = fig.subplots()
    for i, name in enumerate(DESIGNS):
        if name in runs:
            d = runs[name]
            sel = d["t"] <= DISTURBANCE_START
            ax.plot(d["t"][sel], d["x"][1][sel], f"C{i}", lw=1, label=name)
    ax.axhspan(-SETTLE_FRACTION * THETA0, SETTLE_FRACTION * THETA0, color="0.85")
    ax.set_xlabel("t [s]"), ax.set_ylabel("θ [rad]"), ax.legend(), ax.grid(alpha=0.3)
    ax.set_title("settling of θ (2 % band), cf. Figure 6.2")
    out["settling"] = save_figure(fig, Path(out_dir) / "balance-linear_settling.png", tight=True)
    return out


def add_claims(res: ExperimentResult, metrics: dict[str, dict[str, Any]], *, full: bool) -> None:
    """The thesis' Table 6.2 statements (and the pole-disk constraints) evaluated on ``metrics``."""
    from sobolev_drake.experiments import Claim
    for a, b in (("H∞", "W∞"), ("H∞-O.F.", "W∞-O.F.")):
        ma, mb = metrics[a], metrics[b]
        res.claims.append(Claim(f"{b} and {a} tuned to similar θ settling time (2 %, within 10 %)",
                                abs(mb["settling_s"] - ma["settling_s"]) <= 0.1 * max(mb["settling_s"], 1e-9),
                                f"{mb['settling_s']:.3f} s vs {ma['settling_s']:.3f} s (ρ = {ma['rho']:.4g})"))
        res.claims.append(Claim(f"(robustness of the rule) {b} and {a} also settle within 10 % of each "
                                f"other with 1 % and 5 % bands",
                                all(abs(mb[k] - ma[k]) <= 0.1 * max(mb[k], 1e-9)
                                    for k in ("settling_1pct_s", "settling_5pct_s")),
                                f"1 %: {mb['settling_1pct_s']:.3f} vs {ma['settling_1pct_s']:.3f} s, "
                                f"5 %: {mb['settling_5pct_s']:.3f} vs {ma['settling_5pct_s']:.3f} s"))
        res.claims.append(Claim(f"{b} ISE θ similar to {a} (thesis {THESIS_TABLE_6_2[b][0] / THESIS_TABLE_6_2[a][0]:.0%})",
                                0.8 <= mb["ise_theta"] / ma["ise_theta"] <= 1.25,
                                f"ours {mb['ise_theta'] / ma['ise_theta']:.0%}"))
        for k, label, ti in (("ise_phidot", "ISE ϕ̇", 1), ("iadu", "IADU (control effort)", 2)):
            res.claims.append(Claim(f"{b} has lower {label} than {a} (by > {1 - LOWER:.0%}; thesis "
                                    f"{THESIS_TABLE_6_2[b][ti] / THESIS_TABLE_6_2[a][ti]:.0%})",
                                    mb[k] < LOWER * ma[k], f"ours {mb[k] / ma[k]:.0%}"))
        if full:
            res.claims.append(Claim(f"{b} has a lower empirical gain ‖x‖/‖w‖ than {a} (by > {1 - LOWER:.0%}; "
                                    f"thesis {THESIS_TABLE_6_2[b][3] / THESIS_TABLE_6_2[a][3]:.0%})",
                                    mb["gain"] < LOWER * ma["gain"], f"ours {mb['gain']:.3g} vs {ma['gain']:.3g}"))
    for name, m in metrics.items():
        res.claims.append(Claim(f"{name}: closed-loop poles of the linearization inside the disk r = {m['radius']:g}",
                                m["max_abs_eig"] <= m["radius"] * (1 + 1e-6), f"max |eig| {m['max_abs_eig']:.2f}"))
