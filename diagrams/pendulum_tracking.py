"""Pendulum tracking a sine: W2 beside InverseDynamicsController
=============================================================

Drake's pendulum (Pendulum.urdf) swinging along a sine under the W2 controller, beside
Drake's ``InverseDynamicsController`` on the same task.

Any finalized MultibodyPlant can serve as the controller's model:
``sd.MechanicalModel.from_plant(plant)`` reads M(q), C(q, q̇)q̇, g(q), the joint damping
(0.1 N·m·s in the URDF) and the actuation matrix, in Drake's own coordinates, so the plant's
state port feeds the controller and its ``u`` drives the actuation port.  Both controllers
start the pendulum at rest 0.4 rad off θ_r(t) = sin 2t.  The W2 run is recorded for Meshcat.

Notes
-----
W2 weights Y0..Y3 = 100, 50, 1, 0.01 give ë = −16.8 ė − 91.4 e − 100 ∫e (e = θ − θ_r), poles
−7.7 ± 3.2j and −1.44.  Drake's controller (its own copy of the plant as model, reference
acceleration fed forward) gets a critically damped triple pole at ω = 100^(1/3) = 4.64 rad/s,
the same mean bandwidth: kp = 3ω² = 64.6, ki = ω³ = 100, kd = 3ω = 13.9.  On an exact model
both turn the error into the same kind of linear chain and differ only in the poles; given
the W2 gains, Drake's controller reproduces the W2 run (tests/examples/test_diagrams.py).  Table
columns: ISE = ∫e² dt, max and final ``|e|``, control effort ∫u² dt and IADU = Σ|Δu| on the
5 ms log grid.

Examples
--------
From the repository root (defaults: 10 s, files in out/diagrams)::

    python diagrams/pendulum_tracking.py
    python diagrams/pendulum_tracking.py 4 my_results
"""

import sys
from pathlib import Path

import numpy as np
from pydrake.common import FindResourceOrThrow
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import AddMultibodyPlantSceneGraph, MultibodyPlant
from pydrake.systems.controllers import InverseDynamicsController
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import LogVectorOutput, Multiplexer

import sobolev_drake as sd

URDF = "drake/examples/pendulum/Pendulum.urdf"
REFERENCE = sd.PiecewiseTrajectory(["theta"], [[sd.sine(1.0, 2.0)]])     # θ_r = sin 2t
X0 = [0.4, 0.0]                                                          # [θ, θ̇] at t = 0
GAINS = sd.controlled_gains(Y0=[100.0], Y1=[50.0], Y2=[1.0], Y3=[0.01])  # K = [kd kp ki]
W = GAINS.K[0, 2] ** (1 / 3)
KP, KI, KD = [3 * W**2], [W**3], [3 * W]                                 # Drake's baseline
LOG_PERIOD = 0.005   # both runs are logged on this grid (IADU, ∫u² dt)


