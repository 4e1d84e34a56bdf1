"""Bounded-real-lemma H-infinity synthesis for a continuous-time generalized plant.

    xdot = A x + B1 w + B2 u,   z = C1 x + D11 w + D12 u,   y = C2 x + D21 w   (D22 = 0)

* state feedback u = K x: variables X = P^-1 > 0, W = K X (the change of variables of (6.7));
* full-order dynamic output feedback (A_K, B_K, C_K, D_K), D_K allowed: Scherer, Gahinet &
  Chilali (1997) / Gahinet & Apkarian (1994) variables (X, Y, Ak, Bk, Ck, Dk), the linearized
  form of (6.22); the controller is reconstructed from an SVD factorization M N^T = I - X Y.

gamma^2 is minimized directly (as the thesis' gamma* in (6.7)/(6.22)). Every result is checked
independently (``certificates.py``) before it is returned. When the optimum sits on the
feedthrough (Parrott) bound the infimum is approached only with unbounded gains (DESIGN.md 4.4);
the synthesis then re-solves at gamma = (1 + delta) gamma_opt minimizing a gain bound, and says
so in ``result.warnings``. W-infinity problems are performance channels of this plant
(``sobolev.py``); LMI regions come from ``regions.py``.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla

from .certificates import (Certificate, as_matrix, certify_closed_loop, parrott_bound,
                           require_detectable, require_stabilizable)
from .lmi import Affine, InfeasibleLMIError, LMIProgram, SynthesisError, bmat
from .regions import LMIRegion, region_lmi

COUPLING_MARGIN = 1e-6  # [[X, I], [I, Y]] >= margin I keeps I - XY invertible (see reconstruct)
EPS = 1e-7  # strictness margin of the LMIs (absolute, problems are scaled by the weights)


class SynthesisWarning(UserWarning):
    """The result is valid but degenerate (feedthrough infimum, regularized, large gains)."""


@dataclass
class GeneralizedPlant:
    A: np.ndarray
    B1: np.ndarray
    B2: np.ndarray
    C1: np.ndarray
    D11: np.ndarray
    D12: np.ndarray
    C2: np.ndarray
    D21: np.ndarray

    @classmethod
    def make(cls, A, B1, B2, C1, D11=None, D12=None, C2=None, D21=None):
        """Validated plant; D11, D12, D21 default to zero, C2 to the identity (full state)."""
        A = as_matrix("A", A)
        n = A.shape[0]
        as_matrix("A", A, (n, n))
        B1 = as_matrix("B1", B1, (n, None))
        B2 = as_matrix("B2", B2, (n, None))
        C1 = as_matrix("C1", C1, (None, n))
        nw, nu, nz = B1.shape[1], B2.shape[1], C1.shape[0]
        D11 = np.zeros((nz, nw)) if D11 is None else as_matrix("D11", D11, (nz, nw))
        D12 = np.zeros((nz, nu)) if D12 is None else as_matrix("D12", D12, (nz, nu))
        C2 = np.eye(n) if C2 is None else as_matrix("C2", C2, (None, n))
        D21 = np.zeros((C2.shape[0], nw)) if D21 is None else as_matrix("D21", D21, (C2.shape[0], nw))
        return cls(A, B1, B2, C1, D11, D12, C2, D21)

    n = property(lambda s: s.A.shape[0])
    nw = property(lambda s: s.B1.shape[1])
    nu = property(lambda s: s.B2.shape[1])
    nz = property(lambda s: s.C1.shape[0])
    ny = property(lambda s: s.C2.shape[0])

    def closed_loop(self, K=None, controller=None):
        """(A_cl, B_cl, C_cl, D_cl) of w -> z with u = K x or the dynamic controller."""
        if K is not None:
            K = as_matrix("K", K, (self.nu, self.n))
            return (self.A + self.B2 @ K, self.B1, self.C1 + self.D12 @ K, self.D11)
        AK, BK, CK, DK = controller
        A = np.block([[self.A + self.B2 @ DK @ self.C2, self.B2 @ CK], [BK @ self.C2, AK]])
        B = np.vstack([self.B1 + self.B2 @ DK @ self.D21, BK @ self.D21])
        C = np.hstack([self.C1 + self.D12 @ DK @ self.C2, self.D12 @ CK])
        D = self.D11 + self.D12 @ DK @ self.D21
        return A, B, C, D

    def convex_combination(self, other, t):
        return GeneralizedPlant(*[(1 - t) * a + t * b for a, b in zip(self.as_tuple(), other.as_tuple())])

    def as_tuple(self):
        return (self.A, self.B1, self.B2, self.C1, self.D11, self.D12, self.C2, self.D21)


@dataclass
class DynamicController:
    """x_K' = AK x_K + BK y,  u = CK x_K + DK y."""

    AK: np.ndarray
    BK: np.ndarray
    CK: np.ndarray
    DK: np.ndarray

    def __iter__(self):
        return iter((self.AK, self.BK, self.CK, self.DK))


