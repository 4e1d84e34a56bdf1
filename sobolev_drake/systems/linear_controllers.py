"""Linear state-feedback and dynamic output-feedback controllers as Drake LeafSystems.

They receive gains computed by ``sobolev_drake.synthesis`` (never re-derive them):

* :class:`LinearStateFeedback`: u = u_r + K (S x - x_r), ports ``x`` (and ``x_r`` if
  ``reference_port=True``), output ``u`` (optionally clipped, then also ``u_raw``). Direct
  feedthrough x -> u.
* :class:`LinearDynamicOutputFeedback`: x_K' = AK x_K + BK (S y - y_op),
  u = u_op + CK x_K + DK (S y - y_op); port ``y`` -> ``u`` (optionally clipped, then also
  ``u_raw``). Without feedthrough (DK = 0) the output depends on the controller state only and
  is declared so (no false algebraic loop).

Both keep their gains in a numeric parameter, so one diagram serves a whole gain sweep
(Python LeafSystems are not garbage collected in drake 1.51): ``set_gains(context, ...)``
retunes a context, ``gains(context)`` reads it back.  The optional selection matrix ``S``
maps the connected signal (e.g. a plant's full state) to the linear model's state / output,
so no extra MatrixGain is needed.  The matrix sizes (and the controller order) are fixed at
construction.
"""

from __future__ import annotations

import numpy as np
from pydrake.systems.framework import BasicVector, LeafSystem

from sobolev_drake.validation import bounds_pair, real_matrix

__all__ = ["LinearStateFeedback", "LinearDynamicOutputFeedback", "controller_system"]


def _mat(name, M, shape=None):
    return real_matrix(name, M, shape, allow_empty=True)


def _bounds(nu, u_min, u_max):
    """Elementwise (lo, hi) of size nu, or None without bounds."""
    if u_min is None and u_max is None:
        return None
    lo = -np.inf if u_min is None else u_min
    hi = np.inf if u_max is None else u_max
    return bounds_pair("u_min", lo, "u_max", hi, nu)


def _selection(S, n):
    """Selection matrix S (n x m) or None (identity, m = n); returns (S or None, m)."""
    if S is None:
        return None, n
    S = _mat("S", S, (n, None))
    return S, S.shape[1]


class _ClippedOutput:
    """Outputs ``u`` (clipped to ``self._bounds`` when set) and ``u_raw`` from ``self._raw``."""

    def _calc_u(self, context, output):
        u = self._raw(context)
        if self._bounds is not None:
            u = np.clip(u, *self._bounds)
        output.SetFromVector(u)

    def _calc_raw(self, context, output):
        output.SetFromVector(self._raw(context))


class LinearStateFeedback(_ClippedOutput, LeafSystem):
    """u = u_r + K (S x - x_r) with constant u_r (operating point) and x_r (port or constant).

    K is stored in a numeric parameter (default: the ``K`` given here), so one diagram can serve
    a gain sweep: :meth:`set_gains` writes new gains into a context.  ``S`` (nx x m, default the
    identity) selects the linear-model state from the m-vector on port ``x``.  With ``u_min`` /
    ``u_max`` the output ``u`` is clipped elementwise and a second output ``u_raw`` gives the
    unclipped command (e.g. to measure saturation).

    Parameters
    ----------
    K : array_like, shape (nu, nx)
        Gain, sign convention u = +K x.
    u_r : array_like, shape (nu,), optional
        Constant input offset (operating point), zero by default.
    x_r : array_like, shape (nx,), optional
        Constant state reference, zero by default (ignored with ``reference_port``).
    reference_port : bool, default False
        Declare an input port ``x_r`` (size nx) for the reference instead of the constant.
    u_min, u_max : float or array_like (nu,), optional
        Elementwise clipping bounds of ``u``.
    S : array_like, shape (nx, m), optional
        Selection of the linear-model state from the m-vector on port ``x`` (identity by
        default).
    """

    def __init__(self, K, *, u_r=None, x_r=None, reference_port=False, u_min=None, u_max=None,
                 S=None):
        super().__init__()
        self.K = real_matrix("K", K)
        nu, nx = self.K.shape
        self.S, nin = _selection(S, nx)
        self.u_r = np.zeros(nu) if u_r is None else _mat("u_r", u_r, (1, nu)).ravel()
        self.x_r = np.zeros(nx) if x_r is None else _mat("x_r", x_r, (1, nx)).ravel()
        self._bounds = _bounds(nu, u_min, u_max)
        self._K_index = self.DeclareNumericParameter(BasicVector(self.K.ravel()))
        self._x = self.DeclareVectorInputPort("x", nin)
        self._xr = self.DeclareVectorInputPort("x_r", nx) if reference_port else None
        self.DeclareVectorOutputPort("u", nu, self._calc_u)
        if self._bounds is not None:
            self.DeclareVectorOutputPort("u_raw", nu, self._calc_raw)

    def set_gains(self, context, K):
        """Write K (shape nu x nx) into this system's parameter in ``context`` (its own context).

        Parameters
        ----------
        context : Context
            This system's context.
        K : array_like, shape (nu, nx)
            The new gain.
        """
        K = _mat("K", K, self.K.shape)
        context.get_mutable_numeric_parameter(self._K_index).SetFromVector(K.ravel())

    def gains(self, context):
        """The gain matrix K currently held by ``context``.

        Parameters
        ----------
        context : Context
            This system's context.

        Returns
        -------
        ndarray, shape (nu, nx)
        """
        return context.get_numeric_parameter(self._K_index).get_value().reshape(self.K.shape)

    def _raw(self, context):
        x = self._x.Eval(context)
        if self.S is not None:
            x = self.S @ x
        xr = self._xr.Eval(context) if self._xr is not None else self.x_r
        return self.u_r + self.gains(context) @ (x - xr)


