"""The speed targets of issue 36, each a ratio measured in one run against its baseline.

    python benchmarks/speed_targets.py [--repeat 3] [--mission-seconds 60] [--arm-seconds 1]
        [--evaluations 2000] [--skip-mission | --skip-arm] [--json out.json]

Process CPU time (``time.process_time``), the variants of one repetition interleaved so machine
load hits them alike, best of ``--repeat``:

* **Tilt-rotor mission** (scenario 2, RK3 at 1e-3, controller period 0.01 s, first
  ``--mission-seconds`` s) against two floors:

  - the project floor: the same diagram with the controller's law returning its first command
    and the force system a constant force (``tiltrotor_mission.floor_patches``; what Drake's
    side and the Python glue cost without the law and the forces);
  - the C++-only floor: the same MultibodyPlant with a constant applied force, a C++
    zero-order hold at the controller period and a log sink, no Python system at all.

  Reported as real-time factors and as mission/floor speed ratios (1 = as fast as the floor).
  Targets: ≥ 0.75 of the project floor, ≥ 0.35 of the C++-only floor.
* **W2 mechanical law vs Drake's InverseDynamicsController** on the 7-joint arm
  (``rigs.seven_link``, gains of ``benchmarks/sampled_controller.py``):

  - per evaluation: one new estimated state fixed, the control output and the time derivatives
    evaluated (what an integrator stage asks of a controller), minus the cost of fixing the
    input alone;
  - per simulation: ``--arm-seconds`` of tracking on the continuous plant (RK3, 1e-6), also
    with the W2 law sampled at 1 kHz.

  Target: the W2 law ≤ 3× IDC per evaluation.

Prints each ratio with its target as met / not met.  The mission's verdict is the median of
the per-repetition ratios (each repetition runs the three variants back to back, so its ratio
shares one moment's machine load), printed with their range and with the ratio of the best
times.  Nothing asserts on these timings (a shared machine's load moves them; the ratios are
what carries over).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))   # sibling benchmark modules

N = 7


def _arm_gains():
    from sobolev_drake.synthesis.mechanical import controlled_gains
    gains = controlled_gains(Y0=[100.0] * N, Y1=[50.0] * N, Y2=[1.0] * N, Y3=[0.01] * N)
    kd, kp, ki = (np.diag(gains.K[:, k * N:(k + 1) * N]) for k in range(3))
    return gains, kp, ki, kd


def arm_controllers():
    """name → make_controller(plant) of the W2 law and Drake's IDC with the same gains."""
    from pydrake.systems.controllers import InverseDynamicsController

    from sobolev_drake.systems.mechanical_controller import MechanicalController, SobolevLaw
    gains, kp, ki, kd = _arm_gains()
    return {"W2 MechanicalController": lambda plant: MechanicalController.from_plant(
                plant, SobolevLaw(gains)),
            "Drake IDC (C++)": lambda plant: InverseDynamicsController(plant, kp, ki, kd, False),
            "W2 sampled 1 kHz": lambda plant: MechanicalController.from_plant(
                plant, SobolevLaw(gains), period=1e-3)}


def per_evaluation(system, states, desired):
    """CPU seconds per (fix state, evaluate control and derivatives), and per fix alone."""
    context = system.CreateDefaultContext()
    port = system.get_input_port_estimated_state()
    system.get_input_port_desired_state().FixValue(context, desired)
    control = system.get_output_port_control()
    derivatives = system.AllocateTimeDerivatives()
    start = time.process_time()
    for x in states:
        port.FixValue(context, x)
        control.Eval(context)
        system.CalcTimeDerivatives(context, derivatives)
    full = time.process_time() - start
    start = time.process_time()
    for x in states:
        port.FixValue(context, x)
    fix = time.process_time() - start
    return full / len(states), fix / len(states)


def arm_simulation(make, duration):
    from sobolev_drake.rigs.seven_link import fly_seven_link_arm
    from sampled_controller import desired
    trajectory = desired(duration)
    return fly_seven_link_arm(make, trajectory, trajectory.value(0.0).ravel() + 0.1,
                              duration)["cpu_s"]


