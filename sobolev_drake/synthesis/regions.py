"""LMI pole regions (Chilali & Gahinet 1996; thesis (6.37)-(6.40)).

A region is D = {s : L + s M + conj(s) M^T < 0} (thesis (6.37) with alpha = L, beta = M).
A matrix A_cl has all its eigenvalues in D iff there is X > 0 with
L (x) X + M (x) (A_cl X) + M^T (x) (A_cl X)^T < 0  (6.38); with A_cl X = A X + B W this is
linear in the state-feedback variables (6.39), and with the Gahinet-Apkarian variables it is
linear in the output-feedback variables (6.40).

The disk of radius r centred at -c is L = [[-r, c], [c, -r]], M = [[0, 1], [0, 0]]
(the thesis prints "alpha = [-r 0; 0 r]", which does not describe a disk: a transcription
error; see docs/design.md §4.4).

Examples
--------
Closed-loop poles in the disk of radius 10 with a damping ratio of at least 0.5 (the
``region`` option of every synthesis; it takes the LMI path):

>>> import numpy as np
>>> import sobolev_drake as sd
>>> region = sd.regions.disk(10.0) & sd.regions.damping(0.5)
>>> str(region.label)
'disk(r=10, c=0) & sector(60.0 deg)'
>>> A, B = np.array([[0.0, 1.0], [-1.0, -0.5]]), np.array([[0.0], [1.0]])
>>> res = sd.winf_state_feedback(A, B, np.eye(2), Gamma0=[1, 1], Gamma1=[0.1, 0.1],
...                              region=region)
>>> round(res.gamma, 2), res.certificate.ok
(1.08, True)
>>> bool(region.contains(np.linalg.eigvals(A + B @ res.K)).all())
True
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike
import scipy.linalg as sla

from ..validation import real_matrix, real_scalar

if TYPE_CHECKING:
    from sobolev_drake.synthesis.lmi import Affine

__all__ = ["LMIRegion", "disk", "half_plane", "sector", "damping", "strip", "intersect",
           "region_lmi"]


@dataclass(frozen=True)
class LMIRegion:
    """Region {s : L + s M + conj(s) M^T < 0}; intersections via ``&``.

    Parameters
    ----------
    L : array_like, shape (k, k)
        Symmetric constant term (alpha of (6.37)).
    M : array_like, shape (k, k)
        Coefficient of s (beta of (6.37)).
    label : str, default "region"
        Name used by ``str`` and in messages.
    """

    L: np.ndarray
    M: np.ndarray
    label: str = "region"

    def __post_init__(self) -> None:
        L = real_matrix("L", self.L)
        M = real_matrix("M", self.M)
        if L.shape != M.shape or L.shape[0] != L.shape[1]:
            raise ValueError(f"region matrices L, M must be square and equal-sized, got {L.shape}, {M.shape}")
        if not np.allclose(L, L.T):
            raise ValueError("region matrix L must be symmetric")
        object.__setattr__(self, "L", L)
        object.__setattr__(self, "M", M)

    def __and__(self, other: object) -> LMIRegion:
        if not isinstance(other, LMIRegion):
            return NotImplemented
        return LMIRegion(sla.block_diag(self.L, other.L), sla.block_diag(self.M, other.M),
                         f"{self.label} & {other.label}")

    def __str__(self) -> str:
        return self.label

    def margin(self, s: complex | ArrayLike) -> np.ndarray:
        """Largest eigenvalue of L + s M + conj(s) M^T for each s (< 0 means inside).

        Parameters
        ----------
        s : complex or array_like of complex
            Point(s) of the complex plane.

        Returns
        -------
        ndarray
            One margin per point (at least 1-D).
        """
        s = np.atleast_1d(np.asarray(s, complex))
        out = np.empty(s.shape)
        for k, sk in enumerate(s.ravel()):
            F = self.L + sk * self.M + np.conj(sk) * self.M.T
            out.ravel()[k] = np.linalg.eigvalsh(0.5 * (F + F.conj().T)).max()
        return out

    def contains(self, s: complex | ArrayLike, tol: float = 0.0) -> np.ndarray:
        """Whether each point is inside the region, ``margin(s) < tol``.

        Parameters
        ----------
        s : complex or array_like of complex
            Point(s) of the complex plane.
        tol : float, default 0.0
            Threshold on :meth:`margin`.

        Returns
        -------
        ndarray of bool
        """
        return self.margin(s) < tol


def disk(radius: float, center: float = 0.0) -> LMIRegion:
    """Disk |s - center| < radius (center real; the thesis uses center 0).

    Parameters
    ----------
    radius : float
        Positive radius.
    center : float, default 0.0
        Real centre of the disk.

    Returns
    -------
    LMIRegion
    """
    r = real_scalar("radius", radius, low=0.0, low_open=True)
    c = -real_scalar("center", center)
    return LMIRegion([[-r, c], [c, -r]], [[0.0, 1.0], [0.0, 0.0]], f"disk(r={r:g}, c={-c:g})")


def half_plane(a: float) -> LMIRegion:
    """Re s < -a (decay rate a).

    Parameters
    ----------
    a : float
        Decay rate.

    Returns
    -------
    LMIRegion
    """
    a = real_scalar("a", a)
    return LMIRegion([[2.0 * a]], [[1.0]], f"Re s < {-a:g}")


def sector(theta: float) -> LMIRegion:
    """Conic sector |Im s| < -Re s tan(theta), i.e. damping ratio >= cos(theta).

    Parameters
    ----------
    theta : float
        Half-angle in (0, π/2) rad, measured from the negative real axis.

    Returns
    -------
    LMIRegion
    """
    th = real_scalar("theta", theta, low=0.0, high=np.pi / 2, low_open=True, high_open=True)
    s, c = np.sin(th), np.cos(th)
    return LMIRegion(np.zeros((2, 2)), [[s, c], [-c, s]], f"sector({np.degrees(th):.1f} deg)")


def damping(zeta: float) -> LMIRegion:
    """Damping ratio >= zeta (a conic sector).

    Parameters
    ----------
    zeta : float
        Damping ratio in (0, 1).

    Returns
    -------
    LMIRegion
        ``sector(arccos(zeta))``.
    """
    zeta = real_scalar("zeta", zeta, low=0.0, high=1.0, low_open=True, high_open=True)
    return sector(np.arccos(zeta))


def strip(a_min: float, a_max: float) -> LMIRegion:
    """Vertical strip -a_max < Re s < -a_min.

    Parameters
    ----------
    a_min, a_max : float
        Bounds of the decay rate, a_max > a_min.

    Returns
    -------
    LMIRegion
    """
    a_min, a_max = real_scalar("a_min", a_min), real_scalar("a_max", a_max)
    if not a_max > a_min:
        raise ValueError(f"strip needs a_max > a_min, got a_min={a_min!r}, a_max={a_max!r}")
    return LMIRegion(np.diag([2.0 * a_min, -2.0 * a_max]), np.diag([1.0, -1.0]),
                     f"strip({-a_max:g} < Re s < {-a_min:g})")


def intersect(*regions: LMIRegion) -> LMIRegion:
    """Intersection of one or more regions (same as ``r1 & r2 & ...``).

    Parameters
    ----------
    *regions : LMIRegion
        One or more regions.

    Returns
    -------
    LMIRegion
        Block-diagonal L and M of the regions.
    """
    if not regions or not all(isinstance(r, LMIRegion) for r in regions):
        raise TypeError(f"intersect takes one or more LMIRegion objects, got {regions!r}")
    out = regions[0]
    for r in regions[1:]:
        out = out & r
    return out


def region_lmi(region: LMIRegion, X: Affine, AX: Affine) -> Affine:
    """Affine expression L (x) X + M (x) AX + M^T (x) AX^T (must be < 0); see (6.38)-(6.40).

    Parameters
    ----------
    region : LMIRegion
        The pole region.
    X : Affine
        Symmetric Lyapunov variable (an :class:`~sobolev_drake.synthesis.lmi.Affine`).
    AX : Affine
        The product A_cl X in the synthesis variables (e.g. A X + B W).

    Returns
    -------
    Affine
        The region LMI's left-hand side.
    """
    from .lmi import kron
    return kron(region.L, X) + kron(region.M, AX) + kron(region.M.T, AX.T)