def _controller_matrices(controller, name="controller", accepted=""):
    """(AK, BK, CK, DK) of a DynamicController, an output-feedback SynthesisResult or a tuple
    (``name`` and ``accepted``, further accepted kinds, for the message)."""
    kind = getattr(controller, "kind", None)
    if kind == "state_feedback":
        raise TypeError("from_controller got a state-feedback SynthesisResult (u = K x); "
                        "wire it with LinearStateFeedback(result.K) instead")
    if kind is not None:
        controller = controller.controller
    try:
        AK, BK, CK, DK = controller
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a DynamicController, an output-feedback "
                        f"SynthesisResult{accepted} or an (AK, BK, CK, DK) tuple, got "
                        f"{type(controller).__name__}") from None
    return AK, BK, CK, DK


class LinearDynamicOutputFeedback(_ClippedOutput, LeafSystem):
    """Full-order dynamic controller (AK, BK, CK, DK) around operating points (y_op, u_op).

    The four matrices are stored in one numeric parameter (defaults: the matrices given here);
    :meth:`set_gains` writes a new controller of the same order and sizes into a context.
    ``feedthrough`` (default: DK given here is nonzero) fixes at construction whether ``u``
    may depend directly on ``y``; a system built without it rejects gains with DK != 0, so the
    declared dependency (no algebraic loop) stays true.  ``S`` (ny x m, default identity) maps
    the m-vector on port ``y`` to the controller's measurement.  ``u_min`` / ``u_max`` clip
    ``u`` (then ``u_raw`` is the unclipped command).  ``x0`` is the default controller state.

    Parameters
    ----------
    AK, BK, CK : array_like
        Controller matrices, shapes (nk, nk), (nk, ny), (nu, nk): x_K' = AK x_K + BK ỹ,
        u = u_op + CK x_K + DK ỹ with ỹ = S y − y_op.
    DK : array_like, shape (nu, ny), optional
        Feedthrough, zero by default.
    y_op : array_like, shape (ny,), optional
        Measurement operating point, zero by default.
    u_op : array_like, shape (nu,), optional
        Input operating point, zero by default.
    x0 : array_like, shape (nk,), optional
        Default controller state, zero by default.
    S : array_like, shape (ny, m), optional
        Selection applied to the m-vector on port ``y`` (identity by default).
    feedthrough : bool, optional
        Whether ``u`` may depend directly on ``y`` (default: ``DK`` is nonzero).
    u_min, u_max : float or array_like (nu,), optional
        Elementwise clipping bounds of ``u``.
    """

    def __init__(self, AK, BK, CK, DK=None, *, y_op=None, u_op=None, x0=None, S=None,
                 feedthrough=None, u_min=None, u_max=None):
        super().__init__()
        self.AK = _mat("AK", AK)
        nk = self.AK.shape[0]
        _mat("AK", AK, (nk, nk))
        self.BK = _mat("BK", BK, (nk, None))
        ny = self.BK.shape[1]
        self.CK = _mat("CK", CK, (None, nk))
        nu = self.CK.shape[0]
        self.DK = np.zeros((nu, ny)) if DK is None else _mat("DK", DK, (nu, ny))
        self.nk, self.ny, self.nu = nk, ny, nu
        self._shapes = ((nk, nk), (nk, ny), (nu, nk), (nu, ny))
        self.S, nin = _selection(S, ny)
        self.y_op = np.zeros(ny) if y_op is None else _mat("y_op", y_op, (1, ny)).ravel()
        self.u_op = np.zeros(nu) if u_op is None else _mat("u_op", u_op, (1, nu)).ravel()
        x0 = np.zeros(nk) if x0 is None else _mat("x0", x0, (1, nk)).ravel()
        self._bounds = _bounds(nu, u_min, u_max)
        if feedthrough is not None and not isinstance(feedthrough, (bool, np.bool_)):
            raise TypeError(f"feedthrough must be None, True or False, got {feedthrough!r}")
        self.feedthrough = bool(np.any(self.DK != 0)) if feedthrough is None else bool(feedthrough)
        if not self.feedthrough and np.any(self.DK != 0):
            raise ValueError("DK must be zero when feedthrough=False (u would depend on y directly)")
        self._p_index = self.DeclareNumericParameter(BasicVector(self._pack(
            (self.AK, self.BK, self.CK, self.DK))))
        self._y = self.DeclareVectorInputPort("y", nin)
        self.DeclareContinuousState(BasicVector(x0))
        # without feedthrough u depends on the controller state (and parameters) only
        prereq = ({self.all_sources_ticket()} if self.feedthrough
                  else {self.xc_ticket(), self.all_parameters_ticket()})
        self.DeclareVectorOutputPort("u", nu, self._calc_u, prerequisites_of_calc=prereq)
        if self._bounds is not None:
            self.DeclareVectorOutputPort("u_raw", nu, self._calc_raw, prerequisites_of_calc=prereq)

    @classmethod
    def from_controller(cls, controller, **kw):
        """From a synthesis ``DynamicController``, an output-feedback ``SynthesisResult`` or any
        (AK, BK, CK, DK) iterable.

        Parameters
        ----------
        controller : DynamicController, SynthesisResult or tuple
            The controller (a state-feedback result raises ``TypeError``).
        **kw
            Keyword arguments of the constructor (``y_op``, ``u_op``, ``x0``, ``S``,
            ``feedthrough``, ``u_min``, ``u_max``).

        Returns
        -------
        LinearDynamicOutputFeedback
        """
        return cls(*_controller_matrices(controller), **kw)

    @staticmethod
    def _pack(mats):
        return np.concatenate([np.asarray(m, dtype=float).ravel() for m in mats])

    def set_gains(self, context, controller):
        """Write ``controller`` = (AK, BK, CK, DK) (a ``DynamicController`` or any iterable; DK
        may be None for 0) into this system's parameter in ``context`` (its own context).

        The shapes must equal the construction ones (the controller order is fixed).

        Parameters
        ----------
        context : Context
            This system's context.
        controller : DynamicController or tuple
            (AK, BK, CK, DK); DK must be zero (or None) unless built with feedthrough.
        """
        try:
            AK, BK, CK, DK = controller
        except (TypeError, ValueError):
            raise ValueError("controller must be an (AK, BK, CK, DK) tuple or DynamicController") from None
        if DK is None:
            DK = np.zeros(self._shapes[3])
        mats = [_mat(n, M, s) for n, M, s in zip(("AK", "BK", "CK", "DK"), (AK, BK, CK, DK), self._shapes)]
        if not self.feedthrough and np.any(mats[3] != 0):
            raise ValueError("DK must be zero: this controller was built with feedthrough=False "
                             "(pass feedthrough=True at construction to allow DK != 0)")
        context.get_mutable_numeric_parameter(self._p_index).SetFromVector(self._pack(mats))

    def gains(self, context):
        """(AK, BK, CK, DK) currently held by ``context``.

        Parameters
        ----------
        context : Context
            This system's context.

        Returns
        -------
        tuple of ndarray
            (AK, BK, CK, DK).
        """
        p, out, k = context.get_numeric_parameter(self._p_index).get_value(), [], 0
        for a, b in self._shapes:
            out.append(p[k:k + a * b].reshape(a, b))
            k += a * b
        return tuple(out)

    def _xk(self, context):
        return context.get_continuous_state_vector().CopyToVector()

    def _dy(self, context):
        y = self._y.Eval(context)
        if self.S is not None:
            y = self.S @ y
        return y - self.y_op

    def DoCalcTimeDerivatives(self, context, derivatives):
        AK, BK, _, _ = self.gains(context)
        derivatives.get_mutable_vector().SetFromVector(AK @ self._xk(context) + BK @ self._dy(context))

    def _raw(self, context):
        _, _, CK, DK = self.gains(context)
        u = self.u_op + CK @ self._xk(context)
        if self.feedthrough:
            u = u + DK @ self._dy(context)
        return u



