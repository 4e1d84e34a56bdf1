"""Argument checks shared by the whole library.

Every public entry point that takes numbers from a user runs them through one of these
functions, so that bad input fails early with the same kind of message everywhere: a
``TypeError`` (wrong kind of object) or ``ValueError`` (right kind, wrong value) that names the
argument, shows the value it got and says what was expected.  Nothing here imports the rest of
the package; every layer may import it.
"""

from __future__ import annotations

import math
import numbers
import operator
import os
import re
from collections.abc import Hashable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any, TypeVar

import numpy as np
from numpy.typing import ArrayLike

T = TypeVar("T")

__all__ = ["check_parameter_fields", "real_array", "real_matrix", "real_vector", "real_scalar", "positive_scalar", "index_tuple",
           "bounds_pair", "one_of", "describe", "sequence", "mapping", "path_like",
           "state_input_disturbance"]


def describe(value: Any, limit: int = 60) -> str:
    """Short ``repr`` of ``value`` for an error message (long arrays are abbreviated)."""
    if isinstance(value, np.ndarray) and value.size > 6:
        return f"array of shape {value.shape} and dtype {value.dtype}"
    text = re.sub(r"\n\s*", " ", repr(value))   # one line (a matrix's repr spans several)
    return text if len(text) <= limit else text[:limit - 3] + "..."


def real_array(name: str, value: ArrayLike) -> np.ndarray:
    """``value`` as a float array; refuses strings, objects, booleans used as numbers and
    complex values (whose imaginary part would otherwise be dropped silently)."""
    if isinstance(value, (str, bytes)):
        raise TypeError(f"{name} must be a real number or array, got the string {describe(value)}")
    if value is None:   # np.asarray(None, dtype=complex) is nan+nanj: not a "complex entry"
        raise TypeError(f"{name} must be a real number or array, got None")
    try:
        arr = np.asarray(value)
    except (TypeError, ValueError) as e:
        raise TypeError(f"{name} must be a real number or array, got {describe(value)} ({e})") from None
    if arr.dtype == object:
        try:
            arr = np.asarray(value, dtype=complex)
        except (TypeError, ValueError):
            raise TypeError(f"{name} must be a real number or array, got {describe(value)} "
                            "(entries that are not numbers, or rows of different lengths)") from None
    if np.iscomplexobj(arr):
        if np.any(np.imag(arr) != 0):
            raise TypeError(f"{name} must be real, got complex entries ({describe(value)})")
        arr = np.real(arr)
    if arr.dtype.kind not in "biuf":
        raise TypeError(f"{name} must be a real number or array, got dtype {arr.dtype} "
                        f"({describe(value)})")
    return arr.astype(float)


def _nonempty_finite(name, arr, value, allow_empty):
    if arr.size == 0 and not allow_empty:
        raise ValueError(f"{name} must not be empty, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite, got non-finite entries ({describe(value)})")
    return arr


def real_matrix(name: str, value: ArrayLike, shape: tuple[int | None, int | None] | None = None, *,
                allow_empty: bool = False) -> np.ndarray:
    """``value`` as a finite real 2-D float array (scalars and vectors are promoted to 2-D).

    ``shape``: expected (rows, cols), ``None`` entries meaning any size.  Empty matrices are
    refused unless ``allow_empty`` (a 0 x 0 plant has nothing to control).
    """
    arr = real_array(name, value)
    if arr.ndim > 2:
        raise ValueError(f"{name} must be a matrix (2-D), got an array of shape {arr.shape}")
    arr = np.atleast_2d(arr)
    if shape is not None:
        for got, want in zip(arr.shape, shape):
            if want is not None and got != want:
                expected = "(" + ", ".join("any" if s is None else str(s) for s in shape) + ")"
                raise ValueError(f"{name} must have shape {expected}, got {arr.shape}")
    return _nonempty_finite(name, arr, value, allow_empty)


def real_vector(name: str, value: ArrayLike, size: int | None = None, *,
                allow_empty: bool = False) -> np.ndarray:
    """``value`` as a finite real 1-D float array (a scalar becomes length 1); ``size``: expected length."""
    arr = real_array(name, value)
    if arr.ndim > 1:
        raise ValueError(f"{name} must be a vector (1-D), got an array of shape {arr.shape}")
    arr = np.atleast_1d(arr)
    if size is not None and arr.size != size:
        raise ValueError(f"{name} must have {size} entries, got {arr.size}")
    return _nonempty_finite(name, arr, value, allow_empty)