@dataclass
class SynthesisResult:
    kind: str  # "state_feedback" | "output_feedback"
    gamma: float  # certified bound on the performance-channel H-infinity norm
    K: np.ndarray | None = None
    controller: DynamicController | None = None
    P: np.ndarray | None = None  # closed-loop Lyapunov matrix
    X: np.ndarray | None = None
    Y: np.ndarray | None = None
    gamma_opt: float = np.nan  # LMI optimum (before any regularization)
    feedthrough_bound: float = 0.0
    solver: str = ""
    backend: str = ""
    status: str = ""
    timings: dict = field(default_factory=dict)
    certificate: Certificate | None = None
    certificates: list = field(default_factory=list)  # polytopic: one per vertex
    region: LMIRegion | None = None
    regularized: bool = False
    warnings: list = field(default_factory=list)

    @property
    def well_posed(self):
        return not self.warnings


def _check_gamma_request(gamma, bound, what="gamma"):
    if gamma is not None and gamma <= bound * (1 + 1e-9):
        raise ValueError(f"{what}={gamma:g} is not achievable: it must exceed the feedthrough "
                         f"(Parrott) bound {bound:.6g}")


FALLBACKS = ("drake", "drake:csdp")  # tried in order when the *default* backend fails


def _solve(prog, backend, options, timings, label):
    """Solve; with the default backend, fall back to Drake/Clarabel then CSDP on failure."""
    chain = [backend] if backend is not None else [None, *FALLBACKS]
    errors = []
    for b in chain:
        try:
            out = prog.solve(b, options if b == backend else None)
        except InfeasibleLMIError as e:
            errors.append(str(e))
            continue
        timings[f"{label}_build"] = timings.get(f"{label}_build", 0.0) + out.build_time
        timings[f"{label}_solve"] = timings.get(f"{label}_solve", 0.0) + out.solve_time
        if out.success and np.all(np.isfinite(out.x)):
            if errors:
                out.status += f" (after fallback: {'; '.join(errors)})"
            return out
        errors.append(f"{out.backend}/{out.solver}: status {out.status}")
    raise InfeasibleLMIError(f"LMI problem ({label}) not solved: " + "; ".join(errors),
                             errors[-1] if errors else "")


def _ladder(solve_at, g_opt, delta, deliberate, res):
    """Re-solve at gamma = (1+d) g_opt minimizing a gain bound.

    ``deliberate`` (feedthrough bound / user request): d = delta. Otherwise the first result
    failed its certificate for numerical reasons: try d = 1e-4, 1e-3, 1e-2 until one passes.
    """
    steps = [delta] if deliberate else [1e-4, 1e-3, 1e-2]
    last = None
    for d in steps:
        try:
            r = solve_at((1 + d) * g_opt)
        except SynthesisError as e:
            last = e
            continue
        r.regularized = True
        if r.certificate.ok or d == steps[-1]:
            return r, d
    if last is not None:
        raise last
    return res, steps[-1]


