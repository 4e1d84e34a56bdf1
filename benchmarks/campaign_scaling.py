"""Campaign scaling on this machine: the same campaign with 1 and 2 worker processes (and on
``dask-local``), measured in the same run.

    python benchmarks/campaign_scaling.py [--campaign manipulator] [--seeds 8] [--workers 1 2]
                                          [--dask] [--duration S] [--out DIR]

Prints a markdown table: wall time, cases per second, speed-up against one worker, the mean cost
per case as the workers saw it (``wall_s`` of the records) and the largest resident memory of a
worker process (sampled every 0.2 s).  The runs write into temporary folders (or ``--out``) and
check that every executor produced the same records.  Nothing asserts on the timings; the
campaign issue's target is a speed-up ≥ 1.7 with 2 workers on a 2-core machine.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import tempfile
import threading
import time
from pathlib import Path

import psutil

from sobolev_drake.campaign import run_campaign


class PeakWorkerMemory:
    """Largest resident set size of any child process while the block runs (MiB)."""

    def __enter__(self):
        self.peak, self._stop = 0.0, threading.Event()
        self._thread = threading.Thread(target=self._sample, daemon=True)
        self._thread.start()
        return self

    def _sample(self):
        me = psutil.Process(os.getpid())
        while not self._stop.wait(0.2):
            for child in me.children(recursive=True):
                try:
                    self.peak = max(self.peak, child.memory_info().rss / 2 ** 20)
                except psutil.Error:
                    pass

    def __exit__(self, *exc):
        self._stop.set()
        self._thread.join()


def records(folder):
    out = {}
    for line in Path(folder, "records.jsonl").read_text(encoding="utf-8").splitlines():
        r = json.loads(line)
        cost = r.pop("wall_s")
        r.pop("pid")
        out[r["key"]] = (r, cost)
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--campaign", default="manipulator")
    ap.add_argument("--seeds", type=int, default=8)
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--dask", action="store_true", help="also run on dask-local with the most workers")
    ap.add_argument("--duration", type=float, default=None)
    ap.add_argument("--out", default=None)
    args = ap.parse_args()
    root = Path(args.out or tempfile.mkdtemp(prefix="campaign_scaling_"))
    runs = [(f"processes × {w}", w, None) for w in args.workers]
    if args.dask:
        runs.append((f"dask-local × {max(args.workers)}", max(args.workers), "dask-local"))
    rows, reference = [], None
    for label, workers, scheduler in runs:
        out = root / label.replace(" × ", "_").replace(" ", "_")
        with PeakWorkerMemory() as mem:
            t0 = time.perf_counter()
            summary = run_campaign(args.campaign, seeds=args.seeds, workers=workers,
                                   scheduler=scheduler, duration=args.duration, out_dir=out,
                                   progress=False)
            wall = time.perf_counter() - t0
        recs = records(out)
        numbers = {k: r for k, (r, _) in recs.items()}
        reference = reference or numbers
        rows.append((label, summary["cases"], wall, statistics.mean(c for _, c in recs.values()),
                     mem.peak, numbers == reference))
    base = rows[0][2]
    print(f"campaign {args.campaign}, {args.seeds} seeds, {os.cpu_count()} CPUs\n")
    print("| executor | cases | wall [s] | cases/s | speed-up | mean cost per case [s] | "
          "peak worker RSS [MiB] | same records |")
    print("|---|---|---|---|---|---|---|---|")
    for label, n, wall, cost, peak, same in rows:
        print(f"| {label} | {n} | {wall:.1f} | {n / wall:.2f} | {base / wall:.2f} | {cost:.2f} | "
              f"{peak:.0f} | {'yes' if same else 'NO'} |")


if __name__ == "__main__":
    main()
