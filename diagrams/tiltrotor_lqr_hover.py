"""Tilt-rotor at hover: Drake's LQR beside the W∞ design
=====================================================

Drake's ``LinearQuadraticRegulator`` on the tilt-rotor at hover, beside the library's W∞
hover design, both flying the nonlinear plant.

The plant is the library's: MultibodyPlant (from ``TiltrotorParams``) plus ``TiltrotorForces``
(propellers, servos, aerodynamic surfaces).  ``sd.tiltrotor.linearization.trim_diagram(trim)``
stacks the propeller speeds and servo torques [nR nL τsR τsL] in one input port, holds the
surfaces and the wind at the hover trim (``tiltrotor/trim.py``) and returns a context at that
trim, so Drake's ``LinearQuadraticRegulator(system, context, Q, R)`` applies as to any Drake
plant: it linearizes through the force systems in AutoDiffXd (``TiltrotorForces_[AutoDiffXd]``)
and returns the AffineSystem u = u0 − K(x − x0) on the plant's state (Drake's order).  Q and R
follow Bryson's rule on the thesis-ordered state (tilts 0.2 rad, roll and pitch 0.1 rad, yaw
0.2 rad, position 0.5 m; rates 1 rad/s, 0.5 rad/s, 1 m/s) and inputs (5 rev/s, 0.5 N m); its
output is clipped like the W∞ controller's (n ≥ 0, ``|τs|`` ≤ 2 N m).

Beside it: the W∞ state feedback of Table 7.2 (``linear_design.design(linearize(trim), "W∞")``
with the integral states of (7.57); ``linearize`` is Drake's linearization of the same
diagram), flown by ``LinearHoverController`` holding the hover point.  Both start from the
same offset (:data:`OFFSET`) in still air.  Table columns: RMS, largest and final position
error, largest roll/pitch, ISE = ∫‖p − p_hover‖² dt, IADU = Σ|Δu| over n and τs (10 ms log).

Notes
-----
The LQR has no integral states (a constant disturbance would leave a steady error); the W∞
design integrates ψ, x, y, z.  Its gain (entries up to 3e2, against 63 for the LQR) clips both
propeller speeds to 0 for the first ~10 ms from this offset, hence its larger IADU.  At hover
the surfaces see no air: both designs act through the propellers and servos only.

Examples
--------
From the repository root (defaults: 5 s, files in out/diagrams)::

    python diagrams/tiltrotor_lqr_hover.py
    python diagrams/tiltrotor_lqr_hover.py 10 my_results
"""

import sys
from pathlib import Path

import numpy as np
from pydrake.systems.controllers import LinearQuadraticRegulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import (ConstantVectorSource, Demultiplexer, Linearize,
                                        LogVectorOutput, Saturation)

import sobolev_drake as sd
from sobolev_drake.tiltrotor import linear_design
from sobolev_drake.tiltrotor.linear_controller import LinearHoverController
from sobolev_drake.tiltrotor.linearization import linearize, trim_diagram
from sobolev_drake.tiltrotor.plant import add_tiltrotor
from sobolev_drake.tiltrotor.trim import trim_hover

#: start offset from the hover trim, thesis order [αR αL φ θ ψ x y z]
OFFSET = np.array([0.0, 0.0, 0.05, -0.05, 0.1, 0.5, -0.5, 0.3])
#: Bryson's rule: largest acceptable deviation of each thesis-ordered state and input
STATE_SCALE = np.r_[0.2, 0.2, 0.1, 0.1, 0.2, 0.5, 0.5, 0.5, 1.0, 1.0, 0.5, 0.5, 0.5, 1.0, 1.0, 1.0]
INPUT_SCALE = np.array([5.0, 5.0, 0.5, 0.5])
#: the W∞ controller's clips, applied to the LQR as well: n ≥ 0, |τs| ≤ 2 N m
U_MIN, U_MAX = np.array([0.0, 0.0, -2.0, -2.0]), np.array([np.inf, np.inf, 2.0, 2.0])
LOG_PERIOD = 0.01


def design(trim):
    """Drake's LQR on the trim diagram and the library's W∞ design; returns
    (lqr AffineSystem, {"K", "eigenvalues"}, W∞ design: a SynthesisResult)."""
    diagram, context, h = trim_diagram(trim)
    T16 = np.kron(np.eye(2), h.model.T)                  # x_drake = T16 x_thesis
    Q = T16 @ np.diag(STATE_SCALE ** -2.0) @ T16.T
    lqr = LinearQuadraticRegulator(diagram, context, Q, np.diag(INPUT_SCALE ** -2.0))
    lin = Linearize(diagram, context)
    K = -lqr.D()
    info = {"K": K, "eigenvalues": np.linalg.eigvals(lin.A() - lin.B() @ K)}
    return lqr, info, linear_design.design(linearize(trim), "W∞")


