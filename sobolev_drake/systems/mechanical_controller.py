"""Nonlinear W2/W∞ and classic H∞ controllers for Euler–Lagrange plants (thesis ch. 5 and 7.3.2).

Two layers:

* :class:`MechanicalLaw` — pure numpy/Drake-model maths, no LeafSystem.  Given the plant
  *model* (a :class:`~sobolev_drake.models.base.MechanicalModel`, usually a separate instance
  from the simulated truth), a :class:`Partition` of the DOF and an inner law
  (:class:`SobolevLaw` or :class:`HinfLaw`), it computes from ``(q, q̇, ∫e, reference)``:

  - ``desired_acceleration(...)``  q̈_des (thesis order, size n): q̈_r − K[ė; e; ∫e] on the
    controlled DOF (5.26)/(5.84), q̈_r − K[ė; e] on the regulated DOF (7.81),
    −Υ1⁻¹U q̇s on the stabilized DOF (5.84);
  - ``generalized_input(..., extra=None)`` u* = M q̈_des + C q̇ + g (+ friction) − extra
    ((5.73)/(5.84); pass ``extra = ϑ_passive(q, q̇, ζ)`` for the tilt-rotor law (7.81));
    for the classic H∞ law the Chen–Lee–Feng force of docs/design.md §4.3;
  - ``actuation(...)`` τ: B⁻¹u* (fully actuated, (5.26)), B̄⁻¹(M̄ q̈c_des + h̄) (reduced model
    (5.5)), B†u* (input coupling, (5.100)/(5.118)) or a user ``allocation(u_star, q, qdot)``
    callable (e.g. the tilt-rotor's bounded least squares (7.84)); optional actuator bounds
    are enforced by bounded least squares (``systems.bounded_ls``; scipy's BVLS when a bound is
    infinite).
  - ``integral_derivative(q, reference)`` = q_c − q_cr, the time derivative of ∫e.

  Another controller (e.g. the tilt-rotor's) can therefore reuse the law without this module's
  LeafSystem::

      law = MechanicalLaw(model, Partition(controlled=[5, 6, 7], regulated=[4, 0, 1],
                                           stabilized=[2, 3]),
                          SobolevLaw(controlled=controlled_gains(...),
                                     regulated=regulated_gains(...),
                                     stabilized=stabilized_gains(...)))
      u_star = law.generalized_input(q, qdot, e_int, reference, extra=theta_passive)

* :class:`MechanicalController` — a LeafSystem wrapping a law, with the ports of Drake's
  controllers (:mod:`.controller_ports`): ``estimated_state`` [q; q̇] (thesis order),
  ``desired_state`` + ``desired_acceleration`` or ``reference`` ([q_r; q̇_r; q̈_r] of the
  *tracked* DOF, ``partition.tracked`` = controlled DOF followed by regulated DOF); outputs
  ``control`` (actuator command), ``generalized_force`` (u*, or the reduced force B̄τ) and
  ``error_integral``.  Continuous (∫q̃c a continuous state) or sampled (``period``).

Drake-native behaviour of the LeafSystem:

* everything an output depends on is in the Context: ∫q̃c (continuous or discrete state), the
  held command of the sampled form (discrete state) and the law itself, an abstract parameter
  (:meth:`MechanicalController.set_inner` writes it into one context; two contexts are
  independent; :meth:`MechanicalController.law_of` reads it).  u and u* are one cache entry
  computed once per context change;
* scalar conversion (``ToAutoDiffXd``, ``ToSymbolic``; Drake's ``Linearize``): the converted
  system hands arrays of its scalar type to the law, which evaluates them with the generic
  law of :mod:`.scalar_law` on the model's :class:`~sobolev_drake.models.scalar_terms.
  ScalarTerms`; the double system keeps the fast paths.  Not differentiable: an active
  actuator bound (see :mod:`.scalar_law`);
* ``period`` = h > 0 gives a sampled controller: at t_k = k h it reads the inputs, holds
  u(t_k) until t_{k+1} and integrates ∫q̃c by forward Euler, ∫_{k+1} = ∫_k + h (q_c − q_cr)(t_k).
  Its first command is computed by an initialization event from the initial state (no
  hold-at-zero start as with a ``ZeroOrderHold`` in front of a continuous controller); with
  ``computation_delay=True`` the command computed at t_k is applied from t_{k+1} (the first
  sample period applies the initial command).  ``Simulator.Initialize`` runs the event (or
  ``system.ExecuteInitializationEvents(context)`` outside a simulator); before it the held
  command is the default discrete state, zero.  On a discrete plant updated at the same
  instants, the plant's step at t_k uses the command held before the controller's update at
  t_k (Drake's simultaneous discrete updates), i.e. one sample of delay comes with the
  plant.

Reference order: ``partition.tracked`` (controlled then regulated, in the order given).
"""

