"""The tilt-rotor missions of thesis §7.3.2: phases, disturbance profiles, diagram and flight.

A mission is the plant, the nonlinear W∞ controller with allocation
(:class:`~sobolev_drake.tiltrotor.controller.TiltrotorWInfController`), the mission reference
and the wind and force disturbances of the mission file (``tiltrotor_missions.json``), built
by :func:`build_mission` and flown by :func:`simulate_mission`.  The controller measures the
constant wind (Assumption 19); gusts are unmeasured disturbances (thesis footnote 8).

See docs/experiments/tiltrotor-hover.md and docs/experiments/tiltrotor-envelope.md.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, TrajectorySource
from pydrake.trajectories import PiecewisePolynomial

from sobolev_drake.data import load
from sobolev_drake.models.base import check_vector
from sobolev_drake.harness import add_log_sinks
from sobolev_drake.systems.reference_catalogue import tiltrotor_mission_reference as mission_reference

if TYPE_CHECKING:
    from pydrake.geometry import Meshcat

    from sobolev_drake.tiltrotor.params import TiltrotorParams

__all__ = ["HOVER", "TRANSITION", "CRUISE", "SCENARIOS", "DURATIONS", "scenario_1_phases",
           "scenario_2_phases", "mission_phases", "pulses", "build_mission", "simulate_mission"]

#: phase kinds (each has its own tracking goal)
HOVER, TRANSITION, CRUISE = "hover", "transition", "cruise"
#: scenario number -> its entry of the mission file
SCENARIOS = {1: "scenario_1_helicopter_mode", 2: "scenario_2_full_envelope"}
#: scenario number -> full mission duration (s)
DURATIONS = {1: 200.0, 2: 250.0}


def scenario_1_phases(duration: float = 200.0) -> list[tuple[str, float, float, str | None]]:
    """Phases of the Table 7.1 path.

    The first 10 s are the acquisition of the path from q(0) = 0 (the reference starts 20 m
    away), reported separately and not held to a goal.

    Parameters
    ----------
    duration : float, default 200
        Mission duration (s): later phases are dropped, the last one is clipped.

    Returns
    -------
    list of (str, float, float, str or None)
        (name, start, end, kind) of each phase.
    """
    bounds = [("acquire", 0.0, 10.0, None), ("helix_climb", 10.0, 105.0, HOVER),
              ("translate", 105.0, 125.0, HOVER), ("descend", 125.0, 186.5, HOVER),
              ("landed_hold", 186.5, math.inf, HOVER)]
    return _clip_phases(bounds, duration)


def scenario_2_phases(duration: float = 250.0) -> list[tuple[str, float, float, str | None]]:
    """Phases of the full-envelope mission (durations from the mission data file).

    Parameters
    ----------
    duration : float, default 250
        Mission duration (s): later phases are dropped, the last one is clipped.

    Returns
    -------
    list of (str, float, float, str)
        (name, start, end, kind) of each phase.
    """
    kinds = {"accelerate_climb": TRANSITION, "cruise_1": CRUISE, "turn": CRUISE,
             "cruise_2": CRUISE, "decelerate_descend": TRANSITION, "hold": HOVER}
    t, bounds = 0.0, []
    for ph in load("tiltrotor_missions")["scenario_2_full_envelope"]["reference"]["phases"]:
        d = ph["duration"]
        end = math.inf if isinstance(d, str) else t + float(d)
        bounds.append((ph["name"], t, end, kinds[ph["name"]]))
        t = end
    return _clip_phases(bounds, duration)


def mission_phases(scenario: int, duration: float) -> list[tuple[str, float, float, str | None]]:
    """Phases of mission ``scenario`` up to ``duration``.

    Parameters
    ----------
    scenario : {1, 2}
        The mission.
    duration : float
        Mission duration (s).

    Returns
    -------
    list of (str, float, float, str or None)
        :func:`scenario_1_phases` or :func:`scenario_2_phases`.
    """
    return scenario_1_phases(duration) if scenario == 1 else scenario_2_phases(duration)


def _clip_phases(bounds, duration):
    out = []
    for name, a, b, kind in bounds:
        if a < duration:
            out.append((name, a, min(b, duration), kind))
    return out


def pulses(events: list[dict[str, Any]],
           duration: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Zero-order-hold 3-D profile of pulse events.

    Parameters
    ----------
    events : list of dict
        ``{"axis": "x"|"y"|"z", "value", "from", "to"}``; overlapping pulses add up.
    duration : float
        End of the profile (s).

    Returns
    -------
    (ndarray, ndarray)
        Knot times and the (3, n) values held from each knot.
    """
    axis = {"x": 0, "y": 1, "z": 2}
    knots = sorted({0.0, float(duration)} | {float(e[k]) for e in events for k in ("from", "to")
                                               if float(e[k]) <= duration})
    knots = [k for k in knots if k <= duration]
    values = np.zeros((3, len(knots)))
    for j, tk in enumerate(knots):
        for e in events:
            if float(e["from"]) <= tk < float(e["to"]):
                values[axis[e["axis"]], j] += float(e["value"])
    return np.array(knots), values