def cpp_floor(duration, period, accuracy):
    """The mission's MultibodyPlant, constant applied force, a C++ ZOH and log sink only."""
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.framework import DiagramBuilder
    from pydrake.systems.primitives import ConstantVectorSource, LogVectorOutput, ZeroOrderHold

    from sobolev_drake.simulation import simulate
    from sobolev_drake.tiltrotor.params import TiltrotorParams
    from sobolev_drake.tiltrotor.plant import _build_plant   # the plant without its force system

    builder = DiagramBuilder()
    plant, _ = _build_plant(TiltrotorParams(), builder)
    force = builder.AddSystem(ConstantVectorSource(np.zeros(plant.num_velocities())))
    builder.Connect(force.get_output_port(), plant.get_applied_generalized_force_input_port())
    hold = builder.AddSystem(ZeroOrderHold(period, plant.num_multibody_states()))
    builder.Connect(plant.get_state_output_port(), hold.get_input_port())
    LogVectorOutput(hold.get_output_port(), builder, period)
    diagram = builder.Build()
    simulator = Simulator(diagram)
    start = time.process_time()
    simulate(diagram, simulator.get_mutable_context(), duration, progress=False,
             integrator="runge_kutta3", accuracy=accuracy, max_step=period, simulator=simulator)
    return time.process_time() - start, simulator.get_num_steps_taken()


def mission(duration, period, accuracy, floor=False):
    """CPU seconds of simulating (not building) the mission, and the steps taken."""
    import contextlib

    from pydrake.systems.analysis import Simulator

    from sobolev_drake.simulation import simulate
    from sobolev_drake.tiltrotor.mission import build_mission
    from tiltrotor_mission import floor_patches

    # the floor's patches act on systems built inside them (the controller binds its compiled
    # update at construction), so the mission is built inside the block too
    with floor_patches() if floor else contextlib.nullcontext():
        built = build_mission(2, duration, period=period)       # as simulate_mission builds it
        diagram = built["diagram"]
        simulator = Simulator(diagram)
        context = simulator.get_mutable_context()
        built["handles"].set_state(context, diagram, np.zeros(8), np.zeros(8))
        start = time.process_time()
        simulate(diagram, context, duration, progress=False, integrator="runge_kutta3",
                 accuracy=accuracy, max_step=period, simulator=simulator)
        cpu = time.process_time() - start
    return cpu, simulator.get_num_steps_taken()


#: the mission's controller period (s) and RK3 accuracy
PERIOD, ACCURACY = 0.01, 1e-3
#: the mission's variants: command-line name -> (printed name, run(duration, period, accuracy)
#: -> (cpu, steps))
VARIANTS = {"mission": ("mission", mission),
            "project-floor": ("project floor", lambda *a: mission(*a, floor=True)),
            "cpp-floor": ("C++-only floor", cpp_floor)}