from __future__ import annotations

import inspect

import numpy as np
from numpy.typing import ArrayLike
from pydrake.common.value import AbstractValue
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import (BasicVector_, Context, ContinuousState, LeafSystem_,
                                       ValueProducer)
from pydrake.systems.scalar_conversion import TemplateSystem

from sobolev_drake.models.base import MechanicalModel, check_vector
from sobolev_drake.systems.controller_ports import DropInPorts
from sobolev_drake.systems.mechanical_law import HinfLaw, MechanicalLaw, SobolevLaw
from sobolev_drake.systems.mechanical_sample import FloatSample
from sobolev_drake.systems.partition import Partition
from sobolev_drake.validation import real_scalar

__all__ = ["Partition", "SobolevLaw", "HinfLaw", "MechanicalLaw", "MechanicalController",
           "MechanicalController_"]

_P = inspect.Parameter
_SIGNATURE = inspect.Signature(
    [_P(name, _P.POSITIONAL_OR_KEYWORD, default=None) for name in ("model", "partition", "inner")]
    + [_P(name, _P.KEYWORD_ONLY, default=None) for name in (
        "law", "allocation", "lower", "upper", "initial_integral", "operating_points", "period")]
    + [_P("computation_delay", _P.KEYWORD_ONLY, default=False)])


class _Shared:
    """A law held in a context.  pydrake deep-copies a Python parameter value whenever Drake
    clones it (new contexts, ``Clone``, scalar conversion of a context); a law is never
    mutated (:meth:`MechanicalLaw.with_inner` makes a new one), so the copies share it, and
    with it the model's plant and context."""

    __slots__ = ("law", "_float")

    def __init__(self, law):
        self.law = law
        self._float = False          # not built yet (None: the law has no float path)

    def float_sample(self):
        """The law's :class:`FloatSample` (built at the first double evaluation), or None."""
        if self._float is False:
            self._float = FloatSample.of(self.law)
        return self._float

    def __deepcopy__(self, memo):
        return self


