"""Figures of flights of :class:`~sobolev_drake.rigs.quadrotor_hover.QuadrotorHoverRig`: the
3-D path, attitude and disturbances (cf. thesis Figure 6.5), and the rotor speeds."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["plot_flights"]


def plot_flights(runs: dict[str, dict[str, Any]], out_dir: str | os.PathLike[str],
                 name: str) -> dict[str, Path]:
    """Write ``<name>_path3d.png``, ``<name>_attitude.png`` and ``<name>_inputs.png``.

    Parameters
    ----------
    runs : dict
        Legend label → result of ``QuadrotorHoverRig.run`` (the first one's reference is drawn).
    out_dir : path-like
        Output directory.
    name : str
        File name prefix (the experiment's name).

    Returns
    -------
    dict
        ``path_3d``, ``attitude``, ``inputs``: the written paths.
    """
    from matplotlib.figure import Figure   # no pyplot: the user's backend is left alone
    from sobolev_drake.plots import save_figure
    out = {}
    fig = Figure(figsize=(7, 6))
    ax = fig.add_subplot(projection="3d")
    first = next(iter(runs.values()))
    ax.plot(*first["x_ref"][3:6], "k--", lw=1, label="reference (Table 6.3)")
    for i, (label, d) in enumerate(runs.items()):
        ax.plot(*d["x"][3:6], f"C{i}", lw=1, label=label)
    ax.set_xlabel("x [m]"), ax.set_ylabel("y [m]"), ax.set_zlabel("z [m]"), ax.legend()
    out["path_3d"] = save_figure(fig, Path(out_dir) / f"{name}_path3d.png")
    fig = Figure(figsize=(8, 9))
    axes = fig.subplots(4, 1, sharex=True)
    for i, (label, d) in enumerate(runs.items()):
        for k, lab in enumerate("ϕθψ"):
            axes[k].plot(d["t"], np.degrees(d["x"][k]), f"C{i}", lw=1, label=label if k == 0 else None)
            axes[k].set_ylabel(f"{lab} [deg]")
        axes[3].plot(d["t"], d["w"][4], "C2", lw=1, label="δy" if i == 0 else None)
        axes[3].plot(d["t"], d["w"][5], "C3", lw=1, label="δz" if i == 0 else None)
    axes[3].set_ylabel("disturbance [N]"), axes[3].set_xlabel("t [s]")
    for a in axes:
        a.grid(alpha=0.3)
    axes[0].legend(fontsize=7), axes[3].legend(fontsize=7)
    fig.suptitle("attitude and disturbances (cf. Figure 6.5)")
    out["attitude"] = save_figure(fig, Path(out_dir) / f"{name}_attitude.png", tight=True)
    fig = Figure(figsize=(8, 3 * len(runs)))
    axes = fig.subplots(len(runs), 1, sharex=True, squeeze=False)
    for i, (label, d) in enumerate(runs.items()):
        for k in range(4):
            axes[i, 0].plot(d["t"], np.sqrt(np.maximum(d["u"][k], 0)), lw=0.8, label=f"Ω{k + 1}")
        axes[i, 0].set_ylabel(f"{label}: Ω [rad/s]"), axes[i, 0].legend(fontsize=7, ncol=4)
        axes[i, 0].grid(alpha=0.3)
    axes[-1, 0].set_xlabel("t [s]")
    out["inputs"] = save_figure(fig, Path(out_dir) / f"{name}_inputs.png", tight=True)
    return out
