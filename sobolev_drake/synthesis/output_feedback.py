"""Full-order dynamic output-feedback H∞ synthesis (controller feedthrough allowed).

Scherer, Gahinet & Chilali (1997) / Gahinet & Apkarian (1994) linearizing variables
(X, Y, Ak, Bk, Ck, Dk): the bounded-real-lemma LMI of the closed loop becomes linear (the
linearized form of thesis (6.22)); pole regions use (6.40).  The controller is reconstructed
from M N^T = I - X Y (:func:`reconstruct_controller`).  The LMI is solved for an exactly
rescaled plant (``scaling.py``: states, inputs and measurements; w and z untouched) and the
controller is mapped back and certified on the original plant.
"""

from __future__ import annotations

import time
from typing import Any, Sequence

import numpy as np
from numpy.typing import ArrayLike

from .certificates import parrott_bound
from .hinf_common import (COUPLING_MARGIN, EPS, certify_result, check_gamma_request, check_options,
                          compress_performance, first_lmi_attempt, note_regularized, publish_result,
                          regularization_ladder, solve_lmi_program, strict_check, validate_plants)
from .problem import (DynamicController, GeneralizedPlant, SynthesisResult, check_initial_states,
                      transient_bound)
from .lmi import Affine, LMIProgram, SynthesisError, bmat
from .hinf_riccati import REGULARIZE_DELTA
from .regions import LMIRegion, region_lmi
from .scaling import resolve_scaling, scale_plant, unscale_controller
from .strategy import DEFAULT_TIME_LIMIT, check_method, lmi_only_options, synthesize
from .options import accepts_options

__all__ = ["reconstruct_controller", "singular_problem", "output_feedback"]


# --------------------------------------------------------------------------- output feedback
def _of_program(p, *, region, gamma, input_weight, gain_bound, strictly_proper, margin=EPS,
                x0=None, gain_weight=0.0):
    """LMI program in the linearizing variables; returns (prog, variables, gamma variable)
    (``gamma`` None: minimized; else fixed).  With ``gain_bound`` the objective is a bound on
    the controller variables (least gain) or, given ``x0`` (n x k, program coordinates), the
    transient bound sum_i x0_i' Y x0_i (Y = P11 of the gamma form: linear in the variables).

    The bounded-real lemma is used in its symmetric gamma form
    [[He(.), ., ., .], [., ., -gamma I, .], [., ., ., -gamma I]] (objective gamma), as in the
    state feedback: the Lyapunov variables are those of the gamma^2 form divided by gamma,
    which balances X (from P^-1) against Y (from P).  On problems whose
    infimum is approached with Y growing without bound, this measured 10x closer agreement
    between solvers on gamma_opt (tests/synthesis/test_synthesis.py random plants: worst 1.3e-4 -> 1.5e-5).
    """
    p = compress_performance(p)
    n, nu, ny = p.n, p.nu, p.ny
    prog = LMIProgram()
    X, Y = prog.sym(n), prog.sym(n)
    Ak, Bk, Ck = prog.full(n, n), prog.full(n, ny), prog.full(nu, n)
    Dk = Affine.lift(np.zeros((nu, ny))) if strictly_proper else prog.full(nu, ny)
    g = prog.scalar() if gamma is None else None
    Ww = np.eye(p.nw) if input_weight is None else input_weight
    gam = g if g is not None else float(gamma)  # variable or constant, same blocks
    gblk = -gam * Ww
    zblk = -gam * np.eye(p.nz)
    I = np.eye(n)
    AX = p.A @ X + p.B2 @ Ck
    AC = p.A + p.B2 @ Dk @ p.C2
    YA = Y @ p.A + Bk @ p.C2
    M21 = Ak + AC.T
    M31 = (p.B1 + p.B2 @ Dk @ p.D21).T
    M32 = (Y @ p.B1 + Bk @ p.D21).T
    M41 = p.C1 @ X + p.D12 @ Ck
    M42 = p.C1 + p.D12 @ Dk @ p.C2
    M43 = p.D11 + p.D12 @ Dk @ p.D21
    prog.add_lmi(bmat([[AX.sym(), M21.T, M31.T, M41.T],
                       [M21, YA.sym(), M32.T, M42.T],
                       [M31, M32, gblk, M43.T],
                       [M41, M42, M43, zblk]]), margin)
    XY = bmat([[X, I], [I, Y]])
    prog.add_pos(XY, COUPLING_MARGIN)
    if region is not None:
        prog.add_lmi(region_lmi(region, XY, bmat([[AX, AC], [Ak, YA]])), EPS)
    def gain_bound_var():  # k >= |[Ak Bk; Ck Dk]|, X <= k I, Y <= k I
        k = prog.scalar()
        Th = bmat([[Ak, Bk], [Ck, Dk]])
        m1, m2 = Th.shape
        prog.add_pos(bmat([[k * np.eye(m2), Th.T], [Th, k * np.eye(m1)]]))
        prog.add_lmi(X - k * I)
        prog.add_lmi(Y - k * I)
        return k

    if gain_bound and x0 is not None:
        terms = [c[None, :] @ Y @ c[:, None] for c in x0.T]  # sum_i x0_i' Y x0_i
        obj = sum(terms[1:], terms[0])
        if gain_weight > 0:  # tie-breaker: bounds the otherwise free X and controller variables
            obj = obj + gain_weight * gain_bound_var()
        prog.minimize(obj)
    elif gain_bound:
        prog.minimize(gain_bound_var())
    else:
        prog.minimize(g)
    return prog, (X, Y, Ak, Bk, Ck, Dk), g


