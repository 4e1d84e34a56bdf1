"""Bounded least squares min ‖u − Bτ̄‖² s.t. lo ≤ τ̄ ≤ hi (thesis (7.84)–(7.86)).

The solver behind :func:`sobolev_drake.tiltrotor.allocation.bounded_least_squares` (re-exported
there, which is where to import it from): a primal–dual active-set method on the small box QP
with a primal active-set and scipy BVLS fallbacks, and a fast path for the default call (the
controller allocates at every sample): the compiled kernel ``sobolev_drake/native/bls.c`` when
built, else Python floats for the vector work and LAPACK called directly for the solves, same
algebra as the general path.

Rank deficiency.  At low airspeed the surface columns of B are (nearly) zero, so the LS problem
has no unique minimizer.  We solve it in scaled variables s = (τ̄ − τ̄_p)/D, D = (hi − lo)/2,
τ̄_p = clip(0, lo, hi) (the "do nothing" command), with a tiny Tikhonov term
ε‖s‖², ε = ``regularization``·‖BD‖²_F (default 1e-12), which makes the QP strictly convex so
the active-set iterations are well defined.  Its bias (≈ ε/σ_min²(BD), up to 1e-5 for badly
conditioned B) is then removed: on the final active set the free variables are re-solved by
minimum-norm least squares (SVD cutoff 1e-10).  Net effect: the exact bounded LS solution when
it is unique; among non-unique minimizers (zero or dependent columns) the one closest to τ̄_p in
range-relative units.  ``regularization=0`` disables the Tikhonov term (singular problems then
go to scipy's BVLS).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike
from scipy.linalg import lapack as _lapack
from scipy.optimize import lsq_linear

from sobolev_drake.validation import real_array

from sobolev_drake.native import kernel

__all__ = ["bounded_least_squares", "box_qp_active_set", "bvls_with_regularization", "check_problem"]


def check_problem(B: ArrayLike, u: ArrayLike, lo: ArrayLike, hi: ArrayLike
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    B, u = real_array("B", B), real_array("u", u)
    if B.ndim != 2 or B.shape[0] == 0 or B.shape[1] == 0:
        raise ValueError(f"B must be a non-empty 2-D matrix (n × m), got shape {B.shape}")
    n, m = B.shape
    if u.shape != (n,):
        raise ValueError(f"u must be a vector of length n = {n} (rows of B), got shape {u.shape}")
    lo = np.broadcast_to(np.asarray(lo, dtype=float), (m,)) if np.ndim(lo) == 0 else np.asarray(lo, dtype=float)
    hi = np.broadcast_to(np.asarray(hi, dtype=float), (m,)) if np.ndim(hi) == 0 else np.asarray(hi, dtype=float)
    if lo.shape != (m,) or hi.shape != (m,):
        raise ValueError(f"lo and hi must be vectors of length m = {m} (columns of B), "
                         f"got shapes {lo.shape} and {hi.shape}")
    if not (np.isfinite(B).all() and np.isfinite(u).all()):
        raise ValueError("B and u must be finite")
    if not (lo <= hi).all():            # also catches NaN
        bad = np.flatnonzero(~(lo <= hi))
        raise ValueError(f"need lo <= hi (no NaN) elementwise; violated at indices {bad.tolist()}")
    if not (np.isfinite(lo).all() and np.isfinite(hi).all()):
        raise ValueError("lo and hi must be finite (the scaling uses the box widths)")
    return B, u, lo, hi


def _solve(H, rhs):
    """Solve H x = rhs (small dense, LU with partial pivoting: LAPACK dgesv, as numpy's solve
    but without its per-call overhead); raises LinAlgError if singular."""
    _, _, x, info = _lapack.dgesv(H, rhs)
    if info != 0:
        raise np.linalg.LinAlgError("singular matrix")
    return x


_GELSD_WORK: dict = {}


def _lstsq_min_norm(A, b, rcond, with_rank=False):
    """Minimum-norm least squares (LAPACK dgelsd, numpy's lstsq driver) with relative
    singular-value cutoff ``rcond``; ``with_rank``: also return the effective rank."""
    n, m = A.shape
    key = (n, m, rcond)
    if key not in _GELSD_WORK:
        lw = _lapack.dgelsd_lwork(n, m, 1, rcond)
        _GELSD_WORK[key] = (int(lw[0]), int(lw[1]))
    lwork, iwork = _GELSD_WORK[key]
    if n < m:                              # dgelsd needs room for the m-vector solution
        b = np.concatenate([b, np.zeros(m - n)])
    x, _, rank, info = _lapack.dgelsd(A, b, lwork, iwork, rcond)
    if info != 0:                          # SVD failed to converge: numpy's path raises too
        out = np.linalg.lstsq(A, b[:n], rcond=rcond)
        return (out[0], int(out[2])) if with_rank else out[0]
    return (x[:m], int(rank)) if with_rank else x[:m]


def _box_qp_pdas(H, g, l, h, low, up, max_iter=25):
    """Primal–dual active-set (semismooth Newton) for min ½sᵀHs − gᵀs, l ≤ s ≤ h.

    Hintermüller, Ito & Kunisch (2003): guess the active sets, solve the equality-constrained
    problem, update the guess from s and the multipliers λ = g − Hs; stop when the guess repeats,
    which certifies the KKT conditions.  Usually 2–4 solves (1 with a correct warm start), but it
    may cycle for general H: returns None then (the caller falls back to the primal method).
    """
    c = np.trace(H) / len(g)
    for it in range(max_iter):
        act = low | up
        free = ~act
        s = np.where(up, h, np.where(low, l, 0.0))
        if free.any():
            Hf = H[free]
            s[free] = _solve(Hf[:, free], g[free] - Hf[:, act] @ s[act])
        lam = g - H @ s
        lam[free] = 0.0
        new_up = lam + c * (s - h) > 0
        new_low = (lam + c * (s - l) < 0) & ~new_up
        if (new_up == up).all() and (new_low == low).all():
            return s, low, up, it + 1
        low, up = new_low, new_up
    return None


def box_qp_active_set(H: np.ndarray, g: np.ndarray, l: np.ndarray, h: np.ndarray, max_iter: int
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray, int] | None:
    """Primal active-set method for min ½sᵀHs − gᵀs, l ≤ s ≤ h, H ≻ 0 (Nocedal–Wright §16.5).

    Returns (s, at_lower, at_upper, iterations) or None if it did not converge (cycling).
    """
    s = np.clip(np.linalg.solve(H, g), l, h)
    low, up = s <= l, s >= h
    at_subspace_min = False
    scale = max(np.max(np.abs(g)), np.max(np.abs(H)) * max(1.0, np.max(np.abs(s))), 1e-300)
    tol = 1e-11 * scale
    for it in range(max_iter):
        if not at_subspace_min:
            free = ~(low | up)
            target = s.copy()
            if free.any():
                Hf = H[free]
                target[free] = np.linalg.solve(Hf[:, free], g[free] - Hf[:, ~free] @ s[~free])
            p = target - s
            # Longest feasible step along p (≤ 1); the first bound hit joins the working set.
            with np.errstate(divide="ignore", invalid="ignore"):
                lim = np.where(p > 0, (h - s) / p, np.where(p < 0, (l - s) / p, np.inf))
            lim[~free] = np.inf
            block = int(np.argmin(lim))
            if lim[block] < 1.0:
                s = s + max(lim[block], 0.0) * p
                if p[block] > 0:
                    up[block], s[block] = True, h[block]
                else:
                    low[block], s[block] = True, l[block]
                continue
            s = target
            at_subspace_min = True
        grad = H @ s - g
        # KKT: at a lower bound the multiplier grad_i must be ≥ 0, at an upper bound −grad_i ≥ 0.
        viol = np.where(low, -grad, 0.0) + np.where(up, grad, 0.0)
        j = int(np.argmax(viol))
        if viol[j] <= tol:
            return s, low, up, it + 1
        low[j] = up[j] = False
        at_subspace_min = False
    return None


_OSQP = {}


def _box_qp_osqp(H, g, l, h):
    """Drake's OSQP on the box QP, then exact re-solve on its active set + KKT check.

    Returns (s, low, up, iterations=0) or None (solver failure or KKT check failed).
    """
    from pydrake.solvers import MathematicalProgram, OsqpSolver, SolverOptions
    if not _OSQP:
        opts = SolverOptions()
        solver = OsqpSolver()
        for k, v in (("eps_abs", 1e-9), ("eps_rel", 1e-9), ("max_iter", 10000)):
            opts.SetOption(solver.solver_id(), k, v)
        _OSQP.update(solver=solver, options=opts)
    prog = MathematicalProgram()
    x = prog.NewContinuousVariables(len(g))
    prog.AddQuadraticCost(H, -g, x, is_convex=True)
    prog.AddBoundingBoxConstraint(l, h, x)
    res = _OSQP["solver"].Solve(prog, None, _OSQP["options"])
    if not res.is_success():
        return None
    s = res.GetSolution(x)
    tol = 1e-7 * (h - l)
    low, up = s <= l + tol, s >= h - tol
    return _box_qp_pdas(H, g, l, h, low, up, max_iter=1)


def bounded_least_squares(B: ArrayLike, u: ArrayLike, lo: ArrayLike, hi: ArrayLike, *,
                          regularization: float = 1e-12, warm_start: ArrayLike | None = None,
                          method: str = "pdas", return_info: bool = False
                          ) -> np.ndarray | tuple[np.ndarray, dict[str, Any]]:
    """τ̄ = argmin ‖u − Bτ̄‖² s.t. lo ≤ τ̄ ≤ hi (thesis (7.84)–(7.86)).

    Parameters
    ----------
    B : array_like, shape (n, m)
        Input matrix.
    u : array_like, shape (n,)
        Desired generalized input u*.
    lo, hi : array_like, shape (m,) or float
        Finite bounds (scalars broadcast); lo == hi fixes a variable.
    regularization : float
        Relative Tikhonov weight ε (module docstring); 0 disables it.
    warm_start : array_like, optional
        Guess of the active set (the ``active`` array of a previous call); only affects speed,
        not the solution.
    method : {"pdas", "osqp"}
        ``"pdas"`` (default: primal–dual active set, pure numpy) or ``"osqp"`` (Drake's OSQP,
        then the exact solve on its active set, KKT-checked; PDAS if the check fails).  Both
        fall back to a primal active-set method and finally to scipy's BVLS.
    return_info : bool
        Also return a dict with ``residual`` ‖u − Bτ̄‖, ``active`` (−1 lower, +1 upper, 0 free
        per variable), ``iterations`` and ``method``.

    Returns
    -------
    ndarray, shape (m,), or (ndarray, dict)
        τ̄, with the info dict when ``return_info``.
    """
    if method == "pdas" and isinstance(regularization, float) and 0.0 < regularization < math.inf:
        out = _bls_fast(B, u, lo, hi, regularization, warm_start)
        if out is not None:
            return out if return_info else out[0]
    B, u, lo, hi = check_problem(B, u, lo, hi)
    if method not in ("pdas", "osqp"):
        raise ValueError(f"method must be 'pdas' or 'osqp', got {method!r}")
    if not (np.isfinite(regularization) and regularization >= 0):
        raise ValueError(f"regularization must be a finite non-negative number, got {regularization}")
    m = B.shape[1]
    width = hi - lo
    tau_p = np.minimum(np.maximum(0.0, lo), hi)        # clip(0, lo, hi)
    var = width > 0                      # fixed variables (lo == hi) are removed
    all_var = bool(var.all())
    scale = 0.5 * width if all_var else np.where(var, 0.5 * width, 1.0)
    tau = tau_p.copy()
    if all_var:
        A = B * scale
        b = u - B @ tau
        l = (lo - tau_p) / scale
        h = (hi - tau_p) / scale
    else:
        tau[~var] = lo[~var]
        A = B[:, var] * scale[var]
        b = u - B @ tau
        l = (lo[var] - tau_p[var]) / scale[var]
        h = (hi[var] - tau_p[var]) / scale[var]
    info = {"method": "none", "iterations": 0}
    active = np.zeros(m, dtype=int)     # −1 on lower bound, +1 on upper bound, 0 free/fixed
    if A.shape[1]:
        k = A.shape[1]
        eps = regularization * max(float((A * A).sum()), 1e-300)
        H = A.T @ A
        H.flat[::k + 1] += eps                         # + ε I
        g = A.T @ b
        if eps == 0.0 and np.linalg.cond(H) > 1e12:  # singular without regularization
            res = bvls_with_regularization(A, b, l, h, eps)
            s, info["method"] = res, "lsq_linear_bvls"
        else:
            out = _box_qp_osqp(H, g, l, h) if method == "osqp" else None
            info["method"] = "osqp"
            if out is None:
                if warm_start is not None:
                    ws = np.asarray(warm_start)
                    if ws.shape != (m,):
                        raise ValueError(f"warm_start must be a length-{m} array of -1/0/+1, got shape {ws.shape}")
                    if not all_var:
                        ws = ws[var]
                    low0, up0 = ws < 0, ws > 0
                else:
                    s0 = _solve(H, g)
                    low0, up0 = s0 < l, s0 > h
                out = _box_qp_pdas(H, g, l, h, low0, up0)
                info["method"] = "pdas"
            if out is None:  # PDAS cycled: primal active set (finite termination for H ≻ 0)
                out = box_qp_active_set(H, g, l, h, max_iter=10 * A.shape[1] + 20)
                info["method"] = "primal_active_set"
            if out is None:  # degenerate cycling: very rare, use the robust reference method
                s, info["method"] = bvls_with_regularization(A, b, l, h, eps), "lsq_linear_bvls"
            else:
                s, low, up, info["iterations"] = out
                s = _polish(A, b, s, low, up, l, h)
        s = np.minimum(np.maximum(s, l), h)
        if all_var:
            tau = tau_p + scale * s
        else:
            tau[var] = tau_p[var] + scale[var] * s
        if info["method"] == "lsq_linear_bvls":
            tol = 1e-12 * max(1.0, float(np.max(np.abs(h - l))))
            low, up = s <= l + tol, s >= h - tol
        if all_var:
            active[low] = -1
            active[up] = 1
        else:
            active[np.flatnonzero(var)[low]] = -1
            active[np.flatnonzero(var)[up]] = 1
    # Variables on a bound are set to it exactly (τ_p + D s may be off by rounding).
    tau = np.where(active < 0, lo, np.where(active > 0, hi, np.minimum(np.maximum(tau, lo), hi)))
    if not return_info:
        return tau
    r = u - B @ tau
    info.update(residual=math.sqrt(float(r @ r)), active=active)
    return tau, info


def _bls_fast(B, u, lo, hi, reg, warm_start, max_iter=25):
    """The default path of :func:`bounded_least_squares` (PDAS, ε > 0, every lo < hi, float64
    arrays): the compiled kernel ``native/bls.c`` when it is built and enabled, else
    :func:`_bls_fast_python`, which the kernel mirrors step by step (same results to
    rounding).  The kernel declines (NotImplemented) the rare inputs it leaves to that Python
    tier (see bls.c: e.g. a warm start given as a list, values that may overflow)."""
    k = kernel("bls")
    if k is not None:
        out = k.solve(B, u, lo, hi, reg, warm_start, max_iter)
        if out is not NotImplemented:
            return out
    return _bls_fast_python(B, u, lo, hi, reg, warm_start, max_iter)


def _bls_fast_python(B, u, lo, hi, reg, warm_start, max_iter=25):
    """Python tier of the default path, kept beside the general path (``_box_qp_pdas`` +
    ``_polish``, the readable reference) because ``benchmarks/speed_tiers.py`` measures it
    ≈ 2× faster (warm-started and cold); the compiled kernel mirrors it step by step.

    The vector work is on Python floats, numpy is kept for the matrix products and LAPACK
    solves: the same algebra as the general path in fewer, cheaper calls (a controller
    allocates at every sample).  Returns (τ̄, info), or None when
    the problem is not of that kind, fails a check or PDAS does not settle — the general path
    then handles it (and raises the descriptive errors).

    Sub-blocks are taken with ``take`` (same values as fancy indexing, half the call cost) and
    the index arrays of an active-set pattern are cached: each numpy call costs 1–3 µs here.
    """
    nd, f64 = np.ndarray, np.float64
    if not (type(B) is nd and type(u) is nd and type(lo) is nd and type(hi) is nd and B.ndim == 2
            and B.dtype == f64 and u.dtype == f64 and lo.dtype == f64 and hi.dtype == f64):
        return None
    n, m = B.shape
    if u.shape != (n,) or lo.shape != (m,) or hi.shape != (m,) or n == 0 or m == 0:
        return None
    isf = math.isfinite
    lol, hil, ul = lo.tolist(), hi.tolist(), u.tolist()
    tp, sc, l, h = [], [], [], []
    for a, b_ in zip(lol, hil):
        if not (isf(a) and isf(b_) and a < b_):
            return None
        t = min(max(0.0, a), b_)                                     # τ̄_p = clip(0, lo, hi)
        d = 0.5 * (b_ - a)                                           # D = (hi − lo)/2
        tp.append(t)
        sc.append(d)
        l.append((a - t) / d)
        h.append((b_ - t) / d)
    if not (all(isf(x) for x in ul) and isf(float(B.sum()))):   # nan/inf (or overflow) in B
        return None
    rng = range(m)
    A = B * np.array(sc)
    b = u - B @ np.array(tp)
    H = A.T @ A
    fro2 = sum(H.diagonal().tolist())                               # ‖A‖²_F = trace AᵀA
    eps = reg * max(fro2, 1e-300)
    H.flat[::m + 1] += eps
    g = A.T @ b
    if warm_start is not None:
        ws = warm_start if type(warm_start) is nd else np.asarray(warm_start)
        if ws.shape != (m,):
            return None
        ws = ws.tolist()
        low, up = [w < 0 for w in ws], [w > 0 for w in ws]
    else:
        s0 = _solve(H, g).tolist()
        low, up = [s0[i] < l[i] for i in rng], [s0[i] > h[i] for i in rng]
    c = (fro2 + m * eps) / m                                         # trace(H) / m
    for it in range(max_iter):
        free, act, s = [], [], []
        for i in rng:
            if up[i]:
                act.append(i)
                s.append(h[i])
            elif low[i]:
                act.append(i)
                s.append(l[i])
            else:
                free.append(i)
                s.append(0.0)
        if free:
            if act:
                key = (m, tuple(act))
                idx = _INDEX.get(key)
                if idx is None:
                    idx = _INDEX[key] = (np.array(free, dtype=np.intp), np.array(act, dtype=np.intp))
                fi, ai = idx
                Hf = H.take(fi, 0)
                xf = _solve(Hf.take(fi, 1), g.take(fi) - Hf.take(ai, 1) @ np.array([s[i] for i in act]))
            else:
                xf = _solve(H, g)
            for i, v in zip(free, xf.tolist()):
                s[i] = v
        sv = np.array(s)
        lam = (g - H @ sv).tolist()
        for i in free:
            lam[i] = 0.0
        new_up, new_low = [], []
        for i in rng:
            nu = lam[i] + c * (s[i] - h[i]) > 0
            new_up.append(nu)
            new_low.append(lam[i] + c * (s[i] - l[i]) < 0 and not nu)
        if new_up == up and new_low == low:
            break
        low, up = new_low, new_up
    else:
        return None
    if free:                                                        # _polish
        if act:
            x, rank = _lstsq_min_norm(A.take(fi, 1), b - A.take(ai, 1) @ sv.take(ai), 1e-10, True)
        else:
            x, rank = _lstsq_min_norm(A, b, 1e-10, True)
        x = x.tolist()
        ok = True
        for i, xi in zip(free, x):
            slack = 1e-12 * (h[i] - l[i])
            if not (xi >= l[i] - slack and xi <= h[i] + slack):
                ok = False
                break
        if ok:
            new = list(s)
            for i, xi in zip(free, x):
                new[i] = min(max(xi, l[i]), h[i])
            if rank == len(free) <= n:
                # full column rank: x is the unique least-squares minimizer on this active
                # set, whose residual cannot exceed that of the regularized s (the test below)
                s = new
            else:
                r_new, r_old = b - A @ np.array(new), b - A @ sv
                if math.sqrt(float(r_new @ r_new)) <= math.sqrt(float(r_old @ r_old)) * (1 + 1e-12) + 1e-300:
                    s = new
    active = [-1 if low[i] else (1 if up[i] else 0) for i in rng]
    tau = []
    for i in rng:
        if active[i] < 0:
            tau.append(lol[i])
        elif active[i] > 0:
            tau.append(hil[i])
        else:
            t = tp[i] + sc[i] * min(max(s[i], l[i]), h[i])
            tau.append(min(max(t, lol[i]), hil[i]))
    tau = np.array(tau)
    r = u - B @ tau
    return tau, {"method": "pdas", "iterations": it + 1, "residual": math.sqrt(float(r @ r)),
                 "active": np.array(active)}


#: index arrays (free, active) per (size, active-set pattern) of :func:`_bls_fast_python`
_INDEX: dict = {}


def _polish(A, b, s, low, up, l, h):
    """Remove the Tikhonov bias: on the final active set, re-solve the free variables by
    minimum-norm least squares (SVD, relative cutoff 1e-10, no normal-equation squaring).

    Kept only if it stays inside the box and does not increase the residual; otherwise (a
    nearly singular free block where the minimum-norm point leaves the box) the regularized
    solution is returned.
    """
    free = ~(low | up)
    if not free.any():
        return s
    fixed = ~free
    rhs = b - A[:, fixed] @ s[fixed]
    Af = A[:, free]
    x = _lstsq_min_norm(Af, rhs, 1e-10)
    lf, hf = l[free], h[free]
    slack = 1e-12 * (hf - lf)
    if (x >= lf - slack).all() and (x <= hf + slack).all():
        new = s.copy()
        new[free] = np.minimum(np.maximum(x, lf), hf)
        r_new, r_old = b - A @ new, b - A @ s
        if math.sqrt(float(r_new @ r_new)) <= math.sqrt(float(r_old @ r_old)) * (1 + 1e-12) + 1e-300:
            return new
    return s


def bvls_with_regularization(A: np.ndarray, b: np.ndarray, l: ArrayLike, h: ArrayLike,
                             eps: float) -> np.ndarray:
    if eps > 0:
        A = np.vstack([A, math.sqrt(eps) * np.eye(A.shape[1])])
        b = np.concatenate([b, np.zeros(A.shape[1])])
    # max_iter: scipy's default (n iterations) can stop bvls before the optimum (measured).
    return lsq_linear(A, b, bounds=(l, h), method="bvls", tol=1e-14, max_iter=50 * A.shape[1]).x
