"""A floating-base plant's state in the model's Euler-angle coordinates, as a system.

:class:`FloatingBaseState` converts the state port of a MultibodyPlant with a quaternion or
roll-pitch-yaw floating base ([q_drake; v_drake]) into the state of its
:class:`~sobolev_drake.models.floating_base.FloatingBaseModel` ([ϕ θ ψ x y z …; their rates]),
so the plant's state port still feeds a controller written for the model::

    plant.get_state_output_port() → FloatingBaseState → MechanicalController("x")

The ZYX chart is singular at θ = ±90°: evaluating the output beyond the model's
``max_pitch`` raises a ``ValueError`` naming the pitch and the state, so a tumbling vehicle
stops the simulation instead of receiving a command computed from meaningless rates.
"""

from __future__ import annotations

import numpy as np
from pydrake.systems.framework import LeafSystem_
from pydrake.systems.scalar_conversion import TemplateSystem

from sobolev_drake.models.euler_chart import check_pitch
from sobolev_drake.systems.scalar_time import template_signature

__all__ = ["FloatingBaseState", "FloatingBaseState_"]


def _value(x):
    return x if isinstance(x, float) else float(x.value()) if hasattr(x, "value") else float(x.Evaluate())


@TemplateSystem.define("FloatingBaseState_")
def FloatingBaseState_(T):   # the class for scalar type T (float, AutoDiffXd, Expression)

    class Impl(LeafSystem_[T]):
        """Drake state [q; v] of a floating-base plant → model state [q_e; q̇_e] (module doc).

        .. pydrake_system::

            name: FloatingBaseState
            input_ports:
            - plant_state
            output_ports:
            - state

        Scalar-convertible (the chart uses only arithmetic, sqrt, arctan2 and arcsin); the
        pitch check uses the value of θ (AutoDiffXd) and is skipped for an Expression whose θ
        is not a constant.

        Parameters
        ----------
        model : FloatingBaseModel
            The model whose coordinates the output uses.
        """

        def _construct(self, model, converter=None):
            LeafSystem_[T].__init__(self, converter)
            if not hasattr(model, "from_drake_state"):
                raise TypeError(f"model must be a FloatingBaseModel (MechanicalModel.from_plant "
                                f"of a floating-base plant), got {type(model).__name__}")
            self.model = model
            plant = model.plant
            self._nq, self._nv = plant.num_positions(), plant.num_velocities()
            self.DeclareVectorInputPort("plant_state", self._nq + self._nv)
            self.DeclareVectorOutputPort("state", 2 * model.n, self._calc,
                                         prerequisites_of_calc={self.all_input_ports_ticket()})

        def _construct_copy(self, other, converter=None):
            Impl._construct(self, other.model, converter=converter)

        __signature__ = template_signature(_construct)

        def _calc(self, context, output):
            x = self.get_input_port(0).Eval(context)
            q, qdot = self.model.from_drake_state(x[:self._nq], x[self._nq:])
            try:
                values = [_value(c) for c in q]
            except RuntimeError:       # a symbolic state: nothing to check
                values = None
            if values is not None:
                check_pitch(values[:3], self.model.max_pitch, values)
            output.SetFromVector(np.concatenate([q, qdot]))

    return Impl


FloatingBaseState = FloatingBaseState_[None]
