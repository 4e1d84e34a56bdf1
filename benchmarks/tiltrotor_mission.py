"""Real-time factor of the full-envelope tilt-rotor mission (scenario 2) and its profile.

    python benchmarks/tiltrotor_mission.py [--duration 250] [--profile-seconds 20] [--top 25]

Runs the whole mission once (no Meshcat recording) and prints simulated time / wall time, then
profiles a shorter run with cProfile and prints the top cumulative and internal costs.
Target: ≥ 20× real time.
"""

from __future__ import annotations

import argparse
import cProfile
import io
import pstats
import time


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=250.0, help="simulated seconds (full run)")
    ap.add_argument("--profile-seconds", type=float, default=10.0, help="simulated seconds profiled")
    ap.add_argument("--top", type=int, default=25, help="rows of the profile to print")
    ap.add_argument("--skip-full", action="store_true", help="only profile")
    ap.add_argument("--integrator", default="runge_kutta3",
                    help="Drake integrator (runge_kutta3 error-controlled; runge_kutta2 fixed step)")
    ap.add_argument("--period", type=float, default=0.01, help="controller sampling period [s]")
    args = ap.parse_args(argv)

    from sobolev_drake.experiments.tiltrotor_missions import build_mission, simulate_mission

    # building (imports, URDF parse, gains) is timed separately from simulating
    t0 = time.perf_counter()
    build_mission(2, 1.0)
    print(f"diagram build (incl. imports): {time.perf_counter() - t0:.2f} s")

    if not args.skip_full:
        t0, c0 = time.perf_counter(), time.process_time()
        built, data = simulate_mission(2, args.duration, integrator=args.integrator,
                                       period=args.period)
        wall = time.perf_counter() - t0
        ctrl = built["controller"]
        cpu = time.process_time() - c0
        print(f"scenario 2, {args.duration:g} s simulated in {wall:.1f} s wall ({cpu:.1f} s CPU): "
              f"real-time factor {args.duration / wall:.2f}x wall, {args.duration / cpu:.2f}x CPU "
              f"(target 20x); controller period {ctrl.period} s, integrator {args.integrator}, "
              f"{built['simulator'].get_num_steps_taken()} steps")

    prof = cProfile.Profile()
    t0 = time.perf_counter()
    prof.enable()
    simulate_mission(2, args.profile_seconds, integrator=args.integrator, period=args.period)
    prof.disable()
    wall = time.perf_counter() - t0
    print(f"\nprofiled {args.profile_seconds:g} s simulated in {wall:.1f} s wall "
          f"({args.profile_seconds / wall:.2f}x real time)")
    for key in ("tottime", "cumulative"):
        s = io.StringIO()
        pstats.Stats(prof, stream=s).sort_stats(key).print_stats(args.top)
        print(f"\n--- top {args.top} by {key} ---")
        print("\n".join(line for line in s.getvalue().splitlines() if line.strip())[:12000])


if __name__ == "__main__":
    main()
