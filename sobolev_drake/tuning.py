"""One-dimensional tuning: find the parameter at which an index matches a target."""

from __future__ import annotations

import numpy as np

__all__ = ["match_parameter"]


def match_parameter(f, target, grid, *, iters=10, rtol=0.01, refine=0):
    """Find p with f(p) ≈ target: scan ``grid`` (ascending, > 0), then bisect on log p.

    f may fail (return nan) or be non-monotone: every interval between neighbouring evaluated
    points where f - target changes sign brackets a solution; the one with the LARGEST p is
    refined (for an input weight ρ that is the least aggressive controller meeting the
    target, i.e. the choice most favourable to the baseline's control effort).  Without a
    bracket — e.g. a V-shaped f whose minimum dips below the target between two grid points,
    as the O.F. settling time does — the intervals next to the point closest to the target
    are halved (geometric midpoints) up to ``refine`` times; if still no bracket, that point
    is returned.  Returns (p, f(p), history [(p, f(p)), ...]).
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
