"""Input-affine form (7.62) of the tilt-rotor generalized forces (Appendix C) and their total.

    ϑ(q, q̇, τ, ζ) = B(q, q̇, ζ) τ̄ + ϑ_passive(q, q̇, ζ),
    τ̄ = [fPR fPL τsR τsL δWR δWL δTR δTL]

* propellers (C.1)–(C.2): the drag torque is written through the thrust, t = λ d (Cq/Ct)(J, φ) f,
  so each thrust column is J_Pᵀ R a_z + λ d (Cq/Ct) W_Pᵀ R a_z.  Cq/Ct depends on the advance ratio
  J = V/(n d), i.e. on the propeller speed: pass ``n`` (rev/s) for an exact identity; by default
  the thesis' hover speed 51.9 rev/s is used (exact whenever J = 0, i.e. no axial/in-plane air
  speed at the rotors; Cq/Ct grows by ~8 % at J = 0.06, e.g. 2 m/s axial at hover speed);
* servomotors (C.3): cos β on the tilt joints (the torque acts about the inclined y axis of
  C2/C3), the viscous friction −ν α̇ is passive;
* surfaces (C.4)–(C.8): the deflection terms of the wing and tail lift / tail side force are the
  columns, everything else is passive.
"""

from __future__ import annotations

import math
from types import ModuleType
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sobolev_drake.models.base import check_vector
from sobolev_drake.tiltrotor.params import TiltrotorParams, body_generalized_force, R_IB
from sobolev_drake.tiltrotor.aerodynamics import AeroModel
from sobolev_drake.tiltrotor.propulsion import PropulsionModel, body_kinematics_scalar, body_wrench_scalar

if TYPE_CHECKING:   # plant imports this module (TiltrotorModel.B)
    from sobolev_drake.tiltrotor.plant import TiltrotorModel

__all__ = [
    "N_REF", "cores", "input_affine", "AffineTerms", "input_affine_terms", "affine_terms_scalar",
    "affine_terms_scalar_python", "input_affine_vectorized", "generalized_force", "thrust_inputs",
    "force_disturbance_generalized", "native_core",
]

#: reference propeller speed (rev/s) for Cq/Ct when ``n`` is not given: thesis hover trim
N_REF = 51.9

_CORES: dict = {}


def cores(params: TiltrotorParams | None = None) -> tuple[PropulsionModel, AeroModel]:
    """The force models of a parameter set (cached per parameter object).

    Parameters
    ----------
    params : TiltrotorParams, optional
        Table B.1 by default.

    Returns
    -------
    tuple
        (PropulsionModel, AeroModel).
    """
    params = TiltrotorParams() if params is None else params
    key = id(params)
    if key not in _CORES:
        _CORES[key] = (params, PropulsionModel(params), AeroModel(params))
    return _CORES[key][1], _CORES[key][2]


def native_core(params: TiltrotorParams) -> tuple[ModuleType, Any] | None:
    """The compiled force kernel for a parameter set (cached beside :func:`cores`; see
    ``sobolev_drake.native``).

    Parameters
    ----------
    params : TiltrotorParams
        The vehicle's parameters.

    Returns
    -------
    tuple or None
        (kernel module, model capsule), or None when the kernel is not built or switched off.
    """
    from sobolev_drake.native import enabled
    if not enabled():            # switched off after the capsule was cached
        return None
    prop, aero = cores(params)
    entry = _CORES[id(params)]
    if len(entry) == 3:
        from sobolev_drake.native import kernel
        from sobolev_drake.native.forces import force_model
        capsule = force_model(prop, aero)
        if capsule is None:                   # not built: nothing to cache
            return None
        entry = _CORES[id(params)] = (*entry, (kernel("forces"), capsule))
    return entry[3]


def _params_of(model_or_params):
    if model_or_params is None:
        return TiltrotorParams()
    if isinstance(model_or_params, TiltrotorParams):
        return model_or_params
    params = getattr(model_or_params, "params", None)
    if not isinstance(params, TiltrotorParams):
        raise TypeError("model must be a TiltrotorModel or TiltrotorParams, "
                        f"got {type(model_or_params).__name__}")
    return params


