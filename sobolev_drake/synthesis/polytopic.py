"""Robust (polytopic) state feedback: one common Lyapunov matrix for all vertices (Corollary 1).

If the bounded-real-lemma LMI (and the region LMI) hold at every vertex (A_i, B_i, D_i) with
the same X = P^-1 and W = K X, they hold on the convex hull because the LMIs are affine in the
plant data for fixed (X, W). The W∞ channel's C1 = [Gamma0^1/2; Gamma1^1/2 A] and
D12 = [0; Gamma1^1/2 B] are affine in (A, B), so convex combinations of vertex generalized
plants are the generalized plants of convex combinations of (A, B, D).
"""

from __future__ import annotations

import itertools
from typing import Any, Callable, Sequence

import numpy as np
from numpy.typing import ArrayLike

from ..validation import bounds_pair, real_scalar
from .certificates import as_matrix
from .hinf import state_feedback
from .problem import SynthesisResult
from .regions import LMIRegion
from .sobolev import hinf_plant, winf_plant

__all__ = [
    "interval_vertices", "robust_winf_state_feedback", "robust_hinf_state_feedback",
    "random_interior_points",
]


#: most interval parameters :func:`interval_vertices` accepts (2^k vertices)
MAX_UNCERTAIN = 12


def interval_vertices(fn: Callable[..., Any], nominal: dict[str, Any],
                      spread: dict[str, float | tuple[float, float]]
                      ) -> list[tuple[dict[str, Any], Any]]:
    """Evaluate ``fn(**params)`` at all 2^k corners of interval parameters.

    ``nominal``: dict of parameter values; ``spread``: dict name -> relative spread (e.g. 0.1
    for +-10 %) or (lo, hi) absolute bounds, for the k uncertain parameters. Returns a list
    of ``(params, fn(**params))`` pairs.
    """
    if not isinstance(nominal, dict) or not isinstance(spread, dict):
        raise TypeError("nominal and spread must be dicts of parameter name -> value")
    unknown = set(spread) - set(nominal)
    if unknown:
        raise ValueError(f"spread names parameters absent from nominal: {sorted(unknown)}")
    if len(spread) > MAX_UNCERTAIN:
        raise ValueError(f"{len(spread)} uncertain parameters give 2^{len(spread)} vertices; at most "
                         f"{MAX_UNCERTAIN} are supported (2^{MAX_UNCERTAIN} LMI blocks per vertex set)")
    bounds = {}
    for k, s in spread.items():
        if np.isscalar(s):
            s = real_scalar(f"spread[{k!r}]", s, low=0.0)
            v = real_scalar(f"nominal[{k!r}]", nominal[k])
            bounds[k] = (v * (1 - s), v * (1 + s))
        else:
            lo, hi = bounds_pair(f"spread[{k!r}] lower bound", s[0], f"spread[{k!r}] upper bound", s[1], 1)
            if not np.all(np.isfinite([lo[0], hi[0]])):
                raise ValueError(f"bounds for {k!r} must be finite, got {s}")
            bounds[k] = (float(lo[0]), float(hi[0]))
    out = []
    names = list(bounds)
    for corner in itertools.product(*[bounds[k] for k in names]):
        params = dict(nominal)
        params.update(zip(names, corner))
        out.append((params, fn(**params)))
    return out


def _vertex_triples(vertices):
    """``vertices`` as a list of (A, B, D) real matrices of one common set of shapes."""
    try:
        triples = list(vertices)
    except TypeError:
        raise TypeError(f"vertices must be a sequence of (A, B, D) tuples, got {type(vertices).__name__}") from None
    if not triples:
        raise ValueError("vertices must contain at least one (A, B, D) tuple, got none")
    out = []
    for i, v in enumerate(triples):
        try:
            A, B, D = v
        except (TypeError, ValueError):
            raise TypeError(f"vertices[{i}] must be an (A, B, D) tuple, got {type(v).__name__}") from None
        mats = tuple(as_matrix(f"vertices[{i}].{n}", M) for n, M in zip("ABD", (A, B, D)))
        if out and tuple(M.shape for M in mats) != tuple(M.shape for M in out[0]):
            raise ValueError(f"vertices[{i}] has shapes A {mats[0].shape}, B {mats[1].shape}, "
                             f"D {mats[2].shape}; vertices[0] has A {out[0][0].shape}, "
                             f"B {out[0][1].shape}, D {out[0][2].shape}: all must match")
        out.append(mats)
    return out


def robust_winf_state_feedback(vertices: Sequence[tuple[ArrayLike, ArrayLike, ArrayLike]],
                               Gamma0: ArrayLike, Gamma1: ArrayLike, *,
                               region: LMIRegion | None = None, **kw: Any) -> SynthesisResult:
    """Common-Lyapunov W∞ state feedback over vertices [(A, B, D), ...]."""
    plants = [winf_plant(A, B, D=D, Gamma0=Gamma0, Gamma1=Gamma1) for A, B, D in _vertex_triples(vertices)]
    return state_feedback(plants[0], vertices=plants[1:], region=region, **kw)


def robust_hinf_state_feedback(vertices: Sequence[tuple[ArrayLike, ArrayLike, ArrayLike]],
                               Q: ArrayLike, R: ArrayLike, *, region: LMIRegion | None = None,
                               **kw: Any) -> SynthesisResult:
    """Common-Lyapunov classic H∞ state feedback over vertices [(A, B, D), ...]."""
    plants = [hinf_plant(A, B, D=D, Q=Q, R=R) for A, B, D in _vertex_triples(vertices)]
    return state_feedback(plants[0], vertices=plants[1:], region=region, **kw)


def random_interior_points(vertices: Sequence[tuple[ArrayLike, ArrayLike, ArrayLike]], count: int,
                           rng: np.random.Generator | int | None = None
                           ) -> list[tuple[np.ndarray, ...]]:
    """Random convex combinations (Dirichlet weights) of vertex tuples (A, B, D)."""
    if isinstance(count, (bool, np.bool_)) or not isinstance(count, (int, np.integer)) or count < 0:
        raise ValueError(f"count must be an integer >= 0, got {count!r}")
    vertices = _vertex_triples(vertices)
    rng = np.random.default_rng(rng)
    pts = []
    for _ in range(count):
        lam = rng.dirichlet(np.ones(len(vertices)))
        pts.append(tuple(sum(l * v[j] for l, v in zip(lam, vertices)) for j in range(len(vertices[0]))))
    return pts
