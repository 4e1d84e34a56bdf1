"""Propellers and servomotors of the tilt-rotor UAV (thesis (7.19)–(7.33), Appendix B).

* :class:`PropellerCoefficients` — wind-tunnel thrust/torque coefficients Ct(J, φ), Cq(J, φ)
  (``data/propeller_coefficients.json``), advance ratio and inflow angle, thrust and torque
  (7.25)–(7.28).  Pure numpy, vectorized; used by the plant, the allocation and the controllers.
* :class:`PropellerForces` — LeafSystem: generalized force of both propellers (7.32) and of the
  servomotors with viscous friction (7.33), in thesis order.
"""

from __future__ import annotations

import numpy as np

from sobolev_drake.data import load


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
    """

    _POWERS = {"1": (0, 0), "J": (1, 0), "phi": (0, 1), "J^2": (2, 0), "J*phi": (1, 1),
               "phi^2": (0, 2), "J^3": (3, 0), "J^2*phi": (2, 1), "J*phi^2": (1, 2),
               "phi^3": (0, 3), "J^4": (4, 0), "J^3*phi": (3, 1), "J^2*phi^2": (2, 2),
               "J*phi^3": (1, 3), "phi^4": (0, 4)}

    def __init__(self, data: dict | None = None):
        data = load("propeller_coefficients") if data is None else data
        self.diameter = float(data["diameter_m"])
        self.rho = float(data["rho_kg_m3"])
        self.J_max = float(data["J_range"][1])
        self.basis = list(data["basis"])
        try:
            self._pw = np.array([self._POWERS[b] for b in self.basis], dtype=float)
        except KeyError as exc:  # pragma: no cover - data file is fixed
            raise ValueError(f"unknown basis term {exc} in propeller_coefficients.json") from None
        self.ct_coef = np.asarray(data["Ct"], dtype=float)
        self.cq_coef = np.asarray(data["Cq"], dtype=float)
        if self.ct_coef.shape != (len(self.basis),) or self.cq_coef.shape != (len(self.basis),):
            raise ValueError("Ct/Cq coefficient vectors must match the basis length")

    # --- coefficients ------------------------------------------------------------------------
    def _features(self, J, phi):
        J, phi = np.broadcast_arrays(np.asarray(J, dtype=float), np.asarray(phi, dtype=float))
        return J[..., None] ** self._pw[:, 0] * phi[..., None] ** self._pw[:, 1]

    def ct(self, J, phi):
        """Thrust coefficient Ct(J, φ) (vectorized over broadcast J, φ)."""
        return self._features(J, phi) @ self.ct_coef

    def cq(self, J, phi):
        """Torque coefficient Cq(J, φ) (vectorized over broadcast J, φ)."""
        return self._features(J, phi) @ self.cq_coef

    # --- kinematics of the inflow ------------------------------------------------------------
    def advance_ratio_and_inflow(self, v_rel_rotor_frame, n):
        """(J, φ) from the rotor's air-relative velocity in the rotor frame and n (rev/s).

        ``v_rel_rotor_frame`` has shape (..., 3) = (u, v, w) with w along the thrust axis;
        ``n`` broadcasts against the leading shape.  Non-positive n gives J = J_max (a stopped
        rotor produces ρd⁴n²Ct = 0 thrust anyway).
        """
        vr = np.asarray(v_rel_rotor_frame, dtype=float)
        if vr.shape[-1:] != (3,):
            raise ValueError(f"v_rel_rotor_frame must have shape (..., 3), got {vr.shape}")
        n = np.asarray(n, dtype=float)
        u, w = vr[..., 0], vr[..., 2]
        v_xz = np.hypot(u, w)
        nd = n * self.diameter
        with np.errstate(divide="ignore", invalid="ignore"):
            J = np.where(nd > 0, v_xz / np.where(nd > 0, nd, 1.0), self.J_max)
        J = np.clip(J, 0.0, self.J_max)
        phi = np.abs(np.clip(np.arctan2(u, w), -np.pi / 2, np.pi / 2))
        return J, phi

    # --- forces ------------------------------------------------------------------------------
    def thrust(self, n, J, phi):
        """Thrust f = ρ d⁴ n² Ct(J, φ) [N] (7.25)/(7.27), n in rev/s."""
        n = np.asarray(n, dtype=float)
        return self.rho * self.diameter ** 4 * n ** 2 * self.ct(J, phi)

    def torque(self, n, J, phi):
        """Drag torque magnitude t = ρ d⁵ n² Cq(J, φ) [N m] (without the rotation sign λ)."""
        n = np.asarray(n, dtype=float)
        return self.rho * self.diameter ** 5 * n ** 2 * self.cq(J, phi)

    def torque_per_thrust(self, J, phi):
        """t / f = d Cq / Ct (Appendix C: the drag torque expressed through the thrust)."""
        return self.diameter * self.cq(J, phi) / self.ct(J, phi)

    def speed_for_thrust(self, f, J, phi):
        """n ≥ 0 with ρ d⁴ n² Ct(J, φ) = f for *fixed* (J, φ) (inverse of (7.25), f ≥ 0)."""
        f = np.asarray(f, dtype=float)
        return np.sqrt(np.maximum(f, 0.0) / (self.rho * self.diameter ** 4 * self.ct(J, phi)))
