"""Run a diagram with Drake's Simulator, an error-controlled integrator and a progress line.

:func:`simulate` is what every experiment uses.  The progress monitor (``Simulator.set_monitor``)
rewrites one line on stderr at most every 0.5 s of wall time when stderr is a terminal, and
always prints one final summary line (simulated time, wall time, steps) unless
``progress=False``.

The same monitor guards the run.  Drake's error control (``IntegratorBase::
CalcAdjustedStepSize``, drake 1.51) answers a NaN or infinite error estimate by shrinking the
step tenfold and retrying, on a branch that skips the minimum-step check
(``set_requested_minimum_step_size``, ``set_throw_on_minimum_step_size_violation``) every
finite estimate passes.  If the derivative at the *start* of a step is not finite (a NaN state,
or a NaN derivative of a finite state), every retry is NaN again, the step underflows to 0 and
the integrator retries forever inside one step of ``AdvanceTo``, where no monitor runs and no
wall-clock check can fire.  If only a later stage is non-finite (a derivative that turns NaN at
some t*), the retries succeed, but the accepted steps close in on t* and then stop advancing
time, forever.  And a NaN in a state entry that is not the first of its group can pass the
error norm unnoticed (Eigen's max-norm skips it): the run "succeeds" with NaN states.

So :func:`simulate` refuses a non-finite initial state, and after every step its monitor
checks that the state and the derivative the next step starts from are finite, that time still
advances (:data:`STALL_STEPS`), that the step budget (``max_steps``) and ``wall_time_limit``
are not spent.  With a finite first stage a step always ends (at the latest when its size
underflows to 0 every stage equals the first), so every check is reached.  The derivative
check costs one evaluation (Drake drops the cached value when a step starts), so it is skipped
where a periodic discrete update starts the next step (it changes the derivative anyway): the
tilt-rotor mission, stepping at its 100 Hz controller updates, checks 3 of 2004 steps in 20 s.
Out of reach of any monitor: a discrete or unrestricted update that makes the derivative
non-finite.
"""

from __future__ import annotations

import math
import numbers
import sys
import time

import numpy as np
from pydrake.systems.analysis import ResetIntegratorFromFlags, Simulator
from pydrake.systems.framework import Context, Context_, Diagram, EventStatus
from tqdm import tqdm

from sobolev_drake.simulation_errors import SimulationDiverged, SimulationStalled, SimulationTimeout

from .validation import one_of, positive_scalar

__all__ = ["simulate", "SimulationTimeout", "SimulationDiverged", "SimulationStalled", "ProgressMonitor",
           "INTEGRATORS"]

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
#: default step budget of :func:`simulate`: this many steps per ``max_step`` of simulated time
#: (on average no step shorter than max_step / STEPS_PER_MAX_STEP) ...
STEPS_PER_MAX_STEP = 1000
#: ... but never fewer than this many steps in all
MIN_STEP_BUDGET = 10_000
#: consecutive steps that advance time by less than Drake's working minimum step size
#: (1e-14 s, relative to t beyond 1 s) after which :func:`simulate` reports a stall; a step
#: ending on an event is followed by at most a few such steps
STALL_STEPS = 100
# Drake's IntegratorBase::get_working_minimum_step_size(): max(1e-14, 1e-14 |t|)
_DRAKE_MIN_STEP = 1e-14
#: how Drake's IntegratorBase starts the messages of a step it gives up on
_DRAKE_GAVE_UP = ("Error control wants to select step smaller than minimum allowed",
                  "Integrator has been directed to a near zero-length step")
_SUCCESS = (EventStatus.Severity.kDidNothing, EventStatus.Severity.kSucceeded)
# one instance returned by every step of the guard (pybind copies a monitor's result into
# C++, so sharing it is safe; constructing one per step cost about a third of the guard)
_SUCCEEDED = EventStatus.Succeeded()


