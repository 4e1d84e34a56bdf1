"""H∞ synthesis for a continuous-time generalized plant.

    xdot = A x + B1 w + B2 u,   z = C1 x + D11 w + D12 u,   y = C2 x + D21 w   (D22 = 0)

:func:`state_feedback` and :func:`output_feedback` choose between two characterizations
(``strategy.py``): Riccati equations with gamma bisection (``riccati.py``,
``hinf_riccati.py``), the default where nothing needs an LMI, and the bounded-real-lemma LMIs
described below (pole regions, polytopes, weights, initial-state objectives).

* state feedback u = K x (this module): variables X = P^-1 > 0, W = K X (the change of
  variables of (6.7));
* full-order dynamic output feedback (A_K, B_K, C_K, D_K), D_K allowed (``output_feedback.py``,
  re-exported here): Scherer, Gahinet & Chilali (1997) / Gahinet & Apkarian (1994) variables
  (X, Y, Ak, Bk, Ck, Dk), the linearized form of (6.22); the controller is reconstructed from an
  SVD factorization M N^T = I - X Y.

gamma is minimized directly (the thesis' gamma* in (6.7)/(6.22); the LMIs are written in the
symmetric gamma form, equivalent to the gamma^2 form, better conditioned). Both syntheses solve
the LMIs for an exactly rescaled plant (``scaling.py``) and map the controller back. Every
result is checked independently (``certificates.py``) on the original plant before it is
returned. When the optimum sits on the feedthrough (Parrott) bound the infimum is approached
only with unbounded gains (docs/design.md §8.2); the synthesis then re-solves at
gamma = (1 + delta) gamma_opt minimizing a gain bound, and says so in ``result.warnings``.
W∞ problems are performance channels of this plant (``sobolev.py``); LMI regions come
from ``regions.py``.
"""

from __future__ import annotations

import time
from typing import Any, Sequence

import numpy as np
from numpy.typing import ArrayLike

from .hinf_common import (COUPLING_MARGIN, EPS, certify_result, check_gamma_request, check_options,  # noqa: F401
                          compress_performance, first_lmi_attempt, note_regularized, publish_result,
                          regularization_ladder, solve_lmi_program, strict_check, validate_plants)
from .problem import (DynamicController, GeneralizedPlant, SynthesisResult, SynthesisWarning,  # noqa: F401
                      check_initial_states, transient_bound)
from .lmi import LMIProgram, SynthesisError, bmat
from .options import accepts_options
from .output_feedback import output_feedback, reconstruct_controller  # noqa: F401
from .hinf_riccati import REGULARIZE_DELTA
from .regions import LMIRegion, region_lmi
from .strategy import DEFAULT_TIME_LIMIT, check_method, lmi_only_options, synthesize
from .scaling import balance_scaling, resolve_scaling, scale_plant, unscale_gain  # noqa: F401

__all__ = ["GeneralizedPlant", "DynamicController", "SynthesisResult", "SynthesisWarning",
           "state_feedback", "output_feedback",
           "reconstruct_controller", "compress_performance", "balance_scaling", "scale_plant",
           "COUPLING_MARGIN", "EPS"]


