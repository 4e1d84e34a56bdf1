"""Your own drone: quadrotor and hexarotor figure-8 beside Drake's LQR
===================================================================

Your own drone: a quadrotor described the way drone packages describe one — one free body
(Drake gives it a quaternion floating joint) and four Drake ``Propeller`` systems — flies a
figure-8 at 2 m/s through a wind gust and a 2 N × 0.5 s push, with the nonlinear W2/W∞ position law and
bounded rotor allocation, beside Drake's LQR designed around hover on the same vehicle; then
the same code flies a hexarotor.  The W2/W∞ flights are recorded to standalone HTML.

The library turns the description into an Euler-angle model (``MechanicalModel.from_plant(
plant, propellers=...)``); Drake's LQR gets its (A, B) from ``Linearize`` of plant + propellers
moved to the minimal Euler chart (``rigs.multirotor.linearize_hover``), because the quaternion
state's 13th coordinate makes Drake's own 13-state linearization unstabilizable.
Run:  python diagrams/multirotor_figure8.py [OUT_DIR]
"""

import sys
from functools import partial
from pathlib import Path

import numpy as np
from pydrake.math import RigidTransform
from pydrake.multibody.plant import PropellerInfo
from pydrake.systems.controllers import LinearQuadraticRegulator

import sobolev_drake as sd
from sobolev_drake import plots, viz
from sobolev_drake.rigs.multirotor import (add_state_feedback, add_w_controller, fly_multirotor,
                                           linearize_hover)
from sobolev_drake.systems.disturbances import TimeProfiledForce
from sobolev_drake.systems.references import PiecewiseTrajectory, TrajectoryReference, const, sine


def description(name, mass, inertia, arm, rotors):
    """SDFormat of a multirotor body: inertia, a hub and one arm + disc per rotor (visual)."""
    visuals = "".join(
        f'<visual name="arm{i}"><pose>{arm / 2 * np.cos(a)} {arm / 2 * np.sin(a)} 0 0 0 {a}</pose>'
        f"<geometry><box><size>{arm} 0.02 0.01</size></box></geometry></visual>"
        f'<visual name="disc{i}"><pose>{arm * np.cos(a)} {arm * np.sin(a)} 0.02 0 0 0</pose>'
        f"<geometry><cylinder><radius>{0.4 * arm}</radius><length>0.005</length></cylinder>"
        "</geometry></visual>"
        for i, a in enumerate(2 * np.pi * np.arange(rotors) / rotors))
    ixx, iyy, izz = inertia
    return (f'<sdf version="1.7"><model name="{name}"><link name="body"><inertial><mass>{mass}'
            f"</mass><inertia><ixx>{ixx}</ixx><iyy>{iyy}</iyy><izz>{izz}</izz><ixy>0</ixy>"
            f"<ixz>0</ixz><iyz>0</iyz></inertia></inertial><visual name=\"hub\"><geometry><box>"
            f"<size>0.1 0.1 0.04</size></box></geometry></visual>{visuals}</link></model></sdf>")


def propellers(count, arm, plant):
    """Rotors on a circle, alternate spin: thrust = command (N), drag torque ±0.0245 m·command."""
    body = plant.GetBodyByName("body").index()
    return [PropellerInfo(body, RigidTransform([arm * np.cos(2 * np.pi * i / count),
                                                arm * np.sin(2 * np.pi * i / count), 0.0]),
                          1.0, 0.0245 * (-1) ** i) for i in range(count)]


# name: (description, propellers, largest command per rotor [N])
VEHICLES = {
    "quadrotor": (description("quadrotor", 0.775, (0.0015, 0.0025, 0.0035), 0.15, 4),
                  partial(propellers, 4, 0.15), 6.0),
    "hexarotor": (description("hexarotor", 1.6, (0.021, 0.021, 0.04), 0.25, 6),
                  partial(propellers, 6, 0.25), 8.0),
}
# W2/W∞ weights: [ψ x y z] with integral action (poles ≈ −3.9, −1.2 ± 0.4j for x, y, z);
# roll/pitch regulated (ë = −24 ė − 225 e: ω ≈ 15 rad/s, ζ = 0.8)
INNER = sd.SobolevLaw(sd.controlled_gains([1.0, 30, 30, 30], [5.0, 60, 60, 60],
                                          [3.0, 20, 20, 20], [0.2, 1, 1, 1]),
                      regulated=sd.regulated_gains([50625.0] * 2, [126.0] * 2, [1.0] * 2))
