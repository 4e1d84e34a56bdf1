"""Output-feedback H∞ synthesis against the floor of its algorithm (issue 36), same run.

On seeded random regular plants (``random_plants.random_plant``: stable, unstable and lightly
damped families, D12 and D21 full rank) at 10, 20, 40 and 60 states, each repetition runs, in
an order rotated per repetition:

* ``ours``: the library's default call ``output_feedback(plant)`` (Riccati path, certified);
* ``floor``: the tightest certified pipeline of the same algorithm, written here without the
  library's validation, fallbacks and Lyapunov matrix: the balanced, normalized plant (as the
  library's), the same gamma bisection (``riccati.bisect_gamma``, same start and relative
  width) whose level test is the ordered real Schur form of the two Hamiltonians
  (``scipy.linalg.schur(sort="lhp")``) with the residual, PSD and coupling tests (without the
  residual test it accepts levels below the optimum and fails its certificate on lightly
  damped plants), the central controller at the same level as ours, and ONE SLICOT ``ab13dd``
  norm of the final closed loop as its certificate;
* ``care``: the same bisection with scipy's ``solve_continuous_are`` as the Riccati solver,
  certified by one ``ab13dd`` norm;
* ``python-control``: ``control.hinfsyn`` (SLICOT SB10AD), in a worker process with a time
  limit (``--pc-timeout``; its CPU time is measured inside the worker).

Times are process CPU seconds (``time.process_time``; one BLAS thread), the best of
``--reps`` interleaved repetitions per plant and method.  Every controller is judged here,
independently of every method: closed-loop eigenvalues (stabilizing?) and the own Hamiltonian
iteration ``certificates.hinf_norm`` ("certified" = stabilizing and the method's claimed
gamma is not below that norm, 1e-6 relative).  Ratios are method time / floor time per plant,
summarized by their median (and range) per size; the table also counts the plants on which
``ours`` reports the closed loop's Lyapunov matrix P (the floor computes none).
``--p-census`` instead counts, on 105 seeded plants of the five regular families (4-60
states), the results with a P and re-checks each P's bounded-real inequality.  Usage::

    python benchmarks/synthesis_floor.py [--sizes 10,20,40,60] [--plants 3] [--reps 3]
                                         [--pc-timeout 60] [--no-pc] [--p-census]
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import time
import warnings

import numpy as np
import scipy.linalg as sla

from sobolev_drake.synthesis.certificates import brl_residual, hinf_norm
from sobolev_drake.synthesis.hinf_common import BRL_TOL
from sobolev_drake.synthesis.output_feedback import output_feedback
from sobolev_drake.synthesis.problem import DynamicController
from sobolev_drake.synthesis.random_plants import FAMILIES as ALL_FAMILIES, random_plant
from sobolev_drake.synthesis.riccati import (ARE_RESIDUAL_TOL, RiccatiInfeasible, bisect_gamma,
                                             central_controller, normalize)
from sobolev_drake.synthesis.scaling import balance_scaling, scale_plant, unscale_controller

FAMILIES = ("stable", "unstable", "lightly_damped")
#: same bisection width and controller level as the library's Riccati path (hinf_riccati.py)
RTOL, GAP, BACKOFF = 1e-6, 2e-5, (5e-5, 1e-4, 1e-3, 1e-2)


def plants(sizes, count, seed=36):
    out = []
    for n in sizes:
        for i in range(count):
            rng = np.random.default_rng([seed, n, i])
            out.append(random_plant(rng, n, FAMILIES[i % len(FAMILIES)], seed=i))
    return out


# --------------------------------------------------------------------------- floor pipelines
def _schur_are(A, B, Q, R, S):
    """Stabilizing X of A'X + XA + Q - (XB + S) R^-1 (B'X + S') = 0 from the ordered real Schur
    form of the Hamiltonian; RiccatiInfeasible when it has not n stable eigenvalues."""
    n = A.shape[0]
    RiBt, RiSt = np.linalg.solve(R, B.T), np.linalg.solve(R, S.T)
    Ah = A - B @ RiSt
    H = np.block([[Ah, -B @ RiBt], [-(Q - S @ RiSt), -Ah.T]])
    _, U, sdim = sla.schur(H, output="real", sort="lhp")
    if sdim != n:
        raise RiccatiInfeasible("no stabilizing solution")
    return _accurate(A, B, Q, R, S, np.linalg.solve(U[:n, :n].T, U[n:, :n].T).T)


def _accurate(A, B, Q, R, S, X):
    """X and F if X solves the equation to ARE_RESIDUAL_TOL (the library's test): without it
    the bisection accepts the blown-up X of levels below the optimum (measured: controllers
    3-7x above their claimed gamma on the lightly damped plants)."""
    X = 0.5 * (X + X.T)
    G = B.T @ X + S.T
    F = -np.linalg.solve(R, G)
    res = A.T @ X + X @ A + Q + G.T @ F
    scale = 2 * np.linalg.norm(A.T @ X) + np.linalg.norm(Q) + np.linalg.norm(G.T @ F)
    if not np.linalg.norm(res) <= ARE_RESIDUAL_TOL * scale:
        raise RiccatiInfeasible("inaccurate")
    return X, F


def _care(A, B, Q, R, S):
    try:
        X = sla.solve_continuous_are(A, B, Q, R, s=S)
    except (np.linalg.LinAlgError, ValueError):
        raise RiccatiInfeasible("no stabilizing solution") from None
    X, F = _accurate(A, B, Q, R, S, X)
    if np.linalg.eigvals(A + B @ F).real.max() >= 0:  # scipy may return a non-stabilizing X
        raise RiccatiInfeasible("not stabilizing")
    return X, F


class _Level:
    def __init__(self, gamma, X, Y, F, L):
        self.gamma, self.X, self.Y, self.F, self.L = gamma, X, Y, F, L


def _level_test(pn, solver):
    D1 = np.hstack([pn.D11, pn.D12])
    Dc = np.vstack([pn.D11, pn.D21])
    B, C = np.hstack([pn.B1, pn.B2]), np.vstack([pn.C1, pn.C2])
    Q, S = pn.C1.T @ pn.C1, pn.C1.T @ D1
    Qt, St = pn.B1 @ pn.B1.T, pn.B1 @ Dc.T

    def test(g):
        R = D1.T @ D1
        R[:pn.nw, :pn.nw] -= g * g * np.eye(pn.nw)
        Rt = Dc @ Dc.T
        Rt[:pn.nz, :pn.nz] -= g * g * np.eye(pn.nz)
        X, F = solver(pn.A, B, Q, R, S)
        Y, Lt = solver(pn.A.T, C.T, Qt, Rt, St)
        for M in (X, Y):
            ev = np.linalg.eigvalsh(M)
            if ev.min() < -1e-9 * max(1.0, np.abs(ev).max()):
                raise RiccatiInfeasible("not PSD")
        if np.abs(np.linalg.eigvals(X @ Y)).max() >= g * g * (1 - 1e-12):
            raise RiccatiInfeasible("coupling")
        return _Level(g, X, Y, F, Lt.T)
    return test


def _ab13dd(A, B, C, D):
    from slycot import ab13dd
    n, m, p = A.shape[0], B.shape[1], C.shape[0]
    return ab13dd("C", "I", "S", "D", n, m, p, A, np.eye(n), B, C, D, 1e-10)[0]


def bisection_pipeline(solver):
    """Scale and normalize (as the library), bisect, central controller at (1 + GAP) gamma_hi,
    one ab13dd certificate."""
    def run(p):
        T, Su, Sy = balance_scaling([p], outputs=True)
        nrm = normalize(scale_plant(p, T, Su, Sy))
        test = _level_test(nrm.plant, solver)
        _, hi, _, _ = bisect_gamma(test, 0.0, rtol=RTOL)  # the plants have D11 = 0
        for gap in (GAP,) + BACKOFF:  # the library's levels when a certificate fails
            level = (1 + gap) * hi
            ctrl = unscale_controller(nrm.controller(central_controller(nrm.plant, test(level))),
                                      Su, Sy)
            norm = _ab13dd(*p.closed_loop(controller=ctrl))
            if norm <= level * (1 + 1e-6):
                return ctrl, level * (1 + 1e-6)
        raise RuntimeError(f"certificate failed: ab13dd norm {norm:.8g} above {level:.8g}")
    return run


def ours(p):
    r = output_feedback(p)
    return r.controller, r.gamma, None, r.P is not None


def p_census():
    """Results with a Lyapunov matrix P on 105 seeded plants of the regular families (sizes 4-60,
    three seeds each); every P re-checked (PSD, bounded-real residual <= BRL_TOL at gamma)."""
    regular = [f for f in ALL_FAMILIES if f != "singular"]
    cases = [random_plant(np.random.default_rng([7, n, s, k]), n, f, seed=s)
             for n in (4, 8, 14, 20, 30, 40, 60) for k, f in enumerate(regular) for s in range(3)]
    count = {}
    for case in cases:
        r = output_feedback(case.plant)
        if r.P is not None:
            cl = r.closed_loop(case.plant)
            assert np.linalg.eigvalsh(r.P).min() >= -1e-12 * np.abs(r.P).max(), case
            assert brl_residual(*cl, r.P, r.gamma) <= BRL_TOL, case
        row = count.setdefault(case.family, [0, 0])
        row[0] += r.P is not None
        row[1] += 1
    for fam, (got, total) in count.items():
        print(f"{fam}: P on {got} of {total}")
    print(f"all: P on {sum(v[0] for v in count.values())} of {len(cases)}")


# --------------------------------------------------------------------------- python-control
def _hinfsyn_worker(matrices, ny, nu):
    import control
    t = time.process_time()
    A, B, C, D = matrices
    K, _, gam, _ = control.hinfsyn(control.ss(A, B, C, D), ny, nu)  # u = +K y, as ours
    return (K.A, K.B, K.C, K.D), float(gam), time.process_time() - t


class PythonControl:
    """``control.hinfsyn`` in a worker process, ``timeout`` wall seconds per call."""

    def __init__(self, timeout):
        self.timeout, self.pool = timeout, None

    def __call__(self, p):
        if self.pool is None:
            self.pool = mp.get_context("spawn").Pool(1)
            tiny = (np.array([[-1.0]]), np.array([[1.0, 1.0]]), np.array([[1.0], [1.0]]),
                    np.array([[0.0, 1.0], [1.0, 0.0]]))
            self.pool.apply(_hinfsyn_worker, (tiny, 1, 1))  # import control once
        B, C = np.hstack([p.B1, p.B2]), np.vstack([p.C1, p.C2])
        D = np.block([[p.D11, p.D12], [p.D21, np.zeros((p.ny, p.nu))]])
        job = self.pool.apply_async(_hinfsyn_worker, ((p.A, B, C, D), p.ny, p.nu))
        try:
            ctrl, gam, dt = job.get(self.timeout)
        except mp.TimeoutError:
            self.close()
            raise TimeoutError(f"no answer within {self.timeout:g} s") from None
        return DynamicController(*ctrl), gam, dt

    def close(self):
        if self.pool is not None:
            self.pool.terminate()
            self.pool = None


# --------------------------------------------------------------------------- measurement
def measure(p, call):
    t = time.process_time()
    try:
        ctrl, claimed, *inner = call(p)
    except Exception as e:  # a failure is a measurement here
        return {"time": time.process_time() - t, "ok": False, "stable": False,
                "error": f"{type(e).__name__}: {str(e)[:100]}"}
    dt = inner[0] if inner and inner[0] is not None else time.process_time() - t
    has_p = inner[1] if len(inner) > 1 else None
    cl = p.closed_loop(controller=ctrl)
    stable = bool(np.linalg.eigvals(cl[0]).real.max() < 0)
    norm = hinf_norm(*cl)[0] if stable else np.inf
    return {"time": dt, "stable": stable, "claimed": claimed, "norm": norm, "P": has_p,
            "ok": bool(stable and claimed >= norm * (1 - 1e-6))}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="10,20,40,60")
    ap.add_argument("--plants", type=int, default=3, help="plants per size")
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--pc-timeout", type=float, default=60.0)
    ap.add_argument("--no-pc", action="store_true", help="skip python-control")
    ap.add_argument("--p-census", action="store_true",
                    help="count the results with a Lyapunov matrix P on 105 family plants")
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    if args.p_census:
        p_census()
        return
    methods = {"ours": ours, "floor": bisection_pipeline(_schur_are),
               "care": bisection_pipeline(_care)}
    pc = None if args.no_pc else PythonControl(args.pc_timeout)
    if pc is not None:
        methods["python-control"] = pc
    names = list(methods)
    cases = plants([int(s) for s in args.sizes.split(",")], args.plants)
    best = {}  # (case index, method) -> best row
    for rep in range(args.reps):
        for k, case in enumerate(cases):
            order = names[rep % len(names):] + names[:rep % len(names)]
            for m in order:
                if m == "python-control" and rep > 0 and not best[k, m]["ok"] \
                        and "Timeout" in best[k, m].get("error", ""):
                    continue  # do not wait for a timeout twice
                row = measure(case.plant, methods[m])
                if (k, m) not in best or row["time"] < best[k, m]["time"]:
                    best[k, m] = row
            print(f"rep {rep + 1}: {case}: " + ", ".join(
                f"{m} {best[k, m]['time']:.3f}" for m in names), flush=True)
    if pc is not None:
        pc.close()
    print("per plant: CPU s (certified/stabilizing), ratio to floor")
    for k, case in enumerate(cases):
        f = best[k, "floor"]["time"]
        cells = []
        for m in names:
            r = best[k, m]
            flag = "C" if r["ok"] else ("S" if r["stable"] else "-")
            cells.append(f"{m} {r['time']:.3f}{flag} x{r['time'] / f:.2f}")
        print(f"  {case}: " + ", ".join(cells))
    print("\n| n | method | certified | stabilizing | CPU s (median) | time / floor median "
          "[min, max] | python-control / ours (certified) | P reported |")
    print("|---|---|---|---|---|---|---|---|")
    for n in dict.fromkeys(c.plant.n for c in cases):
        ks = [k for k, c in enumerate(cases) if c.plant.n == n]
        for m in names:
            rows = [best[k, m] for k in ks]
            r = np.array([best[k, m]["time"] / best[k, "floor"]["time"] for k in ks])
            pc_ratio = ""
            if m == "ours" and pc is not None:
                v = [best[k, "python-control"]["time"] / best[k, "ours"]["time"] for k in ks
                     if best[k, "python-control"]["ok"]]
                pc_ratio = f"{np.median(v):.1f}" if v else "no certified hinfsyn"
            print(f"| {n} | {m} | {sum(x['ok'] for x in rows)}/{len(rows)} | "
                  f"{sum(x['stable'] for x in rows)}/{len(rows)} | "
                  f"{np.median([x['time'] for x in rows]):.3f} | {np.median(r):.2f} "
                  f"[{r.min():.2f}, {r.max():.2f}] | {pc_ratio} | "
                  + (f"{sum(bool(x.get('P')) for x in rows)}/{len(rows)} |" if m == "ours"
                     else " |"))


if __name__ == "__main__":
    main()