def _sf_program(plants, *, region, gamma, input_weight, gain_bound, margin=EPS, x0=None):
    """BRL for each vertex with a common X, W; returns (prog, X, W, gamma variable or None)
    (``gamma`` None: minimized; else fixed).  With ``gain_bound`` the objective is a bound on
    |W| and |X^-1| (least gain) or, given ``x0`` (n x k, columns in the program's
    coordinates), the transient bound sum_i x0_i' X^-1 x0_i (:func:`state_feedback`).

    Symmetric gamma form [[He(AX + B2 W), B1, (C1 X + D12 W)'], [B1', -gamma I, D11'],
    [., D11, -gamma I]] (equivalent to the Schur complement of (6.5) in the gamma^2 form with
    X scaled by gamma).  Measured: the gamma^2 form fails in every backend on the two-wheeled
    classic H∞ plant with rho = 1000 (NumericalError / certificate off by 2 %); the
    gamma form solves it ("Solved", certified, Clarabel and the own IPM agree to 5e-7).
    """
    plants = [compress_performance(p) for p in plants]
    p0 = plants[0]
    n, nu = p0.n, p0.nu
    prog = LMIProgram()
    X = prog.sym(n)
    W = prog.full(nu, n)
    g = prog.scalar() if gamma is None else None
    gam = g if g is not None else float(gamma)  # variable or constant, same blocks
    prog.add_pos(X, EPS)
    for p in plants:
        Ww = np.eye(p.nw) if input_weight is None else input_weight
        gblk = -gam * Ww
        zblk = -gam * np.eye(p.nz)
        AX = p.A @ X + p.B2 @ W
        CX = p.C1 @ X + p.D12 @ W
        prog.add_lmi(bmat([[AX.sym(), p.B1, CX.T],
                           [p.B1.T, gblk, p.D11.T],
                           [CX, p.D11, zblk]]), margin)
        if region is not None:
            prog.add_lmi(region_lmi(region, X, AX), EPS)
    if gain_bound and x0 is not None:
        ts = [prog.scalar() for _ in range(x0.shape[1])]
        for t, c in zip(ts, x0.T):  # t >= c' X^-1 c (Schur complement)
            prog.add_pos(bmat([[t, c[None, :]], [c[:, None], X]]))
        prog.minimize(sum(ts[1:], ts[0]))
    elif gain_bound:
        kw, kx = prog.scalar(), prog.scalar()
        prog.add_pos(bmat([[kw * np.eye(n), W.T], [W, np.eye(nu)]]))  # W^T W <= kw I
        prog.add_pos(bmat([[X, np.eye(n)], [np.eye(n), kx * np.eye(n)]]))  # X^-1 <= kx I
        prog.minimize(kw + kx)
    else:
        prog.minimize(g)
    return prog, X, W, g



