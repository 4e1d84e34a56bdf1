"""Tilt-rotor missions of thesis §7.3.2: nonlinear W∞ with control allocation.

* ``tiltrotor-hover``    — scenario 1 (helicopter mode, Table 7.1 path, lateral wind, force
  pulses);
* ``tiltrotor-envelope`` — scenario 2 (take-off while accelerating, 33 m/s cruise, turn,
  deceleration and landing, head wind and gusts; flagship of ``make demo``).

The controller measures the constant wind (Assumption 19); gusts are unmeasured disturbances
(thesis footnote 8).  Tilt references come from the plant's level-flight trims or, with
``schedule="data"``, from the mission file's polynomial.  Tracking is scored per phase
against goals of our own.

See docs/experiments/tiltrotor-hover.md and docs/experiments/tiltrotor-envelope.md.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import (Adder, ConstantVectorSource, TrajectorySource,
                                        VectorLogSink)
from pydrake.trajectories import PiecewisePolynomial

from sobolev_drake.data import load
from sobolev_drake.experiments import Claim, ExperimentResult, register
from sobolev_drake.report import write_table
from sobolev_drake.systems.reference_catalogue import tiltrotor_mission_reference as mission_reference
from sobolev_drake.viz import draw_reference_and_flown as draw_paths

# --- mission bookkeeping -------------------------------------------------------------------------
HOVER, TRANSITION, CRUISE = "hover", "transition", "cruise"
# Goals we report against: RMS position error per phase kind, landing error.
GOAL_RMS = {HOVER: 1.0, TRANSITION: 3.0, CRUISE: 3.0}
GOAL_LANDING = 0.5
SMOKE_DURATION = 10.0


def scenario_1_phases(duration=200.0):
    """Phases of the Table 7.1 path.  The first 10 s are the acquisition of the path from
    q(0) = 0 (the reference starts 20 m away), reported separately and not held to a goal."""
    bounds = [("acquire", 0.0, 10.0, None), ("helix_climb", 10.0, 105.0, HOVER),
              ("translate", 105.0, 125.0, HOVER), ("descend", 125.0, 186.5, HOVER),
              ("landed_hold", 186.5, math.inf, HOVER)]
    return _clip_phases(bounds, duration)


def scenario_2_phases(duration=250.0):
    """Phases of the full-envelope mission (durations from the mission data file)."""
    kinds = {"accelerate_climb": TRANSITION, "cruise_1": CRUISE, "turn": CRUISE,
             "cruise_2": CRUISE, "decelerate_descend": TRANSITION, "hold": HOVER}
    t, bounds = 0.0, []
    for ph in load("tiltrotor_missions")["scenario_2_full_envelope"]["reference"]["phases"]:
        d = ph["duration"]
        end = math.inf if isinstance(d, str) else t + float(d)
        bounds.append((ph["name"], t, end, kinds[ph["name"]]))
        t = end
    return _clip_phases(bounds, duration)


def _clip_phases(bounds, duration):
    out = []
    for name, a, b, kind in bounds:
        if a < duration:
            out.append((name, a, min(b, duration), kind))
    return out


def pulses(events, duration):
    """Zero-order-hold 3-D profile from [{"axis", "value", "from", "to"}] events → (times, values)."""
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


def phase_metrics(t, pos, pos_ref, phases):
    """RMS and max of the 3-D position error ‖p − p_r‖ per phase (uniformly sampled logs)."""
    t = np.asarray(t)
    err = np.linalg.norm(np.asarray(pos) - np.asarray(pos_ref), axis=0)
    rows = []
    for name, a, b, kind in phases:
        m = (t >= a) & (t < b) if b < t[-1] else (t >= a)
        if not np.any(m):
            continue
        e = err[m]
        rows.append({"phase": name, "kind": kind or "-", "from_s": a, "to_s": min(b, t[-1]),
                     "rms_m": float(np.sqrt(np.mean(e**2))), "max_m": float(np.max(e)),
                     "goal_rms_m": GOAL_RMS.get(kind) if kind else None})
    for r in rows:
        r["goal_met"] = None if r["goal_rms_m"] is None else bool(r["rms_m"] < r["goal_rms_m"])
    return rows


def effort_metrics(t, tau_bar, speeds, saturation):
    """Control effort and time on actuator bounds.

    Effort: RMS of each actuator signal and IADU ∫|du/dt| dt (finite differences of the
    zero-order-hold logs).  Time on bounds: seconds during which each actuator sat on a bound.
    """
    t = np.asarray(t)
    dt = np.diff(t)
    names = ["fPR", "fPL", "tauSR", "tauSL", "dWR", "dWL", "dTR", "dTL"]
    out = {}
    for i, nm in enumerate(names):
        out[nm] = {"rms": float(np.sqrt(np.mean(tau_bar[i] ** 2))),
                   "iadu": float(np.sum(np.abs(np.diff(tau_bar[i])))),
                   "time_on_bound_s": float(np.sum(dt * (np.abs(saturation[i, :-1]) > 0.5)))}
    for i, nm in enumerate(["nPR", "nPL"]):
        out[nm] = {"rms": float(np.sqrt(np.mean(speeds[i] ** 2))),
                   "max": float(np.max(speeds[i])),
                   "iadu": float(np.sum(np.abs(np.diff(speeds[i]))))}
    return out


# --- diagram -------------------------------------------------------------------------------------
SCENARIOS = {1: "scenario_1_helicopter_mode", 2: "scenario_2_full_envelope"}
DURATIONS = {1: 200.0, 2: 250.0}


def _plant_port(handles, name):
    port = getattr(handles, name, None)
    if port is not None and hasattr(port, "get_index"):
        return port
    for sys in (handles.adapter, handles.plant):
        if sys is not None and sys.HasInputPort(name):
            return sys.GetInputPort(name)
    raise KeyError(f"tilt-rotor plant handles expose no input port {name!r}")


def build_mission(scenario, duration, *, period=0.01, schedule="plant", meshcat=None, params=None):
    """Diagram of plant + W∞ controller + mission reference, wind and force disturbances.

    Returns a dict with the diagram, handles, controller and the log sinks.
    ``schedule``: ``"plant"`` (level-flight trims of the plant model, default) or ``"data"``
    (polynomial of the mission file) for the regulated tilt references.  ``params``:
    TiltrotorParams of the plant and of the controller's model (default: the defaults).
    """
    from sobolev_drake.tiltrotor import plant as tr
    from sobolev_drake.tiltrotor import controller as tc
    from sobolev_drake.tiltrotor.law import make_law

    spec = load("tiltrotor_missions")[SCENARIOS[scenario]]
    builder = DiagramBuilder()
    handles = tr.add_tiltrotor(builder, params)
    law = make_law(handles.model, tc.thesis_inner_law(), schedule=schedule)
    ctrl = builder.AddSystem(tc.TiltrotorWInfController(law, period=period))
    ctrl.set_name("w_inf_controller")
    ref = builder.AddSystem(mission_reference(scenario))
    ref.set_name("mission_reference")
    # wind: measured constant part (Assumption 19) + unmeasured gusts (footnote 8); C++
    # primitives so the plant's every-stage wind evaluation stays cheap.
    const = builder.AddSystem(ConstantVectorSource(np.asarray(spec["constant_wind"], float)))
    tg, vg = pulses(spec.get("wind_gusts", []), duration)
    gust = builder.AddSystem(TrajectorySource(PiecewisePolynomial.ZeroOrderHold(tg, vg)))
    wind = builder.AddSystem(Adder(2, 3))
    builder.Connect(const.get_output_port(), wind.get_input_port(0))
    builder.Connect(gust.get_output_port(), wind.get_input_port(1))
    tf, vf = pulses(spec.get("force_disturbances", []), duration)
    force = builder.AddSystem(TrajectorySource(PiecewisePolynomial.ZeroOrderHold(tf, vf)))
    builder.Connect(wind.get_output_port(), _plant_port(handles, "wind"))
    builder.Connect(force.get_output_port(), _plant_port(handles, "force_disturbance"))
    builder.Connect(handles.x, ctrl.GetInputPort("x"))
    builder.Connect(ref.GetOutputPort("reference"), ctrl.GetInputPort("reference"))
    builder.Connect(const.get_output_port(), ctrl.GetInputPort("wind_measured"))
    for name in ("propeller_speed", "servo_torque", "surface_deflection"):
        builder.Connect(ctrl.GetOutputPort(name), _plant_port(handles, name))
    logs = {}
    # one log sample per controller sample: a log period of 5 controller periods gives event
    # times k·0.05 and j·0.01 that differ by an ulp at some instants, each costing the
    # integrator an extra (1e-16 s) step
    log_period = period
    for label, port in [("x", handles.x), ("reference", ref.GetOutputPort("reference")),
                        ("wind", wind.get_output_port()), ("force", force.get_output_port()),
                        ("record", ctrl.GetOutputPort("sample_record"))]:
        sink = builder.AddSystem(VectorLogSink(port.size(), log_period))
        builder.Connect(port, sink.get_input_port())
        logs[label] = sink
    recorder = None
    if meshcat is not None and handles.scene_graph is not None:
        from sobolev_drake import viz
        recorder = viz.add_meshcat_recorder(builder, handles.scene_graph, meshcat, publish_period=0.1)
    diagram = builder.Build()
    return {"diagram": diagram, "handles": handles, "controller": ctrl, "logs": logs,
            "reference": ref, "recorder": recorder, "law": law}


# --- run, score, plot ----------------------------------------------------------------------------
def simulate_mission(scenario, duration, *, schedule="plant", record=False, progress=False,
                     integrator="runge_kutta3", accuracy=1e-3, period=0.01, params=None):
    """Build, initialise (q(0) = q̇(0) = 0) and simulate; returns (built dict, logs dict).

    The integrator's maximum step is the controller period (the sampled controller's events
    bound the steps anyway)."""
    from pydrake.systems.analysis import Simulator
    from sobolev_drake.simulation import simulate

    meshcat = None
    if record:
        from sobolev_drake import viz
        meshcat = viz.start_meshcat()
    built = build_mission(scenario, duration, schedule=schedule, meshcat=meshcat, period=period,
                          params=params)
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


def plot_mission(data, out_dir, stem):
    """PNG figures: 3-D path, positions, attitude, tilt angles, propeller speeds, servo
    torques, δe/δr, wind, tracking errors and allocation residual. Returns {label: path}."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from sobolev_drake.viz import save_figure

    t, x, ref = data["t"], data["x"], data["reference"]
    q, pr = x[:8], ref[0:4]
    tau = data["tau_bar"]
    out = {}
    fig = plt.figure(figsize=(7, 6))
    ax = fig.add_subplot(projection="3d")
    ax.plot(pr[0], pr[1], pr[2], "k--", lw=1, label="reference")
    ax.plot(q[5], q[6], q[7], "C0", lw=1.5, label="W∞ + allocation")
    ax.set_xlabel("x [m]"), ax.set_ylabel("y [m]"), ax.set_zlabel("z [m]")
    ax.legend()
    out["path_3d"] = save_figure(fig, Path(out_dir) / f"{stem}_path3d.png")

    def panel(rows, title, fname):
        fig, axes = plt.subplots(len(rows), 1, figsize=(8, 1.9 * len(rows) + 0.6), sharex=True)
        axes = np.atleast_1d(axes)
        for axis, (lab, curves) in zip(axes, rows):
            for y, style, name in curves:
                axis.plot(t, y, style, lw=1, label=name)
            axis.set_ylabel(lab)
            axis.grid(alpha=0.3)
            if len(curves) > 1:
                axis.legend(fontsize=7, loc="upper right")
        axes[-1].set_xlabel("time [s]")
        fig.suptitle(title)
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
    sp = data["propeller_speed"]
    out["actuators"] = panel([("n [rev/s]", [(sp[0], "C0", "nR"), (sp[1], "C1", "nL")]),
                              ("τs [N m]", [(tau[2], "C0", "τsR"), (tau[3], "C1", "τsL")]),
                              ("δ [deg]", [(0.5 * (tau[6] + tau[7]) * deg, "C0", "δe"),
                                           (0.5 * (tau[6] - tau[7]) * deg, "C1", "δr"),
                                           (tau[4] * deg, "C2", "δWR"), (tau[5] * deg, "C3", "δWL")])],
                             "actuators", "actuators")
    w, f = data["wind"], data["force"]
    out["disturbances"] = panel([("wind [m/s]", [(w[i], f"C{i}", f"ζ{a}") for i, a in enumerate("xyz")]),
                                 ("force [N]", [(f[i], f"C{i}", f"f{a}") for i, a in enumerate("xyz")])],
                                "wind and force disturbances", "disturbances")
    err = q[5:8] - pr[:3]
    out["errors"] = panel([("e [m]", [(err[i], f"C{i}", f"e{a}") for i, a in enumerate("xyz")]),
                           ("‖u*−Bτ̄‖", [(data["allocation_residual"][0], "C3", "residual")])],
                          "tracking error and allocation residual", "errors")
    return out


