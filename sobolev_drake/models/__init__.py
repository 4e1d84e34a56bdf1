"""Plant builders: URDF → MultibodyPlant wrapped as :class:`MechanicalModel` (docs/design.md §5).

Each model module provides a parameter dataclass (thesis table values by default), a
MechanicalModel subclass with the thesis closed forms, ``make_<name>_model(params)`` (standalone
model on its own plant) and ``add_<name>(builder, params)`` (plant + SceneGraph + thesis adapter,
returning :class:`PlantHandles`).  ``MechanicalModel.from_plant(plant)`` models any other
MultibodyPlant (:class:`PlantModel`; :class:`FloatingBaseModel` for a quaternion or
roll-pitch-yaw floating base driven by propellers).
"""

from sobolev_drake.models.base import MechanicalModel, PlantModel, check_vector
from sobolev_drake.models.floating_base import FloatingBaseModel
from sobolev_drake.models.handles import PlantHandles
from sobolev_drake.models.arm import ArmParams, TwoLinkArmModel, add_arm, make_arm_model
from sobolev_drake.models.two_wheeled import (TwoWheeledModel, TwoWheeledParams, add_two_wheeled,
                                              make_two_wheeled_model)
from sobolev_drake.models.quadrotor import (QuadrotorModel, QuadrotorParams, add_quadrotor,
                                            make_quadrotor_model)

__all__ = [
    "MechanicalModel", "PlantModel", "FloatingBaseModel", "check_vector", "PlantHandles",
    "ArmParams", "TwoLinkArmModel", "add_arm", "make_arm_model",
    "TwoWheeledParams", "TwoWheeledModel", "add_two_wheeled", "make_two_wheeled_model",
    "QuadrotorParams", "QuadrotorModel", "add_quadrotor", "make_quadrotor_model",
]
