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

Framing the vehicle (Meshcat's default camera sits at (0, −3, 1) m looking at the origin, so a
vehicle 2 m up or 2 km away is out of view)::

    frame_camera(meshcat, target=[0, 0, 2], radius=1.0)          # static view of a 1 m object
    t, p = trajectory_from_log(logger.FindLog(context), indices=(5, 6, 7))  # or plant=, body=
    follow_camera(recorder, t, p, meshcat=meshcat, radius=1.5)   # camera rides along
    save_recording_html(meshcat, recorder, out_dir / "run.html")

``follow_camera`` writes the translation p(t) − p(t₀) of the camera rig ``/Cameras/default``
into the recording (one keyframe per animation frame) and points the camera at p(t₀).  Mouse
orbit/zoom/pan keep working while the animation plays: the user's view offset rides along with
the vehicle.  Meshcat's viewer alone would not do this (three.js OrbitControls keep the camera
position in the rig frame but aim at the target as a *world* point, so a translated rig keeps
staring at the start point); :func:`save_recording_html` therefore adds a short inline script
(:data:`FOLLOW_CAMERA_JS`) that aims at the target expressed in the rig frame, only when the
recording animates the rig.  Checked in headless Chromium (screenshots at several playback
times) on a 2 km straight flight and on 60 s of the tilt-rotor envelope mission: the vehicle
stays centred; without the script it is out of view after 3 s of the 2 km flight.  Call ``follow_camera``
after the simulation and before ``save_recording_html``, and pass ``meshcat=`` so the initial
view is centred on p(t₀).  The recorder's frame rate is 1/publish_period.  Caveat: a browser
connected *live* to the Meshcat server receives the rig animation without the script (the
camera then aims at the start point); the saved HTML is the intended replay.

Tilt-rotor missions (thesis state q = [αR αL φ θ ψ x y z], z up, Drake world frame)::

    follow_camera(built["recorder"], data["t"], data["x"][5:8].T, meshcat=built["meshcat"],
                  radius=1.5, elevation_deg=15.0, azimuth_deg=-120.0)