def score(data, scenario, duration):
    """Metrics: per-phase errors, landing error, effort, bounds, attitude/tilt extremes."""
    t, q = data["t"], data["x"][:8]
    phases = scenario_1_phases(duration) if scenario == 1 else scenario_2_phases(duration)
    rows = phase_metrics(t, q[5:8], data["reference"][0:3], phases)
    effort = effort_metrics(t, data["tau_bar"], data["propeller_speed"], data["saturation"])
    land = float(np.linalg.norm(q[5:8, -1] - data["reference"][0:3, -1]))
    finite = bool(np.all(np.isfinite(data["x"])))
    tau, dmax = data["tau_bar"], 5 * np.pi / 36
    bounds_check = {
        "tau_within_bounds": bool(np.all(tau[:2] >= -1e-9) and np.all(tau[:2] <= 100 + 1e-9)
                                  and np.all(np.abs(tau[2:4]) <= 2 + 1e-9)
                                  and np.all(np.abs(tau[4:]) <= dmax + 1e-9)),
        "speeds_nonnegative": bool(np.all(data["propeller_speed"] >= 0)),
        "max_speed_rev_s": float(np.max(data["propeller_speed"]))}
    return {"phases": rows, "effort": effort, "final_position_error_m": land,
            "max_abs_roll_deg": float(np.degrees(np.max(np.abs(q[2])))),
            "max_abs_pitch_deg": float(np.degrees(np.max(np.abs(q[3])))),
            "tilt_range_deg": [float(np.degrees(np.min(q[:2]))), float(np.degrees(np.max(q[:2])))],
            "max_allocation_residual": float(np.max(data["allocation_residual"])),
            "rms_allocation_residual": float(np.sqrt(np.mean(data["allocation_residual"] ** 2))),
            "finite": finite, "duration_s": float(t[-1]), "bounds_check": bounds_check}


