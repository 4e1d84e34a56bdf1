"""The compiled bounded least squares (``sobolev_drake/native/bls.c``) against its Python reference
``bounded_ls._bls_fast_python``: same None-ness, active sets, iterations, τ̄ and residual.

Tolerances.  The kernel has its own loops where Python calls BLAS/LAPACK (products, LU, SVD),
so the two agree to rounding, not bit for bit.  On well-conditioned problems that means
|Δτ̄| ≤ 1e-9·(1 + |τ̄|) and identical decisions.  Near-zero or duplicated columns and very
different box widths make the regularized free block H_ff = A_fᵀA_f + εI nearly singular
(condition up to 1/reg = 1e12): there any backward-stable solve — Python's LAPACK as well as
the kernel — only determines the free variables to the forward-error bound of
:func:`_sensitivity`, so τ̄ may differ by that much, and a decision (an active bound, the
iteration count, PDAS settling) whose margin is below it may flip.  Measured on 20 000 such
problems: the kernel differs from Python about as often (≈ 0.3 %) and as much as Python differs
from itself when B is perturbed by one ulp.  Those relaxations apply only to problems that are
ill-conditioned in that sense; the tilt-rotor problems are held to the strict criteria.
"""

import importlib

import numpy as np
import pytest

from sobolev_drake import native
from sobolev_drake.data import load
from sobolev_drake.tiltrotor.plant import TiltrotorModel
from sobolev_drake.systems import bounded_ls as bl
from sobolev_drake.tiltrotor.allocation import bounded_least_squares, tiltrotor_bounds
from sobolev_drake.tiltrotor.input_affine import input_affine_terms

REG = 1e-12          # bounded_least_squares' default regularization
MAX_ITER = 25        # _bls_fast's default
EPS = np.finfo(float).eps


@pytest.fixture(scope="module")
def kern():
    # imported directly (not through native.kernel) so the comparisons also run when the
    # kernels are disabled by SOBOLEV_DRAKE_NATIVE=0; an ImportError here means "not built"
    return importlib.import_module("sobolev_drake.native._bls")


def test_kernel_is_built_and_selected():
    mod = importlib.import_module("sobolev_drake.native._bls")   # CI has gcc: must be built
    assert native.kernel("bls") is (mod if native.enabled() else None)
    assert callable(mod.solve) and callable(mod.min_norm_lstsq)


# ------------------------------------------------------------------------------------------
# helpers
# ------------------------------------------------------------------------------------------


def _scaled(B, lo, hi):
    tp = np.minimum(np.maximum(0.0, lo), hi)
    D = 0.5 * (hi - lo)
    return tp, D, B * D


def _cond_H(B, lo, hi):
    """Condition number of the regularized H = AᵀA + εI on the non-zero columns of A = B·D
    (an exactly zero column is decoupled: its variable is exactly 0 in both paths)."""
    _, _, A = _scaled(B, lo, hi)
    A = A[:, np.any(A != 0, axis=0)]
    if A.shape[1] == 0:
        return 1.0
    H = A.T @ A
    H[np.diag_indices_from(H)] += REG * np.trace(H)
    return np.linalg.cond(H)


def _sensitivity(B, u, lo, hi, tau, active):
    """Forward-error bound, in scaled units s = (τ̄ − τ̄_p)/D, of the free variables on this
    active set: ε‖H_ff⁻¹‖₂·‖|A_f|ᵀw‖, w = |u| + |B||τ̄_p| + |A||s|, i.e. ‖H_ff⁻¹‖ times the
    rounding of the terms of g_f − H_fa s_a − H_ff s_f that every backward-stable solver makes.
    (The measured differences stay below 7× this bound on 20 000 random problems.)"""
    tp, D, A = _scaled(B, lo, hi)
    f = np.asarray(active) == 0
    if not f.any():
        return 0.0
    m = len(lo)
    H = A.T @ A
    H[np.diag_indices(m)] += REG * np.trace(H)
    s = (tau - tp) / D
    w = np.abs(u) + np.abs(B) @ np.abs(tp) + np.abs(A) @ np.abs(s)
    return EPS * np.linalg.norm(np.linalg.inv(H[np.ix_(f, f)]), 2) * np.linalg.norm(np.abs(A[:, f]).T @ w)