"""

from __future__ import annotations

import os
import re
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from sobolev_drake.recording_html import animates_path, external_script_sources  # noqa: E402
from sobolev_drake.validation import describe, index_tuple, real_array, real_scalar, real_vector  # noqa: E402
from pydrake.geometry import (Meshcat, MeshcatAnimation, MeshcatParams, MeshcatVisualizer,  # noqa: E402
                              MeshcatVisualizerParams, Rgba, SceneGraph)
from pydrake.math import RigidTransform  # noqa: E402
from pydrake.multibody.plant import MultibodyPlant  # noqa: E402
from pydrake.multibody.tree import RigidBody  # noqa: E402
from pydrake.systems.framework import DiagramBuilder  # noqa: E402
from pydrake.systems.primitives import VectorLog  # noqa: E402

from sobolev_drake.systems.references import TrajectoryReference  # noqa: E402

__all__ = [
    "start_meshcat", "add_meshcat_recorder", "save_recording_html",
    "draw_path", "draw_reference_and_flown",
    "frame_camera", "camera_position", "follow_camera", "trajectory_from_log",
    "FOLLOW_CAMERA_PATH", "FOLLOW_CAMERA_JS",
]


# what MeshcatParams.host accepts: "" (Drake's default) or "*" (every interface), a host name,
# an IPv4 or a bracket-free IPv6 address
_HOST = re.compile(r"|\*|[A-Za-z0-9_](?:[A-Za-z0-9_.-]*[A-Za-z0-9_])?|[0-9A-Fa-f:.]*:[0-9A-Fa-f:.]*")


def start_meshcat(*, host: str = "localhost", port: int = 0) -> Meshcat:
    """A Drake Meshcat server.  ``port=0`` asks the OS for a free ephemeral port, so parallel
    runs (CI with pytest-xdist, several experiments) never collide; ``host='localhost'`` keeps it
    off the network.  The URL is ``meshcat.web_url()``.

    Parameters
    ----------
    host : str, default "localhost"
        Interface the server listens on: a host name or IP address of this machine, or "*"
        for every interface.
    port : int, default 0
        0 (any free port) or a port in [1024, 65535].

    Returns
    -------
    pydrake.geometry.Meshcat
        The server (stats plot hidden).

    Raises
    ------
    RuntimeError
        If the server cannot listen there (a host that is not this machine, a port in use);
        the message names the host and port.
    """
    if isinstance(port, bool) or not isinstance(port, (int, np.integer)) or not (port == 0 or 1024 <= port <= 65535):
        raise ValueError(f"port must be 0 (any free port) or an integer in [1024, 65535], got {port!r}")
    if not isinstance(host, str):
        raise TypeError(f"host must be a host name or IP address string, got {host!r}")
    if not _HOST.fullmatch(host):
        raise ValueError(f"host must be a host name or IP address (e.g. 'localhost', "
                         f"'127.0.0.1', or '*' for every interface), got {host!r}")
    try:
        return Meshcat(MeshcatParams(host=host, port=int(port), show_stats_plot=False))
    except RuntimeError as err:   # e.g. a name that does not resolve, or a port in use
        where = "any free port" if port == 0 else f"port {int(port)}"
        raise RuntimeError(f"Meshcat could not listen on host {host!r}, {where} ({err}); check "
                           "that the host is an address of this machine and the port is free"
                           ) from None


def add_meshcat_recorder(builder: DiagramBuilder, scene_graph: SceneGraph, meshcat: Meshcat, *,
                         publish_period: float = 1 / 32,
                         live: bool = False) -> MeshcatVisualizer:
    """Add a MeshcatVisualizer for ``scene_graph`` and start recording its frames.

    ``live=False`` (default) records without streaming every frame to connected browsers (faster
    in batch runs); the animation is published by :func:`save_recording_html`.

    Parameters
    ----------
    builder : DiagramBuilder
        Builder of the diagram holding ``scene_graph``.
    scene_graph : SceneGraph
        The geometry to draw (not None).
    meshcat : Meshcat
        Server, e.g. from :func:`start_meshcat`.
    publish_period : float, default 1/32
        Positive publish (and recording) period in seconds.
    live : bool, default False
        Also send the transforms to the browsers while recording.

    Returns
    -------
    MeshcatVisualizer
        The visualizer, recording.
    """
    if scene_graph is None:
        raise ValueError("scene_graph is None: build the plant with a DiagramBuilder to get geometry")
    publish_period = real_scalar("publish_period", publish_period, low=0.0, low_open=True)
    params = MeshcatVisualizerParams()
    params.publish_period = float(publish_period)
    vis = MeshcatVisualizer.AddToBuilder(builder, scene_graph, meshcat, params)
    vis.StartRecording(set_transforms_while_recording=bool(live))
    return vis


def save_recording_html(meshcat: Meshcat, recorder: MeshcatVisualizer,
                        path: str | os.PathLike[str]) -> Path:
    """Stop the recording, publish it as Meshcat's animation, write ``meshcat.StaticHtml()``.

    Raises ``RuntimeError`` if the page would load an external script.  When the recording
    animates the camera rig (:func:`follow_camera`), :data:`FOLLOW_CAMERA_JS` is added to the
    page.

    Parameters
    ----------
    meshcat : Meshcat
        The server the recording was made on.
    recorder : MeshcatVisualizer
        The recording visualizer from :func:`add_meshcat_recorder`.
    path : str or Path
        Output HTML file (parent folders are created).

    Returns
    -------
    Path
        ``path``.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    recorder.StopRecording()
    recorder.PublishRecording()
    html = meshcat.StaticHtml()
    bad = external_script_sources(html)
    if bad:
        raise RuntimeError(f"Meshcat StaticHtml references external resources: {bad[:3]}")
    if animates_path(html, FOLLOW_CAMERA_PATH):
        html = _inject_follow_script(html)
    path.write_text(html, encoding="utf-8")
    return path