def _plant_port(handles, name):
    port = getattr(handles, name, None)
    if port is not None and hasattr(port, "get_index"):
        return port
    for sys in (handles.adapter, handles.plant):
        if sys is not None and sys.HasInputPort(name):
            return sys.GetInputPort(name)
    raise KeyError(f"tilt-rotor plant handles expose no input port {name!r}")


def build_mission(scenario: int, duration: float, *, period: float = 0.01, schedule: str = "plant",
                  meshcat: Meshcat | None = None, params: TiltrotorParams | None = None,
                  plant_params: TiltrotorParams | None = None,
                  wind_gusts: list[dict[str, Any]] | None = None,
                  force_disturbances: list[dict[str, Any]] | None = None, design: str = "thesis",
                  constant_wind: ArrayLike | None = None,
                  smooth_reference: float | None = None) -> dict[str, Any]:
    """Diagram of plant + W∞ controller + mission reference, wind and force disturbances.

    Parameters
    ----------
    scenario : {1, 2}
        The mission (:data:`SCENARIOS`).
    duration : float
        Length of the disturbance profiles (s).
    period : float, default 0.01
        Controller sample period (s); also the log period.
    schedule : str, default "plant"
        Regulated tilt references: ``"plant"`` (level-flight trims of the plant model) or
        ``"data"`` (polynomial of the mission file).
    meshcat : Meshcat, optional
        Given, a recorder is added.
    params : TiltrotorParams, optional
        Parameters of the plant and of the controller's model (default: the defaults).
    plant_params : TiltrotorParams, optional
        Given, the flown plant has these parameters while the controller keeps the model of
        ``params`` (a perturbed truth, e.g. a Monte-Carlo case).
    wind_gusts, force_disturbances : list of dict, optional
        Pulse events (:func:`pulses`) replacing the mission file's.
    design : {"thesis", "scheduled"}, default "thesis"
        The law's weighting (:data:`~sobolev_drake.tiltrotor.law.DESIGNS`).
    constant_wind : array_like, shape (3,), optional
        Constant (measured) wind, inertial m/s, replacing the mission file's.
    smooth_reference : float, optional
        Given, the half-window h (s) of a C² smootherstep blend of the reference at every
        phase junction (:func:`~sobolev_drake.systems.reference_smoothing.smooth_junctions`;
        h below half the shortest phase).  Default None: the tabulated reference, with its
        velocity/acceleration steps, for both designs (the thesis row and the scheduled
        design's published numbers are flown without smoothing).

    Returns
    -------
    dict
        ``diagram``, ``handles``, ``controller``, ``logs`` (sinks by label), ``reference``,
        ``recorder``, ``law``.
    """
    from sobolev_drake.tiltrotor import controller as tc
    from sobolev_drake.tiltrotor import plant as tr
    from sobolev_drake.tiltrotor.law import make_law

    spec = load("tiltrotor_missions")[SCENARIOS[scenario]]
    builder = DiagramBuilder()
    if plant_params is None:
        handles = tr.add_tiltrotor(builder, params)
        model = handles.model
    else:  # perturbed truth; the controller's model keeps the nominal parameters
        from sobolev_drake.tiltrotor.trim import tiltrotor_model
        handles = tr.add_tiltrotor(builder, plant_params)
        model = tiltrotor_model(params)
    law = make_law(model, tc.thesis_inner_law(), schedule=schedule, design=design)
    ctrl = builder.AddSystem(tc.TiltrotorWInfController(law, period=period))
    ctrl.set_name("w_inf_controller")
    ref = builder.AddSystem(mission_reference(scenario, smooth_reference))
    ref.set_name("mission_reference")
    # wind: measured constant part (Assumption 19) + unmeasured gusts (footnote 8), both in one
    # zero-order-hold profile (the sums an Adder of the two would form, to the bit) so that
    # the force system's every-stage read is one C++ source
    if constant_wind is None:
        constant_wind = spec["constant_wind"]
    measured = check_vector("constant_wind", constant_wind, 3)
    const = builder.AddSystem(ConstantVectorSource(measured))
    tg, vg = pulses(spec.get("wind_gusts", []) if wind_gusts is None else wind_gusts, duration)
    wind = builder.AddSystem(TrajectorySource(PiecewisePolynomial.ZeroOrderHold(
        tg, measured[:, None] + vg)))
    wind.set_name("wind")
    tf, vf = pulses(spec.get("force_disturbances", []) if force_disturbances is None
                    else force_disturbances, duration)
    force = builder.AddSystem(TrajectorySource(PiecewisePolynomial.ZeroOrderHold(tf, vf)))
    builder.Connect(wind.get_output_port(), _plant_port(handles, "wind"))
    builder.Connect(force.get_output_port(), _plant_port(handles, "force_disturbance"))
    builder.Connect(handles.x, ctrl.GetInputPort("x"))
    builder.Connect(ref.GetOutputPort("reference"), ctrl.GetInputPort("reference"))
    builder.Connect(const.get_output_port(), ctrl.GetInputPort("wind_measured"))
    # the three commands through one port: the force system's actuator-input record then reads
    # one port per sample instead of three
    builder.Connect(ctrl.GetOutputPort("actuator_command"), handles.u)
    # one log sample per controller sample: a log period of 5 controller periods gives event
    # times k·0.05 and j·0.01 that differ by an ulp at some instants, each costing the
    # integrator an extra (1e-16 s) step
    logs = add_log_sinks(builder, [("x", handles.x), ("reference", ref.GetOutputPort("reference")),
                                   ("wind", wind.get_output_port()), ("force", force.get_output_port()),
                                   ("record", ctrl.GetOutputPort("sample_record"))], period)
    recorder = None
    if meshcat is not None and handles.scene_graph is not None:
        from sobolev_drake import viz
        recorder = viz.add_meshcat_recorder(builder, handles.scene_graph, meshcat, publish_period=0.1)
    diagram = builder.Build()
    return {"diagram": diagram, "handles": handles, "controller": ctrl, "logs": logs,
            "reference": ref, "recorder": recorder, "law": law}


