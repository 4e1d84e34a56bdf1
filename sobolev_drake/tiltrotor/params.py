"""Parameters (thesis Table B.1) and rigid-body kinematics of the tilt-rotor UAV (section 7.2).

Generalized coordinates in thesis order q = [αR αL φ θ ψ x y z] (7.1)–(7.13); z up;
R_I^B = Rz(ψ) Ry(θ) Rx(φ); R_B^A2 = Ry(αR) Rx(−β), R_B^A3 = Ry(αL) Rx(β).

This module has no Drake dependency: it is shared by the URDF writer, the force systems
(propellers, aerodynamics), the input-affine form and the tests.  Generalized forces are
obtained from the Jacobians of the thesis in closed form:

* a force ``F_B`` (body axes) at body point ``r`` plus a body torque ``M_B`` on the main body give
  ``[0, 0, Wηᵀ (r × F_B + M_B), R F_B]``  ((7.47) with J_S (7.35), W_S (7.36));
* on a thruster group they also give ``e_yᵀ (R_B^A d × F_B + M_B)`` on its tilt angle (7.32).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sobolev_drake.validation import check_parameter_fields

__all__ = [
    "DOF_NAMES", "ACTUATOR_NAMES", "SURFACES", "TiltrotorParams", "rot_x", "rot_y", "rot_z",
    "R_IB", "W_eta", "R_BA", "body_generalized_force", "body_point_velocity", "R_W", "cross_rows",
    "params_key",
]

#: thesis order of the generalized coordinates
DOF_NAMES = ("alpha_R", "alpha_L", "phi", "theta", "psi", "x", "y", "z")
#: thesis order of the input-affine actuator vector τ̄ (7.62)
ACTUATOR_NAMES = ("f_PR", "f_PL", "tau_sR", "tau_sL", "delta_WR", "delta_WL", "delta_TR", "delta_TL")
#: aerodynamic surfaces (7.34)–(7.56): fuselage, wings, tails, interference (at C1)
SURFACES = ("F", "WR", "WL", "TR", "TL", "I")
#: how the angle-of-attack tables meet sideslip (``TiltrotorParams.crossflow``; the
#: aerodynamics module docstring explains both)
CROSSFLOW_MODELS = ("independence", "thesis")
#: how the angle-of-attack tables (−90°…90°) meet reverse flow u < 0
#: (``TiltrotorParams.reverse_flow``; see the aerodynamics module docstring)
REVERSE_FLOW_MODELS = ("mirrored", "clipped")


def _v(x):
    return np.asarray(x, dtype=float)


#: parameters that must be > 0 (masses, gravity, air density, areas, lengths); the others only finite
_POSITIVE = ("g", "m1", "m2", "m3", "rho", "S", "chord", "span")


@dataclass(frozen=True)
class TiltrotorParams:
    """Physical and aerodynamic parameters of the ProVANT-Emergentia tilt-rotor (Table B.1).

    Gravity: Table B.1 lists 9.87 m/s², the text of (7.17) 9.8 m/s²; 9.8 is the default because
    it reproduces the thesis' hover trim n = 51.9 rev/s best (see ``trim_hover``).

    SI units, angles in radians; vectors ``d_X_Y`` are positions of point Y from the origin of
    frame X, in X's axes (B: main body, A: thruster group frame A2 or A3).  Masses, g, rho, S,
    chord and span must be positive, every other field finite.

    Parameters
    ----------
    g : float, default 9.8
        Gravitational acceleration (m/s²).
    beta : float, default 5°
        Thruster inclination toward the fuselage, β of (7.4), (7.6).
    epsilon : float, default 5°
        Wing dihedral (visual only: R_I^S = R_I^B, App. B).
    mu : float, default 30°
        V-tail dihedral (visual only).
    nu : float, default 0.005
        Servo viscous friction ν (N m s/rad), (7.33).
    m1, m2, m3 : float, default 7.0, 0.3, 0.3
        Masses (kg) of the main body C1 and the right and left thruster groups C2, C3.
    d_B_C1 : ndarray, shape (3,)
        Main body centre of mass C1.
    d_B_A2, d_B_A3 : ndarray, shape (3,)
        Right and left servo joints A2, A3.
    d_A_C : ndarray, shape (3,)
        Thruster group centre of mass (A2→C2, A3→C3).
    d_A_P : ndarray, shape (3,)
        Propeller hub (A2→PR, A3→PL).
    d_B_F, d_B_WR, d_B_WL, d_B_TR, d_B_TL : ndarray, shape (3,)
        Aerodynamic centres of the fuselage, right and left wing, right and left tail.
    I_C1, I_C2, I_C3 : ndarray, shape (3, 3)
        Inertia tensors (kg m²) of the main body and the thruster groups about their centres
        of mass.
    lambda_R, lambda_L : float, default 1.0, -1.0
        Propeller rotation signs λR, λL of (7.25)–(7.28).
    rho : float, default 1.21
        Air density (kg/m³).
    S : float, default 0.125
        Reference area (m²) of each tested component (each wing or tail half uses S/2).
    chord : float, default 0.1366
        Reference length (m) of the pitch moment coefficients.
    span : float, default 1.7592
        Reference length (m) of the yaw moment coefficients.
    c_delta_a, c_delta_e, c_delta_r : float, default 0.7104, 0.3759, -0.0730
        Control surface coefficients per unit deflection: aileron lift (wings), ruddervator
        lift (elevator part) and side force (rudder part) of the tails.
    crossflow : {"independence", "thesis"}, default "independence"
        How the angle-of-attack tables meet sideslip (see the aerodynamics module): on the
        x–z-plane dynamic pressure, or on κ = ½ρV² as (7.41)–(7.45) are written.
    reverse_flow : {"mirrored", "clipped"}, default "mirrored"
        How the angle-of-attack tables meet reverse flow u < 0: tables at atan2(w, |u|) with
        axes along the flow (continuous; identical to "clipped" in forward flow), or the
        thesis form α = atan2(w, max(u, 0)), which jumps where w changes sign.
    """

    g: float = 9.8
    beta: float = np.deg2rad(5.0)        # thruster inclination toward the fuselage
    epsilon: float = np.deg2rad(5.0)     # wing dihedral (visual only: R_I^S = R_I^B, App. B)
    mu: float = np.deg2rad(30.0)         # V-tail dihedral (visual only)
    nu: float = 0.005                    # servo viscous friction [N m s/rad]
    m1: float = 7.0
    m2: float = 0.3
    m3: float = 0.3
    d_B_C1: np.ndarray = field(default_factory=lambda: _v([0.05, 0.0, 0.12]))
    d_B_A2: np.ndarray = field(default_factory=lambda: _v([0.03, -1.025, 0.292]))
    d_B_A3: np.ndarray = field(default_factory=lambda: _v([0.03, 1.025, 0.292]))
    d_A_C: np.ndarray = field(default_factory=lambda: _v([0.0, 0.0, 0.07]))   # A2→C2, A3→C3
    d_A_P: np.ndarray = field(default_factory=lambda: _v([0.0, 0.0, 0.1]))    # A2→PR, A3→PL
    d_B_F: np.ndarray = field(default_factory=lambda: _v([0.1960, 0.0, 0.1200]))
    d_B_WR: np.ndarray = field(default_factory=lambda: _v([0.0060, -0.4650, 0.2620]))
    d_B_WL: np.ndarray = field(default_factory=lambda: _v([0.0060, 0.4650, 0.2620]))
    d_B_TR: np.ndarray = field(default_factory=lambda: _v([-0.4823, -0.2952, 0.3532]))
    d_B_TL: np.ndarray = field(default_factory=lambda: _v([-0.4823, 0.2952, 0.3532]))
    I_C1: np.ndarray = field(default_factory=lambda: _v([[2.727, 0, -0.002], [0, 7.447, 0], [-0.002, 0, 9.95]]))
    I_C2: np.ndarray = field(default_factory=lambda: np.diag([0.005, 0.005, 0.002]))
    I_C3: np.ndarray = field(default_factory=lambda: np.diag([0.005, 0.005, 0.002]))
    # propellers (7.25)–(7.28): rotation signs λR = 1, λL = −1
    lambda_R: float = 1.0
    lambda_L: float = -1.0
    # aerodynamics (Appendix B)
    rho: float = 1.21
    S: float = 0.125                    # reference area of each tested component
    chord: float = 0.1366
    span: float = 1.7592
    c_delta_a: float = 0.7104
    c_delta_e: float = 0.3759
    c_delta_r: float = -0.0730
    # "independence": α-table terms on the x–z-plane dynamic pressure ½ρ(u² + w²) = κ cos²β;
    # "thesis": on κ = ½ρV² as (7.41)–(7.45) are written (7× the measured side force in a
    # pure crossflow, see tiltrotor/aerodynamics.py)
    crossflow: str = "independence"
    # "clipped": α = atan2(w, max(u, 0)) (loads jump where w changes sign in reverse flow);
    # "mirrored": tables at atan2(w, |u|), axes along the flow (continuous; see aerodynamics)
    reverse_flow: str = "mirrored"

    def __post_init__(self) -> None:
        check_parameter_fields(self, positive=_POSITIVE)
        if self.crossflow not in CROSSFLOW_MODELS:
            raise ValueError(f"crossflow must be one of {CROSSFLOW_MODELS}, got {self.crossflow!r}")
        if self.reverse_flow not in REVERSE_FLOW_MODELS:
            raise ValueError(f"reverse_flow must be one of {REVERSE_FLOW_MODELS}, "
                             f"got {self.reverse_flow!r}")

    @property
    def mass(self) -> float:
        """Total mass m1 + m2 + m3 (kg)."""
        return self.m1 + self.m2 + self.m3

    def with_(self, **changes: Any) -> TiltrotorParams:
        """Copy with some parameters changed.

        Parameters
        ----------
        **changes
            Field names and their new values (checked as at construction).

        Returns
        -------
        TiltrotorParams
            The modified copy (``self`` is frozen and unchanged).
        """
        return replace(self, **changes)

    def aero_points(self) -> np.ndarray:
        """Body-frame aerodynamic centres in ``SURFACES`` order (interference at C1).

        Returns
        -------
        ndarray, shape (6, 3)
            d_B_F, d_B_WR, d_B_WL, d_B_TR, d_B_TL, d_B_C1.
        """
        return np.array([self.d_B_F, self.d_B_WR, self.d_B_WL, self.d_B_TR, self.d_B_TL, self.d_B_C1])


# --- rotations ---------------------------------------------------------------------------------
def rot_x(a: float) -> NDArray[np.float64]:
    """Elementary rotation matrix Rx(a) about the x axis (right-handed, active).

    Parameters
    ----------
    a : float
        Rotation angle (rad).

    Returns
    -------
    ndarray, shape (3, 3)
        Rx(a): maps vectors in the rotated frame's axes to the parent frame's axes.
    """
    c, s = np.cos(a), np.sin(a)
    return np.array([[1.0, 0, 0], [0, c, -s], [0, s, c]])


def rot_y(a: float) -> NDArray[np.float64]:
    """Elementary rotation matrix Ry(a) about the y axis (right-handed, active).

    Parameters
    ----------
    a : float
        Rotation angle (rad).

    Returns
    -------
    ndarray, shape (3, 3)
        Ry(a): maps vectors in the rotated frame's axes to the parent frame's axes.
    """
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s], [0, 1.0, 0], [-s, 0, c]])


def rot_z(a: float) -> NDArray[np.float64]:
    """Elementary rotation matrix Rz(a) about the z axis (right-handed, active).

    Parameters
    ----------
    a : float
        Rotation angle (rad).

    Returns
    -------
    ndarray, shape (3, 3)
        Rz(a): maps vectors in the rotated frame's axes to the parent frame's axes.
    """
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])


def R_IB(q: ArrayLike) -> np.ndarray:
    """R_I^B = Rz(ψ) Ry(θ) Rx(φ) (7.2).

    Parameters
    ----------
    q : array_like, shape (8,)
        Generalized coordinates in thesis order [αR αL φ θ ψ x y z] (rad, m); only the
        Euler angles φ, θ, ψ = q[2:5] are used.

    Returns
    -------
    ndarray, shape (3, 3)
        Rotation from main-body axes B to inertial axes I (z up).
    """
    return rot_z(q[4]) @ rot_y(q[3]) @ rot_x(q[2])


def W_eta(q: ArrayLike) -> np.ndarray:
    """Wη of (7.10): body angular velocity ω_B = Wη η̇, η = [φ θ ψ].

    Parameters
    ----------
    q : array_like, shape (8,)
        Generalized coordinates in thesis order [αR αL φ θ ψ x y z] (rad, m); only φ and θ
        (q[2], q[3]) are used.

    Returns
    -------
    ndarray, shape (3, 3)
        Wη, mapping Euler-angle rates η̇ (rad/s) to the body-axes angular velocity ω_B
        (rad/s).
    """
    sphi, cphi = np.sin(q[2]), np.cos(q[2])
    sth, cth = np.sin(q[3]), np.cos(q[3])
    return np.array([[1.0, 0.0, -sth], [0.0, cphi, cth * sphi], [0.0, -sphi, cphi * cth]])


def R_BA(params: TiltrotorParams, alpha_R: float,
         alpha_L: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(R_B^A2, R_B^A3) = (Ry(αR) Rx(−β), Ry(αL) Rx(β)) (7.4), (7.6).

    Parameters
    ----------
    params : TiltrotorParams
        Vehicle parameters; only the thruster inclination ``beta`` (β, rad) is used.
    alpha_R, alpha_L : float
        Tilt angles αR, αL (rad) of the right and left thruster groups (q[0], q[1]).

    Returns
    -------
    tuple of ndarray, each shape (3, 3)
        (R_B^A2, R_B^A3): rotations from the right and left thruster-group frames A2, A3 to
        the main-body axes B.
    """
    return rot_y(alpha_R) @ rot_x(-params.beta), rot_y(alpha_L) @ rot_x(params.beta)


