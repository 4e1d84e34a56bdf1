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
"""

from __future__ import annotations

import numpy as np
from pydrake.systems.framework import BasicVector, LeafSystem

from sobolev_drake.models.base import MechanicalModel, check_vector


class ThesisForceAdapter(LeafSystem):
    """LeafSystem: (u, disturbance, plant_state) → (applied_generalized_force, x).

    Input ports
    -----------
    ``u`` : actuator commands in thesis units (size ``model.num_inputs``); zero if unconnected.
    ``disturbance`` : thesis-ordered generalized force w (size n); zero if unconnected.
    ``plant_state`` : Drake state [q_drake; v_drake] (connect the plant's state output).

    Output ports
    ------------
    ``applied_generalized_force`` : Drake-ordered τ_drake (connect to the plant's
        applied_generalized_force input).
    ``x`` : thesis-ordered [q; q̇]; depends on ``plant_state`` only, so feeding a controller
        from ``x`` back into ``u`` creates no algebraic loop.
    """

    def __init__(self, model):
        super().__init__()
        self.model = model
        n = model.n
        self.n = n
        self.nu = int(getattr(model, "num_inputs", n))
        self._u = self.DeclareVectorInputPort("u", self.nu)
        self._w = self.DeclareVectorInputPort("disturbance", n)
        self._state = self.DeclareVectorInputPort("plant_state", 2 * n)
        self.DeclareVectorOutputPort("applied_generalized_force", n, self._calc_force)
        self.DeclareVectorOutputPort(
            "x", 2 * n, self._calc_x,
            prerequisites_of_calc={self.input_port_ticket(self._state.get_index())})

    def _read_optional(self, port, context, size):
        if port.HasValue(context):
            return np.asarray(port.Eval(context), dtype=float)
        return np.zeros(size)

    def thesis_force(self, x_thesis, u, w) -> np.ndarray:
        """B(q) u + w − K(q̇) in thesis order (exposed for tests and controllers)."""
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

    def _thesis_state(self, context) -> np.ndarray:
        s = np.asarray(self._state.Eval(context), dtype=float)
        n = self.n
        return np.concatenate([self.model.to_thesis(s[:n]), self.model.to_thesis(s[n:])])

    def _calc_force(self, context, output: BasicVector) -> None:
        # non-finite commands would otherwise surface later as a NaN state
        u = check_vector("u (actuator command)", self._read_optional(self._u, context, self.nu), self.nu)
        w = check_vector("disturbance", self._read_optional(self._w, context, self.n), self.n)
        tau = self.thesis_force(self._thesis_state(context), u, w)
        output.SetFromVector(self.model.force_to_drake(tau))

    def _calc_x(self, context, output: BasicVector) -> None:
        output.SetFromVector(self._thesis_state(context))
