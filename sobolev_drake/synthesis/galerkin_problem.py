"""Design model, costs and Galerkin linear systems of the successive Galerkin approximation.

Every cost handled here has the same structure: for a state x and a stacked decision
v = [u; w] (control, then disturbance) the running cost is quadratic in v,

    ℓ(x, v) = q(x) + 2 s(x)ᵀ v + vᵀ S(x) v,

and the dynamics are ẋ = F(x) + G(x) v with F = f, G = [g k].  Hence

* W2 / W∞ in the weighted Sobolev space (4.13) with z = h(x), ż = ∇h ẋ, B = ∇hᵀσ₁∇h:
  ℓ = ½hᵀσ₀h + ½(f + Gv)ᵀB(f + Gv) − ½γ²wᵀw, i.e.
  q = ½hᵀσ₀h + ½fᵀBf, s = ½GᵀBf, S = ½GᵀBG − ½γ² diag(0, I);
* classic H∞ (Beard & McLain 1998): ℓ = hᵀQh + uᵀRu − γ²wᵀw, i.e. q = hᵀQh, s = 0,
  S = diag(R, −γ²I).

For V = cᵀΦ the stationary point of the Hamiltonian ∇Vᵀ(F + Gv) + ℓ is
v* = −S⁻¹(½Gᵀ∇Φᵀc + s): for W2 this is (4.8), for W∞ the pair (4.19)/(4.20), for H∞
u = −½R⁻¹gᵀ∇V, w = γ⁻²/2 kᵀ∇V.  Policies are therefore affine in the coefficients,
v(x) = v₀(x) + L(x) p, and the Galerkin system (4.25)/(4.28) for the next coefficients,
A(p) c = −b(p) with A_kj = ∫Ω φ_k ∇φ_jᵀ(F + Gv) and b_k = ∫Ω φ_k ℓ(x, v), is affine (A) and
quadratic (b) in p.  :class:`AffineGalerkinSystem` precomputes A = A₀ + A₁·p as a tensor once;
b is evaluated from the (cheap) pointwise cost at the quadrature nodes.
"""

from __future__ import annotations

from contextlib import AbstractContextManager, nullcontext
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np
from numpy.typing import ArrayLike
from pydrake.autodiffutils import AutoDiffXd, InitializeAutoDiff

from sobolev_drake.errors import SynthesisError

from sobolev_drake.synthesis.galerkin_basis import (Box, FunctionBasis, PolynomialBasis,
                                                    check_points, object_call)

__all__ = ["InputAffineModel", "W2Cost", "WinfCost", "HinfCost", "NodeData",
           "AffineGalerkinSystem", "solve_quasidefinite", "autodiff_jacobian", "quiet",
           "GalerkinDivergenceError", "GalerkinConvergenceError", "AdmissibilityError",
           "SaddlePointError"]


class GalerkinDivergenceError(SynthesisError):
    """The iteration diverged; ``history`` holds the per-iteration records (no coefficients)."""

    def __init__(self, message: str, history: list[dict] | None = None) -> None:
        super().__init__(message)
        self.history = list(history or [])


class GalerkinConvergenceError(SynthesisError):
    """The iteration did not reach the tolerance within the iteration budget."""

    def __init__(self, message: str, history: list[dict] | None = None) -> None:
        super().__init__(message)
        self.history = list(history or [])


class AdmissibilityError(SynthesisError, ValueError):
    """The initial control does not stabilize the design model on Ω."""


class SaddlePointError(SynthesisError, ValueError):
    """γ (or the weights) violate the saddle-point condition (4.22) somewhere on Ω."""


