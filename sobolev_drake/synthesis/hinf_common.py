"""Shared pipeline of the bounded-real-lemma syntheses (``hinf.py``, ``output_feedback.py``).

The solver call with its fallback chain, the regularizing ladder, certification of results
(``certificates.py``) and the warning/timing bookkeeping; the problem and result types are in
``problem.py``.
"""

from __future__ import annotations

import time
import warnings

from typing import Any, Callable, Sequence

import numpy as np
from numpy.typing import ArrayLike

from .certificates import (brl_residual, certify_closed_loop, check_weight, require_detectable,
                           require_stabilizable)
from ..validation import real_scalar
from .lmi import BACKENDS, InfeasibleLMIError, LMIProgram, SolveOutcome, SynthesisError
from .problem import GeneralizedPlant, SynthesisResult, SynthesisWarning
from .regions import LMIRegion

__all__ = [
    "COUPLING_MARGIN", "EPS", "check_options", "BRL_TOL",
    "compress_performance", "certify_result", "publish_result", "validate_plants",
    "check_gamma_request", "first_lmi_attempt", "regularization_ladder", "solve_lmi_program",
    "strict_check", "NORM_BRACKET",
]

COUPLING_MARGIN = 1e-6  # [[X, I], [I, Y]] >= margin I keeps I - XY invertible (see reconstruct)
EPS = 1e-7  # strictness margin of the LMIs (absolute, problems are scaled by the weights)


def check_options(plant: GeneralizedPlant, *, delta: float | None, rtol: float,
                  margin: float | None = None, regularize: bool | str = "auto",
                  region: LMIRegion | None = None, backend: str | Sequence[str] | None = None,
                  solver_options: dict[str, Any] | None = None,
                  input_weight: ArrayLike | None = None) -> None:
    """Validate the keywords shared by the syntheses, so that a bad value is named here instead
    of surfacing as solver noise (a NaN in the LMI data, an infeasible program)."""
    if not isinstance(plant, GeneralizedPlant):
        raise TypeError("plant must be a GeneralizedPlant (GeneralizedPlant.make, winf_plant, "
                        f"hinf_plant), got {type(plant).__name__}")
    if delta is not None:
        real_scalar("delta", delta, low=0.0, low_open=True)
    real_scalar("rtol", rtol, low=0.0, low_open=True)
    if margin is not None:
        real_scalar("margin", margin, low=0.0)
    if not (isinstance(regularize, bool) or regularize == "auto"):
        raise ValueError(f"regularize must be 'auto', True or False, got {regularize!r}")
    if region is not None and not isinstance(region, LMIRegion):
        raise TypeError(f"region must be an LMIRegion (regions.disk(...), half_plane(...), ...) "
                        f"or None, got {region!r}")
    if not (backend is None or isinstance(backend, (str, list, tuple))):  # names: see solve_lmi_program
        raise TypeError(f"backend must be None, a name in lmi.BACKENDS {BACKENDS} or a sequence "
                        f"of names, got {backend!r}")
    if solver_options is not None and not isinstance(solver_options, dict):
        raise TypeError(f"solver_options must be a dict of solver settings, got {solver_options!r}")
    if input_weight is not None:
        check_weight("input_weight", input_weight, plant.nw, definite=False)


def check_gamma_request(gamma: float | None, bound: float, what: str = "gamma") -> None:
    if gamma is not None:
        gamma = real_scalar(what, gamma, low=0.0, low_open=True)
    if gamma is not None and gamma <= bound * (1 + 1e-9):
        raise ValueError(f"{what}={gamma:g} is not achievable: it must exceed the feedthrough "
                         f"(Parrott) bound {bound:.6g}")


FALLBACKS = ("drake", "drake:csdp")  # tried in order when the *default* backend fails
AUTO_CHAIN = ("ipm", "clarabel", *FALLBACKS)  # backend="auto"


