"""Work the Riccati path skips (issue 36, benchmarks/synthesis_floor.py) without changing its
answers: the stable eigenvalues of the Hamiltonian's Schur form stand for those of A + B F
where they are clearly left of the axis, and the default output feedback's optimum agrees with
an independent bisection whose level test is scipy's CARE on the raw (unbalanced,
unnormalized) plant.  Facts only, no timing."""

import warnings

import numpy as np
import pytest
import scipy.linalg as sla

from sobolev_drake.synthesis import riccati
from sobolev_drake.synthesis.certificates import brl_residual, hinf_norm
from sobolev_drake.synthesis.hinf_riccati import riccati_synthesis
from sobolev_drake.synthesis.output_feedback import output_feedback
from sobolev_drake.synthesis.random_plants import plant_family, random_plant
from test_certificate_floor import stabilizing_brl_solution   # the same backward-error bound

FAMILIES = ("stable", "unstable", "lightly_damped", "ill_conditioned", "feedthrough")


@pytest.mark.parametrize("kind", ["output_feedback", "state_feedback"])
def test_schur_shortcut_only_where_a_plus_bf_is_hurwitz(monkeypatch, kind):
    """Every level whose Schur form vouched for A + B F (``stable`` True, no eigenvalues
    computed) is checked here by the eigenvalues of A + B F: all in the open left half plane.
    And the shortcut is actually taken (most accepted levels), so this is not vacuous."""
    seen = {"shortcut": 0, "full": 0}
    checked = riccati._checked

    def spy(A, B, Q, R, S, X, name="X", stable=False):
        X, F = checked(A, B, Q, R, S, X, name, stable)  # raises when the level is refused
        if stable:
            seen["shortcut"] += 1
            assert np.linalg.eigvals(A + B @ F).real.max() < 0
        else:
            seen["full"] += 1
        return X, F
    monkeypatch.setattr(riccati, "_checked", spy)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for case in plant_family(10, (4, 16), seed=36, families=FAMILIES):
            riccati_synthesis(case.plant, kind == "output_feedback")
    assert seen["shortcut"] > 0 and seen["shortcut"] >= seen["full"]


def test_schur_shortcut_refused_near_the_axis():
    """B = 0, Q = 0: H = diag(A, -A'), X = 0, A + B F = A.  A stable eigenvalue within
    STABLE_MARGIN ||H||_1 of the imaginary axis is not vouched for (the eigenvalues are then
    computed by _checked); one well left of it is."""
    B, Q, R, S = np.zeros((2, 1)), np.zeros((2, 2)), np.eye(1), np.zeros((2, 1))
    for slow, vouched in ((-1e-9, False), (-1e-3, True)):
        X, stable = riccati._schur_solution(np.diag([slow, -1.0]), B, Q, R, S)
        assert np.allclose(X, 0) and stable is vouched


def _care_level(p, g):
    """True when scipy's CARE finds stabilizing, PSD X and Y of the raw plant at level g with
    rho(XY) < g^2 (X and Y do not depend on the scaling or normalization of u, y, z, w)."""
    D1, Dc = np.hstack([p.D11, p.D12]), np.vstack([p.D11, p.D21])
    R = D1.T @ D1
    R[:p.nw, :p.nw] -= g * g * np.eye(p.nw)
    Rt = Dc @ Dc.T
    Rt[:p.nz, :p.nz] -= g * g * np.eye(p.nz)
    sols = []
    for A, B, Q, RR, S in ((p.A, np.hstack([p.B1, p.B2]), p.C1.T @ p.C1, R, p.C1.T @ D1),
                           (p.A.T, np.vstack([p.C1, p.C2]).T, p.B1 @ p.B1.T, Rt, p.B1 @ Dc.T)):
        try:
            X = sla.solve_continuous_are(A, B, Q, RR, s=S)
        except (np.linalg.LinAlgError, ValueError):
            return False
        X = 0.5 * (X + X.T)
        G = B.T @ X + S.T
        F = -np.linalg.solve(RR, G)
        resid = A.T @ X + X @ A + Q + G.T @ F
        scale = 2 * np.linalg.norm(A.T @ X) + np.linalg.norm(Q) + np.linalg.norm(G.T @ F)
        ev = np.linalg.eigvalsh(X)
        if (np.linalg.norm(resid) > 1e-7 * scale or ev.min() < -1e-9 * max(1, abs(ev).max())
                or np.linalg.eigvals(A + B @ F).real.max() >= 0):
            return False
        sols.append(X)
    return np.abs(np.linalg.eigvals(sols[0] @ sols[1])).max() < g * g


