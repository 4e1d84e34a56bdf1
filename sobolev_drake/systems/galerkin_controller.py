"""State feedback u = u*(x) from a successive-Galerkin design (W2 (4.8), W∞ (4.20), H∞).

:class:`GalerkinController` evaluates the control law of a
:class:`~sobolev_drake.synthesis.galerkin.GalerkinResult` (or any object with a vectorized
``control(X) -> (Q, nu)`` method) at the current state.  The basis gradient and the model terms
are evaluated vectorized over all basis functions (no Python loop over terms).

The plant state (e.g. the thesis' [ϕ θ ϕ̇ θ̇] of the two-wheeled vehicle) is mapped to the
design state by ``x_design = selection @ x + offset`` (e.g. ``selection`` picking [θ ϕ̇ θ̇]);
``u_limits`` optionally saturates the output.
"""

from __future__ import annotations

import numpy as np
from pydrake.systems.framework import BasicVector, LeafSystem

__all__ = ["GalerkinController", "selection_matrix"]


def selection_matrix(indices, size: int) -> np.ndarray:
    """Rows of the identity: x_design = S x picks ``indices`` of a state of length ``size``."""
    idx = list(indices)
    if any((not 0 <= i < size) for i in idx):
        raise ValueError(f"selection indices {idx} out of range for a state of size {size}")
    return np.eye(size)[idx]


class GalerkinController(LeafSystem):
    """Drake LeafSystem: input port ``x`` (plant state), output port ``u`` = u*(S x + o).

    Parameters
    ----------
    law : object with ``control(X) -> (Q, nu)`` (a ``GalerkinResult``) and, if ``nu`` /
        ``n`` are not given, ``problem.model.nu`` / ``problem.model.n``.
    plant_state_size : size of the input port (default: the design state size).
    selection : (n_design, plant_state_size) matrix, or a list of indices (default identity).
    offset : design-state offset (default 0).
    u_limits : optional (lo, hi) saturation of the output.
    """

    def __init__(self, law, *, plant_state_size: int | None = None, selection=None, offset=None,
                 u_limits=None, n: int | None = None, nu: int | None = None):
        super().__init__()
        if not callable(getattr(law, "control", None)):
            raise TypeError("law must have a vectorized control(X) method (e.g. GalerkinResult)")
        model = getattr(getattr(law, "problem", None), "model", None)
        self._n = int(n if n is not None else model.n)
        self._nu = int(nu if nu is not None else model.nu)
        size = self._n if plant_state_size is None else int(plant_state_size)
        if selection is None:
            S = np.eye(size)[: self._n] if size == self._n else None
            if S is None:
                raise ValueError(f"plant_state_size {size} differs from the design state size "
                                 f"{self._n}: give a selection")
        else:
            sel = np.asarray(selection)
            S = selection_matrix(sel, size) if sel.ndim == 1 else sel.astype(float)
        if S.shape != (self._n, size):
            raise ValueError(f"selection must have shape ({self._n}, {size}), got {S.shape}")
        self._S = S
        self._o = np.zeros(self._n) if offset is None else np.asarray(offset, float).reshape(self._n)
        if u_limits is not None:
            lo, hi = (np.broadcast_to(np.asarray(v, float), (self._nu,)) for v in u_limits)
            if np.any(lo > hi):
                raise ValueError("u_limits: lower bound above upper bound")
            self._lim = (lo, hi)
        else:
            self._lim = None
        self._law = law
        self._x = self.DeclareVectorInputPort("x", size)
        self.DeclareVectorOutputPort("u", BasicVector(self._nu), self._calc_u,
                                     prerequisites_of_calc={self.input_port_ticket(
                                         self._x.get_index())})

    def design_state(self, x) -> np.ndarray:
        return self._S @ np.asarray(x, float) + self._o

    def _calc_u(self, context, output):
        xd = self.design_state(self._x.Eval(context))
        u = np.asarray(self._law.control(xd[None, :]), float)[0]
        if self._lim is not None:
            u = np.clip(u, *self._lim)
        output.SetFromVector(u)