def _write_table(out_dir, stem, columns, rows, title):
    return write_table(out_dir, stem, columns, rows, title=title)


def _fmt(v, nd=2):
    return "-" if v is None else (f"{v:.{nd}f}" if isinstance(v, float) else str(v))


def schedule_table(out_dir, speeds=(0, 5, 10, 15, 20, 24, 27, 30, 33, 34)):
    """Tilt reference α(V): the plant's level-flight trims beside the mission file's polynomial."""
    from sobolev_drake.tiltrotor.trim import tilt_reference_polynomial, tilt_schedule
    rows = []
    for tr in tilt_schedule(np.asarray(speeds, dtype=float)):
        a_poly = float(tilt_reference_polynomial(tr.V))
        rows.append([f"{tr.V:g}", f"{tr.q[0]:.4f}", f"{a_poly:.4f}", f"{a_poly - tr.q[0]:+.4f}",
                     f"{tr.q[3]:.4f}", f"{tr.n[0]:.2f}"])
    return _write_table(out_dir, "tiltrotor-tilt-schedule",
                        ["V [m/s]", "α trim (plant) [rad]", "α polynomial (data) [rad]",
                         "difference [rad]", "θ trim [rad]", "n trim [rev/s]"], rows,
                        "Tilt reference: plant level-flight trims vs mission-file polynomial")


