"""Planar gripper: six damped joints under the W2 controller
=========================================================

Drake's planar gripper (planar_gripper.sdf: three fingers, two damped joints each) tracking
a finger wave under the W2 controller, beside Drake's ``InverseDynamicsController``.

``sd.MechanicalModel.from_plant`` on a 6-DOF plant with joint damping (0.1 N·m·s on every
joint): the damping becomes the model's friction term D q̇, which the controller cancels, as
Drake's controller does with its own copy of the plant.  The finger bases are welded 120°
apart, 0.19 m from the centre, as in Drake's planar-gripper example.  The fingers start
straight and at rest; finger k (φ_k = 2πk/3) follows 0.35 sin(1.5t + φ_k) on its base joint
and 0.6 + 0.4 sin(3t + φ_k) on its middle joint, which keeps the fingers at least 1 cm apart
(no contact).  The W2 run is recorded for Meshcat.

Notes
-----
Every joint gets the same gains.  W2 weights Y0..Y3 = 100, 50, 1, 0.01: ë = −16.8 ė − 91.4 e
− 100 ∫e, poles −7.7 ± 3.2j and −1.44.  Drake's controller: critically damped triple pole at
the same mean bandwidth ω = 100^(1/3) = 4.64 rad/s, kp = 3ω² = 64.6, ki = ω³ = 100,
kd = 3ω = 13.9.  Neither comes near the 75 N·m effort limit.  Table columns (summed over the
six joints, max over them for the errors): ISE = ∫e² dt, max and final ``|e|``, ∫|u|² dt and
IADU = Σ|Δu| on the 5 ms log grid.

Examples
--------
From the repository root (defaults: 10 s, files in out/diagrams)::

    python diagrams/gripper_tracking.py
    python diagrams/gripper_tracking.py 4 my_results
"""

import sys
from pathlib import Path

import numpy as np
from pydrake.common import FindResourceOrThrow
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import AddMultibodyPlantSceneGraph, MultibodyPlant
from pydrake.systems.controllers import InverseDynamicsController
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import LogVectorOutput, Multiplexer

import sobolev_drake as sd

SDF = "drake/examples/planar_gripper/planar_gripper.sdf"
WAVE = [c for k in range(3) for c in (sd.sine(0.35, 1.5, phase=2 * np.pi * k / 3),
                                      sd.sine(0.4, 3.0, phase=2 * np.pi * k / 3, offset=0.6))]
X0 = np.zeros(12)                                                         # straight, at rest
GAINS = sd.controlled_gains(Y0=[100.0] * 6, Y1=[50.0] * 6, Y2=[1.0] * 6, Y3=[0.01] * 6)
W = GAINS.K[0, 12] ** (1 / 3)                                             # ki^(1/3)
KP, KI, KD = [3 * W**2] * 6, [W**3] * 6, [3 * W] * 6                     # Drake's baseline
LOG_PERIOD = 0.005


def add_gripper(plant):
    """The gripper in ``plant``, finger bases welded 120° apart; finalized."""
    Parser(plant).AddModels(FindResourceOrThrow(SDF))
    for k in range(3):
        X_WB = RigidTransform(RollPitchYaw(2 * np.pi * k / 3, 0, 0), [0, 0, 0])
        plant.WeldFrames(plant.world_frame(), plant.GetFrameByName(f"finger{k + 1}_base"),
                         X_WB @ RigidTransform([0, 0, 0.19]))
    plant.Finalize()
    return plant


def closed_loop(controller, duration, meshcat=None):
    """Simulate 'W2' or 'Drake IDC' from X0; returns (t, x, u, reference, recorder)."""
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlantSceneGraph(builder, time_step=0.0)
    model = sd.MechanicalModel.from_plant(add_gripper(plant))
    reference = sd.PiecewiseTrajectory(model.dof_names, [WAVE])
    ref = builder.AddSystem(sd.TrajectoryReference(reference))
    if controller == "W2":
        ctrl = builder.AddSystem(sd.MechanicalController(model, sd.Partition(controlled=range(6)),
                                                         sd.SobolevLaw(GAINS)))
        builder.Connect(plant.get_state_output_port(), ctrl.GetInputPort("x"))
        builder.Connect(ref.GetOutputPort("reference"), ctrl.GetInputPort("reference"))
        u = ctrl.GetOutputPort("u")
    else:   # Drake's controller, with its own copy of the plant as its model
        own_model = add_gripper(MultibodyPlant(0.0))
        ctrl = builder.AddSystem(InverseDynamicsController(own_model, KP, KI, KD, True))
        desired = builder.AddSystem(Multiplexer([6, 6]))                  # [q_r; q̇_r]
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
    return x.sample_times(), x.data(), ul.data(), reference, recorder


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
    sd.viz.frame_camera(meshcat, target=[0, 0, 0], radius=0.22, azimuth_deg=0.0)  # view along −x
    rows, series = {}, {}
    for name in ("W2", "Drake IDC"):
        t, x, u, reference, recorder = closed_loop(name, duration, meshcat if name == "W2" else None)
        e = x[:6].T - reference.evaluate(t)[0]
        rows[name] = scores(t, e, u.T)
        if name == "W2":
            series["W2 q [rad]"] = x[:6].T
        series.update({f"{name} error [rad]": e, f"{name} u [N·m]": u.T})
        if recorder:
            html = sd.viz.save_recording_html(meshcat, recorder,
                                              Path(out_dir) / "gripper_tracking.html")
    png = sd.plots.plot_time_series(t, series, Path(out_dir) / "gripper_tracking.png",
                                  labels={k: reference.names for k in series},
                                  references={"W2 q [rad]": reference.evaluate(t)[0]})
    return {"rows": rows, "recording": html, "plot": png}


if __name__ == "__main__":
    result = run(float(sys.argv[1]) if len(sys.argv) > 1 else 10.0,
                 sys.argv[2] if len(sys.argv) > 2 else "out/diagrams")
    print(f"every joint: W2 gains [kd kp ki] = {np.round(GAINS.K[0, ::6], 3)}; "
          f"Drake IDC kp, ki, kd = {KP[0]:.3g}, {KI[0]:.3g}, {KD[0]:.3g}")
    keys = list(result["rows"]["W2"])
    print("| controller | " + " | ".join(keys) + " |\n" + "|---" * (len(keys) + 1) + "|")
    for name, row in result["rows"].items():
        print(f"| {name} | " + " | ".join(f"{row[k]:.4g}" for k in keys) + " |")
    print("recording:", result["recording"])
    print("plot:", result["plot"])
