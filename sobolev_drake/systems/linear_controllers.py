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

Both are ``TemplateSystem`` s: ``ToAutoDiffXd()``, ``ToSymbolic()`` and Drake's ``Linearize``
work on them and on diagrams holding them (a converted system starts from the construction
gains; ``Linearize(diagram, context)`` copies those of ``context``).  Drake's ``LinearSystem``
(``DynamicController.to_drake()``) converts too, but holds its matrices in the system, not
the context, and neither clips nor samples.

``period`` (None: continuous) samples the controller: at t = k·period the command is computed
from the inputs at that instant and held until the next sample (a state-space controller
advances by its zero-order-hold discretization, exact for the held measurement).  The first
command is computed by an initialization event (``Simulator.Initialize()`` or
``system.ExecuteInitializationEvents(context)``) from the initial inputs, not held at zero as by
a ZeroOrderHold in front of a controller; before it, the held command is the operating-point
input.  ``computation_delay=True`` applies each sample's command one period later (at [0, T)
and [T, 2T) the command computed at t = 0).

Drake's controller port names are aliases (``estimated_state`` is ``x`` / ``y``,
``desired_state`` is ``x_r``, ``control`` is ``u``, with the ``get_input_port_...`` methods of
Drake's ``PidController``): swapping one for the other is one line.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike
import scipy.linalg
from pydrake.systems.framework import BasicVector_, Context, ContinuousState, LeafSystem_
from pydrake.systems.scalar_conversion import TemplateSystem

from sobolev_drake.systems.control_output import ControlOutput, template_signature, value_of, vector_of
from sobolev_drake.synthesis.problem import DynamicController, SynthesisResult
from sobolev_drake.validation import bounds_pair, positive_scalar, real_matrix

__all__ = ["LinearStateFeedback", "LinearDynamicOutputFeedback", "controller_system"]


def _mat(name, M, shape=None):
    return real_matrix(name, M, shape, allow_empty=True)


def _bounds(nu, u_min, u_max):
    """Elementwise (lo, hi) of size nu, or None without bounds."""
    if u_min is None and u_max is None:
        return None
    return bounds_pair("u_min", -np.inf if u_min is None else u_min,
                       "u_max", np.inf if u_max is None else u_max, nu)


def _selection(S, n):
    """Selection matrix S (n x m) or None (identity, m = n); returns (S or None, m)."""
    S = None if S is None else _mat("S", S, (n, None))
    return S, n if S is None else S.shape[1]


@TemplateSystem.define("LinearStateFeedback_")
def LinearStateFeedback_(T):  # noqa: N802  (Drake's template naming)
    """LinearStateFeedback for scalar type T (``LinearStateFeedback`` is the float one)."""

    class Impl(ControlOutput, LeafSystem_[T]):
        """u = u_r + K (S x - x_r) with constant u_r (operating point) and x_r (port or constant).

        .. pydrake_system::

            name: LinearStateFeedback
            input_ports:
            - x (alias estimated_state)
            - x_r (alias desired_state; with reference_port)
            output_ports:
            - u (alias control)
            - u_raw (with u_min or u_max)

        K is stored in a numeric parameter (default: the ``K`` given here), so one diagram can
        serve a gain sweep: :meth:`set_gains` writes new gains into a context.  ``S`` (nx x m,
        default the identity) selects the linear-model state from the m-vector on port ``x``.
        With ``u_min`` / ``u_max`` the output ``u`` is clipped elementwise and a second output
        ``u_raw`` gives the unclipped command (e.g. to measure saturation).  Converts to
        AutoDiffXd and Expression; ``period`` samples it (module docstring).

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
        period : float, optional
            Sample period (s) of a sampled controller; None (default) for a continuous one.
        computation_delay : bool, default False
            With ``period``: apply each sample's command one period later.
        """

        def _construct(self, K, *, u_r=None, x_r=None, reference_port=False, u_min=None,
                       u_max=None, S=None, period=None, computation_delay=False, converter=None):
            LeafSystem_[T].__init__(self, converter)
            self._kw = dict(u_r=u_r, x_r=x_r, reference_port=reference_port, u_min=u_min,
                            u_max=u_max, S=S, period=period, computation_delay=computation_delay)
            self.K = real_matrix("K", K)
            nu, nx = self.K.shape
            self.S, nin = _selection(S, nx)
            self.u_r = np.zeros(nu) if u_r is None else _mat("u_r", u_r, (1, nu)).ravel()
            self.x_r = np.zeros(nx) if x_r is None else _mat("x_r", x_r, (1, nx)).ravel()
            self._K_index = self.DeclareNumericParameter(BasicVector_[T](vector_of(T, self.K)))
            self._x = self.DeclareVectorInputPort("x", nin)
            self._xr = self.DeclareVectorInputPort("x_r", nx) if reference_port else None
            # exact prerequisites: Drake then needs no symbolic sparsity analysis at Build()
            prereq = {self.input_port_ticket(p.get_index()) for p in (self._x, self._xr) if p is not None}
            self._control_output(T, nu, bounds=_bounds(nu, u_min, u_max), period=period,
                                 computation_delay=computation_delay, hold0=self.u_r,
                                 prerequisites=prereq | {self.all_parameters_ticket()})

        def _construct_copy(self, other, converter=None):
            Impl._construct(self, other.K, converter=converter, **other._kw)

        def set_gains(self, context: Context, K: ArrayLike) -> None:
            """Write K (shape nu x nx) into this system's parameter in ``context`` (its own
            context).

            Parameters
            ----------
            context : Context
                This system's context.
            K : array_like, shape (nu, nx)
                The new gain.
            """
            K = _mat("K", K, self.K.shape)
            context.get_mutable_numeric_parameter(self._K_index).SetFromVector(vector_of(T, K))

        def gains(self, context: Context) -> np.ndarray:
            """The gain matrix K currently held by ``context``.

            Parameters
            ----------
            context : Context
                This system's context.

            Returns
            -------
            ndarray, shape (nu, nx)
            """
            return value_of(context.get_numeric_parameter(self._K_index), T).reshape(self.K.shape)

        def _command(self, context):
            x = self._x.Eval(context)
            if self.S is not None:
                x = self.S @ x
            xr = self._xr.Eval(context) if self._xr is not None else self.x_r
            return self.u_r + self.gains(context) @ (x - xr)

    Impl.__signature__ = template_signature(Impl._construct)
    return Impl