def draw_path(meshcat: Meshcat, name: str, points: ArrayLike,
              rgba: Sequence[float] = (0.1, 0.4, 1.0, 1.0), *, line_width: float = 2.0) -> None:
    """Draw a polyline (e.g. a reference path) at meshcat path ``/paths/<name>``.

    Parameters
    ----------
    meshcat : Meshcat
        The server.
    name : str
        Last element of the scene path ``/paths/<name>``.
    points : array_like, shape (N, 3) or (3, N)
        At least 2 finite points, inertial frame.
    rgba : sequence of 4 float, default (0.1, 0.4, 1.0, 1.0)
        Colour, entries in [0, 1].
    line_width : float, default 2.0
        Positive line width.
    """
    P = real_array("points", points)
    if P.ndim != 2 or 3 not in P.shape:
        raise ValueError(f"points must be (N, 3) or (3, N), got shape {P.shape}")
    if P.shape[1] == 3 and P.shape[0] != 3:
        P = P.T  # Meshcat wants 3 × N
    if not np.all(np.isfinite(P)):
        raise ValueError("points must be finite")
    if P.shape[1] < 2:
        raise ValueError("points needs at least 2 points")
    color = real_vector("rgba", rgba, 4)
    if np.any((color < 0) | (color > 1)):
        raise ValueError(f"rgba entries must be in [0, 1], got {tuple(rgba)}")
    line_width = real_scalar("line_width", line_width, low=0.0, low_open=True)
    if not isinstance(meshcat, Meshcat):
        raise TypeError(f"meshcat must be a pydrake Meshcat (e.g. from start_meshcat()), got "
                        f"{type(meshcat).__name__}")
    meshcat.SetLine(f"/paths/{name}", P, line_width, Rgba(*color.tolist()))


FOLLOW_CAMERA_PATH = "/Cameras/default"
_MESHCAT_FOV_DEG = 75.0  # vertical field of view of Meshcat's default perspective camera

# Inline script added by save_recording_html when the recording animates the camera rig.
# OrbitControls compute the camera position as target + offset in the camera's parent frame but
# call Object3D.lookAt(target), which takes a world point; aiming at the target mapped through
# the parent's world matrix makes orbiting consistent inside a moving rig (a no-op for a rig at
# the origin).  Re-applied on every render, so a camera replaced later is patched as well.
FOLLOW_CAMERA_JS = """<script>
// sobolev_drake.viz.follow_camera: aim the camera at the orbit target expressed in the frame of
// the (animated) camera rig /Cameras/default, so the view follows the recorded vehicle.
(function () {
  function patch() {
    var cam = viewer.camera;
    if (!cam || cam.sobolevFollow) { return; }
    var lookAt = cam.lookAt;
    cam.lookAt = function (v) {
      if (v && v.isVector3 && this.parent) {
        this.parent.updateWorldMatrix(true, false);
        return lookAt.call(this, this.parent.localToWorld(v.clone()));
      }
      return lookAt.apply(this, arguments);
    };
    cam.sobolevFollow = true;
  }
  var render = viewer.render;
  viewer.render = function () { patch(); return render.apply(viewer, arguments); };
})();
</script>
"""


def _point(name: str, v) -> np.ndarray:
    a = real_array(name, v).reshape(-1)
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be a finite 3-vector (x, y, z) in Drake's world frame, "
                         f"got {describe(v)}")
    return a


def camera_position(target: ArrayLike, *, distance: float | None = None, radius: float = 1.0,
                    elevation_deg: float = 20.0, azimuth_deg: float = -90.0) -> np.ndarray:
    """Camera location looking at ``target`` (world frame, z up) from ``distance`` metres.

    Parameters
    ----------
    target : array_like, shape (3,)
        Point looked at, world frame.
    distance : float, optional
        Camera distance from ``target`` in metres.  None fits a sphere of ``radius`` into
        Meshcat's 75° vertical field of view with a 20 % margin.
    radius : float, default 1.0
        Radius of the sphere to fit when ``distance`` is None.
    elevation_deg : float, default 20.0
        Elevation above the horizontal, in (−90, 90).
    azimuth_deg : float, default -90.0
        Azimuth about +z from +x (−90°: camera on the −y side, Meshcat's default direction).

    Returns
    -------
    ndarray, shape (3,)
        The camera position, world frame.
    """
    target = _point("target", target)
    if distance is None:
        radius = real_scalar("radius", radius, low=0.0, low_open=True)
        distance = 1.2 * radius / np.sin(np.radians(_MESHCAT_FOV_DEG / 2))
    distance = real_scalar("distance", distance, low=0.0, low_open=True)
    elevation_deg = real_scalar("elevation_deg", elevation_deg, low=-90.0, high=90.0,
                                low_open=True, high_open=True)
    azimuth_deg = real_scalar("azimuth_deg", azimuth_deg)
    el, az = np.radians(elevation_deg), np.radians(azimuth_deg)
    return target + float(distance) * np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])


