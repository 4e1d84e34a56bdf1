"""Euler–Lagrange view of a MultibodyPlant in the thesis' generalized coordinates.

Drake's generalized coordinates are related to the thesis' by a constant invertible map
``q_drake = T q_thesis`` (a permutation for the flying bodies, a permutation with scales where a
model uses e.g. a prismatic axle ``x = r ϕ``).  Because the flying bodies use the x, y, z, yaw,
pitch, roll joint chain of docs/design.md §3, ``q̇ = v`` and Drake's

* ``CalcMassMatrix``                   is M(q),
* ``CalcBiasTerm``                     is C(q, q̇) q̇,
* ``CalcGravityGeneralizedForces``     is −g(q),

so the thesis' quantities are ``M_th = Tᵀ M T``, ``h_th = Tᵀ h`` and generalized forces map as
``τ_drake = T⁻ᵀ τ_th``.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike
from pydrake.multibody.plant import MultibodyPlant, PropellerInfo
from pydrake.multibody.tree import ForceElementIndex
from pydrake.systems.framework import Context

from sobolev_drake.models.plant_checks import check_context, check_plant, constraint_kinds

__all__ = ["check_vector", "MechanicalModel", "PlantModel"]


def check_vector(name: str, value: ArrayLike, size: int) -> np.ndarray:
    """Return ``value`` as a float vector of length ``size`` or raise a clear ``ValueError``.

    Rejects wrong sizes and non-finite entries (NaN/inf), naming the argument, and complex
    entries (``TypeError``).  Called at every integrator stage by the controllers: the common
    case is one shape test and one reduction.

    Parameters
    ----------
    name : str
        Argument name used in the error message.
    value : array_like
        The vector to check.
    size : int
        Required length.

    Returns
    -------
    ndarray, shape (size,)
        ``value`` as floats.
    """
    if getattr(value, "dtype", None) is not None and value.dtype.kind == "c":
        raise TypeError(f"{name} must be real, got complex entries")  # astype would drop .imag
    arr = np.asarray(value, dtype=float)
    if arr.shape == (size,) and np.isfinite(arr).all():
        return arr
    if arr.shape != (size,):
        raise ValueError(f"{name} must be a vector of length {size}, got shape {arr.shape}")
    raise ValueError(f"{name} must be finite, got {arr}")


class MechanicalModel:
    """M(q), C(q,q̇)q̇, g(q) and C(q,q̇)v of a MultibodyPlant in the thesis' coordinates.

    Parameters
    ----------
    plant : MultibodyPlant
        Finalized, double-valued plant whose q̇ = v.
    coordinate_map : array_like, shape (n, n), optional
        Invertible matrix T with ``q_drake = T q_thesis`` (default identity).
    dof_names : sequence of str, optional
        Thesis names of the generalized coordinates, in thesis order (default q0, q1, ...).
    name : str, default "model"
        Human-readable model name.

    Notes
    -----
    All public methods take and return thesis-ordered vectors.  One private context is reused,
    so instances are cheap to query but not thread-safe.
    """

    def __init__(self, plant: MultibodyPlant, *, coordinate_map=None, dof_names=None, name="model"):
        check_plant(plant)
        if plant.num_positions() != plant.num_velocities():
            raise ValueError("MechanicalModel needs q̇ = v (no quaternion floating base); "
                             f"got nq = {plant.num_positions()}, nv = {plant.num_velocities()}")
        self.plant = plant
        self.name = name
        self.n = plant.num_positions()
        T = np.eye(self.n) if coordinate_map is None else np.asarray(coordinate_map, dtype=float)
        if T.shape != (self.n, self.n) or abs(np.linalg.det(T)) < 1e-12:
            raise ValueError(f"coordinate_map must be an invertible {self.n}x{self.n} matrix")
        self.T = T
        self.T_inv = np.linalg.inv(T)
        self.dof_names = list(dof_names) if dof_names is not None else [f"q{i}" for i in range(self.n)]
        if len(self.dof_names) != self.n:
            raise ValueError(f"dof_names must have {self.n} entries, got {len(self.dof_names)}")
        self.context = plant.CreateDefaultContext()
        if type(self).friction is MechanicalModel.friction:
            for index in plant.GetJointIndices():
                joint = plant.get_joint(index)
                if joint.num_velocities() and np.any(joint.GetDampingVector(self.context)):
                    raise ValueError(
                        f"joint {joint.name()!r} has damping {joint.GetDampingVector(self.context)}"
                        f", which {type(self).__name__} would ignore: override friction(q̇) to "
                        "include it, or use MechanicalModel.from_plant(plant), which does")

    # --- coordinate maps -------------------------------------------------------------------
    def to_drake(self, q_thesis: ArrayLike) -> np.ndarray:
        """Thesis-ordered coordinates (or velocities) → Drake's.

        Parameters
        ----------
        q_thesis : array_like, shape (n,)
            Coordinates or velocities in thesis order.

        Returns
        -------
        ndarray, shape (n,)
            T q_thesis.
        """
        return self.T @ np.asarray(q_thesis, dtype=float)

    def to_thesis(self, q_drake: ArrayLike) -> np.ndarray:
        """Drake-ordered coordinates (or velocities) → thesis order.

        Parameters
        ----------
        q_drake : array_like, shape (n,)
            Coordinates or velocities in Drake's order.

        Returns
        -------
        ndarray, shape (n,)
            T⁻¹ q_drake.
        """
        return self.T_inv @ np.asarray(q_drake, dtype=float)

    def force_to_drake(self, tau_thesis: ArrayLike) -> np.ndarray:
        """Thesis generalized force → Drake generalized force (τ_d = T⁻ᵀ τ_th).

        Parameters
        ----------
        tau_thesis : array_like, shape (n,)
            Generalized force in thesis coordinates.

        Returns
        -------
        ndarray, shape (n,)
            τ_d.
        """
        return self.T_inv.T @ np.asarray(tau_thesis, dtype=float)

    def force_to_thesis(self, tau_drake: ArrayLike) -> np.ndarray:
        """Drake generalized force → thesis generalized force (τ_th = Tᵀ τ_d).

        Parameters
        ----------
        tau_drake : array_like, shape (n,)
            Generalized force in Drake's coordinates.

        Returns
        -------
        ndarray, shape (n,)
            τ_th.
        """
        return self.T.T @ np.asarray(tau_drake, dtype=float)

    def _set(self, q, qdot=None):
        q = check_vector("q", q, self.n)
        self.plant.SetPositions(self.context, self.T @ q)
        if qdot is not None:
            qdot = check_vector("qdot", qdot, self.n)
            self.plant.SetVelocities(self.context, self.T @ qdot)

    # --- Euler–Lagrange terms ----------------------------------------------------------------
    def M(self, q: ArrayLike) -> np.ndarray:
        """Inertia matrix M(q) (thesis order).

        Parameters
        ----------
        q : array_like, shape (n,)
            Generalized coordinates, thesis order.

        Returns
        -------
        ndarray, shape (n, n)
            M(q) = Tᵀ M_drake T.
        """
        self._set(q)
        return self.T.T @ self.plant.CalcMassMatrix(self.context) @ self.T

    def Cqdot(self, q: ArrayLike, qdot: ArrayLike) -> np.ndarray:
        """Coriolis/centripetal vector C(q, q̇) q̇ (Drake's bias term).

        Parameters
        ----------
        q, qdot : array_like, shape (n,)
            Generalized coordinates and velocities, thesis order.

        Returns
        -------
        ndarray, shape (n,)
            C(q, q̇) q̇, thesis order.
        """
        self._set(q, qdot)
        return self.T.T @ self.plant.CalcBiasTerm(self.context)

    def g(self, q: ArrayLike) -> np.ndarray:
        """Gravity vector g(q) as in M q̈ + C q̇ + g = τ (i.e. minus Drake's gravity forces).

        Parameters
        ----------
        q : array_like, shape (n,)
            Generalized coordinates, thesis order.

        Returns
        -------
        ndarray, shape (n,)
            g(q), thesis order.
        """
        self._set(q)
        return -self.T.T @ self.plant.CalcGravityGeneralizedForces(self.context)

    def C_times(self, q: ArrayLike, qdot: ArrayLike, v: ArrayLike) -> np.ndarray:
        """C(q, q̇) v for any v by polarization (docs/design.md §3).

        With Christoffel symbols (a, b) ↦ C(q, a) b is symmetric bilinear, hence
        C(q, q̇) v = ¼ [c(q̇ + v) − c(q̇ − v)] with c(a) = C(q, a) a.

        Parameters
        ----------
        q, qdot : array_like, shape (n,)
            Generalized coordinates and velocities, thesis order.
        v : array_like, shape (n,)
            The vector multiplied by C(q, q̇).

        Returns
        -------
        ndarray, shape (n,)
            C(q, q̇) v, thesis order.
        """
        qdot = check_vector("qdot", qdot, self.n)
        v = check_vector("v", v, self.n)
        return 0.25 * (self.Cqdot(q, qdot + v) - self.Cqdot(q, qdot - v))

    def B(self, q: ArrayLike) -> np.ndarray:
        """Input matrix B(q) (thesis order, columns = actuator inputs). Overridden per model.

        The base class raises ``NotImplementedError``.

        Parameters
        ----------
        q : array_like, shape (n,)
            Generalized coordinates, thesis order.

        Returns
        -------
        ndarray, shape (n, number of inputs)
            B(q).
        """
        raise NotImplementedError(f"{self.name} does not define an input matrix")

    #: True when K(q̇) ≡ 0, so per-sample paths may skip adding it (a model overriding
    #: :meth:`friction` with a non-zero K must leave this False).
    frictionless: bool = False

    def friction(self, qdot: ArrayLike) -> np.ndarray:
        """Velocity-dependent generalized friction K(q̇) (thesis order, on the left-hand side of
        M q̈ + C q̇ + K(q̇) + g = B u + w, cf. (4.30)).  Zero unless a model overrides it.

        Parameters
        ----------
        qdot : array_like, shape (n,)
            Generalized velocities, thesis order.

        Returns
        -------
        ndarray, shape (n,)
            K(q̇) (zeros here).
        """
        check_vector("qdot", qdot, self.n)
        return np.zeros(self.n)

    #: the model class of floating-base plants, registered by models.floating_base (which
    #: imports this module, so it cannot be imported here)
    floating_base_model = None

    @classmethod
    def from_plant(cls, plant: MultibodyPlant, *, context: Context | None = None,
                   name: str | None = None, propellers: Sequence[PropellerInfo] | None = None,
                   **floating: ArrayLike | str | None) -> MechanicalModel:
        """A model of any finalized ``MultibodyPlant`` (continuous or discrete).

        Without a floating base: a :class:`PlantModel` in Drake's coordinates (q_thesis =
        q_drake, so the plant's state port is the controller's ``x`` and its actuation port
        takes the controller's ``u``).  With a quaternion or roll-pitch-yaw floating joint, or
        ``propellers``: a :class:`~sobolev_drake.models.floating_base.FloatingBaseModel` in
        Euler-angle coordinates [ϕ θ ψ x y z …] whose inputs are the propeller commands (its
        state comes from the plant's state port through
        :class:`~sobolev_drake.systems.floating_state.FloatingBaseState`).

        Parameters
        ----------
        plant : MultibodyPlant
            Finalized, double-valued plant: joints with q̇ = v (revolute, prismatic, planar,
            weld, universal) and at most one quaternion or roll-pitch-yaw floating joint, no
            constraints; parsed or built in code.
        context : Context, optional
            A context of ``plant`` whose parameters (masses, damping, reflected inertias) the
            model uses, the plant's defaults when omitted: ``plant.CreateDefaultContext()`` or,
            in a diagram, ``plant.GetMyContextFromRoot(diagram_context)``.  Copied, never
            modified.
        name : str, optional
            Model name for messages (default: the name(s) of the model instance(s) holding the
            actuated joints, or the floating body).
        propellers : sequence of PropellerInfo, optional
            The propellers of the Drake ``Propeller`` system driving a floating base, in its
            command order (they become the first columns of B(q)).
        **floating
            ``command_lower``, ``command_upper``, ``max_pitch``, ``reaction_torque`` of
            ``FloatingBaseModel``.

        Returns
        -------
        PlantModel or FloatingBaseModel

        Raises
        ------
        TypeError
            ``plant`` is not a double ``MultibodyPlant``, ``context`` not a double ``Context``.
        ValueError
            ``plant`` is not finalized, has no inputs, constraints or an element the model
            cannot represent (see :class:`PlantModel`); ``context`` is another system's.
        """
        check_plant(plant)
        kinds = {plant.get_joint(i).type_name() for i in plant.GetJointIndices()}
        if propellers is not None or kinds & {"quaternion_floating", "rpy_floating"}:
            return cls.floating_base_model(plant, propellers=propellers, context=context,
                                           name=name, **floating)
        if floating:
            raise TypeError(f"from_plant got {sorted(floating)}, which only a floating-base "
                            "plant (or propellers=) takes")
        return PlantModel(plant, context=context, name=name)


#: force elements whose generalized forces the model represents (gravity is g(q))
_SUPPORTED_FORCE_ELEMENTS = ("UniformGravityFieldElement",)


class PlantModel(MechanicalModel):
    """:class:`MechanicalModel` of an arbitrary MultibodyPlant, built by
    :meth:`MechanicalModel.from_plant`.

    What the plant's equations contain and where it is in the model:

    * M(q) — ``CalcMassMatrix``, which includes the reflected (rotor) inertia of joint actuators;
    * C(q, q̇) q̇ and g(q) — the bias term and the uniform gravity field;
    * joint damping — Drake applies τ = −d v per joint; here it is the friction term
      K(q̇) = D q̇ of (4.30), D = diag(d) read from the context at construction;
    * B — ``MakeActuationMatrix()`` (columns in actuator order, i.e. the order of the plant's
      actuation input port); constant in q.

    Refused with a ``ValueError`` naming the element: force elements other than gravity
    (springs, bushings, custom ones: subclass :class:`MechanicalModel` and put them in
    ``g``/``friction``), joints whose q̇ ≠ v (ball joints; floating bases go to
    :class:`~sobolev_drake.models.floating_base.FloatingBaseModel`), constraints (couplers, e.g. from a URDF ``<mimic>``, and
    distance, ball and weld constraints: their forces are not in M q̈ + C q̇ + g = B u), a plant
    without joint actuators (B would have no columns) and actuators with Drake's implicit PD
    control.  Contact, joint limits and effort limits are not part of M q̈ + C q̇ + g = B u;
    the effort limits are available as ``input_lower``/``input_upper`` for a controller's
    ``lower``/``upper``.

    Parameters
    ----------
    plant, context, name
        As in :meth:`MechanicalModel.from_plant`.
    """

    def __init__(self, plant: MultibodyPlant, *, context=None, name=None):
        check_plant(plant)
        _refuse_unsupported(plant)
        if context is not None:
            check_context(plant, context)
        if name is None:   # the model instance(s) holding the actuated joints
            instances = sorted({plant.get_joint_actuator(a).joint().model_instance()
                                for a in plant.GetJointActuatorIndices()}, key=int)
            name = " + ".join(plant.GetModelInstanceName(i) for i in instances)
        names = plant.GetPositionNames(add_model_instance_prefix=False, always_add_suffix=False)
        super().__init__(plant, dof_names=names, name=name)
        if context is not None:     # copied: Clone() refuses a plant's context in a diagram
            self.context.SetTimeStateAndParametersFrom(context)
        damping = np.zeros(self.n)
        for index in plant.GetJointIndices():
            joint = plant.get_joint(index)
            if joint.num_velocities():
                start = joint.velocity_start()
                damping[start:start + joint.num_velocities()] = joint.GetDampingVector(self.context)
                # the law adds D q̇ itself; zeroed here so Drake's force-element pass (the
                # recursive inverse dynamics) does not count it twice
                joint.SetDampingVector(self.context, np.zeros(joint.num_velocities()))
        if np.any(damping < 0):
            raise ValueError(f"joint damping must be >= 0, got {damping}")
        self.damping = damping
        self.frictionless = not np.any(damping)
        self._B = plant.MakeActuationMatrix()
        self.num_inputs = self._B.shape[1]
        self.input_upper = np.array([plant.get_joint_actuator(i).effort_limit()
                                     for i in plant.GetJointActuatorIndices()], dtype=float)
        self.input_lower = -self.input_upper

    def B(self, q: ArrayLike) -> np.ndarray:
        """Actuation matrix (n × number of actuators), constant in q.

        Parameters
        ----------
        q : array_like, shape (n,)
            Generalized coordinates (checked only).

        Returns
        -------
        ndarray, shape (n, num_inputs)
            A copy of the plant's ``MakeActuationMatrix()``.
        """
        check_vector("q", q, self.n)
        return self._B.copy()

    def friction(self, qdot: ArrayLike) -> np.ndarray:
        """Joint damping D q̇ (Drake's τ = −d v, moved to the left-hand side).

        Parameters
        ----------
        qdot : array_like, shape (n,)
            Generalized velocities.

        Returns
        -------
        ndarray, shape (n,)
            K(q̇) = D q̇, D = diag(joint damping).
        """
        return self.damping * check_vector("qdot", qdot, self.n)


def _refuse_unsupported(plant: MultibodyPlant) -> None:
    """ValueError naming the first joint, force element, constraint, actuator (or none) refused."""
    for index in plant.GetJointIndices():
        joint = plant.get_joint(index)
        if joint.num_positions() != joint.num_velocities():
            raise ValueError(
                f"joint {joint.name()!r} ({joint.type_name()}) has {joint.num_positions()} "
                f"positions and {joint.num_velocities()} velocities; the Euler–Lagrange model "
                "needs q̇ = v (only a quaternion or roll-pitch-yaw floating base is converted)")
    context = plant.CreateDefaultContext()
    rng = np.random.default_rng(0)
    q = rng.uniform(-1.0, 1.0, plant.num_positions())
    plant.SetPositions(context, q)
    v = rng.uniform(-1.0, 1.0, plant.num_velocities())
    qdot = plant.MapVelocityToQDot(context, v)
    for index in plant.GetJointIndices():
        joint = plant.get_joint(index)
        s, m = joint.position_start(), joint.num_positions()
        # the map is exact for joints with q̇ = v, so any difference is structural
        if m and not np.allclose(qdot[s:s + m], v[joint.velocity_start():joint.velocity_start() + m],
                                 rtol=0.0, atol=1e-12):
            raise ValueError(
                f"joint {joint.name()!r} ({joint.type_name()}) has q̇ ≠ v (its velocities are "
                "not the time derivatives of its positions); the Euler–Lagrange model needs "
                "q̇ = v: use revolute/prismatic joint chains instead")
    for i in range(plant.num_force_elements()):
        element = plant.get_force_element(ForceElementIndex(i))
        kind = type(element).__name__
        if kind not in _SUPPORTED_FORCE_ELEMENTS:
            raise ValueError(
                f"force element {i} ({kind}) is not represented by from_plant (supported: "
                f"{', '.join(_SUPPORTED_FORCE_ELEMENTS)} and joint damping); subclass "
                "MechanicalModel and add its generalized force to g(q) or friction(q̇)")
    if plant.num_constraints():
        raise ValueError(
            f"plant has {plant.num_constraints()} constraint(s) ({constraint_kinds(plant)}); "
            "from_plant models M q̈ + C q̇ + g = B u without constraint forces: build the plant "
            "without them (remove the URDF <mimic> tags and the plant.Add*Constraint calls; a "
            "weld constraint can become plant.WeldFrames), or write the constrained mechanism "
            "in independent coordinates as a MechanicalModel subclass")
    if plant.num_actuators() == 0:
        raise ValueError(
            "plant has no joint actuators (num_actuators() = 0), so the model would have no "
            "inputs (B is n × 0): add actuators before plant.Finalize(), with "
            "plant.AddJointActuator(name, joint) in code or a <transmission> per actuated joint "
            "in a URDF (SDFormat gives a joint one unless its <axis><limit><effort> is 0); "
            "thrusters (pydrake's Propeller) need a floating base and from_plant(propellers=)")
    for index in plant.GetJointActuatorIndices():
        actuator = plant.get_joint_actuator(index)
        if actuator.has_controller():
            raise ValueError(
                f"actuator {actuator.name()!r} has Drake's implicit PD controller, so the "
                "actuation port does not carry torques; build the plant without PD gains")
