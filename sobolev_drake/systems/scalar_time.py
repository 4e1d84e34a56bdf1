"""Scalar-type-generic helpers for the time-driven sources (float, AutoDiffXd, Expression).

A scalar-convertible Python LeafSystem (pydrake's ``TemplateSystem``) computes its outputs
with T = float, ``AutoDiffXd`` or ``symbolic.Expression``.  The sources of this package branch
on the time (pulse windows, trajectory pieces, gust ramps).  These helpers take the branch:

* float and AutoDiffXd: on the value (AutoDiffXd keeps the derivatives of the branch taken;
  an indicator's derivative is 0, as almost everywhere);
* Expression: a symbolic ``if_then_else`` (Drake folds it to the branch taken when the time is
  a constant, and keeps the whole piecewise expression when it has free variables, as for
  ``SystemSymbolicInspector``).
"""

from __future__ import annotations

import inspect
import math
from bisect import bisect_left
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import pydrake.math as dm
from pydrake.autodiffutils import AutoDiffXd
from pydrake.symbolic import Expression, if_then_else, logical_and

#: a scalar of any of Drake's types (for the hints of the scalar-generic functions)
Scalar = float | AutoDiffXd | Expression

__all__ = ["Scalar", "scalar_value", "is_symbolic", "interval_indicator", "piece_index", "piecewise",
           "smooth_window", "probe_scalar_type", "template_signature"]


def is_symbolic(x: Scalar) -> bool:
    """True if ``x`` is a ``symbolic.Expression`` (or a Variable's expression).

    Parameters
    ----------
    x : float, AutoDiffXd or Expression
        A scalar.

    Returns
    -------
    bool
    """
    return isinstance(x, Expression)


def scalar_value(x: Scalar, name: str = "time") -> float:
    """The float value of a scalar of any Drake type (an AutoDiffXd's value, a constant
    Expression evaluated).

    Parameters
    ----------
    x : float, AutoDiffXd or Expression
        The scalar.
    name : str, default "time"
        Its name in the error message.

    Returns
    -------
    float

    Raises
    ------
    ValueError
        For an Expression with free variables (it has no value).
    """
    if isinstance(x, AutoDiffXd):
        return x.value()
    if isinstance(x, Expression):
        if not x.GetVariables().empty():
            raise ValueError(f"{name} must be a constant to be used as a number here, got the "
                             f"symbolic expression {x} (free variables {x.GetVariables()})")
        return x.Evaluate()
    return float(x)


def interval_indicator(t: Scalar, lo: float, hi: float,
                       closed: tuple[bool, bool] = (True, True)) -> float | Expression:
    """1 if ``t`` lies between ``lo`` and ``hi``, else 0, for t of any scalar type.

    Parameters
    ----------
    t : float, AutoDiffXd or Expression
        The time.
    lo, hi : float
        Ends (±inf allowed: that side is open-ended).
    closed : (bool, bool), default (True, True)
        Whether each end belongs to the interval.

    Returns
    -------
    float or Expression
        1.0/0.0 for a numeric t; an ``if_then_else`` expression for a symbolic t.
    """
    if isinstance(t, Expression):
        conditions = []
        if lo > -math.inf:
            conditions.append(t >= lo if closed[0] else t > lo)
        if hi < math.inf:
            conditions.append(t <= hi if closed[1] else t < hi)
        if not conditions:
            return Expression(1.0)
        cond = conditions[0] if len(conditions) == 1 else logical_and(*conditions)
        return if_then_else(cond, Expression(1.0), Expression(0.0))
    v = scalar_value(t)
    above = lo < v or (closed[0] and v == lo)
    below = v < hi or (closed[1] and v == hi)
    return 1.0 if (above and below) else 0.0


def piece_index(t_value: float, breakpoints: Sequence[float]) -> int:
    """Index k of the piece containing ``t_value``: piece k covers (b_{k−1}, b_k].

    Parameters
    ----------
    t_value : float
        Numeric time.
    breakpoints : sequence of float
        Increasing breakpoints b_0 < b_1 < … (K − 1 of them for K pieces).

    Returns
    -------
    int
    """
    return bisect_left(breakpoints, t_value)


