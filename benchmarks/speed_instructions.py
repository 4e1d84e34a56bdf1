"""The mission ratios of issue 36 by instruction count: deterministic where CPU time is not.

    python benchmarks/speed_instructions.py [--mission-seconds 2] [--jobs 2]

Runs each variant of ``speed_targets.py`` (the mission, its project floor, the C++-only floor)
once under valgrind's callgrind, counting only the instructions executed inside
``Simulator::AdvanceTo`` (building the diagram and importing are left out), and prints the
counts and the mission/floor ratios.  The counts repeat to the instruction from run to run, so
a change's effect shows even when the machine's load moves CPU times by ±25 %.  Instructions
are not time: Python and pybind11 code runs at fewer instructions per cycle than Drake's C++,
so the ratios by time are lower than these (docs/scale.md gives both).  Needs valgrind (without
it the script says so and exits 0, so ``make bench`` goes on); a
2 s mission takes a few minutes per variant (6.5 min wall for all three, two at a time).
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))                # the sibling speed_targets.py: its variants
from speed_targets import PERIOD, VARIANTS   # noqa: E402
TOGGLE = "drake::systems::Simulator<double>::AdvanceTo*"


def count(variant: str, seconds: float, folder: str) -> int:
    """Instructions executed inside AdvanceTo by one run of ``variant``."""
    cmd = ["valgrind", "--tool=callgrind", f"--callgrind-out-file={folder}/{variant}.out",
           f"--toggle-collect={TOGGLE}", sys.executable, str(HERE / "speed_targets.py"),
           "--skip-arm", "--variant", variant, "--mission-seconds", repr(seconds)]
    run = subprocess.run(cmd, capture_output=True, text=True, env={**os.environ, "PYTHONHASHSEED": "0"})
    found = re.search(r"I\s+refs:\s+([\d,]+)", run.stderr)
    if run.returncode != 0 or not found:
        raise RuntimeError(f"{variant}: valgrind failed ({run.returncode}):\n{run.stderr[-2000:]}")
    return int(found.group(1).replace(",", ""))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mission-seconds", type=float, default=2.0, help="simulated seconds")
    ap.add_argument("--jobs", type=int, default=2, help="variants run at once")
    args = ap.parse_args(argv)
    if shutil.which("valgrind") is None:     # `make bench` runs every benchmark: not an error
        print("speed_instructions: skipped, valgrind is not installed (it counts instructions "
              "with callgrind); CPU-time ratios: benchmarks/speed_targets.py")
        return
    with tempfile.TemporaryDirectory() as folder, ThreadPoolExecutor(args.jobs) as pool:
        counts = dict(zip(VARIANTS, pool.map(lambda v: count(v, args.mission_seconds, folder),
                                             VARIANTS)))
    print(f"tilt-rotor scenario 2, first {args.mission_seconds:g} s, instructions inside AdvanceTo\n")
    print("| variant | instructions | per controller sample |")
    print("|---|---|---|")
    samples = args.mission_seconds / PERIOD
    for name, n in counts.items():
        print(f"| {name} | {n / 1e6:.1f} M | {n / samples / 1e3:.0f} k |")
    m = counts["mission"]
    print(f"\nmission / project floor (speed ratio by instructions): {counts['project-floor'] / m:.3f}")
    print(f"mission / C++-only floor (speed ratio by instructions): {counts['cpp-floor'] / m:.3f}")


if __name__ == "__main__":
    main()
