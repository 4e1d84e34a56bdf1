"""Run a diagram with Drake's Simulator, an error-controlled integrator and a progress line.

:func:`simulate` is what every experiment uses.  The progress monitor (``Simulator.set_monitor``)
rewrites one line on stderr at most every 0.5 s of wall time when stderr is a terminal, and
always prints one final summary line (simulated time, wall time, steps) unless
``progress=False``.  The monitor costs one Python call per integrator step, negligible next to
the Python LeafSystems of our diagrams.
"""

from __future__ import annotations

import math
import sys
import time

from pydrake.systems.analysis import ResetIntegratorFromFlags, Simulator
from pydrake.systems.framework import Context_, EventStatus

from .validation import one_of, positive_scalar

__all__ = ["simulate", "SimulationTimeout", "ProgressMonitor", "INTEGRATORS"]

# Error-controlled schemes accepted by ResetIntegratorFromFlags (plus the fixed-step ones).
INTEGRATORS = ("runge_kutta3", "runge_kutta5", "radau3", "implicit_euler", "bogacki_shampine3",
               "velocity_implicit_euler", "runge_kutta2", "explicit_euler", "semi_explicit_euler")
_FIXED_STEP = ("runge_kutta2", "explicit_euler", "semi_explicit_euler")
#: Relative slack added to ``max_step`` (see :func:`simulate`); 1e-6 covers the rounding of
#: event times up to t ≈ 1e7 s and changes no step size by a measurable amount.
MAX_STEP_SLACK = 1e-6
#: most steps (duration / max_step) :func:`simulate` accepts without a ``wall_time_limit``: at
#: 10 µs per step of a minimal diagram that is already about three hours
MAX_STEPS_UNBOUNDED = 1e9


class ProgressMonitor:
    """Callable for ``Simulator.set_monitor``: a tqdm-like single line on ``stream``.

    Parameters
    ----------
    t_start, t_end : float
        Simulated start and end times (s) of the run; the bar shows the fraction between them.
    label : str, optional
        Prefix of the line (default ``"simulate"``).
    stream : file-like, optional
        Where the line is written (default ``sys.stderr``).
    period : float, default 0.5
        Minimum wall-clock seconds between two rewrites of the live line.
    live : bool, optional
        Rewrite the line during the run; default: whether ``stream`` is a terminal.
    """

    def __init__(self, t_start: float, t_end: float, *, label: str = "", stream=None, period: float = 0.5,
                 live: bool | None = None):
        self.t_start, self.t_end = float(t_start), float(t_end)
        self.label = label or "simulate"
        self.stream = stream if stream is not None else sys.stderr
        self.period = float(period)
        self.live = self.stream.isatty() if live is None and hasattr(self.stream, "isatty") else bool(live)
        self.wall0 = time.perf_counter()
        self._last = -float("inf")
        self.calls = 0

    def _line(self, t: float) -> str:
        span = max(self.t_end - self.t_start, 1e-12)
        frac = min(max((t - self.t_start) / span, 0.0), 1.0)
        wall = time.perf_counter() - self.wall0
        bar = "#" * int(20 * frac)
        return f"{self.label}: [{bar:<20}] {100 * frac:5.1f}%  t = {t:8.3f}/{self.t_end:.3f} s  wall {wall:6.1f} s"

    def __call__(self, context) -> EventStatus:
        self.calls += 1
        if self.live:
            now = time.perf_counter()
            if now - self._last >= self.period:
                self._last = now
                self.stream.write("\r" + self._line(context.get_time()))
                self.stream.flush()
        return EventStatus.Succeeded()

    def finish(self, t: float, steps: int) -> None:
        """Write the final summary line (progress, simulated and wall time, steps).

        Parameters
        ----------
        t : float
            Simulated time (s) reached.
        steps : int
            Number of integrator steps taken.
        """
        prefix = "\r" if self.live else ""
        self.stream.write(f"{prefix}{self._line(t)}  ({steps} steps)\n")
        self.stream.flush()


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


class _WallClock(ProgressMonitor):
    """Progress monitor that also stops the simulation after ``limit`` seconds of wall time."""

    def __init__(self, t_start, t_end, *, limit, show, **kw):
        super().__init__(t_start, t_end, **kw)
        self.limit, self.show, self.expired = limit, show, False

    def __call__(self, context) -> EventStatus:
        if self.limit is not None and time.perf_counter() - self.wall0 > self.limit:
            self.expired = True
            return EventStatus.ReachedTermination(None, "wall_time_limit reached")
        return super().__call__(context) if self.show else EventStatus.Succeeded()


