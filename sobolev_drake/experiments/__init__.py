"""Registry of the thesis experiments.

Each module in this package registers one or more experiments with :func:`register`; the CLI
(`sobolev-drake list | run NAME | demo | reproduce`) discovers them with :func:`discover`, so
adding an experiment never edits a shared file.

An experiment's ``run`` callable has the signature::

    run(out_dir: pathlib.Path, *, duration: float | None, record: bool, smoke: bool) -> ExperimentResult

``smoke=True`` asks for a short version (seconds of wall time) used by the test suite.
"""

from __future__ import annotations

import importlib
from importlib import resources
import math
import pkgutil
import warnings
from dataclasses import dataclass
from typing import Callable

# the result records live with the code that saves and loads them; re-exported here for the
# experiment modules
from sobolev_drake.report import Claim, ExperimentResult
from sobolev_drake.errors import SobolevDrakeError

__all__ = ["Claim", "ExperimentResult", "Experiment", "UnknownExperimentError", "register",
           "discover", "get", "flagship", "thesis_differences", "THESIS_TABLES", "MAX_DURATION_FACTOR",
           "MIN_DURATION_FACTOR"]

#: the thesis tables whose numbers the experiments compare with ours, each explained in
#: ``thesis_differences.md`` (a test checks one section per table)
THESIS_TABLES = ("4.2", "5.3", "5.6", "5.7", "5.9", "6.1", "6.2", "6.4", "7.2")


@dataclass
class Experiment:
    name: str
    summary: str
    run: Callable[..., ExperimentResult]
    default_duration: float | None = None
    flagship: int = 0  # priority for `make demo`; the highest registered wins
    thesis_ref: str = ""
    #: longest ``duration`` the experiment accepts (s); ``None``: MAX_DURATION_FACTOR x default
    max_duration_override: float | None = None

    @property
    def max_duration(self) -> float | None:
        """Longest simulated time this experiment is meant for: its references, disturbance
        profiles and log buffers are laid out for about its default duration, so far longer
        runs only add hours of wall time (or memory for time grids) without new information."""
        if self.max_duration_override is not None:
            return self.max_duration_override
        if self.default_duration is None:
            return None
        return MAX_DURATION_FACTOR * self.default_duration


    @property
    def min_duration(self) -> float | None:
        """Shortest simulated time that still gives the experiment's indices some samples
        (shorter runs divide by empty logs): MIN_DURATION_FACTOR x its default duration."""
        return None if self.default_duration is None else MIN_DURATION_FACTOR * self.default_duration

    def check_duration(self, duration: float | None, option: str = "duration") -> None:
        """Refuse a simulated time outside [:attr:`min_duration`, :attr:`max_duration`]
        (``sobolev-drake run --duration`` and campaign cases follow the same rule).

        Parameters
        ----------
        duration : float or None
            Seconds (None: the experiment's default, always accepted).
        option : str, default "duration"
            How the message names the value (``"--duration"`` on the command line).

        Raises
        ------
        ValueError
            Naming the option, the value, the bound and the default.
        """
        low, high = self.min_duration, self.max_duration
        default = f"its default is {self.default_duration} s"   # bounds exist only with a default
        smoke = "--smoke" if option.startswith("--") else "smoke=True"
        if duration is not None and high is not None and duration > high:
            raise ValueError(f"{option} {duration:g} s is longer than experiment {self.name!r} can "
                             f"use (at most {high:g} s; {default})")
        if duration is not None and low is not None and duration < low:
            raise ValueError(f"{option} {duration:g} s is too short for experiment {self.name!r} "
                             f"(at least {low:g} s; {default}; {smoke} gives the short version)")


#: default bound on ``--duration``: this many times the experiment's default duration
MAX_DURATION_FACTOR = 10.0
#: lower bound on ``--duration``: this fraction of the experiment's default duration
MIN_DURATION_FACTOR = 0.01


REGISTRY: dict[str, Experiment] = {}


class UnknownExperimentError(SobolevDrakeError, KeyError):
    def __str__(self) -> str:  # KeyError quotes its message; we want plain text
        return self.args[0]


def register(name: str, summary: str, *, default_duration: float | None = None, flagship: int = 0,
             thesis_ref: str = "", max_duration: float | None = None
             ) -> Callable[[Callable[..., ExperimentResult]], Callable[..., ExperimentResult]]:
    """Decorator registering ``run`` as experiment ``name`` (``max_duration``: see
    :attr:`Experiment.max_duration`)."""

    if not isinstance(name, str) or not name.strip():
        raise ValueError(f"experiment name must be a non-empty string, got {name!r}")
    for label, value in (("default_duration", default_duration), ("max_duration", max_duration)):
        if value is not None and not (isinstance(value, (int, float)) and not isinstance(value, bool)
                                      and math.isfinite(value) and value > 0):
            raise ValueError(f"{label} must be a finite number of seconds > 0 or None, got {value!r}")

    def wrap(run):
        if name in REGISTRY and REGISTRY[name].run is not run:
            raise ValueError(f"experiment {name!r} registered twice")
        REGISTRY[name] = Experiment(name, summary, run, default_duration, flagship, thesis_ref,
                                    max_duration)
        return run

    return wrap


IMPORT_ERRORS: dict[str, str] = {}  # module name -> error text, for modules that failed to import


def discover() -> dict[str, Experiment]:
    """Import every module of this package so that they register themselves.

    A module that fails to import must not take the whole CLI down with it (``run X`` should
    work while an unrelated experiment ``Y`` is broken): the failure is recorded in
    :data:`IMPORT_ERRORS`, announced once with a warning, and named by :func:`get` when the
    requested experiment is missing.
    """
    for info in pkgutil.iter_modules(__path__):
        if info.name.startswith("_") or info.name in IMPORT_ERRORS:
            continue
        try:
            importlib.import_module(f"{__name__}.{info.name}")
        except Exception as exc:  # noqa: BLE001 - reported, not swallowed
            IMPORT_ERRORS[info.name] = f"{type(exc).__name__}: {exc}"
            warnings.warn(f"experiment module {info.name!r} failed to import: "
                          f"{IMPORT_ERRORS[info.name]}", RuntimeWarning, stacklevel=2)
    return REGISTRY


def get(name: str) -> Experiment:
    discover()
    if name not in REGISTRY:
        known = ", ".join(sorted(REGISTRY)) or "(none)"
        broken = "".join(f"; module {m!r} failed to import ({e})" for m, e in sorted(IMPORT_ERRORS.items()))
        raise UnknownExperimentError(f"unknown experiment {name!r}; known experiments: {known}{broken}")
    return REGISTRY[name]


def flagship() -> Experiment:
    """The experiment `make demo` runs: the highest ``flagship`` priority (> 0) registered."""
    discover()
    flag = [e for e in REGISTRY.values() if e.flagship > 0]
    if not flag:
        raise UnknownExperimentError("no flagship experiment is registered")
    return max(flag, key=lambda e: (e.flagship, e.name))


def thesis_differences() -> str:
    """Why the thesis' printed numbers differ from ours: one markdown section per table of
    :data:`THESIS_TABLES` (the readings that reproduce them, or the evidence that none exists),
    as REPRODUCTION.md prints it.

    Returns
    -------
    str
        The markdown text of ``sobolev_drake/experiments/thesis_differences.md``.
    """
    return (resources.files(__name__) / "thesis_differences.md").read_text(encoding="utf-8")
