"""The Riccati path's certificate and Lyapunov matrix at the floor's cost (issue 36): the norm
from SLICOT's ab13dd re-checked by the own code, P from the n-state error Riccati equation.
Speed is measured in ``benchmarks/synthesis_floor.py``; here only facts that could fail."""

import warnings

import numpy as np
import pytest

from sobolev_drake.synthesis import certificates
from sobolev_drake.synthesis.certificates import brl_residual, certify_closed_loop, hinf_norm
from sobolev_drake.synthesis.hinf import output_feedback, state_feedback
from sobolev_drake.synthesis.random_plants import random_plant

pytest.importorskip("slycot")

#: hinf_norm returns a lower bound within (1 + 2e-7) of the norm, ab13dd is asked for 1e-10
NORM_AGREEMENT = 3e-7


def stable_system(rng, n, m=2, p=3, damping=None):
    A = rng.normal(size=(n, n)) / np.sqrt(n)
    A -= (np.linalg.eigvals(A).real.max() + (0.3 if damping is None else damping)) * np.eye(n)
    return A, rng.normal(size=(n, m)), rng.normal(size=(p, n)), rng.normal(size=(p, m))


@pytest.mark.parametrize("seed, damping", [(0, None), (1, None), (2, 1e-3), (3, 1e-2)])
def test_certificate_norm_agrees_with_the_own_hamiltonian_iteration(seed, damping):
    """Lightly damped systems (sharp peaks) included: the two norms are independent codes."""
    A, B, C, D = stable_system(np.random.default_rng(seed), 12, damping=damping)
    cert = certify_closed_loop(A, B, C, D, 1e9)
    own = hinf_norm(A, B, C, D)[0]
    assert cert.achieved == pytest.approx(own, rel=NORM_AGREEMENT)
    assert cert.achieved >= own * (1 - 1e-9)  # lower bounds, ~1e-10 rounding


def test_a_wrong_slicot_answer_is_caught_by_the_own_check(monkeypatch):
    """ab13dd's value must be reproduced by the gain at its peak frequency and may not be below
    the gain at 0: an underestimate (the unsafe direction) falls back to the own iteration."""
    A, B, C, D = stable_system(np.random.default_rng(4), 8)
    own = hinf_norm(A, B, C, D)[0]
    for wrong in [(0.5 * own, 1.0), (own, 1e6), (np.nan, 0.0)]:
        monkeypatch.setattr(certificates, "_slicot_norm", lambda *a, w=wrong: w)
        assert certify_closed_loop(A, B, C, D, 1e9).achieved == pytest.approx(own, rel=1e-12)
    monkeypatch.setattr(certificates, "_slicot_norm", lambda *a: None)  # no slycot
    assert certify_closed_loop(A, B, C, D, 1e9).achieved == pytest.approx(own, rel=1e-12)


def stabilizing_brl_solution(cl, P, level):
    """(backward error, its bound, spectral abscissa of the feedback) of P for the closed loop
    ``cl``'s bounded-real Riccati equation at ``level``.

    The backward error is the residual's largest entry over the largest entry of the sum of its
    terms' magnitudes.  Bound: the gains and P are computed in floating point (relative
    rounding ~ eps per operation on 2n-state data), amplified by κ = max(cond(V), ||A_F|| /
    min |Re λ(A_F)|): the conditioning of the loop's eigenvector basis, or that of the Riccati
    equation itself, whose Lyapunov operator in A_F = Acl + Bcl F has separation ~ 2 min
    |Re λ(A_F)| — small when ``level`` sits near the loop's norm.  A correct P has backward
    error <= 2n eps κ (measured 3e-16 ... 1.3e-13 on the plants below, 2 to 5 orders under the
    bound; on the near-norm P of test_riccati_shortcuts.py 2e-11 to 1.1e-10 across OpenBLAS
    kernel families, with min |Re λ(A_F)| = 1.2e-6 ||A_F||); a wrong P (another solution, a
    stale block) leaves a backward error of order 1.  The stabilizing solution is the one whose
    A_F is Hurwitz (unique)."""
    Acl, Bcl, Ccl, Dcl = cl
    R = Dcl.T @ Dcl - level ** 2 * np.eye(Bcl.shape[1])
    F = -np.linalg.solve(R, Bcl.T @ P + Dcl.T @ Ccl)
    resid = Acl.T @ P + P @ Acl + Ccl.T @ Ccl + (P @ Bcl + Ccl.T @ Dcl) @ F
    a = np.abs
    terms = a(Acl).T @ a(P) + a(P) @ a(Acl) + a(Ccl).T @ a(Ccl) \
        + (a(P) @ a(Bcl) + a(Ccl).T @ a(Dcl)) @ a(F)
    AF = Acl + Bcl @ F
    ev = np.linalg.eigvals(AF)
    kappa = max(np.linalg.cond(np.linalg.eig(Acl)[1]),
                np.linalg.norm(AF, 2) / max(np.abs(ev.real).min(), np.finfo(float).tiny))
    tol = Acl.shape[0] * np.finfo(float).eps * kappa
    return a(resid).max() / terms.max(), tol, ev.real.max()


def riccati_data(res, plant, P):
    """:func:`stabilizing_brl_solution` at the design level (res.gamma = level (1 + 1e-6),
    hinf_riccati._result)."""
    return stabilizing_brl_solution(res.closed_loop(plant), P, res.gamma / (1 + 1e-6))


@pytest.mark.parametrize("family, seed", [("stable", 0), ("lightly_damped", 2),
                                          ("feedthrough", 3), ("unstable", 2),
                                          ("ill_conditioned", 4)])
@pytest.mark.parametrize("kind", ["output_feedback", "state_feedback"])
def test_reported_p_is_the_closed_loops_stabilizing_riccati_solution(family, seed, kind):
    """P from the separation structure (X and the error block's n-state Riccati solution)
    is the stabilizing solution of the 2n-state closed loop's bounded-real Riccati equation
    (checked here: residual and stability of its feedback) and satisfies the bounded-real
    inequality checked on its own; the certificate's norm agrees with the own
    Hamiltonian iteration."""
    plant = random_plant(np.random.default_rng([36, 14, seed]), 14, family).plant
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = (output_feedback if kind == "output_feedback" else state_feedback)(plant)
    assert res.method == "riccati" and res.certificate.ok
    cl = res.closed_loop(plant)
    own = hinf_norm(*cl)[0]
    # on closed loops with condition numbers ~1e9 the gains themselves carry ~1e-7 rounding
    # (measured: ab13dd 3e-7 above the own lower bound on the unstable plant); never below it
    assert res.certificate.achieved == pytest.approx(own, rel=1e-6)
    assert res.certificate.achieved >= own * (1 - 1e-9)  # both lower bounds, ~1e-10 rounding
    assert res.P is not None
    assert brl_residual(*cl, res.P, res.gamma) <= 1e-7  # hinf_common.BRL_TOL
    resid, tol, stab = riccati_data(res, plant, res.P)
    assert resid <= tol, (resid, tol)
    assert stab < 0
