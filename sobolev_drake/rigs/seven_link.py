"""The 7-joint arm (:mod:`sobolev_drake.models.serial_chain`) tracking a desired state under a
controller the caller makes: the loop of Drake's ``InverseDynamicsController`` example, so
swapping that controller for the library's is the one line ``make_controller`` returns.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike
from pydrake.systems.analysis import Simulator
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import DiagramBuilder, System
from pydrake.systems.primitives import LogVectorOutput, TrajectorySource, ZeroOrderHold
from pydrake.trajectories import Trajectory

from sobolev_drake.models.serial_chain import seven_link_arm

__all__ = ["fly_seven_link_arm"]


def fly_seven_link_arm(make_controller: Callable[[MultibodyPlant], System], desired: Trajectory,
                       q0: ArrayLike, duration: float, *, time_step: float = 0.0,
                       zoh: float | None = None, log_period: float = 1e-3) -> dict:
    """Fly the 7-joint arm from ``q0`` (at rest) tracking ``desired`` with
    ``make_controller(controller_plant)``.

    The controller takes ``estimated_state`` (the plant's state, through a ZeroOrderHold of
    period ``zoh`` if given) and ``desired_state`` (``desired`` and its derivative), and its
    ``control`` drives the plant's actuation (Drake's controller ports).

    Parameters
    ----------
    make_controller : callable
        ``make_controller(plant)`` → the controller system, given a separate (continuous)
        copy of the arm as Drake's controllers expect.
    desired : Trajectory
        Desired joint positions (7); its derivative is the desired velocity.
    q0 : array_like, shape (7,)
        Initial joint positions.
    duration : float
        Simulated seconds.
    time_step : float, default 0.0
        The simulated plant's discrete step (s); 0 for a continuous plant.
    zoh : float, optional
        Period of a ZeroOrderHold between the plant's state and the controller.
    log_period : float, default 1e-3
        Period of the state and command logs (s).

    Returns
    -------
    dict
        "t" (log times), "x" (14 × samples), "u" (7 × samples, at the same times) and
        "cpu_s" (process time of ``AdvanceTo``).
    """
    builder = DiagramBuilder()
    plant = builder.AddSystem(seven_link_arm(time_step))
    controller = builder.AddSystem(make_controller(seven_link_arm()))
    source = builder.AddSystem(TrajectorySource(desired, output_derivative_order=1))
    state = plant.get_state_output_port()
    if zoh is not None:
        hold = builder.AddSystem(ZeroOrderHold(zoh, plant.num_multibody_states()))
        builder.Connect(state, hold.get_input_port())
        state = hold.get_output_port()
    builder.Connect(state, controller.get_input_port_estimated_state())
    builder.Connect(source.get_output_port(), controller.get_input_port_desired_state())
    builder.Connect(controller.get_output_port_control(), plant.get_actuation_input_port())
    x_log = LogVectorOutput(plant.get_state_output_port(), builder, log_period)
    u_log = LogVectorOutput(controller.get_output_port_control(), builder, log_period)
    diagram = builder.Build()
    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    plant.SetPositions(plant.GetMyMutableContextFromRoot(context), np.asarray(q0, dtype=float))
    simulator.get_mutable_integrator().set_target_accuracy(1e-6)
    start = time.process_time()
    simulator.AdvanceTo(duration)
    cpu = time.process_time() - start
    return {"t": x_log.FindLog(context).sample_times(), "x": x_log.FindLog(context).data(),
            "u": u_log.FindLog(context).data(), "cpu_s": cpu}
