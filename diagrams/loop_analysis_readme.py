"""Loop analysis of the README's synthesis examples
================================================

The README's synthesis examples analysed: poles, margins, S/T/KS, the W∞ channel, responses.

The first README block designs three W∞ controllers for Drake's Acrobot linearized upright
(state feedback at the optimum, output feedback measuring the two angles, state feedback with
its poles in a disk of 250 rad/s); the second block is python-control's ``hinfsyn`` example.
``sd.loop_analysis(result, plant)`` analyses each loop against the generalized plant it was
designed for (so the performance channel w -> z is drawn with its certified γ), and
``sd.plot_loop_analysis`` writes one figure per design; the markdown tables are printed and
returned.

What the analysis says about these designs (measured): the acrobot is open-loop unstable
(pole at +5.7 rad/s) and a disturbance entering with the torque is rejected at the price of
small input margins (disk margin about 0.09, ±0.8 dB, ±5°, which ``sd.synthesis.margins``'s
exact uniform gain margin confirms); the angle-only output feedback has controller poles near
1.3e3 rad/s, about 200 x the plant's fastest mode, and the analysis warns with the disk that
would bound them.

Examples
--------
From the repository root (files in out/diagrams by default)::

    python diagrams/loop_analysis_readme.py
    python diagrams/loop_analysis_readme.py my_results
"""

import sys
import warnings
from pathlib import Path

import control
import numpy as np
from pydrake.examples import AcrobotPlant
from pydrake.systems.primitives import Linearize

import sobolev_drake as sd

UPRIGHT = np.array([np.pi, 0.0, 0.0, 0.0])
ANGLES = np.eye(4)[:2]
G0, G1 = np.eye(4), 0.1 * np.eye(4)


def designs():
    """{name: (result, generalized plant)} of the README's synthesis examples."""
    acrobot = AcrobotPlant()
    context = acrobot.CreateDefaultContext()
    context.SetContinuousState(UPRIGHT)
    acrobot.get_input_port(0).FixValue(context, [0.0])
    lin = Linearize(acrobot, context)
    A, B = lin.A(), lin.B()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sd.synthesis.SynthesisWarning)
        out = {
            "acrobot W∞ state feedback": (sd.winf_state_feedback(lin, Gamma0=G0, Gamma1=G1),
                                          sd.winf_plant(A, B, D=B, Gamma0=G0, Gamma1=G1)),
            "acrobot W∞ output feedback (angles)": (
                sd.winf_output_feedback(lin, C=ANGLES, Gamma0=G0, Gamma1=G1),
                sd.winf_plant(A, B, ANGLES, B, Gamma0=G0, Gamma1=G1)),
            "acrobot W∞ state feedback in disk(250)": (
                sd.winf_state_feedback(lin, Gamma0=G0, Gamma1=G1, region=sd.regions.disk(250.0)),
                sd.winf_plant(A, B, D=B, Gamma0=G0, Gamma1=G1)),
        }
        P = control.ss([[-1.0, 1.0], [0.0, 2.0]], [[1.0, 0.0], [1.0, 1.0]],
                       [[1.0, 0.0], [0.0, 0.0], [0.0, 1.0]], [[0.0, 0.0], [0.0, 1.0], [0.1, 0.0]])
        hs = sd.hinfsyn(P, 1, 1).result
        gp, _ = sd.synthesis.generalized_plant(P, 1, 1)
        out["python-control hinfsyn example"] = (hs, gp)
    return out


def run(out_dir="out/diagrams"):
    """Analyse every design, write one PNG each; {name: (LoopAnalysis, png path, table)}."""
    out_dir = Path(out_dir)
    results = {}
    for i, (name, (res, plant)) in enumerate(designs().items()):
        an = sd.loop_analysis(res, plant)
        png = sd.plot_loop_analysis(an, out_dir / f"loop_analysis_{i}.png", title=name)
        results[name] = (an, png, an.table())
    return results


if __name__ == "__main__":
    for name, (an, png, table) in run(sys.argv[1] if len(sys.argv) > 1 else "out/diagrams").items():
        print(f"## {name}\n\n{table}\nfigure: {png}\n")