# --------------------------------------------------------------------------- state feedback
def compress_performance(p):
    """Same plant with z replaced by U^T z, U an orthonormal basis of range [C1 D11 D12].

    |z| is unchanged (the dropped components vanish identically); the W-infinity channel
    has 2n rows but rank <= n + nw + nu, so the BRL block shrinks (faster SDP).
    """
    M = np.hstack([p.C1, p.D11, p.D12])
    if M.shape[0] <= M.shape[1]:
        return p
    U, sv, _ = np.linalg.svd(M, full_matrices=False)
    r = max(1, int(np.sum(sv > 1e-12 * max(sv.max(), 1e-300))))
    U = U[:, :r]
    return GeneralizedPlant(p.A, p.B1, p.B2, U.T @ p.C1, U.T @ p.D11, U.T @ p.D12, p.C2, p.D21)


def _sf_program(plants, *, region, gamma2, input_weight, gain_bound, margin=EPS):
    """BRL (gamma^2 form, Schur complement of (6.5)) for each vertex with a common X, W."""
    plants = [compress_performance(p) for p in plants]
    p0 = plants[0]
    n, nu = p0.n, p0.nu
    prog = LMIProgram()
    X = prog.sym(n)
    W = prog.full(nu, n)
    g2 = prog.scalar() if gamma2 is None else None
    prog.add_pos(X, EPS)
    for p in plants:
        Ww = np.eye(p.nw) if input_weight is None else input_weight
        gblk = (-g2 * Ww) if g2 is not None else -gamma2 * Ww
        AX = p.A @ X + p.B2 @ W
        CX = p.C1 @ X + p.D12 @ W
        prog.add_lmi(bmat([[AX.sym(), p.B1, CX.T],
                           [p.B1.T, gblk, p.D11.T],
                           [CX, p.D11, -np.eye(p.nz)]]), margin)
        if region is not None:
            prog.add_lmi(region_lmi(region, X, AX), EPS)
    if gain_bound:
        kw, kx = prog.scalar(), prog.scalar()
        prog.add_pos(bmat([[kw * np.eye(n), W.T], [W, np.eye(nu)]]))  # W^T W <= kw I
        prog.add_pos(bmat([[X, np.eye(n)], [np.eye(n), kx * np.eye(n)]]))  # X^-1 <= kx I
        prog.minimize(kw + kx)
    else:
        prog.minimize(g2)
    return prog, X, W, g2


def _finish(res, plants, region, rtol, verify, status):
    certs = []
    for p in plants:
        cl = p.closed_loop(K=res.K) if res.kind == "state_feedback" else p.closed_loop(controller=res.controller)
        certs.append(certify_closed_loop(*cl, res.gamma, region=region, rtol=rtol, solver_status=status))
    res.certificates = certs
    res.certificate = max(certs, key=lambda c: c.achieved) if certs else None
    if verify:
        for i, c in enumerate(certs):
            if not c.ok:
                where = f" (vertex {i})" if len(certs) > 1 else ""
                raise SynthesisError(f"{res.kind} result from {res.backend}/{res.solver} rejected{where}: "
                                     + "; ".join(c.failures) + f" [solver status: {status}]")
    return res


def _first_attempt(build, out, g_opt, gamma, bound, plants, region, rtol, regularize, warns):
    """Certify the unregularized optimum; decide whether the regularizing ladder must run.

    The SDP optimum is approached from above, so without a requested gamma the result is
    certified against the solver's gamma plus a 1e-6 relative slack.  Returns
    (res or None, on_bound, need_regularization); re-raises the certificate failure when the
    optimum fails and regularization is not allowed.  Appends the on-bound warning to ``warns``.
    """
    first_error = None
    try:
        res = build(out, g_opt * (1 + 1e-6) if gamma is None else g_opt)
        _finish(res, plants, region, rtol, False, out.status)
    except SynthesisError as e:
        first_error, res = e, None
    on_bound = bound > 0 and g_opt <= bound * (1 + 1e-3)
    if on_bound:
        warns.append(f"optimal gamma {g_opt:.6g} sits on the feedthrough bound {bound:.6g}: the "
                     f"infimum needs unbounded gains, the LMI optimum's gains depend on solver noise")
    need = regularize is True or (regularize == "auto" and gamma is None
                                  and (on_bound or res is None or not res.certificate.ok))
    if res is None and not need:
        raise first_error
    return res, on_bound, need


