"""C² smoothing of a piecewise reference at its junctions (optional; off by default).

A :class:`~sobolev_drake.systems.references.PiecewiseTrajectory` whose pieces meet with a step
in velocity or acceleration (the tilt-rotor envelope mission has 2.59 m/s² lateral steps at
its phase junctions) becomes C² by blending the two pieces that meet at each breakpoint b
over the window [b − h, b + h] with the quintic smootherstep weight

    w(s) = 10 s³ − 15 s⁴ + 6 s⁵,   s = (t − (b − h)) / (2h) ∈ [0, 1],

    q = (1 − w) q_L + w q_R,
    q̇ = (1 − w) q̇_L + w q̇_R + ẇ (q_R − q_L),
    q̈ = (1 − w) q̈_L + w q̈_R + 2 ẇ (q̇_R − q̇_L) + ẅ (q_R − q_L),

where q_L, q_R are the left and right pieces evaluated (extrapolated) over the whole window.
w, ẇ, ẅ are 0, 0, 0 at s = 0 and 1, 0, 0 at s = 1, so q, q̇, q̈ are continuous at both window
ends (C²); inside the window everything is analytic, so the jerk is bounded (it steps at the
window ends, where w⃛ = 60/(2h)³ ≠ 0: the result is C², not C³).  Outside the windows the
smoothed trajectory uses the very same piece objects, so it equals the original exactly.

This is not from the thesis (its references keep their steps); it is the optional
reference smoothing of issue #33.
"""

from __future__ import annotations

import numpy as np

from sobolev_drake.systems.references import Coordinate, PiecewiseTrajectory
from sobolev_drake.systems.scalar_time import Scalar
from sobolev_drake.validation import real_scalar

__all__ = ["smootherstep", "blend_coordinates", "smooth_junctions"]


def smootherstep(t: Scalar | np.ndarray, start: float, width: float
                 ) -> tuple[Scalar | np.ndarray, Scalar | np.ndarray, Scalar | np.ndarray]:
    """Quintic smootherstep weight w and its first two time derivatives on [start, start+width].

    Parameters
    ----------
    t : float, ndarray, AutoDiffXd or Expression
        Time(s) inside the window (not clipped: the caller evaluates it inside only).
    start : float
        Window start.
    width : float
        Window length (> 0).

    Returns
    -------
    w, wdot, wddot
        10s³ − 15s⁴ + 6s⁵ and its derivatives in t, with s = (t − start)/width.

    Examples
    --------
    >>> from sobolev_drake.systems.reference_smoothing import smootherstep
    >>> [float(v) for v in smootherstep(1.0, 0.0, 2.0)]   # the middle: w = 1/2, slope 15/16 / 2
    [0.5, 0.9375, 0.0]
    """
    s = (t - start) * (1.0 / width)
    w = s * s * s * (10.0 + s * (-15.0 + 6.0 * s))
    dw = s * s * (30.0 + s * (-60.0 + 30.0 * s)) * (1.0 / width)
    ddw = s * (60.0 + s * (-180.0 + 120.0 * s)) * (1.0 / (width * width))
    return w, dw, ddw