def reconstruct_controller(p: GeneralizedPlant, X: np.ndarray, Y: np.ndarray, Ak: np.ndarray,
                           Bk: np.ndarray, Ck: np.ndarray, Dk: np.ndarray, rank_tol: float = 0.0
                           ) -> tuple[DynamicController, np.ndarray | None]:
    """Controller from the linearizing variables; M N^T = I - X Y by SVD (balanced factors).

    At the LMI optimum I - XY tends to be rank deficient (a lower-order controller suffices);
    the synthesis keeps it invertible with a margin on [[X, I], [I, Y]] (``COUPLING_MARGIN``),
    which costs ~1e-6 relative in gamma and avoids spurious huge/unstable controller modes.
    Optional truncation of singular values below ``rank_tol * s_max`` gives a reduced-order
    controller (approximate; the certificate decides). Returns (controller, P) with P the
    closed-loop Lyapunov matrix (None when truncated).
    """
    n = p.n
    U, s, Vt = np.linalg.svd(np.eye(n) - X @ Y)
    r = int(np.sum(s > rank_tol * max(s.max(), 1e-300)))
    if r == 0:
        raise SynthesisError("I - XY vanishes: no controller can be reconstructed")
    M = U[:, :r] * np.sqrt(s[:r])
    N = Vt[:r].T * np.sqrt(s[:r])
    Mp, Np = np.linalg.pinv(M), np.linalg.pinv(N)  # exact inverses when r = n
    DK = Dk
    CK = (Ck - DK @ p.C2 @ X) @ Mp.T
    BK = Np @ (Bk - Y @ p.B2 @ DK)
    rest = Ak - Y @ (p.A + p.B2 @ DK @ p.C2) @ X - N @ BK @ p.C2 @ X - Y @ p.B2 @ CK @ M.T
    AK = Np @ rest @ Mp.T
    P = None
    if r == n:
        Pi1 = np.block([[X, np.eye(n)], [M.T, np.zeros((n, n))]])
        Pi2 = np.block([[np.eye(n), Y], [np.zeros((n, n)), N.T]])
        P = np.linalg.solve(Pi1.T, Pi2.T).T  # P Pi1 = Pi2
        P = 0.5 * (P + P.T)
    return DynamicController(AK, BK, CK, DK), P


def singular_problem(plant: GeneralizedPlant, tol: float = 1e-9) -> str:
    """"" for a regular output-feedback problem, else which rank condition fails: D12 without
    full column rank (an input reaches z without cost) or D21 without full row rank (a
    measurement without noise, e.g. y = C x)."""
    msgs = []
    for name, M, full in (("D12", plant.D12, plant.D12.shape[1]), ("D21", plant.D21, plant.D21.shape[0])):
        s = np.linalg.svd(M, compute_uv=False) if M.size else np.zeros(0)
        r = int(np.sum(s > tol * max(1.0, s.max() if s.size else 0.0)))
        if r < full:
            msgs.append(f"rank {name} = {r} < {full}")
    return ", ".join(msgs)


