"""Riccati (Glover-Doyle) characterization of the H∞ problem, for regular plants.

For the generalized plant of ``problem.GeneralizedPlant`` (D22 = 0) write
B = [B1 B2], C = [C1; C2], D1. = [D11 D12], D.1 = [D11; D21] and, at a level gamma,

    R  = D1.' D1. - diag(gamma^2 I_nw, 0_nu),      Rt = D.1 D.1' - diag(gamma^2 I_nz, 0_ny).

* X solves A'X + XA + C1'C1 - (XB + C1'D1.) R^-1 (B'X + D1.'C1) = 0 (the game Riccati equation
  of the full-information problem, D11 allowed), F = -R^-1 (D1.'C1 + B'X) = [F1; F2];
* Y solves the dual equation for (A', C', B1 B1', Rt, B1 D.1'), L = -(B1 D.1' + Y C') Rt^-1.

**State feedback** (D12 full column rank).  u = K x can reach gamma iff gamma > |D11| (the
closed loop keeps D11) and X is stabilizing (A + B F Hurwitz) with X >= 0.  Then the saddle
point of the quadratic game in (u, w) -- convex in u because D12 has full column rank, concave
in w because gamma > |D11| -- is [w; u] = F x, so K = F2 (the u rows of F) achieves it.

**Output feedback** (D12 full column rank, D21 full row rank, Glover & Doyle 1988; Zhou, Doyle
& Glover 1996, ch. 17).  After the normalization D12 = [0; I], D21 = [0 I] (:func:`normalize`,
orthogonal changes of z and w, invertible changes of u and y) a controller reaching gamma
exists iff gamma exceeds the Parrott bound, X and Y are stabilizing and positive semidefinite,
and rho(X Y) < gamma^2.  :func:`central_controller` builds the central controller.

The imaginary-axis rank conditions of the standard problem are not tested separately: when
they fail the Hamiltonians have imaginary-axis eigenvalues at every gamma, the gamma search
finds no feasible level and the caller falls back to the LMI synthesis.  Nothing here is
trusted on its own: the callers certify every controller on the original plant
(``certificates.py``), whichever path produced it.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np
import scipy.linalg as sla

from sobolev_drake.errors import SynthesisError

from .certificates import parrott_bound
from .problem import DynamicController, GeneralizedPlant

__all__ = [
    "RiccatiInfeasible", "rank_deficiency", "state_feedback_test", "Normalization", "normalize",
    "OutputFeedbackLevel", "output_feedback_test", "output_feedback_level_test",
    "central_controller", "BudgetExceeded",
    "bisect_gamma",
]

#: relative ARE residual above which a Riccati solution is not trusted.  scipy's solver is
#: backward stable (residuals ~1e-13 relative on well-posed levels); near the optimal gamma the
#: solution grows without bound and the residual with it, so the level is declared infeasible
#: there -- conservative, costs only a slightly larger gamma.
ARE_RESIDUAL_TOL = 1e-7


class RiccatiInfeasible(SynthesisError):
    """The level gamma is not reachable according to the Riccati tests (reason attached)."""


def rank_deficiency(plant: GeneralizedPlant, output_feedback: bool, tol: float = 1e-9) -> str:
    """"" when the problem is regular, else which rank condition fails.

    Regular: D12 full column rank, and for output feedback D21 full row rank."""
    checks = [("D12", plant.D12, plant.nu, 1)]
    if output_feedback:
        checks.append(("D21", plant.D21, plant.ny, 0))
    msgs = []
    for name, M, full, _ in checks:
        s = np.linalg.svd(M, compute_uv=False) if M.size else np.zeros(0)
        r = int(np.sum(s > tol * max(1.0, s.max() if s.size else 0.0)))
        if r < full:
            msgs.append(f"rank {name} = {r} < {full}")
    return ", ".join(msgs)


#: above this condition number of R the Hamiltonian's R^-1 loses the accuracy the extended
#: pencil keeps: only then may scipy's QZ decide a level the Schur form could not
R_COND_QZ = 1e6


#: the stable eigenvalues of the Hamiltonian's Schur form stand for those of A + B F (no
#: separate eigenvalue computation) when they are at least STABLE_MARGIN ||H||_1 left of the
#: imaginary axis and U11's reciprocal condition estimate is at least STABLE_RCOND
#: (:func:`_schur_solution`)
STABLE_MARGIN = 1e-6
STABLE_RCOND = 1e-6


def _schur_solution(A, B, Q, R, S):
    """(X, stable) from the ordered real Schur form of the Hamiltonian (Laub's method), or
    (None, False) when X cannot be formed accurately (non-finite Hamiltonian, ill-conditioned
    U11); raises RiccatiInfeasible when the Hamiltonian has not exactly n stable eigenvalues
    (no stabilizing solution: the level is infeasible).

    ``stable`` True: the Schur form already shows A + B F Hurwitz, F = -R^-1 (B'X + S').
    Why: H [U11; U21] = [U11; U21] T11 (the stable invariant subspace), whose first block row
    is (A - B R^-1 S') U11 - B R^-1 B' U21 = U11 T11, so with X = U21 U11^-1 exactly
    A + B F = U11 T11 U11^-1: the closed-loop eigenvalues are those of T11, whose real parts
    are its diagonal (LAPACK's Schur canonical form: 2 x 2 blocks with equal diagonal
    entries).  In floating point A + B F is that similarity plus the Schur form's backward
    error (~eps ||H||) amplified by ||U11^-1||, so the eigenvalues of T11 are trusted only
    with a margin: all at least STABLE_MARGIN ||H||_1 left of the axis and rcond(U11) >=
    STABLE_RCOND (then ||U11^-1|| <~ n 1e6 and the perturbation ~1e-8 ||H||, 100x inside the
    margin).  Otherwise (``stable`` False) :func:`_checked` computes eig(A + B F).  How often
    the rule applies and that it was never wrong is measured in docs/scale.md (issue 36); the
    final certificate re-checks the closed loop's eigenvalues independently anyway."""
    n = A.shape[0]
    RiBt, RiSt = np.linalg.solve(R, B.T), np.linalg.solve(R, S.T)
    Ah = A - B @ RiSt
    # the blocks written into one Fortran-ordered array that LAPACK may overwrite (the values
    # of np.block; no copy on the way into dgees)
    H = np.empty((2 * n, 2 * n), order="F")
    H[:n, :n] = Ah
    H[:n, n:] = -B @ RiBt
    H[n:, :n] = -(Q - S @ RiSt)
    H[n:, n:] = -Ah.T
    if not np.all(np.isfinite(H)):
        return None, False
    h1 = np.linalg.norm(H, 1)  # before dgees overwrites H
    T, sdim, U = _ordered_schur(H)
    if sdim != n:
        raise RiccatiInfeasible(f"Hamiltonian has {sdim} stable eigenvalues, not {n}")
    U11, U21 = U[:n, :n], U[n:, :n]
    # X' = U11'^-1 U21' through one LU, whose reciprocal condition estimate (O(n^2)) replaces
    # the SVD of np.linalg.cond (same 1e12 threshold, within the estimator's factor ~n);
    # LAPACK's getrf / getrs directly, as scipy's lu_factor / lu_solve call them
    lu, piv, info = _GETRF(U11.T)
    if info < 0:
        return None, False
    rcond, info = _GECON(lu, np.linalg.norm(U11.T, 1), norm="1")
    if info != 0 or not rcond > 1e-12:
        return None, False
    stable = bool(rcond >= STABLE_RCOND and np.diag(T)[:n].max() <= -STABLE_MARGIN * h1)
    Xt, info = _GETRS(lu, piv, U21.T)
    if info != 0:
        return None, False
    return Xt.T, stable


_GEES, _GETRF, _GECON, _GETRS = (sla.lapack.dgees, sla.lapack.dgetrf, sla.lapack.dgecon,
                                 sla.lapack.dgetrs)
_GEES_LWORK: dict = {}


def _lhp(re, im):
    return re < 0.0


def _ordered_schur(H):
    """(T, sdim, U) of ``scipy.linalg.schur(H, output="real", sort="lhp")``, with LAPACK's
    dgees called directly: the same routine, arguments and optimal workspace (queried once
    per size instead of on every call) -- the same bits, without the wrapper's per-call
    workspace query and input copy (~40 us of a 0.5 ms Schur form at 40 x 40, twice per level
    of a bisection).  ``H`` (Fortran-ordered, float) is overwritten.  LinAlgError when dgees
    fails, as scipy's."""
    m = H.shape[0]
    lwork = _GEES_LWORK.get(m)
    if lwork is None:
        lwork = _GEES_LWORK[m] = int(_GEES(_lhp, H, lwork=-1)[-2][0])
    T, sdim, _, _, U, _, info = _GEES(_lhp, H, lwork=lwork, overwrite_a=1, sort_t=1)
    if info != 0:
        raise np.linalg.LinAlgError(f"dgees failed (info {info})")
    return T, sdim, U


def _stabilizing_solution(A, B, Q, R, S, name="X"):
    """Stabilizing, positive semidefinite solution X of
    A'X + XA + Q - (XB + S) R^-1 (B'X + S') = 0 and the gain F = -R^-1 (B'X + S'), R symmetric
    nonsingular and possibly indefinite; RiccatiInfeasible (naming ``name``) otherwise.

    The ordered Schur form of the 2n x 2n Hamiltonian first (measured 2.7x faster than scipy's
    extended-pencil QZ at n = 30); scipy's ``solve_continuous_are`` (QZ of the extended pencil,
    no inverse of R) when the Schur form gives no X, or when its X fails the checks and R is
    ill-conditioned (cond > ``R_COND_QZ``: near the feedthrough bound, tiny regularizing
    perturbations), the one case the pencil is more accurate.  A Schur X with a well-conditioned
    R that fails the residual test is the blow-up of X near the optimum: the level is declared
    infeasible (measured on 44 random plants, 1900 levels, regular and singular families: the
    QZ solve never passed where the Schur solution had failed).  Either way the residual, the
    positive semidefiniteness and the stability of A + B F (in that order: a level rejected by
    the cheaper tests needs no eigenvalues) are checked here."""
    try:
        # RiccatiInfeasible: wrong number of stable modes
        X, stable = _schur_solution(A, B, Q, R, S)
    except (np.linalg.LinAlgError, ValueError):
        X = None
    if X is not None:
        try:
            return _checked(A, B, Q, R, S, X, name, stable)
        except RiccatiInfeasible:
            if np.linalg.cond(R) <= R_COND_QZ:
                raise
            # not accurate enough: the extended pencil decides
    try:
        X = sla.solve_continuous_are(A, B, Q, R, s=S)
    except (np.linalg.LinAlgError, ValueError) as e:
        raise RiccatiInfeasible(f"no stabilizing Riccati solution ({e})") from None
    return _checked(A, B, Q, R, S, X, name)


def _checked(A, B, Q, R, S, X, name="X", stable=False):
    """(X, F) after the residual, PSD and stability tests; ``stable``: the Schur form already
    showed A + B F Hurwitz (:func:`_schur_solution`), no eigenvalues computed here."""
    if not np.all(np.isfinite(X)):
        raise RiccatiInfeasible("Riccati solution not finite")
    X = 0.5 * (X + X.T)
    G = B.T @ X + S.T
    F = -np.linalg.solve(R, G)
    res = A.T @ X + X @ A + Q + G.T @ F
    scale = (2 * np.linalg.norm(A.T @ X) + np.linalg.norm(Q) + np.linalg.norm(G.T @ F) + 1e-300)
    if np.linalg.norm(res) > ARE_RESIDUAL_TOL * scale:
        raise RiccatiInfeasible(f"Riccati residual {np.linalg.norm(res) / scale:.1e} (relative)")
    _require_psd(X, name)
    if not stable and np.linalg.eigvals(A + B @ F).real.max() >= 0:
        raise RiccatiInfeasible("Riccati solution not stabilizing")
    return X, F


def _require_psd(X, name):
    ev = np.linalg.eigvalsh(X)
    if ev.min() < -1e-9 * max(1.0, np.abs(ev).max()):
        raise RiccatiInfeasible(f"{name} not positive semidefinite (eigenvalue {ev.min():.3g})")


class _GameRiccati:
    """The X (``dual`` False) or Y (``dual`` True) Riccati equation of a plant, its
    level-independent matrices formed once: a bisection solves it at ~25 levels, and forming
    B, Q, S and D'D again at each cost ~10 % of a 20-state level (the arithmetic, hence every
    solution, is that of forming them per level)."""

    def __init__(self, p, dual=False):
        if not dual:
            D1 = np.hstack([p.D11, p.D12])
            self.args = (p.A, np.hstack([p.B1, p.B2]), p.C1.T @ p.C1, p.C1.T @ D1)
            self.DD, self.k, self.name = D1.T @ D1, p.nw, "X"
        else:
            Dc = np.vstack([p.D11, p.D21])
            self.args = (p.A.T, np.vstack([p.C1, p.C2]).T, p.B1 @ p.B1.T, p.B1 @ Dc.T)
            self.DD, self.k, self.name = Dc @ Dc.T, p.nz, "Y"
        self.eye = np.eye(self.k)

    def __call__(self, gamma):
        R = self.DD.copy()
        R[:self.k, :self.k] -= gamma ** 2 * self.eye
        A, B, Q, S = self.args
        return _stabilizing_solution(A, B, Q, R, S, self.name)


def _x_riccati(p, gamma):
    return _GameRiccati(p)(gamma)


# --------------------------------------------------------------------------- state feedback
def state_feedback_test(p: GeneralizedPlant, gamma: float) -> tuple[np.ndarray, np.ndarray]:
    """Gain K = F2 reaching ``gamma`` (see the module docstring), or RiccatiInfeasible."""
    d11 = np.linalg.norm(p.D11, 2) if p.D11.size else 0.0
    if gamma <= d11:
        raise RiccatiInfeasible(f"gamma {gamma:.6g} not above |D11| = {d11:.6g}")
    X, F = _x_riccati(p, gamma)
    return F[p.nw:], X


# --------------------------------------------------------------------------- output feedback
@dataclass
class Normalization:
    """Coordinates of :func:`normalize`: u = Tu u_n, y = Ty y_n (z, w rotated orthogonally)."""

    plant: GeneralizedPlant
    Tu: np.ndarray
    Ty: np.ndarray

    def controller(self, ctrl: DynamicController) -> DynamicController:
        """Controller from y_n to u_n -> controller from y to u (same state)."""
        AK, BK, CK, DK = ctrl
        Tyi = np.linalg.inv(self.Ty)
        return DynamicController(AK, BK @ Tyi, self.Tu @ CK, self.Tu @ DK @ Tyi)


def _complement(Q):
    """Orthonormal basis of the orthogonal complement of the orthonormal columns Q."""
    full, _ = np.linalg.qr(Q, mode="complete")
    return full[:, Q.shape[1]:]


def normalize(p: GeneralizedPlant) -> Normalization:
    """Equivalent plant with D12 = [0; I] and D21 = [0 I] (regular problems only).

    u = Tu u_n with Tu = (D12'D12)^-1/2, y = Ty y_n with Ty = (D21 D21')^1/2; z and w are
    rotated by orthogonal matrices, which changes no closed-loop norm."""
    Tu = sla.fractional_matrix_power(p.D12.T @ p.D12, -0.5).real
    Ty = sla.sqrtm(p.D21 @ p.D21.T).real
    D12n = p.D12 @ Tu
    D21n = np.linalg.solve(Ty, p.D21)
    U = np.hstack([_complement(D12n), D12n])  # U' D12n = [0; I]
    V = np.hstack([_complement(D21n.T), D21n.T])  # D21n V = [0 I]
    pn = GeneralizedPlant(p.A, p.B1 @ V, p.B2 @ Tu, U.T @ p.C1, U.T @ p.D11 @ V, U.T @ D12n,
                          np.linalg.solve(Ty, p.C2), D21n @ V)
    return Normalization(pn, Tu, Ty)


@dataclass
class OutputFeedbackLevel:
    """Riccati data of a reachable level gamma (normalized plant)."""

    gamma: float
    X: np.ndarray
    Y: np.ndarray
    F: np.ndarray
    L: np.ndarray


_PARROTT = {}


def _parrott_bound(pn):
    """``parrott_bound`` of the plant's feedthroughs, memoized by their bytes: a bisection
    tests ~25 levels of one plant (three SVDs each otherwise)."""
    key = tuple((M.shape, M.tobytes()) for M in (pn.D11, pn.D12, pn.D21))
    fb = _PARROTT.get(key)
    if fb is None:
        if len(_PARROTT) > 64:
            _PARROTT.clear()
        fb = _PARROTT[key] = parrott_bound(pn.D11, pn.D12, pn.D21)
    return fb


def output_feedback_test(pn: GeneralizedPlant, gamma: float) -> OutputFeedbackLevel:
    """Riccati data at ``gamma`` for the normalized plant ``pn``, or RiccatiInfeasible."""
    return output_feedback_level_test(pn)(gamma)


def output_feedback_level_test(pn: GeneralizedPlant) -> Callable[[float], OutputFeedbackLevel]:
    """:func:`output_feedback_test` of ``pn`` as a function of gamma alone.

    The level-independent matrices of both Riccati equations (B, Q, S, D'D of each) are
    formed once instead of at every level of a bisection; the arithmetic per level, hence
    every result, is that of :func:`output_feedback_test`.

    Parameters
    ----------
    pn : GeneralizedPlant
        A normalized regular plant (:func:`normalize`).

    Returns
    -------
    callable
        gamma -> :class:`OutputFeedbackLevel`, raising :class:`RiccatiInfeasible` where gamma
        is not reachable.

    Examples
    --------
    >>> import numpy as np
    >>> from sobolev_drake.synthesis.random_plants import random_plant
    >>> p = random_plant(np.random.default_rng(0), 4, "stable").plant
    >>> test = output_feedback_level_test(normalize(p).plant)
    >>> lo, hi, level, count = bisect_gamma(test, 0.0, rtol=1e-6)
    >>> print(f"{hi:.3f}", bool(np.all(np.linalg.eigvalsh(level.X) > -1e-9)))
    2.066 True
    """
    x_eq, y_eq = _GameRiccati(pn), _GameRiccati(pn, dual=True)

    def test(gamma):
        fb = _parrott_bound(pn)
        if gamma <= fb:
            raise RiccatiInfeasible(f"gamma {gamma:.6g} not above the Parrott bound {fb:.6g}")
        X, F = x_eq(gamma)
        Y, Lt = y_eq(gamma)
        rho = np.abs(np.linalg.eigvals(X @ Y)).max()
        if rho >= gamma ** 2 * (1 - 1e-12):
            raise RiccatiInfeasible(f"coupling condition fails: rho(XY) = {rho:.6g} >= "
                                    f"gamma^2 = {gamma ** 2:.6g}")
        return OutputFeedbackLevel(gamma, X, Y, F, Lt.T)
    return test


def central_controller(pn: GeneralizedPlant, lev: OutputFeedbackLevel) -> DynamicController:
    """Central controller of the normalized plant at a reachable level (Glover & Doyle 1988;
    Zhou, Doyle & Glover 1996, Theorem 17.?: the parametrization with Q = 0), D11 allowed."""
    g2 = lev.gamma ** 2
    nw, nu, nz, ny = pn.nw, pn.nu, pn.nz, pn.ny
    m1, p1 = nw - ny, nz - nu  # w-only inputs, z-only outputs
    D = pn.D11
    D1111, D1112, D1121, D1122 = D[:p1, :m1], D[:p1, m1:], D[p1:, :m1], D[p1:, m1:]
    Gl = g2 * np.eye(p1) - D1111 @ D1111.T
    Gr = g2 * np.eye(m1) - D1111.T @ D1111
    Dh11 = -D1121 @ D1111.T @ np.linalg.solve(Gl, D1112) - D1122
    Dh12 = np.linalg.cholesky(np.eye(nu) - D1121 @ np.linalg.solve(Gr, D1121.T))
    Dh21 = np.linalg.cholesky(np.eye(ny) - D1112.T @ np.linalg.solve(Gl, D1112)).T
    F1, F2 = lev.F[:nw], lev.F[nw:]
    F12 = F1[m1:]
    L1, L2 = lev.L[:, :nz], lev.L[:, nz:]
    L12 = L1[:, p1:]
    Z = np.linalg.inv(np.eye(pn.n) - lev.Y @ lev.X / g2)
    Bh2 = Z @ (pn.B2 + L12) @ Dh12
    Ch2 = -Dh21 @ (pn.C2 + F12)
    Bh1 = -Z @ L2 + Bh2 @ np.linalg.solve(Dh12, Dh11)
    Ch1 = F2 + Dh11 @ np.linalg.solve(Dh21, Ch2)
    Ah = pn.A + pn.B1 @ F1 + pn.B2 @ F2 + Bh1 @ np.linalg.solve(Dh21, Ch2)
    return DynamicController(Ah, Bh1, Ch1, Dh11)


# --------------------------------------------------------------------------- gamma search
class BudgetExceeded(SynthesisError):
    """The deadline passed during the gamma search."""


def bisect_gamma(test: Callable[[float], Any], lower: float, *, rtol: float = 1e-6,
                 start: float | None = None, deadline: float | None = None,
                 max_decades: int = 16) -> tuple[float, float, Any, int]:
    """Smallest reachable gamma by bisection on the monotone predicate ``test`` (returns data
    at a reachable level, raises RiccatiInfeasible otherwise).

    ``lower`` is a level known to be unreachable (a feedthrough bound, possibly 0).  Returns
    (gamma_lo, gamma_hi, data at gamma_hi, number of tests); gamma_hi / gamma_lo <= 1 + rtol
    unless gamma_hi is within rtol of ``lower``.  Raises RiccatiInfeasible when no level up to
    10^max_decades times the start is reachable.
    """
    count = [0]

    def attempt(g):
        if deadline is not None and time.perf_counter() > deadline:
            raise BudgetExceeded(f"time budget exhausted in the gamma search (at gamma {g:.6g})")
        count[0] += 1
        try:
            return test(g)
        except RiccatiInfeasible:
            return None
        except (np.linalg.LinAlgError, ValueError):
            return None

    g = start if start is not None else (2.0 * lower if lower > 0 else 1.0)
    lo, hi, data = lower, None, None
    d = attempt(g)
    if d is None:  # search upwards by decades
        lo = g
        for _ in range(max_decades):
            g *= 10.0
            d = attempt(g)
            if d is not None:
                hi, data = g, d
                break
            lo = g
        if hi is None:
            raise RiccatiInfeasible(f"no reachable level up to gamma = {g:.3g}")
    else:  # search downwards by decades (stop at the lower bound)
        hi, data = g, d
        while True:
            g = hi / 10.0
            if g <= lower:
                break
            d = attempt(g)
            if d is None:
                lo = g
                break
            hi, data = g, d
            if count[0] > max_decades + 2:
                lo = 0.0
                break
    while hi > lo * (1 + rtol):
        m = np.sqrt(lo * hi) if lo > 0 else 0.5 * hi
        if lo > 0 and not lo < m < hi:
            break
        d = attempt(m)
        if d is None:
            lo = m
        else:
            hi, data = m, d
        if lower > 0 and hi <= lower * (1 + rtol):
            break
    return lo, hi, data, count[0]