def piecewise(t: Scalar, breakpoints: Sequence[float], values: Sequence[Any]) -> Any:
    """``values[k]`` on (b_{k−1}, b_k] (the last for t beyond the last breakpoint).

    Parameters
    ----------
    t : float, AutoDiffXd or Expression
        The time.
    breakpoints : sequence of float
        K − 1 increasing breakpoints.
    values : sequence
        K values (scalars, or arrays of one shape combined elementwise), or K callables of no
        argument returning them (only the piece taken is called for a numeric t).

    Returns
    -------
    object
        The value of the piece containing t; for a symbolic t an ``if_then_else`` chain
        (elementwise for arrays).
    """
    def get(k):
        return values[k]() if callable(values[k]) else values[k]

    if not isinstance(t, Expression):
        return get(piece_index(scalar_value(t), breakpoints))
    result = np.asarray(get(len(values) - 1), dtype=object)
    for k in range(len(values) - 2, -1, -1):
        cond = t <= breakpoints[k]
        here = np.asarray(get(k), dtype=object)
        result = np.array([if_then_else(cond, _expression(a), _expression(b))
                           for a, b in zip(here.ravel(), result.ravel())],
                          dtype=object).reshape(here.shape)
    return result[()] if result.ndim == 0 else result


def smooth_window(t: Scalar, t0: float, t1: float, rise: float) -> Scalar:
    """1 on [t0, t1], else 0; with rise > 0, half-cosine ramps of length ``rise`` centred on t0
    and t1 (the window's integral stays t1 − t0), for t of any scalar type.

    Parameters
    ----------
    t : float, AutoDiffXd or Expression
        The time.
    t0, t1 : float
        Start and end (t0 < t1).
    rise : float
        Ramp length (0: a rectangular window, closed at both ends).

    Returns
    -------
    float, AutoDiffXd or Expression
    """
    if rise <= 0.0:
        return interval_indicator(t, t0, t1)
    if isinstance(t, float):   # fast path of the generic steps below

        def step(x):   # smooth step 0 → 1 over [−rise/2, rise/2]
            if x <= -0.5 * rise:
                return 0.0
            return 1.0 if x >= 0.5 * rise else 0.5 - 0.5 * math.cos(math.pi * (x / rise + 0.5))

        return step(t - t0) - step(t - t1)

    def step_any(c):   # the ramp equals the constants at both of its ends
        def ramp():
            return 0.5 - 0.5 * dm.cos(math.pi * ((t - c) / rise + 0.5))
        return piecewise(t, [c - 0.5 * rise, c + 0.5 * rise], [0.0, ramp, 1.0])

    return step_any(t0) - step_any(t1)


def _expression(x) -> Expression:
    return x if isinstance(x, Expression) else Expression(float(x))


def probe_scalar_type(T: type, system: str, what: str, fn: Callable[[Any], Any], t: float,
                      advice: str) -> None:
    """Call ``fn(T(t))`` and turn a failure into a clear refusal to convert ``system`` to T.

    A scalar-convertible system holding user callables calls this when it is converted, so a
    function written for floats only (``math.sin``, ``float(t)``, ``if t > 5``) is refused at
    ``ToAutoDiffXd()``/``ToSymbolic()`` rather than at the first evaluation.

    Parameters
    ----------
    T : type
        The scalar type (``AutoDiffXd`` or ``Expression``).
    system : str
        The system's class name, for the message.
    what : str
        The callable's description (which argument, which entry).
    fn : callable
        The callable of time.
    t : float
        A time at which ``fn`` is defined.
    advice : str
        What to do instead.

    Raises
    ------
    TypeError
        Naming the system, the callable, the exception it raised and ``advice``.
    """
    try:
        np.asarray(fn(T(t)), dtype=object)
    except Exception as exc:
        raise TypeError(f"{system} cannot be converted to scalar type {T.__name__}: {what} fails on a "
                        f"{T.__name__} time ({type(exc).__name__}: {exc}); {advice}") from exc


def template_signature(construct: Callable[..., Any]) -> inspect.Signature:
    """The user-facing signature of a ``TemplateSystem`` class (its ``_construct`` without
    ``self`` and ``converter``), for ``help`` and ``inspect.signature``.

    pydrake replaces the class's ``__init__`` by ``(*args, **kwargs)``; assign this to the
    class's ``__signature__`` so the constructor arguments stay visible.

    Parameters
    ----------
    construct : callable
        The class's ``_construct(self, ..., converter=None)``.

    Returns
    -------
    inspect.Signature
    """
    sig = inspect.signature(construct)
    return sig.replace(parameters=[p for n, p in sig.parameters.items()
                                   if n not in ("self", "converter")])
