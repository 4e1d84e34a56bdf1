"""The classic H∞ baseline's generalized input in :class:`~.mechanical_law.MechanicalLaw` (the
double path; the scalar-generic one is :func:`.scalar_law.generalized_input`).

The sliding variable σ = T11 q̃̇ + T12 q̃ + T13 ∫q̃ and u* = M a + h − C(q,q̇)T11⁻¹σ − T11⁻¹R⁻¹σ
with a = q̈_r − T11⁻¹(T12 q̃̇ + T13 q̃) (docs/design.md §4.3: the same inverse dynamics as the
Sobolev law).  Split from :mod:`.mechanical_law` (module size), which calls these functions.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:   # mechanical_law imports this module
    from numpy.typing import ArrayLike

    from sobolev_drake.systems.mechanical_law import MechanicalLaw

__all__ = ["hinf_terms", "hinf_force"]


def hinf_terms(law: MechanicalLaw, q: np.ndarray, qdot: np.ndarray, e_int: np.ndarray,
               reference: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The DOF carrying σ, σ on them and the acceleration a (0 on the stabilized DOF).

    Parameters
    ----------
    law : MechanicalLaw
        A law with the classic H∞ inner law (:class:`~.inner_laws.HinfLaw`).
    q, qdot : ndarray, shape (n,)
        Generalized coordinates and velocities, thesis order (checked by the caller).
    e_int : ndarray, shape (n_c,)
        Error integral ∫q̃c of the controlled DOF.
    reference : array_like, shape (3 n_ref,)
        Stacked reference (see :meth:`~.mechanical_law.MechanicalLaw.split_reference`).

    Returns
    -------
    idx : ndarray of int
        The stabilized, then the controlled DOF.
    sigma : ndarray
        T11 q̇ on the stabilized DOF, σ on the controlled DOF.
    a : ndarray
        0 on the stabilized DOF, q̈_r − T11⁻¹(T12 q̃̇ + T13 q̃) on the controlled DOF.

    Raises
    ------
    ValueError
        The partition has regulated DOF (the classic H∞ baseline has no form for them).
    """
    g = law.law.gains
    qr, qdr, qddr = law.split_reference(reference)
    tr = np.array(law.partition.tracked, dtype=int)
    e, ed = q[tr] - qr, qdot[tr] - qdr
    nc = law.nc
    if law.nr:
        raise ValueError("the classic H∞ baseline has no regulated-DOF form")
    idx = np.concatenate([law.is_, law.ic]).astype(int)
    sigma = np.concatenate([g.T11 * qdot[law.is_], g.sigma(ed[:nc], e[:nc], e_int)])
    a = np.concatenate([np.zeros(law.ns), qddr[:nc] - (g.T12 * ed[:nc] + g.T13 * e[:nc]) / g.T11])
    return idx, sigma, a


def hinf_force(law: MechanicalLaw, q: np.ndarray, qdot: np.ndarray, e_int: np.ndarray,
               reference: ArrayLike) -> np.ndarray:
    """u* = M a + h − C(q,q̇)T11⁻¹σ − T11⁻¹R⁻¹σ (reduced mode: reduced like (5.5)).

    Parameters
    ----------
    law, q, qdot, e_int, reference
        As in :func:`hinf_terms`.

    Returns
    -------
    ndarray, shape (n,) or (n_c,)
        u* (size n_c in the reduced mode).
    """
    g = law.law.gains
    idx, sigma, a = hinf_terms(law, q, qdot, e_int, reference)
    w = np.zeros(law.n)
    w[idx] = sigma / g.T11                      # q̇ − v = T11⁻¹σ
    Cw = law.model.C_times(q, qdot, w)
    M, h = law.dynamics.mass_and_bias(q, qdot)
    acc = np.zeros(law.n)
    acc[idx] = a
    extra = np.zeros(law.n)
    extra[idx] = -g.R_inv * sigma / g.T11       # T11⁻¹ u, u = −R⁻¹σ
    if law.partition.mode == "reduced":
        ic, iu = law.ic, law.iu
        # only the controlled DOF carry σ; reduce M a + h − C w like (5.5)
        Mcu, Muu = M[np.ix_(ic, iu)], M[np.ix_(iu, iu)]
        X = np.linalg.solve(Muu, np.eye(len(iu)))
        Mbar = M[np.ix_(ic, ic)] - Mcu @ X @ M[np.ix_(iu, ic)]
        red = Mbar @ acc[ic] + (h - Cw)[ic] - Mcu @ X @ (h - Cw)[iu]
        return red + extra[ic]
    return M @ acc + h - Cw + extra