def _publish(res, warns, t0, plants, region, rtol, verify):
    """Attach and emit the warnings, total time, and run the final certificate check."""
    res.warnings = warns
    res.timings["total"] = time.perf_counter() - t0
    for w in warns:
        warnings.warn(w, SynthesisWarning, stacklevel=3)  # at the caller of the public function
    return _finish(res, plants, region, rtol, verify, res.status)


def _validate(plants, need_detectable):
    p0 = plants[0]
    for p in plants:
        if tuple(M.shape for M in p.as_tuple()) != tuple(M.shape for M in p0.as_tuple()):
            raise ValueError("all vertex plants must have the same dimensions")
        require_stabilizable(p.A, p.B2)
        if need_detectable:
            require_detectable(p.A, p.C2)


def _pow2(v):
    """Nearest powers of two: scaling by them is exact in floating point."""
    return np.exp2(np.round(np.log2(v)))


def balance_scaling(plants):
    """Diagonal state similarity x = T x~ and input scaling u = Su u~ (powers of two).

    The w -> z map (hence gamma), the closed-loop poles (hence any LMI region) and the
    feasible set are invariant; only the SDP's conditioning changes.  Su makes the columns
    of [B2; D12] unit-sized; T balances [[A, b], [c, 0]] (scipy's matrix_balance, Parlett &
    Reinsch), b / c the row / column magnitudes of [B1 B2 Su] / C1 over the vertices.
    """
    n = plants[0].n
    cu = np.max([np.linalg.norm(np.vstack([p.B2, p.D12]), axis=0) for p in plants], axis=0)
    Su = _pow2(np.where(cu > 0, 1.0 / np.where(cu > 0, cu, 1.0), 1.0))
    absA = np.max([np.abs(p.A) for p in plants], axis=0)
    b = np.max([np.linalg.norm(np.hstack([p.B1, p.B2 * Su]), axis=1) for p in plants], axis=0)
    c = np.max([np.linalg.norm(p.C1, axis=0) for p in plants], axis=0)
    M = np.block([[absA, b[:, None]], [c[None, :], np.zeros((1, 1))]])
    if not (np.all(np.isfinite(M)) and M.any()):
        return np.ones(n), Su
    _, (d, _) = sla.matrix_balance(M, permute=False, separate=True)
    T = _pow2(d[:n] / d[n])
    # the inputs again, now in scaled state coordinates
    cu = np.max([np.linalg.norm(np.vstack([p.B2 / T[:, None], p.D12]), axis=0) for p in plants], axis=0)
    Su = _pow2(np.where(cu > 0, 1.0 / np.where(cu > 0, cu, 1.0), 1.0))
    return T, Su


def scale_plant(p, T, Su):
    """Plant in coordinates x = T x~, u = Su u~ (w, z, y unchanged)."""
    Ti = 1.0 / T
    return GeneralizedPlant(Ti[:, None] * p.A * T, Ti[:, None] * p.B1, Ti[:, None] * p.B2 * Su,
                            p.C1 * T, p.D11, p.D12 * Su, p.C2 * T, p.D21)