def body_generalized_force(q: ArrayLike, r_B: ArrayLike, F_B: ArrayLike,
                           M_B: ArrayLike | None = None) -> NDArray[np.float64]:
    """Generalized force (thesis order) of body-axes forces ``F_B`` (k, 3) at body points
    ``r_B`` (k, 3) plus body torques ``M_B`` (k, 3), all acting on the main body.

    This is ``[0, 0, Wηᵀ Σ(r × F_B + M_B), R_I^B Σ F_B]`` ((7.47) with J_S (7.35), W_S (7.36)).

    Parameters
    ----------
    q : array_like, shape (8,)
        Generalized coordinates in thesis order [αR αL φ θ ψ x y z] (rad, m).
    r_B : array_like, shape (k, 3) or (3,)
        Points of application (m), from the body origin, in body axes B.
    F_B : array_like, shape (k, 3) or (3,)
        Forces (N) in body axes B, one per point.
    M_B : array_like, shape (k, 3) or (3,), optional
        Additional pure torques (N m) on the main body, in body axes B; None for none.

    Returns
    -------
    ndarray, shape (8,)
        Generalized force in thesis order: zero on the tilt angles αR, αL, torques (N m) on
        φ, θ, ψ and the inertial-axes force (N) on x, y, z.
    """
    F_B = np.atleast_2d(F_B)
    tau_B = np.cross(np.atleast_2d(r_B), F_B).sum(axis=0)
    if M_B is not None:
        tau_B = tau_B + np.atleast_2d(M_B).sum(axis=0)
    out = np.zeros(8)
    out[2:5] = W_eta(q).T @ tau_B
    out[5:8] = R_IB(q) @ F_B.sum(axis=0)
    return out


