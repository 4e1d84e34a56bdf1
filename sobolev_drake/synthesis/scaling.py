"""Exact rescaling of a generalized plant before the LMI solve (conditioning only).

Coordinates x = T x~ (diagonal state similarity), u = Su u~ (input scaling), y = Sy y~
(measurement scaling); w and z are never scaled.  The w -> z map of every closed loop, hence
gamma, the closed-loop poles (so any LMI region) and the feasible set of the H∞ problem
are invariant; only the SDP's conditioning changes.  All factors are powers of two, so the
scaling itself is exact in floating point.  The controller found for the scaled plant is
mapped back (:func:`unscale_gain`, :func:`unscale_controller`) and certified on the original
plant by the callers.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Sequence

import numpy as np
from numpy.typing import ArrayLike
import scipy.linalg as sla

if TYPE_CHECKING:
    from sobolev_drake.synthesis.problem import DynamicController, GeneralizedPlant

__all__ = [
    "balance_scaling", "scale_plant", "resolve_scaling", "unscale_gain", "unscale_controller",
]


def _pow2(v):
    """Nearest powers of two: scaling by them is exact in floating point."""
    return np.exp2(np.round(np.log2(v)))


def _unit(norms):
    """Power-of-two factors making nonzero norms ~1 (zero norms: factor 1)."""
    return _pow2(np.where(norms > 0, 1.0 / np.where(norms > 0, norms, 1.0), 1.0))


def balance_scaling(plants: Sequence[GeneralizedPlant], outputs: bool = False
                    ) -> tuple[np.ndarray, ...]:
    """Diagonal state similarity T and input scaling Su (and output scaling Sy) as powers of 2.

    Su makes the columns of [B2; D12] unit-sized; T balances [[A, b], [c, 0]] (scipy's
    matrix_balance, Parlett & Reinsch), b / c the row / column magnitudes of [B1 B2 Su] / C1
    over the vertices (with ``outputs``, the row-normalized [C2 D21] joins c).  Su is then
    recomputed in the balanced state coordinates, and with ``outputs`` Sy makes the rows of
    Sy^-1 [C2 T, D21] unit-sized.  Returns (T, Su) or, with ``outputs``, (T, Su, Sy).
    """
    n = plants[0].n
    Su = _unit(np.max([np.linalg.norm(np.vstack([p.B2, p.D12]), axis=0) for p in plants], axis=0))
    absA = np.max([np.abs(p.A) for p in plants], axis=0)
    b = np.max([np.linalg.norm(np.hstack([p.B1, p.B2 * Su]), axis=1) for p in plants], axis=0)
    cols = []
    for p in plants:
        C = p.C1
        if outputs and p.ny:
            ry = np.linalg.norm(np.hstack([p.C2, p.D21]), axis=1)
            C = np.vstack([C, p.C2 / np.where(ry > 0, ry, 1.0)[:, None]])
        cols.append(np.linalg.norm(C, axis=0))
    c = np.max(cols, axis=0)
    M = np.block([[absA, b[:, None]], [c[None, :], np.zeros((1, 1))]])
    T = np.ones(n)
    if np.all(np.isfinite(M)) and M.any():
        _, (d, _) = sla.matrix_balance(M, permute=False, separate=True)
        T = _pow2(d[:n] / d[n])
    # the inputs (and outputs) again, now in balanced state coordinates
    Su = _unit(np.max([np.linalg.norm(np.vstack([p.B2 / T[:, None], p.D12]), axis=0)
                       for p in plants], axis=0))
    if not outputs:
        return T, Su
    ny = plants[0].ny
    ry = np.max([np.linalg.norm(np.hstack([p.C2 * T, p.D21]), axis=1) for p in plants], axis=0) \
        if ny else np.zeros(0)
    return T, Su, 1.0 / _unit(ry)


def scale_plant(p: GeneralizedPlant, T: np.ndarray, Su: np.ndarray, Sy: np.ndarray | None = None
                ) -> GeneralizedPlant:
    """Plant in coordinates x = T x~, u = Su u~, y = Sy y~ (w, z unchanged)."""
    Ti = 1.0 / T
    C2, D21 = p.C2 * T, p.D21
    if Sy is not None:
        C2, D21 = C2 / Sy[:, None], D21 / Sy[:, None]
    return type(p)(Ti[:, None] * p.A * T, Ti[:, None] * p.B1, Ti[:, None] * p.B2 * Su,
                   p.C1 * T, p.D11, p.D12 * Su, C2, D21)


def resolve_scaling(scaling: bool | Sequence[ArrayLike] | None, plants: Sequence[GeneralizedPlant],
                    outputs: bool = False) -> tuple[np.ndarray, ...]:
    """``scaling`` keyword -> (T, Su) or (T, Su, Sy): True = automatic, False/None = identity,
    or explicit positive vectors of the right lengths."""
    p = plants[0]
    sizes = (p.n, p.nu, p.ny)[:3 if outputs else 2]
    names = ("T", "Su", "Sy")[:len(sizes)]
    if scaling is True:
        return balance_scaling(plants, outputs=outputs)
    if scaling is False or scaling is None:
        return tuple(np.ones(k) for k in sizes)
    expect = ", ".join(f"{nm} of length {k}" for nm, k in zip(names, sizes))
    try:
        vals = tuple(np.asarray(v, float).ravel() for v in scaling)
    except (TypeError, ValueError):
        vals = ()
    if (len(vals) != len(sizes) or any(v.shape != (k,) for v, k in zip(vals, sizes))
            or any(np.any(~(v > 0)) or not np.all(np.isfinite(v)) for v in vals)):
        raise ValueError(f"scaling must be True, False or ({', '.join(names)}) with positive {expect}")
    return vals


def unscale_gain(Ks: np.ndarray, T: np.ndarray, Su: np.ndarray) -> np.ndarray:
    """State feedback of the scaled plant u~ = Ks x~  ->  u = K x with K = Su Ks T^-1."""
    return Su[:, None] * Ks / T


def unscale_controller(ctrl: DynamicController, Su: np.ndarray, Sy: np.ndarray) -> DynamicController:
    """Controller (AK, BK, CK, DK) from y~ to u~ -> controller from y to u (same state)."""
    AK, BK, CK, DK = ctrl
    return type(ctrl)(AK, BK / Sy, Su[:, None] * CK, Su[:, None] * DK / Sy)