def state_feedback(plant, *, region=None, backend=None, solver_options=None, gamma=None,
                   regularize="auto", delta=1e-2, rtol=1e-4, verify=True, input_weight=None,
                   vertices=None, margin=EPS, scaling=True):
    """H-infinity state feedback u = K x minimizing gamma (or feasibility at a given gamma).

    ``vertices``: optional list of extra plants sharing one Lyapunov matrix (polytopic,
    Corollary 1). ``input_weight``: replaces I in the -gamma^2 I block (used by the thesis'
    disturbance-model LMI (6.31)). ``regularize``: "auto" re-solves with a gain bound when the
    optimum sits on the feedthrough bound or the certificate fails; True always; False never.
    ``scaling``: True (default) solves the LMI in balanced coordinates (``balance_scaling``:
    exact diagonal state similarity and input scaling, gamma unchanged) and maps K, X, P back;
    a tuple (T, Su) gives the scalings; False solves in the given coordinates.  The
    certificate is always computed in the original coordinates.
    """
    plants = [plant] + list(vertices or [])
    if any(tuple(M.shape for M in p.as_tuple()) != tuple(M.shape for M in plant.as_tuple())
           for p in plants):
        raise ValueError("all vertex plants must have the same dimensions")
    fb = max(np.linalg.norm(p.D11, 2) if p.D11.size else 0.0 for p in plants)  # SF: D_cl = D11
    _check_gamma_request(gamma, fb)
    timings, warns = {}, []
    t0 = time.perf_counter()
    if scaling is True:
        T, Su = balance_scaling(plants)
    elif scaling is False or scaling is None:
        T, Su = np.ones(plant.n), np.ones(plant.nu)
    else:
        T, Su = (np.asarray(v, float).ravel() for v in scaling)
        if T.shape != (plant.n,) or Su.shape != (plant.nu,) or np.any(T <= 0) or np.any(Su <= 0):
            raise ValueError(f"scaling must be True, False or (T, Su) with positive T of length "
                             f"{plant.n} and Su of length {plant.nu}")
    splants = [scale_plant(p, T, Su) for p in plants]
    _validate(splants, False)  # stabilizability is invariant; its rank test is not: test balanced
    prog, X, W, g2 = _sf_program(splants, region=region, gamma2=None if gamma is None else gamma ** 2,
                                 input_weight=input_weight, gain_bound=gamma is not None, margin=margin)
    out = _solve(prog, backend, solver_options, timings, "lmi")
    g_opt = float(np.sqrt(max(g2.value(out.x)[0, 0], 0.0))) if gamma is None else float(gamma)

    def build(out, g):
        Xv = X.value(out.x)
        Xv = 0.5 * (Xv + Xv.T)
        if np.linalg.eigvalsh(Xv).min() <= 0:
            raise SynthesisError(f"solver returned X not positive definite (status {out.status})")
        Ks = np.linalg.solve(Xv, W.value(out.x).T).T  # K = W X^-1 (6.7), scaled coordinates
        K = Su[:, None] * Ks / T  # u = Su Ks T^-1 x
        P = np.linalg.inv(Xv) / T[:, None] / T  # P = T^-1 Ps T^-1, X = T Xs T
        return SynthesisResult("state_feedback", g, K=K, P=P, X=T[:, None] * Xv * T, gamma_opt=g_opt,
                               feedthrough_bound=fb, solver=out.solver, backend=out.backend,
                               status=out.status, timings=timings, region=region)

    res, on_bound, need = _first_attempt(build, out, g_opt, gamma, fb, plants, region, rtol,
                                         regularize, warns)
    if need:
        def solve_at(g):
            prog2, X2, W2, _ = _sf_program(splants, region=region, gamma2=g ** 2, input_weight=input_weight,
                                           gain_bound=True, margin=margin)
            nonlocal X, W
            X, W = X2, W2
            r = build(_solve(prog2, backend, solver_options, timings, "regularize"), g)
            return _finish(r, plants, region, rtol, False, r.status)
        res, d = _ladder(solve_at, g_opt, delta, on_bound or regularize is True, res)
        warns.append(f"regularized: gamma relaxed to (1+{d:g}) x {g_opt:.6g} = {res.gamma:.6g} "
                     f"minimizing a bound on the gain (|K| = {np.linalg.norm(res.K, 2):.4g})")
    if np.linalg.norm(res.K, 2) > 1e6:
        warns.append(f"very large gain |K| = {np.linalg.norm(res.K, 2):.3g}")
    return _publish(res, warns, t0, plants, region, rtol, verify)