@accepts_options
def state_feedback(plant: GeneralizedPlant, *, method: str = "auto", time_limit: float | None = DEFAULT_TIME_LIMIT,
                   region: LMIRegion | None = None, backend: str | Sequence[str] | None = None,
                   solver_options: dict[str, Any] | None = None, gamma: float | None = None,
                   regularize: bool | str = "auto", delta: float | None = None, rtol: float = 1e-4,
                   verify: bool = True, input_weight: ArrayLike | None = None,
                   vertices: Sequence[GeneralizedPlant] | None = None, margin: float = EPS,
                   scaling: bool | Sequence[ArrayLike] | None = True,
                   initial_states: ArrayLike | None = None) -> SynthesisResult:
    """H∞ state feedback u = K x, certified (sign convention: u = +K x).

    Parameters
    ----------
    plant : GeneralizedPlant
        x' = A x + B1 w + B2 u, z = C1 x + D11 w + D12 u (C2, D21 unused).
    method : {"auto", "riccati", "lmi"}
        Which characterization computes the controller (``strategy.py``): "auto" uses the
        Riccati equation with gamma bisection when the problem allows it and the LMI otherwise
        (pole regions, vertices, input weights, initial states, a named backend).
    time_limit : float or None
        Budget in seconds for the whole call (default 30); None: no limit.
    region, vertices, input_weight, initial_states, backend, solver_options, margin
        LMI-only options, described below.
    gamma : float, optional
        Level to reach instead of the optimum.
    regularize : {"auto", True, False}
        Relax gamma to (1 + delta) gamma_opt for bounded gains: "auto" when the optimum sits on
        the feedthrough bound, the problem is singular or the optimum's controller fails its
        certificate; True always; False never.
    delta : float, optional
        Relaxation of a regularized gamma to (1 + delta) x the optimum.  None (default): 1e-2
        where the optimum sits on the feedthrough bound or the LMI path regularizes; on singular
        problems (D12 rank deficient) the Riccati path's levels 5e-4, 9e-4, 3e-3, 1e-2, 5e-2
        above the estimated infimum, the first whose controller has no pole faster than 1e4 x
        the plant's fastest mode (``hinf_riccati.SINGULAR_LEVELS``, ``POLE_LIMIT``).
    rtol : float
        Relative tolerance of the certificate.
    verify : bool
        Raise :class:`SynthesisError` if the final certificate fails (default True).
    scaling : bool or tuple
        Exact balancing of the plant before solving (below).
    options : SynthesisOptions, optional
        The shared knobs in one value (:class:`~sobolev_drake.synthesis.options.SynthesisOptions`);
        a keyword given beside it must agree with it.

    Returns
    -------
    SynthesisResult
        ``K`` (u = K x), certified ``gamma``, ``gamma_opt``, ``certificate``, ``method``,
        ``warnings``, ``attempts``.

    Notes
    -----
    Riccati path (``riccati.py``): gamma bisection to 1e-6 relative, the gain at
    (1 + 2e-5) x the bisection's upper end (singular problems, D12 rank deficient: see
    ``hinf_riccati.py``).

    LMI path (thesis (6.5)/(6.7) in the symmetric gamma form):
    ``vertices``: optional list of extra plants sharing one Lyapunov matrix (polytopic,
    Corollary 1). ``input_weight``: replaces I in the -gamma I block of w (i.e. -gamma^2 I in
    (6.5)) (used by the thesis' disturbance-model LMI (6.31)).  Regularizing re-solves minimize
    a gain bound at (1 + delta) gamma_opt.
    ``scaling``: True (default) solves the LMI in balanced coordinates (``balance_scaling``:
    exact diagonal state similarity and input scaling, gamma unchanged) and maps K, X, P back;
    a tuple (T, Su) gives the scalings; False solves in the given coordinates.  The
    certificate is always computed in the original coordinates.  ``backend``: None (default:
    direct Clarabel, Drake/Clarabel then CSDP if it fails), "auto" (own IPM first, kept only if
    its result passes the certificate and the bounded-real test of P, else the default chain;
    4-8x faster on 12-20 states, see ``benchmarks/synthesis.py``), one of ``lmi.BACKENDS``,
    or a sequence of those tried in order (e.g. ``("ipm", "clarabel")``: "auto" without Drake's
    single-threaded fallbacks, which take tens of minutes on 28-state output feedback);
    ``result.backend`` / ``result.fallback`` say what produced the result.

    ``initial_states``: x0 (n,) or columns x0_i (n, k).  Changes the secondary objective used
    at a fixed gamma (``gamma`` given, or the regularizing re-solve at (1+delta) gamma_opt)
    from the least-gain bound to the guaranteed transient cost sum_i x0_i' P x0_i, which
    bounds sum_i ||z||^2 of the responses to x(0) = x0_i with w = 0 (the mixed H2/H∞
    idea with a common Lyapunov matrix).  On problems whose optimum sits on the feedthrough
    bound, gamma hardly constrains the closed loop and the least-gain controller can be
    lightly damped; this picks, among the controllers with the same certified gamma, one
    whose transient from the given states is small.  ``result.transient_bound`` reports the
    bound (gamma^2 normalization of P).
    """
    check_options(plant, delta=delta, rtol=rtol, margin=margin, regularize=regularize,
                  region=region, backend=backend, solver_options=solver_options,
                  input_weight=input_weight)
    check_method(method, time_limit)
    features = lmi_only_options(region=region, vertices=vertices, input_weight=input_weight,
                                initial_states=initial_states, backend=backend,
                                solver_options=solver_options, margin=margin)
    if not features:
        check_gamma_request(gamma, np.linalg.norm(plant.D11, 2) if plant.D11.size else 0.0)

    def lmi(regularize, verify, deadline):
        return _lmi_state_feedback(plant, region=region, backend=backend,
                                   solver_options=solver_options, gamma=gamma,
                                   regularize=regularize, delta=REGULARIZE_DELTA if delta is None else delta, rtol=rtol, verify=verify,
                                   input_weight=input_weight, vertices=vertices, margin=margin,
                                   scaling=scaling, initial_states=initial_states,
                                   deadline=deadline)
    return synthesize(plant, "state_feedback", lmi, method=method, time_limit=time_limit,
                      lmi_features=features, gamma=gamma, delta=delta, rtol=rtol, verify=verify,
                      scaling=scaling, regularize=regularize, region=region)


