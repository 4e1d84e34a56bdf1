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

* :class:`MechanicalController` — a LeafSystem wrapping a law: input ports ``x`` (plant state
  [q; q̇], thesis order) and ``reference`` (stacked [q_r; q̇_r; q̈_r] of the *tracked* DOF, i.e.
  ``partition.tracked`` = controlled DOF followed by regulated DOF); continuous state ∫q̃c;
  output ports ``u`` (actuator command), ``generalized_force`` (u*, or the reduced force
  B̄τ) and ``error_integral``.

Reference order: ``partition.tracked`` (controlled then regulated, in the order given).
"""

from __future__ import annotations

import numpy as np
from pydrake.systems.framework import BasicVector, LeafSystem

from sobolev_drake.models.base import check_vector
from sobolev_drake.systems.mechanical_law import HinfLaw, MechanicalLaw, SobolevLaw
from sobolev_drake.systems.partition import Partition

__all__ = ["Partition", "SobolevLaw", "HinfLaw", "MechanicalLaw", "MechanicalController"]


class MechanicalController(LeafSystem):
    """LeafSystem around a :class:`MechanicalLaw` (ports documented in the module docstring).

    Give either ``model``, ``partition`` and ``inner`` (and optionally ``allocation``,
    ``lower``, ``upper``, ``operating_points``) or ``law=`` a ready MechanicalLaw.

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
    """

    def __init__(self, model=None, partition: Partition | None = None, inner=None, *,
                 law: MechanicalLaw | None = None, allocation=None, lower=None, upper=None,
                 initial_integral=None, operating_points=None):
        super().__init__()
        if law is None:
            if model is None or partition is None or inner is None:
                raise ValueError("give either law= or (model, partition, inner)")
            law = MechanicalLaw(model, partition, inner, allocation=allocation, lower=lower,
                                upper=upper, operating_points=operating_points)
        elif not isinstance(law, MechanicalLaw):
            raise TypeError(f"law must be a MechanicalLaw (or pass model, partition, inner), got "
                            f"{type(law).__name__}")
        self.law = law
        n, nc = law.n, law.nc
        self._x = self.DeclareVectorInputPort("x", 2 * n)
        self._ref = self.DeclareVectorInputPort("reference", 3 * law.n_ref)
        x0 = np.zeros(nc) if initial_integral is None else check_vector("initial_integral",
                                                                         initial_integral, nc)
        self.DeclareContinuousState(BasicVector(x0))
        self.DeclareVectorOutputPort("u", law.num_inputs, self._calc_u)
        n_gen = nc if law.partition.mode == "reduced" else n
        self.DeclareVectorOutputPort("generalized_force", n_gen, self._calc_gen)
        self.DeclareVectorOutputPort("error_integral", nc, self._calc_int,
                                     prerequisites_of_calc={self.xc_ticket()})

    def set_inner(self, inner) -> None:
        """Swap the inner law (same model, partition, allocation and bounds) so one diagram can
        serve a tuning sweep (Python LeafSystems are not garbage-collected in drake 1.51).
        Re-initialize the context (time, state) before the next run so no cached output is
        reused.  The new law is checked at the same ``operating_points``.

        Parameters
        ----------
        inner : SobolevLaw or HinfLaw
            The new inner law.
        """
        old = self.law
        self.law = MechanicalLaw(old.model, old.partition, inner, allocation=old.allocation,
                                 lower=old.lower, upper=old.upper,
                                 operating_points=old.operating_points)

    def _read(self, context):
        x = np.asarray(self._x.Eval(context), dtype=float)
        n = self.law.n
        ref = np.asarray(self._ref.Eval(context), dtype=float)
        e_int = np.asarray(context.get_continuous_state_vector().CopyToVector())
        return x[:n], x[n:], e_int, ref

    def DoCalcTimeDerivatives(self, context, derivatives):
        q, _, _, ref = self._read(context)
        derivatives.get_mutable_vector().SetFromVector(self.law.integral_derivative(q, ref))

    def _calc_gen(self, context, output):
        q, qd, ei, ref = self._read(context)
        output.SetFromVector(self.law.generalized_input(q, qd, ei, ref))

    def _calc_u(self, context, output):
        q, qd, ei, ref = self._read(context)
        u_star = self.law.generalized_input(q, qd, ei, ref)
        output.SetFromVector(self.law.allocate(u_star, q, qd))

    def _calc_int(self, context, output):
        output.SetFromVector(context.get_continuous_state_vector().CopyToVector())