def _tikhonov_slack(B, lo, hi):
    """How far apart the residuals of two valid answers to one problem can be, when a flipped
    decision (see the module docstring) leaves one answer at the regularized optimum and the
    other polished.  In scaled units s ∈ [l, h], the regularized optimum s_ε minimizes
    ‖b − As‖² + ε‖s‖² over the box, so ‖r_ε‖² ≤ ‖r*‖² + ε‖s*‖² ≤ ‖r*‖² + εS, with r* the box
    least-squares residual and S = Σ max(l², h²); a polished answer lies between r* and r_ε.
    Hence |r_p − r_c| ≤ √(r*² + εS) − r* ≤ √(εS), ε = REG·‖A‖²_F as in the solver.  (The old
    relative bound 1e-6·max(r) failed under SkylakeX/Sandybridge kernels: 1.6e-10 vs 1.6e-15,
    a consistent problem where one side kept the Tikhonov residual, far inside √(εS).)"""
    tp, D, A = _scaled(B, lo, hi)
    l, h = (lo - tp) / D, (hi - tp) / D
    eps = REG * max(float(np.sum(A * A)), 1e-300)
    return float(np.sqrt(eps * np.sum(np.maximum(l * l, h * h))))


def _run(kern, B, u, lo, hi, ws):
    p = bl._bls_fast_python(B, u, lo, hi, REG, ws, MAX_ITER)
    c = kern.solve(B, u, lo, hi, REG, ws, MAX_ITER)
    assert c is not NotImplemented          # plain finite float64 problems: never declined
    return p, c


def _check_result_form(c, B, u, lo, hi):
    tau, info = c
    m = B.shape[1]
    assert type(tau) is np.ndarray and tau.dtype == np.float64 and tau.shape == (m,)
    assert np.all(lo <= tau) and np.all(tau <= hi)                  # exactly, no tolerance
    act = info["active"]
    assert type(act) is np.ndarray and act.dtype == np.array([0]).dtype and act.shape == (m,)
    assert set(info) == {"method", "iterations", "residual", "active"} and info["method"] == "pdas"
    assert type(info["iterations"]) is int and type(info["residual"]) is float
    assert np.array_equal(tau[act < 0], lo[act < 0]) and np.array_equal(tau[act > 0], hi[act > 0])


def _values_agree(p, c, B, u, lo, hi, relax):
    """τ̄ and residual of two results with the same decisions; returns whether the
    conditioning relaxation was needed."""
    tau_p, tau_c = p[0], c[0]
    tol = 1e-9 * (1 + np.abs(tau_p))
    diff = np.abs(tau_c - tau_p)
    needed = bool(np.any(diff > tol))
    if needed:
        assert relax, (diff / (1 + np.abs(tau_p))).max()
        # reason: ill-conditioned free block, see _sensitivity and the module docstring
        _, D, _ = _scaled(B, lo, hi)
        sens = _sensitivity(B, u, lo, hi, tau_p, p[1]["active"])
        assert np.all(diff <= tol + 100 * D * sens), (diff, D * sens)
    # |‖r_p‖ − ‖r_c‖| ≤ ‖B(τ̄_p − τ̄_c)‖ (+ the rounding of u − Bτ̄ itself, which is all the
    # residual is when the problem is consistent)
    rp, rc = p[1]["residual"], c[1]["residual"]
    floor = 1e-13 * (np.linalg.norm(u) + np.linalg.norm(np.abs(B) @ np.abs(tau_p)))
    assert abs(rp - rc) <= 1e-9 * rp + np.linalg.norm(B @ (tau_p - tau_c)) * (1 + 1e-9) + floor
    return needed


def _decisions_agree(p, c):
    if p is None or c is None:
        return (p is None) == (c is None)
    return np.array_equal(p[1]["active"], c[1]["active"]) and p[1]["iterations"] == c[1]["iterations"]


# ------------------------------------------------------------------------------------------
# random problems
# ------------------------------------------------------------------------------------------

KINDS = ("plain", "zero column", "duplicate column", "near-zero column", "box widths",
         "inside box", "tiny surfaces")


