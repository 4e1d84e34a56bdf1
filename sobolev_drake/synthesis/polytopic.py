"""Robust (polytopic) state feedback: one common Lyapunov matrix for all vertices (Corollary 1).

If the bounded-real-lemma LMI (and the region LMI) hold at every vertex (A_i, B_i, D_i) with
the same X = P^-1 and W = K X, they hold on the convex hull because the LMIs are affine in the
plant data for fixed (X, W). The W-infinity channel's C1 = [Gamma0^1/2; Gamma1^1/2 A] and
D12 = [0; Gamma1^1/2 B] are affine in (A, B), so convex combinations of vertex generalized
plants are the generalized plants of convex combinations of (A, B, D).
"""

from __future__ import annotations

import itertools

import numpy as np

from .hinf import state_feedback
from .sobolev import hinf_plant, winf_plant


def interval_vertices(fn, nominal, spread):
    """Evaluate ``fn(**params)`` at all 2^k corners of interval parameters.

    ``nominal``: dict of parameter values; ``spread``: dict name -> relative spread (e.g. 0.1
    for +-10 %) or (lo, hi) absolute bounds, for the k uncertain parameters. Returns a list
    of (params, fn(**params)) pairs.
    """
    if not isinstance(nominal, dict) or not isinstance(spread, dict):
        raise TypeError("nominal and spread must be dicts of parameter name -> value")
    unknown = set(spread) - set(nominal)
    if unknown:
        raise ValueError(f"spread names parameters absent from nominal: {sorted(unknown)}")
    bounds = {}
    for k, s in spread.items():
        if np.isscalar(s):
            if s < 0:
                raise ValueError(f"relative spread for {k!r} must be >= 0, got {s}")
            v = nominal[k]
            bounds[k] = (v * (1 - s), v * (1 + s))
        else:
            lo, hi = s
            if hi < lo:
                raise ValueError(f"bounds for {k!r} must satisfy lo <= hi, got {s}")
            bounds[k] = (lo, hi)
    out = []
    names = list(bounds)
    for corner in itertools.product(*[bounds[k] for k in names]):
        params = dict(nominal)
        params.update(zip(names, corner))
        out.append((params, fn(**params)))
    return out


def robust_winf_state_feedback(vertices, Gamma0, Gamma1, *, region=None, **kw):
    """Common-Lyapunov W-infinity state feedback over vertices [(A, B, D), ...]."""
    plants = [winf_plant(A, B, D, Gamma0, Gamma1) for A, B, D in vertices]
    return state_feedback(plants[0], vertices=plants[1:], region=region, **kw)


def robust_hinf_state_feedback(vertices, Q, R, *, region=None, **kw):
    """Common-Lyapunov classic H-infinity state feedback over vertices [(A, B, D), ...]."""
    plants = [hinf_plant(A, B, D, Q, R) for A, B, D in vertices]
    return state_feedback(plants[0], vertices=plants[1:], region=region, **kw)


def random_interior_points(vertices, count, rng=None):
    """Random convex combinations (Dirichlet weights) of vertex tuples (A, B, D)."""
    rng = np.random.default_rng(rng)
    pts = []
    for _ in range(count):
        lam = rng.dirichlet(np.ones(len(vertices)))
        pts.append(tuple(sum(l * v[j] for l, v in zip(lam, vertices)) for j in range(len(vertices[0]))))
    return pts