# --------------------------------------------------------------------------- output feedback
def _of_program(p, *, region, gamma2, input_weight, gain_bound, strictly_proper, margin=EPS):
    p = compress_performance(p)
    n, nu, ny = p.n, p.nu, p.ny
    prog = LMIProgram()
    X, Y = prog.sym(n), prog.sym(n)
    Ak, Bk, Ck = prog.full(n, n), prog.full(n, ny), prog.full(nu, n)
    Dk = Affine.lift(np.zeros((nu, ny))) if strictly_proper else prog.full(nu, ny)
    g2 = prog.scalar() if gamma2 is None else None
    Ww = np.eye(p.nw) if input_weight is None else input_weight
    gblk = (-g2 * Ww) if g2 is not None else -gamma2 * Ww
    I = np.eye(n)
    AX = p.A @ X + p.B2 @ Ck
    AC = p.A + p.B2 @ Dk @ p.C2
    YA = Y @ p.A + Bk @ p.C2
    M21 = Ak + AC.T
    M31 = (p.B1 + p.B2 @ Dk @ p.D21).T
    M32 = (Y @ p.B1 + Bk @ p.D21).T
    M41 = p.C1 @ X + p.D12 @ Ck
    M42 = p.C1 + p.D12 @ Dk @ p.C2
    M43 = p.D11 + p.D12 @ Dk @ p.D21
    prog.add_lmi(bmat([[AX.sym(), M21.T, M31.T, M41.T],
                       [M21, YA.sym(), M32.T, M42.T],
                       [M31, M32, gblk, M43.T],
                       [M41, M42, M43, -np.eye(p.nz)]]), margin)
    XY = bmat([[X, I], [I, Y]])
    prog.add_pos(XY, COUPLING_MARGIN)
    if region is not None:
        prog.add_lmi(region_lmi(region, XY, bmat([[AX, AC], [Ak, YA]])), EPS)
    if gain_bound:
        k = prog.scalar()
        Th = bmat([[Ak, Bk], [Ck, Dk]])
        m1, m2 = Th.shape
        prog.add_pos(bmat([[k * np.eye(m2), Th.T], [Th, k * np.eye(m1)]]))
        prog.add_lmi(X - k * I)
        prog.add_lmi(Y - k * I)
        prog.minimize(k)
    else:
        prog.minimize(g2)
    return prog, (X, Y, Ak, Bk, Ck, Dk), g2


def reconstruct_controller(p, X, Y, Ak, Bk, Ck, Dk, rank_tol=0.0):
    """Controller from the linearizing variables; M N^T = I - X Y by SVD (balanced factors).

    At the LMI optimum I - XY tends to be rank deficient (a lower-order controller suffices);
    the synthesis keeps it invertible with a margin on [[X, I], [I, Y]] (``COUPLING_MARGIN``),
    which costs ~1e-6 relative in gamma and avoids spurious huge/unstable controller modes.
    Optional truncation of singular values below ``rank_tol * s_max`` gives a reduced-order
    controller (approximate; the certificate decides). Returns (controller, P) with P the
    closed-loop Lyapunov matrix (None when truncated).
    """
    n = p.n
    U, s, Vt = np.linalg.svd(np.eye(n) - X @ Y)
    r = int(np.sum(s > rank_tol * max(s.max(), 1e-300)))
    if r == 0:
        raise SynthesisError("I - XY vanishes: no controller can be reconstructed")
    M = U[:, :r] * np.sqrt(s[:r])
    N = Vt[:r].T * np.sqrt(s[:r])
    Mp, Np = np.linalg.pinv(M), np.linalg.pinv(N)  # exact inverses when r = n
    DK = Dk
    CK = (Ck - DK @ p.C2 @ X) @ Mp.T
    BK = Np @ (Bk - Y @ p.B2 @ DK)
    rest = Ak - Y @ (p.A + p.B2 @ DK @ p.C2) @ X - N @ BK @ p.C2 @ X - Y @ p.B2 @ CK @ M.T
    AK = Np @ rest @ Mp.T
    P = None
    if r == n:
        Pi1 = np.block([[X, np.eye(n)], [M.T, np.zeros((n, n))]])
        Pi2 = np.block([[np.eye(n), Y], [np.zeros((n, n)), N.T]])
        P = np.linalg.solve(Pi1.T, Pi2.T).T  # P Pi1 = Pi2
        P = 0.5 * (P + P.T)
    return DynamicController(AK, BK, CK, DK), P


