"""Meshcat recordings saved as standalone HTML, and matplotlib figures (Agg backend).

Typical use::

    meshcat = start_meshcat()                                   # free port, localhost only
    recorder = add_meshcat_recorder(builder, h.scene_graph, meshcat)
    diagram = builder.Build(); ...; simulate(diagram, context, 10.0)
    save_recording_html(meshcat, recorder, out_dir / "run.html")  # opens offline in a browser

The HTML written by ``Meshcat.StaticHtml()`` inlines the three.js viewer and the recorded
animation; it loads no external script (checked by :func:`external_script_sources`, which the
tests assert empty).  The viewer's JavaScript still *mentions* a CDN URL (WebXR controller
profiles, fetched only if the user enters VR mode), which is harmless offline.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import matplotlib

if os.environ.get("MPLBACKEND") is None:  # headless default; users may still choose their own
    matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from pydrake.geometry import Meshcat, MeshcatParams, MeshcatVisualizer, MeshcatVisualizerParams, Rgba  # noqa: E402

__all__ = [
    "start_meshcat", "add_meshcat_recorder", "save_recording_html", "external_script_sources",
    "save_figure", "plot_time_series", "draw_path",
]


def start_meshcat(*, host: str = "localhost", port: int = 0) -> Meshcat:
    """A Drake Meshcat server.  ``port=0`` asks the OS for a free ephemeral port, so parallel
    runs (CI with pytest-xdist, several experiments) never collide; ``host='localhost'`` keeps it
    off the network.  The URL is ``meshcat.web_url()``."""
    return Meshcat(MeshcatParams(host=host, port=int(port), show_stats_plot=False))


def add_meshcat_recorder(builder, scene_graph, meshcat: Meshcat, *, publish_period: float = 1 / 32,
                         live: bool = False) -> MeshcatVisualizer:
    """Add a MeshcatVisualizer for ``scene_graph`` and start recording its frames.

    ``live=False`` (default) records without streaming every frame to connected browsers (faster
    in batch runs); the animation is published by :func:`save_recording_html`.
    """
    if scene_graph is None:
        raise ValueError("scene_graph is None: build the plant with a DiagramBuilder to get geometry")
    if not publish_period > 0:
        raise ValueError(f"publish_period must be positive, got {publish_period}")
    params = MeshcatVisualizerParams()
    params.publish_period = float(publish_period)
    vis = MeshcatVisualizer.AddToBuilder(builder, scene_graph, meshcat, params)
    vis.StartRecording(set_transforms_while_recording=bool(live))
    return vis


_SCRIPT_SRC = re.compile(r"<script[^>]*\bsrc\s*=\s*[\"']?(https?:)?//", re.IGNORECASE)
_LINK_HREF = re.compile(r"<link[^>]*\bhref\s*=\s*[\"']?(https?:)?//", re.IGNORECASE)


def external_script_sources(html: str) -> list[str]:
    """The ``<script src=…>`` / ``<link href=…>`` tags of ``html`` pointing at http(s) or //."""
    tags = []
    for pattern in (_SCRIPT_SRC, _LINK_HREF):
        for m in pattern.finditer(html):
            end = html.find(">", m.start())
            tags.append(html[m.start(): end + 1])
    return tags


def save_recording_html(meshcat: Meshcat, recorder: MeshcatVisualizer, path) -> Path:
    """Stop the recording, publish it as Meshcat's animation, write ``meshcat.StaticHtml()``.

    Returns the path.  Raises ``RuntimeError`` if the page would load an external script.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    recorder.StopRecording()
    recorder.PublishRecording()
    html = meshcat.StaticHtml()
    bad = external_script_sources(html)
    if bad:
        raise RuntimeError(f"Meshcat StaticHtml references external resources: {bad[:3]}")
    path.write_text(html, encoding="utf-8")
    return path


def draw_path(meshcat: Meshcat, name: str, points, rgba=(0.1, 0.4, 1.0, 1.0), *, line_width: float = 2.0) -> None:
    """Draw a polyline (e.g. a reference path) at meshcat path ``/paths/<name>``.

    ``points`` is (N, 3) (or (3, N)), inertial frame.
    """
    P = np.asarray(points, dtype=float)
    if P.ndim != 2 or 3 not in P.shape:
        raise ValueError(f"points must be (N, 3) or (3, N), got shape {P.shape}")
    if P.shape[1] == 3 and P.shape[0] != 3:
        P = P.T  # Meshcat wants 3 × N
    if not np.all(np.isfinite(P)):
        raise ValueError("points must be finite")
    if P.shape[1] < 2:
        raise ValueError("points needs at least 2 points")
    if len(rgba) != 4:
        raise ValueError(f"rgba must have 4 entries, got {rgba!r}")
    meshcat.SetLine(f"/paths/{name}", P, line_width, Rgba(*map(float, rgba)))


def save_figure(fig, path, *, dpi: int = 110, tight: bool = False) -> Path:
    """Save a matplotlib figure as PNG (creating folders) and close it.

    ``tight=True`` crops to the drawn artists (``bbox_inches="tight"``, an extra draw pass)."""
    path = Path(path)
    if path.suffix.lower() not in (".png", ".svg", ".pdf"):
        raise ValueError(f"path must end in .png, .svg or .pdf, got {path.name!r}")
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=dpi, bbox_inches="tight" if tight else None)
    plt.close(fig)
    return path


def plot_time_series(t, series: dict, path, *, title: str = "", xlabel: str = "t [s]",
                     ylabels: dict | None = None, labels: dict | None = None,
                     references: dict | None = None, vlines=()) -> Path:
    """One stacked subplot per entry of ``series`` ({panel name: (N,) or (N, k) array}).

    ``labels[name]`` gives the k line labels, ``ylabels[name]`` the axis label,
    ``references[name]`` a same-shaped array drawn dashed (e.g. the reference trajectory),
    ``vlines`` times marked by thin vertical lines (phase switches, disturbance edges).
    """
    t = np.asarray(t, dtype=float)
    if t.ndim != 1:
        raise ValueError(f"t must be 1-D, got shape {t.shape}")
    if not series:
        raise ValueError("series is empty")
    ylabels, labels, references = ylabels or {}, labels or {}, references or {}
    fig, axes = plt.subplots(len(series), 1, sharex=True, figsize=(8, 2.2 * len(series) + 0.6), squeeze=False)
    for ax, (name, y) in zip(axes[:, 0], series.items()):
        y = np.asarray(y, dtype=float)
        y = y[:, None] if y.ndim == 1 else y
        if y.shape[0] != t.size:
            raise ValueError(f"series[{name!r}] has {y.shape[0]} samples, t has {t.size}")
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
