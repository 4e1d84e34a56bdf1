"""A 7-joint serial arm built in code, shaped like a KUKA iiwa (Drake's iiwa models are not
shipped with the pip wheel and are downloaded on first use, so offline runs need one in code).

Seven revolute joints with axes z, y, z, −y, z, y, z (the iiwa's alternation), links as solid
cylinders along z with the iiwa's approximate masses and segment lengths, gravity along −z and
one actuator per joint with the iiwa 14's effort limits (N·m).  No collision geometry, no joint
damping, no joint limits: M q̈ + C q̇ + g = τ exactly, so ``MechanicalModel.from_plant`` and
Drake's ``InverseDynamicsController`` model it exactly.
"""

from __future__ import annotations

import numpy as np
from pydrake.math import RigidTransform
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import FixedOffsetFrame, RevoluteJoint, SpatialInertia

__all__ = ["SEVEN_LINK_EFFORT_LIMITS", "seven_link_arm"]

#: effort limits of the joints (N·m), the iiwa 14's
SEVEN_LINK_EFFORT_LIMITS = np.array([320.0, 320.0, 176.0, 176.0, 110.0, 40.0, 40.0])
_MASSES = (4.0, 4.0, 3.0, 2.7, 1.7, 1.8, 0.3)                       # kg
_LENGTHS = (0.34, 0.2, 0.2, 0.2, 0.2, 0.19, 0.08)                   # m, base to flange
_AXES = ((0, 0, 1), (0, 1, 0), (0, 0, 1), (0, -1, 0), (0, 0, 1), (0, 1, 0), (0, 0, 1))


def seven_link_arm(time_step: float = 0.0) -> MultibodyPlant:
    """The finalized 7-joint arm of the module docstring.

    Parameters
    ----------
    time_step : float, default 0.0
        The plant's discrete time step (s); 0 for a continuous plant.

    Returns
    -------
    MultibodyPlant
        Joints ``joint1`` … ``joint7`` (positions in that order), actuators ``act1`` …
        ``act7`` with :data:`SEVEN_LINK_EFFORT_LIMITS`, welded to the world at the origin.
    """
    if not time_step >= 0.0:
        raise ValueError(f"time_step must be >= 0 (s), got {time_step!r}")
    plant = MultibodyPlant(float(time_step))
    parent_frame = plant.world_frame()
    for i, (mass, length, axis) in enumerate(zip(_MASSES, _LENGTHS, _AXES), start=1):
        inertia = SpatialInertia.SolidCylinderWithMassAboutEnd(mass, 0.06, length, [0, 0, 1])
        body = plant.AddRigidBody(f"link{i}", inertia)
        joint = plant.AddJoint(RevoluteJoint(f"joint{i}", parent_frame, body.body_frame(), axis))
        plant.AddJointActuator(f"act{i}", joint, SEVEN_LINK_EFFORT_LIMITS[i - 1])
        parent_frame = plant.AddFrame(FixedOffsetFrame(
            f"link{i}_end", body.body_frame(), RigidTransform([0.0, 0.0, length])))
    plant.Finalize()
    return plant
