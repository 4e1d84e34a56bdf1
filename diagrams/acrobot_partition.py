"""Acrobot: actuated elbow tracked, passive shoulder free
======================================================

An underactuated partition on Drake's Acrobot (Acrobot.urdf): the actuated elbow tracks a
sine while the passive shoulder is left to its own dynamics; Drake's ``PidController`` on the
elbow is the baseline.

``sd.Partition(controlled=[1], uncontrolled=[0])`` selects the reduced model (thesis (5.5)):
the shoulder's equation is solved for its acceleration and eliminated, which leaves
M̄ q̈_elbow + h̄ = B̄ τ with M̄ = M22 − M12²/M11 (0.188 kg·m² at the start, M22 = 1.33).  The
shoulder is not regulated; it swings as the elbow drives it.  Asking instead to *stabilize*
it, ``Partition(controlled=[1], stabilized=[0])``, raises ``ValueError``: no input reaches
the shoulder (its row of B is zero), so the input-coupling law cannot act on it.  The script
catches that error and prints its message.  The Acrobot starts hanging at rest with the
elbow 0.3 rad off q_r(t) = 0.8 sin t; the W2 run is recorded for Meshcat.

Notes
-----
W2 weights Y0..Y3 = 100, 50, 1, 0.01: the elbow error obeys ë = −16.8 ė − 91.4 e − 100 ∫e
(poles −7.7 ± 3.2j, −1.44).  Drake's PID sees only the elbow's angle and rate (a state
projection) and has no model: no gravity, coupling or acceleration feedforward.  Its gains are
the triple pole ω = 100^(1/3) = 4.64 rad/s of the other examples scaled by M̄ at the start:
kp = 3ω²M̄ = 12.2 N·m/rad, ki = ω³M̄ = 18.8 N·m/(rad·s), kd = 3ωM̄ = 2.62 N·m·s/rad.  Table
columns are for the elbow (ISE = ∫e² dt, max and final ``|e|``, ∫u² dt, IADU = Σ|Δu| on the 5 ms
log grid), plus the shoulder's largest excursion max|q0|.

Examples
--------
From the repository root (defaults: 10 s, files in out/diagrams)::

    python diagrams/acrobot_partition.py
    python diagrams/acrobot_partition.py 4 my_results
"""

import sys
from pathlib import Path

import numpy as np
from pydrake.common import FindResourceOrThrow
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import AddMultibodyPlantSceneGraph, MultibodyPlant
from pydrake.systems.controllers import PidController
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import LogVectorOutput, Multiplexer

import sobolev_drake as sd

URDF = "drake/examples/acrobot/Acrobot.urdf"
REFERENCE = sd.PiecewiseTrajectory(["elbow"], [[sd.sine(0.8, 1.0)]])     # q_r = 0.8 sin t
X0 = [0.0, 0.3, 0.0, 0.0]                                                # [shoulder, elbow, rates]
GAINS = sd.controlled_gains(Y0=[100.0], Y1=[50.0], Y2=[1.0], Y3=[0.01])
PARTITION = sd.Partition(controlled=[1], uncontrolled=[0])
LOG_PERIOD = 0.005


def load(plant):
    """The Acrobot in ``plant``, finalized."""
    Parser(plant).AddModels(FindResourceOrThrow(URDF))
    plant.Finalize()
    return plant


def pid_gains(model):
    """Drake PID's [kp], [ki], [kd]: the triple pole ω = ki_W2^(1/3) scaled by M̄ at X0."""
    M, w = model.M(X0[:2]), GAINS.K[0, 2] ** (1 / 3)
    m_bar = M[1, 1] - M[0, 1] ** 2 / M[0, 0]
    return [3 * w**2 * m_bar], [w**3 * m_bar], [3 * w * m_bar]