# Drake's LQR: Q on [ϕ θ ψ x y z] and their rates, R on the rotor commands
Q_LQR, R_WEIGHT = np.diag([10.0] * 6 + [1.0] * 6), 1.0
# figure-8 x = 2 sin(0.7 t), y = sin(1.4 t), z = 1 m: 2 m/s where the loops cross
FIGURE8 = PiecewiseTrajectory(["psi", "x", "y", "z"],
                              [[const(0.0), sine(2.0, 0.7), sine(1.0, 1.4), const(1.0)]])


def disturbances(duration):
    """A 1−cos gust of 1.5 N along y over [0.3, 0.5]·duration and a 2 N push along x for
    0.5 s from 0.6·duration (generalized forces in Drake's velocity order [torque; force])."""
    g0, g1, push = 0.3 * duration, 0.5 * duration, 0.6 * duration
    gust = lambda t: 0.75 * (1.0 - np.cos(2 * np.pi * (t - g0) / (g1 - g0)))  # noqa: E731
    return [{"index": 4, "value": gust, "from": g0, "to": g1},
            {"index": 3, "value": 2.0, "from": push, "to": push + 0.5}]


def w_law(builder, handles, reference_port):
    return add_w_controller(builder, handles, INNER, reference_port)


def drake_lqr(builder, handles, reference_port):
    lin = linearize_hover(handles)
    K, _ = LinearQuadraticRegulator(lin.A, lin.B, Q_LQR, R_WEIGHT * np.eye(len(lin.u0)))
    return add_state_feedback(builder, handles, K, lin.u0, reference_port)


def fly(vehicle, controller, duration, meshcat=None):
    text, props, upper = VEHICLES[vehicle]
    run = fly_multirotor(text, props, TrajectoryReference(FIGURE8),
                         TimeProfiledForce(6, disturbances(duration)), duration,
                         controller=controller, command_upper=upper, meshcat=meshcat)
    run["e"] = run["x"][:, 3:6] - run["ref"][:, 1:4]
    return run


def scores(run, duration):
    t, err = run["t"], np.linalg.norm(run["e"], axis=1)
    after = (t >= 0.6 * duration) & (t <= 0.6 * duration + 2.0)
    return {"RMS ‖e‖ [m]": float(np.sqrt(np.trapezoid(err ** 2, t) / t[-1])),
            "peak ‖e‖ after push [m]": float(err[after].max()),
            "max tilt [deg]": float(np.rad2deg(np.abs(run["x"][:, :2]).max()))}


def run(duration=10.0, out_dir="out/diagrams"):
    out = Path(out_dir)
    runs, rows, recordings = {}, {}, {}
    for vehicle in VEHICLES:
        for label, controller in (("W2/W∞", w_law), ("Drake LQR", drake_lqr)):
            meshcat = viz.start_meshcat() if label == "W2/W∞" else None
            if meshcat is not None:
                viz.draw_path(meshcat, "figure8", np.column_stack(
                    FIGURE8.evaluate(np.linspace(0.0, 2 * np.pi / 0.7, 200))[0][:, 1:4]))
            r = runs[f"{vehicle} {label}"] = fly(vehicle, controller, duration, meshcat)
            rows[f"{vehicle} {label}"] = scores(r, duration)
            if meshcat is not None:
                recordings[vehicle] = viz.save_recording_html(
                    meshcat, r["recorder"], out / f"multirotor_figure8_{vehicle}.html")
    plot = plots.compare_plot(
        out / "multirotor_figure8.png", runs,
        [("‖e‖ [m]", lambda r: np.linalg.norm(r["e"], axis=1), None),
         ("ϕ, θ [rad]", lambda r: r["x"][:, :2], ["ϕ", "θ"])],
        title="Figure-8 at 2 m/s, gust and 2 N push: W2/W∞ + allocation vs Drake LQR",
        vlines=(0.3 * duration, 0.5 * duration, 0.6 * duration, 0.6 * duration + 0.5))
    return {"rows": rows, "recordings": recordings, "plot": plot, "runs": runs}


if __name__ == "__main__":
    result = run(out_dir=sys.argv[1] if len(sys.argv) > 1 else "out/diagrams")
    for name, row in result["rows"].items():
        print(f"{name:24s}", "  ".join(f"{k} {v:.3f}" for k, v in row.items()))
    print("recordings:", *result["recordings"].values())
    print("plot:", result["plot"])
