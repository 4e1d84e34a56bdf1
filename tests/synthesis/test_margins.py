"""Input delay and gain margins: closed forms and a delay-differential-equation simulation."""

import numpy as np
import pytest
from scipy.linalg import solve_continuous_are

from sobolev_drake.synthesis.hinf import DynamicController
from sobolev_drake.synthesis.margins import input_delay_margin, input_gain_margins


def test_scalar_loops_match_closed_forms():
    # P = 1/s, u = −2 y: crossover 2 rad/s, phase margin 90° → τ = (π/2)/2
    assert input_delay_margin([[0.0]], [[1.0]], [[-2.0]]) == pytest.approx(np.pi / 4, rel=1e-9)
    # P = 1/(s+1), u = −2 y: |L| = 1 at ω = √3, phase margin 120° → τ = (2π/3)/√3
    assert input_delay_margin([[-1.0]], [[1.0]], [[-2.0]]) == pytest.approx(2 * np.pi / 3 / np.sqrt(3), rel=1e-9)
    # |L| < 1 everywhere: no delay destabilizes; gains: stable for every k > 0
    assert input_delay_margin([[-1.0]], [[1.0]], [[-0.5]]) == np.inf
    assert input_gain_margins([[-1.0]], [[1.0]], [[-0.5]]) == (0.0, np.inf)
    # unstable plant 1/(s−1), u = −2 y: stable for k > 1/2 only
    low, high = input_gain_margins([[1.0]], [[1.0]], [[-2.0]])
    assert low == pytest.approx(0.5, rel=1e-5) and high == np.inf


def _delayed_growth(A, B, ctrl, C, tau, T=40.0):
    """‖state‖ at T over ‖state‖ at T/2 of ẋ = A x + B u_c(t − τ), u_c from ``ctrl`` (Euler)."""
    AK, BK, CK, DK = ctrl
    n, nk = A.shape[0], AK.shape[0]
    h = tau / 100
    d = 100
    steps = int(T / h)
    x, xk = np.ones(n), np.zeros(nk)
    hist = [np.zeros(B.shape[1])] * d
    norms = []
    for k in range(steps):
        y = C @ x
        uc = CK @ xk + DK @ y
        hist.append(uc)
        u = hist.pop(0)
        x, xk = x + h * (A @ x + B @ u), xk + h * (AK @ xk + BK @ y)
        if k in (steps // 2, steps - 1):
            norms.append(np.linalg.norm(np.r_[x, xk]))
    return norms[1] / norms[0]


def test_mimo_delay_margin_against_simulation():
    """Two coupled double integrators, LQR state feedback and an observer-based output feedback:
    the loop decays at 0.8 τ* and grows at 1.25 τ* (independent time-domain check)."""
    A = np.zeros((4, 4))
    A[0, 1] = A[2, 3] = 1.0
    A[1, 2] = 0.4
    B = np.array([[0, 0], [1, 0.3], [0, 0], [0.2, 1.0]])
    X = solve_continuous_are(A, B, np.diag([4.0, 1, 4, 1]), np.eye(2))
    K = -B.T @ X                                                  # u = K x (positive convention)
    C = np.array([[1.0, 0, 0, 0], [0, 0, 1.0, 0]])
    Y = solve_continuous_are(A.T, C.T, np.eye(4), 0.1 * np.eye(2))
    L = Y @ C.T / 0.1
    dyn = DynamicController(A + B @ K - L @ C, L, K, np.zeros((2, 2)))
    for ctrl, Cm, tup in ((K, None, (np.zeros((0, 0)), np.zeros((0, 4)), np.zeros((2, 0)), K)),
                          (dyn, C, tuple(dyn))):
        tau = input_delay_margin(A, B, ctrl, Cm)
        assert 0.05 < tau < 2.0
        Cs = np.eye(4) if Cm is None else Cm
        assert _delayed_growth(A, B, tup, Cs, 0.8 * tau) < 0.5
        assert _delayed_growth(A, B, tup, Cs, 1.25 * tau) > 2.0
        low, high = input_gain_margins(A, B, ctrl, Cm)
        assert 0 <= low < 1 < high


def test_bad_input_raises():
    with pytest.raises(ValueError, match="unstable"):
        input_delay_margin([[1.0]], [[1.0]], [[0.5]])
    with pytest.raises(ValueError, match="unstable"):
        input_gain_margins([[1.0]], [[1.0]], [[0.5]])
    with pytest.raises(ValueError, match="K"):
        input_delay_margin(np.zeros((2, 2)), np.ones((2, 1)), np.ones((2, 2)))
    with pytest.raises(ValueError, match="controller must map"):
        input_delay_margin(np.zeros((2, 2)), np.ones((2, 1)),
                           DynamicController(np.zeros((1, 1)), np.zeros((1, 3)), np.zeros((1, 1)), np.zeros((1, 3))),
                           C=np.eye(2))