def simulate_mission(scenario: int, duration: float, *, schedule: str = "plant", record: bool = False,
                     progress: bool = False, integrator: str = "runge_kutta3", accuracy: float = 1e-3,
                     period: float = 0.01, params: TiltrotorParams | None = None,
                     plant_params: TiltrotorParams | None = None,
                     wind_gusts: list[dict[str, Any]] | None = None,
                     force_disturbances: list[dict[str, Any]] | None = None, design: str = "thesis",
                     constant_wind: ArrayLike | None = None, smooth_reference: float | None = None
                     ) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """Build, initialise (q(0) = q̇(0) = 0) and simulate a mission.

    The integrator's maximum step is the controller period (the sampled controller's events
    bound the steps anyway).

    Parameters
    ----------
    scenario : {1, 2}
        The mission.
    duration : float
        Simulated time (s).
    schedule : str, default "plant"
        Tilt references (:func:`build_mission`).
    record : bool, default False
        Record in a new Meshcat (``built["meshcat"]``, ``built["recorder"]``).
    progress : bool, default False
        Print the simulation's progress.
    integrator : str, default "runge_kutta3"
        Integrator name of :func:`sobolev_drake.simulation.simulate`.
    accuracy : float, default 1e-3
        Its target accuracy.
    period : float, default 0.01
        Controller sample period (s).
    params : TiltrotorParams, optional
        Plant and controller-model parameters.
    plant_params : TiltrotorParams, optional
        Parameters of the flown plant only (:func:`build_mission`).
    wind_gusts, force_disturbances : list of dict, optional
        Pulse events replacing the mission file's (:func:`build_mission`).
    design : {"thesis", "scheduled"}, default "thesis"
        The law's weighting (:func:`build_mission`).
    constant_wind : array_like, shape (3,), optional
        Constant measured wind replacing the mission file's (:func:`build_mission`).
    smooth_reference : float, optional
        Half-window (s) of the junction smoothing of the reference (:func:`build_mission`).

    Returns
    -------
    (dict, dict)
        The built dict of :func:`build_mission` (plus ``simulator`` and ``meshcat``) and the
        logs (``t``, ``x``, ``reference``, ``wind``, ``force`` and the controller's record
        split into its named signals), trimmed to a common length.
    """
    from pydrake.systems.analysis import Simulator

    from sobolev_drake.simulation import simulate

    meshcat = None
    if record:
        from sobolev_drake import viz
        meshcat = viz.start_meshcat()
    built = build_mission(scenario, duration, schedule=schedule, meshcat=meshcat, period=period,
                          params=params, plant_params=plant_params, wind_gusts=wind_gusts,
                          force_disturbances=force_disturbances, design=design,
                          constant_wind=constant_wind, smooth_reference=smooth_reference)
    diagram = built["diagram"]
    sim = Simulator(diagram)
    ctx = sim.get_mutable_context()
    built["handles"].set_state(ctx, diagram, np.zeros(8), np.zeros(8))
    simulate(diagram, ctx, duration, progress=progress, label=f"tilt-rotor scenario {scenario}",
             integrator=integrator, accuracy=accuracy, max_step=period, simulator=sim)
    data = {"t": built["logs"]["x"].FindLog(ctx).sample_times().copy()}
    for k, sink in built["logs"].items():
        data[k] = sink.FindLog(ctx).data().copy()
    data.update(built["controller"].split_record(data.pop("record")))
    n = min(v.shape[-1] for v in data.values())
    data = {k: v[..., :n] for k, v in data.items()}
    built["simulator"], built["meshcat"] = sim, meshcat
    return built, data
