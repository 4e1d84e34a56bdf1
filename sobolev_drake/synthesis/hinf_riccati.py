"""H∞ synthesis by Riccati equations and gamma bisection (``riccati.py``), certified.

Regular problems (D12 full column rank; for output feedback also D21 full row rank): bisection
on gamma to a relative width of ``BISECTION_RTOL``, then the Riccati controller at
``(1 + OPTIMUM_GAP) gamma_hi`` -- the state-feedback gain F2 or the central controller.

Singular problems (rank-deficient D12 or D21: an input reaching z without cost, a measurement
without noise -- every W∞ output feedback with y = C x): the infimum is generally not
attained and controllers near it have unbounded gains.  The plant is perturbed by a small cost
eps |u|^2 and/or a measurement noise eps v (:func:`perturbed_plant`); both only add channels, so
the original closed-loop norm is at most the perturbed one.  For a target level gamma_t the
largest eps of a decade ladder at which gamma_t is reachable gives the controller with the
smallest gains.  The target is (1 + delta) x a reference optimum: the LMI optimum when the
caller has it, else the Riccati optimum of the smallest perturbation tried.  By default
(``delta=None``) the target climbs ``SINGULAR_LEVELS`` -- from 5e-4 above the estimate, so within
1e-3 of the infimum -- and stops at the first level whose controller has no pole faster than
``POLE_LIMIT`` x the plant's fastest mode (a controller near an unattained infimum has gains and
poles growing without bound; measured on ``benchmarks/synthesis_singular.py``); the result's
one warning line says which level, perturbation and pole ratio were taken.

Every controller is certified on the original plant (``hinf_common.certify_result``) before it
is returned; the Lyapunov matrix P reported is the stabilizing solution of the closed loop's
bounded-real Riccati equation at the design level, else that between the design level and
the certified gamma, else the central controller's closed-form solution at the design level
(:func:`_closed_loop_lyapunov`).
"""

from __future__ import annotations

import time

from typing import Sequence

import numpy as np
from numpy.typing import ArrayLike
import scipy.linalg as sla

from .certificates import brl_residual, parrott_bound
from .hinf_common import BRL_TOL, certify_result, validate_plants
from .problem import GeneralizedPlant, SynthesisResult
from .lmi import InfeasibleLMIError, SynthesisError
from .riccati import (BudgetExceeded, RiccatiInfeasible, bisect_gamma, central_controller,
                      normalize, output_feedback_level_test, rank_deficiency,
                      state_feedback_test)
from .scaling import resolve_scaling, scale_plant, unscale_controller, unscale_gain

__all__ = ["GammaNotReachable", "perturbed_plant", "riccati_synthesis", "BudgetExceeded"]

BISECTION_RTOL = 1e-6
#: the controller is built at (1 + OPTIMUM_GAP) gamma_hi: close enough for "within 1e-4 of the
#: optimum", far enough from it that the Riccati solutions are not at their blow-up point
OPTIMUM_GAP = 2e-5
#: levels tried when the controller at the first level fails its certificate (numerically)
BACKOFF = (5e-5, 1e-4, 1e-3, 1e-2)
EPS_LADDER = tuple(10.0 ** -k for k in range(1, 9))
#: relaxation of gamma used where the infimum needs unbounded gains and ``delta`` is not given
REGULARIZE_DELTA = 1e-2
#: default levels above the estimated infimum of a singular problem, tightest first
SINGULAR_LEVELS = (5e-4, 9e-4, 3e-3, 1e-2, 5e-2)
#: fastest controller / closed-loop pole allowed by the default, times the plant's fastest mode
POLE_LIMIT = 1e4


def plant_speed(A: ArrayLike) -> float:
    """The plant's fastest mode (rad/s): max |eig A|, at least 1e-6 ‖A‖ and 1e-12."""
    A = np.asarray(A, float)
    return max(float(np.abs(np.linalg.eigvals(A)).max()), 1e-6 * np.linalg.norm(A, 2), 1e-12)


def pole_ratio(res: SynthesisResult, plant: GeneralizedPlant) -> float:
    """Fastest pole of the controller and of the closed loop / the plant's fastest mode."""
    fast = np.abs(np.linalg.eigvals(res.closed_loop(plant)[0])).max()
    if res.controller is not None and res.controller.AK.size:
        fast = max(fast, np.abs(np.linalg.eigvals(res.controller.AK)).max())
    return float(fast) / plant_speed(plant.A)