class ProgressMonitor:
    """Callable for ``Simulator.set_monitor``: a tqdm progress bar of simulated time on ``stream``.

    Parameters
    ----------
    t_start, t_end : float
        Simulated start and end times (s) of the run; the bar shows the fraction between them.
    label : str, optional
        Prefix of the line (default ``"simulate"``).
    stream : file-like, optional
        Where the line is written (default ``sys.stderr``).
    period : float, default 0.5
        Minimum wall-clock seconds between two redraws of the live bar (tqdm's ``mininterval``).
    live : bool, optional
        Redraw the bar during the run; default: whether ``stream`` is a terminal.  Otherwise
        only the final line is written (a log file gets one line per run).
    """

    #: tqdm's line: label, percentage, bar, simulated time, wall time, then the step count
    BAR_FORMAT = "{desc}: {percentage:5.1f}%|{bar:20}| t = {n:.3f}/{total:.3f} s  wall {elapsed}{postfix}"

    def __init__(self, t_start: float, t_end: float, *, label: str = "", stream=None, period: float = 0.5,
                 live: bool | None = None):
        self.t_start, self.t_end = float(t_start), float(t_end)
        self.label = label or "simulate"
        self.stream = stream if stream is not None else sys.stderr
        self.period = float(period)
        self.live = self.stream.isatty() if live is None and hasattr(self.stream, "isatty") else bool(live)
        self.wall0 = time.perf_counter()
        self.calls = 0
        self._span = max(self.t_end - self.t_start, 1e-12)
        self._bar = tqdm(total=self._span, desc=self.label, file=self.stream, mininterval=self.period,
                         bar_format=self.BAR_FORMAT, leave=True, dynamic_ncols=False) if self.live else None

    def __call__(self, context) -> EventStatus:
        self.calls += 1
        if self._bar is not None:
            done = min(max(context.get_time() - self.t_start, 0.0), self._span)
            self._bar.update(done - self._bar.n)     # tqdm redraws at most every `period` s
        return EventStatus.Succeeded()

    def finish(self, t: float, steps: int) -> None:
        """Write the final line (progress, simulated and wall time, steps).

        Parameters
        ----------
        t : float
            Simulated time (s) reached.
        steps : int
            Number of integrator steps taken.
        """
        done = min(max(float(t) - self.t_start, 0.0), self._span)
        postfix = f"{steps} steps"
        if self._bar is not None:
            self._bar.n = done
            self._bar.set_postfix_str(postfix, refresh=False)
            self._bar.close()                   # redraws the final state, then a newline
            self._bar = None
            return
        self.stream.write(tqdm.format_meter(done, self._span, time.perf_counter() - self.wall0,
                                            prefix=self.label, bar_format=self.BAR_FORMAT,
                                            postfix=postfix, ncols=None) + "\n")
        self.stream.flush()


def _all_finite(x) -> bool:
    """Whether every entry of the 1-D float array ``x`` is finite.  A sum of floats is finite
    only if every term is (NaN and ±inf propagate), so for short vectors (the guard's every
    step) the float sum decides and numpy's exact check runs only when it is not finite (a NaN,
    an inf or an overflow); long vectors go to numpy at once."""
    if x.size <= 64 and math.isfinite(sum(x.tolist())):
        return True
    return bool(np.isfinite(x).all())


def _state_layout(system) -> list:
    """``[(path, leaf, offset, size)]``: every leaf system with continuous state and the slice
    of the root's continuous state vector it owns (a Diagram's continuous state concatenates
    its subsystems' in subsystem order, recursively; ``DiagramContinuousState``)."""
    layout = []

    def visit(sys_, path):
        if isinstance(sys_, Diagram):
            for sub in sys_.GetSystems():
                visit(sub, f"{path}::{sub.get_name()}" if path else sub.get_name())
            return
        n = sys_.num_continuous_states()
        if n:
            offset = layout[-1][2] + layout[-1][3] if layout else 0
            layout.append((path or sys_.get_name(), sys_, offset, n))

    visit(system, "")
    return layout


