"""Finite-difference linearization of a :class:`~sobolev_drake.models.base.MechanicalModel`.

Shared by the linear experiments (balance-linear, quadrotor-polytopic), which previously each
carried a private copy of the same right-hand side and central-difference Jacobian.
"""

from __future__ import annotations

import numpy as np

from sobolev_drake.models.base import check_vector

__all__ = ["mechanical_rhs", "central_jacobian", "linearize_mechanical"]


def mechanical_rhs(model, q, qdot, u, w):
    """ẋ = [q̇; M(q)⁻¹(B(q) u + w − C(q,q̇)q̇ − g(q) − K(q̇))] in thesis order (cf. (4.30))."""
    tau = model.B(q) @ np.atleast_1d(u) + w - model.Cqdot(q, qdot) - model.g(q) - model.friction(qdot)
    return np.r_[qdot, np.linalg.solve(model.M(q), tau)]


def central_jacobian(fun, n, h):
    """Columns (fun(h e_i) − fun(−h e_i)) / 2h, i = 1..n: the Jacobian of ``fun`` at 0."""
    if not h > 0:
        raise ValueError(f"step h must be positive, got {h!r}")
    return np.column_stack([(fun(h * e) - fun(-h * e)) / (2 * h) for e in np.eye(n)])


def linearize_mechanical(model, q0, qdot0, u0, w0=None, *, h=1e-6, h_u=None, h_w=None):
    """(A, B, D) of ẋ = f(x, u, w) at (q0, q̇0, u0, w0) by central differences.

    State x = [q; q̇] in thesis order (size 2n), u the actuator vector of ``model.B`` (size m),
    w the generalized disturbance force (size n), so A is 2n × 2n, B 2n × m, D 2n × n
    (D = [0; M(q0)⁻¹]).  ``h`` is the state step; ``h_u`` / ``h_w`` the input / disturbance steps
    (default ``h``; the dynamics are affine in u and w, so large steps are exact and avoid
    round-off).  The point need not be an equilibrium: the Jacobians are of f itself.
    """
    n = model.n
    q0 = check_vector("q0", q0, n)
    qdot0 = check_vector("qdot0", qdot0, n)
    u0 = np.atleast_1d(np.asarray(u0, dtype=float))
    w0 = np.zeros(n) if w0 is None else check_vector("w0", w0, n)
    x0 = np.r_[q0, qdot0]

    def f(x, u, w):
        return mechanical_rhs(model, x[:n], x[n:], u, w)

    A = central_jacobian(lambda dx: f(x0 + dx, u0, w0), 2 * n, h)
    B = central_jacobian(lambda du: f(x0, u0 + du, w0), u0.size, h if h_u is None else h_u)
    D = central_jacobian(lambda dw: f(x0, u0, w0 + dw), n, h if h_w is None else h_w)
    return A, B, D
