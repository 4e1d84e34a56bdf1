"""H-infinity synthesis on generated plant families: ours vs python-control vs cvxpy + Clarabel.

Plants: ``random_plants.plant_family`` (stable, unstable, lightly damped, ill-conditioned,
D11 != 0, singular; 10-40 states), each synthesized as state feedback (SF) and output feedback
(OF), same run, same plants:

* ``ours``: the library's default call (``state_feedback`` / ``output_feedback``);
* ``python-control``: ``control.hinfsyn`` (slycot SB10AD; OF only, as python-control has no
  state-feedback H-infinity);
* ``cvxpy+clarabel``: the library's LMI path through cvxpy (``method="lmi", backend="cvxpy"``),
  up to ``--lmi-max`` states (its time grows ~n^6);
* ``ours+disk``: the default call with a pole region (LMI path), every ``--region-every``-th
  plant up to ``--region-max`` states.

Every controller returned is judged by quantities computed here, independently of the method:
closed-loop stability (eigenvalues) and the closed-loop H-infinity norm (Hamiltonian iteration).
"success" = a stabilizing controller was returned; "honest" = its claimed gamma is not below the
computed norm (1e-6 relative); "gap" = norm / best norm any method reached on that plant - 1
(regular plants: D12, D21 full rank, optimum off the feedthrough bound).  Time ratios are
method time / ours, same plant, same run.  Usage::

    python benchmarks/synthesis.py [--plants 200] [--sizes 10,40] [--lmi-max 16]
                                   [--region-every 5] [--region-max 20] [--pc-timeout 30]
                                   [--json FILE] [--rows FILE.jsonl]
"""

from __future__ import annotations

import argparse
import json
import time
import warnings

import numpy as np

from sobolev_drake.synthesis.certificates import hinf_norm
from sobolev_drake.synthesis.hinf import output_feedback, state_feedback
from sobolev_drake.synthesis.problem import DynamicController
from sobolev_drake.synthesis.random_plants import plant_family
from sobolev_drake.synthesis.regions import disk


def _hinfsyn_worker(matrices, ny, nu):
    import control
    A, B, C, D = matrices
    t = time.perf_counter()
    K, _, gam, _ = control.hinfsyn(control.ss(A, B, C, D), ny, nu)  # u = +K y, as ours
    return (K.A, K.B, K.C, K.D), float(gam), time.perf_counter() - t


class PythonControl:
    """``control.hinfsyn`` in a worker process: SB10AD can run for many minutes on some plants
    (measured: > 80 s on a 16-state plant with D11 != 0), so each call gets ``timeout``
    seconds; the time reported is measured inside the worker (no process overhead)."""

    def __init__(self, timeout):
        self.timeout = timeout
        self.pool = None

    def __call__(self, p):
        import multiprocessing as mp
        if self.pool is None:
            self.pool = mp.get_context("spawn").Pool(1)
            self.pool.apply(_hinfsyn_worker, (_tiny(), 1, 1))  # import control once
        B = np.hstack([p.B1, p.B2])
        C = np.vstack([p.C1, p.C2])
        D = np.block([[p.D11, p.D12], [p.D21, np.zeros((p.ny, p.nu))]])
        job = self.pool.apply_async(_hinfsyn_worker, ((p.A, B, C, D), p.ny, p.nu))
        try:
            ctrl, gam, dt = job.get(self.timeout)
        except mp.TimeoutError:
            self.pool.terminate()
            self.pool = None
            raise TimeoutError(f"no answer within {self.timeout:g} s") from None
        return DynamicController(*ctrl), gam, dt


def _tiny():
    return (np.array([[-1.0]]), np.array([[1.0, 1.0]]), np.array([[1.0], [1.0]]),
            np.array([[0.0, 1.0], [1.0, 0.0]]))


def ours(kind, **kw):
    fn = state_feedback if kind == "SF" else output_feedback

    def run(p):
        r = fn(p, **kw)
        return (r.K if kind == "SF" else r.controller), r.gamma
    return run


def judge(p, kind, method, call):
    t = time.perf_counter()
    try:
        ctrl, claimed, *inner = call(p)
    except Exception as e:  # report, keep going: a failure is a measurement here
        return {"method": method, "time": time.perf_counter() - t, "success": False,
                "error": f"{type(e).__name__}: {str(e)[:120]}"}
    dt = inner[0] if inner else time.perf_counter() - t
    cl = p.closed_loop(K=ctrl) if kind == "SF" else p.closed_loop(controller=ctrl)
    stable = bool(np.linalg.eigvals(cl[0]).real.max() < 0)
    norm = hinf_norm(*cl)[0] if stable else np.inf
    return {"method": method, "time": dt, "success": stable, "claimed": claimed, "norm": norm,
            "honest": bool(stable and claimed >= norm * (1 - 1e-6))}


