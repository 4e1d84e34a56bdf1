"""Euler–Lagrange model of a plant with a floating base (quaternion or roll-pitch-yaw joint),
driven by propellers, in Euler-angle coordinates.

Drake's floating joints have q̇ ≠ v (quaternion: 7 positions, 6 velocities).  The model uses
the coordinates q = [ϕ θ ψ x y z, other joints] (ZYX Euler angles of the floating body then
its position — the thesis quadrotor's order, (5.123); other joints in Drake's order) and
q̇ their time derivatives.  Drake's velocities are v = J(q) q̇ with
J = blockdiag(R W, I₃, I) (:mod:`~sobolev_drake.models.euler_chart`), so from Drake's
M_d v̇ + C_d v = τ_g + τ and v̇ = J q̈ + J̇ q̇ (J̇ q̇ = [R Ẇ η̇; 0] because Ṙ W η̇ = R (ω_B × ω_B)
= 0), projecting with Jᵀ gives the Lagrange equations in q:

    M(q) = Jᵀ M_d J,   C(q, q̇) q̇ = Jᵀ (M_d J̇ q̇ + C_d v),   g(q) = −Jᵀ τ_g,   B(q) = Jᵀ B_d,

B_d's columns being the generalized force of each input at unit command: one per Drake
``PropellerInfo`` (thrust ``thrust_ratio`` along the propeller's z axis, reaction torque
``moment_ratio`` about it, at ``X_BP`` on its body — exactly what Drake's ``Propeller`` system
applies), then the plant's joint actuators.  ``reaction_torque="body_z"`` keeps only the
component of each reaction torque along the z axis of the propeller's body,
moment_ratio (n · ẑ_B) ẑ_B for propeller axis n — the thesis' B₀ of (5.123), whose drag
torques are d cos α along body z for rotors tilted by α; a Drake ``Propeller`` cannot apply
that torque, so the plant must then be driven another way (e.g. the quadrotor's adapter).  C q̇ is quadratic in q̇, so ``C_times``'s
polarization holds.  The chart is singular at θ = ±90°: every evaluation refuses |θ| ≥
``max_pitch`` by name (:func:`~sobolev_drake.models.euler_chart.check_pitch`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike
from pydrake.multibody.plant import MultibodyPlant, PropellerInfo
from pydrake.multibody.tree import JacobianWrtVariable, Joint
from scipy.optimize import lsq_linear

from sobolev_drake.models.base import MechanicalModel, check_vector
from sobolev_drake.models.euler_chart import (DEFAULT_MAX_PITCH, check_pitch, euler_rates,
                                              euler_to_quaternion, quaternion_to_euler,
                                              rotation_of_euler)
from sobolev_drake.models.euler_zyx import euler_rate_matrix, euler_rate_matrix_dot
from sobolev_drake.models.plant_checks import check_context, check_plant

__all__ = ["FLOATING_JOINTS", "REACTION_TORQUES", "FloatingBaseModel", "floating_joint"]

#: Drake joint types a floating base may use
FLOATING_JOINTS = ("quaternion_floating", "rpy_floating")
#: readings of a propeller's reaction torque in B(q): along its axis (Drake's ``Propeller``)
#: or its component along the body z axis only ((5.123))
REACTION_TORQUES = ("axial", "body_z")
EULER_NAMES = ("phi", "theta", "psi", "x", "y", "z")


def floating_joint(plant: MultibodyPlant) -> Joint | None:
    """The plant's one floating joint (quaternion or roll-pitch-yaw), or None.

    Parameters
    ----------
    plant : MultibodyPlant
        Finalized plant.

    Returns
    -------
    Joint or None

    Raises
    ------
    ValueError
        More than one floating joint (the model has one floating base).
    """
    joints = [plant.get_joint(i) for i in plant.GetJointIndices()
              if plant.get_joint(i).type_name() in FLOATING_JOINTS]
    if len(joints) > 1:
        raise ValueError(f"plant has {len(joints)} floating joints "
                         f"({', '.join(repr(j.name()) for j in joints)}); a floating-base model "
                         "has one: weld or join the other bodies to the base")
    return joints[0] if joints else None


class FloatingBaseModel(MechanicalModel):
    """:class:`MechanicalModel` of a floating-base plant in Euler-angle coordinates, inputs =
    propeller commands then joint actuators (module docstring); built by
    ``MechanicalModel.from_plant(plant, propellers=...)``.

    Parameters
    ----------
    plant : MultibodyPlant
        Finalized double plant with one quaternion or roll-pitch-yaw floating joint; other
        joints need q̇ = v; no joint damping, constraints or force elements but gravity.
    propellers : sequence of PropellerInfo, optional
        The propellers of the Drake ``Propeller`` system driving the plant, in its command
        order.
    context : Context, optional
        Plant context whose parameters the model uses (copied).
    name : str, optional
        Model name (default: the floating body's model instance).
    command_lower, command_upper : array_like, optional
        Bounds of the inputs (default 0 and +inf for propellers, the effort limits for joint
        actuators); ``input_lower``/``input_upper``.
    max_pitch : float, optional
        |θ| refused from here on (default :data:`~.euler_chart.DEFAULT_MAX_PITCH`, 80°).
    reaction_torque : {"axial", "body_z"}, default "axial"
        Each propeller's reaction torque in B(q): ``"axial"`` moment_ratio along its axis n
        (what Drake's ``Propeller`` applies); ``"body_z"`` only its component along the z axis
        ẑ_B of the propeller's body, moment_ratio (n · ẑ_B) ẑ_B — the thesis' B₀ of (5.123)
        (drag torque d cos α along body z for a rotor tilted by α).
    """

    def __init__(self, plant, *, propellers=None, context=None, name=None, command_lower=None,
                 command_upper=None, max_pitch=DEFAULT_MAX_PITCH, reaction_torque="axial"):
        check_plant(plant)
        joint = floating_joint(plant)
        if joint is None:
            raise ValueError("plant has no quaternion or roll-pitch-yaw floating joint: use "
                             "MechanicalModel.from_plant(plant) without propellers")
        self.plant, self.joint = plant, joint
        self.kind = joint.type_name()
        self.max_pitch = float(max_pitch)
        if not 0.0 < self.max_pitch < 0.5 * np.pi:
            raise ValueError(f"max_pitch must be in (0, π/2) rad, got {max_pitch}")
        if reaction_torque not in REACTION_TORQUES:
            raise ValueError(f"reaction_torque must be one of {REACTION_TORQUES}, got "
                             f"{reaction_torque!r}")
        self.reaction_torque = reaction_torque
        self.context = plant.CreateDefaultContext()
        self._last = {}
        if context is not None:
            check_context(plant, context)
            self.context.SetTimeStateAndParametersFrom(context)
        self._check_elements()
        self.n = plant.num_velocities()
        fq, fv = joint.position_start(), joint.velocity_start()
        # the other joints (q̇ = v): their Drake position and velocity indices, in Drake order
        rest_q = [i for i in range(plant.num_positions()) if not fq <= i < fq + joint.num_positions()]
        rest_v = [i for i in range(plant.num_velocities()) if not fv <= i < fv + 6]
        self._fq, self._fv, self._rest_q, self._rest_v = fq, fv, rest_q, rest_v
        names = plant.GetPositionNames(add_model_instance_prefix=False, always_add_suffix=False)
        self.dof_names = list(EULER_NAMES) + [names[i] for i in rest_q]
        self.name = name or plant.GetModelInstanceName(joint.child_body().model_instance())
        self.T = None                    # no constant coordinate map: PlantDynamics' slow path
        self.propellers = list(propellers or [])
        for i, info in enumerate(self.propellers):
            if not isinstance(info, PropellerInfo):
                raise TypeError(f"propellers[{i}] must be a pydrake PropellerInfo, got "
                                f"{type(info).__name__}")
        actuators = plant.MakeActuationMatrix() if plant.num_actuators() else np.zeros((self.n, 0))
        self._B_actuators = actuators
        self.num_inputs = len(self.propellers) + actuators.shape[1]
        if self.num_inputs == 0:
            raise ValueError("the floating-base plant has no inputs: pass propellers=[PropellerInfo"
                             "(...), ...] (those of the Drake Propeller system driving it) or add "
                             "joint actuators")
        effort = np.array([plant.get_joint_actuator(i).effort_limit()
                           for i in plant.GetJointActuatorIndices()], dtype=float)
        lo = np.r_[np.zeros(len(self.propellers)), -effort]
        hi = np.r_[np.full(len(self.propellers), np.inf), effort]
        self.input_lower = lo if command_lower is None else check_vector(
            "command_lower", np.broadcast_to(command_lower, lo.shape), lo.size)
        self.input_upper = hi if command_upper is None else _upper(command_upper, hi.size)
        if np.any(self.input_lower > self.input_upper):
            raise ValueError(f"command_lower {self.input_lower} exceeds command_upper "
                             f"{self.input_upper}")

    def _check_elements(self):
        plant = self.plant
        for index in plant.GetJointIndices():
            joint = plant.get_joint(index)
            if joint is not self.joint and joint.num_positions() != joint.num_velocities():
                raise ValueError(f"joint {joint.name()!r} ({joint.type_name()}) has q̇ ≠ v; only "
                                 "the floating base may")
            if joint.num_velocities() and np.any(joint.GetDampingVector(self.context)):
                raise ValueError(f"joint {joint.name()!r} has damping "
                                 f"{joint.GetDampingVector(self.context)}, which the "
                                 "floating-base model does not represent: set it to zero")
        if plant.num_constraints():
            raise ValueError(f"plant has {plant.num_constraints()} constraint(s), which the "
                             "floating-base model does not represent")
        if plant.num_force_elements() > 1:     # element 0 is gravity
            raise ValueError("the floating-base model represents gravity only: the plant has "
                             f"{plant.num_force_elements() - 1} other force element(s)")

    # --- the chart ------------------------------------------------------------------------
    def to_drake_state(self, q: ArrayLike, qdot: ArrayLike | None = None, *,
                       J: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Drake's (positions, velocities) of a model state.

        Parameters
        ----------
        q : array_like, shape (n,)
            [ϕ θ ψ x y z, other joints].
        qdot : array_like, shape (n,), optional
            Its time derivative (zeros when omitted).
        J : ndarray, optional
            :meth:`velocity_jacobian` at ``q`` when already known.

        Returns
        -------
        (ndarray, ndarray)
            Drake's q (``num_positions``) and v (``num_velocities``).
        """
        q = check_vector("q", q, self.n)
        qdot = np.zeros(self.n) if qdot is None else check_vector("qdot", qdot, self.n)
        qd = np.zeros(self.plant.num_positions())
        vd = np.zeros(self.n)
        att = euler_to_quaternion(q[:3]) if self.kind == "quaternion_floating" else q[:3]
        qd[self._fq:self._fq + len(att)] = att
        qd[self._fq + len(att):self._fq + len(att) + 3] = q[3:6]
        qd[self._rest_q] = q[6:]
        J = self.velocity_jacobian(q) if J is None else J
        vd[self._fv:self._fv + 6] = J[self._fv:self._fv + 6, :6] @ qdot[:6]
        vd[self._rest_v] = qdot[6:]
        return qd, vd

    def from_drake_state(self, q_drake: ArrayLike,
                         v_drake: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """The model state (q, q̇) of Drake's positions and velocities (any scalar type).

        Parameters
        ----------
        q_drake, v_drake : array_like
            Drake's positions and velocities.

        Returns
        -------
        (ndarray, ndarray)
            q = [ϕ θ ψ x y z, other joints] and q̇.
        """
        q_drake, v_drake = np.asarray(q_drake).ravel(), np.asarray(v_drake).ravel()
        fq, fv = self._fq, self._fv
        if self.kind == "quaternion_floating":
            eta, pos = quaternion_to_euler(q_drake[fq:fq + 4]), q_drake[fq + 4:fq + 7]
        else:
            eta, pos = q_drake[fq:fq + 3], q_drake[fq + 3:fq + 6]
        q = np.concatenate([eta, pos, q_drake[self._rest_q]])
        qdot = np.concatenate([euler_rates(eta, v_drake[fv:fv + 3]), v_drake[fv + 3:fv + 6],
                               v_drake[self._rest_v]])
        return q, qdot

    def velocity_jacobian(self, q: ArrayLike) -> np.ndarray:
        """J(q) with Drake's v = J q̇ (n × n; rows in Drake's velocity order).

        Parameters
        ----------
        q : array_like, shape (n,)
            Model coordinates.

        Returns
        -------
        ndarray, shape (n, n)
        """
        q = check_vector("q", q, self.n)
        check_pitch(q[:3], self.max_pitch, q)
        J = np.zeros((self.n, self.n))
        fv = self._fv
        J[fv:fv + 3, :3] = rotation_of_euler(q[:3]) @ euler_rate_matrix(q[0], q[1])
        J[fv + 3:fv + 6, 3:6] = np.eye(3)
        if self._rest_v:
            J[self._rest_v, np.arange(6, self.n)] = 1.0
        return J

    def _set(self, q, qdot=None):
        """Write (q, q̇) into the model's context (q̇ = 0 when omitted) and return J(q); the
        last q and state are remembered, as a controller asks for M, C q̇, g and B at one
        state."""
        q = check_vector("q", q, self.n)
        key_q = q.tobytes()
        if key_q != self._last.get("q"):
            self._last = {"q": key_q, "J": self.velocity_jacobian(q)}
        J = self._last["J"]
        if qdot is None and "state" in self._last:
            return J                      # M, g and B do not depend on the velocities
        key = None if qdot is None else check_vector("qdot", qdot, self.n).tobytes()
        if self._last.get("state", 0) != key:
            qd, vd = self.to_drake_state(q, qdot, J=J)
            self.plant.SetPositionsAndVelocities(self.context, np.concatenate([qd, vd]))
            self._last["state"] = key
        return J

    # --- Euler–Lagrange terms ---------------------------------------------------------------
    def M(self, q: ArrayLike) -> np.ndarray:
        """M(q) = Jᵀ M_d J.

        Parameters
        ----------
        q : array_like, shape (n,)
            Model coordinates.

        Returns
        -------
        ndarray, shape (n, n)
        """
        J = self._set(q)
        return J.T @ self.plant.CalcMassMatrix(self.context) @ J

    def Cqdot(self, q: ArrayLike, qdot: ArrayLike) -> np.ndarray:
        """C(q, q̇) q̇ = Jᵀ (M_d J̇ q̇ + C_d v).

        Parameters
        ----------
        q, qdot : array_like, shape (n,)
            Model coordinates and their rates.

        Returns
        -------
        ndarray, shape (n,)
        """
        J = self._set(q, qdot)
        q, qdot = np.asarray(q, float), np.asarray(qdot, float)
        jdot_qdot = np.zeros(self.n)
        fv = self._fv
        jdot_qdot[fv:fv + 3] = rotation_of_euler(q[:3]) @ euler_rate_matrix_dot(
            q[0], q[1], qdot[0], qdot[1]) @ qdot[:3]
        ctx = self.context
        return J.T @ (self.plant.CalcMassMatrix(ctx) @ jdot_qdot + self.plant.CalcBiasTerm(ctx))

    def g(self, q: ArrayLike) -> np.ndarray:
        """g(q) = −Jᵀ τ_g.

        Parameters
        ----------
        q : array_like, shape (n,)
            Model coordinates.

        Returns
        -------
        ndarray, shape (n,)
        """
        J = self._set(q)
        return -J.T @ self.plant.CalcGravityGeneralizedForces(self.context)

    def B(self, q: ArrayLike) -> np.ndarray:
        """B(q) = Jᵀ [propeller wrenches at unit command, joint actuation] (n × num_inputs);
        with ``reaction_torque="body_z"`` a propeller's reaction torque is its body-z
        component only ((5.123)).

        Parameters
        ----------
        q : array_like, shape (n,)
            Model coordinates.

        Returns
        -------
        ndarray, shape (n, num_inputs)
        """
        J = self._set(q)
        plant, ctx, world = self.plant, self.context, self.plant.world_frame()
        cols = []
        for info in self.propellers:
            body = plant.get_body(info.body_index)
            X_WB = body.EvalPoseInWorld(ctx)
            Jv = plant.CalcJacobianSpatialVelocity(ctx, JacobianWrtVariable.kV, body.body_frame(),
                                                   info.X_BP.translation(), world, world)
            axis = X_WB.multiply(info.X_BP).rotation().col(2)
            moment = info.moment_ratio * axis
            if self.reaction_torque == "body_z":     # (5.123): (n · ẑ_B) ẑ_B, n · ẑ_B = R_BP[2, 2]
                moment = info.moment_ratio * info.X_BP.rotation().matrix()[2, 2] * X_WB.rotation().col(2)
            cols.append(Jv.T @ np.concatenate([moment, info.thrust_ratio * axis]))
        B_d = np.column_stack(cols + [self._B_actuators]) if cols else self._B_actuators
        return J.T @ B_d

    def hover_input(self, q: ArrayLike | None = None, *, lower: ArrayLike | None = None,
                    upper: ArrayLike | None = None) -> np.ndarray:
        """Inputs u₀ with B(q) u₀ = g(q) at rest (scipy's bounded least squares).

        Parameters
        ----------
        q : array_like, shape (n,), optional
            Configuration (default: level at the origin, other joints at zero).
        lower, upper : array_like, optional
            Bounds (default the model's ``input_lower``/``input_upper``).

        Returns
        -------
        ndarray, shape (num_inputs,)

        Raises
        ------
        ValueError
            The inputs cannot balance gravity at ``q`` (residual above rounding).
        """
        q = np.zeros(self.n) if q is None else check_vector("q", q, self.n)
        B, g = self.B(q), self.g(q)
        lo = self.input_lower if lower is None else np.asarray(lower, float)
        hi = self.input_upper if upper is None else np.asarray(upper, float)
        u = lsq_linear(B, g, bounds=(lo, hi), method="bvls", tol=1e-12).x
        residual = np.linalg.norm(B @ u - g)
        if residual > 1e-8 * max(1.0, np.linalg.norm(g)):
            raise ValueError(f"the inputs cannot hold {self.name} at q = {q}: ‖B u − g‖ = "
                             f"{residual:.3g} N at best within [{lo}, {hi}]")
        return u


MechanicalModel.floating_base_model = FloatingBaseModel    # from_plant's dispatch


def _upper(value, size):
    arr = np.asarray(np.broadcast_to(np.asarray(value, dtype=float), (size,)), dtype=float)
    if np.any(np.isnan(arr)):
        raise ValueError(f"command_upper must not contain NaN, got {arr}")
    return arr.copy()
