"""Small dense primal-dual interior-point solver for the LMI programs of ``lmi.py``.

Problem (the LMIs as stored):  minimize c'x  subject to  S_b = C_b - sum_i x_i A_{b,i} >= 0
for each block b, with its dual  maximize -<C, Z>  s.t.  <A_i, Z> = -c_i, Z >= 0.

Infeasible-start path following with the HKM search direction and Mehrotra's
predictor-corrector (Helmberg, Rendl, Vanderbei & Wolkowicz 1996; Kojima, Shindoh & Hara 1997;
Monteiro 1997).  The Newton system is reduced to the m x m Schur complement
M_ij = sum_b tr(A_{b,i} Z_b A_{b,j} S_b^-1) (m = number of decision variables), which for the
synthesis LMIs (a few hundred variables, blocks of 20-90 rows) is far cheaper than a KKT system
holding the dense cone Hessians of size (n(n+1)/2)^2 (what Clarabel factors).  Everything is
dense numpy except the sparse A_i in the Schur-complement product; results are certified
independently by the callers like any other backend.

Measured behaviour (tests/synthesis/test_synthesis.py plants, benchmarks/synthesis.py):
* near the optimum M has cond ~ 1/mu^2; without iterative refinement the dual residual grew
  from 1e-10 to 1e-4 below mu ~ 1e-8 ("AlmostSolved" on most problems); one refinement step
  against the true operator keeps it at ~1e-10;
* on problems whose infimum is approached with a Lyapunov variable growing without bound
  (output feedback, |Y| 1e5..1e10) the dual step lengths collapse (0.02-0.2) while mu stalls
  at 1e-3..1e-6 and the primal residual drifts up (S is updated, not recomputed, and x is
  huge): the method either stops "AlmostSolved" *below* Clarabel's optimum (certified, up to
  5e-4 lower: Clarabel stops early there) or "Stalled" at a point whose controller fails the
  certificate (3-state benchmark plant: gamma 1.002 claimed, 1.187 achieved).  The SDPT3 step
  and centering heuristics below halve the iteration count but do not remove these cases.
"""

from __future__ import annotations

import functools
import time
from typing import Any

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
from threadpoolctl import ThreadpoolController

__all__ = ["solve_sdp"]


@functools.lru_cache(maxsize=1)
def _blas_threads() -> ThreadpoolController:
    """threadpoolctl's view of the BLAS libraries loaded in this process (scanned once: numpy's
    and scipy's OpenBLAS are loaded before any solve).

    The IPM works on many small dense matrices; multi-threaded BLAS on them is slower, and
    much slower on a loaded machine (measured: 14 s vs 1.1 s for the 20-state benchmark).
    Limiting through the cached controller costs ~50 µs per solve.
    """
    return ThreadpoolController()


def _max_step(X, dX):
    """Largest alpha in (0, inf] with X + alpha dX >= 0 (X > 0)."""
    Li = np.linalg.inv(np.linalg.cholesky(X))
    lo = np.linalg.eigvalsh(Li @ dX @ Li.T)[0]
    return np.inf if lo >= 0 else -1.0 / lo


def solve_sdp(c: np.ndarray, C: list[np.ndarray], A: list[np.ndarray], **kw: Any
              ) -> tuple[np.ndarray, str, dict[str, Any]]:
    """:func:`_solve_sdp` with single-threaded BLAS (threadpoolctl; restored afterwards)."""
    with _blas_threads().limit(limits=1, user_api="blas"):
        return _solve_sdp(c, C, A, **kw)


