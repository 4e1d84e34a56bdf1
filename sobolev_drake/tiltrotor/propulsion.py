"""Propellers and servomotors of the tilt-rotor UAV (thesis (7.19)–(7.33), Appendix B).

* :class:`PropulsionModel` — the propeller generalized force (7.32): the numpy reference
  (:meth:`~PropulsionModel.unit_columns` times :meth:`~PropulsionModel.thrust_and_torque`) and
  the scalar tier (:func:`~sobolev_drake.tiltrotor.body_frame.body_kinematics_scalar`,
  :meth:`~PropulsionModel.rotors_scalar`,
  :meth:`~PropulsionModel.propeller_force_scalar`), which ``native/forces.c`` mirrors.
* :class:`PropellerForces` — LeafSystem: generalized force of both propellers (7.32) and of the
  servomotors with viscous friction (7.33), in thesis order; ``PropellerForces_[T]`` for
  AutoDiffXd and Expression runs the scalar-generic tier
  (:func:`~sobolev_drake.tiltrotor.generic_forces.propeller_force_generic`).

The propeller's coefficients Ct(J, φ), Cq(J, φ) (7.25)–(7.30) are
:class:`~sobolev_drake.tiltrotor.propeller.PropellerCoefficients`.  The scalar tier is kept
beside the reference because ``benchmarks/speed_tiers.py`` measures it ≈ 6× faster on the
paths that run without the compiled kernel (the plant's forces when the kernel is not built;
the trims and the force systems here, which it does not cover).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from types import ModuleType

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pydrake.systems.framework import LeafSystem_
from pydrake.systems.scalar_conversion import TemplateSystem

from sobolev_drake.tiltrotor.body_frame import BodyKinematics, body_kinematics_scalar, body_wrench_scalar
from sobolev_drake.tiltrotor.generic_forces import propeller_force_generic
from sobolev_drake.tiltrotor.params import R_W, TiltrotorParams, cross_rows
from sobolev_drake.tiltrotor.propeller import PropellerCoefficients
from sobolev_drake.tiltrotor.scalars import Scalar, ScalarMath, default_instantiation, scalar_math

__all__ = [
    "body_kinematics_scalar", "body_wrench_scalar", "PropulsionModel", "PropellerForces",
    "PropellerForces_",
]


class PropulsionModel:
    """The propeller (7.19)–(7.32) and servomotor (7.33) generalized forces.

    Two forms of ϑ_P (module docstring): the numpy reference (:meth:`unit_columns` times
    :meth:`thrust_and_torque`) and the scalar tier (:meth:`rotors_scalar`,
    :meth:`propeller_force_scalar`, :meth:`propeller_force`).

    Parameters
    ----------
    params : TiltrotorParams, optional
        Table B.1 by default.
    coefficients : PropellerCoefficients, optional
        Ct, Cq of the package data by default.
    """

    def __init__(self, params: TiltrotorParams | None = None,
                 coefficients: PropellerCoefficients | None = None) -> None:
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
        # ∂Ct/∂J, ∂Cq/∂J at J = 0 as polynomials in φ: (power of φ, Ct coefficient, Cq coefficient)
        self._dJ_terms = [(j, a, b) for (i, j), a, b in c._terms if i == 1]

    def rotor_frames(self, q: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64],
                                                NDArray[np.float64]]:
        """Rotor frames and hub positions of both rotors (7.19)–(7.24).

        Parameters
        ----------
        q : array_like, shape (8,)
            Generalized coordinates, thesis order.

        Returns
        -------
        R_BA : ndarray, shape (2, 3, 3)
            Rotor frames in body axes.
        r : ndarray, shape (2, 3)
            Rotor centres, body axes.
        d : ndarray, shape (2, 3)
            R_B^A d_A,P.
        """
        sb, cb = math.sin(self.params.beta), math.cos(self.params.beta)
        RA = np.empty((2, 3, 3))
        for k, (a, s) in enumerate(((q[0], -sb), (q[1], sb))):   # Ry(α) Rx(∓β)
            sa, ca = math.sin(a), math.cos(a)
            RA[k] = ((ca, sa * s, sa * cb), (0.0, cb, -s), (-sa, ca * s, ca * cb))
        dA = RA @ self.params.d_A_P
        return RA, self.d_B_A + dA, dA

    def rotor_air_velocity(self, q: ArrayLike, qdot: np.ndarray, zeta: ArrayLike) -> NDArray[np.float64]:
        """Air-relative rotor velocities in the rotor frames (7.31).

        Parameters
        ----------
        q, qdot : array_like, shape (8,)
            Generalized coordinates and velocities, thesis order.
        zeta : array_like, shape (3,)
            Wind, inertial axes (m/s).

        Returns
        -------
        ndarray, shape (2, 3)
            (u, v, w) per rotor, w along its thrust axis (m/s).
        """
        RA, r, dA = self.rotor_frames(q)
        R, W = R_W(q)
        w = W @ qdot[2:5]
        vb = (R.T @ (qdot[5:8] - zeta)) + cross_rows(w[None, :], r)
        # tilt rate about B's y axis through A: α̇ e_y × R_B^A d_A,P = α̇ [d_z, 0, −d_x]
        vb[:, 0] += qdot[0:2] * dA[:, 2]
        vb[:, 2] -= qdot[0:2] * dA[:, 0]
        return np.einsum("kji,kj->ki", RA, vb)

    def unit_columns(self, q: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Generalized force per newton of thrust and per N m of torque about each rotor axis
        (7.32): the numpy reference of ϑ_P is ``G_f f + G_t λt`` (:meth:`thrust_and_torque`).

        Parameters
        ----------
        q : array_like, shape (8,)
            Generalized coordinates, thesis order.

        Returns
        -------
        G_f, G_t : ndarray, shape (8, 2)
            Thrust and torque columns, thesis order.
        """
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

    def thrust_and_torque(self, q: ArrayLike, qdot: np.ndarray, zeta: ArrayLike, n: ArrayLike
                          ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64],
                                     NDArray[np.float64]]:
        """Thrusts, signed drag torques and inflow of both rotors (7.25)–(7.31).

        Parameters
        ----------
        q, qdot : array_like, shape (8,)
            Generalized coordinates and velocities, thesis order.
        zeta : array_like, shape (3,)
            Wind, inertial axes (m/s).
        n : array_like, shape (2,)
            Propeller speeds (rev/s).

        Returns
        -------
        f : ndarray, shape (2,)
            Thrusts (N).
        t : ndarray, shape (2,)
            Signed drag torques λ t (N m).
        J, phi : ndarray, shape (2,)
            Advance ratios and inflow angles (rad).
        """
        vr = self.rotor_air_velocity(q, qdot, zeta)
        J, phi = self.coef.advance_ratio_and_inflow(vr, n)
        f = self.coef.thrust(n, J, phi)
        t = self.lam * self.coef.torque(n, J, phi)
        return f, t, J, phi

    def rotors_scalar(self, q: Sequence[Scalar], qdot: Sequence[Scalar], kin: BodyKinematics,
                      m: ModuleType | ScalarMath = math) -> tuple[tuple[Scalar, ...], tuple[Scalar, ...]]:
        """Per-rotor geometry and inflow with Python floats (scalar tier of the plant's forces
        and the controller's input-affine terms, module docstring); branch-free, so it serves
        every scalar type with the matching ``m``.

        Parameters
        ----------
        q, qdot : list of 8 floats
            Generalized coordinates and velocities, thesis order.
        kin : tuple
            From :func:`body_kinematics_scalar`.
        m : module or ScalarMath, default math
            ``sin`` and ``cos`` of the scalar type.

        Returns
        -------
        tuple of two tuples
            (right, left rotor), each ``(dx, dy, dz, rx, ry, rz, zx, zy, zz, u, w)``:
            R_B^A d_A,P, the hub position r in body axes, the rotor axis z in body axes and the
            rotor-frame air-relative velocity components u (in-plane x) and w (axial) (7.31).
        """
        sin, cos = m.sin, m.cos
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

    def propeller_force_scalar(self, kin: BodyKinematics, rotors: tuple[tuple[float, ...], tuple[float, ...]],
                               n: Sequence[float]) -> list[float]:
        """ϑ_P (7.32) in Python floats (scalar tier; the compiled kernel mirrors it).

        Parameters
        ----------
        kin : tuple
            From :func:`body_kinematics_scalar`.
        rotors : tuple
            From :meth:`rotors_scalar`.
        n : sequence of 2 floats
            Propeller speeds (rev/s).

        Returns
        -------
        list of 8 floats
            ϑ_P, thesis order.
        """
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

    def propeller_force(self, q: ArrayLike, qdot: ArrayLike, zeta: ArrayLike,
                        n: ArrayLike) -> NDArray[np.float64]:
        """ϑ_P (7.32), thesis order, by the scalar tier: the reference ``G_f f + G_t λt`` of
        :meth:`unit_columns` and :meth:`thrust_and_torque` to rounding (tested).

        Kept beside the reference because ``benchmarks/speed_tiers.py`` measures it ≈ 6× faster.

        Parameters
        ----------
        q, qdot : array_like, shape (8,)
            Generalized coordinates and velocities, thesis order.
        zeta : array_like, shape (3,)
            Wind, inertial axes (m/s).
        n : array_like, shape (2,)
            Propeller speeds (rev/s).

        Returns
        -------
        ndarray, shape (8,)
            ϑ_P, thesis order.
        """
        # Python floats: arithmetic on numpy scalars is several times slower
        q, qdot = [float(v) for v in q], [float(v) for v in qdot]
        zeta, n = [float(v) for v in zeta], [float(v) for v in n]
        kin = body_kinematics_scalar(q, qdot, zeta)
        return np.array(self.propeller_force_scalar(kin, self.rotors_scalar(q, qdot, kin), n))

    def servo_force(self, qdot: np.ndarray, tau_s: ArrayLike) -> NDArray[np.float64]:
        """ϑ_s (7.33): τs acts about the inclined y axis of C2/C3, i.e. cos β τs on the tilt
        joint (the reaction on the body cancels), minus viscous friction ν α̇.

        Parameters
        ----------
        qdot : array_like, shape (8,)
            Generalized velocities, thesis order.
        tau_s : array_like, shape (2,)
            Servo torques (N m).

        Returns
        -------
        ndarray, shape (8,)
            ϑ_s, thesis order.
        """
        out = np.zeros(8)
        out[0:2] = self.cosb * np.asarray(tau_s) - self.params.nu * qdot[0:2]
        return out


