"""Solve times of the linear W-infinity LMIs per backend (state feedback + disk, output feedback).

This measures the LMI path only (``method="lmi"``), which is what pole regions, polytopes and
the thesis' literal LMIs use; ``benchmarks/synthesis.py`` compares the default synthesis with
python-control and cvxpy on generated plant families.

Plants: 2 and 3 states (thesis examples' size), 12 states, and a 20-state plant shaped like the
tilt-rotor design (8 DOF -> 16 states + 4 integral states, 4 inputs, 3 disturbances).
Prints wall and process CPU times (LMI build + solve + certificate; the CPU time is the
steadier number on a shared machine) and ratios against the fastest backend of the same run.
Backends: ``clarabel`` (direct, default of the library), ``auto`` (own IPM, certified, with
fallback to Clarabel), ``ipm`` (own Schur-complement IPM alone), ``cvxpy``, ``drake`` (see
``synthesis/lmi.py``).  "backend" is the one that produced the result (after any fallback).
Measured (this machine, 2 cores shared, CPU seconds, 2026-11-21): 20 states SF+disk: clarabel
5.1-5.6, auto/ipm 0.58-0.61, cvxpy 5.0, drake 32; 20 states OF: clarabel 12.5-13.0, auto/ipm
4.7-5.3, cvxpy 12.6, drake 74.  The IPM stalls on the 3-state OF plant (infimum needs
|Y| -> infinity): auto falls back to Clarabel there.  Usage::

    python benchmarks/synthesis_backends.py [--backends clarabel,auto,ipm,cvxpy,drake] [--sizes 2,3,12,20]
                                   [--no-of] [--of-max 20]
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

from sobolev_drake.synthesis.hinf import output_feedback, state_feedback
from sobolev_drake.synthesis.regions import disk
from sobolev_drake.synthesis.sobolev import winf_plant


def mechanical_plant(n_dof, n_int, n_u, n_w, rng, damping=0.5):
    """Linearized mechanical plant [q; qdot] (+ integral states of the first n_int q's).

    M, stiffness K > 0, viscous damping; each input acts mainly on one DOF (plus random
    coupling), so the plant is underactuated but well conditioned, like a linearized vehicle.
    (Purely random M^-1 K with few inputs gave LMIs on which every solver failed.)
    """
    Mh = np.eye(n_dof) + 0.1 * rng.normal(size=(n_dof, n_dof))
    M = Mh @ Mh.T
    L = rng.normal(size=(n_dof, n_dof))
    Kst = 0.5 * (L @ L.T) / n_dof + 0.5 * np.eye(n_dof)
    Bq = np.zeros((n_dof, n_u))
    Bq[:n_u, :n_u] = np.eye(n_u)
    Bq += 0.3 * rng.normal(size=(n_dof, n_u))
    Dq = rng.normal(size=(n_dof, n_w))
    Mi = np.linalg.inv(M)
    n = 2 * n_dof + n_int
    A = np.zeros((n, n))
    A[:n_dof, n_dof:2 * n_dof] = np.eye(n_dof)
    A[n_dof:2 * n_dof, :n_dof] = -Mi @ Kst
    A[n_dof:2 * n_dof, n_dof:2 * n_dof] = -damping * Mi
    A[2 * n_dof:, :n_int] = np.eye(n_int)
    B = np.zeros((n, n_u))
    B[n_dof:2 * n_dof] = Mi @ Bq
    D = np.zeros((n, n_w))
    D[n_dof:2 * n_dof] = Mi @ Dq
    return A, B, D


def plants(sizes, rng):
    out = {}
    for n in sizes:
        ndof = 0
        if n == 2:
            A = np.array([[0, 50], [-50, -50.0]])
            B = D = np.array([[0.0], [1]])
        elif n == 3:
            A = np.array([[0, 0, 1.0], [0, -0.5, 2], [30, 1, -0.5]])  # balance-like
            B, D = np.array([[0.0], [2], [-3]]), np.array([[0.0, 0], [1, 0], [0, 1]])
        elif n == 20:
            ndof = 8
            A, B, D = mechanical_plant(8, 4, 4, 3, rng)
        else:
            ndof = (n - 2) // 2
            A, B, D = mechanical_plant(ndof, n - 2 * ndof, 2, 2, rng)
        # measure positions and integral states (velocities unmeasured), as in the thesis' O.F.
        keep = [i for i in range(A.shape[0]) if i < ndof or i >= 2 * ndof] if n > 3 else [0]
        C = np.eye(A.shape[0])[keep]
        out[n] = (A, B, D, C)
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--backends", default="clarabel,auto,ipm,cvxpy,drake")
    ap.add_argument("--sizes", default="2,3,12,20")
    ap.add_argument("--no-of", action="store_true")
    ap.add_argument("--of-max", type=int, default=20, help="largest size for output feedback")
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    rng = np.random.default_rng(0)
    backends = args.backends.split(",")
    rows = []
    for n, (A, B, D, C) in plants([int(s) for s in args.sizes.split(",")], rng).items():
        G0, G1 = np.eye(n), 0.1 * np.eye(n)
        p = winf_plant(A, B, C, D, Gamma0=G0, Gamma1=G1)
        region = disk(20.0 if n > 3 else 4 * max(1.0, np.abs(np.linalg.eigvals(A)).max()))
        cases = [("SF+disk", lambda b: state_feedback(p, backend=b, region=region))]
        if not args.no_of and n <= args.of_max:
            cases.append(("OF", lambda b: output_feedback(p, backend=b, method="lmi")))
        for name, fn in cases:
            res = {}
            for b in backends:
                t, c = time.perf_counter(), time.process_time()
                try:
                    r = fn(b)
                    res[b] = (time.perf_counter() - t, time.process_time() - c, r.gamma,
                              f"{r.timings.get('lmi_solve', np.nan):.3f} by {r.backend}"
                              + (" (fallback)" if r.fallback else "") + (" (regularized)" if r.regularized else ""))
                except Exception as e:  # report, keep benchmarking the others
                    res[b] = (np.nan, np.nan, np.nan, str(e)[:60])
            best = min((v[0] for v in res.values() if np.isfinite(v[0])), default=np.nan)
            for b, (tt, tc, g, ts) in res.items():
                rows.append((n, name, b, tt, tt / best, g, ts))
                print(f"n={n:3d} {name:8s} {b:10s} total {tt:8.3f} s (cpu {tc:7.3f} s)  x{tt / best:6.2f}  "
                      f"gamma {g:.6g}  solve {ts}", flush=True)


if __name__ == "__main__":
    main()