class GammaNotReachable(InfeasibleLMIError):
    """A requested gamma fails the Riccati conditions of a regular problem (below the optimum);
    an ``InfeasibleLMIError`` like the LMI path's answer to the same request."""


def perturbed_plant(p: GeneralizedPlant, eps_u: float, eps_y: float) -> GeneralizedPlant:
    """``p`` with z extended by eps_u u (if eps_u > 0) and w by a noise v entering y as
    eps_y v (if eps_y > 0).  Any controller's closed-loop norm of ``p`` is at most that of the
    perturbed plant (the perturbed channel contains the original one)."""
    A, B1, B2, C1, D11, D12, C2, D21 = p.as_tuple()
    if eps_u > 0:
        C1 = np.vstack([C1, np.zeros((p.nu, p.n))])
        D11 = np.vstack([D11, np.zeros((p.nu, D11.shape[1]))])
        D12 = np.vstack([D12, eps_u * np.eye(p.nu)])
    if eps_y > 0:
        B1 = np.hstack([B1, np.zeros((p.n, p.ny))])
        D11 = np.hstack([D11, np.zeros((D11.shape[0], p.ny))])
        D21 = np.hstack([D21, eps_y * np.eye(p.ny)])
    return GeneralizedPlant(A, B1, B2, C1, D11, D12, C2, D21)


