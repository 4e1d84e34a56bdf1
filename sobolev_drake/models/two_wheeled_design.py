"""Design model (4.30) of the two-wheeled vehicle in closed form, in the state x = [θ ϕ̇ θ̇]
(the wheel angle ϕ is cyclic), vectorized over quadrature nodes (thesis 4.4).

    ẋ = f(x) + g(x) u + k(x) w,  f = [θ̇; −M⁻¹(C q̇ + K(q̇) + G)],  g = [0; M⁻¹F],  k = [0 0; M⁻¹]

with the terms of :mod:`sobolev_drake.models.two_wheeled`; :func:`cross_check_design_model`
compares them with the Drake model.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from sobolev_drake.models.two_wheeled import TwoWheeledParams, make_two_wheeled_model

#: a vectorized map of states X (Q, 3) to f, g or k
_StateMap = Callable[[np.ndarray], np.ndarray]

__all__ = ["design_model", "cross_check_design_model"]


def design_model(params: TwoWheeledParams | None = None
                 ) -> tuple[_StateMap, _StateMap, _StateMap]:
    """Vectorized f, g, k of (4.30) for x = [θ ϕ̇ θ̇].

    Parameters
    ----------
    params : TwoWheeledParams, optional
        The vehicle (Table 4.1 by default).

    Returns
    -------
    (f, g, k) : tuple of callables
        f(X) (Q, 3), g(X) (Q, 3, 1) and k(X) (Q, 3, 2) of states X (Q, 3).
    """
    p = params or TwoWheeledParams()
    a = (p.M + p.m) * p.r ** 2 + p.Ir
    d = p.m * p.l ** 2 + p.Ip

    def minv(X):
        b = p.m * p.l * p.r * np.cos(X[:, 0])
        det = a * d - b * b
        out = np.empty((X.shape[0], 2, 2), dtype=np.result_type(X, float))   # object arrays: AutoDiff gains
        out[:, 0, 0], out[:, 1, 1] = d / det, a / det
        out[:, 0, 1] = out[:, 1, 0] = -b / det
        return out

    def f(X):
        th, phid, thd = X[:, 0], X[:, 1], X[:, 2]
        # −(C q̇ + K(q̇) + G) with C q̇ = [−m l r sinθ θ̇², 0], K = [kϕ̇, −kϕ̇], G = [0, −m g l sinθ]
        rhs = np.stack([p.m * p.l * p.r * np.sin(th) * thd ** 2 - p.k * phid,
                        p.k * phid + p.m * p.g * p.l * np.sin(th)], axis=1)
        Mi = minv(X)
        acc = Mi[:, :, 0] * rhs[:, 0, None] + Mi[:, :, 1] * rhs[:, 1, None]
        return np.stack([thd, acc[:, 0], acc[:, 1]], axis=1)

    def g(X):
        Mi = minv(X)
        out = np.zeros((X.shape[0], 3, 1), dtype=np.result_type(X, float))
        out[:, 1:, 0] = Mi[:, :, 0] - Mi[:, :, 1]  # M⁻¹ F, F = [1, −1]
        return out

    def k(X):
        out = np.zeros((X.shape[0], 3, 2), dtype=np.result_type(X, float))
        out[:, 1:, :] = minv(X)
        return out

    return f, g, k


def cross_check_design_model(points: np.ndarray | None = None) -> float:
    """Max |difference| between the closed-form f, g, k and the ``TwoWheeledModel`` (Drake) terms.

    Parameters
    ----------
    points : ndarray, optional
        States [θ ϕ̇ θ̇] (Q, 3) to compare at (three fixed points by default).

    Returns
    -------
    float
    """
    model = make_two_wheeled_model()
    f, g, k = design_model(model.params)
    X = np.array([[0.3, -1.0, 0.7], [-0.7, 2.5, -1.1], [0.0, 0.0, 0.0]]) if points is None else points
    F, G, Kd = f(X), g(X), k(X)
    err = 0.0
    for x, Fi, Gi, Ki in zip(X, F, G, Kd):
        q, qd = np.array([0.0, x[0]]), np.array([x[1], x[2]])
        M = model.M(q)
        h = model.Cqdot(q, qd) + model.friction(qd) + model.g(q)
        acc = -np.linalg.solve(M, h)
        err = max(err, np.abs(Fi - [x[2], *acc]).max(),
                  np.abs(Gi[1:] - np.linalg.solve(M, model.B(q))).max(),
                  np.abs(Ki[1:] - np.linalg.inv(M)).max())
    return float(err)