def _state_name(leaf, index: int, size: int) -> str | None:
    """Name of continuous state ``index`` of ``leaf`` where Drake has one (MultibodyPlant)."""
    names = getattr(leaf, "GetStateNames", None)
    if names is None:
        return None
    try:
        names = names(False)
    except (RuntimeError, TypeError):
        return None
    return names[index] if len(names) == size else None


def _describe_entries(layout, values, symbol: str, limit: int = 4) -> tuple[str, str | None]:
    """``"x[3] = nan (subsystem 'plant', its continuous state 1 'q1'), ..."`` for the
    non-finite entries of ``values`` and the first owning subsystem's name."""
    bad = np.flatnonzero(~np.isfinite(values))
    parts, first = [], None
    for i in bad[:limit]:
        for path, leaf, offset, size in layout:
            if offset <= i < offset + size:
                first = first or path
                name = _state_name(leaf, int(i - offset), size)
                parts.append(f"{symbol}[{i}] = {float(values[i])!r} (subsystem {path!r}, its continuous state "
                             f"{i - offset}{'' if name is None else f' {name!r}'})")
                break
        else:
            parts.append(f"{symbol}[{i}] = {float(values[i])!r}")
    more = f" and {bad.size - limit} more" if bad.size > limit else ""
    return ", ".join(parts) + more, first


