"""Cost per simulated second of the sampled MechanicalController against the continuous one.

    python benchmarks/sampled_controller.py [--duration 2] [--repeat 3] [--json out.json]

The 7-joint arm of ``sobolev_drake.models.serial_chain`` (iiwa-like, built in code) tracks a
multi-sine desired state from a 0.1 rad offset under the W2 law (diagonal weights Y0..Y3 = 100,
50, 1, 0.01 per joint), in Drake's InverseDynamicsController diagram with the controller line
swapped (``MechanicalController.from_plant``).  Two plants:

* ``continuous``: MultibodyPlant(0), error-controlled RK3 at accuracy 1e-6, log every 1 ms;
* ``discrete 1 ms``: MultibodyPlant(1e-3) (the issue's setup); with the continuous controller
  the simulator still integrates ∫e between the plant's steps.

Controllers: the continuous one (``period=None``), sampled at 1 kHz and at 500 Hz, and Drake's
InverseDynamicsController with the same gains (a reference, C++), and the former way to sample,
a ZeroOrderHold on the state in front of the continuous controller.  For each, process CPU time
per simulated second (best of ``--repeat``, the runs of one repetition interleaved so machine
load hits them alike), its ratio to the continuous controller on the same plant, measured in
the same run, the ISE = ∫|q − q_d|² dt relative to the continuous controller's, and the largest
|τ|/effort limit in the first 2 ms (the start-up).  Nothing asserts on these timings; the
accuracy claims (ISE within 5 %, no start-up spike) are tests in
``tests/systems/test_drake_native_mechanical.py``.
"""

from __future__ import annotations

import argparse
import json

import numpy as np
from pydrake.systems.controllers import InverseDynamicsController
from pydrake.trajectories import PiecewisePolynomial

from sobolev_drake.models.serial_chain import SEVEN_LINK_EFFORT_LIMITS
from sobolev_drake.rigs.seven_link import fly_seven_link_arm
from sobolev_drake.synthesis.mechanical import controlled_gains
from sobolev_drake.systems.mechanical_controller import MechanicalController, SobolevLaw

N = 7
GAINS = controlled_gains(Y0=[100.0] * N, Y1=[50.0] * N, Y2=[1.0] * N, Y3=[0.01] * N)
KD, KP, KI = (np.diag(GAINS.K[:, k * N:(k + 1) * N]) for k in range(3))
CONTROLLERS = {
    "continuous": lambda plant: MechanicalController.from_plant(plant, SobolevLaw(GAINS)),
    "sampled 1 kHz": lambda plant: MechanicalController.from_plant(plant, SobolevLaw(GAINS),
                                                                   period=1e-3),
    "sampled 500 Hz": lambda plant: MechanicalController.from_plant(plant, SobolevLaw(GAINS),
                                                                    period=2e-3),
    "Drake IDC (C++)": lambda plant: InverseDynamicsController(plant, KP, KI, KD, False),
    # the former way to sample: a ZeroOrderHold (1 kHz) on the state in front of the
    # continuous controller, which holds x = 0 until its first sample
    "ZOH 1 kHz + continuous": lambda plant: MechanicalController.from_plant(plant,
                                                                            SobolevLaw(GAINS)),
}
ZOH = {"ZOH 1 kHz + continuous": 1e-3}
PLANTS = {"continuous": 0.0, "discrete 1 ms": 1e-3}


def desired(duration):
    times = np.linspace(0.0, duration + 1.0, int(100 * (duration + 1.0)) + 1)
    amp = np.array([0.4, 0.3, 0.5, -0.4, 0.6, 0.5, 0.7])
    q = 0.2 + amp[:, None] * np.sin(np.outer(0.3 * np.arange(1, N + 1) + 1.0, times))
    return PiecewisePolynomial.CubicWithContinuousSecondDerivatives(times, q, np.zeros(N),
                                                                    np.zeros(N))


def fly(make_controller, time_step, trajectory, duration, zoh=None):
    """One run: (CPU seconds of AdvanceTo, ISE, start-up peak |τ|/limit)."""
    run = fly_seven_link_arm(make_controller, trajectory, trajectory.value(0.0).ravel() + 0.1,
                             duration, time_step=time_step, zoh=zoh)
    cpu, t, x, u = run["cpu_s"], run["t"], run["x"], run["u"]
    e = x[:N] - trajectory.vector_values(t)
    ise = float(np.trapezoid(np.sum(e ** 2, axis=0), t))
    startup = t <= 2e-3
    peak = float(np.max(np.abs(u[:, startup]).T / SEVEN_LINK_EFFORT_LIMITS))
    return cpu, ise, peak


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=2.0, help="simulated seconds per run")
    ap.add_argument("--repeat", type=int, default=3, help="interleaved repetitions")
    ap.add_argument("--json", help="write the table to this file")
    args = ap.parse_args(argv)
    trajectory = desired(args.duration)
    best, quality = {}, {}
    for _ in range(args.repeat):
        for plant_name, time_step in PLANTS.items():
            for name, make in CONTROLLERS.items():
                cpu, ise, peak = fly(make, time_step, trajectory, args.duration, ZOH.get(name))
                key = (plant_name, name)
                best[key] = min(best.get(key, np.inf), cpu)
                quality[key] = (ise, peak)
    rows = []
    print(f"7-joint arm, {args.duration:g} s simulated, best of {args.repeat} (process CPU)\n")
    print("| plant | controller | CPU s per sim. s | × continuous | ISE / continuous | "
          "start-up max |τ|/limit |")
    print("|---|---|---|---|---|---|")
    for plant_name in PLANTS:
        base_cpu = best[plant_name, "continuous"]
        base_ise = quality[plant_name, "continuous"][0]
        for name in CONTROLLERS:
            cpu = best[plant_name, name] / args.duration
            ise, peak = quality[plant_name, name]
            row = {"plant": plant_name, "controller": name, "cpu_per_sim_s": cpu,
                   "cost_ratio": best[plant_name, name] / base_cpu, "ise_ratio": ise / base_ise,
                   "startup_peak": peak}
            rows.append(row)
            print(f"| {plant_name} | {name} | {cpu:.3f} | {row['cost_ratio']:.2f} | "
                  f"{row['ise_ratio']:.4f} | {peak:.3f} |")
    if args.json:
        with open(args.json, "w", encoding="utf-8") as f:
            json.dump(rows, f, indent=2)


if __name__ == "__main__":
    main()