def output_feedback(plant, *, region=None, backend=None, solver_options=None, gamma=None,
                    regularize="auto", delta=1e-2, rtol=1e-4, verify=True, input_weight=None,
                    strictly_proper=False, margin=EPS):
    """Full-order dynamic output-feedback H-infinity synthesis (controller feedthrough allowed)."""
    p = plant
    _validate([p], True)
    fb = 0.0 if strictly_proper is None else parrott_bound(p.D11, p.D12, p.D21)
    if strictly_proper:
        fb = np.linalg.norm(p.D11, 2)
    _check_gamma_request(gamma, fb)
    timings, warns = {}, []
    t0 = time.perf_counter()
    kw = dict(region=region, input_weight=input_weight, strictly_proper=strictly_proper, margin=margin)
    prog, V, g2 = _of_program(p, gamma2=None if gamma is None else gamma ** 2, gain_bound=gamma is not None, **kw)
    out = _solve(prog, backend, solver_options, timings, "lmi")
    g_opt = float(np.sqrt(max(g2.value(out.x)[0, 0], 0.0))) if gamma is None else float(gamma)

    def build(out, g):
        vals = [v.value(out.x) for v in V]
        vals[0], vals[1] = 0.5 * (vals[0] + vals[0].T), 0.5 * (vals[1] + vals[1].T)
        ctrl, P = reconstruct_controller(p, *vals)
        return SynthesisResult("output_feedback", g, controller=ctrl, P=P, X=vals[0], Y=vals[1],
                               gamma_opt=g_opt, feedthrough_bound=fb, solver=out.solver,
                               backend=out.backend, status=out.status, timings=timings, region=region)

    res, on_bound, need = _first_attempt(build, out, g_opt, gamma, fb, [p], region, rtol,
                                         regularize, warns)
    if need:
        def solve_at(g):
            prog2, V2, _ = _of_program(p, gamma2=g ** 2, gain_bound=True, **kw)
            V[:] = V2
            r = build(_solve(prog2, backend, solver_options, timings, "regularize"), g)
            return _finish(r, [p], region, rtol, False, r.status)
        V = list(V)
        res, d = _ladder(solve_at, g_opt, delta, on_bound or regularize is True, res)
        warns.append(f"regularized: gamma relaxed to (1+{d:g}) x {g_opt:.6g} = {res.gamma:.6g} "
                     "minimizing a bound on the controller matrices")
    if res.controller.AK.shape[0] < p.n:
        warns.append(f"I - XY numerically rank deficient: controller order reduced to "
                     f"{res.controller.AK.shape[0]} (of {p.n})")
    return _publish(res, warns, t0, [p], region, rtol, verify)


# --------------------------------------------------------------------------- functional API
def hinf_state_feedback(plant, **kwargs):
    """python-control style: ``K, gamma, result = hinf_state_feedback(plant, ...)``."""
    r = state_feedback(plant, **kwargs)
    return r.K, r.gamma, r


def hinfsyn(plant, **kwargs):
    """python-control style: ``controller, gamma, result = hinfsyn(plant, ...)`` (AK, BK, CK, DK)."""
    r = output_feedback(plant, **kwargs)
    return r.controller, r.gamma, r
