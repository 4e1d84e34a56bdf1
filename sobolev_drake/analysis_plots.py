"""The figure of a loop analysis (:func:`~sobolev_drake.synthesis.loop_analysis.loop_analysis`).

:func:`plot_loop_analysis` draws six panels: the pole map (plant, controller, closed loop and
the warning's pole limit), singular values of S, T and KS, of the performance channel w -> z
with the certified γ, Bode magnitude and phase of the loop-at-a-time input loops with their
disk-based margins, and the step response of the performance channel.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from sobolev_drake.plots import save_figure
from sobolev_drake.synthesis.loop_analysis import LoopAnalysis

__all__ = ["plot_loop_analysis"]


def _db(x):
    with np.errstate(divide="ignore"):
        return 20 * np.log10(np.maximum(x, 1e-300))


def _poles(ax, an, pole_factor):
    for summary, marker, label in ((an.plant, "x", "plant"), (an.controller, "o", "controller"),
                                   (an.closed_loop, "+", "closed loop")):
        if summary is not None and summary.poles.size:
            ax.plot(summary.poles.real, summary.poles.imag, marker, ms=8, mfc="none", label=label)
    limit = pole_factor * an.reference_frequency
    if an.closed_loop.fastest > 0.5 * limit or (an.controller is not None
                                                and an.controller.fastest > 0.5 * limit):
        th = np.linspace(np.pi / 2, 3 * np.pi / 2, 100)
        ax.plot(limit * np.cos(th), limit * np.sin(th), "r--", lw=1, label=f"limit {limit:.3g} rad/s")
    ax.axvline(0, color="k", lw=0.6)
    ax.set_xscale("symlog", linthresh=max(an.closed_loop.slowest, 1e-3))
    ax.set_xlabel("Re λ [rad/s]")
    ax.set_ylabel("Im λ [rad/s]")
    ax.set_title("poles")
    ax.legend(fontsize=7)


def _sigmas(ax, an):
    for name, style in (("S", "-"), ("T", "--"), ("KS", ":")):
        ax.semilogx(an.omega, _db(an.sigma[name][0]), style, label=f"σ̄({name})")
    ax.axhline(0, color="k", lw=0.6)
    ax.set_xlabel("ω [rad/s]")
    ax.set_ylabel("largest singular value [dB]")
    ax.set_title("S, T, KS at the plant output")
    ax.legend(fontsize=7)


def _performance(ax, an):
    if "Tzw" not in an.sigma:
        ax.text(0.5, 0.5, "pass a GeneralizedPlant\nfor the performance channel",
                ha="center", va="center", transform=ax.transAxes)
        ax.set_axis_off()
        return
    ax.semilogx(an.omega, an.sigma["Tzw"].T, lw=1)
    if an.gamma is not None:
        ax.axhline(an.gamma, color="r", ls="--", lw=1, label=f"γ = {an.gamma:.4g}")
        ax.legend(fontsize=7)
    ax.set_xlabel("ω [rad/s]")
    ax.set_ylabel("singular values of w → z [-]")
    ax.set_title("performance channel")


def _bode(ax_mag, ax_ph, an):
    for i, L in enumerate(an.loop_gain):
        ax_mag.semilogx(an.omega, _db(np.abs(L)), label=f"L{i + 1} (input {i + 1})")
        ax_ph.semilogx(an.omega, np.degrees(np.unwrap(np.angle(L))), label=f"L{i + 1}")
    m = an.input_margins
    ax_mag.axhline(0, color="k", lw=0.6)
    ax_mag.set_ylabel("|L_i| [dB]")
    ax_mag.set_title(f"input loops: disk margin {m.multivariable_disk:.2f} "
                     f"(±{m.multivariable_gain_db:.1f} dB, ±{m.multivariable_phase_deg:.0f}°)",
                     fontsize=9)
    ax_mag.legend(fontsize=7)
    for k in range(-3, 2):
        ax_ph.axhline(-180 + 360 * k, color="k", lw=0.4, ls=":")
    ax_ph.set_xlabel("ω [rad/s]")
    ax_ph.set_ylabel("arg L_i [deg]")


def _step(ax, an):
    if an.step is None:
        ax.set_axis_off()
        return
    nz, nw, _ = an.step.shape
    for j in range(nw):
        for i in range(nz):
            ax.plot(an.t, an.step[i, j], lw=0.8)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("z [performance units]")
    ax.set_title("step responses w_j → z_i")


def plot_loop_analysis(analysis: LoopAnalysis, path: str | os.PathLike[str] | None = None, *,
                       title: str = "", pole_factor: float = 100.0) -> Figure | Path:
    """Six-panel figure of a :class:`~sobolev_drake.synthesis.loop_analysis.LoopAnalysis`.

    Parameters
    ----------
    analysis : LoopAnalysis
        What :func:`~sobolev_drake.synthesis.loop_analysis.loop_analysis` returned.
    path : str or Path, optional
        Where to write it (.png, .svg or .pdf); None returns the open figure.
    title : str
        Figure title.
    pole_factor : float
        The factor of the pole warning, to draw its limit.

    Returns
    -------
    matplotlib.figure.Figure or Path
        The figure (``path`` None) or ``path``.

    Examples
    --------
    >>> import numpy as np
    >>> import sobolev_drake as sd
    >>> A, B = np.array([[0.0, 1.0], [0.0, 0.0]]), np.array([[0.0], [1.0]])
    >>> res = sd.winf_state_feedback(A, B, B, Gamma0=[1, 1], Gamma1=[0, 1], gamma=10.0)
    >>> fig = sd.plot_loop_analysis(sd.loop_analysis(res, sd.winf_plant(A, B, D=B, Gamma0=[1, 1], Gamma1=[0, 1])))
    >>> len(fig.axes)
    6
    """
    if not hasattr(analysis, "closed_loop") or not hasattr(analysis, "sigma"):
        raise TypeError(f"analysis must be a LoopAnalysis, got {type(analysis).__name__}")
    fig = Figure(figsize=(13, 7.5))
    grid = fig.add_gridspec(2, 3)
    _poles(fig.add_subplot(grid[0, 0]), analysis, pole_factor)
    _sigmas(fig.add_subplot(grid[0, 1]), analysis)
    _performance(fig.add_subplot(grid[0, 2]), analysis)
    sub = grid[1, 0:2].subgridspec(1, 2)
    _bode(fig.add_subplot(sub[0, 0]), fig.add_subplot(sub[0, 1]), analysis)
    _step(fig.add_subplot(grid[1, 2]), analysis)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return fig if path is None else save_figure(fig, path)
