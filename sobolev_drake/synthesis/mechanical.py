"""Sobolev (W2 / W∞) and classic nonlinear H∞ gains for Euler–Lagrange systems.

The Riccati sets of Theorems 1, 4 and 12 of the thesis are the algebraic Riccati equations of
LQR problems on chains of integrators, one chain per DOF group (docs/design.md §4.2):

==============  =====================  ==========================  ===========================
DOF group       chain state            weights                     thesis
==============  =====================  ==========================  ===========================
controlled      [ė, e, ∫e], input ë    Y0 ∫e, Y1 e, Y2 ė, Y3 ë     (5.18)–(5.24), (5.75)–(5.82)
regulated       [ė, e], input ë        Σ0 e, Σ1 ė, Σ2 ë            (7.69)–(7.80)
stabilized      [q̇s], input q̈s         Υ0 q̇s, Υ1 q̈s                (5.76)/(5.91), (7.70)
==============  =====================  ==========================  ===========================

Each ``*_gains`` function solves ``AᵀP + PA − P B W⁻¹ Bᵀ P + D = 0`` with
``scipy.linalg.solve_continuous_are`` (W the weight on the highest derivative, D the block
diagonal of the others) and returns a :class:`SobolevGains` whose ``K = W⁻¹BᵀP`` gives the
desired error acceleration ``ë* = −K @ chain_state`` (the bracket of (5.26)/(5.84)).

W2 and W∞ give the *same* gains here: the disturbance enters the error dynamics through the
same matrix as the input (k = g), so the worst-case disturbance (5.54)/(5.109) is zero
(Remarks 30 and 36).  The ``norm`` argument ("W2" or "Winf") is only recorded.  The W∞ gain
γ of the closed loop is the bound of Theorems 3/6: γ² ≥ λmax(M⁻¹ E M⁻¹) (inequality
(5.56)/(5.111)), see :func:`winf_gamma`.

The classic nonlinear H∞ baseline (Chen, Lee & Feng 1994, with integral action; docs/design.md §4.3)
is :func:`hinf_mechanical_gains`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike
from scipy.linalg import solve_continuous_are

from ..validation import one_of, real_array, real_scalar

__all__ = [
    "SobolevGains", "controlled_gains", "regulated_gains", "stabilized_gains", "sobolev_gains",
    "controlled_closed_form", "regulated_closed_form", "stabilized_closed_form",
    "winf_gamma", "HinfMechanicalGains", "hinf_mechanical_gains",
]

_NORMS = ("W2", "Winf")


def _weight(name: str, value: ArrayLike, n: int | None, *, definite: bool) -> np.ndarray:
    """Validate one weight: scalar, vector (diagonal) or symmetric matrix.

    ``definite=True`` demands positive definiteness, otherwise positive semidefiniteness.
    """
    arr = real_array(name, value)
    if arr.ndim == 0:
        arr = arr.reshape(1, 1) if n is None else arr * np.eye(n)
    elif arr.ndim == 1:
        arr = np.diag(arr)
    if arr.ndim != 2 or arr.shape[0] != arr.shape[1]:
        raise ValueError(f"{name} must be a scalar, a vector of diagonal entries or a square "
                         f"matrix, got shape {np.shape(value)}")
    if arr.size == 0:
        raise ValueError(f"{name} must not be empty (one weight per DOF), got shape {np.shape(value)}")
    if n is not None and arr.shape[0] != n:
        raise ValueError(f"{name} must be {n}x{n} (same size as the other weights), "
                         f"got {arr.shape[0]}x{arr.shape[1]}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite")
    scale = max(1.0, float(np.max(np.abs(arr))))
    if np.max(np.abs(arr - arr.T)) > 1e-10 * scale:
        raise ValueError(f"{name} must be symmetric")
    arr = 0.5 * (arr + arr.T)
    lam = np.linalg.eigvalsh(arr)
    if definite and lam[0] <= 1e-14 * scale:
        raise ValueError(f"{name} must be positive definite (smallest eigenvalue {lam[0]:.3g})")
    if not definite and lam[0] < -1e-12 * scale:
        raise ValueError(f"{name} must be positive semidefinite (smallest eigenvalue {lam[0]:.3g})")
    return arr


def _size(weights) -> int:
    for w in weights:
        shape = np.shape(w)   # only the size here; _weight checks the values
        if len(shape) >= 1:
            return shape[0]
    return 1


@dataclass
class SobolevGains:
    """Solution of one integrator-chain Riccati equation.

    Attributes
    ----------
    group : "controlled", "regulated" or "stabilized".
    n : number of DOF in the group.
    P : CARE solution (chain state ordered [ė, e, ∫e] / [ė, e] / [q̇s]); V = ½ xᵀ P x is the
        block of (5.18) / (5.75) / (7.69) belonging to this group.
    K : acceleration gain, desired error acceleration = −K @ chain_state (K = W⁻¹ Bᵀ P).
    blocks : the thesis' named blocks (controlled: Q K T R S P of (5.18); regulated: A B C of
        (7.69); stabilized: U of (5.75)).  Off-diagonal blocks need not be symmetric when the
        weights are full matrices.
    weights : the validated weights by thesis name.
    A, B : chain matrices; closed_loop = A − B K ((5.27) / (5.86) restricted to the group).
    norm : "W2" or "Winf" (identical gains, Remarks 30/36).
    """

    group: str
    n: int
    P: np.ndarray
    K: np.ndarray
    blocks: dict
    weights: dict
    A: np.ndarray
    B: np.ndarray
    norm: str = "W2"

    @property
    def closed_loop(self) -> np.ndarray:
        return self.A - self.B @ self.K

    @property
    def top_weight(self) -> np.ndarray:
        """Weight on the highest derivative (Y3, Σ2 or Υ1): the E block of (5.70)."""
        return self.weights[{"controlled": "Y3", "regulated": "S2", "stabilized": "U1"}[self.group]]

    def value(self, x: ArrayLike) -> float:
        """V = ½ xᵀ P x for a chain state x."""
        x = np.asarray(x, dtype=float)
        return 0.5 * float(x @ self.P @ x)

    def stage_cost(self, x: ArrayLike, acc: ArrayLike) -> float:
        """½(xᵀ D x + ëᵀ W ë): the integrand of the W^{m,2} norm (½ of (5.10))."""
        x = np.asarray(x, dtype=float)
        acc = np.asarray(acc, dtype=float)
        return 0.5 * float(x @ self._D() @ x + acc @ self.top_weight @ acc)

    def _D(self) -> np.ndarray:
        w = self.weights
        if self.group == "controlled":
            return _blkdiag(w["Y2"], w["Y1"], w["Y0"])
        if self.group == "regulated":
            return _blkdiag(w["S1"], w["S0"])
        return w["U0"]

    def riccati_residual(self) -> np.ndarray:
        """AᵀP + PA − P B W⁻¹ Bᵀ P + D (zero up to round-off)."""
        P, A, B = self.P, self.A, self.B
        return A.T @ P + P @ A - P @ B @ np.linalg.solve(self.top_weight, B.T @ P) + self._D()


def _blkdiag(*mats) -> np.ndarray:
    n = sum(m.shape[0] for m in mats)
    out = np.zeros((n, n))
    i = 0
    for m in mats:
        k = m.shape[0]
        out[i:i + k, i:i + k] = m
        i += k
    return out


def _chain(n: int, order: int):
    """Integrator chain with state [x^(order−1), ..., x] (highest derivative first), input x^(order)."""
    A = np.zeros((order * n, order * n))
    for i in range(1, order):
        A[i * n:(i + 1) * n, (i - 1) * n:i * n] = np.eye(n)
    B = np.zeros((order * n, n))
    B[:n] = np.eye(n)
    return A, B


def _solve(A, B, D, W, group):
    try:
        P = solve_continuous_are(A, B, D, W)
    except (np.linalg.LinAlgError, ValueError) as exc:  # pragma: no cover - weights validated
        raise ValueError(f"{group} Riccati equation has no stabilizing solution: {exc}") from exc
    P = 0.5 * (P + P.T)
    lam = np.linalg.eigvalsh(P)
    if lam[0] <= 0:
        # Q − K R⁻¹ K > 0 and the Schur condition of Theorems 1/4/12 are exactly P > 0.
        raise ValueError(f"{group} Riccati solution is not positive definite "
                         f"(smallest eigenvalue {lam[0]:.3g}); check the weights")
    K = np.linalg.solve(W, B.T @ P)
    return P, K


def _norm(norm: str) -> str:
    return one_of("norm", norm, _NORMS)


def controlled_gains(Y0: ArrayLike, Y1: ArrayLike, Y2: ArrayLike, Y3: ArrayLike, *,
                     norm: str = "W2") -> SobolevGains:
    """Controlled-DOF gains (W^{3,2} on z = ∫q̃c; Theorem 1 (5.18)–(5.24), Theorem 4 (5.77)–(5.82)).

    Y0 and Y3 must be positive definite; Y1, Y2 positive semidefinite suffice for the CARE (the
    thesis asks all four positive definite).  Weights may be scalars (times I), vectors
    (diagonals) or full symmetric matrices of equal size.

    Parameters
    ----------
    Y0 : float, array_like (n,) or (n, n)
        Weight of ∫e.
    Y1 : float, array_like (n,) or (n, n)
        Weight of e.
    Y2 : float, array_like (n,) or (n, n)
        Weight of ė.
    Y3 : float, array_like (n,) or (n, n)
        Weight of ë.
    norm : {"W2", "Winf"}, default "W2"
        Recorded only: W2 and W∞ coincide (Remark 30).

    Returns
    -------
    SobolevGains
        ``group="controlled"``; blocks Q, K, T, R, S, P with the chain CARE solution
        ``[[Q, K, T], [Kᵀ, R, S], [Tᵀ, Sᵀ, P]]`` on [ė, e, ∫e]; the block equations are
        (5.32)–(5.37) with 2K read as K + Kᵀ, 2S as S + Sᵀ.  The gain ``K = Y3⁻¹[Q K T]``
        (5.26).

    Examples
    --------
    One DOF: the gains [K_d, K_p, K_i] of ë = −K_d ė − K_p e − K_i ∫e (a PID law):

    >>> import numpy as np
    >>> import sobolev_drake as sd
    >>> gains = sd.controlled_gains(1.0, 2.0, 1.0, 1.0)
    >>> np.round(gains.K, 3)
    array([[2.51 , 2.649, 1.   ]])
    >>> bool(np.all(np.linalg.eigvals(gains.closed_loop).real < 0))
    True
    """
    n = _size((Y0, Y1, Y2, Y3))
    Y0 = _weight("Y0", Y0, n, definite=True)
    Y1 = _weight("Y1", Y1, n, definite=False)
    Y2 = _weight("Y2", Y2, n, definite=False)
    Y3 = _weight("Y3", Y3, n, definite=True)
    A, B = _chain(n, 3)
    P, K = _solve(A, B, _blkdiag(Y2, Y1, Y0), Y3, "controlled")
    s = slice(0, n), slice(n, 2 * n), slice(2 * n, 3 * n)
    blocks = {"Q": P[s[0], s[0]], "K": P[s[0], s[1]], "T": P[s[0], s[2]],
              "R": P[s[1], s[1]], "S": P[s[1], s[2]], "P": P[s[2], s[2]]}
    return SobolevGains("controlled", n, P, K, {k: v.copy() for k, v in blocks.items()},
                        {"Y0": Y0, "Y1": Y1, "Y2": Y2, "Y3": Y3}, A, B, _norm(norm))


def regulated_gains(S0: ArrayLike, S1: ArrayLike, S2: ArrayLike, *, norm: str = "W2") -> SobolevGains:
    """Regulated-DOF gains (W^{2,2} on z = q̃r; Theorem 12 (7.69)–(7.80)).

    Σ0 and Σ2 positive definite, Σ1 semidefinite (scalars, diagonals or symmetric matrices of
    equal size).

    Parameters
    ----------
    S0 : float, array_like (n,) or (n, n)
        Σ0, weight of e.
    S1 : float, array_like (n,) or (n, n)
        Σ1, weight of ė.
    S2 : float, array_like (n,) or (n, n)
        Σ2, weight of ë.
    norm : {"W2", "Winf"}, default "W2"
        Recorded only (identical gains).

    Returns
    -------
    SobolevGains
        ``group="regulated"``; blocks A, B, C with CARE solution ``[[A, B], [Bᵀ, C]]`` on
        [ė, e]: −AΣ2⁻¹A + B + Bᵀ + Σ1 = 0 (7.73), −BᵀΣ2⁻¹B + Σ0 = 0 (7.71), C = AΣ2⁻¹B (the
        thesis' (7.76) prints "C = BΓ2⁻¹A", a typo).  Desired ë = −Σ2⁻¹[A B][ė; e].

    Examples
    --------
    >>> import numpy as np
    >>> import sobolev_drake as sd
    >>> gains = sd.regulated_gains(4.0, 1.0, 1.0)       # ë = −√5 ė − 2 e
    >>> np.round(gains.K, 4)
    array([[2.2361, 2.    ]])
    """
    n = _size((S0, S1, S2))
    S0 = _weight("S0", S0, n, definite=True)
    S1 = _weight("S1", S1, n, definite=False)
    S2 = _weight("S2", S2, n, definite=True)
    A, B = _chain(n, 2)
    P, K = _solve(A, B, _blkdiag(S1, S0), S2, "regulated")
    blocks = {"A": P[:n, :n].copy(), "B": P[:n, n:].copy(), "C": P[n:, n:].copy()}
    return SobolevGains("regulated", n, P, K, blocks, {"S0": S0, "S1": S1, "S2": S2}, A, B,
                        _norm(norm))


def stabilized_gains(U0: ArrayLike, U1: ArrayLike, *, norm: str = "W2") -> SobolevGains:
    """Stabilized-DOF gains (W^{1,2} on z = q̇s; (5.76)/(5.91), (7.70)).

    Parameters
    ----------
    U0 : float, array_like (n,) or (n, n)
        Υ0, weight of q̇s (positive definite).
    U1 : float, array_like (n,) or (n, n)
        Υ1, weight of q̈s (positive definite).
    norm : {"W2", "Winf"}, default "W2"
        Recorded only (identical gains).

    Returns
    -------
    SobolevGains
        ``group="stabilized"``; block U solves −UΥ1⁻¹U + Υ0 = 0; desired
        q̈s = −Υ1⁻¹U q̇s (5.84).

    Examples
    --------
    >>> import numpy as np
    >>> import sobolev_drake as sd
    >>> gains = sd.stabilized_gains([4.0, 9.0], 1.0)    # U = diag(√(υ0 υ1))
    >>> np.diag(gains.K).round(6)
    array([2., 3.])
    """
    n = _size((U0, U1))
    U0 = _weight("U0", U0, n, definite=True)
    U1 = _weight("U1", U1, n, definite=True)
    A, B = _chain(n, 1)
    P, K = _solve(A, B, U0, U1, "stabilized")
    return SobolevGains("stabilized", n, P, K, {"U": P.copy()}, {"U0": U0, "U1": U1}, A, B,
                        _norm(norm))


def sobolev_gains(*weights: ArrayLike, norm: str = "W2") -> SobolevGains:
    """Dispatch on the number of weights: 4 → controlled, 3 → regulated, 2 → stabilized."""
    table = {4: controlled_gains, 3: regulated_gains, 2: stabilized_gains}
    if len(weights) not in table:
        raise ValueError("sobolev_gains takes 4 (Y0..Y3), 3 (Σ0..Σ2) or 2 (Υ0, Υ1) weights, "
                         f"got {len(weights)}")
    return table[len(weights)](*weights, norm=norm)


# --- scalar closed forms (cross-check for diagonal weights) ------------------------------------
def controlled_closed_form(y0: float, y1: float, y2: float, y3: float) -> dict:
    """Scalar solution of (5.19)–(5.24): t = √(y0y3), q²/y3 = 2k + y2, k²/y3 = 2qt/y3 + y1.

    Eliminating k = (q²/y3 − y2)/2 gives the quartic ((q²/y3 − y2)/2)² − 2qt − y1y3 = 0; the
    stabilizing (maximal) solution is its largest positive root.
    """
    for name, v in (("y0", y0), ("y3", y3)):
        if not v > 0:
            raise ValueError(f"{name} must be > 0, got {v}")
    for name, v in (("y1", y1), ("y2", y2)):
        if not v >= 0:
            raise ValueError(f"{name} must be >= 0, got {v}")
    t = np.sqrt(y0 * y3)
    # (q⁴/y3² − 2 y2 q²/y3 + y2²)/4 − 2 t q − y1 y3 = 0
    coeffs = [1 / (4 * y3 ** 2), 0.0, -y2 / (2 * y3), -2 * t, y2 ** 2 / 4 - y1 * y3]
    roots = np.roots(coeffs)
    real = roots[np.abs(roots.imag) < 1e-9 * (1 + np.abs(roots.real))].real
    q = float(np.max(real[real > 0]))
    k = (q * q / y3 - y2) / 2
    return {"T": t, "Q": q, "K": k, "R": q * k / y3 - t, "S": q * t / y3, "P": k * t / y3}


def regulated_closed_form(s0: float, s1: float, s2: float) -> dict:
    """Scalar solution of (7.71), (7.73), (7.76): b = √(σ0σ2), a = √(σ2(2b + σ1)), c = ab/σ2."""
    if not (s0 > 0 and s2 > 0 and s1 >= 0):
        raise ValueError("need s0 > 0, s2 > 0 and s1 >= 0")
    b = np.sqrt(s0 * s2)
    a = np.sqrt(s2 * (2 * b + s1))
    return {"A": a, "B": b, "C": a * b / s2}


def stabilized_closed_form(u0: float, u1: float) -> dict:
    """Scalar solution of (5.76): U = √(υ0υ1)."""
    if not (u0 > 0 and u1 > 0):
        raise ValueError("need u0 > 0 and u1 > 0")
    return {"U": float(np.sqrt(u0 * u1))}


def winf_gamma(M: ArrayLike, E: ArrayLike) -> float:
    """Smallest γ with Π − γ²I ≤ 0, Π = M⁻¹ E M⁻¹ ((5.56)/(5.111)) at one configuration.

    ``M`` is the inertia matrix of the controlled model (M̄ for the reduced model (5.5)) and
    ``E`` the block diagonal of the highest-derivative weights (Y3, or blkdiag(Υ1, Γ3, ...)
    (5.70)) in the same DOF order.  The W∞ bound ‖z‖²_W ≤ γ²‖w‖²_L2 + 2V(x0) of Theorems 3/6
    holds with γ the supremum of this value along the trajectory.
    """
    M = np.atleast_2d(np.asarray(M, dtype=float))
    E = np.atleast_2d(np.asarray(E, dtype=float))
    if M.shape != E.shape or M.shape[0] != M.shape[1]:
        raise ValueError(f"M and E must be square of equal size, got {M.shape} and {E.shape}")
    Mi = np.linalg.inv(M)
    Pi = Mi @ E @ Mi.T
    return float(np.sqrt(max(np.linalg.eigvalsh(0.5 * (Pi + Pi.T))[-1], 0.0)))


# --- classic nonlinear H∞ (Chen, Lee & Feng 1994, integral form) -----------------------------
@dataclass
class HinfMechanicalGains:
    """Classic nonlinear H∞ gains with integral action (docs/design.md §4.3).

    Error x̃ = [q̃̇; q̃; ∫q̃] (stabilized DOF contribute only q̇s to the first block), weights
    Q = diag(ω1²I, ω2²I, ω3²I), R = ωu²I, γ > ωu.  With c = γωu/√(γ² − ωu²) and
    s = √(ω2² + 2ω1ω3): T11 = ω1c, T12 = s c, T13 = ω3c (scalars times I: T11 must commute
    with M(q) for the σ dynamics M σ̇ + C σ = u + T11 w to hold).

    σ = T11 q̃̇ + T12 q̃ + T13 ∫q̃, u = −R⁻¹σ and the applied generalized force is
    M(q̈_r − T11⁻¹(T12 q̃̇ + T13 q̃)) + C(q,q̇)(q̇_r − T11⁻¹(T12 q̃ + T13 ∫q̃)) + g + T11⁻¹u.
    The law does not depend on γ (c cancels); γ only enters the certificate
    ∫(x̃ᵀQx̃ + uᵀRu) ≤ γ²∫|T11 w|² + 2V(x̃0) with V = ½σᵀMσ + ½yᵀK̄y, y = [q̃; ∫q̃],
    K̄ given by :meth:`storage_matrix` (derived by us from the HJI, checked in the tests).
    """

    omega1: float
    omega2: float
    omega3: float
    omega_u: float
    gamma: float
    c: float = field(init=False)
    s: float = field(init=False)

    def __post_init__(self) -> None:
        for name in ("omega1", "omega3", "omega_u", "gamma"):
            setattr(self, name, real_scalar(name, getattr(self, name), low=0.0, low_open=True))
        self.omega2 = real_scalar("omega2", self.omega2, low=0.0)
        if not self.gamma > self.omega_u:
            raise ValueError(f"H∞ design infeasible: need gamma > omega_u (R⁻¹ − γ⁻² I > 0), "
                             f"got gamma = {self.gamma}, omega_u = {self.omega_u}")
        self.c = self.gamma * self.omega_u / np.sqrt(self.gamma ** 2 - self.omega_u ** 2)
        self.s = np.sqrt(self.omega2 ** 2 + 2 * self.omega1 * self.omega3)

    @property
    def T11(self) -> float:
        return self.omega1 * self.c

    @property
    def T12(self) -> float:
        return self.s * self.c

    @property
    def T13(self) -> float:
        return self.omega3 * self.c

    @property
    def R_inv(self) -> float:
        return 1.0 / self.omega_u ** 2

    def storage_matrix(self) -> np.ndarray:
        """K̄ (2×2 scalar pattern, ⊗ I) of V's [q̃; ∫q̃] part.

        From the HJI (cross terms of σ with q̃, ∫q̃ vanish): k11 = ω1²T12/T11,
        k12 = ω1²T13/T11, k22 = ω1² T12 T13 / T11².
        """
        a, b, c3, w1 = self.T11, self.T12, self.T13, self.omega1
        return np.array([[w1 ** 2 * b / a, w1 ** 2 * c3 / a], [w1 ** 2 * c3 / a, w1 ** 2 * b * c3 / a ** 2]])

    def sigma(self, edot: ArrayLike, e: ArrayLike, e_int: ArrayLike) -> np.ndarray | float:
        """σ = T11 q̃̇ + T12 q̃ + T13 ∫q̃ (controlled DOF); stabilized DOF: σ = T11 q̇s."""
        return self.T11 * np.asarray(edot) + self.T12 * np.asarray(e) + self.T13 * np.asarray(e_int)

    def storage(self, M: ArrayLike, sigma: ArrayLike, e: ArrayLike, e_int: ArrayLike) -> float:
        """V(x̃) = ½ σᵀ M σ + ½ [e; ∫e]ᵀ (K̄ ⊗ I) [e; ∫e] (M in the σ ordering)."""
        Kb = self.storage_matrix()
        e = np.asarray(e, dtype=float)
        ei = np.asarray(e_int, dtype=float)
        sigma = np.asarray(sigma, dtype=float)
        return 0.5 * float(sigma @ np.asarray(M) @ sigma + Kb[0, 0] * e @ e
                           + 2 * Kb[0, 1] * e @ ei + Kb[1, 1] * ei @ ei)

    def stage_cost(self, edot: ArrayLike, e: ArrayLike, e_int: ArrayLike, u: ArrayLike) -> float:
        """½(x̃ᵀQx̃ + uᵀRu)."""
        sq = lambda v: float(np.sum(np.asarray(v, dtype=float) ** 2))  # noqa: E731
        return 0.5 * (self.omega1 ** 2 * sq(edot) + self.omega2 ** 2 * sq(e)
                      + self.omega3 ** 2 * sq(e_int) + self.omega_u ** 2 * sq(u))


def hinf_mechanical_gains(omega1: float, omega2: float, omega3: float, omega_u: float,
                          gamma: float) -> HinfMechanicalGains:
    """Classic nonlinear H∞ gains (Chen, Lee & Feng 1994, integral form; docs/design.md §4.3).

    All weights are positive scalars (the classic design weighs all DOF equally); ω2 may be 0.
    Feasibility requires γ > ωu (R⁻¹ − γ⁻²I > 0).

    Parameters
    ----------
    omega1 : float
        ω1, weight (ω1²I in Q) of the velocity error q̃̇.
    omega2 : float
        ω2 ≥ 0, weight of the position error q̃.
    omega3 : float
        ω3, weight of the error integral ∫q̃.
    omega_u : float
        ωu, input weight R = ωu²I.
    gamma : float
        Attenuation level γ > ωu (enters the certificate only; the law does not depend on it).

    Returns
    -------
    HinfMechanicalGains
        With T11 = ω1c, T12 = s c, T13 = ω3c, c = γωu/√(γ² − ωu²), s = √(ω2² + 2ω1ω3).

    Examples
    --------
    >>> import sobolev_drake as sd
    >>> gains = sd.hinf_mechanical_gains(1.0, 1.0, 1.0, omega_u=0.5, gamma=1.0)
    >>> [round(float(T), 4) for T in (gains.T11, gains.T12, gains.T13)]
    [0.5774, 1.0, 0.5774]
    >>> law = sd.HinfLaw(gains)       # the inner law of a MechanicalController
    """
    return HinfMechanicalGains(omega1, omega2, omega3, omega_u, gamma)   # checked there
