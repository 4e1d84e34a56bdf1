"""Wind-tunnel coefficients of the tilt-rotor's 24-inch propeller (thesis (7.25)–(7.30)).

:class:`PropellerCoefficients` holds Ct(J, φ) and Cq(J, φ) of ``data/propeller_coefficients.json``
and gives the advance ratio and inflow angle, thrust and torque; pure numpy, vectorized.  The
force models of :mod:`sobolev_drake.tiltrotor.propulsion`, the allocation's thrust inversion
and the controllers use it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sobolev_drake.data import load

if TYPE_CHECKING:   # a type hint only: this module stays pure numpy
    from sobolev_drake.tiltrotor.scalars import Scalar

__all__ = ["PropellerCoefficients"]


class PropellerCoefficients:
    """Ct(J, φ) and Cq(J, φ) of the 24-inch propeller, quartic in (J, φ).

    Conventions (from the json ``description``, which follows the thesis author's simulator):

    * relative air velocity ``(u, v, w)`` of the rotor *with respect to the air* (rotor velocity
      minus wind, (7.31)) expressed in the rotor frame whose z axis is the thrust axis;
    * advance ratio ``J = sqrt(u² + w²) / (n d)`` clamped to ``[0, 0.75]`` (the lateral
      component v is ignored; the thesis (7.29) uses the full magnitude);
    * inflow angle ``φ = |clip(atan2(u, w), −π/2, π/2)|`` (the thesis (7.30) writes
      ``acos(w / V)``; both are 0 in axial flight and π/2 in edgewise flight);
    * thrust ``f = ρ d⁴ n² Ct(J, φ)``, torque ``t = ρ d⁵ n² Cq(J, φ)``, n in rev/s.

    Parameters
    ----------
    data : dict, optional
        Contents of ``data/propeller_coefficients.json`` (read when omitted).
    """

    _POWERS = {"1": (0, 0), "J": (1, 0), "phi": (0, 1), "J^2": (2, 0), "J*phi": (1, 1),
               "phi^2": (0, 2), "J^3": (3, 0), "J^2*phi": (2, 1), "J*phi^2": (1, 2),
               "phi^3": (0, 3), "J^4": (4, 0), "J^3*phi": (3, 1), "J^2*phi^2": (2, 2),
               "J*phi^3": (1, 3), "phi^4": (0, 4)}

    def __init__(self, data: dict | None = None) -> None:
        data = load("propeller_coefficients") if data is None else data
        self.diameter = float(data["diameter_m"])
        self.rho = float(data["rho_kg_m3"])
        self.J_max = float(data["J_range"][1])
        self.basis = list(data["basis"])
        try:
            self._pw = np.array([self._POWERS[b] for b in self.basis], dtype=float)
        except KeyError as exc:  # pragma: no cover - data file is fixed
            raise ValueError(f"unknown basis term {exc} in propeller_coefficients.json") from None
        self._pJ = self._pw[:, 0].astype(np.int64)
        self._pP = self._pw[:, 1].astype(np.int64)
        self.ct_coef = np.asarray(data["Ct"], dtype=float)
        self.cq_coef = np.asarray(data["Cq"], dtype=float)
        self._terms = [((int(i), int(j)), float(a), float(b)) for (i, j), a, b in
                       zip(self._pw, self.ct_coef, self.cq_coef) if a != 0.0 or b != 0.0]
        if self.ct_coef.shape != (len(self.basis),) or self.cq_coef.shape != (len(self.basis),):
            raise ValueError("Ct/Cq coefficient vectors must match the basis length")

    # --- coefficients ------------------------------------------------------------------------
    def _features(self, J, phi):
        J, phi = np.asarray(J, dtype=float), np.asarray(phi, dtype=float)
        if J.shape != phi.shape:
            J, phi = np.broadcast_arrays(J, phi)
        return J[..., None] ** self._pJ * phi[..., None] ** self._pP

    def ct_cq_scalar(self, J: Scalar, phi: Scalar) -> tuple[Scalar, Scalar]:
        """(Ct, Cq) at scalar (J, φ) with Python floats: :meth:`ct` and :meth:`cq` in the scalar
        force tier of :mod:`~sobolev_drake.tiltrotor.propulsion`, without a numpy call per rotor.
        Arithmetic only, so AutoDiffXd or Expression arguments work too (the generic tier,
        :mod:`~sobolev_drake.tiltrotor.generic_forces`).

        Parameters
        ----------
        J, phi : float
            Advance ratio and inflow angle (rad); or AutoDiffXd / Expression.

        Returns
        -------
        tuple of 2 floats
            (Ct, Cq), of the arguments' scalar type.
        """
        Jp = (1.0, J, J * J, J * J * J, J * J * J * J)
        Pp = (1.0, phi, phi * phi, phi * phi * phi, phi * phi * phi * phi)
        ct = cq = 0.0
        for (i, j), a, b in self._terms:
            f = Jp[i] * Pp[j]
            ct += a * f
            cq += b * f
        return ct, cq

    def ct_in_J(self, phi: float) -> tuple[float, float, float, float, float]:
        """Coefficients of the quartic J ↦ Ct(J, φ) at fixed φ (Newton thrust inversion).

        Parameters
        ----------
        phi : float
            Inflow angle (rad).

        Returns
        -------
        tuple of 5 floats
            Coefficients, highest power first.
        """
        Pp = (1.0, phi, phi * phi, phi * phi * phi, phi * phi * phi * phi)
        c = [0.0] * 5
        for (i, j), a, _ in self._terms:
            c[i] += a * Pp[j]
        return c[4], c[3], c[2], c[1], c[0]

    def ct(self, J: ArrayLike, phi: ArrayLike) -> NDArray[np.float64]:
        """Thrust coefficient Ct(J, φ) (vectorized over broadcast J, φ).

        Parameters
        ----------
        J, phi : array_like
            Advance ratio and inflow angle (rad), broadcast together.

        Returns
        -------
        ndarray
            Ct, the broadcast shape.
        """
        return self._features(J, phi) @ self.ct_coef

    def cq(self, J: ArrayLike, phi: ArrayLike) -> NDArray[np.float64]:
        """Torque coefficient Cq(J, φ) (vectorized over broadcast J, φ).

        Parameters
        ----------
        J, phi : array_like
            Advance ratio and inflow angle (rad), broadcast together.

        Returns
        -------
        ndarray
            Cq, the broadcast shape.
        """
        return self._features(J, phi) @ self.cq_coef

    # --- kinematics of the inflow ------------------------------------------------------------
    def advance_ratio_and_inflow(self, v_rel_rotor_frame: ArrayLike,
                                 n: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Advance ratio and inflow angle from the rotor's air-relative velocity (7.29)–(7.30).

        Non-positive n gives J = J_max (a stopped rotor produces ρd⁴n²Ct = 0 thrust anyway).

        Parameters
        ----------
        v_rel_rotor_frame : array_like, shape (..., 3)
            (u, v, w) in the rotor frame, w along the thrust axis (m/s).
        n : array_like
            Propeller speeds (rev/s), broadcast against the leading shape.

        Returns
        -------
        J, phi : ndarray
            Advance ratio (clamped to J_max) and inflow angle (rad).
        """
        vr = np.asarray(v_rel_rotor_frame, dtype=float)
        if vr.shape[-1:] != (3,):
            raise ValueError(f"v_rel_rotor_frame must have shape (..., 3), got {vr.shape}")
        n = np.asarray(n, dtype=float)
        u, w = vr[..., 0], vr[..., 2]
        v_xz = np.hypot(u, w)
        nd = n * self.diameter
        # n ≤ 0 → J = J_max (huge ratio clipped); the thrust ρd⁴n²Ct is 0 at n = 0 anyway
        J = np.minimum(v_xz / np.maximum(nd, 1e-300), self.J_max)
        phi = np.abs(np.clip(np.arctan2(u, w), -np.pi / 2, np.pi / 2))
        return J, phi

    # --- forces ------------------------------------------------------------------------------
    def thrust(self, n: ArrayLike, J: ArrayLike, phi: ArrayLike) -> NDArray[np.float64]:
        """Thrust f = ρ d⁴ n² Ct(J, φ) (7.25)/(7.27).

        Parameters
        ----------
        n : array_like
            Propeller speeds (rev/s).
        J, phi : array_like
            Advance ratio and inflow angle (rad), broadcast together.

        Returns
        -------
        ndarray
            Thrust (N).
        """
        n = np.asarray(n, dtype=float)
        return self.rho * self.diameter ** 4 * n ** 2 * self.ct(J, phi)

    def torque(self, n: ArrayLike, J: ArrayLike, phi: ArrayLike) -> NDArray[np.float64]:
        """Drag torque magnitude t = ρ d⁵ n² Cq(J, φ) (without the rotation sign λ).

        Parameters
        ----------
        n : array_like
            Propeller speeds (rev/s).
        J, phi : array_like
            Advance ratio and inflow angle (rad), broadcast together.

        Returns
        -------
        ndarray
            Torque (N m).
        """
        n = np.asarray(n, dtype=float)
        return self.rho * self.diameter ** 5 * n ** 2 * self.cq(J, phi)

    def torque_per_thrust(self, J: ArrayLike, phi: ArrayLike) -> NDArray[np.float64]:
        """t / f = d Cq / Ct (Appendix C: the drag torque expressed through the thrust).

        Parameters
        ----------
        J, phi : array_like
            Advance ratio and inflow angle (rad), broadcast together.

        Returns
        -------
        ndarray
            Torque per thrust (m).
        """
        return self.diameter * self.cq(J, phi) / self.ct(J, phi)

    def speed_for_thrust(self, f: ArrayLike, J: ArrayLike, phi: ArrayLike) -> NDArray[np.float64]:
        """n ≥ 0 with ρ d⁴ n² Ct(J, φ) = f for *fixed* (J, φ) (inverse of (7.25), f ≥ 0).

        Parameters
        ----------
        f : array_like
            Thrust (N); negative values count as 0.
        J, phi : array_like
            Advance ratio and inflow angle (rad), broadcast together.

        Returns
        -------
        ndarray
            Propeller speeds (rev/s).
        """
        f = np.asarray(f, dtype=float)
        return np.sqrt(np.maximum(f, 0.0) / (self.rho * self.diameter ** 4 * self.ct(J, phi)))
