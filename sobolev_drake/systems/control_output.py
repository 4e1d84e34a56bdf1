"""The command output shared by the library's controller LeafSystems (issue #31).

:class:`ControlOutput` gives a controller written as a ``TemplateSystem`` (so it converts to
AutoDiffXd and Expression) its output ``u`` = clip(command), the unclipped ``u_raw`` when
clipped, and optionally a sampled version of it:

* ``period=None``: continuous, ``u`` is computed from the inputs whenever it is evaluated;
* ``period=T``: at t = k·T the command is computed from the inputs of that instant and held
  until the next sample.  The first command is computed by an initialization event
  (``Simulator.Initialize()`` or ``system.ExecuteInitializationEvents(context)``) from the
  initial inputs, so the controller never starts by holding zero as a ZeroOrderHold in front
  of it would; ``computation_delay=True`` applies each sample's command one period later.

It also accepts Drake's controller port names (``estimated_state``, ``desired_state``,
``control``) as aliases of the controller's own, with the accessors of Drake's
``PidController``, so swapping a Drake controller for a library one is one line.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike
from pydrake.autodiffutils import AutoDiffXd
from pydrake.math import max as _smax, min as _smin
from pydrake.symbolic import Expression
from pydrake.systems.framework import BasicVector_, InputPort, OutputPort

from sobolev_drake.systems.scalar_time import template_signature
from sobolev_drake.validation import positive_scalar

__all__ = ["ControlOutput", "SCALARS", "clip", "template_signature", "value_of", "vector_of"]

#: the non-double scalar types the library's controllers convert to
SCALARS = (AutoDiffXd, Expression)


def vector_of(T: type, values: ArrayLike) -> np.ndarray:
    """``values`` as a vector of scalar type ``T`` (float array, or object array of ``T``).

    Parameters
    ----------
    T : type
        ``float``, ``AutoDiffXd`` or ``Expression``.
    values : array_like
        Numbers (or ``T`` objects).

    Returns
    -------
    ndarray
    """
    values = np.asarray(values).ravel()
    if T is float:
        return values.astype(float)
    return np.array([v if isinstance(v, T) else T(float(v)) for v in values], dtype=object)


def value_of(vector: BasicVector_, T: type) -> np.ndarray:
    """The entries of a ``BasicVector_[T]``: a read-only view for float, a copy otherwise
    (pydrake cannot reference object arrays).

    Parameters
    ----------
    vector : BasicVector_[T]
        A parameter or state vector.
    T : type
        Its scalar type.

    Returns
    -------
    ndarray
    """
    return vector.get_value() if T is float else vector.CopyToVector()


def clip(u: np.ndarray, bounds: tuple[np.ndarray, np.ndarray] | None) -> np.ndarray:
    """``u`` clipped to ``bounds`` = (lo, hi) elementwise (None: unchanged), for any scalar type
    (Drake's ``min``/``max`` for AutoDiffXd and Expression).

    Parameters
    ----------
    u : ndarray
        Command (float or object array).
    bounds : (ndarray, ndarray) or None
        Lower and upper bounds (infinite ends allowed).

    Returns
    -------
    ndarray
    """
    if bounds is None:
        return u
    if u.dtype != object:
        return np.clip(u, *bounds)
    out = u.copy()
    for i, (lo, hi) in enumerate(zip(*bounds)):
        out[i] = _smin(out[i], hi) if np.isfinite(hi) else out[i]
        out[i] = _smax(out[i], lo) if np.isfinite(lo) else out[i]
    return out


class ControlOutput:
    """Mixin of the library's controller LeafSystems: the output ``u`` (clipped, with ``u_raw``)
    of the command ``self._command(context)``, continuous or sampled with a first sample at
    initialization and an optional one-sample delay, and Drake's controller port names.

    A subclass calls :meth:`_control_output` in its constructor and may override
    ``_advance(context, discrete_state)`` (called after each periodic sample, e.g. to step a
    controller state).
    """

    #: Drake's controller port names -> this system's
    _drake_names = {"estimated_state": "x", "desired_state": "x_r", "control": "u"}

    def _control_output(self, T, nu, *, bounds, period, computation_delay, prerequisites,
                        hold0=None):
        self._T, self._nu, self._bounds = T, nu, bounds
        self.period = None if period is None else positive_scalar("period", period)
        if not isinstance(computation_delay, (bool, np.bool_)):
            raise TypeError(f"computation_delay must be True or False, got {computation_delay!r}")
        if computation_delay and self.period is None:
            raise ValueError("computation_delay=True needs a sample period: give period (s)")
        self.computation_delay = bool(computation_delay)
        raw = self._command
        if self.period is not None:
            hold0 = np.zeros(nu) if hold0 is None else hold0
            self._hold = self.DeclareDiscreteState(
                BasicVector_[T](vector_of(T, np.tile(hold0, 1 + self.computation_delay))))
            self.DeclarePeriodicDiscreteUpdateEvent(self.period, 0.0, self._sample)
            self.DeclareInitializationDiscreteUpdateEvent(self._first_sample)
            prerequisites = {self.xd_ticket()}

            def raw(context):
                return value_of(context.get_discrete_state(self._hold), T)[:nu]

        def calc_u(context, output):
            if T is float:   # the hot path of a simulation: no wrapper
                output.SetFromVector(clip(raw(context), bounds))
            else:
                output.SetFromVector(self._scalar_math(lambda: clip(raw(context), bounds)))

        def calc_raw(context, output):
            output.SetFromVector(self._scalar_math(lambda: raw(context)))
        self.DeclareVectorOutputPort("u", nu, calc_u, prerequisites_of_calc=prerequisites)
        if bounds is not None:
            self.DeclareVectorOutputPort("u_raw", nu, calc_raw, prerequisites_of_calc=prerequisites)

    def _scalar_math(self, compute):
        """``compute()``, for AutoDiffXd / Expression with NumPy's floating-point warnings off:
        NumPy reads the processor's status flags after an object-array loop, so a flag left
        by earlier native code surfaces as a spurious "invalid value" warning there."""
        if self._T is float:
            return compute()
        with np.errstate(all="ignore"):
            return compute()

    def _sample(self, context, discrete_state):
        self._scalar_math(lambda: self._do_sample(context, discrete_state))

    def _do_sample(self, context, discrete_state):
        u = self._command(context)
        if self.computation_delay:   # apply the previous sample's command, keep this one
            u = np.concatenate([context.get_discrete_state(self._hold).CopyToVector()[self._nu:], u])
        discrete_state.get_mutable_vector(self._hold).SetFromVector(u)
        self._advance(context, discrete_state)

    def _first_sample(self, context, discrete_state):
        u = self._scalar_math(lambda: self._command(context))
        discrete_state.get_mutable_vector(self._hold).SetFromVector(
            np.concatenate([u] * (1 + self.computation_delay)))

    def _advance(self, context, discrete_state):
        """Hook after each periodic sample (nothing by default)."""

    def _drake_name(self, name, has):
        target = self._drake_names.get(name)
        return target if target is not None and has(target) else name

    def GetInputPort(self, port_name: str) -> InputPort:  # noqa: N802  (Drake's name)
        return super().GetInputPort(self._drake_name(port_name, super().HasInputPort))

    def GetOutputPort(self, port_name: str) -> OutputPort:  # noqa: N802
        return super().GetOutputPort(self._drake_name(port_name, super().HasOutputPort))

    def HasInputPort(self, port_name: str) -> bool:  # noqa: N802
        return super().HasInputPort(self._drake_name(port_name, super().HasInputPort))

    def HasOutputPort(self, port_name: str) -> bool:  # noqa: N802
        return super().HasOutputPort(self._drake_name(port_name, super().HasOutputPort))

    def get_input_port_estimated_state(self) -> InputPort:
        """The measured-signal input (Drake's ``estimated_state``: ``x``, or ``y``).

        Returns
        -------
        InputPort
        """
        return self.GetInputPort("estimated_state")

    def get_input_port_desired_state(self) -> InputPort:
        """The reference input ``x_r`` (Drake's ``desired_state``; needs ``reference_port``).

        Returns
        -------
        InputPort
        """
        return self.GetInputPort("desired_state")

    def get_output_port_control(self) -> OutputPort:
        """The command output ``u`` (Drake's ``control``).

        Returns
        -------
        OutputPort
        """
        return self.GetOutputPort("control")
