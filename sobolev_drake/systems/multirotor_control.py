"""Position and yaw tracking of any multirotor by the nonlinear W2/W∞ law, through its attitude
(thesis §5.2 partitions with the regulated group of §7.3.2), with bounded rotor allocation.

A multirotor whose rotors all push along its body z axis cannot make a lateral force at level
attitude: the rows x, y of B(q) vanish there, so x and y cannot be *controlled* DOF of the
input-coupling law (Assumption 6).  They are controlled through the attitude instead, with the
partition q = [ϕ θ ψ x y z] → controlled [ψ x y z] (integral action), regulated [ϕ θ]:

1. the controlled law (5.84) gives the desired accelerations of ψ, x, y, z, hence through
   u* = M q̈_des + C q̇ + g the world force F (rows x, y, z of u*) the rotors must produce;
2. the attitude whose thrust axis (body z) points along F at the current yaw gives the
   regulated references ϕ_d = asin(−f_y), θ_d = atan2(f_x, f_z) with f = Rz(ψ)ᵀ F/‖F‖
   (tilt limited to ``max_tilt``), tracked by the regulated law (7.81) with zero reference
   rates;
3. u* of the full q̈_des is allocated to the rotors by bounded least squares
   (:func:`~sobolev_drake.systems.rotor_allocation.allocate`, (7.84)–(7.86)) within the
   model's command bounds: the torque rows are met and the thrust is the projection of F on
   the body z axis (for rotors along body z the column space of B is the product of the
   torques and that axis).

Any number of rotors works (``B(q)`` has one column per rotor); the model is a
:class:`~sobolev_drake.models.floating_base.FloatingBaseModel` or the thesis
:class:`~sobolev_drake.models.quadrotor.QuadrotorModel` (same coordinate order).
"""

from __future__ import annotations

from typing import NoReturn

import numpy as np
from numpy.typing import ArrayLike
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import Context, ContinuousState, LeafSystem, ValueProducer

from sobolev_drake.models.base import check_vector
from sobolev_drake.systems.mechanical_law import MechanicalLaw
from sobolev_drake.systems.inner_laws import SobolevLaw
from sobolev_drake.systems.partition import Partition
from sobolev_drake.systems.rotor_allocation import allocate

__all__ = ["MULTIROTOR_PARTITION", "MultirotorLaw", "MultirotorController"]

#: q = [ϕ θ ψ x y z]: ψ, x, y, z tracked with integral action, roll and pitch regulated
MULTIROTOR_PARTITION = Partition(controlled=[2, 3, 4, 5], regulated=[0, 1])