class _Guard(ProgressMonitor):
    """The monitor :func:`simulate` installs: it chains a monitor already set on the simulator,
    then checks after every step that the state and its derivative are finite, that time
    advances, that the step budget and the wall-clock limit are not spent, and draws the
    progress line.  A check that fails stores its exception in ``failure`` (``expired`` for
    the wall clock) and ends ``AdvanceTo`` with ``ReachedTermination``."""

    def __init__(self, system, t_start, t_end, *, limit, show, max_steps, max_step, prior, **kw):
        super().__init__(t_start, t_end, **kw)
        self.limit, self.show, self.expired = limit, show, False
        self.system, self.max_steps, self.max_step, self.prior = system, max_steps, max_step, prior
        self.layout = _state_layout(system) if system.num_continuous_states() else None
        self.failure: Exception | None = None
        self.steps = -1                 # Initialize() calls the monitor once before any step
        self._t_last, self._still = -math.inf, 0
        self._accepted = None           # (t, x, xdot) of the last step checked
        self.ticks = _periodic_updates(system)

    def _stop(self, failure: Exception) -> EventStatus:
        self.failure = failure
        return EventStatus.ReachedTermination(None, str(failure).splitlines()[0])

    def __call__(self, context) -> EventStatus:
        if self.prior is not None:      # the caller's own monitor decides first
            status = self.prior(context)
            if status.severity() not in _SUCCESS:
                return status
        self.steps += 1
        t = context.get_time()
        # a step counts as progress when it advances time by more than Drake's working minimum
        # step (error control never proposes less; only event-limited slivers are shorter)
        if t - self._t_last > min(_DRAKE_MIN_STEP * max(1.0, abs(t)), 0.5 * self.max_step):
            self._still = 0
        else:
            self._still += 1
        self._t_last = t
        if self.layout is not None:
            x = context.get_continuous_state_vector().CopyToVector()
            if not _all_finite(x):
                text, sub = _describe_entries(self.layout, x, "x")
                return self._stop(SimulationDiverged(
                    f"simulate: the continuous state is not finite at t = {t:.9g} s: {text}", t, sub))
            if self._at_update(t):
                # a discrete update starts the next step and changes the derivative: this one
                # would cost an evaluation (~1/3 of a step) and predict nothing
                return self._finish(context, t)
            # the derivative the next step starts from: if it is not finite, that step never ends
            xdot = self.system.EvalTimeDerivatives(context).get_vector().CopyToVector()
            if not _all_finite(xdot):
                text, sub = _describe_entries(self.layout, xdot, "xdot")
                return self._stop(SimulationDiverged(
                    f"simulate: the time derivative is not finite at t = {t:.9g} s: {text}", t, sub))
            self._accepted = (t, x, xdot)
        return self._finish(context, t)

    def _at_update(self, t: float) -> bool:
        """Whether a periodic discrete update of some subsystem falls at ``t``."""
        tol = 1e-12 * max(1.0, abs(t))
        for period, offset in self.ticks:      # a loop, not any(generator): run every step
            if t >= offset and abs(t - offset - period * round((t - offset) / period)) <= tol:
                return True
        return False

    def _finish(self, context, t: float) -> EventStatus:
        if self._still >= STALL_STEPS:
            return self._stop(self._stalled(context, t))
        if self.steps >= self.max_steps:
            return self._stop(SimulationStalled(
                f"simulate: max_steps={self.max_steps} steps used up at simulated t = {t:.9g} s of "
                f"{self.t_end:.9g} s (steps of {(t - self.t_start) / max(self.steps, 1):.3g} s on average, "
                f"max_step={self.max_step:g} s): the system is stiff or nearly singular here; pass a "
                "larger max_steps=, an implicit integrator=, or fix the model", t, self.steps))
        if self.limit is not None and time.perf_counter() - self.wall0 > self.limit:
            self.expired = True
            return EventStatus.ReachedTermination(None, "wall_time_limit reached")
        return super().__call__(context) if self.show else _SUCCEEDED

    def _ahead(self, context) -> tuple[float, str, str | None] | None:
        """The first non-finite derivative just ahead of the last checked step: probed on a
        copy of ``context`` at t + h along the derivative, h from Drake's working minimum step
        up to 10 ``max_step``; ``(h, entries, subsystem)`` or None."""
        if self._accepted is None:
            return None
        t, x, xdot = self._accepted
        probe = context.Clone()
        h = _DRAKE_MIN_STEP * max(1.0, abs(t))
        while h <= 10.0 * self.max_step:
            probe.SetTime(t + h)
            probe.SetContinuousState(x + h * xdot)
            ahead = self.system.EvalTimeDerivatives(probe).get_vector().CopyToVector()
            if not np.isfinite(ahead).all():
                return (h, *_describe_entries(self.layout, ahead, "xdot"))
            h *= 10.0
        return None

    def _stalled(self, context, t: float) -> Exception:
        """Why time stopped advancing (:meth:`_ahead` finds what the integrator runs into)."""
        found = self._ahead(context)
        if found is not None:
            return _diverged_ahead(found, t, "the integrator cannot step past it "
                                   f"({STALL_STEPS} steps without advancing time)")
        return SimulationStalled(
            f"simulate: time stopped advancing at t = {t:.9g} s ({STALL_STEPS} consecutive steps shorter "
            "than Drake's minimum step size; no non-finite derivative found just ahead)", t, self.steps)

    def gave_up(self, context, error: RuntimeError) -> SimulationDiverged | None:
        """Drake's integrator gave up on a step (minimum step size, e.g. implicit schemes on a
        NaN derivative): a :class:`SimulationDiverged` naming the time and subsystem when a
        non-finite derivative lies just ahead of the last checked step, else None."""
        try:
            found = self._ahead(context)
        except Exception:  # noqa: BLE001 - the probe is a diagnosis; Drake's error is re-raised
            return None
        if found is None:
            return None
        return _diverged_ahead(found, self._accepted[0],
                               f"Drake's integrator gave up: {str(error).splitlines()[0]}")


def _diverged_ahead(found, t: float, why: str) -> SimulationDiverged:
    """The error for a non-finite derivative ``found`` (:meth:`_Guard._ahead`) just after t."""
    h, text, sub = found
    return SimulationDiverged(
        f"simulate: the time derivative turns non-finite just after t = {t:.9g} s (at t + {h:.1g} s "
        f"along the current derivative: {text}); {why}", t, sub)


