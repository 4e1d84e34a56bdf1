"""Sliding surfaces of the classic nonlinear H∞ baseline (docs/design.md §4.3).

The thesis tunes its H∞ baselines "by trial and error" and prints no weights.  A surface
(ω1, ω2, ω3) steers the tracking error along s² + c1 s + c0 with c1 = √(ω2² + 2ω1ω3)/ω1 and
c0 = ω3/ω1.  :func:`matched_hinf_surface` aims it at a W2/W∞ design's error dynamics (our rule
for a fair comparison); :func:`scaled_surface` states other tunings relative to it, as the
fitted readings of the thesis' H∞ rows do.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from sobolev_drake.synthesis.mechanical import SobolevGains

__all__ = ["matched_hinf_surface", "scaled_surface"]


def matched_hinf_surface(gains: SobolevGains) -> tuple[float, float, float]:
    """(ω1, ω2, ω3) of a classic H∞ sliding surface that aims at the W design's error dynamics.

    The thesis tunes its H∞ baselines "by trial and error" and prints no weights.  Our rule: the
    surface ė + (s/ω1) e + (ω3/ω1) ∫e with ω1 = 1 takes the mean, over the controlled DOF, of the
    slow factor s² + (k/q) s + t/q of the W closed-loop polynomials s³ + (q/y3)s² + (k/y3)s + t/y3
    (blocks Q, K, T of the W2/W∞ solution), so both controllers aim at the same error dynamics;
    ω2 then follows from s² = ω2² + 2ω1ω3 (clipped at 0).

    Parameters
    ----------
    gains : ~sobolev_drake.synthesis.mechanical.SobolevGains
        The W2/W∞ gains of the controlled DOF (blocks "Q", "K", "T").

    Returns
    -------
    (float, float, float)
        ω1 = 1, ω2, ω3 for :func:`~sobolev_drake.synthesis.mechanical.hinf_mechanical_gains`.
    """
    q = np.diag(gains.blocks["Q"])
    k = np.diag(gains.blocks["K"])
    t = np.diag(gains.blocks["T"])
    c1, c0 = float(np.mean(k / q)), float(np.mean(t / q))
    w2sq = c1 ** 2 - 2 * c0
    return 1.0, float(np.sqrt(max(w2sq, 0.0))), c0


def scaled_surface(surface: tuple[float, float, float], c1_factor: float, c0_factor: float | None = None) -> tuple[float, float, float]:
    """A classic H∞ sliding surface with its error polynomial's coefficients scaled.

    The surface (ω1, ω2, ω3) steers the error along s² + c1 s + c0 with c1 = √(ω2² + 2ω1ω3)/ω1
    and c0 = ω3/ω1.  This returns the surface of s² + (c1_factor·c1) s + (c0_factor·c0), ω1
    kept.  With ``c0_factor`` omitted it is c1_factor²: the same dynamics run c1_factor times
    faster (roots scaled by c1_factor; below 1, slower).  Used to state tunings the thesis
    does not print (docs/experiments/quadrotor-attitude.md, balance-coupled.md).

    Parameters
    ----------
    surface : (float, float, float)
        (ω1 > 0, ω2 ≥ 0, ω3 > 0), e.g. from :func:`matched_hinf_surface`.
    c1_factor : float
        Factor (> 0) on c1.
    c0_factor : float, optional
        Factor (> 0) on c0; ``c1_factor ** 2`` by default.

    Returns
    -------
    (float, float, float)
        (ω1, ω2', ω3') for :func:`~sobolev_drake.synthesis.mechanical.hinf_mechanical_gains`.

    Raises
    ------
    ValueError
        For non-positive or non-finite factors or surface weights, or when the scaled
        polynomial has c1'² < 2c0' (no real ω2 represents it).
    """
    w1, w2, w3 = (float(v) for v in surface)
    if not (np.isfinite([w1, w2, w3]).all() and w1 > 0 and w2 >= 0 and w3 > 0):
        raise ValueError(f"surface must be (ω1 > 0, ω2 >= 0, ω3 > 0), got {tuple(surface)!r}")
    a1 = float(c1_factor)
    a0 = a1 ** 2 if c0_factor is None else float(c0_factor)
    for name, v in (("c1_factor", a1), ("c0_factor", a0)):
        if not (np.isfinite(v) and v > 0):
            raise ValueError(f"{name} must be a finite number > 0, got {v!r}")
    c1, c0 = a1 * np.sqrt(w2 ** 2 + 2 * w1 * w3) / w1, a0 * w3 / w1
    w2sq = (w1 * c1) ** 2 - 2 * w1 * (w1 * c0)
    if w2sq < 0:
        raise ValueError(f"c1_factor={a1!r}, c0_factor={a0!r} give s² + {c1:.4g}s + {c0:.4g}, which "
                         f"needs c1² >= 2c0 to be a classic H∞ surface")
    return w1, float(np.sqrt(w2sq)), float(w1 * c0)