def solve_lmi_program(prog: LMIProgram, backend: str | Sequence[str] | None,
                      options: dict[str, Any] | None, timings: dict[str, float], label: str,
                      check: Callable[[SolveOutcome], SynthesisResult] | None = None,
                      deadline: float | None = None) -> SolveOutcome:
    """Solve the LMI program with ``backend``; None and "auto" are chains of backends.

    ``None`` (default): direct Clarabel, then on solver failure Drake/Clarabel, then CSDP.
    A sequence of backend names is a chain tried in that order, like "auto" (an own-IPM result
    is checked the same way).
    ``"auto"``: the own interior-point method ("ipm", 4-8x faster on the 20-state benchmark)
    first; its outcome is kept only if the solver reports (almost) solved *and* ``check(out)``
    (the result built from it, with :func:`strict_check`) passes; otherwise the default chain
    runs.  ``solver_options`` apply to an explicitly named backend only.  A fallback is recorded
    in ``out.status`` ("after fallback: ...") and ``out.extra["fallback"]``.

    ``deadline`` (``time.perf_counter()`` value): no backend is started after it, and Clarabel
    and the own IPM get the remaining time as their ``time_limit``.
    """
    if backend is None:
        chain = [None, *FALLBACKS]
    elif isinstance(backend, (list, tuple)):
        # an explicit chain, e.g. ("ipm", "clarabel"): "auto" without the slow Drake fallbacks
        if not backend or not all(isinstance(b, str) and b.lower() != "auto"
                                  and b.lower() in BACKENDS for b in backend):
            raise ValueError("a backend chain must be a non-empty sequence of lmi.BACKENDS "
                             f"names other than 'auto' {BACKENDS}, got {backend!r}")
        chain = list(backend)
    elif str(backend).lower() == "auto":
        chain = list(AUTO_CHAIN)
    else:
        chain = [backend]
    explicit = len(chain) == 1
    errors = []
    previous = 0.0      # wall time of the last backend tried on this program
    for b in chain:
        opts = options if explicit else None
        if deadline is not None:
            left = deadline - time.perf_counter()
            name = (b or "clarabel").lower()
            if left <= 0:
                errors.append(f"time budget exhausted before backend {name}")
                break
            if left < previous:
                # the previous backend's time on this program says the next one would most
                # likely stop on the limit without a result
                errors.append(f"{name} skipped: {left:.1f} s left, the previous backend took "
                              f"{previous:.1f} s")
                break
            if name in ("clarabel", "ipm") or (explicit and name in ("drake", "drake:clarabel")):
                # Clarabel and the own IPM stop themselves in time
                opts = {"time_limit": left, **(opts or {})}
            elif not explicit:
                # the fallbacks of the automatic chain do not stop in time: CSDP cannot be
                # stopped (measured 120 s on a 15-state region problem), Drake's Clarabel was
                # measured 4-10 s past its time_limit on 15-16-state region problems
                errors.append(f"{name} skipped: it does not keep to the time budget")
                continue
        started = time.perf_counter()
        try:
            out = prog.solve(b, opts)
        except InfeasibleLMIError as e:
            errors.append(str(e))
            previous = time.perf_counter() - started
            continue
        previous = time.perf_counter() - started
        timings[f"{label}_build"] = timings.get(f"{label}_build", 0.0) + out.build_time
        timings[f"{label}solve_lmi_program"] = timings.get(f"{label}solve_lmi_program", 0.0) + out.solve_time
        if out.success and np.all(np.isfinite(out.x)):
            why = _rejection(check, out) if b == "ipm" and not explicit and check else None
            if why is None:
                if errors:
                    out.extra["fallback"] = "; ".join(errors)
                    out.status += f" (after fallback: {out.extra['fallback']})"
                return out
            errors.append(f"{out.backend}/{out.solver}: status {out.status}, result rejected: {why}")
            continue
        errors.append(f"{out.backend}/{out.solver}: status {out.status}")
    raise InfeasibleLMIError(f"LMI problem ({label}) not solved: " + "; ".join(errors),
                             errors[-1] if errors else "")


#: certificates.hinf_norm returns a lower bound within a factor (1 + 2 rtol), rtol = 1e-7, of
#: the norm; this factor times it is an upper bound
NORM_BRACKET = 1 + 2e-7

BRL_TOL = 1e-7  # relative; Clarabel's results measure <= 1e-10 on the test plants


def _rejection(check, out):
    """None if the result built from ``out`` passes its certificate, else the reason."""
    try:
        res = check(out)
    except (SynthesisError, np.linalg.LinAlgError, ValueError) as e:
        return str(e)
    cert = res.certificate
    return None if cert.ok else "; ".join(cert.failures)


def strict_check(res: SynthesisResult, plants: Sequence[GeneralizedPlant], region: LMIRegion | None,
                 rtol: float, status: str) -> SynthesisResult:
    """Certificate of ``res`` plus the Lyapunov test: the reported P must satisfy the
    gamma^2-form bounded-real inequality of every closed loop (``brl_residual`` <= BRL_TOL).
    Used to accept a result of the automatic chain's first (own IPM) backend: its norm can
    pass while P, on degenerate problems (uncontrollable disturbance-model states), does not."""
    res = certify_result(res, plants, region, rtol, False, status)
    if res.P is not None and res.certificate.ok:
        for p in plants:
            r = brl_residual(*res.closed_loop(p), res.P, res.gamma)
            if r > BRL_TOL:
                res.certificate.failures.append(f"P violates the gamma^2-form bounded-real "
                                                f"inequality (relative eigenvalue {r:.2e})")
                break
    return res


