"""Figures of experiments and examples: matplotlib, written as PNG.

The figures are built with :class:`matplotlib.figure.Figure` directly, not through pyplot, so
drawing and saving them needs no GUI backend and importing the package leaves the user's
matplotlib backend alone.

:func:`plot_time_series` stacks named signals over time, :func:`compare_plot` overlays several
logged runs panel by panel, :func:`plot_semilogy` and :func:`plot_paths_3d` draw positive
signals on a log axis and flown paths in 3-D; :func:`save_figure` writes and closes any figure.
Meshcat recordings are in :mod:`sobolev_drake.viz`.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike
from matplotlib.figure import Figure

from sobolev_drake.validation import describe, mapping, path_like, real_array, sequence

__all__ = ["save_figure", "plot_time_series", "compare_plot", "plot_semilogy", "plot_paths_3d"]


def save_figure(fig: Figure, path: str | os.PathLike[str], *, dpi: int = 110,
                tight: bool = False) -> Path:
    """Save a matplotlib figure (creating folders) and close it.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure; closed afterwards.
    path : str or Path
        Output file; its suffix (``.png``, ``.svg`` or ``.pdf``) selects the format.
    dpi : int, default 110
        Resolution.
    tight : bool, default False
        Crop to the drawn artists (``bbox_inches="tight"``, an extra draw pass).

    Returns
    -------
    Path
        ``path``.
    """
    path = _figure_path(path)
    if not hasattr(fig, "savefig"):
        raise TypeError(f"fig must be a matplotlib Figure, got {type(fig).__name__}")
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=dpi, bbox_inches="tight" if tight else None)
    pyplot = sys.modules.get("matplotlib.pyplot")   # a figure of pyplot's own is released too;
    if pyplot is not None:                          # without pyplot none can be its
        pyplot.close(fig)
    return path


def _figure_path(path) -> Path:
    """``path`` as a Path ending in .png, .svg or .pdf (checked before a figure is drawn)."""
    path = path_like("path", path)
    if path.suffix.lower() not in (".png", ".svg", ".pdf"):
        raise ValueError(f"path must end in .png, .svg or .pdf, got {path.name!r}")
    return path


def compare_plot(path: str | os.PathLike[str], runs: dict,
                 panels: Sequence[tuple[str, Callable[[Any], ArrayLike], Sequence[str] | None]], *,
                 title: str = "", vlines: Sequence[float] = ()) -> Path:
    """Stacked panels overlaying several logged runs (one line style per run, one colour per
    component).

    Parameters
    ----------
    path : str or Path
        PNG file to write.
    runs : dict
        {name: run}; each run has "t" and whatever the panels read.
    panels : sequence of (str, callable, list of str or None)
        (y label, ``fn(run) -> (N,) or (N, k)`` array, component labels).
    title : str
        Figure title.
    vlines : sequence of float
        Times marked by light vertical lines (e.g. disturbance windows).

    Returns
    -------
    Path
    """
    _figure_path(path)
    mapping("runs", runs, "{name: run}")
    panels = sequence("panels", panels, "(y label, fn(run), component labels) triples")
    if not panels:
        raise ValueError("panels must contain at least one (y label, fn(run), labels) triple")
    for k, panel in enumerate(panels):
        if isinstance(panel, (str, bytes)) or len(sequence(f"panels[{k}]", panel)) != 3:
            raise ValueError(f"panels[{k}] must be a (y label, fn(run), component labels) "
                             f"triple, got {panel!r}")
    for name, run in runs.items():
        if not hasattr(run, "__getitem__") or isinstance(run, (str, bytes)) \
                or (isinstance(run, Mapping) and "t" not in run):
            raise ValueError(f"runs[{name!r}] must be a run with sample times 't' (e.g. a dict "
                             f"with keys 't' and the logged signals), got {describe(run)}")
    fig = Figure(figsize=(8, 1.9 * len(panels) + 0.8))
    axes = fig.subplots(len(panels), 1, sharex=True, squeeze=False)
    styles = ["-", "--", ":", "-."]
    for ax, (ylabel, fn, labels) in zip(axes[:, 0], panels):
        for k, (name, run) in enumerate(runs.items()):
            y = np.asarray(fn(run), dtype=float)
            y = y[:, None] if y.ndim == 1 else y
            for j in range(y.shape[1]):
                lab = f"{name} {labels[j]}" if labels else name
                ax.plot(run["t"], y[:, j], styles[k % 4], lw=1.0, color=f"C{j}", label=lab)
        for v in vlines:
            ax.axvline(v, color="0.75", lw=0.6)
        ax.set_ylabel(ylabel)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=6, ncol=4, loc="upper right")
    axes[-1, 0].set_xlabel("t [s]")
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return save_figure(fig, path)


def plot_semilogy(path: str | os.PathLike[str], curves: dict, *, ylabel: str, xlabel: str = "t [s]",
                  floor: float = 1e-12) -> Path:
    """Several positive signals on one logarithmic axis (values below ``floor`` drawn at it).

    Parameters
    ----------
    path : str or Path
        PNG file to write.
    curves : dict
        {label: (x, y)}.
    ylabel, xlabel : str
        Axis labels.
    floor : float
        Smallest value drawn.

    Returns
    -------
    Path
    """
    _figure_path(path)
    mapping("curves", curves, "{label: (x, y)}")
    for name, xy in curves.items():
        if isinstance(xy, (str, bytes)) or not hasattr(xy, "__len__") or len(xy) != 2:
            raise ValueError(f"curves[{name!r}] must be an (x, y) pair of arrays, got {describe(xy)}")
    fig = Figure(figsize=(8, 2.8))
    ax = fig.subplots()
    for k, (name, (x, y)) in enumerate(curves.items()):
        ax.semilogy(x, np.maximum(y, floor), ["-", "--"][k % 2], lw=1.0, label=name)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    return save_figure(fig, path)


def _positions(name, value) -> np.ndarray:
    """``value`` as an (N, 3) float array (NaN gaps allowed: matplotlib breaks the line)."""
    arr = real_array(name, value)
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ValueError(f"{name} must have shape (N, 3) (one x, y, z row per sample), got {arr.shape}")
    return arr


def plot_paths_3d(path: str | os.PathLike[str], reference: ArrayLike, flown: dict) -> Path:
    """A reference path (dotted black) and flown paths in 3-D.

    Parameters
    ----------
    path : str or Path
        PNG file to write.
    reference : array_like
        (N, 3) reference positions.
    flown : dict
        {label: (N, 3) positions}.

    Returns
    -------
    Path
    """
    _figure_path(path)
    ref = _positions("reference", reference)
    flown = {name: _positions(f"flown[{name!r}]", xyz)
             for name, xyz in mapping("flown", flown, "{label: (N, 3) positions}").items()}
    fig = Figure(figsize=(6, 5))
    ax = fig.add_subplot(projection="3d")
    ax.plot(ref[:, 0], ref[:, 1], ref[:, 2], "k:", lw=1.0, label="reference")
    for k, (name, xyz) in enumerate(flown.items()):
        ax.plot(xyz[:, 0], xyz[:, 1], xyz[:, 2], ["-", "--"][k % 2], lw=1.0, label=name)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")
    ax.legend(fontsize=7)
    fig.tight_layout()
    return save_figure(fig, path)


def plot_time_series(t: ArrayLike, series: dict, path: str | os.PathLike[str], *, title: str = "",
                     xlabel: str = "t [s]",
                     ylabels: dict | None = None, labels: dict | None = None,
                     references: dict | None = None, vlines: Sequence[float] = ()) -> Path:
    """One stacked subplot per entry of ``series`` ({panel name: (N,) or (N, k) array}).

    Parameters
    ----------
    t : array_like, shape (N,)
        Sample times.
    series : dict
        {panel name: (N,) or (N, k) array}, one panel each, in order.
    path : str or Path
        Output image (see :func:`save_figure`).
    title : str, optional
        Figure title.
    xlabel : str, default "t [s]"
        Label of the shared time axis.
    ylabels : dict, optional
        {panel name: axis label} (default: the panel name).
    labels : dict, optional
        {panel name: the k line labels}.
    references : dict, optional
        {panel name: array shaped like the series}, drawn dashed in the same colours (e.g. the
        reference trajectory).
    vlines : sequence of float, optional
        Times marked by thin vertical lines (phase switches, disturbance edges).

    Returns
    -------
    Path
        The saved figure's path.
    """
    _figure_path(path)
    t = np.asarray(t, dtype=float)
    if t.ndim != 1:
        raise ValueError(f"t must be 1-D, got shape {t.shape}")
    if not mapping("series", series, "{panel name: (N,) or (N, k) array}"):
        raise ValueError("series is empty")
    ylabels, labels, references = ylabels or {}, labels or {}, references or {}
    checked = {}
    for name, y in series.items():   # before the figure exists (nothing left open on an error)
        y = real_array(f"series[{name!r}]", y)
        y = y[:, None] if y.ndim == 1 else y
        if y.ndim != 2:
            raise ValueError(f"series[{name!r}] must have shape (N,) or (N, k), got {y.shape}")
        if y.shape[0] != t.size:
            raise ValueError(f"series[{name!r}] has {y.shape[0]} samples, t has {t.size}")
        checked[name] = y
    fig = Figure(figsize=(8, 2.2 * len(series) + 0.6))
    axes = fig.subplots(len(series), 1, sharex=True, squeeze=False)
    for ax, (name, y) in zip(axes[:, 0], checked.items()):
        names = labels.get(name) or ([name] if y.shape[1] == 1 else [f"{name}[{i}]" for i in range(y.shape[1])])
        lines = ax.plot(t, y)
        for line, lab in zip(lines, names):
            line.set_label(str(lab))
        if name in references:
            r = np.asarray(references[name], dtype=float)
            r = r[:, None] if r.ndim == 1 else r
            for i, line in enumerate(lines[: r.shape[1]]):
                ax.plot(t, r[:, i], "--", color=line.get_color(), lw=1.0)
        for v in vlines:
            ax.axvline(float(v), color="0.7", lw=0.6)
        ax.set_ylabel(ylabels.get(name, name))
        ax.grid(True, alpha=0.3)
        if y.shape[1] <= 8:
            ax.legend(loc="upper right", fontsize=7, ncol=min(4, y.shape[1]))
    axes[-1, 0].set_xlabel(xlabel)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return save_figure(fig, path)


# --- camera framing -----------------------------------------------------------------------------
