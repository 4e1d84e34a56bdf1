"""The mechanical control law for any Drake scalar type (``float``, ``AutoDiffXd``,
``Expression``): what a scalar-converted :class:`~sobolev_drake.systems.mechanical_controller.
MechanicalController` evaluates.

The functions take a :class:`~sobolev_drake.systems.mechanical_law.MechanicalLaw` (partition,
gains, bounds, allocation: double data) and the model's terms for the scalar type
(:class:`~sobolev_drake.models.scalar_terms.ScalarTerms`) and repeat the law's double
specialization (``MechanicalLaw.generalized_input`` / ``allocate``: per-state caches, the
permutation fast path) operation for operation with generic numpy; on doubles the two agree to
rounding (tested).

Where the law is not differentiable it says so instead of returning a wrong derivative:

* actuator bounds (``lower``/``upper``): the bounded least-squares allocation is an active-set
  method.  Where no bound is active (the unconstrained τ strictly inside the bounds) it *is*
  the unconstrained least-squares solution, and its derivative is returned; where a bound is
  active a ``ValueError`` names the bound, and a symbolic input a ``TypeError`` (the active set
  depends on values).  Build the controller without bounds for a linear model, or linearize
  where no bound is active;
* an ``allocation`` callable is called with the scalar-typed arrays and must accept them (a
  ``TypeError`` names it otherwise).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from sobolev_drake.models.scalar_terms import ScalarTerms, inverse, pseudo_inverse, solve
from sobolev_drake.systems.inner_laws import SobolevLaw

if TYPE_CHECKING:   # mechanical_law imports this module
    from sobolev_drake.systems.mechanical_law import MechanicalLaw

__all__ = ["integral_derivative", "desired_acceleration", "generalized_input", "allocate"]


def _dtype(*arrays):
    return object if any(np.asarray(a).dtype == object for a in arrays) else float


def _split(law, reference):
    m = law.n_ref
    return reference[:m], reference[m:2 * m], reference[2 * m:]


def integral_derivative(law: MechanicalLaw, q: ArrayLike, reference: ArrayLike) -> np.ndarray:
    """d/dt ∫q̃c = q_c − q_cr (``MechanicalLaw.integral_derivative`` for any scalar type).

    Parameters
    ----------
    law : MechanicalLaw
        The law (partition).
    q : ndarray, shape (n,)
        Generalized coordinates, thesis order.
    reference : ndarray, shape (3 n_ref,)
        Stacked reference [q_r; q̇_r; q̈_r] of the tracked DOF.

    Returns
    -------
    ndarray, shape (n_c,)
    """
    return q[law.ic] - reference[:law.nc]


def desired_acceleration(law: MechanicalLaw, q: ArrayLike, qdot: ArrayLike, e_int: ArrayLike,
                         reference: ArrayLike) -> np.ndarray:
    """q̈_des of the Sobolev law (``MechanicalLaw.desired_acceleration``; uncontrolled entries
    are zero here, not NaN: NaN has no Expression form and the reduced model ignores them).

    Parameters
    ----------
    law : MechanicalLaw
        A law whose inner law is a SobolevLaw.
    q, qdot : ndarray, shape (n,)
        Generalized coordinates and velocities, thesis order.
    e_int : ndarray, shape (n_c,)
        Error integral of the controlled DOF.
    reference : ndarray, shape (3 n_ref,)
        Stacked reference.

    Returns
    -------
    ndarray, shape (n,)
    """
    inner = law.law
    qr, qdr, qddr = _split(law, reference)
    tracked = list(law.partition.tracked)
    e, ed = q[tracked] - qr, qdot[tracked] - qdr
    nc = law.nc
    acc = np.zeros(law.n, dtype=_dtype(q, qdot, e_int, reference))
    acc[law.ic] = qddr[:nc] - inner.controlled.K @ np.concatenate([ed[:nc], e[:nc], e_int])
    if law.nr:
        acc[law.ir] = qddr[nc:] - inner.regulated.K @ np.concatenate([ed[nc:], e[nc:]])
    if law.ns:
        acc[law.is_] = -inner.stabilized.K @ qdot[law.is_]
    return acc


def _reduction(law, M):
    """Mcu Muu⁻¹ and M̄ = Mcc − Mcu Muu⁻¹ Muc of (5.5)."""
    ic, iu = law.ic, law.iu
    X = M[np.ix_(ic, iu)] @ inverse(M[np.ix_(iu, iu)])
    return X, M[np.ix_(ic, ic)] - X @ M[np.ix_(iu, ic)]


def generalized_input(law: MechanicalLaw, terms: ScalarTerms, q: ArrayLike, qdot: ArrayLike,
                      e_int: ArrayLike, reference: ArrayLike) -> np.ndarray:
    """u* of :meth:`MechanicalLaw.generalized_input` (Sobolev and H∞ laws, every partition
    mode) for the scalar type of ``terms``.

    Parameters
    ----------
    law : MechanicalLaw
        The law.
    terms : ScalarTerms
        The model's terms for the scalar type of the arrays.
    q, qdot : ndarray, shape (n,)
        Generalized coordinates and velocities, thesis order.
    e_int : ndarray, shape (n_c,)
        Error integral of the controlled DOF.
    reference : ndarray, shape (3 n_ref,)
        Stacked reference.

    Returns
    -------
    ndarray, shape (n,) or (n_c,)
        u* (size n_c in the reduced mode).
    """
    M, h = terms.mass_and_bias(q, qdot)
    reduced = law.partition.mode == "reduced"
    ic, iu = law.ic, law.iu
    if isinstance(law.law, SobolevLaw):
        acc = desired_acceleration(law, q, qdot, e_int, reference)
        if reduced:
            X, Mbar = _reduction(law, M)
            return Mbar @ acc[ic] + h[ic] - X @ h[iu]
        return M @ acc + h
    g = law.law.gains
    qr, qdr, qddr = _split(law, reference)
    nc = law.nc
    e, ed = q[ic] - qr[:nc], qdot[ic] - qdr[:nc]
    idx = np.concatenate([law.is_, law.ic]).astype(int)
    sigma = np.concatenate([g.T11 * qdot[law.is_], g.T11 * ed + g.T12 * e + g.T13 * e_int])
    dtype = _dtype(q, qdot, e_int, reference)
    w, acc, extra = (np.zeros(law.n, dtype=dtype) for _ in range(3))
    w[idx] = sigma / g.T11                                     # q̇ − v = T11⁻¹σ
    acc[idx] = np.concatenate([np.zeros(law.ns), qddr[:nc] - (g.T12 * ed + g.T13 * e) / g.T11])
    extra[idx] = -g.R_inv * sigma / g.T11                      # T11⁻¹ u, u = −R⁻¹σ
    rest = h - terms.C_times(q, qdot, w)
    if reduced:
        X, Mbar = _reduction(law, M)
        return Mbar @ acc[ic] + rest[ic] - X @ rest[iu] + extra[ic]
    return M @ acc + rest + extra


def _values(tau):
    """Numeric values of τ (AutoDiffXd: its values; Expression: only if constant)."""
    if tau.dtype != object:
        return tau
    out = []
    for x in tau:
        if isinstance(x, float):
            out.append(x)
        elif hasattr(x, "value"):
            out.append(x.value())
        elif x.GetVariables().empty():
            out.append(x.Evaluate())
        else:
            raise TypeError(
                "actuator bounds (lower/upper): the bounded least-squares allocation is an "
                "active-set method whose active set depends on values, so it has no symbolic "
                "form; build the controller without lower/upper for symbolic analysis, or use "
                "ToAutoDiffXd at a state where no bound is active")
    return np.array(out, dtype=float)


def allocate(law: MechanicalLaw, terms: ScalarTerms, u_star: ArrayLike, q: ArrayLike,
             qdot: ArrayLike) -> np.ndarray:
    """τ from u* (:meth:`MechanicalLaw.allocate`) for the scalar type of ``terms``.

    B⁻¹, B̄⁻¹ or B†; with actuator bounds the unconstrained τ is returned where it is strictly
    inside them (there the bounded solution equals it, derivative included), else an error
    names the active bound (module docstring); on doubles an active bound gives the bounded
    least-squares τ of the double law.

    Parameters
    ----------
    law : MechanicalLaw
        The law.
    terms : ScalarTerms
        The model's terms for the scalar type of the arrays.
    u_star : ndarray
        Generalized input from :func:`generalized_input`.
    q, qdot : ndarray, shape (n,)
        Generalized coordinates and velocities, thesis order.

    Returns
    -------
    ndarray, shape (n_τ,)
    """
    if law.allocation is not None:
        try:
            return np.asarray(law.allocation(u_star, q, qdot))
        except (TypeError, ValueError) as exc:
            raise TypeError(
                f"allocation {law.allocation!r} failed on {terms.scalar.__name__} arrays "
                f"({exc}); write it with numpy operations on object arrays, or keep the "
                "controller in double") from exc
    B = terms.input_matrix(q)
    if law.partition.mode == "reduced":
        M, _ = terms.mass_and_bias(q, qdot)
        X, _ = _reduction(law, M)
        B = B[law.ic] - X @ B[law.iu]
    tau = solve(B, u_star) if B.shape[0] == B.shape[1] else pseudo_inverse(B) @ u_star
    if law.lower is None and law.upper is None:
        return tau
    values = _values(tau)
    lo = -np.inf * np.ones(law.num_inputs) if law.lower is None else law.lower
    hi = np.inf * np.ones(law.num_inputs) if law.upper is None else law.upper
    active = np.flatnonzero((values <= lo) | (values >= hi))
    if not active.size:
        return tau
    if tau.dtype != object:
        return law.allocate(u_star, q, qdot)
    i = int(active[0])
    raise ValueError(
        f"actuator bound active at this state: τ[{i}] = {values[i]:.6g} outside "
        f"({lo[i]:.6g}, {hi[i]:.6g}) (lower, upper); the bounded least-squares allocation is "
        "not differentiable where a bound is active: linearize at a state where every τ is "
        "strictly inside [lower, upper], or build the controller without lower/upper")