class _Problem:
    """One synthesis problem in balanced coordinates: the level test and controller builder."""

    def __init__(self, plant, output_feedback, scaling):
        self.plant = plant
        self.of = output_feedback
        self._variants = {}
        if output_feedback:
            self.T, self.Su, self.Sy = resolve_scaling(scaling, [plant], outputs=True)
            self.scaled = scale_plant(plant, self.T, self.Su, self.Sy)
            self.bound = parrott_bound(plant.D11, plant.D12, plant.D21)
        else:
            self.T, self.Su = resolve_scaling(scaling, [plant])
            self.scaled = scale_plant(plant, self.T, self.Su)
            self.bound = np.linalg.norm(plant.D11, 2) if plant.D11.size else 0.0
        validate_plants([self.scaled], output_feedback)  # PBH tests on the balanced plant
        self.deficiency = rank_deficiency(self.scaled, output_feedback)
        s = self.scaled
        self.z_scale = np.linalg.norm(np.hstack([s.C1, s.D11, s.D12]), 2)
        self.y_scale = np.linalg.norm(np.vstack([s.B1, s.D11, s.D21]), 2)

    def variant(self, eps):
        """(scaled plant, level test, normalization) for the perturbation ``eps`` (0: the
        plant itself); built once per eps (the normalization's matrix powers were rebuilt for
        the bisection and again for every controller level)."""
        if eps not in self._variants:
            self._variants[eps] = self._variant(eps)
        return self._variants[eps]

    def _variant(self, eps):
        s = self.scaled
        if eps > 0:
            need_u = "D12" in self.deficiency
            need_y = self.of and "D21" in self.deficiency
            s = perturbed_plant(s, eps * self.z_scale if need_u else 0.0,
                                eps * self.y_scale if need_y else 0.0)
        if not self.of:
            return s, (lambda g: state_feedback_test(s, g)), None
        nrm = normalize(s)
        return s, output_feedback_level_test(nrm.plant), nrm

    def controller(self, eps, gamma):
        """Controller of the original plant reaching ``gamma`` on the eps-perturbed plant."""
        _, test, nrm = self.variant(eps)
        data = test(gamma)
        if not self.of:
            gain = unscale_gain(data[0], self.T, self.Su)
        else:
            ctrl = nrm.controller(central_controller(nrm.plant, data))
            gain = unscale_controller(ctrl, self.Su, self.Sy)
        self._storage = (gain, gamma, data)
        return gain

    def storage(self, gain):
        """Closed-form routes to the closed loop's Lyapunov matrix P for the controller
        ``gain`` last built by :meth:`controller`: (first, last), two tuples of candidates,
        functions of (A_cl, B_cl, C_cl, D_cl, level) returning a P -- ``first`` tried before
        the 2n-state solve of :func:`_closed_loop_lyapunov`, ``last`` after it (both empty
        for another gain).  The caller accepts a candidate only on its own bounded-real check
        (``brl_residual``).

        State feedback u = F2 x: the game Riccati solution X is the stabilizing solution of the
        closed loop's bounded-real Riccati equation at the design level (its closed-loop
        matrix A + B1 F1 + B2 F2 is Hurwitz).

        Central controller (state x^ estimating the scaled state x~): with the worst-case
        disturbance split off, w = F1 x~ + r, the dissipation splits into x~'X x~ and a storage
        e'Pi e of the estimation error e = x~ - x^, whose dynamics driven by r do not involve
        x~ (the separation structure of Zhou, Doyle & Glover 1996, sec. 16.8).  So
        P = S'diag(X, Pi) S with S (x, x_K) = (x~, e), for any solution Pi of the error
        block's bounded-real Riccati equation at the design level:

        1. the stabilizing one, from the n-state equation of the error block of the closed
           loop in those coordinates (one n-state solve instead of one of the 2n-state loop);
           then P is the closed loop's stabilizing solution;
        2. in closed form, Pi = level^2 Y^-1 - X (Doyle, Glover, Khargonekar & Francis 1989;
           Zhou, Doyle & Glover 1996, ch. 16: the error block is the output-estimation
           problem whose dual Riccati solution is Y (I - X Y / level^2)^-1, and its
           inverse times level^2 solves the error block's equation), no Riccati solve at all.
           It is the error block's anti-stabilizing (largest) solution, so P is a solution
           of the loop's equation but not its stabilizing one: a larger storage (a looser
           ``transient_bound``), hence last, after the 2n-state solve -- where the first
           fails (the loop's norm within rounding of the level, where the stabilizing
           solution is ill-posed), the 2n-state solve fails too and Y is well enough
           conditioned.  P >= 0 because rho(XY) < level^2."""
        kept, _, data = getattr(self, "_storage", (None, None, None))
        if kept is not gain:
            return (), ()
        Ti = 1.0 / self.T
        if not self.of:
            X = Ti[:, None] * data[1] * Ti
            return (lambda Acl, Bcl, Ccl, Dcl, level: X,), ()
        X, n = data.X, self.plant.n

        def storage_matrix(Pi):
            # S = [[diag(1/T), 0], [diag(1/T), -I]]: P = S'diag(X, Pi) S
            Pi = 0.5 * (Pi + Pi.T)
            return np.block([[Ti[:, None] * (X + Pi) * Ti, -Ti[:, None] * Pi],
                             [-Pi * Ti, Pi]])

        def stabilizing(Acl, Bcl, Ccl, Dcl, level):
            # S^-1 = [[diag(T), 0], [I, -I]]: the error block of S A_cl S^-1 and the error
            # columns of C_cl S^-1, rows of S B_cl
            A_ee = (Ti[:, None] * Acl[:n, n:] - Acl[n:, n:])  # (S A_cl)[e, x_K]
            A22 = -A_ee  # times S^-1[x_K, e] = -I
            B2 = Ti[:, None] * Bcl[:n] - Bcl[n:]
            C2 = -Ccl[:, n:]
            R = Dcl.T @ Dcl - level ** 2 * np.eye(Dcl.shape[1])
            return storage_matrix(sla.solve_continuous_are(A22, B2, C2.T @ C2, R,
                                                           s=C2.T @ Dcl))

        def closed_form(Acl, Bcl, Ccl, Dcl, level):
            # at the level the controller was built at (data.gamma), as X and Y
            return storage_matrix(data.gamma ** 2 * sla.cho_solve(sla.cho_factor(data.Y),
                                                                  np.eye(n)) - X)
        return (stabilizing,), (closed_form,)

    def optimum(self, eps, deadline):
        _, test, _ = self.variant(eps)
        return bisect_gamma(test, self.bound, rtol=BISECTION_RTOL, deadline=deadline)


