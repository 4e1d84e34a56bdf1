"""Timing of the balance-sgaa W∞ design (successive Galerkin approximation, thesis 4.4).

    python benchmarks/galerkin.py [--nodes 20 40] [--methods tensor direct] [--blas-threads 1] [--json out.json]

For each Gauss–Legendre rule (nodes³ points on Ω) it times the full W∞ design (Algorithm 4.2,
degree-4 basis, 34 terms, γ = 5, tol 1e-8): problem set-up (basis, model and cost at the
nodes, checks), tensor precomputation and the iterations, with the ``tensor`` method (A(p) =
A₀ + A₁·p precomputed once) and the ``direct`` method (A assembled from the nodes at every
Galerkin solve).  It prints wall and process-CPU seconds and the 40³/20³ ratios, and the
largest coefficient difference between rules (quadrature convergence).  Target: full W∞ design
< 10 s.  Nothing here is asserted; the machine may be shared, so CPU time is the fairer number.

Measured (2-core machine shared with other jobs, load ≈ 3, 1 BLAS thread): 20³ nodes — direct
0.9 s wall / 0.4 s CPU, tensor 1.5 s / 0.7 s; 40³ nodes — direct 7.3 s / 2.3 s, tensor
8.2 s / 3.2 s (CPU ratio 40³/20³ ≈ 4.3–5.6 for 8× the nodes); the coefficients change by
< 3e-11 from 20³ to 40³ (8³ already agrees with 20³ to 2e-9, 6³ to 1e-4), so 40³ is a
stress test only.

BLAS threads: unless ``OPENBLAS_NUM_THREADS`` is already set, this script sets it to 1 before
numpy loads.  The Galerkin products are tall and skinny (34 × Q times Q × 34·P); on the shared
2-core machine a multi-threaded OpenBLAS spins on them (measured under load: 34×64000 @ 64000×34
takes 1.6 s CPU with threads vs 0.009 s single-threaded).  Pass ``--blas-threads N`` to compare.
"""

from __future__ import annotations

import os
import sys

if __name__ == "__main__":  # must happen before numpy is imported
    for i, a in enumerate(sys.argv):
        if a == "--blas-threads" and i + 1 < len(sys.argv):
            os.environ["OPENBLAS_NUM_THREADS"] = sys.argv[i + 1]
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import json  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

from sobolev_drake.models.two_wheeled_design import design_model  # noqa: E402
from sobolev_drake.synthesis.galerkin_balance import WINF, sgaa_problem, u0  # noqa: E402


def time_design(nodes: int, method: str) -> dict:
    w0, c0 = time.perf_counter(), time.process_time()
    prob = sgaa_problem(WINF, design_model(), nodes)
    w1, c1 = time.perf_counter(), time.process_time()
    res = prob.solve(u0, tol=1e-8, method=method, check_u0="simulate")
    w2, c2 = time.perf_counter(), time.process_time()
    return {"nodes": nodes, "points": nodes ** 3, "method": method,
            "setup_wall": w1 - w0, "setup_cpu": c1 - c0,
            "tensor_wall": res.diagnostics.get("tensor_time", np.nan),
            "solve_wall": w2 - w1, "solve_cpu": c2 - c1,
            "total_wall": w2 - w0, "total_cpu": c2 - c0,
            "iterations": res.iterations,
            "inner": [h["inner_iterations"] for h in res.history],
            "residual_rel": res.history[-1]["residual_rel"],
            "coefficients": res.coefficients.tolist()}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--nodes", type=int, nargs="+", default=[20, 40])
    ap.add_argument("--methods", nargs="+", default=["tensor", "direct"])
    ap.add_argument("--json", default=None)
    ap.add_argument("--blas-threads", default=None, help="OPENBLAS_NUM_THREADS (default 1)")
    args = ap.parse_args(argv)
    print(f"OPENBLAS_NUM_THREADS = {os.environ.get('OPENBLAS_NUM_THREADS')}")
    time_design(6, "tensor")  # warm-up (first calls load LAPACK paths etc.)
    rows = []
    print(f"{'nodes':>6} {'points':>7} {'method':>7} {'setup':>7} {'tensor':>7} {'solve':>7} "
          f"{'total':>7} {'cpu':>7} {'iters':>5}  inner")
    for n in args.nodes:
        for m in args.methods:
            r = time_design(n, m)
            rows.append(r)
            print(f"{n:>6} {r['points']:>7} {m:>7} {r['setup_wall']:7.2f} {r['tensor_wall']:7.2f} "
                  f"{r['solve_wall']:7.2f} {r['total_wall']:7.2f} {r['total_cpu']:7.2f} "
                  f"{r['iterations']:>5}  {r['inner']}")
    for m in args.methods:
        sel = [r for r in rows if r["method"] == m]
        for a, b in zip(sel, sel[1:]):
            print(f"{m}: {b['nodes']}³/{a['nodes']}³ ratio: wall {b['total_wall'] / a['total_wall']:.2f}, "
                  f"cpu {b['total_cpu'] / a['total_cpu']:.2f} (points ×{b['points'] / a['points']:.0f})")
            dc = np.abs(np.subtract(b["coefficients"], a["coefficients"])).max()
            print(f"{m}: max coefficient change {a['nodes']}³ → {b['nodes']}³: {dc:.2e}")
    best = min(r["total_wall"] for r in rows)
    print(f"fastest full W∞ design: {best:.2f} s wall (target < 10 s)")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(rows, fh, indent=1)


if __name__ == "__main__":
    main()
