"""Control allocation (thesis (7.84)–(7.89)) and thrust → propeller-speed inversion (7.90).

* :func:`bounded_least_squares` — min ‖u − Bτ̄‖² s.t. lo ≤ τ̄ ≤ hi (7.84)–(7.86), solved by a
  primal–dual active-set method (fallbacks: primal active set, scipy BVLS) on the small box QP.
  Chosen by measurement (``benchmarks/allocation.py``): it matches a tight Clarabel reference
  to ~1e-9, is faster than scipy ``lsq_linear`` (bvls/trf), OSQP and Clarabel called directly,
  and warm-started from the previous active set needs a single linear solve.  Raw Drake OSQP
  is faster cold (~2×) but returns no exact active-set solution; ``method="osqp"`` uses it
  followed by the exact re-solve and KKT check.
* :func:`tiltrotor_bounds` — thrust 0–100 N, servo torque ±2 N m, surfaces
  ±(5π/36)·sigmf(V_air; s = 2, c = 12) (7.87)–(7.89) (``tiltrotor_missions.json``).
* :class:`ControlAllocator` — LeafSystem wrapping the two.
* :func:`propeller_speed_for_thrust` — solve f = ρd⁴n²Ct(J, φ), J = V_xz/(n d) for n (7.90);
  :func:`rotor_inflow` gives (V_xz, φ) from the rotor-frame air-relative velocity.

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

import numpy as np
from scipy.linalg import lapack as _lapack
from scipy.optimize import lsq_linear
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import LeafSystem, ValueProducer

from sobolev_drake.data import load

# --------------------------------------------------------------------------------------------
# bounded least squares
# --------------------------------------------------------------------------------------------


def _check_problem(B, u, lo, hi):
    B = np.asarray(B, dtype=float)
    if B.ndim != 2 or B.shape[0] == 0 or B.shape[1] == 0:
        raise ValueError(f"B must be a non-empty 2-D matrix (n × m), got shape {B.shape}")
    n, m = B.shape
    u = np.asarray(u, dtype=float)
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


def _lstsq_min_norm(A, b, rcond):
    """Minimum-norm least squares (LAPACK dgelsd, numpy's lstsq driver) with relative
    singular-value cutoff ``rcond``."""
    n, m = A.shape
    key = (n, m, rcond)
    if key not in _GELSD_WORK:
        lw = _lapack.dgelsd_lwork(n, m, 1, rcond)
        _GELSD_WORK[key] = (int(lw[0]), int(lw[1]))
    lwork, iwork = _GELSD_WORK[key]
    if n < m:                              # dgelsd needs room for the m-vector solution
        b = np.concatenate([b, np.zeros(m - n)])
    x, _, _, info = _lapack.dgelsd(A, b, lwork, iwork, rcond)
    if info != 0:                          # SVD failed to converge: numpy's path raises too
        return np.linalg.lstsq(A, b[:n], rcond=rcond)[0]
    return x[:m]


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


def _box_qp_active_set(H, g, l, h, max_iter):
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


def bounded_least_squares(B, u, lo, hi, *, regularization: float = 1e-12, warm_start=None,
                          method: str = "pdas", return_info: bool = False):
    """τ̄ = argmin ‖u − Bτ̄‖² s.t. lo ≤ τ̄ ≤ hi (thesis (7.84)–(7.86)).

    Parameters
    ----------
    B : (n, m) input matrix; u : (n,) desired generalized input u*; lo, hi : (m,) finite bounds
        (scalars broadcast).  lo == hi fixes a variable.
    regularization : relative Tikhonov weight ε (module docstring); 0 disables it.
    warm_start : optional guess of the active set (the ``active`` array of a previous call);
        only affects speed, not the solution.
    method : ``"pdas"`` (default: primal–dual active set, pure numpy) or ``"osqp"`` (Drake's
        OSQP, then the exact solve on its active set, KKT-checked; PDAS if the check fails).
        Both fall back to a primal active-set method and finally to scipy's BVLS.
    return_info : also return a dict with ``residual`` ‖u − Bτ̄‖, ``active`` (−1 lower, +1 upper,
        0 free per variable), ``iterations`` and ``method``.
    """
    if method == "pdas" and isinstance(regularization, float) and 0.0 < regularization < math.inf:
        out = _bls_fast(B, u, lo, hi, regularization, warm_start)
        if out is not None:
            return out if return_info else out[0]
    B, u, lo, hi = _check_problem(B, u, lo, hi)
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
            res = _fallback(A, b, l, h, eps)
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
                out = _box_qp_active_set(H, g, l, h, max_iter=10 * A.shape[1] + 20)
                info["method"] = "primal_active_set"
            if out is None:  # degenerate cycling: very rare, use the robust reference method
                s, info["method"] = _fallback(A, b, l, h, eps), "lsq_linear_bvls"
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
    arrays) with the 8-element vector work on Python floats and numpy kept for the matrix
    products and LAPACK solves: the same algebra as ``_box_qp_pdas`` + ``_polish`` in fewer,
    cheaper calls (a controller allocates at every sample).  Returns (τ̄, info), or None when
    the problem is not of that kind, fails a check or PDAS does not settle — the general path
    then handles it (and raises the descriptive errors).
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
    for a, b_ in zip(lol, hil):
        if not (isf(a) and isf(b_) and a < b_):
            return None
    if not (all(isf(x) for x in ul) and np.isfinite(B).all()):
        return None
    rng = range(m)
    tp = [min(max(0.0, a), b_) for a, b_ in zip(lol, hil)]          # τ̄_p = clip(0, lo, hi)
    sc = [0.5 * (b_ - a) for a, b_ in zip(lol, hil)]                 # D = (hi − lo)/2
    l = [(a - t) / d for a, t, d in zip(lol, tp, sc)]
    h = [(b_ - t) / d for b_, t, d in zip(hil, tp, sc)]
    A = B * np.array(sc)
    b = u - B @ np.array(tp)
    eps = reg * max(float((A * A).sum()), 1e-300)
    H = A.T @ A
    H.flat[::m + 1] += eps
    g = A.T @ b
    if warm_start is not None:
        ws = np.asarray(warm_start)
        if ws.shape != (m,):
            return None
        ws = ws.tolist()
        low, up = [w < 0 for w in ws], [w > 0 for w in ws]
    else:
        s0 = _solve(H, g).tolist()
        low, up = [s0[i] < l[i] for i in rng], [s0[i] > h[i] for i in rng]
    c = float(np.trace(H)) / m
    for it in range(max_iter):
        free = [i for i in rng if not (low[i] or up[i])]
        act = [i for i in rng if low[i] or up[i]]
        s = [h[i] if up[i] else (l[i] if low[i] else 0.0) for i in rng]
        if free:
            if act:
                fi, ai = np.array(free, dtype=np.intp), np.array(act, dtype=np.intp)
                Hf = H[fi]
                xf = _solve(Hf[:, fi], g[fi] - Hf[:, ai] @ np.array([s[i] for i in act]))
            else:
                xf = _solve(H, g)
            for i, v in zip(free, xf.tolist()):
                s[i] = v
        lam = (g - H @ np.array(s)).tolist()
        for i in free:
            lam[i] = 0.0
        new_up = [lam[i] + c * (s[i] - h[i]) > 0 for i in rng]
        new_low = [lam[i] + c * (s[i] - l[i]) < 0 and not new_up[i] for i in rng]
        if new_up == up and new_low == low:
            break
        low, up = new_low, new_up
    else:
        return None
    if free:                                                        # _polish
        sv = np.array(s)
        if act:
            ai = np.array(act, dtype=np.intp)
            rhs = b - A[:, ai] @ sv[ai]
            x = _lstsq_min_norm(A[:, np.array(free, dtype=np.intp)], rhs, 1e-10).tolist()
        else:
            x = _lstsq_min_norm(A, b, 1e-10).tolist()
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


def _fallback(A, b, l, h, eps):
    if eps > 0:
        A = np.vstack([A, math.sqrt(eps) * np.eye(A.shape[1])])
        b = np.concatenate([b, np.zeros(A.shape[1])])
    # max_iter: scipy's default (n iterations) can stop bvls before the optimum (measured).
    return lsq_linear(A, b, bounds=(l, h), method="bvls", tol=1e-14, max_iter=50 * A.shape[1]).x


# --------------------------------------------------------------------------------------------
# tilt-rotor bounds (7.85)–(7.89)
# --------------------------------------------------------------------------------------------


def sigmf(v, s: float = 2.0, c: float = 12.0):
    """Sigmoid 1 / (1 + exp(−s(v − c))) (7.89), overflow-safe, vectorized."""
    v = np.asarray(v, dtype=float)
    z = -s * (v - c)
    return np.where(z >= 0, np.exp(-np.abs(z)) / (1.0 + np.exp(-np.abs(z))), 1.0 / (1.0 + np.exp(-np.abs(z))))


_THESIS_LIMITS: dict = {}


def _thesis_limits() -> dict:
    """``controller_limits_thesis`` of ``tiltrotor_missions.json`` (parsed once per process)."""
    if not _THESIS_LIMITS:
        _THESIS_LIMITS.update(load("tiltrotor_missions")["controller_limits_thesis"])
    return _THESIS_LIMITS


def tiltrotor_bounds(v_air, *, limits: dict | None = None):
    """(lo, hi) of τ̄ = [fPR fPL τsR τsL δWR δWL δTR δTL] (7.85)–(7.89).

    ``v_air`` : relative airspeed magnitude V_air (m/s), a scalar used for all four surfaces or
    a 4-vector [V_WR, V_WL, V_TR, V_TL] (thesis: one V_air per surface A; a size-1 array counts
    as a scalar).  ``limits`` defaults
    to ``controller_limits_thesis`` of ``tiltrotor_missions.json`` (thrust [0, 100] N, servo
    [−2, 2] N m, δ ∈ ±5π/36 rad, s = 2, c = 12 m/s).  Below ≈ 8 m/s the surface range is
    < 0.03 % of δ_max: the surfaces are effectively removed from the allocation.
    """
    if limits is None:
        if "_parsed" not in _THESIS_LIMITS:
            _thesis_limits()
            _THESIS_LIMITS["_parsed"] = _parse_limits(_THESIS_LIMITS)
        s, c, f_lo, f_hi, t_lo, t_hi, d_lo, d_hi = _THESIS_LIMITS["_parsed"]
    else:
        s, c, f_lo, f_hi, t_lo, t_hi, d_lo, d_hi = _parse_limits(limits)
    v = np.asarray(v_air, dtype=float)
    if v.size == 1:  # scalar or a size-1 port value: the same airspeed for all surfaces
        v = np.full(4, float(v.ravel()[0]))
    if v.shape != (4,):
        raise ValueError(f"v_air must be a non-negative scalar or a 4-vector [WR, WL, TR, TL], got {v_air!r}")
    # sigmf (7.89) per surface in plain floats (same overflow-safe form as :func:`sigmf`)
    lo, hi = [f_lo, f_lo, t_lo, t_lo], [f_hi, f_hi, t_hi, t_hi]
    for x in v.tolist():
        if not (x >= 0 and math.isfinite(x)):
            raise ValueError(f"v_air must be a non-negative scalar or a 4-vector [WR, WL, TR, TL], got {v_air!r}")
        z = -s * (x - c)
        e = math.exp(-abs(z))
        g = e / (1.0 + e) if z >= 0 else 1.0 / (1.0 + e)
        lo.append(d_lo * g)
        hi.append(d_hi * g)
    return np.array(lo), np.array(hi)


def _parse_limits(lim):
    f_lo, f_hi = lim["thrust_N"]
    t_lo, t_hi = lim["servo_torque_Nm"]
    d_lo, d_hi = lim["surface_deflection_rad"]
    return tuple(float(x) for x in (lim["sigmoid_s"], lim["sigmoid_c_m_s"], f_lo, f_hi, t_lo, t_hi,
                                    d_lo, d_hi))


# --------------------------------------------------------------------------------------------
# LeafSystem
# --------------------------------------------------------------------------------------------


class ControlAllocator(LeafSystem):
    """Bounded least-squares allocation (7.84) as a LeafSystem.

    Inputs: ``u_star`` (n) — desired generalized input; ``B`` (n·m) — input matrix flattened
    **row-major** (``B.ravel()`` / ``B.reshape(n, m)``); then, depending on ``bounds``:

    * callable ``bounds(airspeed) -> (lo, hi)`` → input ``airspeed`` (size ``airspeed_size``),
      e.g. :func:`tiltrotor_bounds` (the default, n = m = 8);
    * ``"input"`` → input ``bounds`` (2m) = [lo; hi];
    * a pair (lo, hi) of constant vectors → no further input.

    Outputs: ``tau`` (m) and ``residual`` (1) = ‖u* − Bτ̄‖, both from one cached solve.
    The outputs depend on the inputs (direct feedthrough).  ``regularization`` and ``method``
    are passed to :func:`bounded_least_squares`.
    """

    def __init__(self, n: int = 8, m: int = 8, bounds=tiltrotor_bounds, *, airspeed_size: int = 1,
                 regularization: float = 1e-12, method: str = "pdas"):
        super().__init__()
        self._method, self._last_active = method, None
        for name, val in (("n", n), ("m", m), ("airspeed_size", airspeed_size)):
            if not isinstance(val, (int, np.integer)) or val < 1:
                raise ValueError(f"{name} must be a positive integer, got {val!r}")
        self._n, self._m, self._reg = int(n), int(m), float(regularization)
        self._u = self.DeclareVectorInputPort("u_star", self._n)
        self._B = self.DeclareVectorInputPort("B", self._n * self._m)
        self._bounds_fn, self._const = None, None
        if callable(bounds):
            self._bounds_fn = bounds
            self._air = self.DeclareVectorInputPort("airspeed", int(airspeed_size))
        elif isinstance(bounds, str) and bounds == "input":
            self._bnd = self.DeclareVectorInputPort("bounds", 2 * self._m)
        else:
            try:
                lo, hi = bounds
            except (TypeError, ValueError):
                raise ValueError("bounds must be a callable bounds(airspeed) -> (lo, hi), "
                                 "'input', or a pair (lo, hi) of length-m vectors") from None
            self._const = _check_problem(np.zeros((1, self._m)), np.zeros(1), lo, hi)[2:]
        self._cache = self.DeclareCacheEntry(
            "allocation", ValueProducer(allocate=lambda: AbstractValue.Make(np.zeros(self._m + 1)),
                                        calc=self._solve),
            prerequisites_of_calc={self.all_input_ports_ticket()})
        self.DeclareVectorOutputPort("tau", self._m, self._calc_tau,
                                     prerequisites_of_calc={self._cache.ticket()})
        self.DeclareVectorOutputPort("residual", 1, self._calc_residual,
                                     prerequisites_of_calc={self._cache.ticket()})

    def bounds(self, context):
        """(lo, hi) used in ``context``."""
        if self._bounds_fn is not None:
            lo, hi = self._bounds_fn(self._air.Eval(context))
            return np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
        if self._const is not None:
            return self._const
        v = self._bnd.Eval(context)
        return v[:self._m], v[self._m:]

    def _solve(self, context, abstract_value):
        B = self._B.Eval(context).reshape(self._n, self._m)
        lo, hi = self.bounds(context)
        # The previous active set warm-starts the solver: it changes speed, not the result.
        tau, info = bounded_least_squares(B, self._u.Eval(context), lo, hi, regularization=self._reg,
                                          warm_start=self._last_active, method=self._method,
                                          return_info=True)
        self._last_active = info["active"]
        abstract_value.set_value(np.concatenate([tau, [info["residual"]]]))

    def _calc_tau(self, context, output):
        output.SetFromVector(self._cache.Eval(context)[:self._m])

    def _calc_residual(self, context, output):
        output.SetFromVector(self._cache.Eval(context)[self._m:])


# --------------------------------------------------------------------------------------------
# thrust → propeller speed (7.90)
# --------------------------------------------------------------------------------------------


class UnreachableThrustError(ValueError):
    """The requested thrust is outside [0, f(n_max)] for the given inflow."""


def _thrust(coef, n, v_xz, phi):
    """ρ d⁴ n² Ct(J, φ) with J = clip(V_xz/(n d), 0, J_max); 0 at n = 0."""
    d = coef.diameter
    with np.errstate(divide="ignore", invalid="ignore"):
        J = np.where(n > 0, v_xz / np.where(n > 0, n * d, 1.0), coef.J_max)
    J = np.clip(J, 0.0, coef.J_max)
    return coef.rho * d ** 4 * n ** 2 * coef.ct(J, phi)


def rotor_inflow(v_rel_rotor_frame):
    """(V_xz, φ) of (7.90) from the rotor-frame air-relative velocity (..., 3) = (u, v, w).

    Same conventions as ``PropellerCoefficients.advance_ratio_and_inflow``: V_xz = ‖(u, w)‖,
    φ = |clip(atan2(u, w), −π/2, π/2)|.
    """
    v = np.asarray(v_rel_rotor_frame, dtype=float)
    if v.shape[-1:] != (3,):
        raise ValueError(f"v_rel_rotor_frame must have shape (..., 3), got {v.shape}")
    return np.hypot(v[..., 0], v[..., 2]), np.abs(np.clip(np.arctan2(v[..., 0], v[..., 2]), -np.pi / 2, np.pi / 2))


def propeller_speed_for_thrust(thrust, v_xz=0.0, phi=0.0, *, coefficients=None, n_max: float | None = None,
                               on_unreachable: str = "raise", grid: int = 16, tol: float = 1e-10):
    """Propeller speed n ≥ 0 (rev/s) with f = ρ d⁴ n² Ct(J, φ), J = V_xz/(n d) (7.90).

    ``thrust``, ``v_xz`` (air-relative speed in the rotor's x–z plane, m/s) and ``phi``
    (inflow angle, rad) broadcast (vectorized over the rotors); :func:`rotor_inflow` computes
    them from the rotor-frame air-relative velocity.  J depends on n, so this is a 1-D
    root search: a grid on [0, n_max] (n_max from the json ``n_range_rev_s``) brackets the
    smallest n where the thrust reaches f, then safeguarded regula falsi (Illinois) refines it to
    |f(n) − f| ≤ tol·max(1, f).  Thrust outside [0, f(n_max)] raises
    :class:`UnreachableThrustError` (``on_unreachable="raise"``) or is saturated to n = 0 /
    n_max (``"clip"``).
    """
    from sobolev_drake.systems.propulsion import PropellerCoefficients

    coef = coefficients if coefficients is not None else PropellerCoefficients()
    if on_unreachable not in ("raise", "clip"):
        raise ValueError(f"on_unreachable must be 'raise' or 'clip', got {on_unreachable!r}")
    if n_max is None:
        n_max = float(load("propeller_coefficients")["n_range_rev_s"][1])
    if not (np.isfinite(n_max) and n_max > 0):
        raise ValueError(f"n_max must be positive, got {n_max}")
    f, V, ph = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (thrust, v_xz, phi)))
    shape = f.shape
    f, V, ph = f.ravel(), V.ravel(), ph.ravel()
    if not (np.all(np.isfinite(f)) and np.all(np.isfinite(V)) and np.all(np.isfinite(ph))):
        raise ValueError("thrust, v_xz and phi must be finite")
    if np.any(V < 0):
        raise ValueError("v_xz is a speed magnitude and must be >= 0")
    ns = np.linspace(0.0, n_max, grid + 1)
    G = _thrust(coef, ns[None, :], V[:, None], ph[:, None])          # (k, grid+1)
    ftol = tol * np.maximum(1.0, np.abs(f))
    f_max = G[:, -1]
    bad = (f < -ftol) | (f > f_max + ftol)
    if np.any(bad):
        if on_unreachable == "raise":
            i = int(np.flatnonzero(bad)[0])
            raise UnreachableThrustError(
                f"thrust {f[i]:.6g} N is unreachable for v_xz = {V[i]:.4g} m/s, phi = {ph[i]:.4g} rad: "
                f"achievable range is [0, {f_max[i]:.6g}] N for n in [0, {n_max:g}] rev/s")
    ft = np.clip(f, 0.0, f_max)
    # Smallest grid interval [ns[k-1], ns[k]] where the thrust reaches ft.
    k = np.argmax(G >= ft[:, None] - ftol[:, None], axis=1)
    a = ns[np.maximum(k - 1, 0)]
    b = ns[k]
    ga = _thrust(coef, a, V, ph) - ft
    gb = _thrust(coef, b, V, ph) - ft
    n = np.where(np.abs(ga) <= ftol, a, b)
    done = (np.abs(ga) <= ftol) | (np.abs(gb) <= ftol)
    side = np.zeros_like(a)
    for _ in range(100):
        if np.all(done):
            break
        # Illinois regula falsi; fall back to bisection if the secant leaves the bracket.
        c = np.where(gb != ga, b - gb * (b - a) / np.where(gb != ga, gb - ga, 1.0), 0.5 * (a + b))
        c = np.where((c <= np.minimum(a, b)) | (c >= np.maximum(a, b)), 0.5 * (a + b), c)
        gc = _thrust(coef, c, V, ph) - ft
        n = np.where(done, n, c)
        done = done | (np.abs(gc) <= ftol) | (np.abs(b - a) <= 1e-14 * n_max)
        left = np.sign(gc) == np.sign(ga)
        a, ga, b, gb = (np.where(left, c, a), np.where(left, gc, ga),
                        np.where(left, b, c), np.where(left, gb, gc))
        gb = np.where(left & (side == 1), 0.5 * gb, gb)
        ga = np.where(~left & (side == -1), 0.5 * ga, ga)
        side = np.where(left, 1, -1)
    return n.reshape(shape)