def bmm(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Batched product (Q, a, b) @ (Q, b, c) -> (Q, a, c) for a small contraction size b.

    numpy's stacked ``matmul`` is slow for tiny matrices; a loop over the (small) contraction
    axis with broadcasting is vectorized over the batch and the other two axes."""
    out = A[:, :, 0, None] * B[:, None, 0, :]
    for i in range(1, A.shape[2]):
        out += A[:, :, i, None] * B[:, None, i, :]
    return out


def bmv(A: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Batched matrix-vector product (Q, a, b) @ (Q, b) -> (Q, a)."""
    out = A[:, :, 0] * x[:, 0, None]
    for i in range(1, A.shape[2]):
        out += A[:, :, i] * x[:, i, None]
    return out


def _call(name, fun, X, shape, role="model function"):
    """``fun(X)`` checked for ``shape``; float, or (object X) of the entries' scalar type."""
    out = (object_call(f"the {role} {name}", fun, X) if X.dtype == object
           else np.asarray(fun(X), dtype=float))
    if out.shape != shape:
        raise ValueError(f"{name}(X) must return shape {shape} for X of shape {X.shape} "
                         f"(vectorized over the first axis), got {out.shape}")
    return out


class InputAffineModel:
    """ẋ = f(x) + g(x)u + k(x)w (4.10) given by vectorized callables.

    ``f(X) -> (Q, n)``, ``g(X) -> (Q, n, nu)``, ``k(X) -> (Q, n, nw)`` for X of shape (Q, n);
    ``k=None`` means no disturbance channel (nw = 0).  Shapes are checked on a probe batch and
    f(0) = 0 (Assumption 3) is enforced.  Functions written with dtype-preserving NumPy code
    also evaluate on object arrays of AutoDiffXd or Expression (:meth:`evaluate`), which the
    scalar-generic Galerkin law needs.
    """

    def __init__(self, f: Callable, g: Callable, k: Callable | None = None, *, n: int,
                 nu: int | None = None, nw: int | None = None) -> None:
        self.f, self.g, self.k, self.n = f, g, k, int(n)
        probe = np.zeros((2, self.n))
        probe[1] = 0.1
        F = np.asarray(f(probe), dtype=float)
        if F.shape != (2, self.n):
            raise ValueError(f"f(X) must return shape (Q, {self.n}), got {F.shape} for Q = 2")
        Gp = np.asarray(g(probe), dtype=float)
        if Gp.ndim != 3 or Gp.shape[:2] != (2, self.n):
            raise ValueError(f"g(X) must return shape (Q, {self.n}, nu), got {Gp.shape} for Q = 2")
        self.nu = Gp.shape[2] if nu is None else int(nu)
        if Gp.shape[2] != self.nu:
            raise ValueError(f"g(X) has {Gp.shape[2]} columns but nu = {self.nu}")
        if k is None:
            self.nw = 0
        else:
            Kp = np.asarray(k(probe), dtype=float)
            if Kp.ndim != 3 or Kp.shape[:2] != (2, self.n):
                raise ValueError(f"k(X) must return shape (Q, {self.n}, nw), got {Kp.shape}")
            self.nw = Kp.shape[2]
            if nw is not None and int(nw) != self.nw:
                raise ValueError(f"k(X) has {self.nw} columns but nw = {nw}")
        if np.max(np.abs(F[0])) > 1e-9:
            raise ValueError(f"f(0) must be 0 (origin an equilibrium, Assumption 3), got {F[0]}")

    @property
    def m(self) -> int:
        return self.nu + self.nw

    def evaluate(self, X: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """F (Q, n) and G = [g k] (Q, n, nu + nw) at the points X (float, or an object array of
        AutoDiffXd / Expression: then the functions' own outputs, a ``TypeError`` naming a
        function that fails on them)."""
        X = check_points("X", X, self.n, keep_object=True)
        Q = X.shape[0]
        F = _call("f", self.f, X, (Q, self.n))
        G = _call("g", self.g, X, (Q, self.n, self.nu))
        if self.nw:
            G = np.concatenate([G, _call("k", self.k, X, (Q, self.n, self.nw))], axis=2)
        return F, G


def _spd(name, M, size):
    M = np.atleast_2d(np.asarray(M, dtype=float))
    if M.shape != (size, size):
        raise ValueError(f"{name} must be a {size}x{size} matrix, got shape {M.shape}")
    if not np.allclose(M, M.T, atol=1e-12 * max(1.0, np.abs(M).max())):
        raise ValueError(f"{name} must be symmetric")
    if np.linalg.eigvalsh(M).min() <= 0:
        raise ValueError(f"{name} must be positive definite, eigenvalues "
                         f"{np.linalg.eigvalsh(M).tolist()}")
    return M


@dataclass
class W2Cost:
    """J = ½‖z‖²σ₀ + ½‖ż‖²σ₁ with z = h(x) (4.2); ``dh(X) -> (Q, nz, n)`` is ∇h."""

    h: Callable
    dh: Callable
    sigma0: np.ndarray
    sigma1: np.ndarray
    kind = "w2"

    def __post_init__(self) -> None:
        nz = np.atleast_2d(np.asarray(self.sigma0, dtype=float)).shape[0]
        self.sigma0 = _spd("sigma0", self.sigma0, nz)
        self.sigma1 = _spd("sigma1", self.sigma1, nz)

    def gamma_value(self) -> float | None:
        return None

    def coefficients(self, X: np.ndarray, F: np.ndarray, G: np.ndarray, nu: int
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        nz = np.asarray(self.sigma0).shape[0]
        return _sobolev_coefficients(self, X, F, G, nu, nz, gamma=None)

    def decision_terms(self, X: np.ndarray, F: np.ndarray, G: np.ndarray, nu: int
                       ) -> tuple[np.ndarray, np.ndarray]:
        """(s, S) of ℓ = q + 2sᵀv + vᵀSv without q (no h needed; any scalar type)."""
        nz = np.asarray(self.sigma0).shape[0]
        return _sobolev_terms(self, X, F, G, nu, nz, gamma=None)[1:]


@dataclass
class WinfCost:
    """J = ½‖z‖²σ₀ + ½‖ż‖²σ₁ − ½γ²‖w‖² (4.12)/(4.13)."""

    h: Callable
    dh: Callable
    sigma0: np.ndarray
    sigma1: np.ndarray
    gamma: float
    kind = "winf"

    def __post_init__(self) -> None:
        W2Cost.__post_init__(self)

    def gamma_value(self) -> float | None:
        return float(self.gamma)

    def coefficients(self, X: np.ndarray, F: np.ndarray, G: np.ndarray, nu: int
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        nz = np.asarray(self.sigma0).shape[0]
        return _sobolev_coefficients(self, X, F, G, nu, nz, gamma=float(self.gamma))

    def decision_terms(self, X: np.ndarray, F: np.ndarray, G: np.ndarray, nu: int
                       ) -> tuple[np.ndarray, np.ndarray]:
        """(s, S) of ℓ = q + 2sᵀv + vᵀSv without q (no h needed; any scalar type)."""
        nz = np.asarray(self.sigma0).shape[0]
        return _sobolev_terms(self, X, F, G, nu, nz, gamma=float(self.gamma))[1:]


@dataclass
class HinfCost:
    """Classic H∞ (Beard & McLain 1998): ∫ hᵀQh + uᵀRu − γ²wᵀw dt (no ½)."""

    h: Callable
    Q: np.ndarray
    R: np.ndarray
    gamma: float
    kind = "hinf"

    def __post_init__(self) -> None:
        nz = np.atleast_2d(np.asarray(self.Q, dtype=float)).shape[0]
        self.Q = _spd("Q", self.Q, nz)
        self.R = np.atleast_2d(np.asarray(self.R, dtype=float))
        self.R = _spd("R", self.R, self.R.shape[0])

    def gamma_value(self) -> float | None:
        return float(self.gamma)

    def coefficients(self, X: np.ndarray, F: np.ndarray, G: np.ndarray, nu: int
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        h = _call("h", self.h, X, (X.shape[0], self.Q.shape[0]), role="cost function")
        q = np.einsum("qi,ij,qj->q", h, self.Q, h)
        return (q, *self.decision_terms(X, F, G, nu))

    def decision_terms(self, X: np.ndarray, F: np.ndarray, G: np.ndarray, nu: int
                       ) -> tuple[np.ndarray, np.ndarray]:
        """(s, S) = (0, diag(R, −γ²I)) (constants)."""
        Qn, m, R = X.shape[0], G.shape[2], self.R
        if R.shape != (nu, nu):
            raise ValueError(f"R must be a {nu}x{nu} matrix (nu = {nu}), got shape {R.shape}")
        s = np.zeros((Qn, m))
        S = np.zeros((Qn, m, m))
        S[:, :nu, :nu] = R
        if m > nu:
            S[:, nu:, nu:] = -float(self.gamma) ** 2 * np.eye(m - nu)
        return s, S


def _sobolev_coefficients(cost, X, F, G, nu, nz, gamma):
    h = _call("h", cost.h, X, (X.shape[0], nz), role="cost function")
    BF, s, S = _sobolev_terms(cost, X, F, G, nu, nz, gamma)
    q = 0.5 * np.sum((h @ cost.sigma0) * h, axis=1) + 0.5 * np.sum(F * BF, axis=1)
    return q, s, S


def _sobolev_terms(cost, X, F, G, nu, nz, gamma):
    """B F, s = ½GᵀBF and S = ½GᵀBG − ½γ² diag(0, I) with B = ∇hᵀσ₁∇h (any scalar type)."""
    Qn, n = X.shape
    m = G.shape[2]
    Dh = _call("dh", cost.dh, X, (Qn, nz, n), role="cost function")
    s1Dh = np.tensordot(Dh, cost.sigma1, axes=(1, 0))  # (Q, n, nz) = ∇hᵀσ₁
    B = bmm(s1Dh, Dh)  # ∇hᵀσ₁∇h
    BF = bmv(B, F)
    Gt = G.transpose(0, 2, 1)
    s = 0.5 * bmv(Gt, BF)
    S = 0.5 * bmm(Gt, bmm(B, G))
    if m > nu:
        if gamma is None:
            raise ValueError("a disturbance channel needs gamma")
        S[:, nu:, nu:] -= 0.5 * gamma ** 2 * np.eye(m - nu)
    return BF, s, S


def quiet(X: ArrayLike) -> AbstractContextManager[Any]:
    """A context without floating-point warnings for an object array X (else a no-op).

    NumPy reads the processor's status flags after an object loop, so a flag left by earlier
    native code (Drake) surfaces as a spurious "invalid value" warning (as in
    ``ControlOutput``).

    Parameters
    ----------
    X : array_like
        The points about to be evaluated.

    Returns
    -------
    context manager
    """
    return np.errstate(all="ignore") if np.asarray(X).dtype == object else nullcontext()


def autodiff_jacobian(fun: Callable, x: ArrayLike) -> np.ndarray:
    """∂fun/∂x at the point x by one AutoDiffXd evaluation (exact to rounding).

    Parameters
    ----------
    fun : callable
        Vectorized ``fun(X) -> (Q, p)`` that evaluates on object arrays of AutoDiffXd.
    x : array_like, shape (n,)
        The point.

    Returns
    -------
    ndarray, shape (p, n)
    """
    x = np.asarray(x, dtype=float)
    u = np.asarray(fun(InitializeAutoDiff(x).ravel()[None, :]))[0]
    J = np.zeros((u.shape[0], x.shape[0]))
    for i, ui in enumerate(u):  # an entry with no (or empty) derivatives is a constant
        if isinstance(ui, AutoDiffXd) and ui.derivatives().size:
            J[i] = ui.derivatives()
    if not np.all(np.isfinite(J)):
        raise FloatingPointError(f"non-finite AutoDiffXd Jacobian at x = {x.tolist()}: {J}")
    return J


def solve_quasidefinite(S: np.ndarray, r: np.ndarray) -> np.ndarray:
    """x = S⁻¹r for a batch S (Q, m, m), r (Q, m) of any scalar type (object arrays of
    AutoDiffXd or Expression), by Gaussian elimination in the natural order (no pivoting).

    No pivoting is needed (nor possible for symbolic entries): S = ½∂²ℓ/∂v² is symmetric
    quasi-definite, [[Suu, Suw], [Swu, Sww]] with Suu ≻ 0 (Assumption 4, checked at the
    nodes) and Sww ≺ 0 (the saddle condition (4.22)); every leading principal submatrix of such
    a matrix is nonsingular, so the natural-order pivots are nonzero (Vanderbei 1995, strong
    factorizability), and the elimination is stable when the blocks are well conditioned
    (Gill, Saunders & Shinnerl 1996).  m ≤ 3 here: explicit loops over the small dimension.

    Parameters
    ----------
    S : ndarray, shape (Q, m, m)
        Symmetric quasi-definite matrices (float or object).
    r : ndarray, shape (Q, m)
        Right-hand sides.

    Returns
    -------
    ndarray of object, shape (Q, m)
    """
    A = np.array(S, dtype=object)
    b = np.array(r, dtype=object)
    m = A.shape[1]
    for k in range(m):
        for i in range(k + 1, m):
            lik = A[:, i, k] / A[:, k, k]
            A[:, i, k + 1:] = A[:, i, k + 1:] - lik[:, None] * A[:, k, k + 1:]
            b[:, i] = b[:, i] - lik * b[:, k]
    x = np.empty_like(b)
    for k in reversed(range(m)):
        acc = b[:, k]
        for j in range(k + 1, m):
            acc = acc - A[:, k, j] * x[:, j]
        x[:, k] = acc / A[:, k, k]
    return x


class NodeData:
    """Everything evaluated once at a set of points: Φ, ∇Φ, F, G and the cost coefficients."""

    def __init__(self, model: InputAffineModel, cost: W2Cost | WinfCost | HinfCost,
                 basis: PolynomialBasis | FunctionBasis, X: np.ndarray,
                 weights: np.ndarray | None = None) -> None:
        self.X = X
        self.w = weights
        self.nu, self.nw = model.nu, model.nw
        self.Phi = basis.evaluate(X)
        self.dPhi = basis.gradient(X)
        self.F, self.G = model.evaluate(X)
        self.q, self.s, self.S = cost.coefficients(X, self.F, self.G, model.nu)
        # Gᵀ∇Φᵀ: (Q, m, N)
        self.GtdPhi = bmm(self.G.transpose(0, 2, 1), self.dPhi.transpose(0, 2, 1))
        nu = self.nu
        Suu = self.S[:, :nu, :nu]
        eig_uu = np.linalg.eigvalsh(Suu)
        if eig_uu.min() <= 1e-12 * max(1.0, np.abs(eig_uu).max()):
            raise SaddlePointError(
                "the control weight (gᵀBg for W2/W∞, R for H∞) is not positive definite at "
                f"some points of Ω (min eigenvalue {eig_uu.min():.3e}); Assumption 4 "
                "(∇h and g of full column rank) fails there")
        self.Sinv = np.linalg.inv(self.S)
        self.v0_saddle = -bmv(self.Sinv, self.s)
        self.L_saddle = -0.5 * bmm(self.Sinv, self.GtdPhi)  # (Q, m, N)
        if self.nw:
            self.Sww_inv = np.linalg.inv(self.S[:, nu:, nu:])

    # policies ------------------------------------------------------------------------------
    def saddle(self, c: np.ndarray) -> np.ndarray:
        """v*(c) = −S⁻¹(½Gᵀ∇Φᵀc + s) at the nodes, shape (Q, m)."""
        Qn, m, N = self.L_saddle.shape
        return self.v0_saddle + (self.L_saddle.reshape(Qn * m, N) @ c).reshape(Qn, m)

    def best_response_w(self, c: np.ndarray, u: np.ndarray) -> np.ndarray:
        """argmax_w of the Hamiltonian for V = cᵀΦ and the given control u (Q, nu)."""
        nu = self.nu
        Qn, m, N = self.GtdPhi.shape
        kdV = (self.GtdPhi[:, nu:, :].reshape(-1, N) @ c).reshape(Qn, m - nu)
        rhs = 0.5 * kdV + self.s[:, nu:] + bmv(self.S[:, nu:, :nu], u)
        return -bmv(self.Sww_inv, rhs)

    def running_cost(self, v: np.ndarray) -> np.ndarray:
        Sv = bmv(self.S, v)
        return self.q + np.sum((2.0 * self.s + Sv) * v, axis=1)

    def hamiltonian(self, c: np.ndarray, v: np.ndarray) -> np.ndarray:
        """∇Vᵀ(F + Gv) + ℓ(x, v) for V = cᵀΦ (the GHJ residual of the policy v)."""
        drift = self.F + bmv(self.G, v)
        return bmv(self.dPhi, drift) @ c + self.running_cost(v)

    # Galerkin system for an arbitrary policy evaluated at the nodes -----------------------
    def system(self, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(A, b) of (4.25)/(4.28) for the decision v (Q, m) at the nodes."""
        drift = self.F + bmv(self.G, v)
        D = bmv(self.dPhi, drift)
        Wphi = self.Phi * self.w[:, None]
        return Wphi.T @ D, Wphi.T @ self.running_cost(v)


class AffineGalerkinSystem:
    """Galerkin system (A(p), b(p)) for the affine policy v = v₀ + L p, p = [p_slow; p_fast].

    The first ``slow`` entries of p (the outer control coefficients of the W∞/H∞ loop) change
    once per outer iteration: their contribution to v and A is assembled from the nodes and
    cached.  For the remaining ``fast`` entries (the disturbance loop, or the W2 control) the
    tensor method precomputes A₁ (N, N, P_fast) once, A = A_slow + A₁·p_fast; b(p) is evaluated
    at the nodes (it is quadratic in p).  ``method="direct"`` assembles A from the nodes at
    every call instead of using the tensor.
    """

    def __init__(self, nodes: NodeData, v0: np.ndarray, L: np.ndarray, *, method: str = "tensor",
                 slow: int = 0, chunk_entries: int = 4_000_000) -> None:
        if method not in ("tensor", "direct"):
            raise ValueError(f"method must be 'tensor' or 'direct', got {method!r}")
        self.nodes, self.v0, self.method, self.slow = nodes, v0, method, int(slow)
        self.L_slow, self.L_fast = L[:, :, :self.slow], L[:, :, self.slow:]
        Phi, dPhi, G, w = nodes.Phi, nodes.dPhi, nodes.G, nodes.w
        Qn, N = Phi.shape
        P = self.L_fast.shape[2]
        self.Wphi = Phi * w[:, None]
        self._cache_key, self._v_slow, self._A_slow = None, None, None
        if method == "direct":
            return
        A1 = np.zeros((N, N * P))
        step = max(1, chunk_entries // max(1, N * P))
        for a in range(0, Qn, step):
            sl = slice(a, min(Qn, a + step))
            D1 = bmm(dPhi[sl], bmm(G[sl], self.L_fast[sl])).reshape(-1, N * P)
            A1 += self.Wphi[sl].T @ D1
        self.A1 = A1.reshape(N, N, P)

    @staticmethod
    def _apply(L, p):
        Qn, m, P = L.shape
        return (L.reshape(Qn * m, P) @ p).reshape(Qn, m)

    def _slow_part(self, p_slow):
        key = p_slow.tobytes()
        if key != self._cache_key:
            v = self.v0 + self._apply(self.L_slow, p_slow) if self.slow else self.v0
            nodes = self.nodes
            self._A_slow = None if self.method == "direct" else \
                self.Wphi.T @ bmv(nodes.dPhi, nodes.F + bmv(nodes.G, v))
            self._cache_key, self._v_slow = key, v
        return self._v_slow, self._A_slow

    def policy(self, p: np.ndarray) -> np.ndarray:
        v_slow, _ = self._slow_part(np.asarray(p[:self.slow], dtype=float))
        return v_slow + self._apply(self.L_fast, p[self.slow:])

    def solve(self, p: np.ndarray) -> np.ndarray:
        p = np.asarray(p, dtype=float)
        v_slow, A_slow = self._slow_part(p[:self.slow])
        v = v_slow + self._apply(self.L_fast, p[self.slow:])
        if self.method == "tensor":
            A = A_slow + self.A1 @ p[self.slow:]
            b = self.Wphi.T @ self.nodes.running_cost(v)
        else:
            A, b = self.nodes.system(v)
        return solve_galerkin(A, b)


def solve_galerkin(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """c with A c = −b, refusing singular or non-finite systems."""
    if not (np.all(np.isfinite(A)) and np.all(np.isfinite(b))):
        raise GalerkinDivergenceError("non-finite Galerkin system (the policy blew up)")
    cond = np.linalg.cond(A)
    if not np.isfinite(cond) or cond > 1e14:
        raise GalerkinDivergenceError(
            f"singular Galerkin matrix (condition number {cond:.2e}): the current policy is not "
            "admissible on Ω for this basis, or the basis is degenerate")
    return np.linalg.solve(A, -b)


def box_test_points(box: Box, count: int, seed: int = 12345) -> np.ndarray:
    """Seeded uniform test points in Ω, used for residual and positivity diagnostics."""
    return box.sample(count, seed=seed)
