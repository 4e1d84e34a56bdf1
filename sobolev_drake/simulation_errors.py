"""How :func:`sobolev_drake.simulation.simulate` stops a run it cannot finish."""

from __future__ import annotations

from sobolev_drake.errors import SimulationError

__all__ = ["SimulationTimeout", "SimulationDiverged", "SimulationStalled"]


class SimulationTimeout(SimulationError, TimeoutError):
    """:func:`simulate` ran longer than its ``wall_time_limit``; ``simulated`` is where it stopped.

    Parameters
    ----------
    message : str
        The error message.
    simulated : float
        Simulated time reached when the simulation was stopped (kept as ``.simulated``).

    Examples
    --------
    >>> import sobolev_drake as sd
    >>> from pydrake.systems.framework import DiagramBuilder
    >>> from pydrake.systems.primitives import ConstantVectorSource, Integrator
    >>> builder = DiagramBuilder()
    >>> source = builder.AddSystem(ConstantVectorSource([1.0]))
    >>> integrator = builder.AddSystem(Integrator(1))
    >>> builder.Connect(source.get_output_port(), integrator.get_input_port())
    >>> diagram = builder.Build()
    >>> try:                                         # 1e5 s of simulation in 0.05 s of wall time
    ...     sd.simulate(diagram, diagram.CreateDefaultContext(), 1e5, wall_time_limit=0.05,
    ...                 progress=False)
    ... except sd.SimulationTimeout as error:
    ...     print(0.0 < error.simulated < 1e5)
    True
    """

    def __init__(self, message: str, simulated: float) -> None:
        super().__init__(message)
        self.simulated = simulated


class SimulationDiverged(SimulationError, RuntimeError):
    """:func:`simulate` met a state or time derivative that is not finite (NaN or ±inf).

    Parameters
    ----------
    message : str
        The error message: the simulated time, the entries and the subsystems that own them.
    simulated : float
        Simulated time (s) of the context when the run was stopped (kept as ``.simulated``);
        the context keeps the state reached.
    subsystem : str or None
        Name of the (first) subsystem whose state or derivative is not finite, relative to the
        simulated diagram (``"outer::inner"`` inside nested diagrams); kept as ``.subsystem``.
    """

    def __init__(self, message: str, simulated: float, subsystem: str | None) -> None:
        super().__init__(message)
        self.simulated = simulated
        self.subsystem = subsystem


class SimulationStalled(SimulationError, RuntimeError):
    """:func:`simulate` stopped a run that used up its step budget or stopped advancing time.

    Parameters
    ----------
    message : str
        The error message.
    simulated : float
        Simulated time (s) reached (kept as ``.simulated``); the context keeps the state reached.
    steps : int
        Simulator steps taken by this call (kept as ``.steps``).

    Examples
    --------
    >>> import sobolev_drake as sd
    >>> from pydrake.systems.framework import DiagramBuilder
    >>> from pydrake.systems.primitives import ConstantVectorSource, Integrator
    >>> builder = DiagramBuilder()
    >>> source = builder.AddSystem(ConstantVectorSource([1.0]))
    >>> integrator = builder.AddSystem(Integrator(1))
    >>> builder.Connect(source.get_output_port(), integrator.get_input_port())
    >>> diagram = builder.Build()
    >>> try:                                         # a step budget of 5 for 10 s
    ...     sd.simulate(diagram, diagram.CreateDefaultContext(), 10.0, max_steps=5,
    ...                 progress=False)
    ... except sd.SimulationStalled as error:
    ...     print(error.steps, error.simulated < 10.0)
    5 True
    """

    def __init__(self, message: str, simulated: float, steps: int) -> None:
        super().__init__(message)
        self.simulated = simulated
        self.steps = steps