def blend_coordinates(left: Coordinate, right: Coordinate, start: float, width: float) -> Coordinate:
    """The C² blend of two coordinates over [start, start + width] (``left`` at the start,
    ``right`` at the end, value, velocity and acceleration matched at both ends).

    Parameters
    ----------
    left, right : Coordinate
        The coordinates before and after the junction (both evaluated on the whole window).
    start : float
        Window start (finite).
    width : float
        Window length (> 0).

    Returns
    -------
    Coordinate
        With float, vectorized and any-scalar-type (AutoDiffXd, Expression) forms.

    Raises
    ------
    TypeError
        If ``left`` or ``right`` is not a Coordinate.
    ValueError
        If ``width`` is not positive or ``start`` not finite.

    Examples
    --------
    >>> from sobolev_drake.systems.references import const, poly
    >>> from sobolev_drake.systems.reference_smoothing import blend_coordinates
    >>> c = blend_coordinates(const(0.0), poly([0.0, 1.0]), start=-1.0, width=2.0)
    >>> [round(float(v), 6) for v in c.scalar(1.0)]   # at the window end: the right piece
    [1.0, 1.0, 0.0]
    """
    for name, c in (("left", left), ("right", right)):
        if not isinstance(c, Coordinate):
            raise TypeError(f"{name} must be a Coordinate, got {type(c).__name__}")
    a = real_scalar("start", start)
    h = real_scalar("width", width, low=0.0, low_open=True)

    def mix(lv, rv, w, dw, ddw):
        (f0, d0, dd0), (f1, d1, dd1) = lv, rv
        df, ddf = f1 - f0, d1 - d0
        return (f0 + w * df, d0 + w * ddf + dw * df,
                dd0 + w * (dd1 - dd0) + 2.0 * dw * ddf + ddw * df)

    def fn(t):
        return mix(left(t), right(t), *smootherstep(t, a, h))

    def fn_scalar(t):
        return mix(left.scalar(t), right.scalar(t), *smootherstep(t, a, h))

    def fn_generic(t):
        return mix(left.at(t), right.at(t), *smootherstep(t, a, h))

    return Coordinate(fn, f"blend[{left.description} -> {right.description}] on "
                          f"[{a:g}, {a + h:g}]", scalar=fn_scalar, generic=fn_generic)


def smooth_junctions(trajectory: PiecewiseTrajectory, half_window: float) -> PiecewiseTrajectory:
    """``trajectory`` made C² at every breakpoint by a smootherstep blend over [b − h, b + h].

    Parameters
    ----------
    trajectory : PiecewiseTrajectory
        The reference (any number of pieces; pieces must be defined, i.e. extrapolable, over
        h on each side of their breakpoints — true of the polynomial and sine pieces).
    half_window : float
        h (s), > 0, and below half of the shortest gap between breakpoints (windows must not
        overlap or touch).

    Returns
    -------
    PiecewiseTrajectory
        Breakpoints b_k ± h; pieces: the original ones outside the windows (the same objects,
        so equal values there), a :func:`blend_coordinates` piece inside each window.  A
        trajectory without breakpoints is returned unchanged.

    Raises
    ------
    TypeError
        If ``trajectory`` is not a PiecewiseTrajectory.
    ValueError
        If ``half_window`` is not a positive finite number or the windows would overlap.

    Examples
    --------
    >>> from sobolev_drake.systems.references import PiecewiseTrajectory, const, poly
    >>> from sobolev_drake.systems.reference_smoothing import smooth_junctions
    >>> ramp = PiecewiseTrajectory(["x"], [[const(0.0)], [poly([0.0, 1.0], t0=1.0)]], [1.0])
    >>> s = smooth_junctions(ramp, 0.5)
    >>> s.breakpoints.tolist()
    [0.5, 1.5]
    >>> [row["class"] for row in s.smoothness()]   # the velocity step is gone
    ['C2+', 'C2+']
    """
    if not isinstance(trajectory, PiecewiseTrajectory):
        raise TypeError(f"trajectory must be a PiecewiseTrajectory, got {type(trajectory).__name__}")
    h = real_scalar("half_window (s)", half_window, low=0.0, low_open=True)
    b = trajectory.breakpoints
    if b.size == 0:
        return trajectory
    if b.size > 1 and 2.0 * h >= float(np.min(np.diff(b))):
        raise ValueError(f"half_window (s) must be < {float(np.min(np.diff(b))) / 2:g} (half the "
                         f"shortest gap between breakpoints {b.tolist()}), got {h!r}")
    pieces, bps = [trajectory.pieces[0]], []
    for k, bk in enumerate(b.tolist()):
        left, right = trajectory.pieces[k], trajectory.pieces[k + 1]
        pieces += [[blend_coordinates(cl, cr, bk - h, 2.0 * h) for cl, cr in zip(left, right)], right]
        bps += [bk - h, bk + h]
    desc = (trajectory.description + f" [C² smootherstep blend over ±{h:g} s at each junction]").strip()
    return PiecewiseTrajectory(trajectory.names, pieces, bps, desc)