def real_scalar(name: str, value: Any, *, low: float | None = None, high: float | None = None,
                low_open: bool = False,
                high_open: bool = False, finite: bool = True) -> float:
    """``value`` as a Python float, checked against [low, high] (open ends with ``*_open``)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        if isinstance(value, np.ndarray) and value.shape == () and value.dtype.kind in "iuf":
            value = value.item()
        else:
            raise TypeError(f"{name} must be a real number, got {describe(value)} "
                            f"({type(value).__name__})")
    x = float(value)
    if math.isnan(x) or (finite and math.isinf(x)):
        raise ValueError(f"{name} must be a finite number, got {x!r}")
    if low is not None and (x < low or (low_open and x == low)):
        raise ValueError(f"{name} must be {'>' if low_open else '>='} {low:g}, got {x!r}")
    if high is not None and (x > high or (high_open and x == high)):
        raise ValueError(f"{name} must be {'<' if high_open else '<='} {high:g}, got {x!r}")
    return x


def positive_scalar(name: str, value: Any) -> float:
    """A finite number > 0."""
    return real_scalar(name, value, low=0.0, low_open=True)


def index_tuple(name: str, value: Any, size: int | None, *,
                names: Sequence[str] | None = None) -> tuple[int, ...]:
    """Distinct integer indices in ``range(size)`` (a single int is a one-element tuple;
    ``size`` None: any index >= 0).

    ``names``: optional sequence of ``size`` labels (e.g. joint names) that may be given instead
    of indices.  Floats (even 1.0), booleans and unknown names are refused: a silently
    truncated index would control the wrong degree of freedom.
    """
    where = f"range({size})" if size is not None else "0, 1, 2, ..."
    items = [value] if isinstance(value, (numbers.Number, str, np.generic)) else value
    if isinstance(items, np.ndarray):
        items = items.ravel().tolist() if items.dtype.kind in "iu" else list(items.ravel())
    try:
        items = list(items)
    except TypeError:
        raise TypeError(f"{name} must be a sequence of indices in {where}, "
                        f"got {describe(value)}") from None
    out = []
    for item in items:
        if isinstance(item, str):
            if names is None or item not in list(names):
                known = (f"; known names: {list(names)}" if names is not None
                         else " (names are not accepted here: give integer indices)")
                raise ValueError(f"{name}: {item!r} is not an index in {where}{known}")
            out.append(list(names).index(item))
            continue
        if isinstance(item, (bool, np.bool_)):
            raise TypeError(f"{name} must contain integer indices, got the boolean {item!r}")
        try:
            i = operator.index(item)
        except TypeError:
            raise TypeError(f"{name} must contain integer indices in {where}, got "
                            f"{describe(item)} ({type(item).__name__})") from None
        if i < 0:
            raise ValueError(f"{name}: index {i} is negative (indices count from 0)")
        if size is not None and i >= size:
            raise ValueError(f"{name}: index {i} is out of {where}")
        out.append(i)
    if len(set(out)) != len(out):
        raise ValueError(f"{name} must not repeat an index, got {describe(value)}")
    return tuple(out)


def bounds_pair(lo_name: str, lo: ArrayLike, hi_name: str, hi: ArrayLike,
                size: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi) as float vectors of one length with lo <= hi entrywise (infinite ends allowed)."""
    lo_arr, hi_arr = real_array(lo_name, lo), real_array(hi_name, hi)
    lo_arr, hi_arr = np.atleast_1d(lo_arr), np.atleast_1d(hi_arr)
    if size is not None:
        lo_arr = np.broadcast_to(lo_arr, (size,)) if lo_arr.size == 1 else lo_arr
        hi_arr = np.broadcast_to(hi_arr, (size,)) if hi_arr.size == 1 else hi_arr
    for nm, a in ((lo_name, lo_arr), (hi_name, hi_arr)):
        if a.ndim != 1 or (size is not None and a.size != size):
            what = f"a vector of {size} entries (one per channel)" if size is not None else "a vector"
            raise ValueError(f"{nm} must be a scalar or {what}, got shape {a.shape}")
        if np.any(np.isnan(a)):
            raise ValueError(f"{nm} must not contain NaN, got {describe(a)}")
    if lo_arr.shape != hi_arr.shape:
        raise ValueError(f"{lo_name} and {hi_name} must have the same length, got "
                         f"{lo_arr.size} and {hi_arr.size}")
    bad = np.flatnonzero(lo_arr > hi_arr)
    if bad.size:
        i = int(bad[0])
        raise ValueError(f"{lo_name} must not exceed {hi_name}: entry {i} has "
                         f"{lo_name}={lo_arr[i]!r} > {hi_name}={hi_arr[i]!r}")
    return np.array(lo_arr, dtype=float), np.array(hi_arr, dtype=float)