def closed_loop(trim, controller, duration, meshcat=None):
    """The nonlinear tilt-rotor from trim + OFFSET under ``controller`` (Drake's LQR as an
    AffineSystem, or a W∞ design's SynthesisResult); returns (t, x thesis-ordered (16, N), u (4, N),
    recorder)."""
    b = DiagramBuilder()
    h = add_tiltrotor(b, trim.info["model"].params)
    if isinstance(controller, sd.SynthesisResult):
        c = b.AddSystem(LinearHoverController(controller, trim))
        ref = b.AddSystem(ConstantVectorSource(np.zeros(12)))      # hold the hover point
        b.Connect(h.x, c.GetInputPort("x"))
        b.Connect(ref.get_output_port(), c.GetInputPort("reference"))
        for name in ("propeller_speed", "servo_torque"):
            b.Connect(c.GetOutputPort(name), getattr(h, name))
        u_ports = [c.GetOutputPort("propeller_speed"), c.GetOutputPort("servo_torque")]
    else:
        c = b.AddSystem(controller)
        sat = b.AddSystem(Saturation(U_MIN, U_MAX))
        demux = b.AddSystem(Demultiplexer([2, 2]))
        b.Connect(h.plant.get_state_output_port(), c.get_input_port())
        b.Connect(c.get_output_port(), sat.get_input_port())
        b.Connect(sat.get_output_port(), demux.get_input_port())
        b.Connect(demux.get_output_port(0), h.propeller_speed)
        b.Connect(demux.get_output_port(1), h.servo_torque)
        u_ports = [demux.get_output_port(0), demux.get_output_port(1)]
    x_log = LogVectorOutput(h.x, b, LOG_PERIOD)
    u_logs = [LogVectorOutput(p, b, LOG_PERIOD) for p in u_ports]
    recorder = None
    if meshcat is not None:
        recorder = sd.viz.add_meshcat_recorder(b, h.scene_graph, meshcat, publish_period=0.05)
    diagram = b.Build()
    context = diagram.CreateDefaultContext()
    h.set_state(context, diagram, trim.q + OFFSET, np.zeros(8))
    sd.simulate(diagram, context, duration, progress=False, accuracy=1e-5, max_step=LOG_PERIOD)
    x = x_log.FindLog(context)
    u = np.vstack([log.FindLog(context).data() for log in u_logs])
    return x.sample_times(), x.data(), u, recorder


def scores(t, x, u):
    """Position-error, attitude and effort numbers of one run (x: (16, N), u: (4, N))."""
    e = x[5:8].T                                   # position error from the hover point (origin)
    dist = np.linalg.norm(e, axis=1)
    return {"RMS ‖e‖ [m]": float(np.sqrt(np.mean(dist**2))), "max ‖e‖ [m]": float(dist.max()),
            "final ‖e‖ [m]": float(dist[-1]),
            "max |φ|,|θ| [°]": float(np.degrees(np.abs(x[2:4]).max())),
            "ISE [m²s]": float(sd.norms.ise(t, e).sum()), "IADU": float(sd.norms.iadu(t, u.T).sum())}


def run(duration=5.0, out_dir="out/diagrams"):
    """Both closed loops for ``duration`` s; returns {"rows": {controller: {column: value}},
    "recording": HTML path, "plot": PNG path, "lqr": {"K", "eigenvalues"}, "winf": design}."""
    trim = trim_hover()
    lqr, info, winf = design(trim)
    meshcat = sd.viz.start_meshcat()
    sd.viz.frame_camera(meshcat, target=[0, 0, 0], radius=3.0)
    rows, runs, html = {}, {}, None
    for i, (name, controller) in enumerate({"Drake LQR (16 states)": lqr,
                                            "W∞ (Table 7.2, integral states)": winf}.items()):
        t, x, u, recorder = closed_loop(trim, controller, duration, meshcat if i == 0 else None)
        rows[name] = scores(t, x, u)
        runs[name] = (t, x, u)
        if recorder is not None:
            html = sd.viz.save_recording_html(meshcat, recorder, Path(out_dir) / "tiltrotor_lqr_hover.html")
    (t, x_lqr, u_lqr), (_, x_winf, u_winf) = runs.values()
    series = {"LQR: p − p_hover [m]": x_lqr[5:8].T, "W∞: p − p_hover [m]": x_winf[5:8].T,
              "n [rev/s]": np.column_stack([u_lqr[0], u_winf[0]]),
              "τsR [N m]": np.column_stack([u_lqr[2], u_winf[2]])}
    labels = {"LQR: p − p_hover [m]": ["x", "y", "z"], "W∞: p − p_hover [m]": ["x", "y", "z"],
              "n [rev/s]": ["LQR nR", "W∞ nR"], "τsR [N m]": ["LQR", "W∞"]}
    png = sd.plots.plot_time_series(t, series, Path(out_dir) / "tiltrotor_lqr_hover.png", labels=labels)
    return {"rows": rows, "recording": html, "plot": png, "lqr": info, "winf": winf}


if __name__ == "__main__":
    result = run(float(sys.argv[1]) if len(sys.argv) > 1 else 5.0,
                 sys.argv[2] if len(sys.argv) > 2 else "out/diagrams")
    eig = result["lqr"]["eigenvalues"]
    print(f"Drake LQR: closed-loop eigenvalues of the linearized plant, max real part "
          f"{eig.real.max():.4g}; W∞: certified gamma {result['winf'].gamma:.5g}")
    keys = list(next(iter(result["rows"].values())))
    print("| controller | " + " | ".join(keys) + " |\n" + "|---" * (len(keys) + 1) + "|")
    for name, row in result["rows"].items():
        print(f"| {name} | " + " | ".join(f"{row[k]:.4g}" for k in keys) + " |")
    print("recording:", result["recording"])
    print("plot:", result["plot"])
