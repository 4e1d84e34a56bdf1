"""Propellers and servomotors of the tilt-rotor UAV (thesis (7.19)–(7.33), Appendix B).

* :class:`PropellerCoefficients` — wind-tunnel thrust/torque coefficients Ct(J, φ), Cq(J, φ)
  (``data/propeller_coefficients.json``), advance ratio and inflow angle, thrust and torque
  (7.25)–(7.28).  Pure numpy, vectorized; used by the plant, the allocation and the controllers.
* :class:`PropellerForces` — LeafSystem: generalized force of both propellers (7.32) and of the
  servomotors with viscous friction (7.33), in thesis order.
"""

from __future__ import annotations

import math

import numpy as np
from pydrake.systems.framework import BasicVector, LeafSystem

from sobolev_drake.data import load
from sobolev_drake.tiltrotor.params import R_W, TiltrotorParams, cross_rows

__all__ = [
    "body_kinematics_scalar", "body_wrench_scalar", "PropellerCoefficients", "PropulsionModel",
    "PropellerForces",
]


def body_kinematics_scalar(q, qdot, zeta):
    """Body-frame kinematics of the fast (Python scalar) force paths, thesis order q.

    ``q``, ``qdot`` (size 8) and the wind ``zeta`` (size 3) must already be lists of Python
    floats.  Returns ((sin ϕ, cos ϕ, sin θ, cos θ), R row-major (9 floats, body → inertial,
    Z-Y-X Euler angles), body angular velocity (wx, wy, wz) and body air velocity
    Rᵀ(ṗ − ζ) (vbx, vby, vbz)).  Shared by the propeller and aerodynamic force paths.
    """
    sin, cos = math.sin, math.cos
    sf, cf = sin(q[2]), cos(q[2])
    st, ct = sin(q[3]), cos(q[3])
    sp, cp = sin(q[4]), cos(q[4])
    r00, r01, r02 = cp * ct, cp * st * sf - sp * cf, cp * st * cf + sp * sf
    r10, r11, r12 = sp * ct, sp * st * sf + cp * cf, sp * st * cf - cp * sf
    r20, r21, r22 = -st, ct * sf, ct * cf
    dphi, dth, dpsi = qdot[2], qdot[3], qdot[4]
    wx, wy, wz = dphi - st * dpsi, cf * dth + ct * sf * dpsi, -sf * dth + cf * ct * dpsi
    vix, viy, viz = qdot[5] - zeta[0], qdot[6] - zeta[1], qdot[7] - zeta[2]
    vbx = r00 * vix + r10 * viy + r20 * viz
    vby = r01 * vix + r11 * viy + r21 * viz
    vbz = r02 * vix + r12 * viy + r22 * viz
    return ((sf, cf, st, ct), (r00, r01, r02, r10, r11, r12, r20, r21, r22),
            (wx, wy, wz), (vbx, vby, vbz))