def _random_problem(rng, kind):
    n, m = (int(x) for x in rng.integers(1, 11, 2))
    B = rng.standard_normal((n, m)) * rng.uniform(0.2, 5.0, m)
    u = rng.standard_normal(n) * rng.uniform(0.5, 10.0)
    lo = -rng.uniform(0.05, 2.0, m) * rng.integers(0, 2, m)          # some lower bounds at 0
    hi = rng.uniform(0.05, 2.0, m)
    if kind == "zero column":
        B[:, rng.integers(0, m, max(1, m // 3))] = 0.0
    elif kind == "duplicate column" and m > 1:
        i, j = rng.choice(m, 2, replace=False)
        B[:, j] = B[:, i]
        if rng.random() < 0.5:                       # same box too: identical columns of A
            lo[j], hi[j] = lo[i], hi[i]
    elif kind == "near-zero column":
        B[:, rng.integers(0, m)] *= 1e-9             # surfaces at low airspeed
    elif kind == "box widths":
        w = 10.0 ** rng.uniform(-4, 2, m)
        lo, hi = lo * w, hi * w
    elif kind == "inside box":                       # unconstrained optimum strictly inside
        lo, hi = -np.full(m, 2.0), np.full(m, 2.0)
        u = B @ rng.uniform(-1.0, 1.0, m)
        if rng.random() < 0.5:
            u = u + 1e-3 * rng.standard_normal(n)
    elif kind == "tiny surfaces":                    # box half-widths ~1e-11 on some columns
        k = rng.integers(1, m + 1)
        lo[m - k:], hi[m - k:] = -1e-11 * hi[m - k:], 1e-11 * hi[m - k:]
    return B, u, lo, hi


def test_native_matches_python_on_random_problems(kern):
    rng = np.random.default_rng(20240611)
    counts = {"problems": 0, "ill": 0, "relaxed": 0, "flipped": 0, "none": 0, "ws": 0}
    for trial in range(700):
        kind = KINDS[trial % len(KINDS)]
        B, u, lo, hi = _random_problem(rng, kind)
        m = B.shape[1]
        ill = bool(_cond_H(B, lo, hi) > 1e8)
        cold = bl._bls_fast_python(B, u, lo, hi, REG, None, MAX_ITER)
        mode = trial // len(KINDS) % 3
        if mode == 0:
            ws = None
        elif mode == 1:                  # correct warm start (the controller's normal case)
            ws = None if cold is None else cold[1]["active"]
        else:                            # wrong warm start
            ws = rng.integers(-1, 2, m)
        counts["ws"] += ws is not None
        p, c = _run(kern, B, u, lo, hi, ws)
        counts["problems"] += 1
        counts["ill"] += ill
        if c is not None:
            _check_result_form(c, B, u, lo, hi)
        if not _decisions_agree(p, c):
            # only where the conditioning leaves the decision undetermined (module docstring)
            assert ill, (kind, trial)
            counts["flipped"] += 1
            if p is not None and c is not None:
                rp, rc = p[1]["residual"], c[1]["residual"]
                assert abs(rp - rc) <= _tikhonov_slack(B, lo, hi) + 1e-12 * np.linalg.norm(u)
            continue
        if p is None:
            counts["none"] += 1
            continue
        counts["relaxed"] += _values_agree(p, c, B, u, lo, hi, relax=ill)
        if mode == 1 and ws is not None:
            assert c[1]["iterations"] == 1       # a correct warm start needs one solve
    assert counts["problems"] >= 300 and counts["ws"] >= 200
    assert counts["flipped"] <= 0.02 * counts["ill"], counts
    assert counts["relaxed"] <= 0.05 * counts["problems"], counts
    assert counts["none"] < 0.2 * counts["problems"], counts      # mostly settled problems


@pytest.mark.parametrize("n,m", [(1, 1), (1, 6), (3, 10), (10, 3), (8, 8), (40, 30), (5, 60)])
def test_sizes_including_heap_workspace(kern, n, m):
    """n < m, n > m and sizes beyond the kernel's stack buffer (heap workspace)."""
    rng = np.random.default_rng(n * 100 + m)
    for _ in range(5):
        B = rng.standard_normal((n, m))
        u = 5 * rng.standard_normal(n)
        lo, hi = -rng.uniform(0.1, 1, m), rng.uniform(0.1, 1, m)
        p, c = _run(kern, B, u, lo, hi, None)
        assert _decisions_agree(p, c)
        if p is not None:
            _check_result_form(c, B, u, lo, hi)
            _values_agree(p, c, B, u, lo, hi, relax=False)


def test_strided_inputs(kern):
    """Non-contiguous arrays are read through their strides (no copy, no fallback)."""
    rng = np.random.default_rng(8)
    B = rng.standard_normal((8, 16))
    u = rng.standard_normal(16)[::2] * 10
    lo, hi = -np.ones(16)[::2], np.ones(16)[::2]
    for Bv in (B[:, ::2], np.asfortranarray(B[:, :8]), B[:, :8].T.copy().T):
        ref = bl._bls_fast_python(np.ascontiguousarray(Bv), np.ascontiguousarray(u),
                                  np.ascontiguousarray(lo), np.ascontiguousarray(hi), REG, None)
        c = kern.solve(Bv, u, lo, hi, REG, None, MAX_ITER)
        assert np.array_equal(c[1]["active"], ref[1]["active"])
        assert np.allclose(c[0], ref[0], rtol=1e-12, atol=1e-12)


# ------------------------------------------------------------------------------------------
# tilt-rotor problems
# ------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def tiltrotor():
    return TiltrotorModel()


def _tiltrotor_problems(model, rng, count):
    coeffs = load("tiltrotor_missions")["scenario_2_full_envelope"]["tilt_reference_vs_forward_speed"]["coefficients"]
    for i in range(count):
        U = rng.uniform(0.0, 6.0) if i % 2 == 0 else rng.uniform(15.0, 33.0)   # hover / cruise
        alpha = np.polyval(coeffs, U) + rng.normal(scale=0.05, size=2)
        q = np.concatenate([alpha, rng.normal(scale=0.1, size=3), rng.normal(size=3)])
        qd = np.concatenate([rng.normal(scale=0.3, size=5), [U, 0.0, 0.0] + rng.normal(scale=1.0, size=3)])
        zeta = rng.normal(scale=2.0, size=3)
        t = input_affine_terms(model, q, qd, zeta)
        lo, hi = tiltrotor_bounds(t.surface_speed[1:5])
        u = t.B @ rng.uniform(lo, hi) + rng.normal(size=8) * rng.choice([0.0, 0.1, 10.0, 100.0])
        yield t.B, u, lo, hi


def test_native_matches_python_on_tiltrotor_problems(kern, tiltrotor):
    """Controller-like 8×8 problems (hover: surface columns with ~1e-11 ranges; cruise: full
    surface authority), cold, warm-started from the previous sample, and wrongly warm-started:
    strict agreement (no conditioning relaxation)."""
    rng = np.random.default_rng(77)
    last = None
    settled = 0
    for B, u, lo, hi in _tiltrotor_problems(tiltrotor, rng, 160):
        cold = bl._bls_fast_python(B, u, lo, hi, REG, None, MAX_ITER)
        for ws in (None, last, None if cold is None else cold[1]["active"], rng.integers(-1, 2, 8)):
            p, c = _run(kern, B, u, lo, hi, ws)
            assert _decisions_agree(p, c)
            if p is not None:
                settled += 1
                _check_result_form(c, B, u, lo, hi)
                _values_agree(p, c, B, u, lo, hi, relax=False)
        if cold is not None:
            last = cold[1]["active"]
    assert settled >= 400


def test_bounded_least_squares_uses_native_result(tiltrotor, monkeypatch):
    """The public function returns the kernel's result (the Python reference is not called)."""
    monkeypatch.setattr(native, "_ENABLED", True)

    def not_called(*args, **kwargs):
        raise AssertionError("the Python reference ran")

    monkeypatch.setattr(bl, "_bls_fast_python", not_called)
    rng = np.random.default_rng(3)
    for B, u, lo, hi in _tiltrotor_problems(tiltrotor, rng, 6):
        tau, info = bounded_least_squares(B, u, lo, hi, return_info=True)
        assert np.all(lo <= tau) and np.all(tau <= hi)
        tau2, info2 = bounded_least_squares(B, u, lo, hi, warm_start=info["active"], return_info=True)
        assert info2["iterations"] == 1 and np.array_equal(info2["active"], info["active"])


# ------------------------------------------------------------------------------------------
# dispatch, None and fallback cases
# ------------------------------------------------------------------------------------------


class _Spy:
    def __init__(self, fn):
        self.fn, self.calls = fn, 0

    def __call__(self, *args, **kwargs):
        self.calls += 1
        return self.fn(*args, **kwargs)


def _small_problem(seed=1):
    rng = np.random.default_rng(seed)
    return rng.standard_normal((8, 8)), 5 * rng.standard_normal(8), -np.ones(8), np.ones(8)


def test_disabled_kernel_uses_python(monkeypatch):
    B, u, lo, hi = _small_problem()
    spy = _Spy(bl._bls_fast_python)
    monkeypatch.setattr(bl, "_bls_fast_python", spy)
    with native.disabled():
        tau, info = bounded_least_squares(B, u, lo, hi, return_info=True)
    assert spy.calls == 1
    monkeypatch.setattr(native, "_ENABLED", True)
    tau2, info2 = bounded_least_squares(B, u, lo, hi, return_info=True)
    assert spy.calls == 1                       # the kernel answered
    assert np.allclose(tau, tau2, rtol=1e-12, atol=1e-12) and info2["iterations"] == info["iterations"]


def test_enabled_lookup_finds_kernel(monkeypatch, kern):
    monkeypatch.setattr(native, "_ENABLED", True)
    spy = _Spy(bl._bls_fast_python)
    monkeypatch.setattr(bl, "_bls_fast_python", spy)
    B, u, lo, hi = _small_problem()
    bounded_least_squares(B, u, lo, hi)
    assert native.kernel("bls") is kern and spy.calls == 0


def _none_cases():
    B, u, lo, hi = _small_problem()
    inf_B = B.copy()
    inf_B[0, 0] = np.inf
    yield "B not an ndarray", (B.tolist(), u, lo, hi, None)
    yield "B float32", (B.astype(np.float32), u, lo, hi, None)
    yield "B big-endian", (B.astype(">f8"), u, lo, hi, None)
    yield "B 1-D", (B.ravel(), u, lo, hi, None)
    yield "B matrix subclass", (np.asmatrix(B), u, lo, hi, None)
    yield "u wrong length", (B, u[:7], lo, hi, None)
    yield "lo wrong length", (B, u, lo[:7], hi, None)
    yield "empty B", (np.zeros((0, 8)), np.zeros(0), lo, hi, None)
    yield "inf in B", (inf_B, u, lo, hi, None)
    yield "nan in u", (B, np.r_[np.nan, u[1:]], lo, hi, None)
    yield "lo == hi", (B, u, np.r_[1.0, lo[1:]], hi, None)
    yield "lo > hi", (B, u, hi, lo, None)
    yield "infinite bound", (B, u, np.r_[-np.inf, lo[1:]], hi, None)
    yield "warm start wrong length", (B, u, lo, hi, np.zeros(7, dtype=int))
    yield "warm start 2-D", (B, u, lo, hi, np.zeros((8, 1)))


@pytest.mark.parametrize("name,args", list(_none_cases()), ids=[c[0] for c in _none_cases()])
def test_none_cases(kern, name, args):
    """Where the reference returns None (the general path then raises or handles it), so does
    the kernel — or it declines (NotImplemented) and the dispatch asks the reference."""
    assert bl._bls_fast_python(*args[:4], REG, args[4]) is None
    assert kern.solve(*args[:4], REG, args[4], MAX_ITER) in (None, NotImplemented)
    assert bl._bls_fast(*args[:4], REG, args[4]) is None


def test_pdas_not_settling_is_none(kern):
    B, u, lo, hi = _small_problem()
    for max_iter in (0, 1, -2):        # 1: the cold guess is not the optimum here
        assert bl._bls_fast_python(B, u, lo, hi, REG, None, max_iter) is None
        assert kern.solve(B, u, lo, hi, REG, None, max_iter) is None


def _declined_cases():
    B, u, lo, hi = _small_problem()
    yield "warm start list", (B, u, lo, hi, REG, [0, 1, -1, 0, 0, 0, 1, 0])
    yield "warm start float16", (B, u, lo, hi, REG, np.ones(8, dtype=np.float16))
    yield "warm start objects", (B, u, lo, hi, REG, np.array([0] * 8, dtype=object))
    yield "overflowing B", (B * 1e300, u, lo, hi, REG, None)       # Python: inf/nan arithmetic
    yield "overflowing box", (B, u, lo * 1e308, hi * 1e308, REG, None)
    yield "width underflows", (B, u, np.zeros(8), np.full(8, 5e-324), REG, None)  # 1/0 in Python
    yield "singular H", (np.zeros((8, 8)), u, lo, hi, 1e-30, None)  # ε underflows: dgesv fails


@pytest.mark.parametrize("name,args", list(_declined_cases()), ids=[c[0] for c in _declined_cases()])
def test_declined_cases_are_decided_by_python(kern, name, args):
    """Inputs the kernel does not read or values that may overflow: NotImplemented, and the
    dispatch returns (or raises) exactly what the reference does."""
    assert kern.solve(*args, MAX_ITER) is NotImplemented

    def outcome(fn):
        with np.errstate(all="ignore"):
            try:
                out = fn(*args)
            except Exception as e:          # noqa: BLE001 - the exception type is the outcome
                return type(e)
        return out if out is None else (out[0].tolist(), out[1]["active"].tolist(), out[1]["iterations"])

    assert outcome(bl._bls_fast) == outcome(bl._bls_fast_python)


@pytest.mark.parametrize("ws", [np.array([1, 0, -1, 0, 0, 1, 0, 0], dtype=np.int32),
                                np.array([True, False] * 4), np.array([0.5, -0.5, np.nan, 0, 0, 0, 2, -1]),
                                np.array([1, 0, 1, 0, 0, 0, 0, 1], dtype=np.uint8)])
def test_warm_start_dtypes(kern, ws):
    """Warm starts of any plain numeric dtype mean sign(w), as in Python (NaN: free)."""
    B, u, lo, hi = _small_problem(4)
    p, c = _run(kern, B, u, lo, hi, ws)
    assert _decisions_agree(p, c)
    _values_agree(p, c, B, u, lo, hi, relax=False)


def test_min_norm_lstsq_matches_lapack(kern):
    """The kernel's minimum-norm least squares (QR-preconditioned Jacobi SVD) against LAPACK
    dgelsd with the same relative cutoff: same rank, same solution up to the conditioning of the
    kept part (σ_max/σ_rank · ε)."""
    rng = np.random.default_rng(12)
    for trial in range(600):
        r, c = (int(x) for x in rng.integers(1, 11, 2))
        F = rng.standard_normal((r, c)) * 10.0 ** rng.uniform(-3, 3, c)
        kind = trial % 6
        if kind == 5 and min(r, c) > 1:         # exactly low rank, e.g. wide with zero columns
            q = int(rng.integers(1, min(r, c)))
            F = rng.standard_normal((r, q)) @ rng.standard_normal((q, c))
            F[:, rng.integers(0, c)] = 0.0
        elif kind == 1:
            F[:, rng.integers(0, c)] = 0.0
        elif kind == 2 and c > 1:
            F[:, 1] = 3.0 * F[:, 0]
        elif kind == 3:
            F[:, rng.integers(0, c)] *= 1e-12
        elif kind == 4 and trial % 12 == 4:
            F[:] = 0.0
        y = rng.standard_normal(r)
        x_ref, rank_ref = bl._lstsq_min_norm(F, y, 1e-10, True)
        x, rank = kern.min_norm_lstsq(F.tolist(), y.tolist(), 1e-10)
        assert rank == rank_ref
        sv = np.linalg.svd(F, compute_uv=False)
        kappa = sv[0] / sv[rank - 1] if rank else 1.0
        scale = np.abs(x_ref).max()
        assert np.abs(np.array(x) - x_ref).max() <= 1e-14 * kappa * max(scale, 1e-300) * 10 + 1e-300
