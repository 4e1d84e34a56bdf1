"""Secondary objective ``initial_states``: guaranteed transient cost at a fixed certified gamma.

The bound sum_i x0_i' P x0_i is checked against the exact cost of the closed loop, computed
independently of the LMI from the observability Gramian (A_cl' L + L A_cl + C_cl' C_cl = 0,
cost from x(0) = x0 with w = 0 is x0' L x0).
"""

import warnings

import numpy as np
import pytest
from scipy.linalg import solve_continuous_are, solve_continuous_lyapunov

from sobolev_drake.synthesis.hinf import SynthesisWarning, output_feedback, state_feedback
from sobolev_drake.synthesis.regions import disk
from sobolev_drake.synthesis.sobolev import winf_plant

warnings.simplefilter("ignore", UserWarning)
warnings.simplefilter("ignore", SynthesisWarning)

# thesis simple example (6.41): matched disturbance, the W∞ optimum sits on the feedthrough bound
A = np.array([[0, 50], [-50, -50.0]])
B = np.array([[0.0], [1]])
G0, G1 = np.diag([10.0, 10]), np.eye(2)
X0 = np.array([[1.0, 0.0], [0.5, 2.0]])  # two initial states as columns


def exact_cost(res, plant, X0):
    """sum_i integral |z|^2 dt from x(0) = x0_i (controller state 0), w = 0."""
    Acl, _, Ccl, _ = res.closed_loop(plant)
    L = solve_continuous_lyapunov(Acl.T, -Ccl.T @ Ccl)
    Z = np.zeros((Acl.shape[0], X0.shape[1]))
    Z[:X0.shape[0]] = X0
    return float(np.sum(Z * (L @ Z)))


def test_state_feedback_transient_objective_bounds_and_beats_least_gain():
    p = winf_plant(A, B, D=B, Gamma0=G0, Gamma1=G1)
    least = state_feedback(p, method="lmi")  # the LMI path's least-gain regularization
    r = state_feedback(p, initial_states=X0)
    assert r.regularized and r.certificate.ok
    assert np.isclose(r.gamma, least.gamma)  # same certified gamma, different controller
    assert any("transient bound" in w for w in r.warnings)
    cost, cost_least = exact_cost(r, p, X0), exact_cost(least, p, X0)
    assert cost <= r.transient_bound * (1 + 1e-6)  # the bound holds
    assert r.transient_bound <= cost * 1.05  # and is nearly tight (H∞ constraint inactive)
    assert cost < 0.6 * cost_least  # measured 232.5 vs 460.0


def test_riccati_state_feedback_is_transient_optimal_at_its_gamma():
    """The stabilizing solution of the H∞ Riccati equation is the smallest P of the
    bounded-real inequality, so the Riccati gain at a level gamma minimizes x0'P x0 for every
    x0 at once: the default (Riccati) controller's transient cost equals the optimum of the
    LMI's transient objective at the same gamma.  Tolerance: the LMI optimum is accurate to
    Clarabel's relative gap (~1e-8) and P to the ARE residual; 1e-4 is far above both."""
    p = winf_plant(A, B, D=B, Gamma0=G0, Gamma1=G1)
    ric = state_feedback(p)  # optimum on the feedthrough bound: regularized at (1+delta)
    assert ric.method == "riccati" and ric.regularized
    lmi = state_feedback(p, method="lmi", gamma=ric.gamma, initial_states=X0)
    assert exact_cost(ric, p, X0) == pytest.approx(exact_cost(lmi, p, X0), rel=1e-4)


def test_state_feedback_transient_bound_approaches_lqr_cost_when_gamma_is_loose():
    """With a loose gamma the H∞ constraint is inactive: the minimal bound is the cost of
    the LQR with Q = C1'C1, R = D12'D12, S = C1'D12 (Riccati, independent of the LMI)."""
    p = winf_plant(A, B, D=B, Gamma0=G0, Gamma1=G1)
    r = state_feedback(p, gamma=50.0, initial_states=X0)
    Q, R, S = p.C1.T @ p.C1, p.D12.T @ p.D12, p.C1.T @ p.D12
    Pr = solve_continuous_are(p.A, p.B2, Q, R, s=S)
    lqr = float(np.sum(X0 * (Pr @ X0)))
    assert lqr <= exact_cost(r, p, X0) * (1 + 1e-6)
    assert r.transient_bound == pytest.approx(lqr, rel=2e-3)


def test_output_feedback_transient_objective():
    C = np.array([[1.0, 1.0]])
    p = winf_plant(A, B, C, B, Gamma0=G0, Gamma1=G1)
    least = output_feedback(p, region=disk(500.0), regularize=True)
    r = output_feedback(p, region=disk(500.0), regularize=True, initial_states=X0)
    assert r.certificate.ok and np.isclose(r.gamma, least.gamma)
    cost = exact_cost(r, p, X0)
    assert cost <= r.transient_bound * (1 + 1e-6)
    assert cost <= exact_cost(least, p, X0) * (1 + 1e-6)  # measured 280.4 vs 335.0 (bound 513.6)


def test_initial_states_bad_input():
    p = winf_plant(A, B, D=B, Gamma0=G0, Gamma1=G1)
    with pytest.raises(ValueError, match="initial_states must have shape"):
        state_feedback(p, initial_states=np.ones(3))
    with pytest.raises(ValueError, match="initial_states must be finite"):
        state_feedback(p, initial_states=np.zeros(2))
    with pytest.raises(ValueError, match="initial_states must have shape"):
        output_feedback(winf_plant(A, B, np.eye(2), B, Gamma0=G0, Gamma1=G1), initial_states=np.ones((2, 2, 1)))


def test_output_feedback_transient_gain_weight_is_a_tie_breaker():
    """``transient_gain_weight`` adds w |x0|^2 k (k bounds X, Y and the controller variables)
    to the transient objective: each result certified with a valid bound, and the transient
    bound can only grow with w (scalarized bi-objective: the first objective is monotone in w)."""
    C = np.array([[1.0, 1.0]])
    p = winf_plant(A, B, C, B, Gamma0=G0, Gamma1=G1)
    bounds = []
    for w in (0.0, 1e-3, 1e-1):
        r = output_feedback(p, region=disk(500.0), regularize=True, initial_states=X0,
                            transient_gain_weight=w)
        assert r.certificate.ok
        assert exact_cost(r, p, X0) <= r.transient_bound * (1 + 1e-6)
        bounds.append(r.transient_bound)
    # measured 513.6, 563.7, 608.0
    assert bounds[0] <= bounds[1] * (1 + 1e-4) and bounds[1] <= bounds[2] * (1 + 1e-4)
    assert bounds[2] > 1.05 * bounds[0]  # the weight acts
    with pytest.raises(ValueError, match="transient_gain_weight must be a finite number >= 0"):
        output_feedback(p, initial_states=X0, transient_gain_weight=-1.0)
    with pytest.raises(ValueError, match="needs initial_states"):
        output_feedback(p, transient_gain_weight=1e-3)
