"""Which characterization solves a synthesis call, in what order, within what time.

``method="auto"`` (default of :func:`~sobolev_drake.synthesis.hinf.state_feedback` and
:func:`~sobolev_drake.synthesis.hinf.output_feedback`):

* options only the LMIs express (a pole region, polytope vertices, an input weight, initial
  states, strictly proper controllers, a named LMI backend or solver options): the LMI path;
* regular problems: the Riccati path (``hinf_riccati.py``), the LMI path if it fails;
* singular problems: the Riccati path on slightly perturbed plants estimates the infimum
  (from above) and returns a controller with bounded gains at (1 + delta) x that estimate;
  the LMI path if it fails.  ``regularize=False`` returns the LMI optimum's controller
  instead (gains that depend on where the solver stops).

``method="riccati"`` / ``"lmi"`` force one path.  Every path certifies its controller on the
original plant; a call that finds none raises :class:`SynthesisError` listing every attempt
with its time and outcome.  ``time_limit`` bounds the whole call: no solver is started after it
and the LMI solver gets the remaining time as its own limit.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Any, Callable, Sequence

import numpy as np

from ..validation import one_of, real_scalar
from .hinf_common import certify_result, publish_result
from .hinf_riccati import (REGULARIZE_DELTA, BudgetExceeded, GammaNotReachable,
                           riccati_synthesis)
from .lmi import SynthesisError
from .riccati import rank_deficiency

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from sobolev_drake.synthesis.problem import GeneralizedPlant, SynthesisResult
    from sobolev_drake.synthesis.regions import LMIRegion

__all__ = ["DEFAULT_TIME_LIMIT", "check_method", "lmi_only_options", "synthesize"]

METHODS = ("auto", "riccati", "lmi")
DEFAULT_TIME_LIMIT = 30.0


def check_method(method: str, time_limit: float | None) -> None:
    one_of("method", method, METHODS)
    if time_limit is not None:
        real_scalar("time_limit", time_limit, low=0.0, low_open=True)


def lmi_only_options(*, margin: float | None = None, **options: Any) -> list[str]:
    """Names of the given options that only the LMI path supports: any value other than None,
    False or 0 counts (an empty vertex list does not; a bad value then gets the LMI path's
    error), and ``margin`` when it differs from the default."""
    from .hinf_common import EPS

    def given(name, v):
        if v is None or v is False:
            return False
        if name == "vertices" and isinstance(v, (list, tuple)):
            return len(v) > 0
        if isinstance(v, (int, float, np.number)):
            return v != 0
        return True
    names = [k for k, v in options.items() if given(k, v)]
    if margin is not None and margin != EPS:
        names.append("margin")
    return names


def _deadline(t0, time_limit):
    return None if time_limit is None or not np.isfinite(time_limit) else t0 + time_limit


class _Log:
    def __init__(self):
        self.entries = []

    def add(self, what, t, outcome):
        self.entries.append(f"{what}: {time.perf_counter() - t:.3g} s, {outcome}")

    def fail(self, kind, deadline):
        late = deadline is not None and time.perf_counter() > deadline
        raise SynthesisError(f"no certified {kind.replace('_', ' ')} controller"
                             + (" within the time budget" if late else "") + "; tried: "
                             + " | ".join(self.entries))


def _lmi_only(lmi, regularize, verify, t0, deadline):
    """The LMI path alone; a failure keeps its type and gains the time spent (and whether the
    budget ran out) in its message."""
    try:
        res = lmi(regularize=regularize, verify=verify, deadline=deadline)
    except SynthesisError as e:
        late = deadline is not None and time.perf_counter() > deadline
        e.args = (f"{e.args[0] if e.args else e} [LMI path: {time.perf_counter() - t0:.3g} s"
                  + (", time budget exhausted" if late else "") + "]",) + e.args[1:]
        raise
    return res.replace(attempts=[f"LMI: {time.perf_counter() - t0:.3g} s, certified gamma "
                                 f"{res.gamma:.6g}"])


#: LMI-only options under which a Riccati controller may still answer a region problem
REGION_FALLBACK_OK = {"region", "backend", "solver_options"}
#: levels (times the Riccati optimum without region) tried for a controller in the region
REGION_LEVELS = (1.1, 1.5, 2.0, 4.0, 10.0)


def _riccati_in_region(plant, of, region, delta, rtol, scaling, deadline, lmi_error):
    """Fallback when the LMI path fails on a region problem: Riccati controllers at increasing
    levels above the optimum without region (a lower bound of the optimum in it) until one
    certifies with its poles in the region.  Relaxing gamma slows the central controller down
    (measured on the benchmark's failures: all poles inside the disk from 1.1-1.5 x on).
    Returns (result, warnings) or None."""
    try:
        free, _ = riccati_synthesis(plant, of, delta=delta, rtol=rtol, scaling=scaling,
                                    deadline=deadline)
    except (SynthesisError, BudgetExceeded):
        return None
    base = free.gamma_opt
    for factor in ((1 + (REGULARIZE_DELTA if delta is None else delta)),) + REGION_LEVELS:
        if deadline is not None and time.perf_counter() > deadline:
            return None  # a requested gamma skips the Riccati path's own deadline checks
        try:
            res, warns = riccati_synthesis(plant, of, gamma=factor * base, delta=delta,
                                           rtol=rtol, scaling=scaling, deadline=deadline)
        except BudgetExceeded:
            return None  # the budget is spent: the next level would only raise it again
        except SynthesisError:
            continue
        res = certify_result(res, [plant], region, rtol, False, res.status)
        if res.certificate.ok:
            res = res.replace(region=region, gamma_opt=base, regularized=True)
            return res, warns + [
                f"the LMI path failed ({lmi_error}); returned the Riccati controller at gamma "
                f"= {factor:g} x {base:.6g}, the optimum without the region (a lower bound of "
                f"the optimum in it), whose closed-loop poles lie in the region"]
    return None


def synthesize(plant: GeneralizedPlant, kind: str, lmi: Callable[..., SynthesisResult], *,
               method: str, time_limit: float | None, lmi_features: Sequence[str],
               gamma: float | None, delta: float | None, rtol: float, verify: bool,
               scaling: bool | Sequence[ArrayLike] | None, regularize: bool | str,
               region: LMIRegion | None = None) -> SynthesisResult:
    """Dispatch one synthesis call (see the module docstring).

    ``lmi(regularize=..., verify=..., deadline=...)`` runs the LMI path with the caller's other
    options; ``lmi_features`` names the options given that only the LMI path supports.
    """
    t0 = time.perf_counter()
    deadline = _deadline(t0, time_limit)
    of = kind == "output_feedback"
    if method == "riccati" and lmi_features:
        raise ValueError(f"method='riccati' does not support {', '.join(lmi_features)}; use "
                         "method='lmi' or 'auto'")
    if (method == "auto" and gamma is None and "region" in lmi_features
            and set(lmi_features) <= REGION_FALLBACK_OK):
        # the LMI path, with a slice of the budget kept for the Riccati fallback in the region
        reserve = 0.0 if deadline is None else 0.2 * time_limit
        try:
            return _lmi_only(lmi, regularize, verify, t0,
                             None if deadline is None else deadline - reserve)
        except SynthesisError as e:
            # the reserved slice, even when the LMI solver overran its own limit
            fb_deadline = None if deadline is None else max(deadline,
                                                            time.perf_counter() + reserve)
            found = _riccati_in_region(plant, kind == "output_feedback", region, delta, rtol,
                                       scaling, fb_deadline, e)
            if found is None:
                raise
            res, warns = found
            res = res.replace(attempts=[f"LMI: failed ({e})",
                                        f"Riccati in the region: certified gamma {res.gamma:.6g}"],
                              fallback="the LMI path failed")
            return publish_result(res, warns, t0, [plant], region, rtol, verify,
                                  recertify=False)
    if method == "lmi" or (method == "auto" and lmi_features):
        return _lmi_only(lmi, regularize, verify, t0, deadline)
    singular = rank_deficiency(plant, of)
    if method == "auto" and singular and regularize is False:
        return _lmi_only(lmi, False, verify, t0, deadline)
    log = _Log()
    t = time.perf_counter()
    try:
        res, warns = riccati_synthesis(plant, of, gamma=gamma, delta=delta, rtol=rtol,
                                       scaling=scaling, regularize=regularize, deadline=deadline)
        log.add("Riccati", t, f"certified gamma {res.gamma:.6g}")
        res = res.replace(attempts=log.entries)
        return publish_result(res, warns, t0, [plant], None, rtol, verify, recertify=False)
    except GammaNotReachable:
        raise  # a mathematical answer, not a numerical failure: no fallback
    except (SynthesisError, np.linalg.LinAlgError) as e:
        # a SynthesisError includes RiccatiInfeasible ("no reachable level up to gamma =
        # 1e+16": the bisection's numerics, not a proof) and BudgetExceeded; a LinAlgError is a
        # raw "Singular matrix" from a solve on the way: the LMI path answers either
        log.add("Riccati", t, f"{type(e).__name__}: {e}" if isinstance(e, np.linalg.LinAlgError)
                else str(e))
    if method == "riccati" or (deadline is not None and time.perf_counter() > deadline):
        log.fail(kind, deadline)
    t = time.perf_counter()
    try:
        res = lmi(regularize=regularize, verify=verify, deadline=deadline)
    except SynthesisError as e:
        log.add("LMI", t, str(e))
        log.fail(kind, deadline)
    return res.replace(
        attempts=log.entries + [f"LMI: {time.perf_counter() - t:.3g} s, certified gamma "
                                f"{res.gamma:.6g}"],
        fallback="; ".join(x for x in (res.fallback, "the Riccati path failed") if x))
