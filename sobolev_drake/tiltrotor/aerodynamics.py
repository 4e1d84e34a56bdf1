"""Fuselage, wings, V-tail and interference aerodynamics of the tilt-rotor (7.34)–(7.56), (B.1)–(B.15).

Conventions (our reading of the partly garbled Appendix B, chosen so that drag opposes the air-
relative motion, lift is perpendicular to it and side force / moments are restoring where the
wind-tunnel slopes say so):

* surfaces ``SURFACES = (F, WR, WL, TR, TL, I)`` at the body points of Table B.1 (I at C1);
  every surface frame has the body orientation (Appendix B: R_I^S = R_I^B);
* air-relative velocity (u, v, w) = R_Bᵀ(ṗ_S − ζ) (7.37); V = |(u, v, w)| (7.38);
  α = atan2(w, max(u, 0)), i.e. atan2(w, u) clipped to [−π/2, π/2] ((7.39) with a sign-safe
  arctangent, continuous through u = 0 when w ≠ 0, e.g. vertical climb in hover; pure backward
  flow w = 0, u < 0 gives α = 0), β = asin(v / V) (7.40) — ``reverse_flow="clipped"``, the
  default; see "Reverse flow" below for ``"mirrored"``;
* table arguments α_NED = −α, β_NED = −β (App. B), linear interpolation on the 0.5° grid;
* wind-axes forces (after the NED → z-up rotation Rx(π) of (B.1)–(B.4)):
  f_d = −κ s (c_d^xy(β_NED) + c_d^xz(α_NED)), f_y = κ s (c_y(β_NED) [+ c_δr δr]),
  f_l = κ s (c_l(α_NED) [+ c_δa δW | + c_δe δe]), κ = ½ ρ V²;
* wind axes → surface axes by R_S^W = Ry(−α) Rz(β), whose first column is the air-relative
  velocity direction.  The thesis writes Ry(−α) Rz(−β); with β = asin(v/V) that would make the
  drag push sideways *with* the sideslip, so we read it as a sign slip;
* moments in surface axes [L, M, N] = Rx(π) [0, κ s c̄ c_M(α_NED), κ s b c_N(β_NED)] (B.5)–(B.11);
* areas: s = S for fuselage and interference, S/2 for each wing and tail half (App. B);
  δe = ½(δTR + δTL), δr = ½(δTR − δTL) act on both tail halves.

Crossflow (``TiltrotorParams.crossflow``).  The α tables were measured at β = 0 and the β tables
at α = 0; (7.41)–(7.45) add both at the full dynamic pressure κ.  In a sideways flow (β → ±90°,
u, w → 0) the angle of attack is undefined: (7.39) gives α = ±90° for any small w, and the
α tables then add a flat-plate drag (c_d^xz(90°) ≈ 1.0–1.4 for wing, fuselage, tail) to the
β tables' measured crossflow drag (0.02–0.27).  Measured: a 12 m/s lateral wind pushes the
hovering aircraft with 33 N instead of the 4.3 N of the β tables, and with the heading held no
hover trim within ±60° of attitude exists beyond 12.5 m/s (``tiltrotor.trim.
hover_wind_limit``).  ``"independence"`` (default) applies the independence (sweep) principle:
the α-table terms (lift, c_d^xz, pitch moment, and the aileron / elevator lift of the
deflections) act on the dynamic pressure of the flow in the surface's x–z plane,
½ρ(u² + w²) = κ cos²β.  Identical to the thesis at β = 0 (level flight without sideslip, the
hover trim) and equal to the β tables alone in a pure crossflow; where α flips (u = 0, w → 0±)
the α-table terms vanish instead of jumping by ~10 N at 12 m/s.  What stays is the direction of
the side force, which rotates with α (|c_y(±90°)| ≤ 0.07: 0.2 N at 12 m/s).  ``"thesis"`` keeps
(7.41)–(7.45) as written.

Reverse flow (``TiltrotorParams.reverse_flow``; u < 0: flying backwards through the air, e.g.
hovering in a tail wind).  The tables cover α ∈ [−90°, 90°] only.  (7.39)'s atan(w/u) would map
reverse flow to a small α but orient the drag *along* the motion.  ``"clipped"`` (the thesis'
form above) gives α = ±90° by the sign of w, so the drag acts across the flow and the loads jump
where w changes sign: 44 N at 10 m/s backwards for the whole aircraft, 1.4 N and 0.4 N m on
the fuselage at 3.3 m/s.  The hover mission meets it at 18.6 s and its state slides along
that switching surface (RK5 at 1e-7 creeps through in 10 µs steps; RK3 ends 72 mm from it,
``benchmarks/tiltrotor_integrators.py``).  ``"mirrored"`` (default) reads the tables at atan2(w, |u|)
(front and back of each surface mirrored) and orients the wind axes by the flow direction
θ = atan2(w, u): identical in forward flow, continuous over the whole circle of flow
directions (with ``crossflow="independence"``; the thesis crossflow form still jumps in pure
sideways flow, where the α terms do not vanish), and drag opposes the motion.  Its reverse-flow
lift and moments are an extrapolation without data.  Measured on the hover mission's first
60 s: RK3 within 0.5 mm of RK5 (72 mm clipped), RK2 within 14 mm (111 mm).
"""

