"""Drake's Acrobot balanced upright by a W∞ output-feedback controller that measures only the two
joint angles -- the library's default synthesis call, on the nonlinear plant.

The plant is linearized at the upright equilibrium with Drake's ``Linearize``; the W∞ channel
z = [Γ0^½ x; Γ1^½ ẋ] with a torque disturbance (D = B) gives a singular problem (noise-free
angle measurements), which the default ``output_feedback`` regularizes (see its warning).  Drake's
``LinearQuadraticRegulator`` on the full state is printed beside it as the baseline.
Sign convention: u = +K x for state feedback, u = CK x_K + DK y for the dynamic controller.
Run:  python diagrams/acrobot_upright.py [DURATION_S]
"""

import sys
import warnings

import numpy as np
from pydrake.examples import AcrobotPlant
from pydrake.systems.analysis import Simulator
from pydrake.systems.controllers import LinearQuadraticRegulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import Linearize, LogVectorOutput

from sobolev_drake.synthesis.hinf import output_feedback
from sobolev_drake.synthesis.sobolev import winf_plant
from sobolev_drake.systems.linear_controllers import LinearDynamicOutputFeedback, LinearStateFeedback

UPRIGHT = np.array([np.pi, 0.0, 0.0, 0.0])  # [θ1, θ2, θ̇1, θ̇2]
START = UPRIGHT + [0.05, -0.05, 0.0, 0.0]
C_ANGLES = np.eye(4)[:2]


def linearized_upright():
    acrobot = AcrobotPlant()
    context = acrobot.CreateDefaultContext()
    context.SetContinuousState(UPRIGHT)
    acrobot.get_input_port(0).FixValue(context, [0.0])
    lin = Linearize(acrobot, context)
    return lin.A(), lin.B()


def design():
    """W∞ output feedback (angles measured) and Drake's LQR baseline (full state, u = -K x)."""
    A, B = linearized_upright()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = output_feedback(winf_plant(A, B, B, np.eye(4), 0.1 * np.eye(4), C_ANGLES))
    K_lqr, _ = LinearQuadraticRegulator(A, B, np.eye(4), np.eye(1))
    return res, -K_lqr, [str(w.message) for w in caught]


def fly(controller, duration):
    """Nonlinear closed loop from START; returns (t, x, u)."""
    builder = DiagramBuilder()
    acrobot = builder.AddSystem(AcrobotPlant())
    builder.AddSystem(controller)
    builder.Connect(acrobot.get_output_port(0), controller.get_input_port(0))
    builder.Connect(controller.get_output_port(0), acrobot.get_input_port(0))
    x_log = LogVectorOutput(acrobot.get_output_port(0), builder)
    u_log = LogVectorOutput(controller.get_output_port(0), builder)
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    diagram.GetMutableSubsystemContext(acrobot, context).SetContinuousState(START)
    Simulator(diagram, context).AdvanceTo(duration)
    xl, ul = x_log.FindLog(context), u_log.FindLog(context)
    return xl.sample_times(), xl.data(), ul.data()


def scores(t, x, u):
    e = x[:2] - UPRIGHT[:2, None]
    return {"ISE": float(np.trapezoid(np.sum(e ** 2, axis=0), t)),
            "max |angle error| [rad]": float(np.abs(e).max()),
            "final |angle error| [rad]": float(np.abs(e[:, -1]).max()),
            "effort ∫u² [N²m²s]": float(np.trapezoid(u[0] ** 2, t))}


def run(duration=10.0):
    res, K_lqr, notes = design()
    ctrl = res.controller
    winf = LinearDynamicOutputFeedback(ctrl.AK, ctrl.BK, ctrl.CK, ctrl.DK, y_op=UPRIGHT[:2],
                                       S=C_ANGLES)
    lqr = LinearStateFeedback(K_lqr, x_r=UPRIGHT)
    rows = {"W∞ output feedback (angles)": scores(*fly(winf, duration)),
            "Drake LQR (full state)": scores(*fly(lqr, duration))}
    return res, rows, notes


if __name__ == "__main__":
    res, rows, notes = run(float(sys.argv[1]) if len(sys.argv) > 1 else 10.0)
    print(f"synthesis: {res.method}, certified gamma {res.gamma:.5g} "
          f"(closed-loop norm {res.certificate.achieved:.5g}); " + "; ".join(notes))
    keys = list(next(iter(rows.values())))
    print("| controller | " + " | ".join(keys) + " |\n|---|" + "---|" * len(keys))
    for name, s in rows.items():
        print(f"| {name} | " + " | ".join(f"{s[k]:.4g}" for k in keys) + " |")
