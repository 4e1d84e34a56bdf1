"""Scalar types of the tilt-rotor's Drake systems: double, AutoDiffXd and symbolic Expression.

The force and controller systems are ``TemplateSystem``s (``pydrake.systems.scalar_conversion``):
``ToAutoDiffXd()`` and ``ToSymbolic()`` work on them and on diagrams holding them, so Drake's
``Linearize``, ``LinearQuadraticRegulator(system, context, Q, R)`` and the symbolic inspection
apply.  The double instantiation keeps its float (and compiled) fast path; the other scalar
types run the scalar-generic cores, written once with the functions of a :class:`ScalarMath`:

* float — ``math`` and plain Python branches (used to test the generic cores against the float
  tier);
* AutoDiffXd — Drake's overloads; a branch is decided on the value, so a value carries the
  derivative of the active piece (e.g. the slope of the active segment of an interpolated
  table; exactly on a kink, the central derivative where the cores provide it);
* Expression — Drake's overloads, branches as ``if_then_else`` (decided at once when the
  condition is constant), tables as a tree of ``if_then_else`` over their segments.

:func:`default_instantiation` gives the double instantiation the public name and the
constructor signature (for ``help()`` and the docstring checks).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, NoReturn

import numpy as np
import pydrake.math as dm
from pydrake.autodiffutils import AutoDiffXd
from pydrake.symbolic import Expression, ExpressionKind, Formula, Variable, if_then_else

from sobolev_drake.systems.scalar_time import Scalar, template_signature

if TYPE_CHECKING:
    from pydrake.systems.scalar_conversion import TemplateSystem

__all__ = ["Scalar", "ScalarMath", "scalar_math", "default_instantiation", "DoubleOnly"]


class ScalarMath:
    """Functions of one scalar type for the scalar-generic cores.

    ``sin, cos, sqrt, atan2, asin, abs`` are the type's overloads; :meth:`where` selects a branch;
    :meth:`value` drops the derivatives (AutoDiffXd) and keeps the rest; :meth:`lerp_rows`
    interpolates a table.

    Parameters
    ----------
    kind : {"float", "autodiff", "symbolic"}
        The scalar type: Python float, ``AutoDiffXd`` or ``symbolic.Expression``.
    """

    KINDS = ("float", "autodiff", "symbolic")

    def __init__(self, kind: str) -> None:
        if kind not in self.KINDS:
            raise ValueError(f"kind must be one of {self.KINDS}, got {kind!r}")
        self.kind = kind
        lib = math if kind == "float" else dm
        self.sin, self.cos, self.sqrt = lib.sin, lib.cos, lib.sqrt
        self.atan2, self.asin = lib.atan2, lib.asin
        self.abs = abs if kind == "float" else dm.abs
        self._trees: dict = {}

    def __repr__(self):
        return f"ScalarMath({self.kind!r})"

    def where(self, condition: bool | np.bool_ | Formula, if_true: Scalar, if_false: Scalar) -> Scalar:
        """``if_true`` where ``condition`` holds, else ``if_false`` (both are evaluated).

        Parameters
        ----------
        condition : bool or Formula
            The comparison (a Formula only for Expression).
        if_true, if_false : scalar
            The two branches.

        Returns
        -------
        scalar
            The chosen branch; an ``if_then_else`` Expression for a symbolic condition.
        """
        if isinstance(condition, (bool, int, np.bool_)) or self.kind != "symbolic":
            return if_true if condition else if_false
        return if_then_else(condition, if_true, if_false)

    def value(self, x: Scalar) -> Scalar:
        """``x`` without derivatives: the float value of an AutoDiffXd, ``x`` otherwise.

        Parameters
        ----------
        x : scalar
            A value of this scalar type (or a float).

        Returns
        -------
        scalar
        """
        return x.value() if isinstance(x, AutoDiffXd) else x

    def lerp_rows(self, rows: Sequence[tuple[float, ...]], x: Scalar,
                  imax: int) -> tuple[Scalar, ...]:
        """Linear interpolation of a table at the sample coordinate ``x`` ∈ [0, imax + 1].

        The float arithmetic is the one of the float tier (``AeroModel.loads_scalar``):
        segment ``i = min(⌊x⌋, imax)``, ``r_i + (x − i)(r_{i+1} − r_i)``.  An AutoDiffXd ``x``
        carries the slope of the active segment, and on an interior sample (a kink) the
        central slope ½(r_{i+1} − r_{i−1}), which a central difference sees; a symbolic ``x``
        with variables gives a balanced ``if_then_else`` tree over the segments.

        Parameters
        ----------
        rows : sequence of tuples
            Samples ``rows[i]`` (each a tuple of coefficients), ``imax + 2`` of them.
        x : scalar
            Sample coordinate, already clipped to [0, imax + 1].
        imax : int
            Index of the last segment.

        Returns
        -------
        tuple
            The interpolated coefficients.
        """
        if self.kind == "symbolic" and isinstance(x, Expression):
            if x.get_kind() != ExpressionKind.Constant:
                return self._lerp_tree(rows, x, imax)
            x = x.Evaluate()
        i = int(self.value(x))
        i = i if i <= imax else imax
        fr = x - i
        r0, r1 = rows[i], rows[i + 1]
        out = tuple(a + fr * (b - a) for a, b in zip(r0, r1))
        if isinstance(fr, AutoDiffXd) and fr.value() == 0.0 and i > 0:
            # on an interior sample (e.g. zero sideslip, a node of the β tables) the central
            # slope ½(r_{i+1} − r_{i−1}), as a central difference would see it
            dx = x.derivatives()
            out = tuple(AutoDiffXd(o.value(), dx * (0.5 * (b - c)))
                        for o, b, c in zip(out, r1, rows[i - 1]))
        return out

    def _lerp_tree(self, rows, x, imax):
        key = (id(rows), imax)
        if key not in self._trees:                 # built once per table over a placeholder
            t = Variable("t")
            te = Expression(t)

            def node(lo, hi, k):                   # segments lo..hi-1, coefficient k
                if hi - lo == 1:
                    a, b = rows[lo][k], rows[lo + 1][k]
                    return a + (te - lo) * (b - a)
                mid = (lo + hi) // 2
                return if_then_else(te < mid, node(lo, mid, k), node(mid, hi, k))

            self._trees[key] = (t, rows, [node(0, imax + 1, k) for k in range(len(rows[0]))])
        t, _, trees = self._trees[key]
        return tuple(tree.Substitute(t, x) for tree in trees)


_MATH = {"float": ScalarMath("float"), "autodiff": ScalarMath("autodiff"),
         "symbolic": ScalarMath("symbolic")}


def scalar_math(T: type) -> ScalarMath:
    """The :class:`ScalarMath` of a template parameter.

    Parameters
    ----------
    T : type
        ``float``, ``AutoDiffXd`` or ``Expression``.

    Returns
    -------
    ScalarMath
        Shared instance (it caches the symbolic table trees).
    """
    kinds = {float: "float", AutoDiffXd: "autodiff", Expression: "symbolic"}
    if T not in kinds:
        raise ValueError(f"T must be float, AutoDiffXd or Expression, got {T!r}")
    return _MATH[kinds[T]]


def default_instantiation(template: TemplateSystem, name: str) -> type:
    """The double instantiation of a ``TemplateSystem``, named ``name`` with the signature of
    its ``_construct`` (without ``converter``), so ``help()``, ``inspect.signature`` and the
    docstring checks see the real arguments.

    Parameters
    ----------
    template : TemplateSystem
        The template (``Name_``).
    name : str
        The public name of the double instantiation (``Name``).

    Returns
    -------
    type
        ``template[float]``.
    """
    cls = template[None]
    cls.__name__ = cls.__qualname__ = name
    cls.__signature__ = template_signature(cls._construct)
    return cls


class DoubleOnly:
    """Mixin for a LeafSystem whose mathematics is not differentiable: ``ToAutoDiffXd()`` and
    ``ToSymbolic()`` raise a ``RuntimeError`` naming the system, why, and what to put in its
    place (the class attribute ``conversion_refusal``).  A diagram holding it does not convert
    either (Drake's own error names the class).
    """

    #: why the system is double only and the alternative (completes "does not convert to T: …")
    conversion_refusal = "it is double only"

    def _refusal(self, scalar):
        name = f" {self.get_name()!r}" if self.get_name() else ""
        return f"{type(self).__name__}{name} does not convert to {scalar}: {self.conversion_refusal}"

    def ToAutoDiffXd(self) -> NoReturn:
        """Refused (the class docstring says why and what to use instead).

        Raises
        ------
        RuntimeError
            Always.
        """
        raise RuntimeError(self._refusal("AutoDiffXd"))

    def ToSymbolic(self) -> NoReturn:
        """Refused (the class docstring says why and what to use instead).

        Raises
        ------
        RuntimeError
            Always.
        """
        raise RuntimeError(self._refusal("Expression"))
