"""Acrobot balanced upright by W∞ output feedback
==============================================

Drake's Acrobot (``AcrobotPlant``) balanced upright by a W∞ output-feedback controller that
measures only the two joint angles, beside Drake's LQR on the full state.

The synthesis takes Drake's linearization as it is: ``Linearize`` at the upright equilibrium
returns a ``LinearSystem``, and ``sd.winf_output_feedback(lin, C=C_ANGLES, Gamma0=I,
Gamma1=0.1 I)`` uses its A and B, a disturbance entering with the torque (D defaults to B) and
the cost z = [Γ0^½ x; Γ1^½ ẋ].  ``sd.controller_system(res, x_op=UPRIGHT, u_op=[0],
S=C_ANGLES)`` turns the result into a Drake system that reads the plant's state, keeps the
angles and works in deviations from the upright point.  The baseline is Drake's
``LinearQuadraticRegulator(A, B, Q=I, R=1)``, which returns K for u = −K x; this library
writes u = +K x, hence ``sd.controller_system(-K_lqr, x_op=UPRIGHT)``.  Both start 0.05 rad
off upright on each joint, on the nonlinear plant; the W∞ run is recorded for Meshcat with
Drake's ``AcrobotGeometry``.

Notes
-----
Angles measured without noise make the output-feedback problem singular; the default
synthesis regularizes it and says so in a warning, which ``run`` returns as ``notes``.  The
resulting controller has two fast poles (−651 ± 554j) besides two at −2.3: they give a torque
kick of 26 N·m that is over within 5 ms (two thirds of the W∞ run's IADU), so the logs keep
every integrator step.
The comparison is not like for like: the LQR measures the rates too.  Table columns: ISE =
∫|θ − θ_up|² dt, max and final angle error, ∫u² dt and IADU = Σ|Δu|.

Examples
--------
From the repository root (defaults: 10 s, files in out/diagrams)::

    python diagrams/acrobot_upright.py
    python diagrams/acrobot_upright.py 15 my_results
"""

import sys
import warnings
from pathlib import Path

import numpy as np
from pydrake.examples import AcrobotGeometry, AcrobotPlant
from pydrake.geometry import SceneGraph
from pydrake.systems.controllers import LinearQuadraticRegulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import Linearize, LogVectorOutput

import sobolev_drake as sd

UPRIGHT = np.array([np.pi, 0.0, 0.0, 0.0])   # [θ1, θ2, θ̇1, θ̇2]
START = UPRIGHT + [0.05, -0.05, 0.0, 0.0]
C_ANGLES = np.eye(4)[:2]                     # y = [θ1, θ2]


def design():
    """W∞ output feedback on the angles and Drake's LQR (u = −K x); warnings as strings."""
    acrobot = AcrobotPlant()
    context = acrobot.CreateDefaultContext()
    context.SetContinuousState(UPRIGHT)
    acrobot.get_input_port(0).FixValue(context, [0.0])
    lin = Linearize(acrobot, context)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = sd.winf_output_feedback(lin, C=C_ANGLES, Gamma0=np.eye(4), Gamma1=0.1 * np.eye(4))
    K_lqr, _ = LinearQuadraticRegulator(lin.A(), lin.B(), np.eye(4), np.eye(1))
    return res, K_lqr, [str(w.message) for w in caught]


def closed_loop(controller, duration, meshcat=None):
    """The nonlinear Acrobot from START under ``controller``; returns (t, x, u, recorder)."""
    builder = DiagramBuilder()
    acrobot = builder.AddSystem(AcrobotPlant())
    builder.AddSystem(controller)
    builder.Connect(acrobot.get_output_port(0), controller.get_input_port(0))
    builder.Connect(controller.get_output_port(0), acrobot.get_input_port(0))
    # every integrator step is logged: a fixed 5 ms grid would miss the W∞ controller's fast
    # poles (−651 ± 554j) and report IADU 32 instead of 82 N·m
    x_log = LogVectorOutput(acrobot.get_output_port(0), builder)
    u_log = LogVectorOutput(controller.get_output_port(0), builder)
    recorder = None
    if meshcat is not None:
        scene_graph = builder.AddSystem(SceneGraph())
        AcrobotGeometry.AddToBuilder(builder, acrobot.get_output_port(0), scene_graph)
        recorder = sd.viz.add_meshcat_recorder(builder, scene_graph, meshcat)
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    diagram.GetMutableSubsystemContext(acrobot, context).SetContinuousState(START)
    sd.simulate(diagram, context, duration, progress=False, accuracy=1e-6, max_step=0.01)
    x, u = x_log.FindLog(context), u_log.FindLog(context)
    return x.sample_times(), x.data(), u.data(), recorder