@TemplateSystem.define("MechanicalController_")
def MechanicalController_(T):
    """The controller for scalar type ``T`` (``MechanicalController_[AutoDiffXd]``, ...)."""

    class Impl(DropInPorts, LeafSystem_[T]):
        """LeafSystem around a :class:`MechanicalLaw` (module docstring).

        .. pydrake_system::

            name: MechanicalController
            input_ports:
            - estimated_state
            - desired_state
            - desired_acceleration (optional)
            - reference (optional)
            - x (optional)
            output_ports:
            - control
            - generalized_force
            - error_integral
            - actuation
            - u

        Inputs: ``estimated_state`` [q; q̇] and either ``desired_state`` [q_r; q̇_r] (with
        ``desired_acceleration`` q̈_r, zero if unconnected) or ``reference`` [q_r; q̇_r; q̈_r]
        (:mod:`.controller_ports`; ``x`` is the former name of ``estimated_state``).  Outputs:
        ``control`` the actuator command τ (``actuation``, the name in Drake's
        ``InverseDynamicsController``, and ``u``, the former name, are the same port),
        ``generalized_force`` u* (reduced mode: B̄τ), ``error_integral`` ∫q̃c.  Continuous:
        every output but ``error_integral`` feeds the inputs through; sampled: no output does.

        Give either ``model``, ``partition`` and ``inner`` (and optionally ``allocation``,
        ``lower``, ``upper``, ``operating_points``) or ``law=`` a ready MechanicalLaw.  For a
        MultibodyPlant, :meth:`from_plant` builds the controller that replaces Drake's
        ``InverseDynamicsController`` in one line.

        Parameters
        ----------
        model : MechanicalModel, optional
            See :class:`MechanicalLaw`.
        partition : Partition, optional
            See :class:`MechanicalLaw`.
        inner : SobolevLaw or HinfLaw, optional
            The inner law (``law`` of :class:`MechanicalLaw`).
        law : MechanicalLaw, optional
            A ready law; the other law arguments are then ignored.
        allocation, lower, upper, operating_points
            See :class:`MechanicalLaw`.
        initial_integral : array_like, shape (n_c,), optional
            Default ∫q̃c(0) (zero by default).
        period : float, optional
            Sampling period h (s) of a sampled controller; None (default): continuous.
        computation_delay : bool, default False
            Sampled only: apply the command computed at t_k from t_{k+1}.

        Attributes
        ----------
        law : MechanicalLaw
            The law of a new context (the constructor's); a context's own law is
            :meth:`law_of` it.
        period : float or None
            The sampling period, None when continuous.

        Examples
        --------
        Drake's pendulum (its URDF ships with Drake) driven to θ = 1 rad by the W2 law, in
        place of an ``InverseDynamicsController``:

        >>> import numpy as np
        >>> import sobolev_drake as sd
        >>> from pydrake.all import DiagramBuilder, FindResourceOrThrow, MultibodyPlant, Parser
        >>> builder = DiagramBuilder()
        >>> plant = builder.AddSystem(MultibodyPlant(0.0))
        >>> _ = Parser(plant).AddModels(FindResourceOrThrow("drake/examples/pendulum/Pendulum.urdf"))
        >>> plant.Finalize()
        >>> model = sd.MechanicalModel.from_plant(plant)      # M(q), C(q, q̇)q̇, g(q), B
        >>> model.dof_names, np.round(model.M([0.0]), 3), np.round(model.g([np.pi / 2]), 3)
        (['theta'], array([[0.25]]), array([4.905]))
        >>> law = sd.SobolevLaw(controlled=sd.controlled_gains(100.0, 50.0, 5.0, 1.0))
        >>> controller = builder.AddSystem(sd.MechanicalController.from_plant(plant, law))
        >>> step = sd.PiecewiseTrajectory(["theta"], [[sd.const(1.0)]])
        >>> reference = builder.AddSystem(sd.TrajectoryReference(step))
        >>> builder.Connect(plant.get_state_output_port(), controller.GetInputPort("estimated_state"))
        >>> builder.Connect(reference.GetOutputPort("reference"), controller.GetInputPort("reference"))
        >>> builder.Connect(controller.GetOutputPort("control"), plant.get_actuation_input_port())
        >>> diagram = builder.Build()
        >>> context = diagram.CreateDefaultContext()
        >>> _ = sd.simulate(diagram, context, 5.0, progress=False)
        >>> theta = plant.GetPositions(plant.GetMyContextFromRoot(context))[0]
        >>> bool(abs(theta - 1.0) < 0.01)
        True
        """

        def _construct(self, model=None, partition=None, inner=None, *, law=None,
                       allocation=None, lower=None, upper=None, initial_integral=None,
                       operating_points=None, period=None, computation_delay=False,
                       converter=None):
            LeafSystem_[T].__init__(self, converter)
            if law is None:
                if model is None or partition is None or inner is None:
                    raise ValueError("give either law= or (model, partition, inner)")
                law = MechanicalLaw(model, partition, inner, allocation=allocation, lower=lower,
                                    upper=upper, operating_points=operating_points)
            elif not isinstance(law, MechanicalLaw):
                raise TypeError(f"law must be a MechanicalLaw (or pass model, partition, "
                                f"inner), got {type(law).__name__}")
            if period is not None:
                period = real_scalar("period", period, low=0.0, low_open=True)
            if not isinstance(computation_delay, (bool, np.bool_)):
                raise TypeError(f"computation_delay must be a bool, got {computation_delay!r}")
            if computation_delay and period is None:
                raise ValueError("computation_delay=True needs a period (a sampled controller)")
            self.law, self.period = law, period
            self.computation_delay = bool(computation_delay)
            n, nc = law.n, law.nc
            self._x0 = (np.zeros(nc) if initial_integral is None
                        else check_vector("initial_integral", initial_integral, nc))
            self.declare_tracking_ports(n, law.n_ref)
            self._zero_acc = np.zeros(law.n_ref)
            self._law_index = self.DeclareAbstractParameter(AbstractValue.Make(_Shared(law)))
            self._n_gen = nc if law.partition.mode == "reduced" else n
            if period is None:
                self.DeclareContinuousState(BasicVector_[T](self._x0.tolist()))
                state_ticket = self.xc_ticket()
            else:
                # ∫q̃c, then τ and u* held (and pending, with a computation delay): the outputs
                # are state output ports, copied by Drake without a Python callback
                groups = [self.DeclareDiscreteState(BasicVector_[T](self._x0.tolist()))]
                for _ in range(2 if computation_delay else 1):
                    groups += [self.DeclareDiscreteState(law.num_inputs),
                               self.DeclareDiscreteState(self._n_gen)]
                self.DeclareInitializationDiscreteUpdateEvent(self._initialize)
                self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._sample)
                state_ticket = self.discrete_state_ticket(groups[0])
            self._outputs = self.DeclareCacheEntry(
                "law outputs (u*, tau)",
                ValueProducer(allocate=lambda: AbstractValue.Make((None, None, None)),
                              calc=self._calc_outputs),
                {self.all_input_ports_ticket(), state_ticket, self.all_parameters_ticket()})
            if period is None:
                feed = {self._outputs.ticket()}
                self.DeclareVectorOutputPort("control", law.num_inputs, self._calc_control, feed)
                self.DeclareVectorOutputPort("generalized_force", self._n_gen, self._calc_gen,
                                             feed)
                self.DeclareVectorOutputPort("error_integral", nc, self._calc_int, {state_ticket})
                for alias in ("actuation", "u"):     # InverseDynamicsController's, the former
                    self.DeclareVectorOutputPort(alias, law.num_inputs, self._calc_control, feed)
            else:
                self.DeclareStateOutputPort("control", groups[1])
                self.DeclareStateOutputPort("generalized_force", groups[2])
                self.DeclareStateOutputPort("error_integral", groups[0])
                for alias in ("actuation", "u"):
                    self.DeclareStateOutputPort(alias, groups[1])

        def _construct_copy(self, other, converter=None):
            Impl._construct(self, law=other.law, initial_integral=other._x0,
                            period=other.period, computation_delay=other.computation_delay,
                            converter=converter)

        @classmethod
        def from_plant(cls, plant: MultibodyPlant, inner: SobolevLaw | HinfLaw, *,
                       context: Context | None = None, lower: ArrayLike | None = None,
                       upper: ArrayLike | None = None,
                       period: float | None = None,
                       computation_delay: bool = False) -> MechanicalController:
            """The controller of a fully actuated MultibodyPlant, every DOF controlled: the
            one-line replacement of ``InverseDynamicsController(plant, kp, ki, kd, ...)``.

            The model is ``MechanicalModel.from_plant(plant, context=context)`` (Drake's
            coordinate order, so ``estimated_state`` takes the plant's state and
            ``desired_state`` [q_d; v_d] as Drake's controller does).  With
            ``controlled_gains`` of diagonal weights, K = [K_d, K_p, K_i] are the gains of the
            inverse-dynamics PID law q̈_d + K_p(q_d − q) + K_d(v_d − v) + K_i∫(q_d − q).

            Parameters
            ----------
            plant : MultibodyPlant
                Finalized double plant whose actuation matrix is square and invertible.
            inner : SobolevLaw or HinfLaw
                Gains of size ``plant.num_positions()``.
            context : Context, optional
                Plant context with the parameters to use (see ``MechanicalModel.from_plant``).
            lower, upper : array_like, optional
                Actuator bounds (e.g. the model's ``input_lower``/``input_upper``).
            period : float, optional
                Sampling period (s); None: continuous.
            computation_delay : bool, default False
                See the class.

            Returns
            -------
            MechanicalController
            """
            model = MechanicalModel.from_plant(plant, context=context)
            return cls(model, Partition(controlled=range(model.n)), inner, lower=lower,
                       upper=upper, period=period, computation_delay=computation_delay)

        # --- the law in the context --------------------------------------------------------
        def _my_context(self, context):
            try:
                self.ValidateContext(context)
                return context
            except RuntimeError:
                return self.GetMyMutableContextFromRoot(context)

        def law_of(self, context: Context) -> MechanicalLaw:
            """The law a context evaluates (the constructor's unless :meth:`set_inner` changed
            it there).

            Parameters
            ----------
            context : Context
                This system's context or a root context holding it.

            Returns
            -------
            MechanicalLaw
            """
            return self._my_context(context).get_abstract_parameter(self._law_index).get_value().law

        def set_inner(self, inner: SobolevLaw | HinfLaw, context: Context | None = None) -> None:
            """Swap the inner law in one context (same model, partition, allocation and
            bounds), so one diagram serves a tuning sweep (Python LeafSystems are not
            garbage-collected in drake 1.51).

            The law is a parameter of the context: the outputs of that context follow at once
            (Drake invalidates what depends on it), other contexts keep theirs, and a new
            context starts with the constructor's law.  Reset time and state before the next
            run; a sampled controller applies the new law from its next sample (or from
            re-initialization).

            Parameters
            ----------
            inner : SobolevLaw or HinfLaw
                The new inner law (gain sizes as the partition's).
            context : Context
                This system's context or a root context holding it (required).
            """
            if context is None:
                raise TypeError(
                    "set_inner(inner, context): the law is a parameter of the context since "
                    "#31; pass the context to change (the root context, e.g. "
                    "simulator.get_mutable_context(), or the controller's), got context=None")
            own = self._my_context(context)
            law = own.get_abstract_parameter(self._law_index).get_value().law
            own.get_mutable_abstract_parameter(self._law_index).set_value(
                _Shared(law.with_inner(inner)))

        # --- evaluation --------------------------------------------------------------------
        def _integral(self, context):
            if self.period is None:
                return context.get_continuous_state_vector().CopyToVector()
            return context.get_discrete_state(0).CopyToVector()

        def _calc_outputs(self, context, value):
            # u*, τ and d∫e/dt in one evaluation: the outputs, the continuous state's
            # derivative and the sampled update all read this cache entry
            shared = context.get_abstract_parameter(self._law_index).get_value()
            x, desired, qddot_r = self.read_tracking_parts(context)
            e_int = self._integral(context)
            fast = shared.float_sample() if T is float else None
            out = None if fast is None else fast(x, desired, qddot_r, e_int)
            if out is None:                      # Drake scalars, or a law without float path
                law = shared.law
                n = law.n
                q, qd = x[:n], x[n:]
                ref = np.concatenate([desired, self._zero_acc if qddot_r is None else qddot_r])
                u_star = law.generalized_input(q, qd, e_int, ref)
                out = (u_star, law.allocate(u_star, q, qd), law.integral_derivative(q, ref))
            value.set_value(out)

        def DoCalcTimeDerivatives(self, context: Context, derivatives: ContinuousState) -> None:
            if self.period is not None:         # sampled: no continuous state
                return
            derivatives.get_mutable_vector().SetFromVector(self._outputs.Eval(context)[2])

        def _calc_control(self, context, output):      # continuous form only
            output.SetFromVector(self._outputs.Eval(context)[1])

        def _calc_gen(self, context, output):
            output.SetFromVector(self._outputs.Eval(context)[0])

        def _calc_int(self, context, output):
            output.SetFromVector(self._integral(context))

        # --- sampled form ------------------------------------------------------------------
        def _initialize(self, context, discrete_state):
            u_star, tau, _ = self._outputs.Eval(context)
            for group in range(1, discrete_state.num_groups(), 2):    # held (and pending)
                discrete_state.get_mutable_vector(group).SetFromVector(tau)
                discrete_state.get_mutable_vector(group + 1).SetFromVector(u_star)

        def _sample(self, context, discrete_state):
            u_star, tau, rate = self._outputs.Eval(context)
            e_int = self._integral(context) + self.period * rate
            discrete_state.get_mutable_vector(0).SetFromVector(e_int)
            if self.computation_delay:          # the pending command goes out, this one waits
                for group in (1, 2):
                    discrete_state.get_mutable_vector(group).SetFrom(
                        context.get_discrete_state(group + 2))
                discrete_state.get_mutable_vector(3).SetFromVector(tau)
                discrete_state.get_mutable_vector(4).SetFromVector(u_star)
            else:
                discrete_state.get_mutable_vector(1).SetFromVector(tau)
                discrete_state.get_mutable_vector(2).SetFromVector(u_star)

    Impl.__signature__ = _SIGNATURE
    return Impl


#: the double controller (``MechanicalController_[float]``)
MechanicalController = MechanicalController_[None]