def _solve_sdp(c, C, A, *, tol=1e-8, max_iter=100, step=0.98, verbose=False, stall=4,
               gapdef="both", adaptive=True, refine=1, window=12, time_limit=None):
    """Solve min c'x s.t. C[b] - sum_i x_i A[b][i] >= 0.

    ``C``: list of symmetric (n_b, n_b) arrays; ``A``: list of (m, n_b, n_b) arrays.
    Returns (x, status, info) with status "Solved", "AlmostSolved" (best point with error
    < 1e-5 after progress stopped), "Stalled" (error not halved in ``window`` iterations),
    "MaxIterations", "MaxTime" (``time_limit`` seconds passed, like Clarabel's setting of that
    name) or "NumericalError".  ``adaptive``: SDPT3's step factor 0.9 + 0.09 min(steps)
    and centering exponent max(1, 3 min(steps)^2); ``refine``: refinement steps of the
    search direction; ``gapdef``: "both" (default), "trSZ" (<S, Z>) or "pd" (|primal - dual objective|).
    """
    m = c.size
    nb = len(C)
    dims = [Cb.shape[0] for Cb in C]
    nn = sum(dims)
    # start (Toh, Todd & Tutuncu's SDPT3 rule): x = 0, Z = zeta I, S = eta I per block
    x = np.zeros(m)
    S, Z = [], []
    for Cb, Ab in zip(C, A):
        n = Cb.shape[0]
        nA = np.sqrt(np.einsum("ijk,ijk->i", Ab, Ab))
        zeta = max(10.0, np.sqrt(n), n * np.max((1.0 + np.abs(c)) / (1.0 + nA)))
        eta = max(10.0, np.sqrt(n), np.linalg.norm(Cb), nA.max())
        Z.append(zeta * np.eye(n))
        S.append(eta * np.eye(n))
    normc, normC = 1.0 + np.linalg.norm(c), 1.0 + np.sqrt(sum(np.sum(Cb * Cb) for Cb in C))
    # the A_i are very sparse (a matrix variable's entry touches a few rows/columns of a
    # block): the Schur complement product A (Z A S^-1)^T is a sparse-dense product
    Af = [sp.csr_matrix(Ab.reshape(m, -1)) for Ab in A]
    As = [sp.csr_matrix(Ab.reshape(m * Ab.shape[1], Ab.shape[2])) for Ab in A]
    status, it = "MaxIterations", 0
    best, history = None, []
    stp = step
    stop = None if time_limit is None else time.perf_counter() + time_limit
    for it in range(1, max_iter + 1):
        if stop is not None and time.perf_counter() > stop:
            status = "MaxTime"
            break
        rp = -c - sum(Af[b] @ Z[b].ravel() for b in range(nb))
        Ax = [np.tensordot(x, A[b], axes=1) for b in range(nb)]
        Rd = [C[b] - Ax[b] - S[b] for b in range(nb)]
        gap = sum(np.sum(S[b] * Z[b]) for b in range(nb))
        mu = gap / nn
        pobj = c @ x
        dobj = -sum(np.sum(C[b] * Z[b]) for b in range(nb))
        # both gaps: <S, Z> alone misses a dual residual that is small but multiplies a huge x
        # (measured: objectives 0.33 vs 0.45 with <S, Z> ~ 1e-11 on a disturbance-model plant)
        pd = abs(pobj - dobj)
        relgap = {"trSZ": gap, "pd": pd}.get(gapdef, max(gap, pd)) / (1.0 + abs(pobj) + abs(dobj))
        pres = np.linalg.norm(rp) / normc
        dres = np.sqrt(sum(np.sum(R * R) for R in Rd)) / normC
        err = max(relgap, pres, dres)
        if best is None or err < best[0]:
            best = (err, x.copy(), it)
        elif best[0] < 1e-5 and it - best[2] >= stall:  # no progress: numerical limit reached
            break
        history.append(err)
        if it > window and min(history[-window:]) > 0.5 * min(history[:-window]):
            status = "Stalled"  # no halving of the error in `window` iterations: give up early
            break
        if verbose:
            print(f"{it:3d} {pobj:+.6e} {dobj:+.6e} gap {relgap:.1e} p {pres:.1e} d {dres:.1e} mu {mu:.1e}")
        if relgap < tol and pres < tol and dres < tol:
            status = "Solved"
            break
        try:
            Si = [np.linalg.inv(Sb) for Sb in S]
            # Schur complement M_ij = sum_b tr(A_i Z A_j S^-1)
            M = np.zeros((m, m))
            for b in range(nb):
                n = dims[b]
                # Z A_j S^-1 for all j as one sparse product and one large GEMM, laid out as
                # Gt[(p, q), j] so that M += A Gt is a sparse-times-contiguous product
                T = As[b] @ Si[b]  # rows (j, r): A_j S^-1
                R = T.reshape(m, n, n).transpose(1, 2, 0).reshape(n, n * m)  # [r, (q, j)]
                M += np.asarray(Af[b] @ (Z[b] @ R).reshape(n * n, m))
            M = 0.5 * (M + M.T)
            try:
                cho = sla.cho_factor(M)
            except (np.linalg.LinAlgError, sla.LinAlgError):  # near the optimum M is ill-conditioned
                cho = sla.cho_factor(M + 1e-13 * np.abs(np.diag(M)).max() * np.eye(m))
        except (np.linalg.LinAlgError, sla.LinAlgError):
            status = "NumericalError"
            break

        def direction(sigma_mu, corr):
            # HKM: dZ = sigma mu S^-1 - Z - (Z dS + corr) S^-1, dS = Rd - sum dx_i A_i
            T0 = []
            rhs = rp.copy()
            for b in range(nb):
                T = sigma_mu * Si[b] - Z[b]
                if corr is not None:
                    T = T - corr[b] @ Si[b]
                T0.append(T)
                rhs -= Af[b] @ (T - Z[b] @ Rd[b] @ Si[b]).ravel()
            dx = sla.cho_solve(cho, rhs)
            for k in range(refine + 1):
                dS = [Rd[b] - np.tensordot(dx, A[b], axes=1) for b in range(nb)]
                dZ = []
                for b in range(nb):
                    T = T0[b] - Z[b] @ dS[b] @ Si[b]
                    dZ.append(0.5 * (T + T.T))
                # residual of the dual equations <A_i, dZ> = rp with the true operator:
                # M is ill-conditioned near the optimum (cond ~ 1/mu^2), so one step of
                # iterative refinement keeps the dual iterates feasible
                if k == refine:
                    break
                r = rp - sum(Af[b] @ dZ[b].ravel() for b in range(nb))
                if np.linalg.norm(r) <= 1e-14 * normc:
                    break
                dx = dx + sla.cho_solve(cho, r)
            return dx, dS, dZ

        def steps(dS, dZ):
            ap = min(1.0, stp * min(_max_step(S[b], dS[b]) for b in range(nb)))
            ad = min(1.0, stp * min(_max_step(Z[b], dZ[b]) for b in range(nb)))
            return ap, ad

        try:
            dx, dS, dZ = direction(0.0, None)  # predictor (affine scaling)
            ap, ad = steps(dS, dZ)
            mu_aff = sum(np.sum((S[b] + ap * dS[b]) * (Z[b] + ad * dZ[b])) for b in range(nb)) / nn
            expon = max(1.0, 3.0 * min(ap, ad) ** 2) if adaptive else 3.0
            sigma = min(1.0, (mu_aff / mu) ** expon)
            corr = [dZ[b] @ dS[b] for b in range(nb)]  # Mehrotra second-order term
            dx, dS, dZ = direction(sigma * mu, corr)
            ap, ad = steps(dS, dZ)
            if verbose:
                print(f"    sigma {sigma:.2e} steps {ap:.3f} {ad:.3f}")
        except (np.linalg.LinAlgError, sla.LinAlgError):
            status = "NumericalError"
            break
        if adaptive:
            stp = max(step - 0.08, min(step, 0.9 + 0.09 * min(ap, ad)))
        x = x + ap * dx
        S = [S[b] + ap * dS[b] for b in range(nb)]
        Z = [Z[b] + ad * dZ[b] for b in range(nb)]
        S = [0.5 * (Sb + Sb.T) for Sb in S]
    if status != "Solved" and best is not None and best[0] < 1e-5:
        status, x = "AlmostSolved", best[1]
    return x, status, {"iterations": it}
