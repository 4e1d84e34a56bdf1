"""Two-link arm under a sampled-data W∞ controller (100 Hz, one-sample delay)
==========================================================================

The two-link arm held against gravity by a W∞ controller sampled at 100 Hz with a
one-sample computation delay, designed for the loop that runs (sampled-data design).

The arm is linearized by Drake at q0 = (0.3, 0.5) rad with the torques u0 that hold it there;
``sd.winf_weights(5, 0.8, dof=2)`` asks both joints for 5 rad/s at damping 0.8, with a
disturbance torque entering with the inputs.  ``sd.sampled_data_plant`` discretizes that W∞
plant with the controller's zero-order hold and the delay; ``sd.hinf_discrete`` designs and
certifies in z.  ``sd.loop_analysis`` of that first design reports a controller ringing at the
Nyquist frequency and names the bilinear-domain disk that removes it; the design is repeated
with that region.  The controller (``sd.discrete_controller_system``: Drake's ``AffineSystem``
with ``time_period``) then flies the nonlinear arm (MultibodyPlant) through a torque pulse held
on the sample grid; the energy ratio ‖z‖/‖w‖ of the samples is printed beside the certified γ
(the arm starts at q0, so the bound ‖z‖ ≤ γ‖w‖ applies, up to the plant's nonlinearity).

Examples
--------
From the repository root (files in out/diagrams by default)::

    python diagrams/arm_sampled_winf.py
    python diagrams/arm_sampled_winf.py 3.0 my_results
"""

import sys
import warnings
from pathlib import Path

import numpy as np
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import LogVectorOutput

import sobolev_drake as sd
from sobolev_drake.models.arm import add_arm, make_arm_model
from sobolev_drake.models.linearization import linearize_mechanical
from sobolev_drake.synthesis.discrete import sampled_data_plant
from sobolev_drake.systems.disturbances import TimeProfiledForce

Q0 = np.array([0.3, 0.5])
DT = 0.01
PULSE = (0.1, 0.6, 2.0)   # from, to (s, on the sample grid), torque on joint 1 (N·m)


def design():
    """(W∞ plant, operating point x0, u0, first result, its analysis, result in the region)."""
    model = make_arm_model()
    u0 = np.linalg.solve(model.B(Q0), model.g(Q0))
    A, B, D = linearize_mechanical(model, Q0, np.zeros(2), u0)
    G0, G1 = sd.winf_weights(5.0, 0.8, dof=2)
    plant = sd.winf_plant(A, B, D=B, Gamma0=G0, Gamma1=G1)           # disturbance torques with the inputs
    sdp = sampled_data_plant(plant, DT, computation_delay=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sd.synthesis.SynthesisWarning)
        first = sd.hinf_discrete(sdp, None, None, dt=DT, computation_delay=True)
        an = sd.loop_analysis(first, sdp)
        ring = [w for w in an.warnings if "region=sd.regions.disk(" in w]
        radius = float(ring[0].split("region=sd.regions.disk(")[1].split(")")[0]) if ring else None
        final = first if radius is None else sd.hinf_discrete(
            sdp, None, None, dt=DT, computation_delay=True, region=sd.regions.disk(radius))
    return plant, np.r_[Q0, 0.0, 0.0], u0, first, an, final


def run(duration=3.0, out_dir="out/diagrams"):
    """Design, fly the nonlinear arm, write a plot; a dict of the numbers."""
    plant, x0, u0, first, an, res = design()
    builder = DiagramBuilder()
    arm = add_arm(builder)
    ctrl = builder.AddSystem(sd.discrete_controller_system(res, y_op=x0, u_op=u0))
    t0, t1, torque = PULSE
    pulse = builder.AddSystem(TimeProfiledForce(2, [{"index": 0, "value": torque, "from": t0,
                                                     "to": t1}]))
    builder.Connect(arm.x, ctrl.get_input_port())
    builder.Connect(ctrl.get_output_port(), arm.u)
    builder.Connect(pulse.GetOutputPort("generalized_force"), arm.disturbance)
    x_log = LogVectorOutput(arm.x, builder, publish_period=DT)
    u_log = LogVectorOutput(ctrl.get_output_port(), builder, publish_period=DT)
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    arm.set_state(context, diagram, Q0, [0.0, 0.0])
    simulate(diagram, context, duration)
    x = x_log.FindLog(context).data()
    u = u_log.FindLog(context).data()
    n = min(x.shape[1], u.shape[1]) - 1
    t = DT * np.arange(n)
    # w is the disturbance torque in the input channel (D = B): the pulse as torque on joint 1
    # expressed in input units, held on [t0, t1)
    w = np.zeros((plant.nw, n))
    w[:, (t >= t0 - 1e-9) & (t < t1 - 1e-9)] = np.linalg.solve(
        make_arm_model().B(Q0), [torque, 0.0])[:, None]
    # the logger at t_k publishes before the update at t_k: the command held on [t_k, t_k+1)
    # is the one logged at t_k+1
    z = plant.C1 @ (x[:, :n] - x0[:, None]) + plant.D11 @ w + plant.D12 @ (u[:, 1:n + 1] - u0[:, None])
    ratio = float(np.linalg.norm(z) / np.linalg.norm(w))
    png = sd.plots.plot_time_series(t, {"q - q0 [rad]": (x[:2, :n] - Q0[:, None]).T,
                                        "u - u0 [N·m]": (u[:, 1:n + 1] - u0[:, None]).T},
                                    Path(out_dir) / "arm_sampled_winf.png",
                                    title="arm, W∞ sampled at 100 Hz with a one-sample delay")
    return {"gamma_first": first.gamma, "gamma": res.gamma, "norm": res.discrete.norm_ab13dd,
            "ratio": ratio, "warnings_first": an.warnings, "plot": png,
            "max_error": float(np.abs(x[:2, :n] - Q0[:, None]).max())}


def simulate(diagram, context, duration):
    sd.simulate(diagram, context, duration, label="arm sampled W∞", progress=False,
                accuracy=1e-8, max_step=DT / 4)


if __name__ == "__main__":
    out = run(float(sys.argv[1]) if len(sys.argv) > 1 else 3.0,
              sys.argv[2] if len(sys.argv) > 2 else "out/diagrams")
    print(f"first design: gamma {out['gamma_first']:.4g}; analysis: {out['warnings_first']}")
    print(f"redesign in the suggested region: certified gamma {out['gamma']:.4g} "
          f"(discrete norm {out['norm']:.4g})")
    print(f"nonlinear arm, torque pulse: sampled energy ratio |z|/|w| = {out['ratio']:.4g}, "
          f"max joint error {out['max_error']:.3g} rad")
    print("plot:", out["plot"])
