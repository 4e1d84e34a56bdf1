"""One-dimensional tuning: find the parameter at which an index matches a target.

Three strategies, each kept for the experiments whose published numbers rest on it: a grid scan
followed by bisection (:func:`match_parameter`), bracketing from a first guess followed by regula
falsi (:func:`match_by_regula_falsi`), and plain bisection inside a bracket (:func:`bisect_log`).
"""

from __future__ import annotations

from typing import Any, Callable, Iterable

import numpy as np

__all__ = ["match_parameter", "match_by_regula_falsi", "bisect_log"]


def match_parameter(f: Callable[[float], float], target: float, grid: Iterable[float], *,
                    iters: int = 10, rtol: float = 0.01, refine: int = 0
                    ) -> tuple[float, float, list[tuple[float, float]]]:
    """Find p with f(p) ≈ target: scan ``grid`` (ascending, > 0), then bisect on log p.

    f may fail (return nan) or be non-monotone: every interval between neighbouring evaluated
    points where f - target changes sign brackets a solution; the one with the LARGEST p is
    refined (for an input weight ρ that is the least aggressive controller meeting the
    target, i.e. the choice most favourable to the baseline's control effort).  Without a
    bracket — e.g. a V-shaped f whose minimum dips below the target between two grid points,
    as the O.F. settling time does — the intervals next to the point closest to the target
    are halved (geometric midpoints) up to ``refine`` times; if still no bracket, that point
    is returned.  Returns (p, f(p), history [(p, f(p)), ...]).

    Parameters
    ----------
    f : callable
        ``f(p) -> float``: the index at parameter p (nan if the evaluation failed).
    target : float
        The index value to match.
    grid : iterable of float
        Parameter values scanned first (at least two, all > 0; sorted here).
    iters : int, default 10
        Bisection steps on log p at most.
    rtol : float, default 0.01
        Stop when an end of the bracket is within ``rtol·|target|`` of the target.
    refine : int, default 0
        Times the intervals around the closest point are halved when the grid holds no
        bracket.

    Returns
    -------
    p : float
        The parameter (a bracket end, or the closest evaluated point) whose index is closest
        to the target.
    value : float
        f(p).
    history : list of (float, float)
        Every evaluated (p, f(p)), in evaluation order.
    """
    grid = sorted(float(g) for g in grid)
    if len(grid) < 2 or grid[0] <= 0:
        raise ValueError(f"grid must hold >= 2 positive values, got {grid}")
    hist = [(g, float(f(g))) for g in grid]
    if not any(np.isfinite(v) for _, v in hist):
        raise RuntimeError("match_parameter: f failed on the whole grid")
    for level in range(refine + 1):
        pts = sorted(dict(hist).items())
        brackets = [(a, b) for a, b in zip(pts[:-1], pts[1:])
                    if np.isfinite(a[1]) and np.isfinite(b[1]) and (a[1] - target) * (b[1] - target) <= 0]
        if brackets or level == refine:
            break
        i = min((k for k, (_, v) in enumerate(pts) if np.isfinite(v)), key=lambda k: abs(pts[k][1] - target))
        for j in (i - 1, i + 1):
            if 0 <= j < len(pts):
                q = float(np.sqrt(pts[i][0] * pts[j][0]))
                hist.append((q, float(f(q))))
    if not brackets:
        p, v = min(((p, v) for p, v in hist if np.isfinite(v)), key=lambda h: abs(h[1] - target))
        return p, v, hist
    (lo, flo), (hi, fhi) = brackets[-1]
    for _ in range(iters):
        if min(abs(flo - target), abs(fhi - target)) <= rtol * abs(target):
            break
        mid = float(np.sqrt(lo * hi))
        v = float(f(mid))
        hist.append((mid, v))
        if not np.isfinite(v):
            break
        if (flo - target) * (v - target) <= 0:
            hi, fhi = mid, v
        else:
            lo, flo = mid, v
    p, v = min(((lo, flo), (hi, fhi)), key=lambda h: abs(h[1] - target))
    return p, v, hist


