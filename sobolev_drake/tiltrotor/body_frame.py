"""Body-frame kinematics and the body-wrench map of the tilt-rotor's scalar force tier.

:func:`body_kinematics_scalar` (rotation, body angular velocity, body air velocity) and
:func:`body_wrench_scalar` (rows φ θ ψ x y z of the generalized force of a body-axes force and
torque) are shared by the propeller (:mod:`~sobolev_drake.tiltrotor.propulsion`) and
aerodynamic (:mod:`~sobolev_drake.tiltrotor.aerodynamics`) force paths, their scalar-generic
form (:mod:`~sobolev_drake.tiltrotor.generic_forces`) and the controller's input-affine terms;
``native/forces.c`` mirrors them.  Both are branch-free: the same code serves float,
AutoDiffXd and Expression (``m`` supplies ``sin`` and ``cos``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from types import ModuleType

from sobolev_drake.tiltrotor.scalars import Scalar, ScalarMath

__all__ = ["BodyKinematics", "body_kinematics_scalar", "body_wrench_scalar"]

#: what :func:`body_kinematics_scalar` returns: ((sin ϕ, cos ϕ, sin θ, cos θ), R row-major,
#: body angular velocity, body air velocity), scalars of one Drake type
BodyKinematics = tuple[tuple[Scalar, Scalar, Scalar, Scalar], tuple[Scalar, ...],
                       tuple[Scalar, Scalar, Scalar], tuple[Scalar, Scalar, Scalar]]


def body_kinematics_scalar(q: Sequence[Scalar], qdot: Sequence[Scalar], zeta: Sequence[Scalar],
                           m: ModuleType | ScalarMath = math) -> BodyKinematics:
    """Body-frame kinematics of the scalar force tier (module docstring), thesis order q.

    Shared by the propeller and aerodynamic force paths.  Branch-free, so the same code serves
    every scalar type: ``m`` supplies ``sin`` and ``cos``.

    Parameters
    ----------
    q, qdot : list of 8 floats
        Generalized coordinates and velocities, thesis order (Python floats, or AutoDiffXd /
        Expression with the matching ``m``).
    zeta : list of 3 floats
        Wind, inertial axes (m/s).
    m : module or ScalarMath, default math
        ``sin`` and ``cos`` of the scalar type (:func:`~sobolev_drake.tiltrotor.scalars.scalar_math`).

    Returns
    -------
    tuple
        ((sin ϕ, cos ϕ, sin θ, cos θ), R row-major (9 floats, body → inertial, Z-Y-X Euler
        angles (7.2)), body angular velocity (wx, wy, wz), body air velocity Rᵀ(ṗ − ζ)
        (vbx, vby, vbz)).
    """
    sin, cos = m.sin, m.cos
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


def body_wrench_scalar(kin: BodyKinematics, force: Sequence[Scalar],
                       torque: Sequence[Scalar]) -> tuple[Scalar, ...]:
    """Rows 2..7 (φ θ ψ x y z) of the generalized force of a body-axes force and torque on the
    main body: [Wηᵀ T, R F] (scalar form of ``tiltrotor.params.body_generalized_force``).

    Parameters
    ----------
    kin : tuple
        From :func:`body_kinematics_scalar`.
    force : sequence of 3 floats
        Force F, body axes (N).
    torque : sequence of 3 floats
        Torque T about C1, body axes (N m).

    Returns
    -------
    tuple of 6 floats
        Generalized force rows φ θ ψ x y z.
    """
    (sf, cf, st, ct), (r00, r01, r02, r10, r11, r12, r20, r21, r22), _, _ = kin
    fx, fy, fz = force
    tx, ty, tz = torque
    return (tx, cf * ty - sf * tz, -st * tx + ct * sf * ty + cf * ct * tz,
            r00 * fx + r01 * fy + r02 * fz, r10 * fx + r11 * fy + r12 * fz,
            r20 * fx + r21 * fy + r22 * fz)