@accepts_options
def output_feedback(plant: GeneralizedPlant, *, method: str = "auto", time_limit: float | None = DEFAULT_TIME_LIMIT,
                    region: LMIRegion | None = None, backend: str | Sequence[str] | None = None,
                    solver_options: dict[str, Any] | None = None, gamma: float | None = None,
                    regularize: bool | str = "auto", delta: float | None = None, rtol: float = 1e-4,
                    verify: bool = True, input_weight: ArrayLike | None = None,
                    strictly_proper: bool | None = False, margin: float = EPS,
                    scaling: bool | Sequence[ArrayLike] | None = True,
                    initial_states: ArrayLike | None = None,
                    transient_gain_weight: float = 0.0) -> SynthesisResult:
    """Full-order dynamic output-feedback H∞ synthesis, certified.

    The controller x_K' = AK x_K + BK y, u = CK x_K + DK y (sign convention: u = +(...), no
    minus sign) in ``result.controller``.

    Parameters
    ----------
    plant : GeneralizedPlant
        x' = A x + B1 w + B2 u, z = C1 x + D11 w + D12 u, y = C2 x + D21 w.
    method : {"auto", "riccati", "lmi"}
        As for :func:`~sobolev_drake.synthesis.hinf.state_feedback`.  "auto": the
        two-Riccati (Glover-Doyle) characterization with gamma bisection and the central
        controller on regular problems (D12 full column rank, D21 full row rank); on singular
        ones the LMI optimum, then a bounded-gain Riccati controller of a slightly perturbed
        plant at (1 + delta) gamma_opt (``hinf_riccati.py``); the LMI path for LMI-only
        options.
    time_limit : float or None
        Budget in seconds for the whole call (default 30); None: no limit.
    region, backend, solver_options, input_weight, strictly_proper, margin, initial_states
        LMI-only options (below and in ``state_feedback``).
    transient_gain_weight : float
        LMI path with ``initial_states`` (below).
    gamma, regularize, delta, rtol, verify, scaling, options
        As for :func:`~sobolev_drake.synthesis.hinf.state_feedback`.

    Returns
    -------
    SynthesisResult
        ``controller`` (AK, BK, CK, DK), certified ``gamma``, ``gamma_opt``,
        ``certificate``, ``method``, ``warnings``, ``attempts``.

    Notes
    -----
    LMI path: ``scaling``: True
    (default) solves the LMI for the plant in coordinates x = T x~, u = Su u~, y = Sy y~
    (``scaling.balance_scaling`` with outputs; powers of two, gamma and poles unchanged), a
    tuple (T, Su, Sy) gives them, False solves in the given coordinates.  The controller is
    mapped back to y -> u, X and Y to the original state coordinates (X = T X~ T,
    Y = T^-1 Y~ T^-1), and the certificate is computed on the original plant.
    ``initial_states``: as for state feedback, with the controller state starting at 0; the
    secondary objective sum_i x0_i' Y x0_i is linear in Y.
    ``transient_gain_weight``: w >= 0; with ``initial_states``, adds w * |x0|^2 * k to that
    objective (program coordinates), k the least-gain bound on X, Y and the controller
    variables.  The transient objective alone leaves X and (Ak, Bk, Ck, Dk) free along
    directions that do not change Y, so on singular problems the solver drifts along an
    unbounded optimal set; a small w makes the optimum attained (w = 1e-3: k costs a thousandth
    of what a uniform Y = k I would).
    """
    check_options(plant, delta=delta, rtol=rtol, margin=margin, regularize=regularize,
                  region=region, backend=backend, solver_options=solver_options,
                  input_weight=input_weight)
    if not (np.isfinite(transient_gain_weight) and transient_gain_weight >= 0):
        raise ValueError(f"transient_gain_weight must be a finite number >= 0, got {transient_gain_weight!r}")
    if not isinstance(strictly_proper, (bool, np.bool_)) and strictly_proper is not None:
        raise TypeError(f"strictly_proper must be True or False, got {strictly_proper!r}")
    check_method(method, time_limit)
    features = lmi_only_options(region=region, input_weight=input_weight,
                                initial_states=initial_states, backend=backend,
                                solver_options=solver_options, margin=margin,
                                strictly_proper=strictly_proper,
                                transient_gain_weight=transient_gain_weight)
    if not features and gamma is not None:  # the bound matters only to a requested gamma
        check_gamma_request(gamma, parrott_bound(plant.D11, plant.D12, plant.D21))

    def lmi(regularize, verify, deadline):
        return _lmi_output_feedback(plant, region=region, backend=backend,
                                    solver_options=solver_options, gamma=gamma,
                                    regularize=regularize, delta=REGULARIZE_DELTA if delta is None else delta, rtol=rtol, verify=verify,
                                    input_weight=input_weight, strictly_proper=strictly_proper,
                                    margin=margin, scaling=scaling, initial_states=initial_states,
                                    transient_gain_weight=transient_gain_weight, deadline=deadline)
    return synthesize(plant, "output_feedback", lmi, method=method, time_limit=time_limit,
                      lmi_features=features, gamma=gamma, delta=delta, rtol=rtol, verify=verify,
                      scaling=scaling, regularize=regularize, region=region)