def regularization_ladder(solve_at: Callable[[float], SynthesisResult], g_opt: float, delta: float,
                          deliberate: bool, res: SynthesisResult | None
                          ) -> tuple[SynthesisResult | None, float]:
    """Re-solve at gamma = (1+d) g_opt minimizing a gain bound.

    ``deliberate`` (feedthrough bound / user request): d = delta, then 5 delta if that re-solve
    fails or is rejected by its certificate (measured: the 20-state tilt-rotor output feedback
    at 1.01 gamma_opt, D21 = 0, flips between certified and rejected with 3e-8 changes of the
    plant; at 1.05 it certifies with the same transient bound).  Otherwise the first result
    failed its certificate for numerical reasons: try d = 1e-4, 1e-3, 1e-2 until one passes.
    """
    steps = [delta, 5 * delta] if deliberate else [1e-4, 1e-3, 1e-2]
    last = None
    for d in steps:
        try:
            r = solve_at((1 + d) * g_opt)
        except SynthesisError as e:
            last = e
            continue
        r = r.replace(regularized=True)
        if r.certificate.ok or d == steps[-1]:
            return r, d
    if last is not None:
        raise last
    return res, steps[-1]


def note_regularized(warns: list[str], on_bound: bool, text: str) -> None:
    """Append ``text`` to ``warns``; on a feedthrough-bound optimum, on the line of
    :func:`first_lmi_attempt`'s on-bound warning (one line says what was done)."""
    if on_bound and warns and "sits on the feedthrough bound" in warns[-1]:
        warns[-1] = f"{warns[-1]}; {text}"
    else:
        warns.append(text)


def compress_performance(p: GeneralizedPlant) -> GeneralizedPlant:
    """Same plant with z replaced by U^T z, U an orthonormal basis of range [C1 D11 D12].

    |z| is unchanged (the dropped components vanish identically); the W∞ channel
    has 2n rows but rank <= n + nw + nu, so the BRL block shrinks (faster SDP).
    """
    M = np.hstack([p.C1, p.D11, p.D12])
    if M.shape[0] <= M.shape[1]:
        return p
    U, sv, _ = np.linalg.svd(M, full_matrices=False)
    r = max(1, int(np.sum(sv > 1e-12 * max(sv.max(), 1e-300))))
    U = U[:, :r]
    return GeneralizedPlant(p.A, p.B1, p.B2, U.T @ p.C1, U.T @ p.D11, U.T @ p.D12, p.C2, p.D21)


def certify_result(res: SynthesisResult, plants: Sequence[GeneralizedPlant], region: LMIRegion | None,
                   rtol: float, verify: bool, status: str) -> SynthesisResult:
    certs = []
    for p in plants:
        certs.append(certify_closed_loop(*res.closed_loop(p), res.gamma, region=region, rtol=rtol, solver_status=status))
    res = res.replace(certificates=certs,
                      certificate=max(certs, key=lambda c: c.achieved) if certs else None)
    if verify:
        _raise_failed(res, status)
    return res


def _raise_failed(res, status):
    for i, c in enumerate(res.certificates):
        if not c.ok:
            where = f" (vertex {i})" if len(res.certificates) > 1 else ""
            raise SynthesisError(f"{res.kind} result from {res.backend}/{res.solver} rejected{where}: "
                                 + "; ".join(c.failures) + f" [solver status: {status}]")


def _raise_to_achieved(res, g_opt, delta, plants, region, rtol, status):
    """The optimum's controller is stable (and in the region) but its norm exceeds the solver's
    gamma_opt by more than ``rtol``: the solver stopped at a slightly infeasible point (reduced
    accuracy, or an unattained infimum where it stops somewhere along an unbounded ray).  If the
    excess is below ``delta`` -- the relaxation the regularizing ladder would cost anyway --
    keep the controller and certify it at its own achieved norm; otherwise leave it failed.

    Why a margin: the excess is solver noise (measured up to 6e-4 on the random test plants,
    depending on the CPU's BLAS kernels).  Deciding "regularize or not" at ``rtol`` = 1e-4 made
    the same problem regularized on one CPU and not on another; at ``delta`` (1e-2 by default)
    the decision sits two orders of magnitude above the noise.
    """
    c = res.certificate
    near = c.stable and c.region_ok and np.isfinite(c.achieved) and c.achieved <= g_opt * (1 + delta)
    if not near:
        return res
    # hinf_norm returns a lower bound lb with no singular value above (1 + 2e-7) lb; 1e-6 covers it
    gamma = float(c.achieved) * (1 + 1e-6)
    res = res.replace(gamma=gamma, status=(
        f"{res.status}; gamma raised to the certified norm {gamma:.6g} (the LMI optimum "
        f"{g_opt:.6g} was below it by {c.achieved / g_opt - 1:.1e})"))
    return certify_result(res, plants, region, rtol, False, status)


