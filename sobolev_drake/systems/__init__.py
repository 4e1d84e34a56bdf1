"""Drake LeafSystems: controllers, references, disturbances (and, in their own modules, the
tilt-rotor's propellers, aerodynamics, wind and allocation).

The names below are the general-purpose systems; vehicle-specific ones stay in their modules
(``propulsion``, ``aerodynamics``, ``wind``, ``allocation``, ``tiltrotor_*``).
"""

from sobolev_drake.systems.disturbances import TimeProfiledForce
from sobolev_drake.systems.floating_state import FloatingBaseState
from sobolev_drake.systems.linear_controllers import (LinearDynamicOutputFeedback,
                                                      LinearStateFeedback, controller_system)
from sobolev_drake.systems.mechanical_controller import (HinfLaw, MechanicalController,
                                                         MechanicalLaw, SobolevLaw)
from sobolev_drake.systems.multirotor_control import MultirotorController
from sobolev_drake.systems.partition import Partition, check_actuation
from sobolev_drake.systems.reference_smoothing import smooth_junctions
from sobolev_drake.systems.references import (Coordinate, PiecewiseTrajectory, TrajectoryReference,
                                              const, poly, sine)

__all__ = [
    "TimeProfiledForce",
    "LinearDynamicOutputFeedback", "LinearStateFeedback", "controller_system",
    "HinfLaw", "MechanicalController", "MechanicalLaw", "SobolevLaw",
    "Partition", "check_actuation", "FloatingBaseState", "MultirotorController",
    "Coordinate", "PiecewiseTrajectory", "TrajectoryReference", "const", "poly", "sine",
    "smooth_junctions",
]
