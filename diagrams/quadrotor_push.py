"""Quadrotor pushed at a rotor arm (disturbance plumbing)
======================================================

Quadrotor at hover thrust pushed by an inertial force at a rotor arm (open loop).

Shows the disturbance plumbing: a 3-D force profile (TimeProfiledForce) is mapped to
generalized forces by CartesianForceAtBody (Jacobian transpose, thesis (3.41)) and fed to the
plant's thesis-order ``disturbance`` port; the reference path of Table 5.8 is drawn for scale.
Run:  python diagrams/quadrotor_push.py [OUT_DIR]
"""

import sys
from pathlib import Path

import numpy as np
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, LogVectorOutput

from sobolev_drake import plots, viz
from sobolev_drake.models.quadrotor import add_quadrotor
from sobolev_drake.simulation import simulate
from sobolev_drake.systems.disturbances import CartesianForceAtBody, TimeProfiledForce
from sobolev_drake.systems.reference_catalogue import trajectory

out = Path(sys.argv[1] if len(sys.argv) > 1 else "out/diagrams")
builder = DiagramBuilder()
quad = add_quadrotor(builder)
q0 = np.array([0, 0, 0, 0, 0, 3.0])                         # [ϕ θ ψ x y z]
hover, *_ = np.linalg.lstsq(quad.model.B(q0), quad.model.g(q0), rcond=None)  # Ω² for B Ω² = g
thrust = builder.AddSystem(ConstantVectorSource(hover))
push = builder.AddSystem(TimeProfiledForce(3, [{"index": 1, "value": 0.5, "from": 0.5, "to": 1.0}]))
arm_force = builder.AddSystem(CartesianForceAtBody(quad.model, "body", p_BQ=[0.21, 0, 0]))
builder.Connect(thrust.get_output_port(), quad.u)
builder.Connect(quad.x, arm_force.GetInputPort("x"))
builder.Connect(push.GetOutputPort("generalized_force"), arm_force.GetInputPort("force"))
builder.Connect(arm_force.GetOutputPort("generalized_force"), quad.disturbance)
log = LogVectorOutput(quad.x, builder)
meshcat = viz.start_meshcat()
recorder = viz.add_meshcat_recorder(builder, quad.scene_graph, meshcat)
viz.draw_path(meshcat, "figure8", trajectory("table_5_8").evaluate(np.linspace(0, 40, 400))[0][:, :3])
diagram = builder.Build()
context = diagram.CreateDefaultContext()
quad.set_state(context, diagram, q0, np.zeros(6))
simulate(diagram, context, 3.0, label="quadrotor push")

data = log.FindLog(context)
print("recording:", viz.save_recording_html(meshcat, recorder, out / "quadrotor_push.html"))
print("plot:", plots.plot_time_series(data.sample_times(), {"attitude": data.data()[:3].T,
                                                          "position": data.data()[3:6].T},
                                    out / "quadrotor_push.png", vlines=[0.5, 1.0],
                                    labels={"attitude": ["phi", "theta", "psi"], "position": ["x", "y", "z"]}))
