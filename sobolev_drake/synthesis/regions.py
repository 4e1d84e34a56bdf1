"""LMI pole regions (Chilali & Gahinet 1996; thesis (6.37)-(6.40)).

A region is D = {s : L + s M + conj(s) M^T < 0} (thesis (6.37) with alpha = L, beta = M).
A matrix A_cl has all its eigenvalues in D iff there is X > 0 with
L (x) X + M (x) (A_cl X) + M^T (x) (A_cl X)^T < 0  (6.38); with A_cl X = A X + B W this is
linear in the state-feedback variables (6.39), and with the Gahinet-Apkarian variables it is
linear in the output-feedback variables (6.40).

The disk of radius r centred at -c is L = [[-r, c], [c, -r]], M = [[0, 1], [0, 0]]
(the thesis prints "alpha = [-r 0; 0 r]", which does not describe a disk: a transcription
error; see DESIGN.md 4.4).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla


@dataclass(frozen=True)
class LMIRegion:
    """Region {s : L + s M + conj(s) M^T < 0}; intersections via ``&``."""

    L: np.ndarray
    M: np.ndarray
    label: str = "region"

    def __post_init__(self):
        L = np.atleast_2d(np.asarray(self.L, float))
        M = np.atleast_2d(np.asarray(self.M, float))
        if L.shape != M.shape or L.shape[0] != L.shape[1]:
            raise ValueError(f"region matrices L, M must be square and equal-sized, got {L.shape}, {M.shape}")
        if not np.allclose(L, L.T):
            raise ValueError("region matrix L must be symmetric")
        object.__setattr__(self, "L", L)
        object.__setattr__(self, "M", M)

    def __and__(self, other):
        return LMIRegion(sla.block_diag(self.L, other.L), sla.block_diag(self.M, other.M),
                         f"{self.label} & {other.label}")

    def __str__(self):
        return self.label

    def margin(self, s):
        """Largest eigenvalue of L + s M + conj(s) M^T for each s (< 0 means inside)."""
        s = np.atleast_1d(np.asarray(s, complex))
        out = np.empty(s.shape)
        for k, sk in enumerate(s.ravel()):
            F = self.L + sk * self.M + np.conj(sk) * self.M.T
            out.ravel()[k] = np.linalg.eigvalsh(0.5 * (F + F.conj().T)).max()
        return out

    def contains(self, s, tol=0.0):
        return self.margin(s) < tol


def disk(radius, center=0.0):
    """Disk |s - center| < radius (center real; the thesis uses center 0)."""
    r, c = float(radius), -float(center)
    if r <= 0:
        raise ValueError(f"disk radius must be positive, got {radius}")
    return LMIRegion([[-r, c], [c, -r]], [[0.0, 1.0], [0.0, 0.0]], f"disk(r={r:g}, c={-c:g})")


def half_plane(a):
    """Re s < -a (decay rate a)."""
    return LMIRegion([[2.0 * float(a)]], [[1.0]], f"Re s < {-float(a):g}")


def sector(theta):
    """Conic sector |Im s| < -Re s tan(theta), i.e. damping ratio >= cos(theta)."""
    th = float(theta)
    if not 0 < th < np.pi / 2:
        raise ValueError(f"sector half-angle theta must be in (0, pi/2), got {theta}")
    s, c = np.sin(th), np.cos(th)
    return LMIRegion(np.zeros((2, 2)), [[s, c], [-c, s]], f"sector({np.degrees(th):.1f} deg)")


def damping(zeta):
    """Damping ratio >= zeta (a conic sector)."""
    if not 0 < zeta < 1:
        raise ValueError(f"damping ratio must be in (0, 1), got {zeta}")
    return sector(np.arccos(zeta))


def strip(a_min, a_max):
    """Vertical strip -a_max < Re s < -a_min."""
    if not a_max > a_min:
        raise ValueError(f"strip needs a_max > a_min, got {a_min}, {a_max}")
    return LMIRegion(np.diag([2.0 * a_min, -2.0 * a_max]), np.diag([1.0, -1.0]),
                     f"strip({-a_max:g} < Re s < {-a_min:g})")


def intersect(*regions):
    out = regions[0]
    for r in regions[1:]:
        out = out & r
    return out


def region_lmi(region, X, AX):
    """Affine expression L (x) X + M (x) AX + M^T (x) AX^T (must be < 0); see (6.38)-(6.40)."""
    from .lmi import kron
    return kron(region.L, X) + kron(region.M, AX) + kron(region.M.T, AX.T)
