"""Linear state-feedback and dynamic output-feedback controllers as Drake LeafSystems.

They receive gains computed by ``sobolev_drake.synthesis`` (never re-derive them):

* :class:`LinearStateFeedback`: u = u_r + K (x - x_r), ports ``x`` (and ``x_r`` if
  ``reference_port=True``), output ``u`` (optionally clipped, then also ``u_raw``). Direct
  feedthrough x -> u.  K is a numeric parameter: ``set_gains(context, K)`` retunes a context.
* :class:`LinearDynamicOutputFeedback`: x_K' = AK x_K + BK (y - y_op),
  u = u_op + CK x_K + DK (y - y_op); ports ``y`` -> ``u``. When DK = 0 the output depends on
  the controller state only and is declared so (no false algebraic loop).
"""

from __future__ import annotations

import numpy as np
from pydrake.systems.framework import BasicVector, LeafSystem


def _mat(name, M, shape=None):
    M = np.atleast_2d(np.asarray(M, dtype=float))
    if shape is not None and any(w is not None and g != w for g, w in zip(M.shape, shape)):
        raise ValueError(f"{name} must have shape {shape}, got {M.shape}")
    if not np.all(np.isfinite(M)):
        raise ValueError(f"{name} contains non-finite entries")
    return M


class LinearStateFeedback(LeafSystem):
    """u = u_r + K (x - x_r) with constant u_r (operating point) and x_r (port or constant).

    K is stored in a numeric parameter (default: the ``K`` given here), so one diagram can serve
    a gain sweep: :meth:`set_gains` writes new gains into a context.  With ``u_min`` / ``u_max``
    the output ``u`` is clipped elementwise and a second output ``u_raw`` gives the unclipped
    command (e.g. to measure saturation).
    """

    def __init__(self, K, *, u_r=None, x_r=None, reference_port=False, u_min=None, u_max=None):
        super().__init__()
        self.K = _mat("K", K)
        nu, nx = self.K.shape
        self.u_r = np.zeros(nu) if u_r is None else _mat("u_r", u_r, (1, nu)).ravel()
        self.x_r = np.zeros(nx) if x_r is None else _mat("x_r", x_r, (1, nx)).ravel()
        self._bounds = None
        if u_min is not None or u_max is not None:
            lo = np.full(nu, -np.inf) if u_min is None else np.broadcast_to(
                np.asarray(u_min, dtype=float), (nu,)).copy()
            hi = np.full(nu, np.inf) if u_max is None else np.broadcast_to(
                np.asarray(u_max, dtype=float), (nu,)).copy()
            if np.any(np.isnan(lo)) or np.any(np.isnan(hi)) or np.any(lo > hi):
                raise ValueError(f"u_min must be <= u_max elementwise, got {lo} and {hi}")
            self._bounds = (lo, hi)
        self._K_index = self.DeclareNumericParameter(BasicVector(self.K.ravel()))
        self._x = self.DeclareVectorInputPort("x", nx)
        self._xr = self.DeclareVectorInputPort("x_r", nx) if reference_port else None
        self.DeclareVectorOutputPort("u", nu, self._calc_u)
        if self._bounds is not None:
            self.DeclareVectorOutputPort("u_raw", nu, self._calc_raw)

    def set_gains(self, context, K):
        """Write K (shape nu x nx) into this system's parameter in ``context`` (its own context)."""
        K = _mat("K", K, self.K.shape)
        context.get_mutable_numeric_parameter(self._K_index).SetFromVector(K.ravel())

    def gains(self, context):
        """The gain matrix K currently held by ``context``."""
        return context.get_numeric_parameter(self._K_index).get_value().reshape(self.K.shape)

    def _raw(self, context):
        x = self._x.Eval(context)
        xr = self._xr.Eval(context) if self._xr is not None else self.x_r
        return self.u_r + self.gains(context) @ (x - xr)

    def _calc_u(self, context, output):
        u = self._raw(context)
        if self._bounds is not None:
            u = np.clip(u, *self._bounds)
        output.SetFromVector(u)

    def _calc_raw(self, context, output):
        output.SetFromVector(self._raw(context))


class LinearDynamicOutputFeedback(LeafSystem):
    """Full-order dynamic controller (AK, BK, CK, DK) around operating points (y_op, u_op)."""

    def __init__(self, AK, BK, CK, DK=None, *, y_op=None, u_op=None, x0=None):
        super().__init__()
        self.AK = _mat("AK", AK)
        nk = self.AK.shape[0]
        _mat("AK", AK, (nk, nk))
        self.BK = _mat("BK", BK, (nk, None))
        ny = self.BK.shape[1]
        self.CK = _mat("CK", CK, (None, nk))
        nu = self.CK.shape[0]
        self.DK = np.zeros((nu, ny)) if DK is None else _mat("DK", DK, (nu, ny))
        self.y_op = np.zeros(ny) if y_op is None else _mat("y_op", y_op, (1, ny)).ravel()
        self.u_op = np.zeros(nu) if u_op is None else _mat("u_op", u_op, (1, nu)).ravel()
        x0 = np.zeros(nk) if x0 is None else _mat("x0", x0, (1, nk)).ravel()
        self._y = self.DeclareVectorInputPort("y", ny)
        self.DeclareContinuousState(BasicVector(x0))
        feedthrough = bool(np.any(self.DK != 0))
        prereq = ({self.all_sources_ticket()} if feedthrough else {self.xc_ticket()})
        self.DeclareVectorOutputPort("u", nu, self._calc_u, prerequisites_of_calc=prereq)

    @classmethod
    def from_controller(cls, controller, **kw):
        """From a synthesis ``DynamicController`` (or any (AK, BK, CK, DK) iterable)."""
        AK, BK, CK, DK = controller
        return cls(AK, BK, CK, DK, **kw)

    def _xk(self, context):
        return context.get_continuous_state_vector().CopyToVector()

    def DoCalcTimeDerivatives(self, context, derivatives):
        dy = self._y.Eval(context) - self.y_op
        derivatives.get_mutable_vector().SetFromVector(self.AK @ self._xk(context) + self.BK @ dy)

    def _calc_u(self, context, output):
        u = self.u_op + self.CK @ self._xk(context)
        if np.any(self.DK != 0):
            u = u + self.DK @ (self._y.Eval(context) - self.y_op)
        output.SetFromVector(u)
