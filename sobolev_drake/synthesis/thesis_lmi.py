"""The thesis' W∞ LMIs (6.7) and (6.22) written out as printed, uncertified cross-checks.

:func:`winf_sf_thesis_lmi` and :func:`winf_of_thesis_lmi` solve the thesis' own variables and
return a :class:`~sobolev_drake.synthesis.problem.SynthesisResult` marked uncertified
(``method="thesis_lmi"``); the certified syntheses are in :mod:`.sobolev`, which re-exports
these two.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from ..validation import state_input_disturbance
from .certificates import as_matrix, check_weight
from .lmi import InfeasibleLMIError, LMIProgram, bmat
from .problem import SynthesisResult

__all__ = ["winf_sf_thesis_lmi", "winf_of_thesis_lmi"]


def winf_sf_thesis_lmi(A: ArrayLike, B: ArrayLike, D: ArrayLike, Gamma0: ArrayLike, Gamma1: ArrayLike,
                       backend: str | None = None) -> SynthesisResult:
    """(6.7) written out as in the thesis (variables S, R, gamma*), uncertified.

    Used to cross-check the generalized-plant formulation (same optimal gamma). Arguments as
    :func:`winf_state_feedback`; ``backend`` as :class:`~.lmi.LMIProgram`.

    Returns
    -------
    SynthesisResult
        ``method="thesis_lmi"``, ``gamma = gamma_opt`` = the LMI optimum, ``K = R S^-1``,
        ``X = S``; no certificate (``certified`` False): gamma is not a verified bound.
    """
    A, B, D = state_input_disturbance(A, B, D)
    n, nu, nw = A.shape[0], B.shape[1], D.shape[1]
    G0 = check_weight("Gamma0", Gamma0, n)
    G1 = check_weight("Gamma1", Gamma1, n)
    prog = LMIProgram()
    S, R, g = prog.sym(n), prog.full(nu, n), prog.scalar()
    prog.add_pos(S, 1e-7)
    AS = A @ S + B @ R
    prog.add_lmi(bmat([[AS.sym(), D, AS.T, S],
                       [D.T, -g * np.eye(nw), D.T, None],
                       [AS, D, -np.linalg.inv(G1), None],
                       [S, None, None, -np.linalg.inv(G0)]]), 1e-7)
    prog.minimize(g)
    out = prog.solve(backend)
    if not out.success:
        raise InfeasibleLMIError(f"(6.7) not solved: {out.status}", out.status)
    Sv = S.value(out.x)
    K = np.linalg.solve(Sv, R.value(out.x).T).T
    gamma = float(np.sqrt(g.value(out.x)[0, 0]))
    return _thesis_result("state_feedback", gamma, out, K=K, X=Sv)


def _thesis_result(kind, gamma, out, **fields):
    """The uncertified SynthesisResult of a thesis-literal LMI solve ``out``."""
    return SynthesisResult(kind=kind, gamma=gamma, gamma_opt=gamma, solver=out.solver,
                           backend=out.backend, status=out.status, method="thesis_lmi",
                           warnings=["thesis-literal LMI: gamma is the solver's optimum, "
                                     "not certified"], **fields)


def winf_of_thesis_lmi(A: ArrayLike, B: ArrayLike, C: ArrayLike, D: ArrayLike, Gamma0: ArrayLike,
                       Gamma1: ArrayLike, backend: str | None = None) -> SynthesisResult:
    """(6.22) written out as in the thesis (S, W, Bs, Cs, Df, gamma*), uncertified.

    The thesis' (2,1) block is 0: the free Gahinet-Apkarian variable Ak has been set to
    -(A + B Df C)^T, which does not change the optimum. Used to cross-check
    :func:`winf_output_feedback` (same optimal gamma), whose arguments it takes.

    Returns
    -------
    SynthesisResult
        ``method="thesis_lmi"``, ``gamma = gamma_opt`` = the LMI optimum, ``X = S``,
        ``Y = W``; no controller (the thesis reconstructs none) and no certificate.
    """
    A, B, D = state_input_disturbance(A, B, D)
    n, nu, nw = A.shape[0], B.shape[1], D.shape[1]
    C = as_matrix("C", C, (None, n))
    ny = C.shape[0]
    G0 = check_weight("Gamma0", Gamma0, n)
    G1 = check_weight("Gamma1", Gamma1, n)
    prog = LMIProgram()
    S, W = prog.sym(n), prog.sym(n)
    Bs, Cs, Df, g = prog.full(n, ny), prog.full(nu, n), prog.full(nu, ny), prog.scalar()
    I = np.eye(n)
    prog.add_pos(bmat([[S, I], [I, W]]), 1e-6)
    Psi1 = (A @ S + B @ Cs).sym()
    Psi3 = (W @ A + Bs @ C).sym()
    ABC = A + B @ Df @ C
    # rows of the lower blocks ordered (w, Gamma0, Gamma1) as in Psi6
    col_x = bmat([[np.zeros((nw, n)) + D.T], [S], [A @ S + B @ Cs]])
    col_y = bmat([[D.T @ W], [I], [ABC]])
    Psi6 = bmat([[-g * np.eye(nw), None, D.T],
                 [None, -np.linalg.inv(G0), None],
                 [D, None, -np.linalg.inv(G1)]])
    prog.add_lmi(bmat([[Psi1, np.zeros((n, n)), col_x.T],
                       [np.zeros((n, n)), Psi3, col_y.T],
                       [col_x, col_y, Psi6]]), 1e-7)
    prog.minimize(g)
    out = prog.solve(backend)
    if not out.success:
        raise InfeasibleLMIError(f"(6.22) not solved: {out.status}", out.status)
    return _thesis_result("output_feedback", float(np.sqrt(g.value(out.x)[0, 0])), out,
                          X=S.value(out.x), Y=W.value(out.x))