def first_lmi_attempt(build: Callable[[SolveOutcome, float], SynthesisResult], out: SolveOutcome,
                      g_opt: float, gamma: float | None, bound: float,
                      plants: Sequence[GeneralizedPlant], region: LMIRegion | None, rtol: float,
                      regularize: bool | str, warns: list[str], delta: float
                      ) -> tuple[SynthesisResult | None, bool, bool]:
    """Certify the unregularized optimum; decide whether the regularizing ladder must run.

    The SDP optimum is approached from above, so without a requested gamma the result is
    certified against the solver's gamma plus a 1e-6 relative slack; a stable controller whose
    norm exceeds that by less than ``delta`` is certified at its achieved norm instead
    (:func:`_raise_to_achieved`).  Returns
    (res or None, on_bound, need_regularization); re-raises the certificate failure when the
    optimum fails and regularization is not allowed.  Appends the on-bound warning to ``warns``.
    """
    first_error = None
    try:
        res = build(out, g_opt * (1 + 1e-6) if gamma is None else g_opt)
        res = certify_result(res, plants, region, rtol, False, out.status)
        if gamma is None and not res.certificate.ok:
            res = _raise_to_achieved(res, g_opt, delta, plants, region, rtol, out.status)
    except SynthesisError as e:
        first_error, res = e, None
    on_bound = bound > 0 and g_opt <= bound * (1 + 1e-3)
    if on_bound:
        warns.append(f"optimal gamma {g_opt:.6g} sits on the feedthrough bound {bound:.6g}: the "
                     f"infimum needs unbounded gains, the LMI optimum's gains depend on solver noise")
    need = regularize is True or (regularize == "auto" and gamma is None
                                  and (on_bound or res is None or not res.certificate.ok))
    if res is None and not need:
        raise first_error
    return res, on_bound, need


def publish_result(res: SynthesisResult, warns: list[str], t0: float,
                   plants: Sequence[GeneralizedPlant], region: LMIRegion | None, rtol: float,
                   verify: bool, recertify: bool = True) -> SynthesisResult:
    """Attach and emit the warnings, total time, and run the final certificate check
    (``recertify=False``: keep the certificates already computed for this gamma)."""
    res = res.replace(warnings=list(warns))
    for w in warns:
        warnings.warn(w, SynthesisWarning, stacklevel=3)  # at the caller of the public function
    if recertify or not res.certificates:
        res = certify_result(res, plants, region, rtol, verify, res.status)
    elif verify:
        _raise_failed(res, res.status)
    achieved = max((c.achieved for c in res.certificates), default=np.nan)
    if np.isfinite(achieved) and achieved * NORM_BRACKET > res.gamma:
        # within the certificate's rtol but below the closed loop's norm (an LMI solver's
        # gamma): publish the upper end of the norm's bracket, never less than the norm
        res = certify_result(res.replace(gamma=float(achieved * NORM_BRACKET)), plants, region,
                             rtol, verify, res.status)
    res.timings["total"] = time.perf_counter() - t0
    return res


def validate_plants(plants: Sequence[GeneralizedPlant], need_detectable: bool) -> None:
    p0 = plants[0]
    for p in plants:
        if tuple(M.shape for M in p.as_tuple()) != tuple(M.shape for M in p0.as_tuple()):
            raise ValueError("all vertex plants must have the same dimensions")
        if not (p.C1.any() or p.D12.any()):
            raise ValueError("the performance output z depends on neither x nor u (C1 = 0 and "
                             "D12 = 0; for W∞: Gamma0 = Gamma1 = 0): every stabilizing "
                             "controller gives the same norm, there is nothing to optimize")
        if not (p.B1.any() or p.D11.any() or (need_detectable and p.D21.any())):
            raise ValueError("the disturbance w reaches neither the state nor z (B1 = 0 and "
                             "D11 = 0" + (" and D21 = 0" if need_detectable else "") +
                             "; for W∞: D = 0): the closed-loop norm is 0 for every "
                             "stabilizing controller; use an LQR / H2 design for this plant")
        require_stabilizable(p.A, p.B2)
        if need_detectable:
            require_detectable(p.A, p.C2)