def body_wrench_scalar(kin, force, torque):
    """Rows 2..7 (φ θ ψ x y z) of the generalized force of a body-axes force ``force`` and
    torque ``torque`` (about C1) on the main body: [Wηᵀ T, R F] (scalar form of
    ``tiltrotor_params.body_generalized_force``).  ``kin`` from :func:`body_kinematics_scalar`."""
    (sf, cf, st, ct), (r00, r01, r02, r10, r11, r12, r20, r21, r22), _, _ = kin
    fx, fy, fz = force
    tx, ty, tz = torque
    return (tx, cf * ty - sf * tz, -st * tx + ct * sf * ty + cf * ct * tz,
            r00 * fx + r01 * fy + r02 * fz, r10 * fx + r11 * fy + r12 * fz,
            r20 * fx + r21 * fy + r22 * fz)


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

    def ct_cq_scalar(self, J: float, phi: float):
        """(Ct, Cq) at scalar (J, φ) with Python floats (fast path of the plant)."""
        Jp = (1.0, J, J * J, J * J * J, J * J * J * J)
        Pp = (1.0, phi, phi * phi, phi * phi * phi, phi * phi * phi * phi)
        ct = cq = 0.0
        for (i, j), a, b in self._terms:
            f = Jp[i] * Pp[j]
            ct += a * f
            cq += b * f
        return ct, cq

    def ct_scalar(self, J: float, phi: float) -> float:
        """Ct at scalar (J, φ) with Python floats (Newton thrust inversion of the controller)."""
        Jp = (1.0, J, J * J, J * J * J, J * J * J * J)
        Pp = (1.0, phi, phi * phi, phi * phi * phi, phi * phi * phi * phi)
        ct = 0.0
        for (i, j), a, _ in self._terms:
            ct += a * (Jp[i] * Pp[j])
        return ct

    def ct_in_J(self, phi: float):
        """Coefficients (highest power first) of the quartic J ↦ Ct(J, φ) at fixed φ."""
        Pp = (1.0, phi, phi * phi, phi * phi * phi, phi * phi * phi * phi)
        c = [0.0] * 5
        for (i, j), a, _ in self._terms:
            c[i] += a * Pp[j]
        return c[4], c[3], c[2], c[1], c[0]

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
        # n ≤ 0 → J = J_max (huge ratio clipped); the thrust ρd⁴n²Ct is 0 at n = 0 anyway
        J = np.minimum(v_xz / np.maximum(nd, 1e-300), self.J_max)
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
        self._lam_f = [float(v) for v in self.lam]
        self._dBA_f = [[float(v) for v in A] for A in self.d_B_A]
        self._dAP_f = [float(v) for v in p.d_A_P]
        self._sb, self._cb = math.sin(p.beta), math.cos(p.beta)
        c = self.coef
        self._kf, self._kt = c.rho * c.diameter ** 4, c.rho * c.diameter ** 5

    def rotor_frames(self, q):
        """(R_B^A (2,3,3), rotor centres in body axes r (2,3), R_B^A d_A,P (2,3))."""
        sb, cb = math.sin(self.params.beta), math.cos(self.params.beta)
        RA = np.empty((2, 3, 3))
        for k, (a, s) in enumerate(((q[0], -sb), (q[1], sb))):   # Ry(α) Rx(∓β)
            sa, ca = math.sin(a), math.cos(a)
            RA[k] = ((ca, sa * s, sa * cb), (0.0, cb, -s), (-sa, ca * s, ca * cb))
        dA = RA @ self.params.d_A_P
        return RA, self.d_B_A + dA, dA

    def rotor_air_velocity(self, q, qdot, zeta):
        """Air-relative rotor velocities in the rotor frames (2, 3) (7.31)."""
        RA, r, dA = self.rotor_frames(q)
        R, W = R_W(q)
        w = W @ qdot[2:5]
        vb = (R.T @ (qdot[5:8] - zeta)) + cross_rows(w[None, :], r)
        # tilt rate about B's y axis through A: α̇ e_y × R_B^A d_A,P = α̇ [d_z, 0, −d_x]
        vb[:, 0] += qdot[0:2] * dA[:, 2]
        vb[:, 2] -= qdot[0:2] * dA[:, 0]
        return np.einsum("kji,kj->ki", RA, vb)

    def unit_columns(self, q):
        """(G_f (8, 2), G_t (8, 2)): generalized force per newton of thrust and per N m of torque
        about each rotor axis (7.32)."""
        RA, r, dA = self.rotor_frames(q)
        z = RA[:, :, 2]                                     # rotor axes in body axes
        R, W = R_W(q)
        Wt = W.T
        Gf = np.zeros((8, 2))
        Gt = np.zeros((8, 2))
        Gf[[0, 1], [0, 1]] = dA[:, 2] * z[:, 0] - dA[:, 0] * z[:, 2]   # e_y · (R_B^A d × z)
        Gf[2:5] = Wt @ cross_rows(r, z).T
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

    def propeller_force_vectorized(self, q, qdot, zeta, n):
        """ϑ_P (7.32), thesis order (numpy version of :meth:`propeller_force`)."""
        f, t, _, _ = self.thrust_and_torque(q, qdot, zeta, n)
        Gf, Gt = self.unit_columns(q)
        return Gf @ f + Gt @ t

    def rotors_scalar(self, q, qdot, kin):
        """Per-rotor geometry and inflow with Python floats (fast paths of plant and controller).

        ``q``, ``qdot``: lists of floats (thesis order); ``kin``: :func:`body_kinematics_scalar`.
        Returns two tuples (right, left rotor) of ``(dx, dy, dz, rx, ry, rz, zx, zy, zz, u, w)``:
        R_B^A d_A,P, the hub position r in body axes, the rotor axis z in body axes and the
        rotor-frame air-relative velocity components u (in-plane x) and w (axial) (7.31).
        """
        sin, cos = math.sin, math.cos
        _, _, (wx, wy, wz), (vbx, vby, vbz) = kin
        sb, cb = self._sb, self._cb
        px, py, pz = self._dAP_f
        out = []
        for k, (a, s, A) in enumerate(((q[0], -sb, self._dBA_f[0]), (q[1], sb, self._dBA_f[1]))):
            sa, ca = sin(a), cos(a)
            # R_B^A = Ry(α) Rx(s) with s = ∓β
            m00, m01, m02 = ca, sa * s, sa * cb
            m11, m12 = cb, -s
            m20, m21, m22 = -sa, ca * s, ca * cb
            dx = m00 * px + m01 * py + m02 * pz
            dy = m11 * py + m12 * pz
            dz = m20 * px + m21 * py + m22 * pz
            rx, ry, rz = A[0] + dx, A[1] + dy, A[2] + dz
            ad = qdot[k]
            ux = vbx + wy * rz - wz * ry + ad * dz
            uy = vby + wz * rx - wx * rz
            uz = vbz + wx * ry - wy * rx - ad * dx
            out.append((dx, dy, dz, rx, ry, rz, m02, m12, m22,
                        m00 * ux + m20 * uz,                   # rotor frame: R_B^Aᵀ v
                        m02 * ux + m12 * uy + m22 * uz))
        return out[0], out[1]

    def propeller_force_scalar(self, kin, rotors, n):
        """ϑ_P (7.32) as a list of 8 floats from :func:`body_kinematics_scalar` and
        :meth:`rotors_scalar` at propeller speeds ``n`` (two floats)."""
        sqrt, atan2 = math.sqrt, math.atan2
        c = self.coef
        d, Jmax = c.diameter, c.J_max
        kf, kt = self._kf, self._kt
        out = [0.0] * 8
        Fx = Fy = Fz = Tx = Ty = Tz = 0.0
        for k in (0, 1):
            dx, dy, dz, rx, ry, rz, zx, zy, zz, u, w = rotors[k]
            nk = n[k]
            nd = nk * d
            J = sqrt(u * u + w * w) / nd if nd > 0 else Jmax
            J = Jmax if J > Jmax else J
            phi = atan2(u, w)
            phi = abs(1.5707963267948966 if phi > 1.5707963267948966 else
                      (-1.5707963267948966 if phi < -1.5707963267948966 else phi))
            cT, cQ = c.ct_cq_scalar(J, phi)
            f = kf * nk * nk * cT
            t = self._lam_f[k] * kt * nk * nk * cQ
            bx, by, bz = f * zx, f * zy, f * zz
            out[k] = dz * bx - dx * bz + t * zy          # e_y · (R_B^A d × F + T)
            Fx += bx
            Fy += by
            Fz += bz
            Tx += ry * bz - rz * by + t * zx
            Ty += rz * bx - rx * bz + t * zy
            Tz += rx * by - ry * bx + t * zz
        out[2:8] = body_wrench_scalar(kin, (Fx, Fy, Fz), (Tx, Ty, Tz))
        return out

    def propeller_force(self, q, qdot, zeta, n):
        """ϑ_P (7.32), thesis order — Python scalar math (small numpy calls cost more than the
        arithmetic); equal to :meth:`propeller_force_vectorized` (tested)."""
        # Python floats: arithmetic on numpy scalars is several times slower
        q, qdot = [float(v) for v in q], [float(v) for v in qdot]
        zeta, n = [float(v) for v in zeta], [float(v) for v in n]
        kin = body_kinematics_scalar(q, qdot, zeta)
        return np.array(self.propeller_force_scalar(kin, self.rotors_scalar(q, qdot, kin), n))

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