@pytest.mark.parametrize("case", plant_family(5, (8, 20), seed=5, families=FAMILIES), ids=str)
def test_output_feedback_optimum_matches_an_independent_care_bisection(case):
    """Certified, stabilizing, and gamma_opt within the bisection tolerance of a bisection
    (to 1e-8) whose level test is scipy's CARE on the raw plant.  Tolerance: our gamma_opt
    is the upper end of a bracket of relative width 1e-6 (BISECTION_RTOL) and the two level
    tests flip at the same optimum up to their residual tests near the blow-up of X (measured
    within 7e-7 on 20 plants), so 2e-6."""
    p = case.plant
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = output_feedback(p)
    cl = res.closed_loop(p)
    assert res.method == "riccati" and res.certificate.ok
    assert np.linalg.eigvals(cl[0]).real.max() < 0
    assert hinf_norm(*cl)[0] <= res.gamma * (1 + 2e-7)  # own Hamiltonian lower bound
    lo, hi = 0.5 * res.gamma_opt, 2.0 * res.gamma_opt
    assert _care_level(p, hi) and not _care_level(p, lo)
    while hi > lo * (1 + 1e-8):
        mid = np.sqrt(lo * hi)
        lo, hi = (lo, mid) if _care_level(p, mid) else (mid, hi)
    assert res.gamma_opt == pytest.approx(hi, rel=2e-6)


def test_candidate_p_accepted_on_the_final_test_is_the_stabilizing_solution():
    """A lightly damped plant whose P from the separation structure has a bounded-real
    residual between 1e-9 and BRL_TOL = 1e-7: accepted without the 2n-state CARE that used to
    polish it.  It is still the stabilizing solution of the closed loop's bounded-real Riccati
    equation at the design level: backward error within its bound and a Hurwitz feedback."""
    case = plant_family(8, (6, 40), seed=36, families=FAMILIES)[7]
    assert (case.family, case.plant.n) == ("lightly_damped", 20)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = output_feedback(case.plant)
    cl = res.closed_loop(case.plant)
    assert 1e-9 < brl_residual(*cl, res.P, res.gamma) <= 1e-7
    err, tol, abscissa = stabilizing_brl_solution(cl, res.P, res.gamma / (1 + 1e-6))
    assert err <= tol and abscissa < 0


def test_p_between_design_level_and_gamma_when_the_candidate_fails():
    """The 10-state unstable plant of benchmarks/synthesis_floor.py: the central controller's
    norm is within 1e-10 of its design level, the separation-structure candidate fails there
    (and so did the 2n-state solves at the design level: no P was reported before).  P is now
    the stabilizing solution at sqrt(level gamma): positive semidefinite, the bounded-real
    inequality at the published gamma within BRL_TOL, and its Riccati backward error within
    its bound with a Hurwitz feedback."""
    plant = random_plant(np.random.default_rng([36, 10, 1]), 10, "unstable", seed=1).plant
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = output_feedback(plant)
    assert res.certificate.ok and res.P is not None
    cl = res.closed_loop(plant)
    level = res.gamma / (1 + 1e-6)
    assert np.linalg.eigvalsh(res.P).min() >= -1e-12 * np.abs(res.P).max()
    assert brl_residual(*cl, res.P, res.gamma) <= 1e-7
    err, tol, abscissa = stabilizing_brl_solution(cl, res.P, np.sqrt(level * res.gamma))
    assert err <= tol and abscissa < 0
    Acl, Bcl, Ccl, Dcl = cl
    for balanced in (True, False):  # at the design level scipy's CARE finds no acceptable P
        try:
            Q = sla.solve_continuous_are(Acl, Bcl, Ccl.T @ Ccl,
                                         Dcl.T @ Dcl - level ** 2 * np.eye(Bcl.shape[1]),
                                         s=Ccl.T @ Dcl, balanced=balanced)
        except (np.linalg.LinAlgError, ValueError):
            continue
        assert brl_residual(*cl, 0.5 * (Q + Q.T), res.gamma) > 1e-7