@TemplateSystem.define("PropellerForces_")
def PropellerForces_(T):
    """PropellerForces_[T] for T in float, AutoDiffXd, Expression (``PropellerForces`` is
    ``PropellerForces_[float]``)."""
    m = scalar_math(T)

    class Impl(LeafSystem_[T]):
        """LeafSystem: generalized force of both propellers (7.32) and both servomotors (7.33).

        .. pydrake_system::

            name: PropellerForces
            input_ports:
            - x
            - wind
            - propeller_speed
            - servo_torque
            output_ports:
            - generalized_force

        Inputs: ``x`` (16, thesis order), ``wind`` (3, inertial m/s), ``propeller_speed`` (2,
        rev/s), ``servo_torque`` (2, N m); the last three read zero when unconnected.
        Output: ``generalized_force`` (8, thesis order).

        Scalar types (``PropellerForces_[T]``): double runs the float tier
        (:meth:`PropulsionModel.propeller_force`); ``ToAutoDiffXd()`` and ``ToSymbolic()`` give
        systems on :func:`~sobolev_drake.tiltrotor.generic_forces.propeller_force_generic`
        (equal values; its derivative at zero inflow is documented there).

        Parameters
        ----------
        params : TiltrotorParams, optional
            Table B.1 by default.
        """

        def _construct(self, params=None, converter=None):
            LeafSystem_[T].__init__(self, converter=converter)
            self.core = PropulsionModel(params)
            self._x = self.DeclareVectorInputPort("x", 16)
            self._wind = self.DeclareVectorInputPort("wind", 3)
            self._n = self.DeclareVectorInputPort("propeller_speed", 2)
            self._ts = self.DeclareVectorInputPort("servo_torque", 2)
            # explicit prerequisites: the feedthrough is known without symbolic inspection
            self.DeclareVectorOutputPort("generalized_force", 8, self._calc,
                                         prerequisites_of_calc={self.all_input_ports_ticket()})

        def _construct_copy(self, other, converter=None):
            Impl._construct(self, other.core.params, converter=converter)

        @staticmethod
        def _opt(port, context, size):
            return np.asarray(port.Eval(context)) if port.HasValue(context) else np.zeros(size)

        def _calc(self, context, output) -> None:
            x = np.asarray(self._x.Eval(context))
            zeta = self._opt(self._wind, context, 3)
            n = self._opt(self._n, context, 2)
            ts = self._opt(self._ts, context, 2)
            q, qd = x[:8], x[8:]
            core = self.core
            if T is float:
                output.SetFromVector(core.propeller_force(q, qd, zeta, n) + core.servo_force(qd, ts))
                return
            q, qd, zeta, n, ts = (v.tolist() for v in (q, qd, zeta, n, ts))
            kin = body_kinematics_scalar(q, qd, zeta, m)
            out = propeller_force_generic(core, kin, core.rotors_scalar(q, qd, kin, m), n, m)
            for k in (0, 1):            # servo_force: cos β τs − ν α̇, added as in the float path
                out[k] = out[k] + (core.cosb * ts[k] - core.params.nu * qd[k])
            output.SetFromVector(out)

    return Impl


PropellerForces = default_instantiation(PropellerForces_, "PropellerForces")