def _checked_state(model, q, qdot, zeta):
    return (_params_of(model), check_vector("q", q, 8), check_vector("qdot", qdot, 8),
            check_vector("zeta", zeta, 3))


def _check_torque(torque):
    if torque not in ("through_thrust", "passive"):
        raise ValueError(f"torque must be 'through_thrust' or 'passive', got {torque!r}")


def input_affine(model: TiltrotorModel | TiltrotorParams, q: ArrayLike, qdot: ArrayLike,
                 zeta: ArrayLike, n: ArrayLike | None = None, *,
                 torque: str = "through_thrust") -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(B (8×8), ϑ_passive (8,)) of (7.62) in thesis order at (q, q̇, ζ).

    ``model``: TiltrotorModel or TiltrotorParams; ``n``: propeller speeds (2,) used for the
    torque/thrust ratio Cq/Ct(J, φ) (default ``N_REF``).  Columns of B follow ``ACTUATOR_NAMES``.

    ``torque``: ``"through_thrust"`` (Appendix C, default) puts the drag torque in the thrust
    columns via t = λ d (Cq/Ct) f.  Ct(J, φ) crosses zero near J = 0.75 (windmilling, min Ct ≈
    −0.0025) where that ratio blows up; ``"passive"`` instead puts the torque
    λ ρ d⁵ n² Cq(J, φ) of the given ``n`` into ϑ_passive and keeps B's thrust columns pure thrust.
    Both satisfy ϑ = B τ̄ + ϑ_passive exactly for the given n.

    Computed by the per-sample path (:func:`input_affine_terms`: the compiled kernel, else the
    scalar tier); :func:`input_affine_vectorized` is the numpy reference it is tested against.

    Parameters
    ----------
    model : TiltrotorModel or TiltrotorParams
        The vehicle (its parameters are used).
    q, qdot : array_like, shape (8,)
        Generalized coordinates and velocities, thesis order.
    zeta : array_like, shape (3,)
        Wind, inertial axes (m/s).
    n : array_like, shape (2,), optional
        Propeller speeds (rev/s) of the torque/thrust ratio Cq/Ct(J, φ); ``N_REF`` by default.
    torque : {"through_thrust", "passive"}, default "through_thrust"
        Where the propeller drag torque goes (see :func:`input_affine`).

    Returns
    -------
    B : ndarray, shape (8, 8)
        Input matrix, columns ``ACTUATOR_NAMES``.
    passive : ndarray, shape (8,)
        ϑ_passive, thesis order.
    """
    _check_torque(torque)
    t = input_affine_terms(model, q, qdot, zeta, n, torque=torque)
    return t.B, t.passive


class AffineTerms(NamedTuple):
    """Everything one controller sample needs from the force model at (q, q̇, ζ, n).

    Parameters
    ----------
    B : ndarray, shape (8, 8)
        Input matrix of (7.62).
    passive : ndarray, shape (8,)
        ϑ_passive.
    surface_speed : ndarray, shape (6,)
        Air speed of the surfaces F WR WL TR TL I (7.38).
    rotor_vxz : ndarray, shape (2,)
        Rotor-frame air speed in the x–z plane (J = V_xz/(n d)).
    rotor_phi : ndarray, shape (2,)
        Inflow angle φ of each rotor (7.30).
    """

    B: np.ndarray
    passive: np.ndarray
    surface_speed: np.ndarray
    rotor_vxz: np.ndarray
    rotor_phi: np.ndarray


def input_affine_terms(model: TiltrotorModel | TiltrotorParams, q: ArrayLike, qdot: ArrayLike,
                       zeta: ArrayLike, n: ArrayLike | None = None, *,
                       torque: str = "through_thrust") -> AffineTerms:
    """:class:`AffineTerms` at (q, q̇, ζ): B and ϑ_passive of :func:`input_affine` plus the
    surface air speeds (bounds (7.87)–(7.89)) and the rotor inflow (thrust inversion (7.90)),
    from one pass of scalar kinematics (the controller's per-sample hot path).

    Parameters
    ----------
    model : TiltrotorModel or TiltrotorParams
        The vehicle (its parameters are used).
    q, qdot : array_like, shape (8,)
        Generalized coordinates and velocities, thesis order.
    zeta : array_like, shape (3,)
        Wind, inertial axes (m/s).
    n : array_like, shape (2,), optional
        Propeller speeds (rev/s) of the torque/thrust ratio Cq/Ct(J, φ); ``N_REF`` by default.
    torque : {"through_thrust", "passive"}, default "through_thrust"
        Where the propeller drag torque goes (see :func:`input_affine`).

    Returns
    -------
    AffineTerms
        B, ϑ_passive, surface air speeds and rotor inflow.
    """
    p, q, qdot, zeta = _checked_state(model, q, qdot, zeta)
    nl = [N_REF, N_REF] if n is None else check_vector("n", n, 2).tolist()
    _check_torque(torque)
    return affine_terms_scalar(p, q.tolist(), qdot.tolist(), zeta.tolist(), nl, torque)


def affine_terms_scalar(p: TiltrotorParams, ql: list[float], qdl: list[float], zl: list[float],
                        nl: list[float], torque: str = "through_thrust") -> AffineTerms:
    """:func:`input_affine_terms` on already validated lists of Python floats (q, q̇: 8, ζ: 3,
    n: 2) — the controller's per-sample path, without re-checking what it checked.  Computed
    by the compiled kernel when it is built (equal to :func:`affine_terms_scalar_python` to
    rounding: the kernel's hypot may differ in the last bit), else by that scalar tier.

    Parameters
    ----------
    p : TiltrotorParams
        The vehicle's parameters.
    ql, qdl : list of 8 floats
        Generalized coordinates and velocities, thesis order (validated).
    zl : list of 3 floats
        Wind, inertial axes (m/s).
    nl : list of 2 floats
        Propeller speeds (rev/s) of the torque/thrust ratio.
    torque : {"through_thrust", "passive"}, default "through_thrust"
        Where the propeller drag torque goes (see :func:`input_affine`).

    Returns
    -------
    AffineTerms
        As :func:`input_affine_terms`.
    """
    native = native_core(p)
    if native is not None:
        k, capsule = native
        B, passive, V, vxz, phis = k.affine_terms(capsule, ql, qdl, zl, nl, torque == "through_thrust")
        return AffineTerms(np.array(B).reshape(8, 8), np.array(passive), np.array(V),
                           np.array(vxz), np.array(phis))
    return affine_terms_scalar_python(p, ql, qdl, zl, nl, torque)


def affine_terms_scalar_python(p: TiltrotorParams, ql: list[float], qdl: list[float],
                               zl: list[float], nl: list[float],
                               torque: str = "through_thrust") -> AffineTerms:
    """Scalar tier of :func:`input_affine_terms`, kept beside :func:`input_affine_vectorized`
    because ``benchmarks/speed_tiers.py`` measures it ≈ 6× faster; the kernel mirrors it.

    Parameters
    ----------
    p : TiltrotorParams
        The vehicle's parameters.
    ql, qdl : list of 8 floats
        Generalized coordinates and velocities, thesis order (validated).
    zl : list of 3 floats
        Wind, inertial axes (m/s).
    nl : list of 2 floats
        Propeller speeds (rev/s) of the torque/thrust ratio.
    torque : {"through_thrust", "passive"}, default "through_thrust"
        Where the propeller drag torque goes (see :func:`input_affine`).

    Returns
    -------
    AffineTerms
        As :func:`input_affine_terms`.
    """
    prop, aero = cores(p)
    c = prop.coef
    kin = body_kinematics_scalar(ql, qdl, zl)
    rotors = prop.rotors_scalar(ql, qdl, kin)
    passive, V, cols = aero.loads_scalar(kin, (0.0, 0.0, 0.0, 0.0), columns=True)
    # B assembled row-major in Python floats: [thrust R, thrust L, servo R, servo L, δ columns]
    rows = [[0.0, 0.0, prop.cosb, 0.0, 0.0, 0.0, 0.0, 0.0],
            [0.0, 0.0, 0.0, prop.cosb, 0.0, 0.0, 0.0, 0.0]]
    rows += [[0.0, 0.0, 0.0, 0.0, cols[0][i], cols[1][i], cols[2][i], cols[3][i]] for i in range(6)]
    vxz, phis = [0.0, 0.0], [0.0, 0.0]
    d, Jmax, hp = c.diameter, c.J_max, 0.5 * math.pi
    for k in (0, 1):
        dx, dy, dz, rx, ry, rz, zx, zy, zz, u, w = rotors[k]
        v_xz = math.hypot(u, w)
        phi = math.atan2(u, w)
        phi = abs(hp if phi > hp else (-hp if phi < -hp else phi))
        vxz[k], phis[k] = v_xz, phi
        # J as PropellerCoefficients.advance_ratio_and_inflow (n ≤ 0 → J_max unless V_xz = 0)
        J = min(v_xz / max(nl[k] * d, 1e-300), Jmax)
        ct_, cq_ = c.ct_cq_scalar(J, phi)
        # thrust column G_f (+ G_t λ d Cq/Ct) and torque column G_t (7.32), Appendix C
        gf = (dz * zx - dx * zz, ry * zz - rz * zy, rz * zx - rx * zz, rx * zy - ry * zx)
        gt = (zy, zx, zy, zz)
        if torque == "through_thrust":
            ratio = prop._lam_f[k] * (d * cq_ / ct_)
            col = [a + b * ratio for a, b in zip(gf, gt)]
        else:
            col = list(gf)
            tq = prop._lam_f[k] * (c.rho * d ** 5 * nl[k] ** 2 * cq_)
            passive[k] += tq * zy
            for i, v in enumerate(body_wrench_scalar(kin, (0.0, 0.0, 0.0), (zx, zy, zz))[:3], start=2):
                passive[i] += tq * v
        rows[k][k] = col[0]
        for i, v in enumerate(body_wrench_scalar(kin, (zx, zy, zz), col[1:]), start=2):
            rows[i][k] = v
    passive[0] -= p.nu * qdl[0]
    passive[1] -= p.nu * qdl[1]
    return AffineTerms(np.array(rows), np.array(passive), np.array(V), np.array(vxz), np.array(phis))


def input_affine_vectorized(model: TiltrotorModel | TiltrotorParams, q: ArrayLike, qdot: ArrayLike,
                            zeta: ArrayLike, n: ArrayLike | None = None, *, torque: str = "through_thrust"
                            ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Numpy reference of :func:`input_affine` (same arguments and result), written like
    Appendix C from :meth:`PropulsionModel.unit_columns` and :meth:`AeroModel.terms`; the
    scalar tier is tested against it, the compiled kernel against the scalar tier.

    Parameters
    ----------
    model : TiltrotorModel or TiltrotorParams
        The vehicle (its parameters are used).
    q, qdot : array_like, shape (8,)
        Generalized coordinates and velocities, thesis order.
    zeta : array_like, shape (3,)
        Wind, inertial axes (m/s).
    n : array_like, shape (2,), optional
        Propeller speeds (rev/s) of the torque/thrust ratio Cq/Ct(J, φ); ``N_REF`` by default.
    torque : {"through_thrust", "passive"}, default "through_thrust"
        Where the propeller drag torque goes (see :func:`input_affine`).

    Returns
    -------
    B : ndarray, shape (8, 8)
        Input matrix.
    passive : ndarray, shape (8,)
        ϑ_passive.
    """
    _check_torque(torque)
    p, q, qdot, zeta = _checked_state(model, q, qdot, zeta)
    n = np.full(2, N_REF) if n is None else check_vector("n", n, 2)
    prop, aero = cores(p)
    Gf, Gt = prop.unit_columns(q)
    J, phi = prop.coef.advance_ratio_and_inflow(prop.rotor_air_velocity(q, qdot, zeta), n)
    B = np.zeros((8, 8))
    passive, Bd = aero.terms(q, qdot, zeta)
    passive = passive.copy()
    if torque == "through_thrust":
        ratio = prop.lam * prop.coef.torque_per_thrust(J, phi)
        B[:, 0:2] = Gf + Gt * ratio[None, :]
    else:
        B[:, 0:2] = Gf
        passive += Gt @ (prop.lam * prop.coef.torque(n, J, phi))
    B[0, 2] = B[1, 3] = prop.cosb
    B[:, 4:8] = Bd
    passive[0:2] -= p.nu * qdot[0:2]
    return B, passive


def generalized_force(model: TiltrotorModel | TiltrotorParams, q: ArrayLike, qdot: ArrayLike,
                      zeta: ArrayLike, n: ArrayLike, tau_s: ArrayLike,
                      delta: ArrayLike) -> NDArray[np.float64]:
    """Total ϑ = ϑ_P + ϑ_s + ϑ_F + ϑ_W + ϑ_T + ϑ_I (7.18) for thesis inputs
    τ = [n (rev/s), τs (N m), δ (rad)], by the scalar tier of the force models.

    Parameters
    ----------
    model : TiltrotorModel or TiltrotorParams
        The vehicle (its parameters are used).
    q, qdot : array_like, shape (8,)
        Generalized coordinates and velocities, thesis order.
    zeta : array_like, shape (3,)
        Wind, inertial axes (m/s).
    n : array_like, shape (2,)
        Propeller speeds (rev/s).
    tau_s : array_like, shape (2,)
        Servo torques (N m).
    delta : array_like, shape (4,)
        Deflections [δWR δWL δTR δTL] (rad).

    Returns
    -------
    ndarray, shape (8,)
        ϑ, thesis order.
    """
    p, q, qdot, zeta = _checked_state(model, q, qdot, zeta)
    n = check_vector("n", n, 2)
    tau_s = check_vector("tau_s", tau_s, 2)
    delta = check_vector("delta", delta, 4)
    prop, aero = cores(p)
    return (prop.propeller_force(q, qdot, zeta, n) + prop.servo_force(qdot, tau_s)
            + aero.generalized_force(q, qdot, zeta, delta))


def thrust_inputs(model: TiltrotorModel | TiltrotorParams, q: ArrayLike, qdot: ArrayLike, zeta: ArrayLike,
                  n: ArrayLike) -> NDArray[np.float64]:
    """Thrusts f = ρ d⁴ n² Ct(J, φ) (7.25), (7.27) of both propellers.

    Parameters
    ----------
    model : TiltrotorModel or TiltrotorParams
        The vehicle (its parameters are used).
    q, qdot : array_like, shape (8,)
        Generalized coordinates and velocities, thesis order.
    zeta : array_like, shape (3,)
        Wind, inertial axes (m/s).
    n : array_like, shape (2,)
        Propeller speeds (rev/s).

    Returns
    -------
    ndarray, shape (2,)
        Thrusts (N).
    """
    prop, _ = cores(_params_of(model))
    return prop.thrust_and_torque(check_vector("q", q, 8), check_vector("qdot", qdot, 8),
                                  check_vector("zeta", zeta, 3), check_vector("n", n, 2))[0]


def force_disturbance_generalized(model: TiltrotorModel | TiltrotorParams, q: ArrayLike,
                                  force_inertial: ArrayLike) -> NDArray[np.float64]:
    """Generalized force of an inertial force applied at the main-body centre of mass C1.

    Parameters
    ----------
    model : TiltrotorModel or TiltrotorParams
        The vehicle (its parameters are used).
    q : array_like, shape (8,)
        Generalized coordinates, thesis order.
    force_inertial : array_like, shape (3,)
        Force, inertial axes (N).

    Returns
    -------
    ndarray, shape (8,)
        Generalized force, thesis order.
    """
    p = _params_of(model)
    q = check_vector("q", q, 8)
    F = check_vector("force_inertial", force_inertial, 3)
    return body_generalized_force(q, p.d_B_C1, R_IB(q).T @ F)