def _closed_loop_lyapunov(Acl, Bcl, Ccl, Dcl, gamma, level, candidates=((), ())):
    """Lyapunov matrix P of the closed loop for the bounded-real inequality at ``gamma`` (gamma^2
    form, see ``SynthesisResult``), or None when none is found.

    Candidates, in this order: ``candidates[0]`` (built from the design's Riccati solutions,
    :meth:`_Problem.storage`: the stabilizing solution of the closed loop's bounded-real
    Riccati equation at ``level``, the controller's design level just below ``gamma``,
    without a Riccati solve of the 2n-state closed loop); the stabilizing solution of that
    2n-state equation at sqrt(level gamma), between the design level and the published gamma,
    by scipy's CARE; ``candidates[1]`` (a solution at ``level`` in closed form, not the
    stabilizing one).  A candidate is returned if it is positive semidefinite and its
    ``brl_residual`` at ``gamma`` is at most ``BRL_TOL`` (the LMI path's acceptance test):
    whichever produced it, P is accepted only on that independent check.  An accepted
    candidate is not polished by a 2n-state solve, and the 2n-state equation is solved at
    sqrt(level gamma), not at ``level``, where the loop's norm can equal the level to
    rounding: why, and how often each route answers, is measured in docs/scale.md (issue 36)."""
    mid = np.sqrt(level * gamma)

    def loop_solution(Acl, Bcl, Ccl, Dcl, level):
        return sla.solve_continuous_are(Acl, Bcl, Ccl.T @ Ccl,
                                        Dcl.T @ Dcl - mid ** 2 * np.eye(Bcl.shape[1]),
                                        s=Ccl.T @ Dcl)
    first, last = candidates
    for candidate in (*first, loop_solution, *last):
        try:
            P = candidate(Acl, Bcl, Ccl, Dcl, level)
        except (np.linalg.LinAlgError, ValueError):
            continue
        if _accepted(Acl, Bcl, Ccl, Dcl, P, gamma):
            return 0.5 * (P + P.T)
    return None


def _accepted(Acl, Bcl, Ccl, Dcl, P, gamma):
    """P finite, positive semidefinite and within ``BRL_TOL`` of the gamma^2-form bounded-real
    inequality at ``gamma`` (``brl_residual``)."""
    if P is None or not np.all(np.isfinite(P)):
        return False
    P = 0.5 * (P + P.T)
    return bool(np.linalg.eigvalsh(P).min() >= -1e-12 * np.abs(P).max()
                and brl_residual(Acl, Bcl, Ccl, Dcl, P, gamma) <= BRL_TOL)


def _result(problem, gain, level, gamma_opt, status, timings, rtol):
    """Certified result of a controller designed at ``level``.  The reported gamma is
    level (1 + 1e-6): the central controller's norm can equal its level to rounding
    (measured 3e-10 below it), and the margin keeps the bounded-real inequality of the
    reported P strict in the disturbance block."""
    p = problem.plant
    kind = "output_feedback" if problem.of else "state_feedback"
    res = SynthesisResult(kind, float(level) * (1 + 1e-6), gamma_opt=float(gamma_opt),
                          feedthrough_bound=float(problem.bound), solver="scipy CARE",
                          backend="riccati", status=status, timings=timings, method="riccati",
                          **({"controller": gain} if problem.of else {"K": gain}))
    res = certify_result(res, [p], None, rtol, False, status)
    if res.certificate.ok:
        P = _closed_loop_lyapunov(*res.closed_loop(p), res.gamma, level, problem.storage(gain))
        if P is not None:
            try:  # P^-1 where P is positive definite (Cholesky: independent of the scaling)
                Pi = sla.cho_solve(sla.cho_factor(P), np.eye(P.shape[0]))
            except np.linalg.LinAlgError:
                Pi = None
            if problem.of:
                res = res.replace(P=P, Y=P[:p.n, :p.n], X=None if Pi is None else Pi[:p.n, :p.n])
            else:
                res = res.replace(P=P, X=Pi)
    return res