def simulate(diagram, context, duration: float, *, progress: bool = True, label: str = "",
             integrator: str = "runge_kutta3", accuracy: float = 1e-4, max_step: float = 0.05,
             simulator: Simulator | None = None, wall_time_limit: float | None = None) -> Simulator:
    """Advance ``context`` (the root context of ``diagram``) by ``duration`` seconds.

    Parameters
    ----------
    diagram : Diagram
        The system to simulate (ignored when ``simulator`` is given).
    context : Context
        Root context of ``diagram`` (``diagram.CreateDefaultContext()``), advanced in place;
        ignored (may be None) when ``simulator`` is given.
    duration : float
        Simulated seconds, a finite number > 0.
    progress : bool, default True
        Show the progress line on stderr (live only on a terminal) and a final summary line.
    label : str, optional
        Prefix of the progress line (default ``"simulate"``).
    integrator : str, default "runge_kutta3"
        Drake scheme name, one of :data:`INTEGRATORS` (error controlled unless fixed-step).
    accuracy : float, default 1e-4
        Target accuracy of the error-controlled integrator.
    max_step : float, default 0.05
        Maximum step size (s); also bounds how far a time-profiled discontinuity can be
        overstepped before the error control notices it.  Applied with a relative slack of
        :data:`MAX_STEP_SLACK`: a ``max_step`` equal to (or dividing) the period of a sampled
        controller or log sink otherwise ends many steps a few ulp short of the event time,
        and the integrator then takes an extra full step of ~1e-16 s to reach it (measured:
        10–20 wasted RK3 steps per simulated second in the tilt-rotor missions).
    simulator : Simulator, optional
        Reuse an existing Simulator (e.g. in sweeps); its own context is advanced and
        ``context`` is ignored.
    wall_time_limit : float, optional
        Bound on the wall-clock seconds this call may take; past it the simulation stops and
        :class:`SimulationTimeout` is raised (the context keeps the state reached,
        ``error.simulated`` the simulated time).  ``None`` (default): no bound, but then at
        most :data:`MAX_STEPS_UNBOUNDED` steps of ``max_step`` are accepted.

    Returns
    -------
    Simulator
        Its context holds the final state; logs are in the diagram's sinks.
    """
    duration = positive_scalar("duration", duration)
    one_of("integrator", integrator, INTEGRATORS)
    accuracy = positive_scalar("accuracy", accuracy)
    max_step = positive_scalar("max_step", max_step)
    if wall_time_limit is not None:
        wall_time_limit = positive_scalar("wall_time_limit", wall_time_limit)
    if simulator is not None and not isinstance(simulator, Simulator):
        raise TypeError(f"simulator must be a pydrake Simulator or None, got {type(simulator).__name__}")
    if simulator is None and not isinstance(context, Context_[float]):
        raise TypeError("context must be the root Context of diagram (diagram.CreateDefaultContext()), "
                        f"got {type(context).__name__}; or pass simulator=")
    if not isinstance(label, str):
        raise TypeError(f"label must be a string, got {label!r}")
    if simulator is None:
        simulator = Simulator(diagram, context)
    else:  # reuse: the simulator's own context is advanced (``context`` may be None)
        context = simulator.get_mutable_context()
    ResetIntegratorFromFlags(simulator, integrator, float(max_step) * (1.0 + MAX_STEP_SLACK))
    integ = simulator.get_mutable_integrator()
    if integrator not in _FIXED_STEP:  # fixed-step schemes use max_step as their step
        integ.set_target_accuracy(float(accuracy))
    if wall_time_limit is None and duration / max_step > MAX_STEPS_UNBOUNDED:
        raise ValueError(f"duration={duration:g} s with max_step={max_step:g} s means more than "
                         f"{MAX_STEPS_UNBOUNDED:.0e} integrator steps (hours to days of wall time); "
                         "pass wall_time_limit=... to run it anyway, or shorten it")
    t0 = context.get_time()
    t_end = t0 + duration
    if not math.isfinite(t_end) or t_end == t0:
        raise ValueError(f"duration {duration!r} cannot be added to the context time {t0!r} "
                         "(the sum overflows or rounds back to the start time)")
    monitor = None
    if progress or wall_time_limit is not None:
        monitor = _WallClock(t0, t_end, label=label, limit=wall_time_limit, show=progress)
        simulator.set_monitor(monitor)
    simulator.Initialize()
    try:
        simulator.AdvanceTo(t_end)
    finally:
        if monitor is not None:
            simulator.clear_monitor()
            if progress:
                monitor.finish(simulator.get_context().get_time(), simulator.get_num_steps_taken())
    if monitor is not None and monitor.expired:
        reached = simulator.get_context().get_time()
        raise SimulationTimeout(f"simulate: wall_time_limit={wall_time_limit:g} s reached at simulated "
                                f"t = {reached:.6g} s of {t_end:.6g} s", reached)
    return simulator