def closed_loop(controller, duration, meshcat=None):
    """Simulate 'W2' or 'Drake IDC' from X0; returns (t, x, u, recorder)."""
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlantSceneGraph(builder, time_step=0.0)
    Parser(plant).AddModels(FindResourceOrThrow(URDF))
    plant.Finalize()
    ref = builder.AddSystem(sd.TrajectoryReference(REFERENCE))
    if controller == "W2":
        model = sd.MechanicalModel.from_plant(plant)
        ctrl = builder.AddSystem(sd.MechanicalController(model, sd.Partition(controlled=[0]),
                                                         sd.SobolevLaw(GAINS)))
        builder.Connect(plant.get_state_output_port(), ctrl.GetInputPort("x"))
        builder.Connect(ref.GetOutputPort("reference"), ctrl.GetInputPort("reference"))
        u = ctrl.GetOutputPort("u")
    else:
        model = MultibodyPlant(0.0)                     # the baseline's own model of the plant
        Parser(model).AddModels(FindResourceOrThrow(URDF))
        model.Finalize()
        ctrl = builder.AddSystem(InverseDynamicsController(model, KP, KI, KD, True))
        desired = builder.AddSystem(Multiplexer([1, 1]))  # [θ_r; θ̇_r]
        builder.Connect(ref.GetOutputPort("q_r"), desired.get_input_port(0))
        builder.Connect(ref.GetOutputPort("qdot_r"), desired.get_input_port(1))
        builder.Connect(desired.get_output_port(0), ctrl.get_input_port_desired_state())
        builder.Connect(ref.GetOutputPort("qddot_r"), ctrl.get_input_port_desired_acceleration())
        builder.Connect(plant.get_state_output_port(), ctrl.get_input_port_estimated_state())
        u = ctrl.get_output_port_control()
    builder.Connect(u, plant.get_actuation_input_port())
    x_log = LogVectorOutput(plant.get_state_output_port(), builder, LOG_PERIOD)
    u_log = LogVectorOutput(u, builder, LOG_PERIOD)
    recorder = sd.viz.add_meshcat_recorder(builder, scene_graph, meshcat) if meshcat else None
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    plant.SetPositionsAndVelocities(plant.GetMyMutableContextFromRoot(context), X0)
    sd.simulate(diagram, context, duration, progress=False, accuracy=1e-6, max_step=0.01)
    x, ul = x_log.FindLog(context), u_log.FindLog(context)
    return x.sample_times(), x.data(), ul.data(), recorder


def scores(t, e, u):
    """Tracking and effort numbers of one run (e: (N, k) errors, u: (N, m) inputs)."""
    return {"ISE [rad²s]": float(sd.norms.ise(t, e).sum()),
            "max error [rad]": float(np.abs(e).max()), "final error [rad]": float(np.abs(e[-1]).max()),
            "∫u² dt [N²m²s]": float(np.trapezoid(np.sum(u**2, axis=1), t)),
            "IADU [N·m]": float(sd.norms.iadu(t, u).sum())}


def run(duration=10.0, out_dir="out/diagrams"):
    """Both closed loops for ``duration`` s; returns {"rows": {controller: {column: value}},
    "recording": HTML path, "plot": PNG path}."""
    meshcat = sd.viz.start_meshcat()
    sd.viz.frame_camera(meshcat, target=[0, 0, 0.75], radius=0.6)   # pivot 1 m up, 0.5 m arm
    rows, runs = {}, {}
    for name in ("W2", "Drake IDC"):
        t, x, u, recorder = closed_loop(name, duration, meshcat if name == "W2" else None)
        e = x[:1].T - REFERENCE.evaluate(t)[0]
        runs[name], rows[name] = (x[0], e[:, 0], u[0]), scores(t, e, u.T)
        if recorder:
            html = sd.viz.save_recording_html(meshcat, recorder,
                                              Path(out_dir) / "pendulum_tracking.html")
    panels = ["θ [rad]", "e [rad]", "u [N·m]"]
    series = {k: np.column_stack([runs[n][i] for n in runs]) for i, k in enumerate(panels)}
    png = sd.plots.plot_time_series(t, series, Path(out_dir) / "pendulum_tracking.png",
                                  labels={k: list(runs) for k in series},
                                  references={"θ [rad]": REFERENCE.evaluate(t)[0]})
    return {"rows": rows, "recording": html, "plot": png}


if __name__ == "__main__":
    result = run(float(sys.argv[1]) if len(sys.argv) > 1 else 10.0,
                 sys.argv[2] if len(sys.argv) > 2 else "out/diagrams")
    print(f"W2 gains [kd kp ki] = {np.round(GAINS.K[0], 3)}; Drake IDC kp, ki, kd = "
          f"{KP[0]:.3g}, {KI[0]:.3g}, {KD[0]:.3g}")
    keys = list(result["rows"]["W2"])
    print("| controller | " + " | ".join(keys) + " |\n" + "|---" * (len(keys) + 1) + "|")
    for name, row in result["rows"].items():
        print(f"| {name} | " + " | ".join(f"{row[k]:.4g}" for k in keys) + " |")
    print("recording:", result["recording"])
    print("plot:", result["plot"])