def _certified_at(problem, eps, levels, gamma_opt, status, timings, rtol, deadline=None):
    """First certified controller over the increasing ``levels`` (None if none certifies).
    Raises BudgetExceeded before a retry level once ``deadline`` has passed."""
    last = None
    for i, g in enumerate(levels):
        if i and deadline is not None and time.perf_counter() > deadline:
            raise BudgetExceeded(f"time budget exhausted backing off from the optimum ({last})")
        try:
            gain = problem.controller(eps, g)
        except (RiccatiInfeasible, np.linalg.LinAlgError, ValueError) as e:
            last = f"gamma {g:.6g}: {e}"
            continue
        res = _result(problem, gain, g, gamma_opt, status, timings, rtol)
        # stricter than the certificate's rtol: the central controller reaches its level in
        # exact arithmetic, so a norm above level (1 + 1e-6) is a numerical failure -- back off
        if res.certificate.ok and res.certificate.achieved <= res.gamma:
            return res, None
        last = f"gamma {g:.6g}: " + ("; ".join(res.certificate.failures) or
                                     f"norm {res.certificate.achieved:.8g} above the level")
    return None, last


def riccati_synthesis(plant: GeneralizedPlant, output_feedback: bool, *, gamma: float | None = None,
                      delta: float | None = None, rtol: float = 1e-4,
                      scaling: bool | Sequence[ArrayLike] | None = True, regularize: bool | str = "auto",
                      reference: float | None = None, deadline: float | None = None
                      ) -> tuple[SynthesisResult, list[str]]:
    """Certified Riccati controller for ``plant`` (not yet published: no warnings emitted).

    Returns (result, warnings).  ``reference``: a known optimum (e.g. an LMI's) used as the
    target's base on singular problems instead of the Riccati estimate.  Raises SynthesisError (with the reason) when no
    certified controller is found, BudgetExceeded past ``deadline``.
    """
    t0 = time.perf_counter()
    problem = _Problem(plant, output_feedback, scaling)
    timings, warns = {}, []
    if not problem.deficiency:
        return _regular(problem, gamma, delta, rtol, regularize, timings, warns, t0, deadline)
    return _singular(problem, gamma, delta, rtol, reference, timings, warns, t0, deadline)


def _regular(problem, gamma, delta, rtol, regularize, timings, warns, t0, deadline):
    if gamma is not None:
        level = gamma / (1 + 1e-6)  # designed just below: the reported bound is then gamma
        try:
            problem.variant(0.0)[1](level)
        except RiccatiInfeasible as e:  # the Riccati conditions are necessary and sufficient
            raise GammaNotReachable(f"gamma={gamma:.6g} is not achievable: {e} (the Riccati "
                                    "conditions fail, so no stabilizing controller reaches "
                                    "it)") from None
        res, why = _certified_at(problem, 0.0, [level], np.nan,
                                 f"Riccati at gamma {gamma:.6g}",
                                 timings, rtol)
        if res is None:
            raise SynthesisError(f"gamma={gamma:.6g} is not reachable by the Riccati "
                                 f"characterization ({why})")
        timings["riccati"] = time.perf_counter() - t0
        return res, warns
    lo, hi, _, count = problem.optimum(0.0, deadline)
    timings["riccati_bisection"] = time.perf_counter() - t0
    status = (f"Riccati bisection: {count} levels, optimum in [{lo:.7g}, {hi:.7g}]")
    on_bound = problem.bound > 0 and hi <= problem.bound * (1 + 1e-3)
    delta = REGULARIZE_DELTA if delta is None else delta
    if on_bound or regularize is True:
        levels = [(1 + delta) * hi, (1 + 5 * delta) * hi]
    else:
        levels = [(1 + OPTIMUM_GAP) * hi] + [(1 + b) * hi for b in BACKOFF]
    res, why = _certified_at(problem, 0.0, levels, hi, status, timings, rtol, deadline)
    if res is None:
        raise SynthesisError(f"Riccati controllers near the optimum {hi:.6g} fail their "
                             f"certificates ({why})")
    if on_bound or regularize is True:
        res = res.replace(regularized=True)
        warns.append((f"optimal gamma {hi:.6g} sits on the feedthrough bound "
                      f"{problem.bound:.6g} (the infimum needs unbounded gains); " if on_bound
                      else "") +
                     f"regularized: gamma relaxed to {res.gamma / hi:.4g} x {hi:.6g} = "
                     f"{res.gamma:.6g} (Riccati controller away from the optimum)")
    elif res.gamma > (1 + 1e-4) * hi:
        warns.append(f"the Riccati controller at (1+{OPTIMUM_GAP:g}) x the optimum {hi:.6g} "
                     f"failed its certificate; certified at {res.gamma:.6g} instead")
    timings["riccati"] = time.perf_counter() - t0
    return res, warns


