"""Shared fixtures of the model tests."""

import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource


@pytest.fixture
def fly_constant():
    """``fly(add_plant, q0, qd0, u, w, duration)``: the thesis-ordered state [q; q̇] after
    ``duration`` s of a plant added by ``add_plant(builder)`` (returns PlantHandles) under
    constant commands ``u`` and disturbance ``w``, integrated at 1e-10 target accuracy."""
    def fly(add_plant, q0, qd0, u, w, duration):
        b = DiagramBuilder()
        h = add_plant(b)
        b.Connect(b.AddSystem(ConstantVectorSource(u)).get_output_port(), h.u)
        b.Connect(b.AddSystem(ConstantVectorSource(w)).get_output_port(), h.disturbance)
        diagram = b.Build()
        sim = Simulator(diagram)
        ctx = sim.get_mutable_context()
        pctx = diagram.GetMutableSubsystemContext(h.plant, ctx)
        h.plant.SetPositions(pctx, h.model.to_drake(q0))
        h.plant.SetVelocities(pctx, h.model.to_drake(qd0))
        sim.get_mutable_integrator().set_target_accuracy(1e-10)
        sim.AdvanceTo(duration)
        return h.x.Eval(h.adapter.GetMyContextFromRoot(ctx))
    return fly
