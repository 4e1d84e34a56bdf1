"""Basis functions, boxes and quadrature rules for the successive Galerkin approximation.

The Galerkin projections (4.24)–(4.29) of the thesis are integrals over a box
Ω = [l₁, u₁] × … × [lₙ, uₙ].  This module supplies

* :class:`Box` — the domain, validated (finite, strictly positive widths);
* :func:`gauss_legendre` — the tensor Gauss–Legendre rule (exact for polynomials of degree
  ≤ 2p − 1 per coordinate with p nodes per axis), the default;
* :func:`midpoint` — the composite midpoint rule on cells of width ≈ Δ used by the thesis
  ((4.32), Δ = 0.1).  We apply it on the full tensor grid; the thesis' separable approximation
  (4.33) of the integrand is not reproduced;
* :class:`PolynomialBasis` — complete monomials of total degree 1..d (no constant term, so
  V(0) = 0), e.g. (4.31) for d = 4 in three variables (34 terms);
* :class:`FunctionBasis` — a user basis given by vectorized callables for Φ and ∇Φ.

Every basis evaluates on a batch of points ``X`` of shape ``(Q, n)`` and returns ``Φ`` of shape
``(Q, N)`` and ``∇Φ`` of shape ``(Q, N, n)``, without Python loops over the basis terms.
The same code evaluates them on object arrays of AutoDiffXd or symbolic Expression (the
scalar-generic Galerkin law; a :class:`FunctionBasis` only if its callables accept those,
else a ``TypeError`` naming them, :func:`object_call`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from itertools import combinations_with_replacement
from typing import Callable, Sequence

import numpy as np
from numpy.typing import ArrayLike

from sobolev_drake.errors import ModelError

from ..validation import real_scalar

__all__ = ["Box", "QuadratureRule", "gauss_legendre", "midpoint", "PolynomialBasis",
           "FunctionBasis", "check_points", "object_call", "ObjectEvaluationError"]


def check_points(name: str, X: ArrayLike, n: int, *, keep_object: bool = False) -> np.ndarray:
    """Return ``X`` as a float array of shape (Q, n) or raise a ``ValueError`` naming it.

    Parameters
    ----------
    name : str
        Name of the argument, for the error message.
    X : array_like
        A point (n,) or points (Q, n).
    n : int
        State dimension.
    keep_object : bool, default False
        Keep an object array (AutoDiffXd or symbolic Expression entries) as it is instead of
        casting it to float (the scalar-generic evaluation of the Galerkin law).

    Returns
    -------
    ndarray, shape (Q, n)
    """
    X = np.asarray(X)
    X = X if keep_object and X.dtype == object else np.asarray(X, dtype=float)
    if X.ndim == 1 and X.shape[0] == n:
        X = X[None, :]
    if X.ndim != 2 or X.shape[1] != n:
        raise ValueError(f"{name} must be an array of points of shape (Q, {n}), got {X.shape}")
    return X


class Box:
    """Axis-aligned box Ω = Π [lower_i, upper_i] (the Galerkin domain)."""

    def __init__(self, lower: ArrayLike, upper: ArrayLike) -> None:
        lo = np.atleast_1d(np.asarray(lower, dtype=float))
        hi = np.atleast_1d(np.asarray(upper, dtype=float))
        if lo.ndim != 1 or hi.shape != lo.shape:
            raise ValueError(f"box lower/upper must be vectors of equal length, got shapes "
                             f"{lo.shape} and {hi.shape}")
        if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
            raise ValueError("box bounds must be finite")
        width = hi - lo
        if np.any(width <= 0):
            bad = np.flatnonzero(width <= 0).tolist()
            raise ValueError(f"box must have strictly positive width in every coordinate; "
                             f"width of coordinate(s) {bad} is {width[bad].tolist()}")
        self.lower, self.upper = lo, hi

    @classmethod
    def symmetric(cls, half_widths: ArrayLike) -> "Box":
        h = np.atleast_1d(np.asarray(half_widths, dtype=float))
        return cls(-h, h)

    @property
    def n(self) -> int:
        return self.lower.shape[0]

    @property
    def volume(self) -> float:
        return float(np.prod(self.upper - self.lower))

    def contains(self, X: ArrayLike) -> np.ndarray:
        X = check_points("X", X, self.n)
        return np.all((X >= self.lower) & (X <= self.upper), axis=1)

    def vertices(self) -> np.ndarray:
        """The 2ⁿ corners, shape (2ⁿ, n)."""
        bits = (np.arange(2 ** self.n)[:, None] >> np.arange(self.n)) & 1
        return np.where(bits == 1, self.upper, self.lower)

    def sample(self, count: int, seed: int = 0) -> np.ndarray:
        """``count`` uniform random points (seeded, reproducible)."""
        rng = np.random.default_rng(seed)
        return self.lower + (self.upper - self.lower) * rng.random((count, self.n))

    def __repr__(self) -> str:
        return f"Box(lower={self.lower.tolist()}, upper={self.upper.tolist()})"


@dataclass
class QuadratureRule:
    """Nodes ``points`` (Q, n) and weights ``weights`` (Q,) with Σ w ≈ vol(Ω)."""

    points: np.ndarray
    weights: np.ndarray
    name: str = ""

    @property
    def size(self) -> int:
        return self.weights.shape[0]

    def integrate(self, values: ArrayLike) -> np.ndarray:
        """∫Ω values dΩ for values sampled at the nodes, shape (Q, ...)."""
        return np.tensordot(self.weights, np.asarray(values), axes=(0, 0))


class ObjectEvaluationError(ModelError, TypeError):
    """A user function (model f, g, k, cost h, ∇h or basis) does not evaluate on object arrays
    of AutoDiffXd / Expression: the Galerkin law is then double only."""


def object_call(what: str, fun: Callable, X: np.ndarray) -> np.ndarray:
    """``fun(X)`` for an object array ``X`` (AutoDiffXd or Expression entries), not cast to float.

    Parameters
    ----------
    what : str
        The function's name in the error message, e.g. ``"model function f"``.
    fun : callable
        A vectorized function of points (Q, n).
    X : ndarray of object
        The points.

    Returns
    -------
    ndarray
        Its value (an object array, or a float array for a constant).

    Raises
    ------
    ObjectEvaluationError
        (a ``TypeError``) naming ``what`` when ``fun`` fails on the object array (e.g. it
        fills ``np.empty`` float arrays, which cannot hold AutoDiffXd or Expression entries).
    """
    scalar = type(X.flat[0]).__name__ if X.size else "object"
    try:
        return np.asarray(fun(X))
    except Exception as err:  # noqa: BLE001  (any failure: the function is float-only)
        raise ObjectEvaluationError(
            f"{what}(X) does not evaluate on an object array of {scalar} "
            f"({type(err).__name__}: {err}); for the scalar-generic Galerkin law (AutoDiffXd "
            "gain, Drake scalar conversion) write it with dtype-preserving NumPy code, e.g. "
            "np.zeros(shape, dtype=X.dtype) instead of np.zeros(shape)") from err


def _tensor_rule(box: Box, nodes_1d, weights_1d, name) -> QuadratureRule:
    grids = np.meshgrid(*nodes_1d, indexing="ij")
    wgrids = np.meshgrid(*weights_1d, indexing="ij")
    points = np.stack([g.ravel() for g in grids], axis=1)
    weights = np.prod(np.stack([w.ravel() for w in wgrids], axis=1), axis=1)
    return QuadratureRule(points, weights, name)


#: most quadrature nodes a tensor rule may have (each node holds the basis and its gradient)
MAX_QUADRATURE_NODES = 10_000_000


def _check_grid_size(per_axis):
    total = float(np.prod(np.asarray(per_axis, dtype=float)))
    if total > MAX_QUADRATURE_NODES:
        raise ValueError(f"the tensor rule would have {total:.3g} nodes ({' x '.join(str(int(v)) for v in per_axis)}), "
                         f"more than {MAX_QUADRATURE_NODES:.0e}: use fewer nodes per axis or wider cells")


def gauss_legendre(box: Box, nodes_per_dim: int | Sequence[int]) -> QuadratureRule:
    """Tensor Gauss–Legendre rule with ``nodes_per_dim`` nodes per axis (int or per-axis list)."""
    if not isinstance(box, Box):
        raise TypeError(f"box must be a Box, got {type(box).__name__}")
    counts = [nodes_per_dim] * box.n if np.ndim(nodes_per_dim) == 0 else list(nodes_per_dim)
    if len(counts) != box.n:
        raise ValueError(f"nodes_per_dim must be one integer or {box.n} (one per axis), got {nodes_per_dim!r}")
    for c in counts:
        if isinstance(c, (bool, np.bool_)) or not isinstance(c, (int, np.integer)) or c < 1:
            raise TypeError(f"nodes_per_dim must be integers >= 1, got {nodes_per_dim!r}")
    p = np.array(counts, dtype=int)
    _check_grid_size(p)
    nodes, weights = [], []
    for i in range(box.n):
        t, w = np.polynomial.legendre.leggauss(int(p[i]))
        half = 0.5 * (box.upper[i] - box.lower[i])
        nodes.append(box.lower[i] + half * (t + 1.0))
        weights.append(half * w)
    return _tensor_rule(box, nodes, weights, f"gauss-legendre {tuple(int(v) for v in p)}")


def midpoint(box: Box, width: float = 0.1) -> QuadratureRule:
    """Composite midpoint rule on cells of width ≈ ``width`` (the thesis' (4.32), Δ = 0.1)."""
    if not isinstance(box, Box):
        raise TypeError(f"box must be a Box, got {type(box).__name__}")
    width = real_scalar("width", width, low=0.0, low_open=True)
    _check_grid_size([max(1, int(round((box.upper[i] - box.lower[i]) / width))) for i in range(box.n)])
    nodes, weights = [], []
    for i in range(box.n):
        L = box.upper[i] - box.lower[i]
        cells = max(1, int(round(L / width)))
        h = L / cells
        nodes.append(box.lower[i] + h * (np.arange(cells) + 0.5))
        weights.append(np.full(cells, h))
    return _tensor_rule(box, nodes, weights, f"midpoint Δ≈{width}")


#: most terms of a complete monomial basis (the Galerkin matrices are terms x terms)
MAX_BASIS_TERMS = 20_000


class PolynomialBasis:
    """Complete monomial basis of total degree ``min_degree..degree`` in ``n`` variables.

    ``min_degree = 1`` (default) excludes the constant so that V(0) = 0 holds by construction;
    with ``degree = 4`` and ``n = 3`` this is the 34-term basis (4.31).  Terms are ordered by
    total degree, then lexicographically by variable index (x₁ before x₂ …).  ``exponents`` is
    an integer array (N, n).

    ``scale`` (optional, per variable) evaluates monomials of ``x / scale``; it improves the
    conditioning of the Galerkin matrices on boxes with very different widths while spanning the
    same function space.
    """

    def __init__(self, n: int, degree: int, *, min_degree: int = 1, scale: ArrayLike | None = None,
                 names: Sequence[str] | None = None) -> None:
        for name, v in (("n", n), ("degree", degree), ("min_degree", min_degree)):
            if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, np.integer)):
                raise TypeError(f"{name} must be an integer, got {v!r}")
        n, degree, min_degree = int(n), int(degree), int(min_degree)
        terms = math.comb(n + degree, degree)
        if terms > MAX_BASIS_TERMS:
            raise ValueError(f"PolynomialBasis({n}, {degree}) would have about {terms:.3g} terms, more "
                             f"than {MAX_BASIS_TERMS}: lower the degree")
        if n < 1:
            raise ValueError(f"n must be >= 1, got {n}")
        if degree < 1 or min_degree < 0 or min_degree > degree:
            raise ValueError(f"need 0 <= min_degree <= degree and degree >= 1, got "
                             f"min_degree={min_degree}, degree={degree}")
        exps = []
        for d in range(min_degree, degree + 1):
            for combo in combinations_with_replacement(range(n), d):
                e = np.zeros(n, dtype=int)
                for i in combo:
                    e[i] += 1
                exps.append(e)
        self.exponents = np.array(exps, dtype=int).reshape(-1, n)
        self.n, self.degree = n, degree
        self.scale = np.ones(n) if scale is None else np.broadcast_to(
            np.asarray(scale, dtype=float), (n,)).copy()
        if np.any(self.scale <= 0):
            raise ValueError(f"scale must be positive, got {self.scale}")
        self.var_names = list(names) if names is not None else [f"x{i + 1}" for i in range(n)]

    def __len__(self) -> int:
        return self.exponents.shape[0]

    def _powers(self, X):
        Xs = X / self.scale
        if X.dtype == object:
            # repeated products, x⁰ = 1.0 exactly: AutoDiffXd's pow(x, 0) has the derivative
            # 0·x⁻¹, NaN at x = 0 (the origin, where the gain is taken)
            P = np.empty(X.shape + (self.degree + 1,), dtype=object)
            P[:, :, 0] = 1.0
            for p in range(1, self.degree + 1):
                P[:, :, p] = Xs if p == 1 else P[:, :, p - 1] * Xs
            return P
        # P[q, i, p] = (x_i/s_i)^p for p = 0..degree
        return Xs[:, :, None] ** np.arange(self.degree + 1)[None, None, :]

    def evaluate(self, X: ArrayLike) -> np.ndarray:
        """Φ(X), shape (Q, N) (X may be an object array of AutoDiffXd or Expression)."""
        X = check_points("X", X, self.n, keep_object=True)
        P = self._powers(X)
        out = np.ones((X.shape[0], len(self)), dtype=X.dtype)
        for i in range(self.n):  # loop over coordinates, vectorized over terms
            out *= P[:, i, self.exponents[:, i]]
        return out

    def gradient(self, X: ArrayLike) -> np.ndarray:
        """∇Φ(X), shape (Q, N, n): entry [q, k, i] = ∂φ_k/∂x_i at X[q] (X may be an object
        array of AutoDiffXd or Expression: the same products, entries of that type)."""
        X = check_points("X", X, self.n, keep_object=True)
        P = self._powers(X)
        E = self.exponents
        Em1 = np.maximum(E - 1, 0)
        factors = [P[:, i, E[:, i]] for i in range(self.n)]  # (Q, N) each
        grad = np.empty((X.shape[0], len(self), self.n), dtype=X.dtype)
        for i in range(self.n):  # loops over coordinates only, vectorized over terms
            d = (E[:, i] / self.scale[i]) * P[:, i, Em1[:, i]]
            for j in range(self.n):
                if j != i:
                    d = d * factors[j]
            grad[:, :, i] = d
        return grad

    def names(self) -> list[str]:
        """Human-readable terms, e.g. ``x1^2*x3``."""
        out = []
        for e in self.exponents:
            parts = [(v if p == 1 else f"{v}^{p}") for v, p in zip(self.var_names, e) if p > 0]
            out.append("*".join(parts) if parts else "1")
        return out

    def __repr__(self) -> str:
        return f"PolynomialBasis(n={self.n}, degree={self.degree}, terms={len(self)})"