def verdict(ok):
    return "met" if ok else "NOT met"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3, help="interleaved repetitions")
    ap.add_argument("--mission-seconds", type=float, default=60.0,
                    help="simulated seconds of the mission and its floors")
    ap.add_argument("--arm-seconds", type=float, default=1.0, help="simulated seconds of the arm")
    ap.add_argument("--evaluations", type=int, default=2000, help="controller evaluations")
    ap.add_argument("--skip-mission", action="store_true", help="only the arm")
    ap.add_argument("--skip-arm", action="store_true", help="only the tilt-rotor mission")
    ap.add_argument("--json", help="write the results to this file")
    ap.add_argument("--variant", choices=sorted(VARIANTS),
                    help="simulate only this mission variant once, untimed (for a profiler such "
                         "as benchmarks/speed_instructions.py)")
    args = ap.parse_args(argv)
    if args.variant:
        VARIANTS[args.variant][1](args.mission_seconds, PERIOD, ACCURACY)
        return
    from sobolev_drake.models.serial_chain import seven_link_arm

    rng = np.random.default_rng(0)
    states = rng.normal(scale=0.3, size=(args.evaluations, 2 * N))
    desired = np.full(2 * N, 0.1)
    arm = {name: make(seven_link_arm()) for name, make in arm_controllers().items()
           if "sampled" not in name}       # a sampled controller's outputs are its state
    best: dict = {}
    rounds: list = []          # per repetition: (mission, project floor, C++-only floor) CPU s

    def keep(key, value):
        best[key] = min(best.get(key, np.inf), value)

    period, accuracy, T = PERIOD, ACCURACY, args.mission_seconds
    for _ in range(args.repeat):
        for name, system in ({} if args.skip_arm else arm).items():
            full, fix = per_evaluation(system, states, desired)
            keep(("eval", name), full - fix)
        for name, make in ({} if args.skip_arm else arm_controllers()).items():
            keep(("sim", name), arm_simulation(make, args.arm_seconds))
        if not args.skip_mission:
            this_round = []
            for name, run in VARIANTS.values():
                cpu, steps = run(T, period, accuracy)
                keep(("mission", name), cpu)
                best["steps", name] = steps / T
                this_round.append(cpu)
            rounds.append(this_round)

    results = {}
    law, idc = "W2 MechanicalController", "Drake IDC (C++)"
    if not args.skip_arm:
        print(f"7-joint arm, best of {args.repeat} (process CPU)\n")
        print("| controller | µs per evaluation | CPU s per simulated s |")
        print("|---|---|---|")
        for name in arm_controllers():
            per_eval = f"{1e6 * best['eval', name]:.1f}" if ("eval", name) in best else "—"
            print(f"| {name} | {per_eval} | {best['sim', name] / args.arm_seconds:.3f} |")
        eval_ratio = best["eval", law] / best["eval", idc]
        sim_ratio = best["sim", law] / best["sim", idc]
        results["law_vs_idc_per_evaluation"] = eval_ratio
        results["law_vs_idc_per_simulation"] = sim_ratio
        sampled = best["sim", "W2 sampled 1 kHz"] / best["sim", idc]
        results["sampled_law_vs_idc_per_simulation"] = sampled
        print(f"\nW2 law / IDC per evaluation: {eval_ratio:.2f}× (target ≤ 3×: "
              f"{verdict(eval_ratio <= 3.0)}); per simulation: {sim_ratio:.2f}× "
              f"(sampled at 1 kHz: {sampled:.2f}×)")
    if not args.skip_mission:
        print(f"\ntilt-rotor scenario 2, first {T:g} s, best of {args.repeat} (process CPU)\n")
        print("| variant | CPU s | real-time factor | steps/s |")
        print("|---|---|---|---|")
        for name in ("mission", "project floor", "C++-only floor"):
            cpu = best["mission", name]
            print(f"| {name} | {cpu:.2f} | {T / cpu:.1f}× | {best['steps', name]:.1f} |")
        # each repetition's ratio shares that moment's machine load; their median is the
        # verdict (the quotient of best-of times pairs different moments), the range its spread
        r = np.array(rounds)
        per_round = {"project floor": r[:, 1] / r[:, 0], "C++-only floor": r[:, 2] / r[:, 0]}
        for name, key, target in (("project floor", "mission_vs_project_floor", 0.75),
                                  ("C++-only floor", "mission_vs_cpp_floor", 0.35)):
            ratios = per_round[name]
            median = float(np.median(ratios))
            of_best = best["mission", name] / best["mission", "mission"]
            results[key] = median
            results[key + "_range"] = [float(ratios.min()), float(ratios.max())]
            results[key + "_of_best_times"] = of_best
            lead = "\n" if name == "project floor" else ""
            print(f"{lead}mission speed / {name}: median "
                  f"{median:.2f} over {len(ratios)} repetitions (range {ratios.min():.2f}–"
                  f"{ratios.max():.2f}; of the best times {of_best:.2f}) (target ≥ {target}: "
                  f"{verdict(median >= target)})")
    results["cpu_s"] = {f"{a}/{b}": v for (a, b), v in best.items()}
    if args.json:
        with open(args.json, "w", encoding="utf-8") as f:
            json.dump(results, f, indent=2)


if __name__ == "__main__":
    main()
