"""Propellers and servomotors of the tilt-rotor UAV (thesis (7.19)–(7.33), Appendix B).

* :class:`PropellerCoefficients` — wind-tunnel thrust/torque coefficients Ct(J, φ), Cq(J, φ)
  (``data/propeller_coefficients.json``), advance ratio and inflow angle, thrust and torque
  (7.25)–(7.28).  Pure numpy, vectorized; used by the plant, the allocation and the controllers.
* :class:`PropellerForces` — LeafSystem: generalized force of both propellers (7.32) and of the
  servomotors with viscous friction (7.33), in thesis order.
"""

from __future__ import annotations

import numpy as np
from pydrake.systems.framework import BasicVector, LeafSystem

from sobolev_drake.data import load
from sobolev_drake.models.tiltrotor_params import R_BA, R_IB, TiltrotorParams, W_eta


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


class PropulsionModel:
    """Numpy core of the propeller (7.19)–(7.32) and servomotor (7.33) generalized forces."""

    def __init__(self, params=None, coefficients: PropellerCoefficients | None = None):
        self.params = TiltrotorParams() if params is None else params
        self.coef = PropellerCoefficients() if coefficients is None else coefficients
        p = self.params
        self.lam = np.array([p.lambda_R, p.lambda_L])
        self.d_B_A = np.array([p.d_B_A2, p.d_B_A3])
        self.cosb = np.cos(p.beta)

    def rotor_frames(self, q):
        """(R_B^A (2,3,3), rotor centres in body axes r (2,3), R_B^A d_A,P (2,3))."""
        RA = np.array(R_BA(self.params, q[0], q[1]))
        dA = RA @ self.params.d_A_P
        return RA, self.d_B_A + dA, dA

    def rotor_air_velocity(self, q, qdot, zeta):
        """Air-relative rotor velocities in the rotor frames (2, 3) (7.31)."""
        RA, r, dA = self.rotor_frames(q)
        R = R_IB(q)
        w = W_eta(q) @ qdot[2:5]
        vb = (R.T @ (qdot[5:8] - zeta))[None, :] + np.cross(w, r)
        vb += qdot[0:2, None] * np.cross(np.array([0.0, 1.0, 0.0]), dA)   # tilt rate about B's y
        return np.einsum("kji,kj->ki", RA, vb)

    def unit_columns(self, q):
        """(G_f (8, 2), G_t (8, 2)): generalized force per newton of thrust and per N m of torque
        about each rotor axis (7.32)."""
        RA, r, dA = self.rotor_frames(q)
        z = RA[:, :, 2]                                     # rotor axes in body axes
        Wt, R = W_eta(q).T, R_IB(q)
        Gf = np.zeros((8, 2))
        Gt = np.zeros((8, 2))
        Gf[[0, 1], [0, 1]] = np.cross(dA, z)[:, 1]          # e_y · (R_B^A d × z)
        Gf[2:5] = Wt @ np.cross(r, z).T
        Gf[5:8] = R @ z.T
        Gt[[0, 1], [0, 1]] = z[:, 1]
        Gt[2:5] = Wt @ z.T
        return Gf, Gt

    def thrust_and_torque(self, q, qdot, zeta, n):
        """(f (2,), signed torques λ t (2,), J (2,), φ (2,)) for propeller speeds n (rev/s)."""
        vr = self.rotor_air_velocity(q, qdot, zeta)
        J, phi = self.coef.advance_ratio_and_inflow(vr, n)
        f = self.coef.thrust(n, J, phi)
        t = self.lam * self.coef.torque(n, J, phi)
        return f, t, J, phi

    def propeller_force(self, q, qdot, zeta, n):
        """ϑ_P (7.32), thesis order."""
        f, t, _, _ = self.thrust_and_torque(q, qdot, zeta, n)
        Gf, Gt = self.unit_columns(q)
        return Gf @ f + Gt @ t

    def servo_force(self, qdot, tau_s):
        """ϑ_s (7.33): τs acts about the inclined y axis of C2/C3, i.e. cos β τs on the tilt
        joint (the reaction on the body cancels), minus viscous friction ν α̇."""
        out = np.zeros(8)
        out[0:2] = self.cosb * np.asarray(tau_s) - self.params.nu * qdot[0:2]
        return out


class PropellerForces(LeafSystem):
    """LeafSystem: generalized force of both propellers (7.32) and both servomotors (7.33).

    Inputs: ``x`` (16, thesis order), ``wind`` (3, inertial m/s), ``propeller_speed`` (2, rev/s),
    ``servo_torque`` (2, N m); the last three read zero when unconnected.
    Output: ``generalized_force`` (8, thesis order).
    """

    def __init__(self, params=None):
        super().__init__()
        self.core = PropulsionModel(params)
        self._x = self.DeclareVectorInputPort("x", 16)
        self._wind = self.DeclareVectorInputPort("wind", 3)
        self._n = self.DeclareVectorInputPort("propeller_speed", 2)
        self._ts = self.DeclareVectorInputPort("servo_torque", 2)
        self.DeclareVectorOutputPort("generalized_force", 8, self._calc)

    @staticmethod
    def _opt(port, context, size):
        return np.asarray(port.Eval(context)) if port.HasValue(context) else np.zeros(size)

    def _calc(self, context, output: BasicVector) -> None:
        x = np.asarray(self._x.Eval(context))
        zeta = self._opt(self._wind, context, 3)
        n = self._opt(self._n, context, 2)
        ts = self._opt(self._ts, context, 2)
        q, qd = x[:8], x[8:]
        output.SetFromVector(self.core.propeller_force(q, qd, zeta, n) + self.core.servo_force(qd, ts))
