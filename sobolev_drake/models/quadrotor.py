"""Quadrotor UAV with rotors tilted toward the centre, thesis (5.123), Table 5.4 (Raffo et al. 2011).

    M(q) q̈ + C(q, q̇) q̇ + g(q) = B(q) τ + w,   q = [ϕ θ ψ x y z],   τ = [Ω1² Ω2² Ω3² Ω4²],

    M = blockdiag(Wᵀ I W, m I₃),  g = [0 0 0 0 0 m g],  B = blockdiag(Wᵀ, R) B₀,

with R = Rz(ψ) Ry(θ) Rx(ϕ), I = diag(Ixx, Iyy, Izz), W the map from Euler-angle rates to body
angular velocity (ω_B = W η̇, η = [ϕ θ ψ]), and B₀ (6×4, body frame) the rotor torques/forces:
thrust b Ω² along each rotor axis, drag (reaction) torque d Ω².

Thesis notes.  (5.123) labels the displayed matrix ``W'_η`` but the matrix shown,
[[1, 0, −sθ], [0, cϕ, sϕ cθ], [0, −sϕ, cϕ cθ]], is W itself (body rates from Euler rates); with
that reading M = Wᵀ I W and the torque block Wᵀ τ_B are the correct Euler–Lagrange terms (taking
the label literally would give W I Wᵀ, which is not the kinetic energy metric).  The printed
g(q) = [0 mg]' means [0 0 0 0 0 m g].  The sum in the Christoffel formula runs to 8 (copied from
the tilt-rotor); for this 6-DOF model it is 6.  C(q, q̇) q̇ is implemented here as
Wᵀ(I Ẇ η̇ + ω × I ω), which is the Christoffel-symbol C of M (checked by finite differences).

Rotor geometry (from the signs of B₀): rotor i at l·(+x, +y, −x, −y) for i = 1..4, its axis tilted
by α toward the centre, n_i = cos α ẑ − sin α p̂_i; reaction-torque signs s = (+1, −1, +1, −1).
B₀ of (5.123) keeps only the body-z component d cos α of each drag torque; a drag torque along
the tilted rotor axis would add ∓d sin α to the roll/pitch rows (≈ 9 % of l b cos α).  Both are
available: ``reaction_torque="thesis"`` (default, equals (5.123)) or ``"axial"``.

The label W′_η can also be read literally (``euler_matrix="thesis-printed"``,
:class:`ThesisPrintedQuadrotorModel`, :mod:`~sobolev_drake.models.euler_zyx`): M_η = W I Wᵀ and
torques through W, with C the Christoffel C of that M.  It is not a rigid body; the model's
adapter then makes the physical MultibodyPlant follow the printed equations (as the arm's
printed inertia does).

Drake model: joint chain x, y, z, yaw, pitch, roll (docs/design.md §3), rotor frames
``rotor1..rotor4`` fixed to the body; ``B(q)`` is computed from the rotor frames with Drake's spatial-velocity
Jacobians (Jᵀ applied to each rotor's spatial force), not from the closed form.

Chapter 6 (6.5.3) reuses (5.123) but its ±10 % uncertainty boxes m ∈ [2.0160, 2.4640],
Ixx, Iyy ∈ [0.0346, 0.0422], Izz ∈ [0.0554, 0.0677] are centred on m = 2.24 kg and
Ixx = Iyy = 0.0384 kg m² (Table 5.4: 2.2 kg, 0.0363 kg m²); Izz (0.0615) agrees.
``QuadrotorParams.chapter6_nominal()`` gives those centres.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from numpy.typing import ArrayLike
from pydrake.common.eigen_geometry import AngleAxis
from pydrake.geometry import Cylinder
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.tree import FixedOffsetFrame, JacobianWrtVariable
from pydrake.systems.framework import DiagramBuilder

from sobolev_drake.models.base import MechanicalModel, check_vector
from sobolev_drake.models.euler_zyx import (EULER_READINGS, angular_coriolis, angular_inertia,
                                            euler_rate_matrix, euler_rate_matrix_dot, torque_map)
from sobolev_drake.models.handles import (PlantHandles, UrdfEditor, attach_adapter, build_plant,
                                          coordinate_map, urdf_text,
                                          verify_against_closed_forms)
from sobolev_drake.models.quadrotor_params import QuadrotorParams

__all__ = [
    "QuadrotorParams", "euler_rate_matrix", "euler_rate_matrix_dot", "rotation_zyx", "rotor_poses",
    "QuadrotorModel", "ThesisPrintedQuadrotorModel", "make_quadrotor_model", "add_quadrotor",
]

THESIS_ORDER = ("phi", "theta", "psi", "x", "y", "z")
ROTOR_DIRECTIONS = np.array([[1.0, 0, 0], [0, 1.0, 0], [-1.0, 0, 0], [0, -1.0, 0]])
ROTOR_SPIN = np.array([1.0, -1.0, 1.0, -1.0])
REACTION_MODES = ("thesis", "axial")


def rotation_zyx(phi: float, theta: float, psi: float) -> np.ndarray:
    """R = Rz(ψ) Ry(θ) Rx(ϕ) (body → world)."""
    return RotationMatrix.MakeZRotation(psi).multiply(RotationMatrix.MakeYRotation(theta)).multiply(
        RotationMatrix.MakeXRotation(phi)).matrix()


def rotor_poses(l: float, alpha: float) -> list[RigidTransform]:
    """Pose of each rotor frame in the body frame: origin l p̂_i, z axis n_i tilted toward the centre."""
    poses = []
    for p_hat in ROTOR_DIRECTIONS:
        # tilt about ẑ × p̂ by −α turns ẑ toward −p̂ (toward the centre)
        axis = np.cross([0.0, 0.0, 1.0], p_hat)
        R = RotationMatrix(AngleAxis(-alpha, axis))
        poses.append(RigidTransform(R, l * p_hat))
    return poses


def _quadrotor_urdf(p: QuadrotorParams) -> str:
    ed = UrdfEditor(urdf_text("quadrotor"))
    ed.set_inertial("body", p.m, [0, 0, 0], [p.Ixx, p.Iyy, p.Izz])
    ed.set_visual("body", 1, box={"size": [2 * p.l, 0.02, 0.02]})
    ed.set_visual("body", 2, box={"size": [0.02, 2 * p.l, 0.02]})
    return ed.text()


def _add_rotors(params: QuadrotorParams, tilt: float):
    def hook(plant):
        body = plant.GetBodyByName("body")
        colors = ([0.9, 0.2, 0.2, 0.6], [0.2, 0.2, 0.9, 0.6], [0.2, 0.2, 0.9, 0.6], [0.2, 0.2, 0.9, 0.6])
        for i, X_BR in enumerate(rotor_poses(params.l, tilt)):
            plant.AddFrame(FixedOffsetFrame(f"rotor{i + 1}", body.body_frame(), X_BR))
            if plant.geometry_source_is_registered():
                X_RG = RigidTransform([0.0, 0.0, 0.03])
                plant.RegisterVisualGeometry(body, X_BR.multiply(X_RG), Cylinder(0.1, 0.01),
                                             f"rotor{i + 1}_disc", np.array(colors[i]))
    return hook


class QuadrotorModel(MechanicalModel):
    """MechanicalModel of (5.123), thesis order q = [ϕ θ ψ x y z], inputs Ω_i².

    Parameters
    ----------
    plant : MultibodyPlant, optional
        Finalized plant built by this module (``None``: build a standalone one).
    params : QuadrotorParams, optional
        Table 5.4 by default.
    tilt : float, optional
        Rotor inclination α in radians (default ``params.alpha`` = 5°); 0 gives the untilted
        vehicle.  If ``plant`` is given its rotor frames must have this tilt.
    reaction_torque : {"thesis", "axial"}, default "thesis"
        ``"thesis"``: body-z drag torque d cos α, equals (5.123); ``"axial"``: drag torque along
        the tilted rotor axis.
    """

    num_inputs = 4
    #: the reading of (5.123)'s W′_η this model uses (:data:`~.euler_zyx.EULER_READINGS`)
    euler_matrix = "physical"

    def __init__(self, plant=None, params: QuadrotorParams | None = None, *, tilt=None,
                 reaction_torque: str = "thesis"):
        params = (params or QuadrotorParams()).validate()
        if tilt is not None:
            params = replace(params, alpha=float(tilt)).validate()
        if reaction_torque not in REACTION_MODES:
            raise ValueError(f"reaction_torque must be one of {REACTION_MODES}, got {reaction_torque!r}")
        self.params = params
        self.tilt = params.alpha
        self.reaction_torque = reaction_torque
        if plant is None:
            plant, _ = build_plant(_quadrotor_urdf(params), params.g,
                                   before_finalize=_add_rotors(params, params.alpha))
        T = coordinate_map(plant, [(name, 1.0) for name in THESIS_ORDER])
        super().__init__(plant, coordinate_map=T, dof_names=list(THESIS_ORDER), name="quadrotor")
        self._body = plant.GetBodyByName("body")
        self._rotors = [plant.GetFrameByName(f"rotor{i + 1}") for i in range(4)]
        self._wrench_B = self.body_wrench_matrix()
        z_axis = self._rotors[0].GetFixedPoseInBodyFrame().rotation().col(2)
        plant_tilt = float(np.arctan2(-z_axis[0], z_axis[2]))  # rotor 1 axis = (−sin α, 0, cos α)
        if abs(plant_tilt - self.tilt) > 1e-9:
            raise ValueError(f"plant rotors are tilted by {plant_tilt} rad but tilt = {self.tilt} rad")
        verify_against_closed_forms(self, np.array([0.3, -0.4, 0.5, 1.0, 2.0, 3.0]))

    # --- thesis closed forms -------------------------------------------------------------------
    def M_closed_form(self, q: ArrayLike) -> np.ndarray:
        """M(q) = blockdiag(Wᵀ I W, m I₃) of (5.123).

        Parameters
        ----------
        q : array_like, shape (6,)
            [ϕ θ ψ x y z].

        Returns
        -------
        ndarray, shape (6, 6)
            M(q).
        """
        return self._mass_matrix(q, "physical")

    def _inertia(self):
        p = self.params
        return np.diag([p.Ixx, p.Iyy, p.Izz])

    def _mass_matrix(self, q, reading):
        q = check_vector("q", q, 6)
        M = np.zeros((6, 6))
        M[:3, :3] = angular_inertia(self._inertia(), q[0], q[1], reading)
        M[3:, 3:] = self.params.m * np.eye(3)
        return M

    def Cqdot_closed_form(self, q: ArrayLike, qdot: ArrayLike) -> np.ndarray:
        """C(q, q̇) q̇ = [Wᵀ(I Ẇ η̇ + ω × I ω); 0], ω = W η̇ (Christoffel C of M, see module doc).

        Parameters
        ----------
        q, qdot : array_like, shape (6,)
            [ϕ θ ψ x y z] and its rates.

        Returns
        -------
        ndarray, shape (6,)
            C(q, q̇) q̇.
        """
        q = check_vector("q", q, 6)
        qdot = check_vector("qdot", qdot, 6)
        I = self._inertia()
        W = euler_rate_matrix(q[0], q[1])
        Wdot = euler_rate_matrix_dot(q[0], q[1], qdot[0], qdot[1])
        eta_dot = qdot[:3]
        w = W @ eta_dot
        return np.r_[W.T @ (I @ Wdot @ eta_dot + np.cross(w, I @ w)), np.zeros(3)]

    def g_closed_form(self, q: ArrayLike) -> np.ndarray:
        """g(q) = [0 0 0 0 0 m g] of (5.123).

        Parameters
        ----------
        q : array_like, shape (6,)
            [ϕ θ ψ x y z] (checked only).

        Returns
        -------
        ndarray, shape (6,)
            g.
        """
        check_vector("q", q, 6)
        p = self.params
        return np.array([0.0, 0.0, 0.0, 0.0, 0.0, p.m * p.g])

    def B0_closed_form(self) -> np.ndarray:
        """Body-frame 6×4 matrix of (5.123) (rows: roll, pitch, yaw torque; x, y, z force).

        With ``reaction_torque="axial"`` the in-plane part −s_i d sin α p̂_i of each drag torque
        is added to the torque rows.

        Returns
        -------
        ndarray, shape (6, 4)
            B₀ per unit Ω_i².
        """
        p = self.params
        ca, sa = np.cos(self.tilt), np.sin(self.tilt)
        lb, d, b = p.l * p.b * ca, p.d * ca, p.b
        B0 = np.array([[0.0, lb, 0.0, -lb],
                       [-lb, 0.0, lb, 0.0],
                       [d, -d, d, -d],
                       [-b * sa, 0.0, b * sa, 0.0],
                       [0.0, -b * sa, 0.0, b * sa],
                       [b * ca, b * ca, b * ca, b * ca]])
        if self.reaction_torque == "axial":
            # in-plane part of a drag torque along the tilted axis: −s_i d sin α p̂_i
            B0[:3, :] += (-ROTOR_SPIN * p.d * np.sin(self.tilt) * ROTOR_DIRECTIONS.T)
        return B0

    def B_closed_form(self, q: ArrayLike) -> np.ndarray:
        """B(q) = blockdiag(Wᵀ, R) B₀ of (5.123).

        Parameters
        ----------
        q : array_like, shape (6,)
            [ϕ θ ψ x y z].

        Returns
        -------
        ndarray, shape (6, 4)
            B(q).
        """
        q = check_vector("q", q, 6)
        W = euler_rate_matrix(q[0], q[1])
        R = rotation_zyx(q[0], q[1], q[2])
        B0 = self.B0_closed_form()
        return np.vstack([W.T @ B0[:3], R @ B0[3:]])

    # --- input matrix from the rotor frames ---------------------------------------------------
    def rotor_wrench_in_rotor_frame(self, i: int) -> tuple[np.ndarray, np.ndarray]:
        """(torque, force) per unit Ω_i², expressed in rotor frame i.

        Parameters
        ----------
        i : int
            Rotor index, 0..3.

        Returns
        -------
        torque, force : ndarray, shape (3,)
            Drag torque (body-z component only for ``reaction_torque="thesis"``) and thrust
            [0, 0, b].
        """
        p = self.params
        force = np.array([0.0, 0.0, p.b])
        if self.reaction_torque == "axial":
            torque = np.array([0.0, 0.0, ROTOR_SPIN[i] * p.d])
        else:  # body-z component only, as in (5.123)
            R_BR = self._rotors[i].GetFixedPoseInBodyFrame().rotation().matrix()
            torque = R_BR.T @ np.array([0.0, 0.0, ROTOR_SPIN[i] * p.d * np.cos(self.tilt)])
        return torque, force

    def body_wrench_matrix(self) -> np.ndarray:
        """Unit-Ω² wrench of each rotor about the body origin, in body axes, assembled from the
        poses of the Drake rotor frames (constant: rotors are fixed).

        Returns
        -------
        ndarray, shape (6, 4)
            Rows: torque, force; one column per rotor.
        """
        cols = []
        for i, frame in enumerate(self._rotors):
            X_BR = frame.GetFixedPoseInBodyFrame()
            R_BR, p_BR = X_BR.rotation().matrix(), X_BR.translation()
            torque, force = self.rotor_wrench_in_rotor_frame(i)
            f_B = R_BR @ force
            cols.append(np.r_[R_BR @ torque + np.cross(p_BR, f_B), f_B])
        return np.column_stack(cols)

    def B(self, q: ArrayLike) -> np.ndarray:
        """B(q) (6×4, thesis order) from Drake's spatial-velocity Jacobian of the body:
        B = Tᵀ J_Bᵀ blockdiag(R_WB, R_WB) W_B, with W_B the rotor wrenches moved to the body
        origin (:meth:`body_wrench_matrix`).  Same as summing Jᵢᵀ wrenchᵢ over the rotor frames.

        Parameters
        ----------
        q : array_like, shape (6,)
            [ϕ θ ψ x y z].

        Returns
        -------
        ndarray, shape (6, 4)
            B(q).
        """
        self._set(q)
        plant, ctx, world = self.plant, self.context, self.plant.world_frame()
        frame = self._body.body_frame()
        J = plant.CalcJacobianSpatialVelocity(ctx, JacobianWrtVariable.kV, frame, np.zeros(3),
                                              world, world)
        R_WB = frame.CalcRotationMatrixInWorld(ctx).matrix()
        W_B = self._wrench_B
        return self.T.T @ (J.T @ np.vstack([R_WB @ W_B[:3], R_WB @ W_B[3:]]))

    def B_per_rotor_jacobians(self, q: ArrayLike) -> np.ndarray:
        """B(q) column by column, column i = Jᵢᵀ [τ_W; f_W] with Jᵢ the Jacobian of rotor frame i
        (slower reference implementation of :meth:`B`).

        Parameters
        ----------
        q : array_like, shape (6,)
            [ϕ θ ψ x y z].

        Returns
        -------
        ndarray, shape (6, 4)
            B(q).
        """
        self._set(q)
        plant, ctx, world = self.plant, self.context, self.plant.world_frame()
        cols = []
        for i, frame in enumerate(self._rotors):
            J = plant.CalcJacobianSpatialVelocity(ctx, JacobianWrtVariable.kV, frame, np.zeros(3),
                                                  world, world)
            R_WR = frame.CalcRotationMatrixInWorld(ctx).matrix()
            torque, force = self.rotor_wrench_in_rotor_frame(i)
            cols.append(self.force_to_thesis(J.T @ np.r_[R_WR @ torque, R_WR @ force]))
        return np.column_stack(cols)


class ThesisPrintedQuadrotorModel(QuadrotorModel):
    """The quadrotor with (5.123)'s W′_η read literally: the rotational block of M is W I Wᵀ,
    C q̇ the Christoffel C of that M, body torques enter through W
    (:mod:`~sobolev_drake.models.euler_zyx`); translation, g and the rotor forces are the
    plant's.  The closed forms (``M_closed_form`` …) stay the physical ones: the plant is
    checked against them.  At ϕ = θ = 0 both readings coincide.

    As a controller's model it gives the law the thesis' printed equations imply; as a
    simulated plant (``add_quadrotor(..., euler_matrix="thesis-printed")``) its adapter makes
    the physical MultibodyPlant follow M q̈ + C q̇ + g = B τ + w of this reading.

    Parameters
    ----------
    plant, params, tilt, reaction_torque
        As for :class:`QuadrotorModel`.
    """

    euler_matrix = "thesis-printed"
    #: the adapter applies the force that makes the plant follow this model's equations
    follows_own_equations = True

    def M(self, q: ArrayLike) -> np.ndarray:
        """M(q) = blockdiag(W I Wᵀ, m I₃).

        Parameters
        ----------
        q : array_like, shape (6,)
            [ϕ θ ψ x y z].

        Returns
        -------
        ndarray, shape (6, 6)
        """
        return self._mass_matrix(q, self.euler_matrix)

    def Cqdot(self, q: ArrayLike, qdot: ArrayLike) -> np.ndarray:
        """C(q, q̇) q̇ of :meth:`M` (Christoffel symbols of the first kind).

        Parameters
        ----------
        q, qdot : array_like, shape (6,)
            [ϕ θ ψ x y z] and its rates.

        Returns
        -------
        ndarray, shape (6,)
        """
        q, qdot = check_vector("q", q, 6), check_vector("qdot", qdot, 6)
        return np.r_[angular_coriolis(self._inertia(), q[:3], qdot[:3], self.euler_matrix), np.zeros(3)]

    def B_plant(self, q: ArrayLike) -> np.ndarray:
        """The simulated plant's B(q) (:meth:`QuadrotorModel.B`, Drake's Jacobians).

        Parameters
        ----------
        q : array_like, shape (6,)
            [ϕ θ ψ x y z].

        Returns
        -------
        ndarray, shape (6, 4)
        """
        return QuadrotorModel.B(self, q)

    def B(self, q: ArrayLike) -> np.ndarray:
        """B(q) with the torque rows W τ_B (in place of the plant's Wᵀ τ_B).

        Parameters
        ----------
        q : array_like, shape (6,)
            [ϕ θ ψ x y z].

        Returns
        -------
        ndarray, shape (6, 4)
        """
        B = self.B_plant(q)
        B[:3] = torque_map(q[0], q[1], self.euler_matrix) @ self._wrench_B[:3]
        return B


def _model_class(euler_matrix):
    if euler_matrix not in EULER_READINGS:
        raise ValueError(f"euler_matrix must be one of {EULER_READINGS}, got {euler_matrix!r}")
    return QuadrotorModel if euler_matrix == "physical" else ThesisPrintedQuadrotorModel


def make_quadrotor_model(params: QuadrotorParams | None = None, *, tilt: float | None = None,
                         reaction_torque: str = "thesis",
                         euler_matrix: str = "physical") -> QuadrotorModel:
    """Standalone QuadrotorModel on its own plant (no SceneGraph).

    Parameters
    ----------
    params, tilt, reaction_torque
        As in :class:`QuadrotorModel`.
    euler_matrix : {"physical", "thesis-printed"}, default "physical"
        "thesis-printed" gives a :class:`ThesisPrintedQuadrotorModel`.

    Returns
    -------
    QuadrotorModel
    """
    return _model_class(euler_matrix)(None, params, tilt=tilt, reaction_torque=reaction_torque)


def add_quadrotor(builder: DiagramBuilder, params: QuadrotorParams | None = None, *,
                  tilt: float | None = None,
                  reaction_torque: str = "thesis", euler_matrix: str = "physical") -> PlantHandles:
    """Add the quadrotor (MultibodyPlant + SceneGraph + adapter) to ``builder``.

    B(q) is recomputed from the plant state at every adapter evaluation.

    Parameters
    ----------
    builder : DiagramBuilder
        The builder the systems are added to.
    params : QuadrotorParams, optional
        Table 5.4 by default.
    tilt : float, optional
        Rotor inclination of this plant (rad, default ``params.alpha``, Table 5.4's 5°): use
        ``tilt=0`` for the untilted truth of section 5.3.2.
    reaction_torque : {"thesis", "axial"}, default "thesis"
        See :class:`QuadrotorModel`.
    euler_matrix : {"physical", "thesis-printed"}, default "physical"
        "thesis-printed" simulates (5.123) with W′_η read literally
        (:class:`ThesisPrintedQuadrotorModel`).

    Returns
    -------
    PlantHandles
        ``u`` = [Ω1² Ω2² Ω3² Ω4²] (rad²/s²); ``disturbance`` = [δϕ δθ δψ δx δy δz];
        ``x`` = [ϕ θ ψ x y z, rates].
    """
    model_class = _model_class(euler_matrix)
    params = (params or QuadrotorParams()).validate()
    if tilt is not None:
        params = replace(params, alpha=float(tilt)).validate()
    plant, scene_graph = build_plant(_quadrotor_urdf(params), params.g, builder,
                                     before_finalize=_add_rotors(params, params.alpha))
    model = model_class(plant, params, reaction_torque=reaction_torque)
    return attach_adapter(builder, plant, scene_graph, model, "quadrotor")


Params = QuadrotorParams  # short alias
