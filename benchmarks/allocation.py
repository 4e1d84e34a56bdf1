"""Solver comparison for the bounded least-squares allocation (thesis (7.84)) on 8×8 problems.

    python benchmarks/allocation.py [--problems 200] [--json out.json]

For random problems min ‖u − Bτ‖² s.t. lo ≤ τ ≤ hi (B Gaussian 8×8, bounds drawn so that on
average ~4 bounds are active) it times each candidate and reports its worst deviation from a
tight cvxpy + Clarabel reference, plus a slowly varying sequence (as seen by a sampled
controller) solved cold and warm-started.  Timings are wall-clock medians on this machine (best
of ``--repeat`` per problem); they are not asserted anywhere.

Outcome (2-core machine under load, 200 problems): all exact methods match the reference to
~2e-9 except Drake's Clarabel on the SOCP form (‖Bx − u‖, default tolerances: 4e-4) and scipy
``bvls`` with its default ``max_iter`` (= n, stops early on some seeds).  Raw Drake OSQP is the
fastest cold solve (~0.1–0.2 ms) but certifies nothing and has no rank-deficiency handling;
wrapped with the exact active-set re-solve + KKT check it costs about as much as our pure-numpy
primal–dual active set (~0.4–0.6 ms cold), which warm-started in a sequence needs one
iteration (~0.3 ms).  Default: ``method="pdas"``; ``method="osqp"`` is available.
Since the compiled kernel (``native/bls.c``) the default path costs ≈ 6 µs per 8×8 problem
(the "pdas, pure Python" row is the reference it mirrors).
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np
import scipy.sparse as sp
from scipy.optimize import lsq_linear

from sobolev_drake import native
from sobolev_drake.tiltrotor.allocation import bounded_least_squares


def problems(count: int, seed: int = 0, n: int = 8, m: int = 8):
    rng = np.random.default_rng(seed)
    for _ in range(count):
        B = rng.standard_normal((n, m))
        u = rng.standard_normal(n) * rng.uniform(0.5, 5.0)
        lo, hi = -rng.uniform(0.05, 1.0, m), rng.uniform(0.05, 1.0, m)
        yield B, u, lo, hi


def reference(B, u, lo, hi):
    import cvxpy as cp
    x = cp.Variable(B.shape[1])
    prob = cp.Problem(cp.Minimize(cp.sum_squares(u - B @ x)), [x >= lo, x <= hi])
    prob.solve(solver=cp.CLARABEL, tol_gap_abs=1e-12, tol_gap_rel=1e-12, tol_feas=1e-12, tol_ktratio=1e-10)
    return np.asarray(x.value)


def active_set(B, u, lo, hi):
    return bounded_least_squares(B, u, lo, hi)


def active_set_python(B, u, lo, hi):
    with native.disabled():         # the pure-Python reference of the compiled kernel
        return bounded_least_squares(B, u, lo, hi)


def ours_osqp(B, u, lo, hi):
    return bounded_least_squares(B, u, lo, hi, method="osqp")


def bvls(B, u, lo, hi):
    return lsq_linear(B, u, bounds=(lo, hi), method="bvls", tol=1e-14, max_iter=400).x


def bvls_default_max_iter(B, u, lo, hi):
    return lsq_linear(B, u, bounds=(lo, hi), method="bvls", tol=1e-14).x


def trf(B, u, lo, hi):
    return lsq_linear(B, u, bounds=(lo, hi), method="trf", tol=1e-14, lsmr_tol="auto").x


def osqp_direct(B, u, lo, hi):
    import osqp
    m = B.shape[1]
    solver = osqp.OSQP()
    solver.setup(P=sp.csc_matrix(B.T @ B), q=-(B.T @ u), A=sp.identity(m, format="csc"), l=lo, u=hi,
                 eps_abs=1e-10, eps_rel=1e-10, polish=True, verbose=False, max_iter=20000)
    return solver.solve().x


def clarabel_direct(B, u, lo, hi):
    import clarabel
    m = B.shape[1]
    P = sp.triu(sp.csc_matrix(B.T @ B)).tocsc()
    A = sp.vstack([sp.identity(m), -sp.identity(m)]).tocsc()
    settings = clarabel.DefaultSettings()
    settings.verbose = False
    settings.tol_gap_abs = settings.tol_gap_rel = settings.tol_feas = 1e-12
    solver = clarabel.DefaultSolver(P, -(B.T @ u), A, np.concatenate([hi, -lo]), [clarabel.NonnegativeConeT(2 * m)], settings)
    return np.asarray(solver.solve().x)


def drake_clarabel(B, u, lo, hi):
    from pydrake.solvers import ClarabelSolver, MathematicalProgram
    prog = MathematicalProgram()
    x = prog.NewContinuousVariables(B.shape[1])
    prog.AddL2NormCost(B, -u, x)  # ‖Bx − u‖ (Drake's form is ‖Ax + b‖)
    prog.AddBoundingBoxConstraint(lo, hi, x)
    return ClarabelSolver().Solve(prog).GetSolution(x)


def drake_osqp(B, u, lo, hi):
    from pydrake.solvers import MathematicalProgram, OsqpSolver, SolverOptions
    prog = MathematicalProgram()
    x = prog.NewContinuousVariables(B.shape[1])
    prog.AddQuadraticCost(2 * B.T @ B, -2 * B.T @ u, x, is_convex=True)
    prog.AddBoundingBoxConstraint(lo, hi, x)
    opts = SolverOptions()
    for k, v in (("eps_abs", 1e-10), ("eps_rel", 1e-10), ("max_iter", 20000)):
        opts.SetOption(OsqpSolver().solver_id(), k, v)
    return OsqpSolver().Solve(prog, None, opts).GetSolution(x)


METHODS = {"ours: PDAS + primal active set (compiled)": active_set,
           "ours: PDAS, pure Python": active_set_python, "ours: Drake OSQP + active-set re-solve": ours_osqp, "scipy bvls": bvls, "scipy bvls default max_iter": bvls_default_max_iter,
           "scipy trf": trf, "osqp": osqp_direct, "clarabel": clarabel_direct, "drake Clarabel": drake_clarabel,
           "drake OSQP": drake_osqp,
           "cvxpy+Clarabel (reference)": reference}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--problems", type=int, default=200)
    ap.add_argument("--repeat", type=int, default=3, help="time each solve this many times, keep the best")
    ap.add_argument("--json", default=None, help="write the table as JSON to this file")
    args = ap.parse_args(argv)
    probs = list(problems(args.problems))
    refs = [reference(*p) for p in probs]
    rows = []
    for name, fn in METHODS.items():
        times, errs = [], []
        fn(*probs[0])  # warm-up (imports, JIT-free caches)
        for p, r in zip(probs, refs):
            best = np.inf
            for _ in range(args.repeat):  # best of a few: robust to other load on the machine
                t0 = time.perf_counter()
                x = fn(*p)
                best = min(best, time.perf_counter() - t0)
            times.append(best)
            errs.append(float(np.max(np.abs(np.asarray(x) - r))))
        errs = np.array(errs)
        rows.append({"method": name, "median_us": 1e6 * float(np.median(times)),
                     "p95_us": 1e6 * float(np.percentile(times, 95)), "max_err": float(errs.max()),
                     "fails_1e-6": int(np.sum(errs > 1e-6))})
    # A slowly varying sequence (as in a sampled controller): cold vs warm-started active set.
    rng = np.random.default_rng(1)
    B0, dB = rng.standard_normal((8, 8)), rng.standard_normal((8, 8))
    u0, du = 3 * rng.standard_normal(8), 3 * rng.standard_normal(8)
    lo, hi = -rng.uniform(0.05, 1.0, 8), rng.uniform(0.05, 1.0, 8)
    seq = [(B0 + 0.2 * np.sin(0.01 * k) * dB, u0 + np.sin(0.02 * k) * du) for k in range(args.problems)]
    for label, warm in (("sequence, cold start (ours)", False), ("sequence, warm start (ours)", True)):
        times, active, errs = [], None, []
        for B, u in seq:
            t0 = time.perf_counter()
            x, info = bounded_least_squares(B, u, lo, hi, warm_start=active if warm else None, return_info=True)
            times.append(time.perf_counter() - t0)
            active = info["active"]
            errs.append(float(np.max(np.abs(x - reference(B, u, lo, hi)))) if len(errs) < 20 else 0.0)
        rows.append({"method": label, "median_us": 1e6 * float(np.median(times)),
                     "p95_us": 1e6 * float(np.percentile(times, 95)), "max_err": max(errs),
                     "fails_1e-6": int(np.sum(np.array(errs) > 1e-6))})
    print(f"{args.problems} random 8x8 box-constrained least-squares problems "
          "(sequence rows: first 20 checked against the reference)\n")
    print("| method | median µs | p95 µs | max |τ − τ_ref| | #err > 1e-6 |")
    print("|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['method']} | {r['median_us']:.0f} | {r['p95_us']:.0f} | {r['max_err']:.1e} | {r['fails_1e-6']} |")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(rows, fh, indent=1)
    return rows


if __name__ == "__main__":
    main()