def _periodic_updates(system) -> list:
    """(period, offset) of every subsystem's unique periodic discrete update (controllers)."""
    out, stack = [], [system]
    while stack:
        sub = stack.pop()
        if hasattr(sub, "GetSystems"):
            stack.extend(sub.GetSystems())
            continue
        attr = sub.GetUniquePeriodicDiscreteUpdateAttribute()
        if attr is not None and attr.period_sec() > 0:
            out.append((attr.period_sec(), attr.offset_sec()))
    return sorted(set(out))


def _check_initial_state(system, context) -> None:
    """ValueError naming the entries and subsystems of a non-finite initial continuous state."""
    if not system.num_continuous_states():
        return
    x = context.get_continuous_state_vector().CopyToVector()
    if not np.isfinite(x).all():
        text, _ = _describe_entries(_state_layout(system), x, "x")
        raise ValueError(f"context's continuous state must be finite to simulate, got {text} "
                         f"at t = {context.get_time():.9g} s")


def simulate(diagram: Diagram, context: Context | None, duration: float, *, progress: bool = True, label: str = "",
             integrator: str = "runge_kutta3", accuracy: float = 1e-4, max_step: float = 0.05,
             simulator: Simulator | None = None, wall_time_limit: float | None = None,
             max_steps: int | None = None) -> Simulator:
    """Advance ``context`` (the root context of ``diagram``) by ``duration`` seconds.

    After every step the state and the time derivative the next step starts from must be
    finite, and time must keep advancing; see the module docstring for why Drake's integrator
    would otherwise retry one step forever.  A monitor already set on ``simulator`` keeps
    running (it is called first each step and restored afterwards).

    Parameters
    ----------
    diagram : Diagram
        The system to simulate (ignored when ``simulator`` is given).
    context : Context
        Root context of ``diagram`` (``diagram.CreateDefaultContext()``), advanced in place;
        ignored (may be None) when ``simulator`` is given.  Its continuous state must be
        finite.
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
        ``error.simulated`` the simulated time).  Checked after every step.  ``None``
        (default): no bound, but then at most :data:`MAX_STEPS_UNBOUNDED` steps of
        ``max_step`` are accepted.
    max_steps : int, optional
        Step budget of this call: past it :class:`SimulationStalled` is raised.  Default:
        :data:`STEPS_PER_MAX_STEP` steps per ``max_step`` of ``duration`` (steps of
        ``max_step / STEPS_PER_MAX_STEP`` on average), at least :data:`MIN_STEP_BUDGET`.

    Returns
    -------
    Simulator
        Its context holds the final state; logs are in the diagram's sinks.

    Raises
    ------
    TypeError
        An argument of the wrong kind.
    ValueError
        A bad argument value, or a continuous state in ``context`` that is not finite (the
        message names the entries, their subsystems and, for a MultibodyPlant, the state
        names).
    SimulationDiverged
        The state, or the derivative a step would start from, is not finite at some time, or
        the derivative turns non-finite just ahead of a time the integrator cannot get past;
        the message names the simulated time and the subsystem.
    SimulationStalled
        ``max_steps`` is used up, or :data:`STALL_STEPS` consecutive steps did not advance time.
    SimulationTimeout
        ``wall_time_limit`` was reached.

    Examples
    --------
    A tiny diagram: an integrator of the reference rate q̇_r, which then follows q_r (zero
    until t = 1, then sin(π (t − 1))):

    >>> import numpy as np
    >>> import sobolev_drake as sd
    >>> from pydrake.systems.framework import DiagramBuilder
    >>> from pydrake.systems.primitives import Integrator
    >>> trajectory = sd.PiecewiseTrajectory(["x"], [[sd.const(0.0)], [sd.sine(1.0, np.pi, t0=1.0)]],
    ...                                     breakpoints=[1.0])
    >>> builder = DiagramBuilder()
    >>> reference = builder.AddSystem(sd.TrajectoryReference(trajectory))
    >>> integrator = builder.AddSystem(Integrator(1))
    >>> builder.Connect(reference.GetOutputPort("qdot_r"), integrator.get_input_port())
    >>> diagram = builder.Build()
    >>> context = diagram.CreateDefaultContext()
    >>> simulator = sd.simulate(diagram, context, 1.5, progress=False)
    >>> round(context.get_time(), 6), round(float(context.get_continuous_state_vector()[0]), 3)
    (1.5, 1.0)
    """
    duration = positive_scalar("duration", duration)
    one_of("integrator", integrator, INTEGRATORS)
    accuracy = positive_scalar("accuracy", accuracy)
    max_step = positive_scalar("max_step", max_step)
    if wall_time_limit is not None:
        wall_time_limit = positive_scalar("wall_time_limit", wall_time_limit)
    if max_steps is not None:
        if isinstance(max_steps, bool) or not isinstance(max_steps, numbers.Integral):
            raise TypeError(f"max_steps must be a positive integer or None, got {max_steps!r}")
        if max_steps < 1:
            raise ValueError(f"max_steps must be a positive integer or None, got {max_steps!r}")
    if simulator is not None and not isinstance(simulator, Simulator):
        raise TypeError(f"simulator must be a pydrake Simulator or None, got {type(simulator).__name__}")
    if simulator is None and not isinstance(context, Context_[float]):
        raise TypeError("context must be the root Context of diagram (diagram.CreateDefaultContext()), "
                        f"got {type(context).__name__}; or pass simulator=")
    if not isinstance(label, str):
        raise TypeError(f"label must be a string, got {label!r}")
    if wall_time_limit is None and duration / max_step > MAX_STEPS_UNBOUNDED:
        raise ValueError(f"duration={duration:g} s with max_step={max_step:g} s means more than "
                         f"{MAX_STEPS_UNBOUNDED:.0e} integrator steps (hours to days of wall time); "
                         "pass wall_time_limit=... to run it anyway, or shorten it")
    if simulator is None:
        simulator = Simulator(diagram, context)
    else:  # reuse: the simulator's own context is advanced (``context`` may be None)
        context = simulator.get_mutable_context()
    system = simulator.get_system()
    _check_initial_state(system, context)
    ResetIntegratorFromFlags(simulator, integrator, float(max_step) * (1.0 + MAX_STEP_SLACK))
    integ = simulator.get_mutable_integrator()
    if integrator not in _FIXED_STEP:  # fixed-step schemes use max_step as their step
        integ.set_target_accuracy(float(accuracy))
    t0 = context.get_time()
    t_end = t0 + duration
    if not math.isfinite(t_end) or t_end == t0:
        raise ValueError(f"duration {duration!r} cannot be added to the context time {t0!r} "
                         "(the sum overflows or rounds back to the start time)")
    if max_steps is None:
        max_steps = max(MIN_STEP_BUDGET, math.ceil(STEPS_PER_MAX_STEP * duration / max_step))
    prior = simulator.get_monitor()
    monitor = _Guard(system, t0, t_end, label=label, limit=wall_time_limit, show=progress,
                     max_steps=int(max_steps), max_step=max_step, prior=prior)
    simulator.set_monitor(monitor)
    try:
        simulator.Initialize()
        if monitor.failure is None:
            simulator.AdvanceTo(t_end)
    except RuntimeError as err:
        named = monitor.gave_up(simulator.get_context(), err) if str(err).startswith(_DRAKE_GAVE_UP) else None
        if named is None:
            raise
        raise named from err
    finally:
        if prior is not None:
            simulator.set_monitor(prior)
        else:
            simulator.clear_monitor()
        if progress:
            monitor.finish(simulator.get_context().get_time(), simulator.get_num_steps_taken())
    if monitor.failure is not None:
        raise monitor.failure
    if monitor.expired:
        reached = simulator.get_context().get_time()
        raise SimulationTimeout(f"simulate: wall_time_limit={wall_time_limit:g} s reached at simulated "
                                f"t = {reached:.6g} s of {t_end:.6g} s", reached)
    return simulator
