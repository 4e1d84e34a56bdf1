"""Scalar-generic tier of the tilt-rotor's generalized forces (AutoDiffXd and Expression).

The force systems (:class:`~sobolev_drake.tiltrotor.propulsion.PropellerForces`,
:class:`~sobolev_drake.tiltrotor.aerodynamics.AerodynamicSurfaces`,
:class:`~sobolev_drake.tiltrotor.plant.TiltrotorForces`) compute in double with the float tier
(and the compiled kernel); their AutoDiffXd and Expression instantiations call the functions
here, which are the float tier's expressions with every branch written as ``m.where`` and the
wind-tunnel tables read by ``m.lerp_rows`` (:mod:`sobolev_drake.tiltrotor.scalars`).  On floats
they give the float tier's values (``tests/tiltrotor/test_drake_native_tiltrotor.py``).

Derivatives: the aerodynamic coefficients are piecewise linear in the flow angles (0.5° grid),
so an AutoDiffXd value carries the slope of the active segment, on a sample (e.g. zero
sideslip) the central slope of the two segments; where a surface sees no air
(‖v‖² < 1e-24, skipped by the float tier) its loads and their derivatives are zero, which is
exact since they are quadratic in the air speed.  The propeller at zero inflow: see
:func:`propeller_force_generic`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
from pydrake.autodiffutils import AutoDiffXd

from sobolev_drake.tiltrotor.body_frame import BodyKinematics, body_kinematics_scalar, body_wrench_scalar
from sobolev_drake.tiltrotor.scalars import Scalar, ScalarMath

if TYPE_CHECKING:   # both import this module
    from sobolev_drake.tiltrotor.aerodynamics import AeroModel
    from sobolev_drake.tiltrotor.propulsion import PropulsionModel

__all__ = ["propeller_force_generic", "kink_derivatives", "aero_loads_generic",
           "tiltrotor_force_generic", "force_at_c1"]


def propeller_force_generic(prop: PropulsionModel, kin: BodyKinematics,
                            rotors: tuple[tuple[Scalar, ...], tuple[Scalar, ...]],
                            n: Sequence[Scalar], m: ScalarMath) -> list[Scalar]:
    """ϑ_P (7.32) for every scalar type: ``PropulsionModel.propeller_force_scalar`` with its
    branches written as ``m.where`` (same values; tested).

    At zero inflow (u = w = 0, e.g. the hover trim) the thrust is not differentiable in the
    rotor's air velocity: J = ‖(u, w)‖/(nd) and ∂Ct/∂J(0, φ) depends on the direction
    (e.g. climbing φ = 0, descending φ = π/2 after the clip).  There an AutoDiffXd result
    carries, along each of its derivative directions, the central derivative
    (f(+t) − f(−t))/2t in that direction (:func:`kink_derivatives`): what a central
    difference along a state coordinate gives, so ``Linearize`` at the hover trim agrees
    with it.

    Parameters
    ----------
    prop : PropulsionModel
        The propeller model.
    kin : tuple
        From :func:`~sobolev_drake.tiltrotor.body_frame.body_kinematics_scalar` (with ``m``).
    rotors : tuple
        From ``PropulsionModel.rotors_scalar`` (with ``m``).
    n : sequence of 2 scalars
        Propeller speeds (rev/s).
    m : ScalarMath
        Functions of the scalar type (:func:`~sobolev_drake.tiltrotor.scalars.scalar_math`).

    Returns
    -------
    list of 8 scalars
        ϑ_P, thesis order.
    """
    c = prop.coef
    d, Jmax, H = c.diameter, c.J_max, 1.5707963267948966
    kf, kt = prop._kf, prop._kt
    where, value = m.where, m.value
    out = [0.0] * 8
    Fx = Fy = Fz = Tx = Ty = Tz = 0.0
    for k in (0, 1):
        dx, dy, dz, rx, ry, rz, zx, zy, zz, u, w = rotors[k]
        nk = n[k]
        nd = nk * d
        pos, s2 = nd > 0, u * u + w * w
        still = s2 == 0                  # no inflow: the kink above (safe sqrt and atan2)
        den = where(pos, nd, 1.0)
        J = where(pos, where(still, 0.0, m.sqrt(where(still, 1.0, s2)) / den), Jmax)
        J = where(J > Jmax, Jmax, J)
        phi = m.atan2(where(still, value(u), u), where(still, value(w), w))
        phi = m.abs(where(phi > H, H, where(phi < -H, -H, phi)))
        cT, cQ = c.ct_cq_scalar(J, phi)
        if m.kind == "autodiff" and still and pos:
            cT, cQ = kink_derivatives(prop, cT, cQ, u, w, value(nd))
        f = kf * nk * nk * cT
        t = prop._lam_f[k] * kt * nk * nk * cQ
        bx, by, bz = f * zx, f * zy, f * zz
        out[k] = dz * bx - dx * bz + t * zy
        Fx += bx
        Fy += by
        Fz += bz
        Tx += ry * bz - rz * by + t * zx
        Ty += rz * bx - rx * bz + t * zy
        Tz += rx * by - ry * bx + t * zz
    out[2:8] = body_wrench_scalar(kin, (Fx, Fy, Fz), (Tx, Ty, Tz))
    return out


def kink_derivatives(prop: PropulsionModel, ct: float, cq: float, u: AutoDiffXd | float,
                     w: AutoDiffXd | float, nd: float) -> tuple[AutoDiffXd, AutoDiffXd]:
    """(Ct, Cq) at zero inflow as AutoDiffXd: the values ``ct, cq`` with, along each
    derivative direction e = (du_i, dw_i) of (u, w), the central derivative
    ‖e‖ (g(φ(e)) − g(φ(−e))) / (2 nd), g(φ) = ∂C/∂J(0, φ) (first order in J = ‖v‖/(nd)).

    Parameters
    ----------
    prop : PropulsionModel
        The propeller model (its Ct, Cq terms linear in J).
    ct, cq : float
        Ct(0, φ) and Cq(0, φ) (values at zero inflow).
    u, w : AutoDiffXd or float
        Rotor-frame air velocity components (value 0) with their derivatives.
    nd : float
        n d (m/s), positive.

    Returns
    -------
    ct, cq : AutoDiffXd
    """
    du, dw = (np.asarray(x.derivatives() if isinstance(x, AutoDiffXd) else [], float)
              for x in (u, w))
    size = max(du.size, dw.size)
    du, dw = np.pad(du, (0, size - du.size)), np.pad(dw, (0, size - dw.size))
    H = 1.5707963267948966

    def g(a, b):                                 # ∂(Ct, Cq)/∂J at J = 0 towards (a, b)
        phi = abs(max(-H, min(H, math.atan2(a, b))))
        return np.array([sum(t[k] * phi ** j for j, *t in prop._dJ_terms) for k in (0, 1)])

    grad = np.zeros((2, size))
    for i, (a, b) in enumerate(zip(du.tolist(), dw.tolist())):
        r = math.hypot(a, b)
        if r > 0.0:
            grad[:, i] = 0.5 * r * (g(a, b) - g(-a, -b)) / nd
    return AutoDiffXd(float(ct), grad[0]), AutoDiffXd(float(cq), grad[1])


def aero_loads_generic(aero: AeroModel, kin: BodyKinematics, delta: Sequence[Scalar],
                       m: ScalarMath) -> list[Scalar]:
    """ϑ_aero (thesis order) of ``AeroModel.loads_scalar(kin, delta)[0]`` for every scalar type.

    Parameters
    ----------
    aero : AeroModel
        The aerodynamic model (its tables and constants).
    kin : tuple
        From :func:`~sobolev_drake.tiltrotor.body_frame.body_kinematics_scalar` (with ``m``).
    delta : sequence of 4 scalars
        Deflections [δWR δWL δTR δTL] (rad).
    m : ScalarMath
        Functions of the scalar type (:func:`~sobolev_drake.tiltrotor.scalars.scalar_math`).

    Returns
    -------
    list of 8 scalars
        ϑ_aero, thesis order (rows 0, 1 zero).
    """
    (pts, hrs, atab, btab, start, step, nmax, chord, span, cda, cde, cdr, indep,
     mirror) = aero._scalar_constants
    imax = int(nmax) - 1
    where, sqrt, value = m.where, m.sqrt, m.value
    _, _, (wx, wy, wz), (vbx, vby, vbz) = kin
    de, dr = 0.5 * (delta[2] + delta[3]), 0.5 * (delta[2] - delta[3])
    dlift = (0.0, cda * delta[0], cda * delta[1], cde * de, cde * de, 0.0)
    dside = (0.0, 0.0, 0.0, cdr * dr, cdr * dr, 0.0)
    Fx = Fy = Fz = Tx = Ty = Tz = 0.0
    for k, ((rx, ry, rz), hk, at, bt) in enumerate(zip(pts, hrs, atab, btab)):
        u = vbx + wy * rz - wz * ry
        v = vby + wz * rx - wx * rz
        w = vbz + wx * ry - wy * rx
        V2 = u * u + v * v + w * w
        still = V2 < 1e-24                 # the float tier skips the surface
        V = sqrt(where(still, 1.0, V2))
        ux = u if mirror else where(u > 0.0, u, 0.0)
        h2 = ux * ux + w * w
        flow = h2 > 0.0                    # flow in the x–z plane (else the float tier's
        hs = sqrt(where(flow, h2, 1.0))    # defaults, with their values and no derivative)
        aux = m.abs(ux)
        alpha = m.atan2(where(flow, w, value(w)), where(flow, aux, value(aux)))
        sa, ca = where(flow, w / hs, 0.0), where(flow, ux / hs, 1.0)
        sb = v / V
        sb = where(sb > 1.0, 1.0, where(sb < -1.0, -1.0, sb))
        uw2 = u * u + w * w
        cb = where(uw2 > 0.0, sqrt(where(uw2 > 0.0, uw2, 1.0)), 0.0) / V
        beta = m.asin(sb)
        x = (-alpha - start) / step
        cl, cda_, cm = m.lerp_rows(at, where(x < 0.0, 0.0, where(x > nmax, nmax, x)), imax)
        x = (-beta - start) / step
        cy, cdb, cn = m.lerp_rows(bt, where(x < 0.0, 0.0, where(x > nmax, nmax, x)), imax)
        ks = hk * V2
        ksa = hk * uw2 if indep else ks    # κ cos²β s (aerodynamics module doc, crossflow)
        fd = -(ks * cdb + ksa * cda_)
        fy = ks * (cy + dside[k])
        fl = ksa * (cl + dlift[k])
        cacb, sasb = ca * cb, sa * sb
        bx = cacb * fd - ca * sb * fy - sa * fl
        by = sb * fd + cb * fy
        bz = sa * cb * fd - sasb * fy + ca * fl
        Fx += where(still, 0.0, bx)
        Fy += where(still, 0.0, by)
        Fz += where(still, 0.0, bz)
        Tx += where(still, 0.0, ry * bz - rz * by)
        Ty += where(still, 0.0, rz * bx - rx * bz - ksa * chord * cm)
        Tz += where(still, 0.0, rx * by - ry * bx - ks * span * cn)
    return [0.0, 0.0, *body_wrench_scalar(kin, (Fx, Fy, Fz), (Tx, Ty, Tz))]


def tiltrotor_force_generic(prop: PropulsionModel, aero: AeroModel, q: Sequence[Scalar],
                            qdot: Sequence[Scalar], u: Sequence[Scalar], zeta: Sequence[Scalar],
                            force: Sequence[Scalar] | None, m: ScalarMath, *, cos_beta: float,
                            nu: float, d_B_C1: Sequence[float]) -> list[Scalar]:
    """ϑ (thesis order) of ``TiltrotorForces.thesis_force`` without the disturbance ``w``, for
    every scalar type: propellers, servos (7.33), aerodynamic surfaces and a force at C1.

    Parameters
    ----------
    prop : PropulsionModel
        The propeller model.
    aero : AeroModel
        The aerodynamic model (same parameters).
    q, qdot : list of 8 scalars
        Generalized coordinates and velocities, thesis order.
    u : list of 8 scalars
        Inputs τ = [nPR nPL τsR τsL δWR δWL δTR δTL].
    zeta : list of 3 scalars
        Wind, inertial axes (m/s).
    force : list of 3 scalars or None
        Inertial force at the main body's centre of mass C1 (N); None: none.
    m : ScalarMath
        Functions of the scalar type.
    cos_beta, nu : float
        Servo factor cos β and viscous friction ν of (7.33).
    d_B_C1 : sequence of 3 floats
        C1 in body axes (m).

    Returns
    -------
    list of 8 scalars
        The generalized force, thesis order.
    """
    kin = body_kinematics_scalar(q, qdot, zeta, m)
    tp = propeller_force_generic(prop, kin, prop.rotors_scalar(q, qdot, kin, m), u[0:2], m)
    ta = aero_loads_generic(aero, kin, u[4:8], m)
    tau = [a + b for a, b in zip(tp, ta)]
    tau[0] += cos_beta * u[2] - nu * qdot[0]            # servos (7.33)
    tau[1] += cos_beta * u[3] - nu * qdot[1]
    if force is not None:
        w = force_at_c1(kin, force, d_B_C1)
        for i in range(6):
            tau[2 + i] += w[i]
    return tau


def force_at_c1(kin: BodyKinematics, force: Sequence[Scalar],
                d_B_C1: Sequence[float]) -> tuple[Scalar, ...]:
    """Rows 2..7 of the generalized force of an inertial force at the main body's centre of
    mass C1: [Wηᵀ (d × Rᵀ F), R Rᵀ F] (arithmetic only: every scalar type, and the float tier
    of ``TiltrotorForces.thesis_force``).

    Parameters
    ----------
    kin : tuple
        From :func:`~sobolev_drake.tiltrotor.body_frame.body_kinematics_scalar`.
    force : sequence of 3 scalars
        The force F, inertial axes (N).
    d_B_C1 : sequence of 3 floats
        C1 in body axes (m).

    Returns
    -------
    tuple of 6 scalars
        Generalized force rows φ θ ψ x y z.
    """
    fx, fy, fz = force
    _, (r00, r01, r02, r10, r11, r12, r20, r21, r22), _, _ = kin
    bx = r00 * fx + r10 * fy + r20 * fz
    by = r01 * fx + r11 * fy + r21 * fz
    bz = r02 * fx + r12 * fy + r22 * fz
    dx, dy, dz = d_B_C1
    return body_wrench_scalar(kin, (bx, by, bz), (dy * bz - dz * by, dz * bx - dx * bz,
                                                  dx * by - dy * bx))