def frame_camera(meshcat: Meshcat, target: ArrayLike, **view: float | None) -> np.ndarray:
    """Static view: put Meshcat's camera at :func:`camera_position` (same keywords) looking at
    ``target`` (also the orbit centre).  Resets the rig ``/Cameras/default`` to the origin.

    Parameters
    ----------
    meshcat : Meshcat
        The server.
    target : array_like, shape (3,)
        Point looked at, world frame.
    **view
        ``distance``, ``radius``, ``elevation_deg``, ``azimuth_deg`` of
        :func:`camera_position`.

    Returns
    -------
    ndarray, shape (3,)
        The camera position.
    """
    cam = camera_position(target, **view)
    meshcat.SetCameraPose(cam, _point("target", target))
    return cam


def _trajectory(times, positions) -> tuple[np.ndarray, np.ndarray]:
    t = np.asarray(times, dtype=float)
    P = np.asarray(positions, dtype=float)
    if t.ndim != 1 or t.size < 1:
        raise ValueError(f"times must be a non-empty 1-D array, got shape {t.shape}")
    if P.ndim == 2 and P.shape == (3, t.size) and t.size != 3:
        P = P.T  # accept (3, N) logs as well
    if P.shape != (t.size, 3):
        raise ValueError(f"positions must be (N, 3) (or (3, N)) with N = len(times) = {t.size}, got shape {P.shape}")
    if not np.all(np.isfinite(t)):
        raise ValueError("times must be finite")
    if np.any(np.diff(t) < 0):
        raise ValueError("times must be non-decreasing")
    bad = ~np.all(np.isfinite(P), axis=1)
    if np.any(bad):
        raise ValueError(f"positions must be finite: {int(bad.sum())} non-finite rows, first at t = {t[bad][0]:g}")
    return t, P


def follow_camera(recorder: MeshcatVisualizer | MeshcatAnimation, times: ArrayLike,
                  positions: ArrayLike, *, meshcat: Meshcat | None = None, follow_axes: str = "xyz",
                  **view: float | None) -> int:
    """Write a follow camera into a recording: the rig ``/Cameras/default`` is translated by
    p(t) − p(t₀) at every animation frame in [t₀, t_end] (positions linearly interpolated).

    Call after simulating, before :func:`save_recording_html`.

    Parameters
    ----------
    recorder : MeshcatVisualizer or MeshcatAnimation
        The recording visualizer from :func:`add_meshcat_recorder` (or its animation).
    times : array_like, shape (N,)
        Non-decreasing sample times.
    positions : array_like, shape (N, 3) or (3, N)
        World positions p(t) at ``times``, e.g. from :func:`trajectory_from_log`.
    meshcat : Meshcat, optional
        When given, the camera is first placed by :func:`frame_camera` around p(t₀) with
        ``view``.
    follow_axes : str, default "xyz"
        The followed world axes (``"xy"`` keeps the camera height).
    **view
        ``distance``, ``radius``, ``elevation_deg``, ``azimuth_deg`` for :func:`frame_camera`.

    Returns
    -------
    int
        Number of keyframes written (frames in [t₀, t_end] at the animation's frames per
        second, as in Drake's recorder).
    """
    anim = recorder.get_mutable_recording() if hasattr(recorder, "get_mutable_recording") else recorder
    if not hasattr(anim, "SetTransform") or not hasattr(anim, "frames_per_second"):
        raise TypeError(f"recorder must be a recording MeshcatVisualizer or a MeshcatAnimation, got {type(recorder).__name__}")
    t, P = _trajectory(times, positions)
    if not follow_axes or set(follow_axes) - set("xyz"):
        raise ValueError(f"follow_axes must be a non-empty subset of 'xyz', got {follow_axes!r}")
    mask = np.array([a in follow_axes for a in "xyz"], dtype=float)
    fps, start = float(anim.frames_per_second()), float(anim.start_time())
    f0 = max(0, int(np.ceil((t[0] - start) * fps - 1e-6)))
    f1 = int(np.floor((t[-1] - start) * fps + 1e-6))
    if f1 < f0:
        raise ValueError(f"times span [{t[0]:g}, {t[-1]:g}] s contains no animation frame (fps {fps:g}, start {start:g})")
    frames = np.arange(f0, f1 + 1)
    tf = np.clip(start + frames / fps, t[0], t[-1])
    Pf = np.column_stack([np.interp(tf, t, P[:, i]) for i in range(3)])
    if meshcat is not None:
        frame_camera(meshcat, P[0], **view)
    for f, p in zip(frames, Pf):
        anim.SetTransform(int(f), FOLLOW_CAMERA_PATH, RigidTransform(mask * (p - P[0])))
    return int(frames.size)