def _singular(problem, gamma, delta, rtol, reference, timings, warns, t0, deadline):
    what = problem.deficiency
    estimated = converged = False
    auto = gamma is None and delta is None
    gaps = SINGULAR_LEVELS if auto else (REGULARIZE_DELTA if delta is None else delta,)
    settle = 0.1 * gaps[0]  # the estimate settles well inside the tightest gap
    if gamma is not None:
        base = np.nan
    elif reference is not None and np.isfinite(reference):
        base = reference
    else:  # optimum of shrinking perturbations until it settles (upper bounds, decreasing)
        estimated = True
        prev = hi = None
        for eps in EPS_LADDER[1:]:
            try:
                _, g, _, _ = bisect_gamma(problem.variant(eps)[1], problem.bound,
                                          rtol=0.1 * settle, start=hi, deadline=deadline)
            except RiccatiInfeasible:
                continue
            prev, hi = hi, g
            if prev is not None and hi >= prev * (1 - settle):
                break
        if hi is None:
            raise SynthesisError(f"singular problem ({what}): no perturbation of the ladder "
                                 "has a Riccati solution")
        converged = prev is not None and hi >= prev * (1 - settle)
        base = hi if prev is None else min(prev, hi)
    targets = [gamma / (1 + 1e-6)] if gamma is not None else [(1 + d) * base for d in gaps]
    ref = ("the estimated infimum" if estimated else
           "the requested gamma" if gamma is not None else "the LMI optimum")
    found, last, tried = None, None, 0
    for target in targets:
        if found is not None and deadline is not None and time.perf_counter() > deadline:
            break  # out of time: keep the certified controller of the previous level
        tried += 1
        try:
            res, eps, why = _ladder(problem, target, base, what, timings, rtol, deadline)
        except BudgetExceeded:
            if found is None:
                raise
            tried -= 1  # this level was not finished
            break
        if res is None:
            last = why
            continue
        found = res, eps, pole_ratio(res, problem.plant)
        if not auto or found[2] <= POLE_LIMIT:
            break
    if found is None:
        raise SynthesisError(f"singular problem ({what}): no perturbation of the ladder reaches "
                             f"gamma {targets[-1]:.6g} with a certified controller ({last})")
    res, eps, ratio = found
    res = res.replace(regularized=True)
    level = "" if gamma is not None else f" = (1+{res.gamma / base - 1:.1e}) x {ref} {base:.6g}"
    note = (f"singular problem ({what}): regularized, certified gamma {res.gamma:.6g}{level}"
            + ("" if converged or not estimated else
               f" (the estimate was still decreasing at the smallest perturbation "
               f"{EPS_LADDER[-1]:g}: the infimum may be well below it)")
            + f", plant perturbed by {eps:g} (cost on u / noise on y); fastest pole "
              f"{ratio:.3g} x the plant's fastest mode")
    if auto:
        note += (f" (limit {POLE_LIMIT:g})" if ratio <= POLE_LIMIT else
                 f", above the limit {POLE_LIMIT:g} at every level up to "
                 f"(1+{gaps[tried - 1]:g}) x {ref}"
                 + ("" if tried == len(gaps) else " (time budget reached)")
                 + ": give a region (e.g. regions.disk) to bound it")
    warns.append(note)
    timings["riccati"] = time.perf_counter() - t0
    return res, warns


def _ladder(problem, target, base, what, timings, rtol, deadline):
    """(result, eps, None) for the largest perturbation of ``EPS_LADDER`` (smallest gains)
    whose controller certifies at ``target``, or (None, None, last failure)."""
    status = f"singular problem ({what}): Riccati on the perturbed plant at gamma {target:.6g}"
    last = None
    for eps in EPS_LADDER:  # largest perturbation first: smallest gains
        if deadline is not None and time.perf_counter() > deadline:
            raise BudgetExceeded("time budget exhausted in the perturbation ladder")
        res, why = _certified_at(problem, eps, [target], base, f"{status}, eps {eps:g}",
                                 timings, rtol)
        if res is not None:
            return res, eps, None
        last = why
    return None, None, last
