"""The one controller type of the syntheses: :class:`DynamicController`.

Output-feedback controllers and state-feedback gains alike (a gain is the static controller),
continuous or discrete time; it converts to python-control and Drake systems.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from ..optional import python_control
from .certificates import as_matrix

if TYPE_CHECKING:   # python-control is optional; pydrake only imported when converting
    import control
    from pydrake.systems.primitives import LinearSystem

__all__ = ["DynamicController"]


@dataclass(frozen=True)
class DynamicController:
    """The one controller type of a synthesis result (iterates as (AK, BK, CK, DK))::

        x_K' = AK x_K + BK y,   u = CK x_K + DK y            (dt = 0, continuous time)
        x_K[k+1] = AK x_K[k] + BK y_k,   u_k = CK x_K[k] + DK y_k     (dt > 0, discrete time)

    Positive feedback, as the syntheses design it (no minus sign).  A state-feedback gain
    u = +K x is the static controller of :meth:`static` (no state: AK is 0 × 0, DK = K, y = x).

    Parameters
    ----------
    AK, BK, CK, DK : array_like
        Controller matrices, shapes (nk, nk), (nk, ny), (nu, nk), (nu, ny).
    dt : float, default 0.0
        Sample period (s) of a discrete-time controller; 0 for continuous time.

    Attributes
    ----------
    nk, ny, nu : int
        Numbers of controller states, measurements and controls.

    Raises
    ------
    ValueError
        When the shapes do not fit together or ``dt`` is negative or not finite.

    Examples
    --------
    >>> import sobolev_drake as sd
    >>> K = sd.DynamicController.static([[-1.0, -2.0]])          # u = +K x
    >>> K.nk, K.ny, K.nu, K.AK.shape
    (0, 2, 1, (0, 0))
    >>> K.to_statespace().D                                      # python-control
    array([[-1., -2.]])
    >>> K.to_drake().D()                                         # Drake LinearSystem
    array([[-1., -2.]])
    """

    AK: np.ndarray
    BK: np.ndarray
    CK: np.ndarray
    DK: np.ndarray
    dt: float = 0.0

    def __post_init__(self) -> None:
        DK = as_matrix("DK", self.DK)
        nu, ny = DK.shape
        AK = as_matrix("AK", self.AK)
        nk = AK.shape[0] if AK.size else 0       # a static controller: no state
        if nk:
            AK = as_matrix("AK", AK, (nk, nk))
        empty = nk == 0 and not np.size(self.BK) and not np.size(self.CK)
        BK = np.zeros((0, ny)) if empty else as_matrix("BK", self.BK, (nk, ny))
        CK = np.zeros((nu, 0)) if empty else as_matrix("CK", self.CK, (nu, nk))
        AK = np.zeros((0, 0)) if not nk else AK
        dt = float(self.dt)
        if not (np.isfinite(dt) and dt >= 0):
            raise ValueError(f"dt must be 0 (continuous) or a positive sample period, got {self.dt!r}")
        for name, value in (("AK", AK), ("BK", BK), ("CK", CK), ("DK", DK), ("dt", dt)):
            object.__setattr__(self, name, value)

    @classmethod
    def static(cls, K: ArrayLike, dt: float = 0.0) -> DynamicController:
        """The static controller u = K y (a state-feedback gain: y = x).

        Parameters
        ----------
        K : array_like, shape (nu, ny)
            The gain.
        dt : float, default 0.0
            Sample period (0: continuous time).

        Returns
        -------
        DynamicController
            AK 0 × 0, BK 0 × ny, CK nu × 0, DK = K.
        """
        K = as_matrix("K", K)
        nu, ny = K.shape
        return cls(np.zeros((0, 0)), np.zeros((0, ny)), np.zeros((nu, 0)), K, dt)

    nk = property(lambda s: s.AK.shape[0])
    ny = property(lambda s: s.DK.shape[1])
    nu = property(lambda s: s.DK.shape[0])

    def __iter__(self):
        return iter((self.AK, self.BK, self.CK, self.DK))

    def to_statespace(self) -> control.StateSpace:
        """The controller as a python-control ``StateSpace`` (input y, output u; ``dt`` kept).

        Returns
        -------
        control.StateSpace

        Raises
        ------
        ImportError
            When python-control (the ``control`` extra) is not installed.
        """
        control = python_control("DynamicController.to_statespace")
        return control.ss(self.AK, self.BK, self.CK, self.DK, self.dt)

    def to_drake(self) -> LinearSystem:
        """The controller as Drake's ``LinearSystem`` (input y, output u; period ``dt``).

        The transfer function as a Drake system (scalar-convertible, ``Linearize``-able).  To
        run a synthesized controller around an operating point, with clipping or sampling, use
        :func:`sobolev_drake.controller_system` (continuous results) or
        :func:`sobolev_drake.discrete_controller_system` (discrete results, with the
        zero-order hold and computation delay they were designed for).

        Returns
        -------
        pydrake.systems.primitives.LinearSystem
        """
        from pydrake.systems.primitives import LinearSystem   # synthesis/ imports no Drake system at import
        return LinearSystem(self.AK, self.BK, self.CK, self.DK, time_period=self.dt)