def _lmi_state_feedback(plant, *, region, backend, solver_options, gamma, regularize, delta,
                        rtol, verify, input_weight, vertices, margin, scaling, initial_states,
                        deadline):
    """The LMI path of :func:`state_feedback` (options checked by the caller)."""
    plants = [plant] + list(vertices or [])
    if not all(isinstance(v, GeneralizedPlant) for v in plants):
        raise TypeError("vertices must be a list of GeneralizedPlant objects")
    if any(tuple(M.shape for M in p.as_tuple()) != tuple(M.shape for M in plant.as_tuple())
           for p in plants):
        raise ValueError("all vertex plants must have the same dimensions")
    fb = max(np.linalg.norm(p.D11, 2) if p.D11.size else 0.0 for p in plants)  # SF: D_cl = D11
    check_gamma_request(gamma, fb)
    timings, warns = {}, []
    t0 = time.perf_counter()
    T, Su = resolve_scaling(scaling, plants)
    X0 = check_initial_states(initial_states, plant.n)
    sx0 = None if X0 is None else X0 / T[:, None]  # x = T x~
    splants = [scale_plant(p, T, Su) for p in plants]
    validate_plants(splants, False)  # stabilizability is invariant; its rank test is not: test balanced
    prog, X, W, gv = _sf_program(splants, region=region, gamma=gamma, input_weight=input_weight,
                                 gain_bound=gamma is not None, margin=margin, x0=sx0)
    gval = (lambda o: float(max(gv.value(o.x)[0, 0], 0.0))) if gamma is None else (lambda o: float(gamma))
    lam = g_opt = None  # gamma in the LMI solved last; LMI optimum

    def check(o):  # certificate of the candidate optimum (automatic backend chain)
        nonlocal lam, g_opt
        lam = g_opt = gval(o)
        r = build(o, lam * (1 + 1e-6) if gamma is None else lam)
        return strict_check(r, plants, region, rtol, o.status)

    def build(out, g):
        # the gamma-form X is gamma times the gamma^2-form one (X = P^-1 of A'P + PA + C'C +
        # (PB + C'D)(gamma^2 I - D'D)^-1 (.)' < 0), which is what the result reports
        Xv = X.value(out.x) / lam
        Xv = 0.5 * (Xv + Xv.T)
        if np.linalg.eigvalsh(Xv).min() <= 0:
            raise SynthesisError(f"solver returned X not positive definite (status {out.status})")
        Ks = np.linalg.solve(Xv, W.value(out.x).T / lam).T  # K = W X^-1 (6.7), scaled coords
        K = unscale_gain(Ks, T, Su)  # u = Su Ks T^-1 x
        P = np.linalg.inv(Xv) / T[:, None] / T  # P = T^-1 Ps T^-1, X = T Xs T
        return SynthesisResult("state_feedback", g, K=K, P=P, X=T[:, None] * Xv * T, gamma_opt=g_opt,
                               feedthrough_bound=fb, solver=out.solver, backend=out.backend,
                               status=out.status, timings=timings, region=region,
                               fallback=out.extra.get("fallback", ""))

    out = solve_lmi_program(prog, backend, solver_options, timings, "lmi", check, deadline)
    g_opt = lam = gval(out)
    res, on_bound, need = first_lmi_attempt(build, out, g_opt, gamma, fb, plants, region, rtol,
                                         regularize, warns, delta)
    if need:
        def solve_at(g):
            prog2, X2, W2, _ = _sf_program(splants, region=region, gamma=g, input_weight=input_weight,
                                           gain_bound=True, margin=margin, x0=sx0)
            nonlocal X, W, lam
            X, W, lam = X2, W2, g

            def check2(o):
                return strict_check(build(o, g), plants, region, rtol, o.status)
            r = build(solve_lmi_program(prog2, backend, solver_options, timings, "regularize", check2,
                             deadline), g)
            return certify_result(r, plants, region, rtol, False, r.status)
        res, d = regularization_ladder(solve_at, g_opt, delta, on_bound or regularize is True, res)
        what = "the transient bound from initial_states" if X0 is not None else "a bound on the gain"
        note_regularized(warns, on_bound,
                         f"regularized: gamma relaxed to (1+{d:g}) x {g_opt:.6g} = {res.gamma:.6g} "
                         f"minimizing {what} (|K| = {np.linalg.norm(res.K, 2):.4g})")
    if X0 is not None:
        res = res.replace(transient_bound=transient_bound(res, X0))
    if np.linalg.norm(res.K, 2) > 1e6:
        warns.append(f"very large gain |K| = {np.linalg.norm(res.K, 2):.3g}")
    return publish_result(res, warns, t0, plants, region, rtol, verify)