def run_case(i, case, kind, args, python_control):
    p, n = case.plant, case.plant.n
    methods = [("ours", ours(kind))]
    if kind == "OF":
        methods.append(("python-control", python_control))
    if n <= args.lmi_max:
        methods.append(("cvxpy+clarabel", ours(kind, method="lmi", backend="cvxpy")))
    if i % args.region_every == 0 and n <= args.region_max:
        radius = 10 * max(1.0, np.abs(np.linalg.eigvals(p.A)).max())
        methods.append(("ours+disk", ours(kind, region=disk(radius))))
    rows = [dict(judge(p, kind, m, call), plant=str(case), family=case.family, n=n, kind=kind,
                 regular=case.regular) for m, call in methods]
    best = min((r["norm"] for r in rows if r["success"] and r["method"] != "ours+disk"),
               default=np.inf)
    t_ours = rows[0]["time"]
    for r in rows:
        r["gap"] = r["norm"] / best - 1 if r["success"] and np.isfinite(best) else np.nan
        r["time_ratio"] = r["time"] / t_ours
    return rows


def summarize(rows):
    out = []
    for kind in ("SF", "OF"):
        for method in dict.fromkeys(r["method"] for r in rows if r["kind"] == kind):
            sel = [r for r in rows if r["kind"] == kind and r["method"] == method]
            reg = [r for r in sel if r["regular"] and r["success"] and r["family"] != "feedthrough"]
            gaps = np.array([r["gap"] for r in reg])
            ratios = {b: [r["time_ratio"] for r in sel if lo <= r["n"] <= hi and r["success"]]
                      for b, (lo, hi) in {"10-19": (10, 19), "20-29": (20, 29),
                                          "30-40": (30, 40)}.items()}
            out.append({
                "kind": kind, "method": method, "plants": len(sel),
                "success": sum(r["success"] for r in sel),
                "honest": sum(r.get("honest", False) for r in sel),
                "median gap (regular)": float(np.median(gaps)) if gaps.size else np.nan,
                "max gap (regular)": float(gaps.max()) if gaps.size else np.nan,
                "median time [s]": float(np.median([r["time"] for r in sel])),
                "max time [s]": float(max(r["time"] for r in sel)),
                **{f"time / ours, n {b}": float(np.median(v)) if v else np.nan
                   for b, v in ratios.items()}})
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--plants", type=int, default=200)
    ap.add_argument("--sizes", default="10,40")
    ap.add_argument("--lmi-max", type=int, default=16)
    ap.add_argument("--region-every", type=int, default=5)
    ap.add_argument("--region-max", type=int, default=20)
    ap.add_argument("--seed", type=int, default=2026)
    ap.add_argument("--pc-timeout", type=float, default=30.0,
                    help="seconds allowed to one control.hinfsyn call")
    ap.add_argument("--json", default=None, help="write all rows and the summary as JSON")
    ap.add_argument("--rows", default=None,
                    help="append each plant's rows to this JSON-lines file as they are measured")
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    lo, hi = (int(s) for s in args.sizes.split(","))
    cases = plant_family(args.plants, (lo, hi), seed=args.seed)
    rows, t0 = [], time.perf_counter()
    pc = PythonControl(args.pc_timeout)
    for i, case in enumerate(cases):
        for kind in ("SF", "OF"):
            new = run_case(i, case, kind, args, pc)
            rows += new
            if args.rows:
                with open(args.rows, "a") as fh:
                    fh.writelines(json.dumps(r, default=float) + "\n" for r in new)
        done = i + 1
        eta = (time.perf_counter() - t0) / done * (len(cases) - done)
        print(f"\r[{done}/{len(cases)}] {case}  ETA {eta:5.0f} s   ", end="", flush=True)
    print()
    summary = summarize(rows)
    keys = list(summary[0])
    print("| " + " | ".join(keys) + " |\n|" + "---|" * len(keys))
    for s in summary:
        print("| " + " | ".join(f"{v:.3g}" if isinstance(v, float) else str(v)
                                for v in s.values()) + " |")
    slow = [r for r in rows if r["method"] == "ours" and r["n"] <= 30 and r["time"] > 30]
    failures = "; ".join(f"{r['kind']} {r['plant']}: {r.get('error', 'unstable')}"
                         for r in rows if r["method"] == "ours" and not r["success"])
    print(f"ours: {len(slow)} call(s) over 30 s at <= 30 states; failures: {failures or 'none'}")
    for n_lo, n_hi in ((20, 20), (30, 30), (20, 30)):
        v = [r["time_ratio"] for r in rows if r["method"] == "python-control" and r["regular"]
             and n_lo <= r["n"] <= n_hi]
        if v:
            print(f"regular OF, n {n_lo}-{n_hi}: python-control time / ours median "
                  f"{np.median(v):.1f}x (min {min(v):.1f}x, {len(v)} plants)")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"summary": summary, "rows": rows}, fh, indent=1, default=float)


if __name__ == "__main__":
    main()