from __future__ import annotations

import math

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pydrake.systems.framework import LeafSystem_
from pydrake.systems.scalar_conversion import TemplateSystem

from sobolev_drake.tiltrotor.aero_tables import AeroTables
from sobolev_drake.tiltrotor.generic_forces import aero_loads_generic
from sobolev_drake.tiltrotor.params import R_W, TiltrotorParams, cross_rows
from sobolev_drake.tiltrotor.body_frame import BodyKinematics, body_kinematics_scalar, body_wrench_scalar
from sobolev_drake.tiltrotor.scalars import default_instantiation, scalar_math

__all__ = ["AeroTables", "AeroModel", "AerodynamicSurfaces", "AerodynamicSurfaces_"]


class AeroModel:
    """The aerodynamic generalized forces (affine in the surface deflections), in two forms.

    * the numpy reference, written like the equations: :meth:`surface_air_data`,
      :meth:`surface_loads` and :meth:`terms` (``tests/tiltrotor/test_tiltrotor_forces.py``
      checks it against Drake's Jacobians and a hand computation);
    * the scalar tier :meth:`loads_scalar` (and :meth:`generalized_force` on it): the same loads
      in Python floats, which the plant evaluates when the compiled kernel (which mirrors it
      operation for operation) is not built, and the trims and the force systems always.

    Their scalar-generic form (AutoDiffXd, Expression) is :mod:`~sobolev_drake.tiltrotor.generic_forces`.

    Parameters
    ----------
    params : TiltrotorParams, optional
        Table B.1 by default.
    tables : AeroTables, optional
        The wind-tunnel tables (the package data by default).
    """

    def __init__(self, params: TiltrotorParams | None = None,
                 tables: AeroTables | None = None) -> None:
        self.params = TiltrotorParams() if params is None else params
        self.tables = AeroTables() if tables is None else tables
        p = self.params
        self.points = p.aero_points()
        self.area = p.S * np.array([1.0, 0.5, 0.5, 0.5, 0.5, 1.0])
        t = self.tables
        # (6·N, 3) tables: row k·N + i holds the three coefficients of surface k at sample i
        self._atab = np.ascontiguousarray(t.alpha_tab.transpose(0, 2, 1).reshape(-1, 3))
        self._btab = np.ascontiguousarray(t.beta_tab.transpose(0, 2, 1).reshape(-1, 3))
        self._base = np.arange(6) * t.samples
        self._half_rho_s = 0.5 * p.rho * self.area
        # points of the deflection columns: WR, WL, TR, TL, TR, TL
        self._ctrl_pts = self.points[[1, 2, 3, 4, 3, 4]]
        self.independence = p.crossflow == "independence"
        self.mirrored = p.reverse_flow == "mirrored"
        # the constants as Python floats and tuples: read by loads_scalar at every call, by
        # generic_forces, and packed for the compiled kernel by native.forces.force_model
        self._scalar_constants = (
            [tuple(r) for r in self.points.tolist()], self._half_rho_s.tolist(),
            [[tuple(row) for row in t.alpha_tab[k].T.tolist()] for k in range(6)],
            [[tuple(row) for row in t.beta_tab[k].T.tolist()] for k in range(6)],
            float(t.start), float(t.step), float(t.samples - 1), p.chord, p.span,
            p.c_delta_a, p.c_delta_e, p.c_delta_r, self.independence, self.mirrored)

    def _lookup(self, tab, angle):
        t = self.tables
        x = (np.minimum(np.maximum(angle, t.start), -t.start) - t.start) / t.step
        i = np.minimum(x.astype(np.int64), t.samples - 2)
        fr = (x - i)[:, None]
        idx = self._base + i
        return tab[idx] * (1.0 - fr) + tab[idx + 1] * fr

    def surface_air_data(self, q: ArrayLike, qdot: np.ndarray, zeta: ArrayLike
                         ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64],
                                    NDArray[np.float64]]:
        """Air-relative velocity, air speed and flow angles of every surface (7.37)–(7.40).

        Parameters
        ----------
        q, qdot : ndarray, shape (8,)
            Generalized coordinates and velocities, thesis order.
        zeta : ndarray, shape (3,)
            Wind, inertial axes (m/s).

        Returns
        -------
        v : ndarray, shape (6, 3)
            Air-relative velocity of each surface, body axes.
        V : ndarray, shape (6,)
            Air speeds.
        alpha, beta : ndarray, shape (6,)
            Angles of attack and sideslip (rad; module docstring for reverse flow).
        """
        R, W = R_W(q)
        w = W @ qdot[2:5]
        v = (R.T @ (qdot[5:8] - zeta)) + cross_rows(w[None, :], self.points)
        V = np.sqrt((v * v).sum(axis=1))
        if self.mirrored:   # table angle of reverse flow mirrored front to back (module doc)
            alpha = np.arctan2(v[:, 2], np.abs(v[:, 0]))
        else:               # clip(atan2(w, u), ±π/2), see module doc
            alpha = np.arctan2(v[:, 2], np.maximum(v[:, 0], 0.0))
        beta = np.arcsin(np.clip(v[:, 1] / np.where(V > 1e-12, V, 1.0), -1.0, 1.0))
        return v, V, alpha, beta

    def surface_loads(self, q: ArrayLike, qdot: np.ndarray, zeta: ArrayLike) -> tuple[
            NDArray[np.float64], NDArray[np.float64], tuple[NDArray[np.float64], NDArray[np.float64]],
            NDArray[np.float64], NDArray[np.float64]]:
        """Passive loads per surface (B.1)–(B.11) with δ = 0.

        Parameters
        ----------
        q, qdot : ndarray, shape (8,)
            Generalized coordinates and velocities, thesis order.
        zeta : ndarray, shape (3,)
            Wind, inertial axes (m/s).

        Returns
        -------
        F : ndarray, shape (6, 3)
            Body-axes forces at the aerodynamic centres.
        M : ndarray, shape (6, 3)
            Body-axes moments.
        kappa_s : tuple of two ndarrays, shape (6,)
            κ s of the β-table terms and of the α-table terms (module docstring, crossflow).
        y_w, z_w : ndarray, shape (6, 3)
            Side and lift directions of the wind axes, body axes.
        """
        p = self.params
        v, V, alpha, beta = self.surface_air_data(q, qdot, zeta)
        ca = self._lookup(self._atab, -alpha)      # α_NED = −α: [lift, drag_α, pitch moment]
        cb = self._lookup(self._btab, -beta)       # β_NED = −β: [side, drag_β, yaw moment]
        ks = self._half_rho_s * V * V              # κ s per surface
        if self.mirrored:   # wind axes along the flow direction θ = atan2(w, u) (= α if u ≥ 0)
            h = np.hypot(v[:, 0], v[:, 2])
            hs = np.where(h > 0.0, h, 1.0)
            sa, cal = np.where(h > 0.0, v[:, 2] / hs, 0.0), np.where(h > 0.0, v[:, 0] / hs, 1.0)
        else:
            sa, cal = np.sin(alpha), np.cos(alpha)
        sb, cbe = np.sin(beta), np.cos(beta)
        ksa = ks * cbe * cbe if self.independence else ks    # κ s of the α-table terms
        fd = -(ks * cb[:, 1] + ksa * ca[:, 1])
        fy = ks * cb[:, 0]
        fl = ksa * ca[:, 0]
        # R_S^W = Ry(−α) Rz(β): x_w = [cα cβ, sβ, sα cβ], y_w = [−cα sβ, cβ, −sα sβ], z_w = [−sα, 0, cα]
        zero = np.zeros(6)
        yw = np.stack([-cal * sb, cbe, -sa * sb], axis=1)
        zw = np.stack([-sa, zero, cal], axis=1)
        F = np.stack([cal * cbe * fd - cal * sb * fy - sa * fl,
                      sb * fd + cbe * fy,
                      sa * cbe * fd - sa * sb * fy + cal * fl], axis=1)
        M = np.stack([zero, -ksa * p.chord * ca[:, 2], -ks * p.span * cb[:, 2]], axis=1)
        return F, M, (ks, ksa), yw, zw

    def terms(self, q: ArrayLike, qdot: np.ndarray,
              zeta: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Numpy reference of the aerodynamic generalized force, affine in the deflections:
        ϑ_aero = ϑ_passive + B_δ δ, δ = [δWR, δWL, δTR, δTL] ((B.12)–(B.15), Appendix C).

        Parameters
        ----------
        q, qdot : ndarray, shape (8,)
            Generalized coordinates and velocities, thesis order.
        zeta : ndarray, shape (3,)
            Wind, inertial axes (m/s).

        Returns
        -------
        passive : ndarray, shape (8,)
            ϑ_aero at δ = 0, thesis order.
        B_delta : ndarray, shape (8, 4)
            Generalized force per radian of each deflection.
        """
        p = self.params
        F, M, (ks, ksa), yw, zw = self.surface_loads(q, qdot, zeta)
        R, W = R_W(q)
        # generalized force of main-body loads: η ← Wηᵀ Σ(r × F + M), ξ ← R Σ F  ((7.47)–(7.50))
        passive = np.zeros(8)
        passive[2:5] = W.T @ (cross_rows(self.points, F).sum(axis=0) + M.sum(axis=0))
        passive[5:8] = R @ F.sum(axis=0)
        # unit-deflection forces: aileron lift at WR / WL; ruddervator lift (δe) and side (δr)
        # force on both tail halves, δTR = +½ on δe and δr, δTL = +½ on δe and −½ on δr
        e3, e4 = p.c_delta_e * zw[3] * ksa[3], p.c_delta_e * zw[4] * ksa[4]
        r3, r4 = p.c_delta_r * yw[3] * ks[3], p.c_delta_r * yw[4] * ks[4]
        G = np.array([p.c_delta_a * ksa[1] * zw[1], p.c_delta_a * ksa[2] * zw[2],
                      0.5 * (e3 + r3), 0.5 * (e4 + r4), 0.5 * (e3 - r3), 0.5 * (e4 - r4)])
        tau = W.T @ cross_rows(self._ctrl_pts, G).T     # (3, 6)
        frc = R @ G.T
        Bd = np.zeros((8, 4))
        for rows, cols in ((slice(2, 5), tau), (slice(5, 8), frc)):   # δTR, δTL act on TR and TL
            Bd[rows] = np.column_stack([cols[:, 0], cols[:, 1], cols[:, 2] + cols[:, 3], cols[:, 4] + cols[:, 5]])
        return passive, Bd

    def generalized_force(self, q: ArrayLike, qdot: ArrayLike, zeta: ArrayLike,
                          delta: ArrayLike) -> NDArray[np.float64]:
        """ϑ_F + ϑ_W + ϑ_T + ϑ_I (thesis order) by the scalar tier: ``passive + B_delta δ`` of
        :meth:`terms` to rounding (tested).

        Kept beside :meth:`terms` because ``benchmarks/speed_tiers.py`` measures it ≈ 7× faster.

        Parameters
        ----------
        q, qdot : array_like, shape (8,)
            Generalized coordinates and velocities, thesis order.
        zeta : array_like, shape (3,)
            Wind, inertial axes (m/s).
        delta : array_like, shape (4,)
            Deflections [δWR δWL δTR δTL] (rad).

        Returns
        -------
        ndarray, shape (8,)
            ϑ_aero, thesis order.
        """
        # Python floats: arithmetic on numpy scalars is several times slower
        q, qdot = [float(v) for v in q], [float(v) for v in qdot]
        zeta, delta = [float(v) for v in zeta], [float(v) for v in delta]
        kin = body_kinematics_scalar(q, qdot, zeta)
        return np.array(self.loads_scalar(kin, delta)[0])

    def loads_scalar(self, kin: BodyKinematics, delta: Sequence[float], columns: bool = False
                     ) -> tuple[list[float], list[float], list[tuple[float, ...]] | None]:
        """Scalar tier of the aerodynamic generalized force (thesis order): :meth:`terms` and
        :meth:`surface_air_data` in Python floats, kept because ``benchmarks/speed_tiers.py``
        measures it ≈ 7× faster than them; the compiled kernel mirrors it.

        Parameters
        ----------
        kin : tuple
            Body kinematics from :func:`~sobolev_drake.tiltrotor.propulsion.body_kinematics_scalar`.
        delta : sequence of 4 floats
            Deflections [δWR δWL δTR δTL] (rad).
        columns : bool, default False
            Also return the deflection columns.

        Returns
        -------
        theta : list of 8 floats
            ϑ_aero (thesis order).
        V : list of 6 floats
            Surface air speeds (7.38).
        cols : list of 4 tuples or None
            With ``columns``, the columns [δWR δWL δTR δTL] of B_δ (B.12)–(B.15), each the
            tuple of its rows 2..7 (rows 0, 1 are zero; ``ϑ_aero = ϑ(δ = 0) + B_δ δ``, see
            :meth:`terms`); else None.
        """
        (pts, hrs, atab, btab, start, step, nmax, chord, span, cda, cde, cdr, indep,
         mirror) = self._scalar_constants
        imax = int(nmax) - 1
        sqrt, atan2, asin = math.sqrt, math.atan2, math.asin
        _, _, (wx, wy, wz), (vbx, vby, vbz) = kin
        de, dr = 0.5 * (delta[2] + delta[3]), 0.5 * (delta[2] - delta[3])
        dlift = (0.0, cda * delta[0], cda * delta[1], cde * de, cde * de, 0.0)
        dside = (0.0, 0.0, 0.0, cdr * dr, cdr * dr, 0.0)
        Fx = Fy = Fz = Tx = Ty = Tz = 0.0
        Vs = [0.0] * 6
        # body-axes unit-deflection force per surface 1..4: wing lift (δW), tail lift (δe), tail side (δr)
        unit = [None] * 6
        for k, (rx, ry, rz), hk, at, bt in zip(range(6), pts, hrs, atab, btab):
            u = vbx + wy * rz - wz * ry
            v = vby + wz * rx - wx * rz
            w = vbz + wx * ry - wy * rx
            V2 = u * u + v * v + w * w
            V = Vs[k] = sqrt(V2)
            if V2 < 1e-24:
                continue
            # mirrored: tables at atan2(w, |u|), wind axes along the flow; clipped: u⁺ = max(u, 0)
            # (module doc).  abs(u⁺) = u⁺, so the clipped form is unchanged to the bit.
            ux = u if mirror else (u if u > 0.0 else 0.0)
            h = sqrt(ux * ux + w * w)
            alpha = atan2(w, abs(ux))
            sa, ca = (w / h, ux / h) if h > 0.0 else (0.0, 1.0)
            sb = v / V
            sb = 1.0 if sb > 1.0 else (-1.0 if sb < -1.0 else sb)
            cb = sqrt(u * u + w * w) / V
            beta = asin(sb)
            # table look-ups at α_NED = −α, β_NED = −β: linear interpolation, index clamped to
            # the table ends as in coefficients(); written out twice on purpose (a helper
            # call per look-up measured 20 -> 25 µs per loads_scalar, the plant hot path)
            x = (-alpha - start) / step
            x = 0.0 if x < 0.0 else (nmax if x > nmax else x)
            i = int(x)
            i = i if i <= imax else imax
            fr = x - i
            r0, r1 = at[i], at[i + 1]
            cl, cda_, cm = (r0[0] + fr * (r1[0] - r0[0]), r0[1] + fr * (r1[1] - r0[1]),
                            r0[2] + fr * (r1[2] - r0[2]))
            x = (-beta - start) / step
            x = 0.0 if x < 0.0 else (nmax if x > nmax else x)
            i = int(x)
            i = i if i <= imax else imax
            fr = x - i
            r0, r1 = bt[i], bt[i + 1]
            cy, cdb, cn = (r0[0] + fr * (r1[0] - r0[0]), r0[1] + fr * (r1[1] - r0[1]),
                           r0[2] + fr * (r1[2] - r0[2]))
            ks = hk * V2
            ksa = hk * (u * u + w * w) if indep else ks     # κ cos²β s: see the module doc
            fd = -(ks * cdb + ksa * cda_)
            fy = ks * (cy + dside[k])
            fl = ksa * (cl + dlift[k])
            cacb, sasb = ca * cb, sa * sb
            bx = cacb * fd - ca * sb * fy - sa * fl
            by = sb * fd + cb * fy
            bz = sa * cb * fd - sasb * fy + ca * fl
            Fx += bx
            Fy += by
            Fz += bz
            Tx += ry * bz - rz * by
            Ty += rz * bx - rx * bz - ksa * chord * cm
            Tz += rx * by - ry * bx - ks * span * cn
            if columns and 1 <= k <= 4:
                # lift direction z_w = [−sα, 0, cα], side direction y_w = [−cα sβ, cβ, −sα sβ]
                unit[k] = (-sa * ksa, ca * ksa, -ca * sb * ks, cb * ks, -sa * sb * ks)
        out = [0.0, 0.0, *body_wrench_scalar(kin, (Fx, Fy, Fz), (Tx, Ty, Tz))]
        if not columns:
            return out, Vs, None
        # Deflection columns [δWR δWL δTR δTL]: body force and moment per radian, summed over
        # the surfaces each deflection acts on, then mapped like the loads (rows 2..7).
        cols = []
        for j in range(4):
            Fx = Fy = Fz = Tx = Ty = Tz = 0.0
            if j < 2:                     # aileron: lift c_δa κs z_w at the wing WR / WL
                items = ((j + 1, 1.0, 0.0),)
            else:                         # δTR = +½ on δe and δr, δTL = +½ on δe and −½ on δr
                sr = 0.5 if j == 2 else -0.5
                items = ((3, 0.5, sr), (4, 0.5, sr))
            for k, se, sr in items:
                uk = unit[k]
                if uk is None:
                    continue
                lx, lz, yx, yy, yz = uk
                if j < 2:
                    bx, by, bz = cda * lx, 0.0, cda * lz
                else:
                    ex, ez = cde * lx, cde * lz
                    qx, qy, qz = cdr * yx, cdr * yy, cdr * yz
                    bx, by, bz = se * ex + sr * qx, sr * qy, se * ez + sr * qz
                rx, ry, rz = pts[k]
                Fx += bx
                Fy += by
                Fz += bz
                Tx += ry * bz - rz * by
                Ty += rz * bx - rx * bz
                Tz += rx * by - ry * bx
            cols.append(body_wrench_scalar(kin, (Fx, Fy, Fz), (Tx, Ty, Tz)))
        return out, Vs, cols


@TemplateSystem.define("AerodynamicSurfaces_")
def AerodynamicSurfaces_(T):                     # noqa: D103 - the template of the class below
    m = scalar_math(T)

    class Impl(LeafSystem_[T]):
        """LeafSystem: thesis-ordered generalized force of fuselage, wings, V-tail and interference.

        .. pydrake_system::

            name: AerodynamicSurfaces
            input_ports:
            - x
            - wind
            - surface_deflection
            output_ports:
            - generalized_force

        ``x`` (16, thesis order [q; q̇]), ``wind`` (3, inertial m/s) and ``surface_deflection``
        (4, [δWR δWL δTR δTL] rad; the last two zero if unconnected) give ``generalized_force``
        (8, thesis order): :meth:`AeroModel.generalized_force` in double,
        :func:`~sobolev_drake.tiltrotor.generic_forces.aero_loads_generic` for AutoDiffXd (slope
        of the active table segment) and Expression (``ToAutoDiffXd()``, ``ToSymbolic()``).

        Parameters
        ----------
        params : TiltrotorParams, optional
            Table B.1 by default.
        """

        def _construct(self, params: TiltrotorParams | None = None, converter=None):
            LeafSystem_[T].__init__(self, converter=converter)
            self.core = AeroModel(params)
            self._x, self._wind, self._delta = (self.DeclareVectorInputPort(name, size) for name, size
                                                in (("x", 16), ("wind", 3), ("surface_deflection", 4)))
            self.DeclareVectorOutputPort(        # explicit prerequisites: no symbolic inspection
                "generalized_force", 8, self._calc, prerequisites_of_calc={self.all_input_ports_ticket()})

        def _construct_copy(self, other, converter=None):
            Impl._construct(self, other.core.params, converter=converter)

        def _calc(self, context, output) -> None:
            x = self._x.Eval(context)
            zeta = self._wind.Eval(context) if self._wind.HasValue(context) else np.zeros(3)
            delta = self._delta.Eval(context) if self._delta.HasValue(context) else np.zeros(4)
            if T is float:
                return output.SetFromVector(self.core.generalized_force(
                    x[:8], x[8:], np.asarray(zeta), np.asarray(delta)))
            kin = body_kinematics_scalar(x[:8].tolist(), x[8:].tolist(), list(zeta), m)
            output.SetFromVector(aero_loads_generic(self.core, kin, list(delta), m))

    return Impl


AerodynamicSurfaces = default_instantiation(AerodynamicSurfaces_, "AerodynamicSurfaces")
