"""Flights of the linear hover controllers on the nonlinear tilt-rotor (thesis §7.3.1).

The Table 7.1 path in von Kármán wind from q(0) = :data:`Q0` (:func:`simulate_design`), the
initial error the transient-regularized designs minimize (:func:`initial_error`), the
literal reading of the thesis' turbulence noise (:func:`literal_noise_turbulence`) and the
Table 7.2 indices of a flight (:func:`flight_indices`).

See docs/experiments/tiltrotor-hover-linear.md.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource

from sobolev_drake.harness import add_log_sinks, collect_logs
from sobolev_drake.tiltrotor.linear_controller import LinearHoverController, check_velocity_reference

if TYPE_CHECKING:
    from pydrake.geometry import Meshcat

    from sobolev_drake.synthesis.controller import DynamicController
    from sobolev_drake.synthesis.problem import SynthesisResult
    from sobolev_drake.systems.references import TrajectoryReference
    from sobolev_drake.systems.wind import VonKarmanParameters
    from sobolev_drake.tiltrotor.params import TiltrotorParams
    from sobolev_drake.tiltrotor.trim import Trim

__all__ = ["Q0", "hover_reference", "initial_error", "literal_noise_turbulence", "simulate_design",
           "flight_indices", "literal_noise_flight"]

#: q(0) = [αR αL φ θ ψ x y z] of the flights: 1 m beside and below the start of the path
Q0 = np.array([0, 0, 0, 0, 0, -1.0, 20.0, 0])


def hover_reference() -> TrajectoryReference:
    """The Table 7.1 path (scenario 1 of the mission file) as a reference system.

    Returns
    -------
    TrajectoryReference
        Output ``reference`` (12): [x y z ψ] stacked with rates and accelerations.
    """
    from sobolev_drake.systems.reference_catalogue import tiltrotor_mission_reference
    return tiltrotor_mission_reference(1)


def initial_error(trim: Trim, velocity_reference: str = "zero") -> NDArray[np.float64]:
    """Δx(0) of the flight: q(0) = :data:`Q0`, q̇(0) = 0 against the trim and the path at t = 0
    (velocity error only with ``velocity_reference="path"``); integrals 0.

    Parameters
    ----------
    trim : Trim
        The hover trim (its ``q``).
    velocity_reference : str, default "zero"
        "zero" or "path" (:data:`~sobolev_drake.tiltrotor.linear_controller.VELOCITY_REFERENCES`).

    Returns
    -------
    ndarray, shape (20,)
    """
    check_velocity_reference(velocity_reference)
    q, qd, _ = hover_reference().evaluate(0.0)
    dx = np.zeros(20)
    dx[:8] = Q0 - np.asarray(trim.q, float)
    dx[5:8] = Q0[5:8] - np.asarray(q, float)[:3]
    dx[4] = Q0[4] - float(q[3])
    if velocity_reference == "path":
        dx[13:16] = -np.asarray(qd, float)[:3]
        dx[12] = -float(qd[3])
    return dx


def literal_noise_turbulence() -> VonKarmanParameters:
    """§7.3.1 turbulence with the thesis' "unit variance, sampling time 0.01 s" noise taken
    literally: intensities scaled by √(Δt/π) (``systems/wind.py`` explains the factor).

    Returns
    -------
    VonKarmanParameters
    """
    from dataclasses import replace

    from sobolev_drake.systems.wind import hover_linear_turbulence
    p = hover_linear_turbulence()
    k = np.sqrt(p.sample_time / np.pi)
    return replace(p, sigma=tuple(float(k * v) for v in p.sigma))


def simulate_design(ctrl: SynthesisResult | DynamicController, trim: Trim, duration: float, *, seed: int = 7,
                    log_period: float = 0.01, meshcat: Meshcat | None = None,
                    turbulence: VonKarmanParameters | None = None, max_wall_s: float = 600.0,
                    controller_state0: ArrayLike | None = None, velocity_reference: str = "zero",
                    plant_params: TiltrotorParams | None = None) -> dict[str, Any]:
    """Fly ``ctrl`` on the nonlinear plant (Table 7.1 path, von Kármán wind); returns logs.

    The run stops early (``data["stopped"]`` says why, ``data["t"][-1]`` when) if the state
    stops being finite, |φ| or |θ| exceeds 90° (the linear design has lost the aircraft), or
    the wall time exceeds ``max_wall_s`` (stiff or chattering closed loop).  The plant has the
    parameters of the model ``trim`` was computed on (``crossflow``) unless ``plant_params``
    replaces them (the controller keeps the trim and the design).

    Parameters
    ----------
    ctrl : SynthesisResult or DynamicController
        A hover design (:func:`~sobolev_drake.tiltrotor.linear_design.design`) or its
        controller (:class:`~sobolev_drake.tiltrotor.linear_controller.LinearHoverController`).
    trim : Trim
        The hover trim the design linearized at (``trim.info["model"]`` gives the plant).
    duration : float
        Simulated time (s).
    seed : int, default 7
        Seed of the turbulence.
    log_period : float, default 0.01
        Sampling period of the logs (s).
    meshcat : Meshcat, optional
        Given, the run is recorded (``data["recorder"]``).
    turbulence : VonKarmanParameters, optional
        Replaces the §7.3.1 defaults (for sensitivity runs).
    max_wall_s : float, default 600
        Wall-time limit of the run (s).
    controller_state0 : array_like, optional
        Initial state of a dynamic controller (default 0).
    velocity_reference : str, default "zero"
        "zero" (Δq̇ = q̇, the thesis' q̇_r = 0) or "path" (q̇ − q̇_path).
    plant_params : TiltrotorParams, optional
        Parameters of the flown plant (default: those of ``trim.info["model"]``), e.g. a
        perturbed mass or inertia of a Monte-Carlo case.

    Returns
    -------
    dict
        Logs ``x``, ``reference``, ``du``, ``wind``, ``n``, ``ts`` and times ``t``; ``wall_s``,
        ``stopped``, ``recorder`` and the final integral states ``ctx_integrals``.
    """
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.framework import EventStatus

    from sobolev_drake.systems.wind import mission_wind_sources
    from sobolev_drake.tiltrotor.plant import add_tiltrotor

    b = DiagramBuilder()
    # the plant the trim was computed on, unless a perturbed truth is flown
    h = add_tiltrotor(b, trim.info["model"].params if plant_params is None else plant_params)
    ref = b.AddSystem(hover_reference())
    c = b.AddSystem(LinearHoverController(ctrl, trim, velocity_reference))
    (turb,) = mission_wind_sources("hover_linear", turbulence=turbulence)
    b.AddSystem(turb)
    b.Connect(turb.GetOutputPort("wind"), h.wind)
    zero = b.AddSystem(ConstantVectorSource(np.zeros(3)))
    b.Connect(zero.get_output_port(), h.force_disturbance)
    b.Connect(h.x, c.GetInputPort("x"))
    b.Connect(ref.GetOutputPort("reference"), c.GetInputPort("reference"))
    for name in ("propeller_speed", "servo_torque", "surface_deflection"):
        b.Connect(c.GetOutputPort(name), getattr(h, name))
    sinks = add_log_sinks(b, [("x", h.x), ("reference", ref.GetOutputPort("reference")),
                              ("du", c.GetOutputPort("delta_u")), ("wind", turb.GetOutputPort("wind")),
                              ("n", c.GetOutputPort("propeller_speed")),
                              ("ts", c.GetOutputPort("servo_torque"))], log_period)
    recorder = None
    if meshcat is not None and h.scene_graph is not None:
        from sobolev_drake import viz
        recorder = viz.add_meshcat_recorder(b, h.scene_graph, meshcat, publish_period=0.1)
    diagram = b.Build()
    sim = Simulator(diagram)
    ctx = sim.get_mutable_context()
    turb.seed(ctx, seed)
    h.set_state(ctx, diagram, Q0, np.zeros(8))
    if controller_state0 is not None:
        cv = c.GetMyMutableContextFromRoot(ctx).get_mutable_continuous_state_vector()
        v = cv.CopyToVector()
        if np.shape(controller_state0) != (v.size - 4,):
            raise ValueError(f"controller_state0 must have shape ({v.size - 4},), got {np.shape(controller_state0)}")
        v[4:] = controller_state0
        cv.SetFromVector(v)
    sim.get_mutable_integrator().set_target_accuracy(1e-3)
    sim.get_mutable_integrator().set_maximum_step_size(0.01)
    t0 = time.perf_counter()
    why = []

    def monitor(root_ctx):
        xs = h.x.Eval(h.x.get_system().GetMyContextFromRoot(root_ctx))
        if not np.all(np.isfinite(xs)):
            why.append("state not finite")
        elif np.max(np.abs(xs[2:4])) > np.pi / 2:
            why.append("|roll| or |pitch| > 90°")
        elif time.perf_counter() - t0 > max_wall_s:
            why.append(f"wall time > {max_wall_s:g} s")
        else:
            return EventStatus.Succeeded()
        return EventStatus.ReachedTermination(diagram, why[-1])

    sim.set_monitor(monitor)
    sim.AdvanceTo(duration)
    wall = time.perf_counter() - t0
    data = collect_logs(sinks, ctx)
    data["wall_s"] = wall
    data["stopped"] = (f"stopped at t = {ctx.get_time():.2f} s: {why[-1]}" if why else "")
    data["recorder"] = recorder
    data["ctx_integrals"] = c.GetMyContextFromRoot(ctx).get_continuous_state_vector().CopyToVector()[:4]
    return data


def flight_indices(data: dict[str, Any], trim: Trim) -> dict[str, Any]:
    """Table 7.2 indices of a flight and the tracking summary.

    ISE = ∫ΔxᵀΔx dt (20 states; integral states rebuilt from the logs by the trapezoid rule)
    and IADU = ∫Σ|dΔu/dt| dt (total variation of the logged Δu).

    Parameters
    ----------
    data : dict
        Logs of :func:`simulate_design` (``t``, ``x``, ``reference``, ``du``, optional ``wind``).
    trim : Trim
        The hover trim (its ``q``).

    Returns
    -------
    dict
        ``ise``, ``iadu``, ``ise_first_10s``, ``ise_by_group``, ``rms_pos_m``,
        ``final_pos_err_m``, ``max_tilt_deg``, ``max_attitude_deg``, ``max_lateral_wind_m_s``,
        ``finite``.
    """
    from sobolev_drake.norms import iadu, ise
    t, x, r = data["t"], data["x"], data["reference"]
    q, qd = x[:8].copy(), x[8:].copy()
    q -= np.asarray(trim.q)[:, None]
    q[5:8] -= r[0:3]
    q[4] -= r[3]
    qd[5:8] -= r[4:7]
    qd[4] -= r[7]
    e = q[[4, 5, 6, 7]]
    ints = np.concatenate([np.zeros((4, 1)), np.cumsum(0.5 * (e[:, 1:] + e[:, :-1]) * np.diff(t), axis=1)], axis=1)
    dx = np.vstack([q, qd, ints])
    per = np.asarray(ise(t, dx.T), dtype=float)
    groups = {"tilt": [0, 1], "attitude": [2, 3, 4], "position": [5, 6, 7], "rates": list(range(8, 16)),
              "integrals": [16, 17, 18, 19]}
    early = t <= min(10.0, t[-1])  # the initial-offset transient, reported separately
    ise_early = float(np.sum(ise(t[early], dx[:, early].T))) if early.sum() > 1 else 0.0
    return {"ise": float(np.sum(per)), "iadu": float(np.sum(iadu(t, data["du"].T))),
            "ise_first_10s": ise_early,
            "ise_by_group": {k: float(per[v].sum()) for k, v in groups.items()},
            "rms_pos_m": float(np.sqrt(np.mean(np.sum(q[5:8] ** 2, axis=0)))),
            "final_pos_err_m": float(np.linalg.norm(q[5:8, -1])),
            "max_tilt_deg": float(np.degrees(np.max(np.abs(x[:2])))),
            "max_attitude_deg": float(np.degrees(np.max(np.abs(x[2:4])))),  # |φ|, |θ|
            "max_lateral_wind_m_s": float(np.max(np.abs(data["wind"][1]))) if "wind" in data else None,
            "finite": bool(np.all(np.isfinite(x)))}


def literal_noise_flight(ctrl: SynthesisResult | DynamicController, trim: Trim, duration: float,
                         velocity_reference: str) -> dict[str, Any]:
    """Indices of one flight in :func:`literal_noise_turbulence` (a failed run is reported).

    Parameters
    ----------
    ctrl : SynthesisResult or DynamicController
        A hover design (:func:`simulate_design`).
    trim : Trim
        The hover trim.
    duration : float
        Simulated time (s).
    velocity_reference : str
        "zero" or "path".

    Returns
    -------
    dict
        :func:`flight_indices` with ``stopped`` and ``sim_end_s``, or ``{"sim_error": ...}``.
    """
    try:
        d = simulate_design(ctrl, trim, duration, turbulence=literal_noise_turbulence(),
                            velocity_reference=velocity_reference)
    except Exception as exc:  # the integrator gives up on a diverging loop
        return {"sim_error": f"{type(exc).__name__}: {exc}"}
    idx = flight_indices(d, trim)
    idx.update(stopped=d["stopped"], sim_end_s=float(d["t"][-1]))
    return idx