class MultirotorLaw:
    """The three steps of the module docstring, as pure maths.

    Parameters
    ----------
    model : MechanicalModel
        Model with q = [ϕ θ ψ x y z] (and B(q) one column per rotor command).
    inner : SobolevLaw
        ``controlled`` gains of size 4 ([ψ x y z]) and ``regulated`` gains of size 2 ([ϕ θ]).
    lower, upper : array_like, optional
        Command bounds (default the model's ``input_lower``/``input_upper``, else 0 and +inf).
    max_tilt : float, default 0.6
        Largest attitude tilt asked of the regulated law (rad).
    """

    def __init__(self, model, inner, *, lower=None, upper=None, max_tilt: float = 0.6):
        if model.n != 6:
            raise ValueError(f"MultirotorLaw needs a 6-DOF model q = [ϕ θ ψ x y z], got n = {model.n}")
        if not isinstance(inner, SobolevLaw) or inner.regulated is None:
            raise TypeError("inner must be a SobolevLaw with controlled ([ψ x y z]) and regulated "
                            f"([ϕ θ]) gains, got {inner!r}")
        self.model = model
        self.law = MechanicalLaw(model, MULTIROTOR_PARTITION, inner, allocation=self._allocate)
        m = self.law.num_inputs
        # a model without input bounds (e.g. the thesis QuadrotorModel, inputs Ω²) gets [0, ∞)
        self.lower = check_vector("lower", np.asarray(getattr(model, "input_lower", np.zeros(m))
                                                      if lower is None else lower, float) * np.ones(m), m)
        up = np.asarray(getattr(model, "input_upper", np.full(m, np.inf)) if upper is None else upper,
                        float) * np.ones(m)
        if np.any(np.isnan(up)) or np.any(up < self.lower):
            raise ValueError(f"upper must be ≥ lower = {self.lower}, got {up}")
        self.upper = up
        self.max_tilt = float(max_tilt)
        if not 0.0 < self.max_tilt < 0.5 * np.pi:
            raise ValueError(f"max_tilt must be in (0, π/2) rad, got {max_tilt}")
        self.num_inputs, self.n = m, 6

    def _allocate(self, u_star, q, qdot):
        return allocate(self.law.dynamics.input_matrix(q), u_star, self.lower, self.upper)

    def attitude_reference(self, force: ArrayLike, psi: float) -> np.ndarray:
        """[ϕ_d, θ_d] pointing the body z axis along ``force`` at yaw ``psi`` (tilt limited).

        Parameters
        ----------
        force : array_like, shape (3,)
            World force the thrust must produce (N).
        psi : float
            Yaw (rad).

        Returns
        -------
        ndarray, shape (2,)
        """
        f = np.asarray(force, dtype=float)
        c, s = np.cos(psi), np.sin(psi)
        f = np.array([c * f[0] + s * f[1], -s * f[0] + c * f[1], f[2]])   # Rz(ψ)ᵀ F
        horizontal = np.hypot(f[0], f[1])
        if f[2] <= 0.0 or np.arctan2(horizontal, f[2]) > self.max_tilt:
            # thrust cannot point down or tilt beyond max_tilt: keep the direction, cap the tilt
            f = np.array([f[0] / max(horizontal, 1e-12) * np.sin(self.max_tilt),
                          f[1] / max(horizontal, 1e-12) * np.sin(self.max_tilt), np.cos(self.max_tilt)])
        f = f / np.linalg.norm(f)
        return np.array([np.arcsin(np.clip(-f[1], -1.0, 1.0)), np.arctan2(f[0], f[2])])

    @staticmethod
    def full_reference(reference: ArrayLike, attitude: ArrayLike) -> np.ndarray:
        """The MechanicalLaw reference of [ψ x y z ϕ θ] (values, rates, accelerations): the
        tracked reference and the attitude reference (zero rates).

        Parameters
        ----------
        reference : array_like, shape (12,)
            [q_r; q̇_r; q̈_r] of [ψ x y z].
        attitude : array_like, shape (2,)
            [ϕ_d θ_d].

        Returns
        -------
        ndarray, shape (18,)
        """
        r = check_vector("reference", reference, 12).reshape(3, 4)
        out = np.zeros((3, 6))
        out[:, :4] = r
        out[0, 4:] = attitude
        return out.ravel()

    def command(self, q: ArrayLike, qdot: ArrayLike, e_int: ArrayLike,
                reference: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(τ, u*, [ϕ_d θ_d]) at one state.

        Parameters
        ----------
        q, qdot : array_like, shape (6,)
            Model state.
        e_int : array_like, shape (4,)
            ∫(q_c − q_cr) of [ψ x y z].
        reference : array_like, shape (12,)
            [q_r; q̇_r; q̈_r] of [ψ x y z].

        Returns
        -------
        tau : ndarray, shape (num_inputs,)
        u_star : ndarray, shape (6,)
        attitude : ndarray, shape (2,)
        """
        q, qdot = check_vector("q", q, 6), check_vector("qdot", qdot, 6)
        # pass 1 without attitude error: only the force F of the translational rows matters
        first = self.law.generalized_input(q, qdot, e_int, self.full_reference(reference, q[:2]))
        attitude = self.attitude_reference(first[3:6], q[2])
        u_star = self.law.generalized_input(q, qdot, e_int, self.full_reference(reference, attitude))
        return self._allocate(u_star, q, qdot), u_star, attitude

    def integral_derivative(self, q: ArrayLike, reference: ArrayLike) -> np.ndarray:
        """d/dt ∫e = [ψ x y z] − their references.

        Parameters
        ----------
        q : array_like, shape (6,)
        reference : array_like, shape (12,)

        Returns
        -------
        ndarray, shape (4,)
        """
        return check_vector("q", q, 6)[2:6] - check_vector("reference", reference, 12)[:4]


class MultirotorController(LeafSystem):
    """:class:`MultirotorLaw` as a LeafSystem (continuous ∫e).

    .. pydrake_system::

        name: MultirotorController
        input_ports:
        - x
        - reference
        output_ports:
        - control
        - generalized_force
        - attitude_reference

    ``x`` = [q; q̇] of the model (e.g. from
    :class:`~sobolev_drake.systems.floating_state.FloatingBaseState`), ``reference`` = [q_r; q̇_r;
    q̈_r] of [ψ x y z] (a ``TrajectoryReference`` with those four names); ``control`` = rotor
    commands, ``generalized_force`` = u*, ``attitude_reference`` = [ϕ_d θ_d].

    Double only: ``ToAutoDiffXd()``/``ToSymbolic()`` raise — the bounded allocation and the
    tilt limit are not differentiable; linearize the plant at hover instead
    (``rigs.multirotor.linearize_hover``).

    Parameters
    ----------
    model, inner, lower, upper, max_tilt
        As for :class:`MultirotorLaw`.
    """

    def __init__(self, model, inner, *, lower=None, upper=None, max_tilt: float = 0.6):
        super().__init__()
        self.law = MultirotorLaw(model, inner, lower=lower, upper=upper, max_tilt=max_tilt)
        self.DeclareVectorInputPort("x", 12)
        self.DeclareVectorInputPort("reference", 12)
        self.DeclareContinuousState(4)
        # τ, u* and the attitude reference: one cache entry, computed once per context change
        self._command = self.DeclareCacheEntry(
            "command (tau, u*, attitude)",
            ValueProducer(allocate=lambda: AbstractValue.Make((None, None, None)),
                          calc=self._calc_command),
            {self.all_input_ports_ticket(), self.xc_ticket()})
        feed = {self._command.ticket()}
        for k, (name, size) in enumerate((("control", self.law.num_inputs),
                                          ("generalized_force", 6), ("attitude_reference", 2))):
            self.DeclareVectorOutputPort(name, size, lambda c, o, k=k: o.SetFromVector(
                self._command.Eval(c)[k]), feed)

    def _calc_command(self, context, value):
        x = self.get_input_port(0).Eval(context)
        e = context.get_continuous_state_vector().CopyToVector()
        value.set_value(self.law.command(x[:6], x[6:], e, self.get_input_port(1).Eval(context)))

    def DoCalcTimeDerivatives(self, context: Context, derivatives: ContinuousState) -> None:
        x = self.get_input_port(0).Eval(context)
        r = self.get_input_port(1).Eval(context)
        derivatives.get_mutable_vector().SetFromVector(self.law.integral_derivative(x[:6], r))

    def _refuse(self, scalar):
        return RuntimeError(f"MultirotorController does not convert to {scalar}: its bounded "
                            "allocation and tilt limit are not differentiable; linearize the plant "
                            "at hover (rigs.multirotor.linearize_hover) instead")

    def ToAutoDiffXd(self) -> NoReturn:
        """Refused (see the class docstring).

        Raises
        ------
        RuntimeError
            Always.
        """
        raise self._refuse("AutoDiffXd")

    def ToSymbolic(self) -> NoReturn:
        """Refused (see the class docstring).

        Raises
        ------
        RuntimeError
            Always.
        """
        raise self._refuse("Expression")