def scores(t, e, u):
    """Angle-error and effort numbers of one run (e: (N, 2), u: (N, 1))."""
    return {"ISE [rad²s]": float(sd.norms.ise(t, e).sum()), "max error [rad]": float(np.abs(e).max()),
            "final error [rad]": float(np.abs(e[-1]).max()),
            "∫u² dt [N²m²s]": float(np.trapezoid(np.sum(u**2, axis=1), t)),
            "IADU [N·m]": float(sd.norms.iadu(t, u).sum())}


def run(duration=10.0, out_dir="out/diagrams"):
    """Both closed loops for ``duration`` s; returns {"rows": {controller: {column: value}},
    "recording": HTML path, "plot": PNG path, "synthesis": SynthesisResult, "notes": warnings}."""
    res, K_lqr, notes = design()
    controllers = {
        "W∞ output feedback (angles)": sd.controller_system(res, x_op=UPRIGHT, u_op=[0.0], S=C_ANGLES),
        "Drake LQR (full state)": sd.controller_system(-K_lqr, x_op=UPRIGHT)}   # u = −K_lqr x
    meshcat = sd.viz.start_meshcat()
    sd.viz.frame_camera(meshcat, target=[0, 0, 1.5], radius=1.8)   # links of 1 m and 2 m, upright
    rows, runs = {}, {}
    for i, (name, controller) in enumerate(controllers.items()):
        t, x, u, recorder = closed_loop(controller, duration, meshcat if i == 0 else None)
        e = (x[:2] - UPRIGHT[:2, None]).T
        rows[name] = scores(t, e, u.T)
        grid = np.linspace(0.0, duration, 2001)                     # common time axis to plot
        runs[name] = np.column_stack([np.interp(grid, t, y) for y in e.T]), np.interp(grid, t, u[0])
        if recorder:
            html = sd.viz.save_recording_html(meshcat, recorder, Path(out_dir) / "acrobot_upright.html")
    (e_winf, u_winf), (e_lqr, u_lqr) = runs.values()
    series = {"W∞: θ − θ_up [rad]": e_winf, "LQR: θ − θ_up [rad]": e_lqr,
              "u [N·m]": np.column_stack([u_winf, u_lqr])}
    labels = {"W∞: θ − θ_up [rad]": ["θ1", "θ2"], "LQR: θ − θ_up [rad]": ["θ1", "θ2"],
              "u [N·m]": ["W∞", "LQR"]}
    png = sd.plots.plot_time_series(grid, series, Path(out_dir) / "acrobot_upright.png", labels=labels)
    return {"rows": rows, "recording": html, "plot": png, "synthesis": res, "notes": notes}


if __name__ == "__main__":
    result = run(float(sys.argv[1]) if len(sys.argv) > 1 else 10.0,
                 sys.argv[2] if len(sys.argv) > 2 else "out/diagrams")
    res = result["synthesis"]
    print(f"synthesis: {res.method}, certified gamma {res.gamma:.5g} (closed-loop norm "
          f"{res.certificate.achieved:.5g}); " + "; ".join(result["notes"]))
    keys = list(next(iter(result["rows"].values())))
    print("| controller | " + " | ".join(keys) + " |\n" + "|---" * (len(keys) + 1) + "|")
    for name, row in result["rows"].items():
        print(f"| {name} | " + " | ".join(f"{row[k]:.4g}" for k in keys) + " |")
    print("recording:", result["recording"])
    print("plot:", result["plot"])
