"""Independent checks of linear synthesis results and input validation.

Nothing here uses the LMI: a result is accepted only if

* every closed-loop eigenvalue has negative real part (and lies in the requested LMI region),
* the H∞ norm of the closed-loop performance channel does not exceed the claimed gamma by more
  than a relative tolerance (default 1e-4): SLICOT's ab13dd when slycot is installed, its
  value re-checked by the own gain evaluation, else the own Hamiltonian iteration
  (:func:`hinf_norm`, Bruinsma & Steinbuch 1990, D != 0 handled).

Failures raise :class:`~sobolev_drake.synthesis.lmi.SynthesisError` naming the failed check and
by how much. Input validation (shapes, weights, PBH stabilizability) lives here as well.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from ..validation import describe, real_matrix, real_scalar, real_vector
from .lmi import SynthesisError

if TYPE_CHECKING:
    from sobolev_drake.synthesis.regions import LMIRegion

__all__ = [
    "as_matrix", "check_weight", "sqrtm_psd", "uncontrollable_modes", "require_stabilizable",
    "require_detectable", "parrott_bound", "hinf_norm", "hinf_norm_sweep", "Certificate",
    "certify_closed_loop", "brl_residual",
]


# --------------------------------------------------------------------------- validation
def as_matrix(name: str, M: ArrayLike, shape: tuple[int | None, int | None] | None = None) -> np.ndarray:
    """Return M as a finite real 2-D float array; check its shape (None entries = any size).
    Empty matrices pass (e.g. D21 of a plant without measurements); complex ones are refused."""
    return real_matrix(name, M, shape, allow_empty=True)


def check_weight(name: str, W: ArrayLike, n: int, definite: bool = True) -> np.ndarray:
    """Symmetric positive (semi)definite n x n weight; scalars / vectors mean diagonal."""
    if np.ndim(W) == 0:
        W = real_scalar(name, W) * np.eye(n)
    elif np.ndim(W) == 1:
        W = np.diag(real_vector(name, W, n))
    W = as_matrix(name, W, (n, n))
    if not np.allclose(W, W.T, atol=1e-12 * max(1.0, np.abs(W).max())):
        raise ValueError(f"{name} must be symmetric, got {describe(W)}")
    ev = np.linalg.eigvalsh(W)
    tol = 1e-12 * max(1.0, np.abs(ev).max())
    if (definite and ev.min() <= tol) or ev.min() < -tol:
        kind = "positive definite" if definite else "positive semidefinite"
        raise ValueError(f"{name} must be {kind}; smallest eigenvalue {ev.min():.3g}")
    return 0.5 * (W + W.T)


def sqrtm_psd(W: np.ndarray) -> np.ndarray:
    """Symmetric square root of a PSD matrix."""
    ev, V = np.linalg.eigh(W)
    return (V * np.sqrt(np.clip(ev, 0, None))) @ V.T


def uncontrollable_modes(A: np.ndarray, B: np.ndarray, tol: float = 1e-8,
                         stable_ok: bool = True) -> list[complex]:
    """PBH test: eigenvalues lam of A with rank[A - lam I, B] < n (only Re >= 0 if stable_ok)."""
    n = A.shape[0]
    bad = []
    for lam in np.linalg.eigvals(A):
        if stable_ok and lam.real < -tol:
            continue
        M = np.hstack([A - lam * np.eye(n), B])
        s = np.linalg.svd(M, compute_uv=False)
        if len(s) < n or s[n - 1] <= tol * max(1.0, s[0]):
            bad.append(lam)
    return bad


def require_stabilizable(A: np.ndarray, B: np.ndarray, what: str = "(A, B2)") -> None:
    bad = uncontrollable_modes(A, B)
    if bad:
        raise ValueError(f"{what} is not stabilizable: PBH rank test fails at eigenvalue(s) "
                         f"{np.round(bad, 6).tolist()}")


def require_detectable(A: np.ndarray, C: np.ndarray, what: str = "(A, C2)") -> None:
    bad = uncontrollable_modes(A.T, C.T)
    if bad:
        raise ValueError(f"{what} is not detectable: PBH rank test fails at eigenvalue(s) "
                         f"{np.round(bad, 6).tolist()}")


def parrott_bound(D11: np.ndarray, D12: np.ndarray, D21: np.ndarray) -> float:
    """min over D_K of ||D11 + D12 D_K D21|| (Parrott): no gamma below it is achievable."""
    def perp(M, side):  # orthonormal basis of the left (rows) / right kernel
        U, s, Vt = np.linalg.svd(M)
        r = int(np.sum(s > 1e-10 * max(1.0, s[0] if s.size else 1.0)))
        return U[:, r:] if side == "left" else Vt[r:].T
    a = perp(D12, "left").T @ D11 if D12.size else D11
    b = D11 @ perp(D21, "right") if D21.size else D11
    na = np.linalg.norm(a, 2) if a.size else 0.0
    nb = np.linalg.norm(b, 2) if b.size else 0.0
    return max(na, nb)


# --------------------------------------------------------------------------- norms
def _sigma_max(A, B, C, D, w):
    n = A.shape[0]
    G = C @ np.linalg.solve(1j * w * np.eye(n) - A, B) + D
    return np.linalg.norm(G, 2)


def hinf_norm(A: ArrayLike, B: ArrayLike, C: ArrayLike, D: ArrayLike,
              rtol: float = 1e-7) -> tuple[float, float]:
    """H∞ norm of C (sI-A)^-1 B + D by Hamiltonian iteration.

    Each iteration takes the imaginary-axis eigenvalues of the Hamiltonian at
    gamma = (1+2 rtol) * lower bound and evaluates the gain at the midpoints (Bruinsma &
    Steinbuch 1990); stops when none exist.

    Parameters
    ----------
    A, B, C, D : array_like
        State-space matrices of the continuous-time system.
    rtol : float, default 1e-7
        Relative tolerance of the iteration.

    Returns
    -------
    norm : float
        The H∞ norm; ``inf`` if A is not Hurwitz.
    peak_frequency : float
        Frequency (rad/s) of the peak; ``nan`` if A is not Hurwitz, ``inf`` when the peak is
        the feedthrough ‖D‖ (or the system has no state or no input/output).
    """
    A, B, C, D = (np.atleast_2d(np.asarray(M, float)) for M in (A, B, C, D))
    n = A.shape[0]
    if n and np.max(np.linalg.eigvals(A).real) >= 0:
        return np.inf, np.nan
    if n == 0 or not B.size or not C.size:
        return (np.linalg.norm(D, 2) if D.size else 0.0), np.inf
    ev = np.linalg.eigvals(A)
    cands = [0.0] + [abs(e.imag) for e in ev] + [abs(e) for e in ev]
    lb, wpk = max((_sigma_max(A, B, C, D, w), w) for w in cands)
    dn = np.linalg.norm(D, 2) if D.size else 0.0
    if dn > lb:
        lb, wpk = dn, np.inf
    for _ in range(60):
        # a floor whose square is still a normal float: a zero transfer function (e.g. a
        # performance output that only weighs an input the controller leaves at zero) has
        # lb = 0, and g² must not underflow to 0 (singular R)
        g = (1 + 2 * rtol) * max(lb, 1e-150)
        R = g * g * np.eye(D.shape[1]) - D.T @ D
        S = g * g * np.eye(D.shape[0]) - D @ D.T
        Ri = np.linalg.inv(R)
        Ah = A + B @ Ri @ D.T @ C
        # gamma is a singular value of G(jw) iff i*w is an eigenvalue of this Hamiltonian
        H = np.block([[Ah, B @ Ri @ B.T], [-C.T @ np.linalg.solve(S, C) * g * g, -Ah.T]])
        lam = np.linalg.eigvals(H)
        scale = max(1.0, np.abs(lam).max())
        im = np.sort(np.abs(lam[np.abs(lam.real) < 1e-8 * scale].imag))
        im = np.unique(np.round(im, 12))
        if im.size == 0:
            return lb, wpk
        if im.size == 1:
            mids = im
        else:
            mids = 0.5 * (im[:-1] + im[1:])
        new = max((_sigma_max(A, B, C, D, w), w) for w in np.concatenate([mids, im]))
        if new[0] <= lb * (1 + rtol):
            return lb, wpk
        lb, wpk = new
    return lb, wpk


#: relative accuracy asked of SLICOT's ab13dd (python-control's ``linfnorm`` default)
SLICOT_TOL = 1e-10


def _slicot_norm(A, B, C, D):
    """(norm, peak frequency) of a stable system by SLICOT's ab13dd (compiled Bruinsma-Steinbuch
    on a Hessenberg form, structured Hamiltonian eigenvalues), or None when slycot is missing
    or the routine reports a failure."""
    try:
        from slycot import ab13dd
    except ImportError:
        return None
    n, m, p = A.shape[0], B.shape[1], C.shape[0]
    try:
        g, f = ab13dd("C", "I", "S", "D", n, m, p, A, np.eye(n), B, C, D, SLICOT_TOL)
    except Exception:  # slycot's SlycotError family and argument errors: use the own norm
        return None
    return float(g), float(f)


def _certificate_norm(A, B, C, D):
    """H∞ norm of a stable closed loop for its certificate.

    SLICOT's ab13dd when available: measured 4-7x faster than :func:`hinf_norm` on closed
    loops of 20-120 states (``benchmarks/synthesis_floor.py``), whose frequency evaluations
    are full complex solves.  Its value is re-checked by the own code: the gain at its peak
    frequency, evaluated here (:func:`_sigma_max`), must reproduce it (a norm is a maximum over
    frequencies, so this catches a wrong peak that would inflate the norm), and it may not be
    below the gain at 0 and the feedthrough.  An underestimate is what a certificate must never
    accept; the Riccati path's Lyapunov matrix P (``brl_residual``, an inequality checked on
    its own) bounds the norm from above independently.  Any disagreement -- or no slycot --
    falls back to the own Hamiltonian iteration."""
    A, B, C, D = (np.atleast_2d(np.asarray(M, float)) for M in (A, B, C, D))
    if A.shape[0] and B.size and C.size:
        out = _slicot_norm(A, B, C, D)
        if out is not None and np.isfinite(out[0]):
            g, f = out
            at_peak = np.linalg.norm(D, 2) if f == np.inf else _sigma_max(A, B, C, D, f)
            floor = max(_sigma_max(A, B, C, D, 0.0), np.linalg.norm(D, 2) if D.size else 0.0)
            # 1e-6 at the peak: both evaluations' rounding on closed loops with condition
            # numbers up to 1e10 (measured 2e-8 apart at 3e9); 1e-8 below the floor: an
            # underestimate is the unsafe direction, the own iteration decides then
            if abs(at_peak - g) <= 1e-6 * max(g, 1e-300) and floor <= g * (1 + 1e-8):
                return g
    return hinf_norm(A, B, C, D)[0]


def hinf_norm_sweep(A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray,
                    freqs: ArrayLike | None = None) -> tuple[float, float]:
    """Frequency-sweep lower estimate of the H∞ norm (for tests and plots)."""
    if freqs is None:
        freqs = np.concatenate([[0.0], np.logspace(-3, 5, 2000)])
    vals = [_sigma_max(A, B, C, D, w) for w in freqs]
    i = int(np.argmax(vals))
    return float(vals[i]), float(freqs[i])


# --------------------------------------------------------------------------- certificate
@dataclass
class Certificate:
    """Outcome of the independent checks of one synthesis result."""

    stable: bool
    max_real_eig: float
    achieved: float  # closed-loop performance-channel H∞ norm (Hamiltonian)
    gamma: float  # claimed bound
    rtol: float
    region_ok: bool = True
    region_margin: float = -np.inf  # max over eigenvalues of the region function (< 0 inside)
    solver_status: str = ""
    eigenvalues: np.ndarray = field(default_factory=lambda: np.zeros(0))
    failures: list = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not self.failures

    def raise_if_failed(self) -> None:
        if self.failures:
            raise SynthesisError("certificate failed: " + "; ".join(self.failures))


def certify_closed_loop(Acl: np.ndarray, Bcl: np.ndarray, Ccl: np.ndarray, Dcl: np.ndarray,
                        gamma: float, *, region: LMIRegion | None = None, rtol: float = 1e-4,
                        solver_status: str = "", region_tol: float = 1e-6) -> Certificate:
    """Check stability, region membership and ||T_zw||_inf <= gamma (1 + rtol)."""
    ev = np.linalg.eigvals(Acl) if Acl.size else np.zeros(0)
    mre = float(ev.real.max()) if ev.size else -np.inf
    fails = []
    stable = mre < 0
    if not stable:
        fails.append(f"closed loop unstable: max Re(eig) = {mre:.3g}")
    achieved = _certificate_norm(Acl, Bcl, Ccl, Dcl) if stable else np.inf
    if stable and achieved > gamma * (1 + rtol):
        fails.append(f"H∞ norm {achieved:.6g} exceeds gamma {gamma:.6g} by "
                     f"{achieved / gamma - 1:.2e} (relative; tolerance {rtol:.0e})")
    region_ok, margin = True, -np.inf
    if region is not None and ev.size:
        margin = float(region.margin(ev).max())
        scale = max(1.0, float(np.abs(ev).max()))
        region_ok = margin <= region_tol * scale
        if not region_ok:
            fails.append(f"closed-loop eigenvalue outside region {region}: margin {margin:.3g}")
    return Certificate(stable, mre, float(achieved), float(gamma), rtol, region_ok, margin,
                       solver_status, ev, fails)


def brl_residual(Acl: np.ndarray, Bcl: np.ndarray, Ccl: np.ndarray, Dcl: np.ndarray,
                 P: np.ndarray, gamma: float) -> float:
    """Largest eigenvalue of the gamma^2-form bounded-real matrix of the closed loop,
    [[A'P + PA + C'C, PB + C'D], [(PB + C'D)', D'D - gamma^2 I]], relative to its largest entry.

    <= 0 means V = x'Px certifies ||T_zw|| <= gamma (and ||z||^2 <= gamma^2 ||w||^2 + V(x(0)))."""
    P = 0.5 * (P + P.T)
    PB = P @ Bcl + Ccl.T @ Dcl
    M = np.block([[Acl.T @ P + P @ Acl + Ccl.T @ Ccl, PB],
                  [PB.T, Dcl.T @ Dcl - gamma ** 2 * np.eye(Bcl.shape[1])]])
    return float(np.linalg.eigvalsh(0.5 * (M + M.T)).max() / max(np.abs(M).max(), 1e-300))