LinearStateFeedback = LinearStateFeedback_[None]


def _continuous(name, obj):
    """Refuse a discrete-time result or controller (run as continuous it is another one)."""
    if getattr(obj, "dt", 0):
        raise TypeError(f"{name} is discrete-time (dt = {obj.dt}): use sd.discrete_controller_system")


def _controller_matrices(controller, name="controller", accepted=""):
    """(AK, BK, CK, DK) of a DynamicController, an output-feedback SynthesisResult or a tuple
    (``name`` and ``accepted``, further accepted kinds, for the message)."""
    kind = getattr(controller, "kind", None)
    if kind == "state_feedback":
        raise TypeError("from_controller got a state-feedback SynthesisResult (u = K x); "
                        "wire it with LinearStateFeedback(result.K) instead")
    if kind is not None:
        controller = controller.controller
    _continuous(name, controller)
    try:
        AK, BK, CK, DK = controller
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a DynamicController, an output-feedback "
                        f"SynthesisResult{accepted} or an (AK, BK, CK, DK) tuple, got "
                        f"{type(controller).__name__}") from None
    return AK, BK, CK, DK


@TemplateSystem.define("LinearDynamicOutputFeedback_")
def LinearDynamicOutputFeedback_(T):  # noqa: N802  (Drake's template naming)
    """LinearDynamicOutputFeedback for scalar type T (the float one is the default)."""

    class Impl(ControlOutput, LeafSystem_[T]):
        """Full-order dynamic controller (AK, BK, CK, DK) around operating points (y_op, u_op).

        .. pydrake_system::

            name: LinearDynamicOutputFeedback
            input_ports:
            - y (alias estimated_state)
            output_ports:
            - u (alias control)
            - u_raw (with u_min or u_max)

        The four matrices are stored in one numeric parameter (defaults: the matrices given
        here); :meth:`set_gains` writes a new controller of the same order and sizes into a
        context.  ``feedthrough`` (default: DK given here is nonzero) fixes at construction
        whether ``u`` may depend directly on ``y``; a system built without it rejects gains
        with DK != 0, so the declared dependency (no algebraic loop) stays true.  ``S`` (ny x m,
        default identity) maps the m-vector on port ``y`` to the controller's measurement.
        ``u_min`` / ``u_max`` clip ``u`` (then ``u_raw`` is the unclipped command).  ``x0`` is
        the default controller state.  With ``period`` the controller state is discrete and
        advances by the zero-order-hold discretization of (AK, BK), kept in the parameter
        beside the continuous matrices (``set_gains`` recomputes it).  Converts to AutoDiffXd
        and Expression.

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
        period : float, optional
            Sample period (s) of a sampled controller; None (default) for a continuous one.
        computation_delay : bool, default False
            With ``period``: apply each sample's command one period later.
        """

        _drake_names = {"estimated_state": "y", "control": "u"}

        def _construct(self, AK, BK, CK, DK=None, *, y_op=None, u_op=None, x0=None, S=None,
                       feedthrough=None, u_min=None, u_max=None, period=None,
                       computation_delay=False, converter=None):
            LeafSystem_[T].__init__(self, converter)
            self._args = (AK, BK, CK, DK)
            self._kw = dict(y_op=y_op, u_op=u_op, x0=x0, S=S, feedthrough=feedthrough,
                            u_min=u_min, u_max=u_max, period=period,
                            computation_delay=computation_delay)
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
            if feedthrough is not None and not isinstance(feedthrough, (bool, np.bool_)):
                raise TypeError(f"feedthrough must be None, True or False, got {feedthrough!r}")
            self.feedthrough = (bool(np.any(self.DK != 0)) if feedthrough is None
                                else bool(feedthrough))
            if not self.feedthrough and np.any(self.DK != 0):
                raise ValueError("DK must be zero when feedthrough=False (u would depend on y "
                                 "directly)")
            self.period = None if period is None else positive_scalar("period", period)
            self._p_index = self.DeclareNumericParameter(BasicVector_[T](vector_of(T, self._pack(
                (self.AK, self.BK, self.CK, self.DK)))))
            self._y = self.DeclareVectorInputPort("y", nin)
            if self.period is None:
                self.DeclareContinuousState(BasicVector_[T](vector_of(T, x0)))
            else:
                self._xk_index = self.DeclareDiscreteState(BasicVector_[T](vector_of(T, x0)))
            # without feedthrough u depends on the controller state (and parameters) only
            prereq = {self.xc_ticket(), self.all_parameters_ticket()}
            if self.feedthrough:
                prereq.add(self.input_port_ticket(self._y.get_index()))
            self._control_output(T, nu, bounds=_bounds(nu, u_min, u_max), period=period,
                                 computation_delay=computation_delay, prerequisites=prereq,
                                 hold0=self.u_op)

        def _construct_copy(self, other, converter=None):
            Impl._construct(self, *other._args, converter=converter, **other._kw)

        @classmethod
        def from_controller(cls,
                            controller: DynamicController | SynthesisResult | tuple[ArrayLike, ...],
                            **kw: Any) -> LinearDynamicOutputFeedback:
            """From a synthesis ``DynamicController``, an output-feedback ``SynthesisResult`` or
            any (AK, BK, CK, DK) iterable.

            Parameters
            ----------
            controller : DynamicController, SynthesisResult or tuple
                The controller (a state-feedback result raises ``TypeError``).
            **kw
                Keyword arguments of the constructor (``y_op``, ``u_op``, ``x0``, ``S``,
                ``feedthrough``, ``u_min``, ``u_max``, ``period``, ``computation_delay``).

            Returns
            -------
            LinearDynamicOutputFeedback
            """
            return cls(*_controller_matrices(controller), **kw)

        def _pack(self, mats):
            """The parameter vector: AK, BK, CK, DK (and, sampled, the ZOH Ad, Bd of AK, BK)."""
            mats = tuple(np.asarray(m, dtype=float) for m in mats)
            if self.period is not None:
                nk, ny = self._shapes[1]
                E = scipy.linalg.expm(np.block([[mats[0], mats[1]], [np.zeros((ny, nk + ny))]])
                                      * self.period)
                mats += (E[:nk, :nk], E[:nk, nk:])
            return np.concatenate([m.ravel() for m in mats])

        def set_gains(self, context: Context,
                      controller: DynamicController | tuple[ArrayLike | None, ...]) -> None:
            """Write ``controller`` = (AK, BK, CK, DK) (a ``DynamicController`` or any iterable;
            DK may be None for 0) into this system's parameter in ``context`` (its own context).

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
                raise ValueError("controller must be an (AK, BK, CK, DK) tuple or "
                                 f"DynamicController, got {type(controller).__name__}") from None
            if DK is None:
                DK = np.zeros(self._shapes[3])
            mats = [_mat(n, M, s) for n, M, s in zip(("AK", "BK", "CK", "DK"), (AK, BK, CK, DK),
                                                      self._shapes)]
            if not self.feedthrough and np.any(mats[3] != 0):
                raise ValueError("DK must be zero: this controller was built with "
                                 "feedthrough=False (pass feedthrough=True at construction to "
                                 "allow DK != 0)")
            context.get_mutable_numeric_parameter(self._p_index).SetFromVector(
                vector_of(T, self._pack(mats)))

        def _blocks(self, context):
            p, out, k = value_of(context.get_numeric_parameter(self._p_index), T), [], 0
            shapes = self._shapes + ((self._shapes[0], self._shapes[1]) if self.period else ())
            for a, b in shapes:
                out.append(p[k:k + a * b].reshape(a, b))
                k += a * b
            return out

        def gains(self, context: Context) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
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
            return tuple(self._blocks(context)[:4])

        def _xk(self, context):
            if self.period is None:
                return context.get_continuous_state_vector().CopyToVector()
            return context.get_discrete_state(self._xk_index).CopyToVector()

        def _dy(self, context):
            y = self._y.Eval(context)
            if self.S is not None:
                y = self.S @ y
            return y - self.y_op

        def DoCalcTimeDerivatives(self, context: Context,  # noqa: N802
                                  derivatives: ContinuousState) -> None:
            if self.period is None:
                AK, BK, _, _ = self.gains(context)
                derivatives.get_mutable_vector().SetFromVector(self._scalar_math(
                    lambda: AK @ self._xk(context) + BK @ self._dy(context)))

        def _advance(self, context, discrete_state):
            Ad, Bd = self._blocks(context)[4:]
            discrete_state.get_mutable_vector(self._xk_index).SetFromVector(
                Ad @ self._xk(context) + Bd @ self._dy(context))

        def _command(self, context):
            _, _, CK, DK = self.gains(context)
            u = self.u_op + CK @ self._xk(context)
            if self.feedthrough:
                u = u + DK @ self._dy(context)
            return u

    Impl.__signature__ = template_signature(Impl._construct)
    return Impl


LinearDynamicOutputFeedback = LinearDynamicOutputFeedback_[None]


def controller_system(result: SynthesisResult | DynamicController | ArrayLike, *,
                      x_op: ArrayLike | None = None, u_op: ArrayLike | None = None,
                      y_op: ArrayLike | None = None, S: ArrayLike | None = None,
                      u_min: ArrayLike | None = None, u_max: ArrayLike | None = None,
                      period: float | None = None, computation_delay: bool = False
                      ) -> LinearStateFeedback | LinearDynamicOutputFeedback:
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

    Both convert to AutoDiffXd and Expression (Drake's ``Linearize`` of a closed loop works)
    and answer to Drake's port names ``estimated_state`` and ``control``.

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
    period : float, optional
        Sample period (s): a sampled controller whose first command is computed at
        initialization (see the module docstring); None (default) for a continuous one.
    computation_delay : bool, default False
        With ``period``: apply each sample's command one period later.

    Returns
    -------
    LinearStateFeedback or LinearDynamicOutputFeedback

    Examples
    --------
    A W∞ gain of a mass-spring-damper linearized at x_op = (1, 0), u_op = 1:

    >>> import numpy as np
    >>> import sobolev_drake as sd
    >>> A, B = [[0, 1], [-1, -0.5]], [[0], [1]]
    >>> res = sd.winf_state_feedback(A, B, np.eye(2), Gamma0=[1, 1], Gamma1=[0.1, 0.1], gamma=2.0)
    >>> controller = sd.controller_system(res, x_op=[1.0, 0.0], u_op=[1.0])
    >>> context = controller.CreateDefaultContext()
    >>> _ = controller.GetInputPort("x").FixValue(context, [1.1, 0.0])
    >>> controller.GetOutputPort("u").Eval(context).round(4)      # u_op + K (x − x_op)
    array([0.6925])
    """
    sampling = dict(period=period, computation_delay=computation_delay)
    _continuous("result", result)
    kind = getattr(result, "kind", None)
    try:
        matrix = kind is None and not hasattr(result, "AK") and np.ndim(result) == 2
    except ValueError:   # a ragged (AK, BK, CK, DK) tuple
        matrix = False
    if kind == "state_feedback" or matrix:
        K = real_matrix("K" if kind else "result", result.K if kind else result)
        if y_op is not None:
            raise TypeError("y_op is for output feedback; a state-feedback controller takes x_op")
        nu, nx = K.shape   # checked here to name x_op / u_op (LinearStateFeedback says x_r / u_r)
        x_op = None if x_op is None else _mat("x_op", x_op, (1, nx)).ravel()
        u_op = None if u_op is None else _mat("u_op", u_op, (1, nu)).ravel()
        return LinearStateFeedback(K, u_r=u_op, x_r=x_op, S=S, u_min=u_min, u_max=u_max,
                                   **sampling)
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
                                       u_max=u_max, **sampling)