def body_point_velocity(q: ArrayLike, qdot: ArrayLike, r_B: ArrayLike) -> np.ndarray:
    """Body-axes velocity R_Bᵀ ṗ of main-body points ``r_B`` (k, 3) (7.35).

    Parameters
    ----------
    q : array_like, shape (8,)
        Generalized coordinates in thesis order [αR αL φ θ ψ x y z] (rad, m).
    qdot : array_like, shape (8,)
        Generalized velocities q̇ (rad/s, m/s), same order.
    r_B : array_like, shape (k, 3) or (3,)
        Points (m) fixed on the main body, from the body origin, in body axes B.

    Returns
    -------
    ndarray, shape (k, 3)
        Inertial velocity (m/s) of each point expressed in body axes: R_I^Bᵀ ẋ + ω_B × r_B.
    """
    R = R_IB(q)
    w = W_eta(q) @ qdot[2:5]
    return (R.T @ qdot[5:8])[None, :] + np.cross(w, np.atleast_2d(r_B))


def R_W(q: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(R_I^B, Wη) at q in one pass with scalar math (the hot path of the force systems).

    Parameters
    ----------
    q : array_like, shape (8,)
        Generalized coordinates in thesis order [αR αL φ θ ψ x y z] (rad, m); only the
        Euler angles φ, θ, ψ = q[2:5] are used.

    Returns
    -------
    R : ndarray, shape (3, 3)
        R_I^B = Rz(ψ) Ry(θ) Rx(φ) (7.2), body to inertial axes (same as ``R_IB(q)``).
    W : ndarray, shape (3, 3)
        Wη of (7.10), Euler-angle rates to body angular velocity (same as ``W_eta(q)``).
    """
    sf, cf = math.sin(q[2]), math.cos(q[2])
    st, ct = math.sin(q[3]), math.cos(q[3])
    sp, cp = math.sin(q[4]), math.cos(q[4])
    R = np.array([[cp * ct, cp * st * sf - sp * cf, cp * st * cf + sp * sf],
                  [sp * ct, sp * st * sf + cp * cf, sp * st * cf - cp * sf],
                  [-st, ct * sf, ct * cf]])
    W = np.array([[1.0, 0.0, -st], [0.0, cf, ct * sf], [0.0, -sf, cf * ct]])
    return R, W


def cross_rows(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise cross product of (k, 3) arrays (np.cross is slow for small arrays).

    Parameters
    ----------
    a, b : ndarray, shape (..., 3)
        Vectors to multiply, row by row (broadcast against each other); any units.

    Returns
    -------
    ndarray, shape (..., 3)
        a × b for each row, in the product of the inputs' units.
    """
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def params_key(params: TiltrotorParams) -> tuple:
    """The value of ``params`` as a hashable key (the dataclass holds numpy arrays), for caches
    of models and diagrams built once per parameter value.

    Parameters
    ----------
    params : TiltrotorParams
        Vehicle parameters.

    Returns
    -------
    tuple
        (field name, bytes or string) pairs; equal for equal parameter values.
    """
    from dataclasses import fields
    return tuple((f.name, v if isinstance(v, str) else np.asarray(v, dtype=float).tobytes())
                 for f in fields(params) for v in (getattr(params, f.name),))