def run_mission(scenario, out_dir, *, duration=None, record=False, smoke=False,
                schedule="plant"):
    name = "tiltrotor-hover" if scenario == 1 else "tiltrotor-envelope"
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    if duration is None:
        duration = SMOKE_DURATION if smoke else DURATIONS[scenario]
    built, data = simulate_mission(scenario, duration, schedule=schedule, record=record,
                                   progress=not smoke)
    metrics = score(data, scenario, duration)
    res = ExperimentResult(name=name, metrics=metrics)
    res.outputs.update(plot_mission(data, out_dir, name))
    cols = ["phase", "kind", "from [s]", "to [s]", "RMS ‖e‖ [m]", "max ‖e‖ [m]", "goal RMS [m]",
            "goal met"]
    rows = [[r["phase"], r["kind"], _fmt(r["from_s"], 1), _fmt(r["to_s"], 1), _fmt(r["rms_m"]),
             _fmt(r["max_m"]), _fmt(r["goal_rms_m"], 1), _fmt(r["goal_met"])]
            for r in metrics["phases"]]
    md, js, text = _write_table(out_dir, f"{name}_phases", cols, rows,
                                f"{name}: position tracking per phase (duration {duration:g} s)")
    eff = metrics["effort"]
    cols2 = ["actuator", "RMS", "IADU", "time on bound [s]"]
    rows2 = [[k, _fmt(v["rms"], 3), _fmt(v["iadu"], 2), _fmt(v.get("time_on_bound_s"), 2)]
             for k, v in eff.items()]
    md2, js2, text2 = _write_table(out_dir, f"{name}_effort", cols2, rows2,
                                   f"{name}: control effort and time on actuator bounds")
    summary = (f"\nfinal position error {metrics['final_position_error_m']:.3f} m "
               f"(goal < {GOAL_LANDING} m); max |φ| {metrics['max_abs_roll_deg']:.1f}°, "
               f"max |θ| {metrics['max_abs_pitch_deg']:.1f}°, allocation residual RMS "
               f"{metrics['rms_allocation_residual']:.3g} (max {metrics['max_allocation_residual']:.3g})\n")
    res.table_markdown = text + "\n" + text2 + summary
    if scenario == 2 and not smoke:
        md3, js3, text3 = schedule_table(out_dir)
        res.outputs.update({"schedule_md": md3, "schedule_json": js3})
        res.table_markdown += (f"\ntilt reference used: {schedule!r} schedule\n\n" + text3)
    report = out_dir / f"{name}_report.md"
    report.write_text(f"# {name}\n\n" + res.table_markdown)
    (out_dir / f"{name}_metrics.json").write_text(json.dumps(metrics, indent=1))
    res.outputs.update({"phases_md": md, "phases_json": js, "effort_md": md2, "effort_json": js2,
                        "report": report, "metrics_json": out_dir / f"{name}_metrics.json"})
    for r in metrics["phases"]:
        if r["goal_met"] is not None:
            res.claims.append(Claim(f"{r['phase']} ({r['kind']}): RMS position error < "
                                    f"{r['goal_rms_m']:g} m", r["goal_met"],
                                    f"{r['rms_m']:.2f} m"))
    if not smoke and duration >= DURATIONS[scenario]:
        res.claims.append(Claim(f"final point reached within {GOAL_LANDING} m",
                                metrics["final_position_error_m"] < GOAL_LANDING,
                                f"{metrics['final_position_error_m']:.2f} m"))
    res.claims.append(Claim("attitude within ±60° and state finite",
                            metrics["finite"] and max(metrics["max_abs_roll_deg"],
                                                      metrics["max_abs_pitch_deg"]) < 60, ""))
    if record and built.get("meshcat") is not None:
        from sobolev_drake import viz
        draw_paths(built["meshcat"], built["reference"], duration, data["x"][5:8])
        # The envelope spans ~2 km: a camera rig keyed to the flown path keeps the aircraft in view.
        viz.follow_camera(built["recorder"], data["t"], data["x"][5:8].T, meshcat=built["meshcat"],
                          radius=1.5, elevation_deg=15.0, azimuth_deg=-120.0)
        html = out_dir / f"{name}.html"
        viz.save_recording_html(built["meshcat"], built["recorder"], html)
        res.outputs["recording"] = html
    return res


@register("tiltrotor-hover", "Tilt-rotor helicopter mode (Table 7.1 path), nonlinear W∞ + "
          "allocation, lateral wind and force pulses", default_duration=200.0,
          thesis_ref="7.3.2 scenario 1, Figs 7.14-7.20")
def run_hover(out_dir, *, duration=None, record=False, smoke=False):
    return run_mission(1, out_dir, duration=duration, record=record, smoke=smoke)


@register("tiltrotor-envelope", "Tilt-rotor full flight envelope: take-off, transition, 33 m/s "
          "cruise, turn, transition, landing; nonlinear W∞ + allocation with wind gusts",
          default_duration=250.0, flagship=10, thesis_ref="7.3.2 scenario 2, Figs 7.21-7.27")
def run_envelope(out_dir, *, duration=None, record=False, smoke=False, schedule="plant"):
    """``schedule``: "plant" (our level-flight trims, default) or "data" (mission-file
    polynomial, as the thesis author's simulator) for the tilt references."""
    return run_mission(2, out_dir, duration=duration, record=record, smoke=smoke,
                       schedule=schedule)
