"""How :func:`sobolev_drake.simulation.simulate` stops a run it cannot finish."""

from __future__ import annotations

__all__ = ["SimulationTimeout", "SimulationDiverged", "SimulationStalled"]


class SimulationTimeout(TimeoutError):
    """:func:`simulate` ran longer than its ``wall_time_limit``; ``simulated`` is where it stopped.

    Parameters
    ----------
    message : str
        The error message.
    simulated : float
        Simulated time reached when the simulation was stopped (kept as ``.simulated``).
    """

    def __init__(self, message: str, simulated: float):
        super().__init__(message)
        self.simulated = simulated


class SimulationDiverged(RuntimeError):
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

    def __init__(self, message: str, simulated: float, subsystem: str | None):
        super().__init__(message)
        self.simulated = simulated
        self.subsystem = subsystem


class SimulationStalled(RuntimeError):
    """:func:`simulate` stopped a run that used up its step budget or stopped advancing time.

    Parameters
    ----------
    message : str
        The error message.
    simulated : float
        Simulated time (s) reached (kept as ``.simulated``); the context keeps the state reached.
    steps : int
        Simulator steps taken by this call (kept as ``.steps``).
    """

    def __init__(self, message: str, simulated: float, steps: int):
        super().__init__(message)
        self.simulated = simulated
        self.steps = steps