def closed_loop(controller, duration, meshcat=None):
    """Simulate 'W2' or 'Drake PID' from X0; returns (t, x, u, recorder)."""
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlantSceneGraph(builder, time_step=0.0)
    model = sd.MechanicalModel.from_plant(load(plant))
    ref = builder.AddSystem(sd.TrajectoryReference(REFERENCE))
    if controller == "W2":
        ctrl = builder.AddSystem(sd.MechanicalController(model, PARTITION, sd.SobolevLaw(GAINS)))
        builder.Connect(plant.get_state_output_port(), ctrl.GetInputPort("x"))
        builder.Connect(ref.GetOutputPort("reference"), ctrl.GetInputPort("reference"))
        u = ctrl.GetOutputPort("u")
    else:
        elbow_only = np.eye(4)[[1, 3]]                  # [q_elbow; v_elbow] from the state
        ctrl = builder.AddSystem(PidController(elbow_only, *pid_gains(model)))
        desired = builder.AddSystem(Multiplexer([1, 1]))
        builder.Connect(ref.GetOutputPort("q_r"), desired.get_input_port(0))
        builder.Connect(ref.GetOutputPort("qdot_r"), desired.get_input_port(1))
        builder.Connect(desired.get_output_port(0), ctrl.get_input_port_desired_state())
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


def refused_partition():
    """Asking the law to stabilize the passive shoulder: the ValueError's message."""
    law = sd.SobolevLaw(GAINS, stabilized=sd.stabilized_gains(U0=[1.0], U1=[1.0]))
    try:
        sd.MechanicalController(sd.MechanicalModel.from_plant(load(MultibodyPlant(0.0))),
                                sd.Partition(controlled=[1], stabilized=[0]), law)
    except ValueError as error:
        return str(error)


def scores(t, e, u, shoulder):
    """Elbow tracking and effort numbers of one run, and the shoulder's largest excursion."""
    return {"ISE [rad²s]": float(sd.norms.ise(t, e)), "max error [rad]": float(np.abs(e).max()),
            "final error [rad]": float(abs(e[-1])), "∫u² dt [N²m²s]": float(np.trapezoid(u**2, t)),
            "IADU [N·m]": float(sd.norms.iadu(t, u)),
            "max shoulder [rad]": float(np.abs(shoulder).max())}


def run(duration=10.0, out_dir="out/diagrams"):
    """Both closed loops for ``duration`` s; returns {"rows": {controller: {column: value}},
    "recording": HTML path, "plot": PNG path, "refused": the ValueError's message}."""
    meshcat = sd.viz.start_meshcat()
    sd.viz.frame_camera(meshcat, target=[0, 0, -1.2], radius=2.2)   # links 1 m + 2 m, hanging
    rows, runs = {}, {}
    for name in ("W2", "Drake PID"):
        t, x, u, recorder = closed_loop(name, duration, meshcat if name == "W2" else None)
        e = x[1] - REFERENCE.evaluate(t)[0][:, 0]
        runs[name], rows[name] = (x[1], x[0], e, u[0]), scores(t, e, u[0], x[0])
        if recorder:
            html = sd.viz.save_recording_html(meshcat, recorder,
                                              Path(out_dir) / "acrobot_partition.html")
    keys = ["elbow [rad]", "shoulder [rad]", "elbow error [rad]", "u [N·m]"]
    series = {k: np.column_stack([runs[n][i] for n in runs]) for i, k in enumerate(keys)}
    png = sd.plots.plot_time_series(t, series, Path(out_dir) / "acrobot_partition.png",
                                  labels={k: list(runs) for k in series},
                                  references={"elbow [rad]": REFERENCE.evaluate(t)[0]})
    return {"rows": rows, "recording": html, "plot": png, "refused": refused_partition()}


if __name__ == "__main__":
    result = run(float(sys.argv[1]) if len(sys.argv) > 1 else 10.0,
                 sys.argv[2] if len(sys.argv) > 2 else "out/diagrams")
    print("Partition(controlled=[1], stabilized=[0]) is refused:", result["refused"])
    kp, ki, kd = pid_gains(sd.MechanicalModel.from_plant(load(MultibodyPlant(0.0))))
    print(f"elbow: W2 gains [kd kp ki] = {np.round(GAINS.K[0], 3)}; Drake PID kp, ki, kd = "
          f"{kp[0]:.3g}, {ki[0]:.3g}, {kd[0]:.3g}")
    keys = list(result["rows"]["W2"])
    print("| controller | " + " | ".join(keys) + " |\n" + "|---" * (len(keys) + 1) + "|")
    for name, row in result["rows"].items():
        print(f"| {name} | " + " | ".join(f"{row[k]:.4g}" for k in keys) + " |")
    print("recording:", result["recording"])
    print("plot:", result["plot"])