def controller_system(result, *, x_op=None, u_op=None, y_op=None, S=None, u_min=None,
                      u_max=None):
    """A ready-to-connect Drake system for a synthesized linear controller around an
    operating point.

    The synthesis works in deviations from the operating point (x_op, u_op) at which the
    plant was linearized; this system applies the controller to the absolute signals:

    * state feedback (u = +K x in deviations): u = u_op + K (S x − x_op), a
      :class:`LinearStateFeedback` with input port ``x`` and output ``u``;
    * output feedback (x_K' = A_K x_K + B_K ỹ, u = u_op + C_K x_K + D_K ỹ with
      ỹ = S y − y_op): a :class:`LinearDynamicOutputFeedback` with input port ``y`` and output
      ``u``.  ``y_op`` defaults to ``S @ x_op`` when the connected signal is the plant's state
      and ``S`` selects the measurement (e.g. ``S = C``).

    Parameters
    ----------
    result : SynthesisResult, DynamicController or gain matrix K
        What ``winf_state_feedback``/``winf_output_feedback``/``hinf_*`` returned.
    x_op, u_op : array_like, optional
        Operating point of the linearization (state and input); zero by default.
    y_op : array_like, optional
        Operating point of the measurement (output feedback only).
    S : array_like, optional
        Selection applied to the connected signal (default identity), e.g. the measurement
        matrix C when the plant's full state is connected to an output-feedback controller.
    u_min, u_max : array_like, optional
        Elementwise clipping of u (then an extra output ``u_raw`` is the unclipped command).

    Returns
    -------
    LinearStateFeedback or LinearDynamicOutputFeedback
    """
    kind = getattr(result, "kind", None)
    if kind == "state_feedback" or (kind is None and not hasattr(result, "AK")
                                    and np.ndim(result) == 2):
        K = real_matrix("K" if kind else "result", result.K if kind else result)
        if y_op is not None:
            raise TypeError("y_op is for output feedback; a state-feedback controller takes x_op")
        nu, nx = K.shape   # checked here to name x_op / u_op (LinearStateFeedback says x_r / u_r)
        x_op = None if x_op is None else _mat("x_op", x_op, (1, nx)).ravel()
        u_op = None if u_op is None else _mat("u_op", u_op, (1, nu)).ravel()
        return LinearStateFeedback(K, u_r=u_op, x_r=x_op, S=S, u_min=u_min, u_max=u_max)
    AK, BK, CK, DK = _controller_matrices(result, "result", ", a state-feedback gain matrix K")
    if y_op is None and x_op is not None:
        x_op = real_matrix("x_op", np.atleast_2d(x_op)).ravel()
        if S is None:
            if x_op.size != np.shape(BK)[1]:
                raise ValueError(f"x_op has {x_op.size} entries but the controller measures "
                                 f"{np.shape(BK)[1]} signals: give y_op, or S (the measurement "
                                 "matrix) so that y_op = S x_op")
            y_op = x_op
        else:
            y_op = real_matrix("S", S) @ x_op
    return LinearDynamicOutputFeedback(AK, BK, CK, DK, y_op=y_op, u_op=u_op, S=S, u_min=u_min,
                                       u_max=u_max)
