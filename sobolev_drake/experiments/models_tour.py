"""``models-tour``: every plant of the library under gravity for a few seconds, recorded.

The two-wheeled vehicle, the arm, the quadrotor and the tilt-rotor are simulated open loop and
written as standalone Meshcat replays (camera following the main body) and state plots; a
table of mechanical energy at the start and end of each run checks the Drake models against
physics (friction work, conservation, level hover, trim equilibrium).  The lowest-priority
flagship.

See docs/experiments/models-tour.md.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, LogVectorOutput

from sobolev_drake.experiments import Claim, ExperimentResult, register

DEFAULT_DURATION = 3.0
SMOKE_DURATION = 0.4
#: per model: body the camera follows, radius of the sphere to keep in view [m], followed axes
VIEWS = {"two_wheeled": ("axle", 1.0, "xy"), "arm": ("link1", 2.3, "xyz"),
         "quadrotor": ("body", 0.9, "xyz"), "tiltrotor": ("body", 1.3, "xyz")}


def viz_path() -> str:
    from sobolev_drake.viz import FOLLOW_CAMERA_PATH
    return FOLLOW_CAMERA_PATH


def _energy(plant, context) -> float:
    pc = plant.GetMyContextFromRoot(context)
    return float(plant.EvalKineticEnergy(pc) + plant.EvalPotentialEnergy(pc))


def _setups():
    """(name, add function, q0, qdot0, constant input or None, extra configuration) per model."""
    from sobolev_drake.models.arm import add_arm
    from sobolev_drake.models.quadrotor import add_quadrotor
    from sobolev_drake.models.two_wheeled import add_two_wheeled

    setups = [
        ("two_wheeled", add_two_wheeled, [0.0, 0.3], [0.0, 0.0], None),
        ("arm", add_arm, [np.pi / 4, 0.0], [0.0, 0.0], None),
        ("quadrotor", add_quadrotor, [0, 0, 0, 0, 0, 2.0], [0, 0, 0.5, 0.5, 0, 0], "hover"),
    ]
    try:  # the tilt-rotor is optional for this tour
        from sobolev_drake.tiltrotor.plant import add_tiltrotor
    except ImportError:
        add_tiltrotor = None
    if add_tiltrotor is not None:
        setups.append(("tiltrotor", add_tiltrotor, None, [0] * 8, "trim"))
    return setups


def _run_one(name, add, q0, qd0, u_mode, duration, record, out_dir):
    from sobolev_drake import plots, recording_html, viz
    from sobolev_drake.simulation import simulate

    builder = DiagramBuilder()
    h = add(builder)
    n = h.model.n
    u_const = None
    if u_mode == "trim":  # tilt-rotor: open-loop hover trim (propeller speeds, servo torques), 2 m up
        from sobolev_drake.tiltrotor.trim import trim_hover
        trim = trim_hover()
        q0 = np.array(trim.q, dtype=float)
        q0[7] = 2.0
        u_const = trim.u
        src = builder.AddSystem(ConstantVectorSource(u_const))
        builder.Connect(src.get_output_port(), h.u)
    elif u_mode == "hover":  # Ω² with B(q0) Ω² = g(q0): level hover
        B, g = h.model.B(np.asarray(q0, float)), h.model.g(np.asarray(q0, float))
        u_const, *_ = np.linalg.lstsq(B, g, rcond=None)
        src = builder.AddSystem(ConstantVectorSource(u_const))
        builder.Connect(src.get_output_port(), h.u)
    logger = LogVectorOutput(h.x, builder)
    meshcat = recorder = plant_logger = None
    if record:
        meshcat = viz.start_meshcat()
        recorder = viz.add_meshcat_recorder(builder, h.scene_graph, meshcat)
        plant_logger = LogVectorOutput(h.plant.get_state_output_port(), builder)  # for the camera
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    h.set_state(context, diagram, np.asarray(q0, float), np.asarray(qd0, float))
    if meshcat is not None and name == "quadrotor":
        from sobolev_drake.systems.reference_catalogue import trajectory
        t = np.linspace(0, 40, 400)
        viz.draw_path(meshcat, "figure8_table_5_8", trajectory("table_5_8").evaluate(t)[0][:, :3])
    e0 = _energy(h.plant, context)
    sim = simulate(diagram, context, duration, label=f"models-tour/{name}", accuracy=1e-7)
    e1 = _energy(h.plant, sim.get_context())
    log = logger.FindLog(sim.get_context())
    t, x = log.sample_times(), log.data().T
    outputs = {}
    names = list(h.model.dof_names)
    outputs[f"{name} states"] = plots.plot_time_series(
        t, {"q": x[:, :n], "qdot": x[:, n:]}, out_dir / f"{name}_states.png",
        labels={"q": names, "qdot": [f"d{s}/dt" for s in names]}, title=f"{name} under gravity (open loop)")
    camera_keyframes = 0
    if record:
        body, radius, axes = VIEWS.get(name, (None, 1.5, "xyz"))
        if body is not None:
            tb, pb = viz.trajectory_from_log(plant_logger.FindLog(sim.get_context()), plant=h.plant, body=body)
            camera_keyframes = viz.follow_camera(recorder, tb, pb, meshcat=meshcat, radius=radius,
                                                 elevation_deg=15.0, azimuth_deg=-110.0, follow_axes=axes)
        html = viz.save_recording_html(meshcat, recorder, out_dir / f"{name}.html")
        outputs[f"{name} recording"] = html
        keys = recording_html.animation_keyframes(html.read_text(encoding="utf-8")).get(viz.FOLLOW_CAMERA_PATH, {})
        camera_keyframes = min(camera_keyframes, keys.get(".position", 0))  # what the page really holds
    # work of the non-conservative generalized forces the adapter adds (friction −K(q̇))
    friction = getattr(h.model, "friction", None)
    work = 0.0
    if friction is not None and name != "tiltrotor":
        power = np.array([-friction(xk[n:]) @ xk[n:] for xk in x])
        work = float(np.trapezoid(power, t))
    return {"t": t, "x": x, "e0": e0, "e1": e1, "steps": sim.get_num_steps_taken(), "n": n,
            "u": u_const, "outputs": outputs, "work": work, "camera_keyframes": camera_keyframes}


@register("models-tour", "Every plant (two-wheeled, arm, quadrotor, tilt-rotor) under gravity, "
          "recorded to standalone HTML, with energy checks", default_duration=DEFAULT_DURATION,
          flagship=1, thesis_ref="models of (4.30), (5.119), (5.123), section 7.2")
def run(out_dir: str | Path, *, duration: float | None = None, record: bool = True,
        smoke: bool = False) -> ExperimentResult:
    from sobolev_drake.report import write_table

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    T = float(duration) if duration is not None else (SMOKE_DURATION if smoke else DEFAULT_DURATION)
    result = ExperimentResult("models-tour")
    rows = []
    for name, add, q0, qd0, u_mode in _setups():
        r = _run_one(name, add, q0, qd0, u_mode, T, record, out_dir)
        result.outputs.update(r["outputs"])
        rel = (r["e1"] - r["e0"]) / max(abs(r["e0"]), 1.0)
        rows.append([name, r["n"], T, r["e0"], r["e1"], rel, r["work"], r["steps"]])
        result.metrics[f"{name}_energy_change_rel"] = rel
        if record:
            result.metrics[f"{name}_camera_keyframes"] = r["camera_keyframes"]
            expected = int(np.floor(T * 32 + 1e-6)) + 1  # recorder at 32 frames/s over [0, T]
            result.claims.append(Claim(f"{name} recording: follow camera keyed at every animation frame",
                                       r["camera_keyframes"] == expected,
                                       f"{r['camera_keyframes']} keyframes on {viz_path()} (expected {expected})"))
        x = r["x"]
        if name == "arm":
            result.claims.append(Claim("arm without friction or input conserves energy (|ΔE|/E < 1e-3)",
                                       abs(rel) < 1e-3, f"ΔE/E = {rel:.2e}"))
        elif name == "two_wheeled":
            dE = r["e1"] - r["e0"]
            err = abs(dE - r["work"]) / max(abs(r["e0"]), 1.0)
            result.claims.append(Claim("two-wheeled vehicle: ΔE equals the work of the thesis friction "
                                       "K(q̇) = [kϕ̇, −kϕ̇] (|ΔE − W|/E < 1e-3)", err < 1e-3,
                                       f"ΔE = {dE:.3e} J, W = {r['work']:.3e} J"))
        elif name == "tiltrotor":
            drift = float(np.max(np.linalg.norm(x[:, 5:8] - x[0, 5:8], axis=1)))
            result.metrics["tiltrotor_trim_drift_m"] = drift
            result.claims.append(Claim("tilt-rotor: the hover trim (thesis 7.3.1) is an equilibrium of "
                                       f"the Drake diagram (drift < 1 mm over {T:g} s open loop)", drift < 1e-3,
                                       f"max position drift {drift:.2e} m"))
        elif name == "quadrotor":
            dz = float(np.max(np.abs(x[:, 5] - x[0, 5])))
            tilt = float(np.max(np.abs(x[:, :2])))
            result.claims.append(Claim("quadrotor: Ω² = B⁺g keeps altitude and level attitude "
                                       "while drifting and yawing", dz < 1e-3 and tilt < 1e-3,
                                       f"max |Δz| = {dz:.1e} m, max |ϕ|,|θ| = {tilt:.1e} rad, "
                                       f"Ω² = {np.round(r['u'], 1).tolist()}"))
    md, js, text = write_table(out_dir, "models_tour_energy",
                               ["model", "DOF", "duration [s]", "E(0) [J]", "E(T) [J]", "ΔE/max(|E0|,1)", "friction work [J]", "steps"],
                               rows, title="Open-loop runs under gravity: mechanical energy")
    result.outputs["energy table"] = md
    result.outputs["energy table (json)"] = js
    result.table_markdown = text
    return result