def trajectory_from_log(log: VectorLog | tuple[ArrayLike, ArrayLike], *,
                        indices: Sequence[int] | None = None, plant: MultibodyPlant | None = None,
                        body: RigidBody | str | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(times (N,), positions (N, 3)) for :func:`follow_camera` from a logged signal.

    Give either ``indices`` or ``plant`` and ``body``.

    Parameters
    ----------
    log : VectorLog or (t, data)
        A Drake ``VectorLog`` (``logger.FindLog(context)``) or a pair with ``data`` shaped
        (size, N) like ``VectorLog.data()``.
    indices : sequence of 3 int, optional
        The rows holding x, y, z (e.g. (5, 6, 7) of the tilt-rotor's thesis state
        [αR αL φ θ ψ x y z …], (3, 4, 5) of the quadrotor's).
    plant : MultibodyPlant, optional
        With ``body``: ``log`` holds the plant's positions or state
        (``plant.get_state_output_port()``) and the body origin is computed by forward
        kinematics.
    body : Body or str, optional
        The body (or its name) whose origin is followed.

    Returns
    -------
    times : ndarray, shape (N,)
    positions : ndarray, shape (N, 3)
    """
    if hasattr(log, "sample_times"):
        t, data = np.asarray(log.sample_times(), float), np.asarray(log.data(), float)
    else:
        try:
            t, data = (np.asarray(a, float) for a in log)
        except (TypeError, ValueError) as e:
            raise TypeError("log must be a VectorLog or a (times, data) pair") from e
    if data.ndim != 2 or data.shape[1] != t.size:
        raise ValueError(f"log data must be (size, N) with N = {t.size} samples, got shape {data.shape}")
    if (indices is None) == (plant is None):
        raise ValueError("give either indices=(ix, iy, iz) or plant= and body=")
    if indices is not None:
        idx = list(index_tuple("indices", indices, data.shape[0]))
        if len(idx) != 3 or min(idx) < -data.shape[0] or max(idx) >= data.shape[0]:
            raise ValueError(f"indices must be 3 rows of the {data.shape[0]}-row log, got {indices!r}")
        return t, data[idx].T.copy()
    if body is None:
        raise ValueError("body is required with plant= (a Body or a body name)")
    b = plant.GetBodyByName(body) if isinstance(body, str) else body
    nq = plant.num_positions()
    if data.shape[0] not in (nq, nq + plant.num_velocities()):
        raise ValueError(f"log rows ({data.shape[0]}) must be the plant's positions ({nq}) or state "
                         f"({nq + plant.num_velocities()})")
    ctx = plant.CreateDefaultContext()
    P = np.empty((t.size, 3))
    for k in range(t.size):
        plant.SetPositions(ctx, data[:nq, k])
        P[k] = plant.EvalBodyPoseInWorld(ctx, b).translation()
    return t, P


# --- reading the recorded commands back (tests, claims) -------------------------------------------
def _inject_follow_script(html: str) -> str:
    anchor = html.rfind("</body>")
    if anchor < 0:
        raise RuntimeError("Meshcat StaticHtml has no </body>: cannot add the follow-camera script")
    return html[:anchor] + FOLLOW_CAMERA_JS + html[anchor:]


def draw_reference_and_flown(meshcat: Meshcat, traj_ref: TrajectoryReference, duration: float,
                             flown: ArrayLike) -> None:
    """Draw a reference path (black) and the flown path (blue) in Meshcat.

    Parameters
    ----------
    meshcat : Meshcat
    traj_ref : TrajectoryReference
        Its first three coordinates are the reference position.
    duration : float
        Time span of the reference to draw (s).
    flown : array_like, shape (3, N)
        Flown positions.
    """
    ts = np.linspace(0.0, duration, max(int(duration * 5), 50))
    pts = np.array([traj_ref.evaluate(t)[0][:3] for t in ts])
    draw_path(meshcat, "reference", pts, rgba=(0.05, 0.05, 0.05, 1.0))
    draw_path(meshcat, "flown", np.asarray(flown).T, rgba=(0.1, 0.4, 1.0, 1.0))
