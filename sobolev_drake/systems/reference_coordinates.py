"""Reference coordinates: one scalar function of time per piece, t ↦ (f, ḟ, f̈), with a numpy
form, a float fast path, a form for any Drake scalar type and — for :func:`const`,
:func:`sine` and :func:`poly` — a description the compiled kernel evaluates
(``native/reference.c``, :func:`compiled_program`).  Assembled into trajectories by
:class:`~sobolev_drake.systems.references.PiecewiseTrajectory`.
"""

from __future__ import annotations

import math
from typing import Any, Callable, Sequence

import numpy as np
from numpy.typing import ArrayLike
import pydrake.math as dm

from sobolev_drake.native import kernel
from sobolev_drake.systems.scalar_time import Scalar
from sobolev_drake.validation import real_scalar, real_vector

__all__ = ["Coordinate", "const", "sine", "poly", "compiled_program"]


class Coordinate:
    """One scalar reference coordinate on a piece: t ↦ (f(t), ḟ(t), f̈(t)), vectorized in t.

    Calling the coordinate with t (scalar or array) returns (f, ḟ, f̈) as float arrays shaped
    like t.

    Parameters
    ----------
    fn : callable
        ``fn(t) -> (f, ḟ, f̈)`` for a float array t of absolute times (results broadcast to
        t's shape).
    description : str, optional
        Text shown by ``repr``.
    scalar : callable, optional
        The same function for one Python float t returning three floats; the per-sample
        evaluation of a simulation uses it (numpy's per-call overhead dominates there).
        Default: ``fn`` converted to floats.
    generic : callable, optional
        The same function for one scalar t of any Drake type (float, AutoDiffXd, Expression),
        written with ``pydrake.math`` functions; used by the AutoDiffXd and symbolic versions
        of :class:`TrajectoryReference`.  Default: ``fn`` called with that scalar (fine for
        arithmetic-only functions).
    """

    def __init__(self, fn: Callable, description: str = "", scalar: Callable | None = None, generic: Callable | None = None) -> None:
        self._fn = fn
        self.description = description
        self._scalar = scalar
        self._generic = generic
        # the compiled kernel's form of const/sine/poly coordinates (None: Python only)
        self._spec: tuple | None = None

    def scalar(self, t: float) -> tuple[float, float, float]:
        """(f, ḟ, f̈) as floats at one time t.

        Parameters
        ----------
        t : float
            Absolute time.

        Returns
        -------
        f, fdot, fddot : float
        """
        if self._scalar is not None:
            return self._scalar(t)
        f, df, ddf = self(t)
        return float(f), float(df), float(ddf)

    def at(self, t: Scalar) -> tuple[Scalar, Scalar, Scalar]:
        """(f, ḟ, f̈) at one time t of any Drake scalar type (float: :meth:`scalar`).

        Parameters
        ----------
        t : float, AutoDiffXd or Expression
            Absolute time.

        Returns
        -------
        f, fdot, fddot : scalars of t's type (or floats where constant)
        """
        return self.scalar(t) if isinstance(t, float) else tuple((self._generic or self._fn)(t))

    def __call__(self, t: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        t = np.asarray(t, dtype=float)
        f, df, ddf = self._fn(t)
        shape = t.shape
        return (np.broadcast_to(f, shape).astype(float), np.broadcast_to(df, shape).astype(float),
                np.broadcast_to(ddf, shape).astype(float))

    def __repr__(self) -> str:
        return f"Coordinate({self.description})"


def const(c: float) -> Coordinate:
    """f(t) = c.

    Parameters
    ----------
    c : float
        The constant (finite).

    Returns
    -------
    Coordinate
        Value c, zero derivatives.
    """
    c = real_scalar("c", c)
    coordinate = Coordinate(lambda t: (c + 0 * t, 0 * t, 0 * t), f"{c:g}", scalar=lambda t: (c, 0.0, 0.0),
                            generic=lambda t: (c, 0.0, 0.0))
    coordinate._spec = (0, c)
    return coordinate


def sine(amplitude: float, omega: float, *, phase: float = 0.0, offset: float = 0.0, t0: float = 0.0) -> Coordinate:
    """f(t) = offset + A sin(ω (t − t0) + phase)  (use phase = π/2 for a cosine).

    Parameters
    ----------
    amplitude : float
        A.
    omega : float
        Angular frequency ω (rad/s).
    phase : float, default 0.0
        Phase (rad).
    offset : float, default 0.0
        Constant added.
    t0 : float, default 0.0
        Time origin of the sine.

    Returns
    -------
    Coordinate
        With its analytic derivatives.
    """
    A, w, ph, c, s = (real_scalar(n, v) for n, v in (("amplitude", amplitude), ("omega", omega),
                                                   ("phase", phase), ("offset", offset), ("t0", t0)))

    def fn(t):
        arg = w * (t - s) + ph
        return c + A * np.sin(arg), A * w * np.cos(arg), -A * w * w * np.sin(arg)

    def fn_scalar(t):   # float fast path of fn_generic (math.sin on a float)
        arg = w * (t - s) + ph
        sn = math.sin(arg)
        return c + A * sn, A * w * math.cos(arg), -A * w * w * sn

    def fn_generic(t):
        arg = w * (t - s) + ph
        sn = dm.sin(arg)
        return c + A * sn, A * w * dm.cos(arg), -A * w * w * sn

    coordinate = Coordinate(fn, f"{c:g} + {A:g} sin({w:g}(t-{s:g}) + {ph:g})", scalar=fn_scalar,
                            generic=fn_generic)
    coordinate._spec = (1, A, w, ph, c, s)
    return coordinate


def poly(coefficients: Sequence[float], *, t0: float = 0.0) -> Coordinate:
    """f(t) = Σ_k c_k (t − t0)^k with ascending coefficients c_0, c_1, …

    Parameters
    ----------
    coefficients : sequence of float
        c_0, c_1, … (ascending powers).
    t0 : float, default 0.0
        Time origin of the polynomial.

    Returns
    -------
    Coordinate
        With its analytic derivatives.
    """
    c = real_vector("coefficients (ascending powers c_0, c_1, ...)", coefficients)
    P = np.polynomial.Polynomial(c)
    dP, ddP = P.deriv(1), P.deriv(2)
    s = real_scalar("t0", t0)
    cs = [P.coef.tolist()[::-1], dP.coef.tolist()[::-1], ddP.coef.tolist()[::-1]]  # highest first

    def fn_scalar(t):   # any scalar type: Horner uses + and * only
        x = t - s
        out = []
        for cc in cs:
            v = cc[0]
            for a in cc[1:]:
                v = v * x + a
            out.append(v)
        return out[0], out[1], out[2]

    coordinate = Coordinate(lambda t: (P(t - s), dP(t - s), ddP(t - s)), f"poly{tuple(c)} in (t-{s:g})",
                            scalar=fn_scalar, generic=fn_scalar)
    coordinate._spec = (2, s, *(len(cc) for cc in cs), *(a for cc in cs for a in cc))
    return coordinate



def compiled_program(pieces: Sequence[Sequence[Coordinate]], breakpoints: ArrayLike) -> Any:
    """The compiled kernel's program of a piecewise trajectory, or None.

    ``native/reference.c`` evaluates [q; q̇; q̈] at a float time with the operations of
    :meth:`~sobolev_drake.systems.references.PiecewiseTrajectory.evaluate_scalar`, in the same
    order, so the values are equal to the bit (tests/native/test_native_reference.py).

    Parameters
    ----------
    pieces : sequence of sequences of Coordinate
        The pieces (piece k applies on (b_{k−1}, b_k]).
    breakpoints : array_like
        The strictly increasing breakpoints, one fewer than the pieces.

    Returns
    -------
    capsule or None
        None when a coordinate is not made by :func:`const`, :func:`sine` or :func:`poly` (or
        is a polynomial of more than 64 coefficients), or the kernel is not built or is
        switched off; the Python path then evaluates the trajectory.
    """
    k = kernel("reference")
    specs = [[c._spec for c in piece] for piece in pieces]
    if k is None or any(spec is None for piece in specs for spec in piece):
        return None
    try:
        return k.make_program(np.asarray(breakpoints, dtype=float).tolist(), specs)
    except ValueError:       # a polynomial beyond the kernel's 64 coefficients: Python path
        return None