def match_by_regula_falsi(evaluate: Callable[[float], tuple[float, dict[str, Any]]], target: float,
                          p0: float, *, iters: int = 7, factor: float = 3.0, rtol: float = 0.02,
                          decreasing: bool = True
                          ) -> tuple[float, dict[str, Any], list[tuple[float, float]]]:
    """Find p with ``evaluate(p)[0]`` ≈ ``target`` from a first guess, without a grid.

    Bracket by multiplying or dividing p by ``factor``, then regula falsi on (log p, log index),
    clamped to the inner 80 % of the bracket.  Suited to a positive index that is monotone in p
    and whose evaluation is a full simulation (few evaluations): the H∞ σ-gain searches of the
    mechanical experiments, where the index (IADU) decreases with ωu, or (``decreasing=False``)
    increases with it (ISE).  An evaluation that failed (``run.get("failed")``), or returned a
    non-finite or non-positive index, counts as "index too large".

    Parameters
    ----------
    evaluate : callable
        ``evaluate(p) -> (index, run)``, run a dict kept for the best point.
    target : float
        The index to match (> 0).
    p0 : float
        First guess (> 0).
    iters : int
        Number of evaluations at most.
    factor : float
        Bracketing step (> 1).
    rtol : float
        Stop when |log(index/target)| < log(1 + rtol).
    decreasing : bool
        Whether the index decreases as p grows.

    Returns
    -------
    (p, run, history)
        The evaluated p closest to the target in log ratio, its run, and [(p, index), ...].
    """
    hist, runs = [], {}

    def ev(p):
        val, run = evaluate(p)
        if run.get("failed") or not np.isfinite(val) or val <= 0:
            val = np.inf
        hist.append((float(p), float(val)))
        runs[float(p)] = run
        return val

    below = above = None  # below: p must grow; above: p must shrink
    p = float(p0)
    for _ in range(iters):
        val = ev(p)
        if abs(np.log(val / target)) < np.log1p(rtol):
            break
        if (val > target) == decreasing:
            below = (p, val)
        else:
            above = (p, val)
        if below is None:
            p = p / factor
        elif above is None:
            p = p * factor
        else:
            (a, fa), (b, fb) = below, above
            la, lb = np.log(a), np.log(b)
            if np.isfinite(fa) and np.isfinite(fb):
                ga, gb = np.log(fa / target), np.log(fb / target)
                x = la - ga * (lb - la) / (gb - ga)
                x = min(max(x, la + 0.1 * (lb - la)), lb - 0.1 * (lb - la))
            else:
                x = 0.5 * (la + lb)
            p = float(np.exp(x))
    best = min(hist, key=lambda h: abs(np.log(h[1] / target)) if np.isfinite(h[1]) else np.inf)
    return best[0], runs[best[0]], hist


def bisect_log(evaluate: Callable[[float], tuple[float, Any]], target: float,
               bracket: tuple[float, float], *, iters: int = 8, increasing: bool = True
               ) -> tuple[float, float, Any]:
    """Bisection on log p inside ``bracket`` so that ``evaluate(p)[0]`` ≈ ``target``.

    Every midpoint is evaluated (never the ends); the midpoint whose index is closest to the
    target, among those whose payload is not None, is returned.  Suited to an index known to be
    monotone on the bracket whose evaluations may fail (payload None, index treated as too large
    when ``increasing``): the SGAA H∞ design's settling time against its input weight ρ.

    Parameters
    ----------
    evaluate : callable
        ``evaluate(p) -> (index, payload)``; payload None marks a failed evaluation.
    target : float
        The index to match.
    bracket : (float, float)
        Positive lower and upper ends of the search.
    iters : int
        Number of midpoints evaluated.
    increasing : bool
        Whether the index increases as p grows.

    Returns
    -------
    (p, index, payload)
    """
    lo, hi = np.log(bracket[0]), np.log(bracket[1])
    best = None
    for _ in range(iters):
        mid = 0.5 * (lo + hi)
        value, payload = evaluate(np.exp(mid))
        if payload is not None and (best is None or abs(value - target) < abs(best[1] - target)):
            best = (np.exp(mid), value, payload)
        if (value > target) == increasing:
            hi = mid
        else:
            lo = mid
    if best is None:
        raise RuntimeError("bisect_log: no evaluation in the bracket succeeded")
    return best
