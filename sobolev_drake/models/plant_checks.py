"""Checks of the plant and context handed to ``MechanicalModel.from_plant`` (shared by
:mod:`~sobolev_drake.models.base` and :mod:`~sobolev_drake.models.floating_base`)."""

from __future__ import annotations

from pydrake.multibody.plant import MultibodyPlant, MultibodyPlant_
from pydrake.systems.framework import Context

__all__ = ["check_plant", "check_context", "constraint_kinds"]


def check_plant(plant: object) -> None:
    """TypeError unless ``plant`` is a double MultibodyPlant; ValueError unless finalized."""
    if not isinstance(plant, MultibodyPlant):
        scalars = [s.__name__ for (s,) in MultibodyPlant_.param_list
                   if isinstance(plant, MultibodyPlant_[s])]
        got = f"MultibodyPlant_[{scalars[0]}]" if scalars else type(plant).__name__
        raise TypeError(
            f"plant must be a finalized MultibodyPlant of scalar type float, got {got}: pass "
            "the double plant (the one ToAutoDiffXd/ToSymbolic converted; for a Diagram, the "
            "plant inside it, e.g. diagram.GetSubsystemByName('plant'))")
    if not plant.is_finalized():
        raise ValueError(f"plant {plant.get_name()!r} must be finalized before from_plant: call "
                         "plant.Finalize() after adding its bodies, joints and actuators")


def check_context(plant: MultibodyPlant, context: object) -> None:
    """TypeError/ValueError naming ``context`` unless it is a double context of ``plant``."""
    fix = ("pass plant.CreateDefaultContext() or plant.GetMyContextFromRoot(diagram_context) "
           "of the diagram holding the plant, or omit it for the plant's defaults")
    if not isinstance(context, Context):
        raise TypeError(f"context must be a double Context of plant {plant.get_name()!r}, got "
                        f"{type(context).__name__}: {fix}")
    try:
        plant.ValidateContext(context)
    except RuntimeError as err:
        try:
            plant.GetMyContextFromRoot(context)
            fix = "it is the diagram's, holding the plant's: pass plant.GetMyContextFromRoot(context)"
        except RuntimeError:
            pass
        raise ValueError(f"context is not a context of plant {plant.GetSystemPathname()!r} "
                         f"(Drake: {str(err).splitlines()[0]}); {fix}") from err


def constraint_kinds(plant: MultibodyPlant) -> str:
    """The plant's constraints by kind, as far as pydrake tells them apart (only distance
    constraints have a query of their own)."""
    context, distance = plant.CreateDefaultContext(), 0
    for constraint_id in plant.GetConstraintIds():
        try:
            plant.GetDistanceConstraintParams(context, constraint_id)
            distance += 1
        except RuntimeError:
            pass
    kinds = [f"{distance} distance"] if distance else []
    if plant.num_constraints() > distance:
        kinds.append(f"{plant.num_constraints() - distance} coupler (e.g. from a URDF <mimic>), "
                     "ball or weld")
    return ", ".join(kinds)