def _lmi_output_feedback(plant, *, region, backend, solver_options, gamma, regularize, delta,
                         rtol, verify, input_weight, strictly_proper, margin, scaling,
                         initial_states, transient_gain_weight, deadline):
    """The LMI path of :func:`output_feedback` (options checked by the caller)."""
    p = plant
    fb = 0.0 if strictly_proper is None else parrott_bound(p.D11, p.D12, p.D21)
    if strictly_proper:
        fb = np.linalg.norm(p.D11, 2)
    check_gamma_request(gamma, fb)
    timings, warns = {}, []
    t0 = time.perf_counter()
    T, Su, Sy = resolve_scaling(scaling, [p], outputs=True)
    X0 = check_initial_states(initial_states, p.n)
    if transient_gain_weight > 0 and X0 is None:
        raise ValueError("transient_gain_weight > 0 needs initial_states (it weights the transient objective)")
    sp_ = scale_plant(p, T, Su, Sy)
    validate_plants([sp_], True)  # stabilizability/detectability are invariant; test the balanced plant
    x0s = None if X0 is None else X0 / T[:, None]
    kw = dict(region=region, input_weight=input_weight, strictly_proper=strictly_proper, margin=margin,
              x0=x0s, gain_weight=0.0 if x0s is None else transient_gain_weight * float(np.sum(x0s**2)))
    prog, V, gv = _of_program(sp_, gamma=gamma,
                              gain_bound=gamma is not None, **kw)
    gval = (lambda o: float(max(gv.value(o.x)[0, 0], 0.0))) if gamma is None else (lambda o: float(gamma))
    lam, g_opt = [None], None  # gamma in the LMI solved last; LMI optimum

    def check(o):  # certificate of the candidate optimum (automatic backend chain)
        nonlocal g_opt
        lam[0] = g_opt = gval(o)
        r = build(o, lam[0] * (1 + 1e-6) if gamma is None else lam[0])
        return strict_check(r, [p], region, rtol, o.status)

    def build(out, g):
        vals = [v.value(out.x) for v in V]
        Xs, Ys = 0.5 * (vals[0] + vals[0].T), 0.5 * (vals[1] + vals[1].T)
        ctrl_s, Ps = reconstruct_controller(sp_, Xs, Ys, *vals[2:])
        ctrl = unscale_controller(ctrl_s, Su, Sy)
        # reported X, Y, P in the gamma^2 normalization (P_gamma^2 = gamma P_gamma)
        Xs, Ys = Xs / lam[0], Ys * lam[0]
        P = None
        if Ps is not None:  # closed-loop state [x; x_K] = diag(T, I) [x~; x_K]
            d = 1.0 / np.concatenate([T, np.ones(Ps.shape[0] - p.n)])
            P = lam[0] * d[:, None] * Ps * d
        return SynthesisResult("output_feedback", g, controller=ctrl, P=P, X=T[:, None] * Xs * T,
                               Y=Ys / T[:, None] / T, gamma_opt=g_opt, feedthrough_bound=fb,
                               solver=out.solver, backend=out.backend, status=out.status,
                               timings=timings, region=region,
                               fallback=out.extra.get("fallback", ""))

    out = solve_lmi_program(prog, backend, solver_options, timings, "lmi", check, deadline)
    g_opt = gval(out)
    lam[0] = g_opt
    res, on_bound, need = first_lmi_attempt(build, out, g_opt, gamma, fb, [p], region, rtol,
                                         regularize, warns, delta)
    if need:
        def solve_at(g):
            prog2, V2, _ = _of_program(sp_, gamma=g, gain_bound=True, **kw)
            V[:] = V2
            lam[0] = g

            def check2(o):
                return strict_check(build(o, g), [p], region, rtol, o.status)
            r = build(solve_lmi_program(prog2, backend, solver_options, timings, "regularize", check2,
                             deadline), g)
            return certify_result(r, [p], region, rtol, False, r.status)
        V = list(V)
        res, d = regularization_ladder(solve_at, g_opt, delta, on_bound or regularize is True, res)
        what = ("the transient bound from initial_states" if X0 is not None
                else "a bound on the (scaled) controller matrices")
        note_regularized(warns, on_bound,
                         f"regularized: gamma relaxed to (1+{d:g}) x {g_opt:.6g} = {res.gamma:.6g} "
                         f"minimizing {what}")
    if not need and gamma is None:
        sing = singular_problem(p)
        if sing:
            warns.append(f"singular problem ({sing}): the optimum is generally an unattained infimum "
                         "and the controller of the LMI optimum depends on where the solver stops; "
                         "regularize=True gives the least-gain controller at (1+delta) gamma_opt")
    if X0 is not None:
        res = res.replace(transient_bound=transient_bound(res, X0))
    if res.controller.AK.shape[0] < p.n:
        warns.append(f"I - XY numerically rank deficient: controller order reduced to "
                     f"{res.controller.AK.shape[0]} (of {p.n})")
    return publish_result(res, warns, t0, [p], region, rtol, verify)
