"""Two-link arm tracking Table 5.2 (W2/W∞ controller)
==================================================

Two-link arm tracking Table 5.2 with the nonlinear W2/W∞ controller (thesis 5.3.1).

Plant + reference + controller + disturbance, simulated with a Meshcat recording and scored
with the thesis indices.  Run:  python diagrams/arm_w2_tracking.py [OUT_DIR]
"""

import sys
from pathlib import Path

import numpy as np
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import LogVectorOutput

from sobolev_drake import norms, plots, viz
from sobolev_drake.models.arm import add_arm
from sobolev_drake.simulation import simulate
from sobolev_drake.synthesis.mechanical import controlled_gains
from sobolev_drake.systems.disturbances import TimeProfiledForce
from sobolev_drake.systems.mechanical_controller import MechanicalController, Partition, SobolevLaw
from sobolev_drake.systems.reference_catalogue import table_5_2

out = Path(sys.argv[1] if len(sys.argv) > 1 else "out/diagrams")
builder = DiagramBuilder()
arm = add_arm(builder)                                   # MultibodyPlant + SceneGraph + adapter
ref = builder.AddSystem(table_5_2())                     # q_r, q̇_r, q̈_r of Table 5.2
gains = controlled_gains(Y0=[100, 200], Y1=[500, 400], Y2=[40, 40], Y3=[0.0720, 0.0126])
ctrl = builder.AddSystem(MechanicalController(arm.model, Partition(controlled=[0, 1]), SobolevLaw(gains)))
w = builder.AddSystem(TimeProfiledForce(2, [            # w1, w2 of section 5.3.1
    {"index": 0, "value": 40.0, "from": 10.0, "to": 20.0},
    {"index": 1, "value": lambda t: -40 * np.sin(2 * np.pi * t / 10), "from": 25.0, "to": 35.0}]))
builder.Connect(arm.x, ctrl.GetInputPort("x"))
builder.Connect(ref.GetOutputPort("reference"), ctrl.GetInputPort("reference"))
builder.Connect(ctrl.GetOutputPort("u"), arm.u)
builder.Connect(w.GetOutputPort("generalized_force"), arm.disturbance)
x_log = LogVectorOutput(arm.x, builder)
u_log = LogVectorOutput(ctrl.GetOutputPort("u"), builder)
meshcat = viz.start_meshcat()
recorder = viz.add_meshcat_recorder(builder, arm.scene_graph, meshcat)
diagram = builder.Build()
context = diagram.CreateDefaultContext()
arm.set_state(context, diagram, [np.pi / 4, 0.0], [0.0, 0.0])  # q(0) of section 5.3.1
simulate(diagram, context, 40.0, label="arm W2/W∞")

x, u = x_log.FindLog(context), u_log.FindLog(context)
t = x.sample_times()
e = x.data()[:2].T - ref.evaluate(t)[0]
print("ISE q1, q2:", norms.ise(t, e), " IADU:", norms.iadu(u.sample_times(), u.data().T).sum())
print("recording:", viz.save_recording_html(meshcat, recorder, out / "arm_w2_tracking.html"))
print("plot:", plots.plot_time_series(t, {"error": e, "u": u.data().T}, out / "arm_w2_tracking.png"))
