"""Generic adapter between the thesis' Euler–Lagrange interface and a MultibodyPlant.

The thesis writes every plant as M(q) q̈ + C(q, q̇) q̇ + K(q̇) + g(q) = B(q) u + w, in its own
coordinate order and units.  The plant integrates Drake's equations in Drake's coordinates
q_drake = T q_thesis, so the generalized force to apply is

    τ_drake = T⁻ᵀ (B(q) u + w − K(q̇))

(K is the model's ``friction``; zero unless the model defines it).  One class serves every model;
``B(q)`` is re-evaluated from the state at every call (state-dependent for the quadrotor).

A model whose equations deliberately differ from its plant's (``follows_own_equations``, e.g.
the arm with the thesis' printed inertia matrix) gets the force that makes the plant follow the
model: with q̈ = M_model⁻¹(B u + w − K − h_model), the plant needs
τ = M_plant q̈ + h_plant, h = C q̇ + g (thesis order, then mapped as above).

The adapter is scalar-convertible (``ToAutoDiffXd``, ``ToSymbolic``; Drake's ``Linearize`` of a
diagram holding it): the double system evaluates the model's methods, the converted ones the
same terms through :class:`~sobolev_drake.models.scalar_terms.ScalarTerms` (a converted copy of
the plant, the model's own closed forms where it overrides them).
"""

from __future__ import annotations

import inspect

import numpy as np
from pydrake.systems.framework import LeafSystem_
from pydrake.systems.scalar_conversion import TemplateSystem

from sobolev_drake.models.base import MechanicalModel, check_vector
from sobolev_drake.models.scalar_terms import ScalarTerms, quiet, solve

__all__ = ["ThesisForceAdapter", "ThesisForceAdapter_"]


@TemplateSystem.define("ThesisForceAdapter_")
def ThesisForceAdapter_(T):
    """The adapter for scalar type ``T`` (``ThesisForceAdapter_[AutoDiffXd]``, ...)."""

    class Impl(LeafSystem_[T]):
        """LeafSystem: (u, disturbance, plant_state) → (applied_generalized_force, x).

        .. pydrake_system::

            name: ThesisForceAdapter
            input_ports:
            - u
            - disturbance
            - plant_state
            output_ports:
            - applied_generalized_force
            - x

        ``u``: actuator commands in thesis units (size ``model.num_inputs``), zero if
        unconnected; ``disturbance``: thesis-ordered generalized force w (size n), zero if
        unconnected; ``plant_state``: Drake state [q_drake; v_drake] (connect the plant's state
        output).  ``applied_generalized_force``: Drake-ordered τ_drake (connect to the plant's
        applied_generalized_force input); ``x``: thesis-ordered [q; q̇], depending on
        ``plant_state`` only, so feeding a controller from ``x`` back into ``u`` creates no
        algebraic loop.

        Parameters
        ----------
        model : MechanicalModel
            The model of the plant the adapter drives.
        """

        def _construct(self, model, converter=None):
            LeafSystem_[T].__init__(self, converter)
            if not isinstance(model, MechanicalModel):
                raise TypeError(f"model must be a MechanicalModel, got {type(model).__name__}")
            self.model = model
            n = model.n
            self.n = n
            self.nu = int(getattr(model, "num_inputs", n))
            self._terms = None if T is float else ScalarTerms(model, T)
            self._u = self.DeclareVectorInputPort("u", self.nu)
            self._w = self.DeclareVectorInputPort("disturbance", n)
            self._state = self.DeclareVectorInputPort("plant_state", 2 * n)
            self.DeclareVectorOutputPort("applied_generalized_force", n, self._calc_force,
                                         prerequisites_of_calc={self.all_input_ports_ticket()})
            self.DeclareVectorOutputPort(
                "x", 2 * n, self._calc_x,
                prerequisites_of_calc={self.input_port_ticket(self._state.get_index())})

        def _construct_copy(self, other, converter=None):
            Impl._construct(self, other.model, converter=converter)

        def _read_optional(self, port, context, size):
            if port.HasValue(context):
                value = port.Eval(context)
                return np.asarray(value, dtype=float) if T is float else value
            return np.zeros(size)

        def thesis_force(self, x_thesis, u, w) -> np.ndarray:
            """B(q) u + w − K(q̇) in thesis order (exposed for tests and controllers); for a
            model that ``follows_own_equations``, the force that makes the plant follow it.

            Parameters
            ----------
            x_thesis : ndarray, shape (2 n,)
                Thesis-ordered [q; q̇].
            u : ndarray, shape (num_inputs,)
                Actuator commands.
            w : ndarray, shape (n,)
                Generalized disturbance force.

            Returns
            -------
            ndarray, shape (n,)
                Generalized force in thesis order.
            """
            if T is not float:
                return self._thesis_force_scalar(x_thesis, u, w)
            n = self.n
            q, qdot = x_thesis[:n], x_thesis[n:]
            tau = self.model.B(q) @ u + w
            friction = getattr(self.model, "friction", None)
            if friction is not None:
                tau = tau - friction(qdot)
            if getattr(self.model, "follows_own_equations", False):
                m = self.model
                qddot = np.linalg.solve(m.M(q), tau - m.Cqdot(q, qdot) - m.g(q))
                tau = (MechanicalModel.M(m, q) @ qddot + MechanicalModel.Cqdot(m, q, qdot)
                       + MechanicalModel.g(m, q))
            return tau

        def _thesis_force_scalar(self, x_thesis, u, w):
            n, terms = self.n, self._terms
            q, qdot = x_thesis[:n], x_thesis[n:]
            tau = terms.input_matrix(q) @ u + w - terms.friction(qdot)
            if getattr(self.model, "follows_own_equations", False):
                M, h = terms.mass_and_bias(q, qdot)          # the model's equations (with K)
                qddot = solve(M, tau + terms.friction(qdot) - h)
                M_plant, Cqdot, g = terms.plant_terms(q, qdot)
                tau = M_plant @ qddot + Cqdot + g
            return tau

        def _thesis_state(self, context) -> np.ndarray:
            s = self._state.Eval(context)
            n = self.n
            if T is float:
                s = np.asarray(s, dtype=float)
                return np.concatenate([self.model.to_thesis(s[:n]), self.model.to_thesis(s[n:])])
            T_inv = self.model.T_inv
            return np.concatenate([T_inv @ s[:n], T_inv @ s[n:]])

        def _calc_force(self, context, output) -> None:
            u = self._read_optional(self._u, context, self.nu)
            w = self._read_optional(self._w, context, self.n)
            if T is float:
                # non-finite commands would otherwise surface later as a NaN state
                u = check_vector("u (actuator command)", u, self.nu)
                w = check_vector("disturbance", w, self.n)
                tau = self.thesis_force(self._thesis_state(context), u, w)
                output.SetFromVector(self.model.force_to_drake(tau))
                return
            with quiet(T):
                tau = self._thesis_force_scalar(self._thesis_state(context), u, w)
                output.SetFromVector(self.model.T_inv.T @ tau)

        def _calc_x(self, context, output) -> None:
            output.SetFromVector(self._thesis_state(context))

    Impl.__signature__ = inspect.Signature(
        [inspect.Parameter("model", inspect.Parameter.POSITIONAL_OR_KEYWORD)])
    return Impl


#: the double adapter (``ThesisForceAdapter_[float]``)
ThesisForceAdapter = ThesisForceAdapter_[None]