def one_of(name: str, value: T, options: Iterable) -> T:
    """``value`` if it is one of ``options``, else a ValueError listing them."""
    # an array compared with a string is an array, whose truth value is ambiguous
    if not isinstance(value, Hashable) or value not in tuple(options):
        raise ValueError(f"{name} must be one of {tuple(options)}, got {describe(value)}")
    return value


def sequence(name: str, value: Any, what: str = "items") -> list:
    """``value`` as a list; a TypeError naming ``name`` if it is not a sequence (strings,
    bytes, dicts and non-iterables are refused: their items are rarely what was meant).

    Parameters
    ----------
    name : str
        Argument name for the message.
    value : object
        The argument.
    what : str, default "items"
        What the items should be, e.g. "coordinate-name strings" (for the message).

    Returns
    -------
    list
    """
    if isinstance(value, (str, bytes, Mapping)) or not isinstance(value, Iterable):
        raise TypeError(f"{name} must be a sequence of {what}, got {describe(value)} "
                        f"({type(value).__name__})")
    return list(value)


def mapping(name: str, value: Any, what: str = "{label: value}") -> Mapping:
    """``value`` if it is a mapping (dict), else a TypeError naming ``name``.

    Parameters
    ----------
    name : str
        Argument name for the message.
    value : object
        The argument.
    what : str, default "{label: value}"
        The expected content (for the message).

    Returns
    -------
    Mapping
    """
    if not isinstance(value, Mapping):
        raise TypeError(f"{name} must be a dict {what}, got {describe(value)} "
                        f"({type(value).__name__})")
    return value


def path_like(name: str, value: str | os.PathLike) -> Path:
    """``value`` as a :class:`pathlib.Path`: a TypeError naming ``name`` unless it is a ``str``
    or ``os.PathLike``, a ValueError for an empty string (it would mean the current folder).

    Parameters
    ----------
    name : str
        Argument name for the message.
    value : object
        The argument.

    Returns
    -------
    pathlib.Path
    """
    if not isinstance(value, (str, os.PathLike)):
        raise TypeError(f"{name} must be a file path (str or pathlib.Path), got "
                        f"{describe(value)} ({type(value).__name__})")
    if isinstance(value, str) and not value.strip():
        raise ValueError(f"{name} must be a file path, got the empty string {value!r}")
    return Path(value)


def check_parameter_fields(params: Any, positive: Iterable[str] = (),
                           nonnegative: Iterable[str] = ()) -> None:
    """Check a dataclass of physical parameters: every numeric field finite (arrays entrywise),
    the fields named in ``positive`` > 0 and those in ``nonnegative`` >= 0; strings are skipped.
    Errors name ``<Class>.<field>``."""
    from dataclasses import fields

    cls = type(params).__name__
    for f in fields(params):
        if not f.init:
            continue
        value = getattr(params, f.name)
        label = f"{cls}.{f.name}"
        if f.name in positive:
            real_scalar(label, value, low=0.0, low_open=True)
        elif f.name in nonnegative:
            real_scalar(label, value, low=0.0)
        elif isinstance(value, str):   # option fields (e.g. model variants) are checked by their class
            continue
        elif np.ndim(value) == 0:
            real_scalar(label, value)
        else:
            arr = real_array(label, value)
            if not np.all(np.isfinite(arr)):
                raise ValueError(f"{label} must be finite, got {describe(value)}")


def state_input_disturbance(A: ArrayLike, B: ArrayLike, D: ArrayLike
                            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(A, B, D) of x' = A x + B u + D w as float matrices: A non-empty square, B and D with n
    rows and at least one column each.

    Parameters
    ----------
    A, B, D : array_like
        State, control-input and disturbance matrices.

    Returns
    -------
    tuple of ndarray

    Raises
    ------
    ValueError
        Naming the matrix whose shape or values do not fit.

    Examples
    --------
    >>> from sobolev_drake.validation import state_input_disturbance
    >>> [M.shape for M in state_input_disturbance([[0, 1], [0, 0]], [[0], [1]], [[0], [1]])]
    [(2, 2), (2, 1), (2, 1)]
    """
    A = real_matrix("A", A, allow_empty=True)
    n = A.shape[0]
    real_matrix("A", A, (n, n), allow_empty=True)
    if n == 0:   # before the weights, whose checks would fail on empty matrices
        raise ValueError(f"A must be a non-empty square matrix (the plant has no state), got "
                         f"shape {A.shape}")
    B = real_matrix("B", B, (n, None), allow_empty=True)
    D = real_matrix("D", D, (n, None), allow_empty=True)
    for name, M, what in (("B", B, "control input"), ("D", D, "disturbance")):
        if M.shape[1] == 0:
            raise ValueError(f"{name} must have at least one {what} column, got shape {M.shape}")
    return A, B, D