class FunctionBasis:
    """User-supplied basis: ``phi(X) -> (Q, N)`` and ``grad(X) -> (Q, N, n)`` (vectorized).

    Shapes are checked on construction, and the gradient against central finite differences
    (relative error tolerance ``fd_tol``; pass ``fd_tol=None`` to skip).
    """

    def __init__(self, n: int, size: int, phi: Callable, grad: Callable, *,
                 names: Sequence[str] | None = None,
                 check_box: Box | None = None, fd_tol: float | None = 1e-5) -> None:
        self.n, self._size = int(n), int(size)
        self._phi, self._grad = phi, grad
        self._names = list(names) if names is not None else [f"phi{k + 1}" for k in range(size)]
        box = check_box if check_box is not None else Box(-np.ones(self.n), np.ones(self.n))
        X = box.sample(7, seed=1)
        Phi, dPhi = self.evaluate(X), self.gradient(X)
        if fd_tol is not None:
            h = 1e-6 * np.maximum(1.0, box.upper - box.lower)
            fd = np.empty_like(dPhi)
            for i in range(self.n):
                e = np.zeros(self.n)
                e[i] = h[i]
                fd[:, :, i] = (self.evaluate(X + e) - self.evaluate(X - e)) / (2 * h[i])
            err = np.max(np.abs(fd - dPhi)) / max(1.0, np.max(np.abs(dPhi)))
            if err > fd_tol:
                raise ValueError(f"basis gradient does not match finite differences of phi "
                                 f"(relative error {err:.2e} > {fd_tol:g})")
        del Phi

    def __len__(self) -> int:
        return self._size

    def evaluate(self, X: ArrayLike) -> np.ndarray:
        X = check_points("X", X, self.n, keep_object=True)
        out = (object_call("basis phi", self._phi, X) if X.dtype == object
               else np.asarray(self._phi(X), dtype=float))
        if out.shape != (X.shape[0], self._size):
            raise ValueError(f"basis phi(X) must return shape {(X.shape[0], self._size)}, "
                             f"got {out.shape}")
        return out

    def gradient(self, X: ArrayLike) -> np.ndarray:
        X = check_points("X", X, self.n, keep_object=True)
        out = (object_call("basis grad", self._grad, X) if X.dtype == object
               else np.asarray(self._grad(X), dtype=float))
        if out.shape != (X.shape[0], self._size, self.n):
            raise ValueError(f"basis grad(X) must return shape "
                             f"{(X.shape[0], self._size, self.n)}, got {out.shape}")
        return out

    def names(self) -> list[str]:
        return list(self._names)
