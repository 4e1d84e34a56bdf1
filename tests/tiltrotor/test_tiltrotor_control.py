"""Tilt-rotor nonlinear W∞ law (thesis §7.3.2): gains, partition, u*, allocation bookkeeping."""

import numpy as np
from scipy.linalg import solve_continuous_are

from sobolev_drake.tiltrotor import controller as tc


def _chain_gain(weights, R):
    """Private check: LQR of a chain of integrators of order len(weights) per DOF.

    State [e^(k-1); …; e; ∫e…] (highest derivative first), input the next derivative; weights[i]
    on the i-th block.  Returns K with input* = −K x."""
    m = R.shape[0]
    k = len(weights)
    A = np.zeros((k * m, k * m))
    for i in range(1, k):
        A[i * m:(i + 1) * m, (i - 1) * m:i * m] = np.eye(m)
    B = np.zeros((k * m, m))
    B[:m] = np.eye(m)
    Q = np.zeros((k * m, k * m))
    for i, W in enumerate(weights):
        Q[i * m:(i + 1) * m, i * m:(i + 1) * m] = W
    P = solve_continuous_are(A, B, Q, R)
    return np.linalg.solve(R, B.T @ P), P


W = tc.THESIS_WEIGHTS


class _Gains:
    def __init__(self, Ks, Kr, Kc):
        self.Ks, self.Kr, self.Kc = Ks, Kr, Kc


def thesis_gains_by_care():
    Ks, _ = _chain_gain([W["Upsilon0"]], W["Upsilon1"])
    Kr, _ = _chain_gain([W["Sigma1"], W["Sigma0"]], W["Sigma2"])
    Kc, _ = _chain_gain([W["Gamma2"], W["Gamma1"], W["Gamma0"]], W["Gamma3"])
    return _Gains(Ks, Kr, Kc)


def test_care_gains_satisfy_theorem_12_riccati_set():
    """(7.70)–(7.75) hold for the blocks of the CARE solutions (diagonal weights)."""
    _, Pr = _chain_gain([W["Sigma1"], W["Sigma0"]], W["Sigma2"])
    A, B = Pr[:3, :3], Pr[:3, 3:]
    S2i = np.linalg.inv(W["Sigma2"])
    assert np.allclose(-B @ S2i @ B + W["Sigma0"], 0, atol=1e-8)            # (7.71)
    assert np.allclose(-A @ S2i @ A + 2 * B + W["Sigma1"], 0, atol=1e-6)     # (7.73)
    # (7.76) reads C = BΓ2⁻¹A in the thesis; the CARE gives C = BΣ2⁻¹A (Γ2 is a typo)
    assert np.allclose(Pr[3:, 3:], B @ S2i @ A, atol=1e-8)
    assert not np.allclose(Pr[3:, 3:], B @ np.linalg.inv(W["Gamma2"]) @ A, atol=1e-3)
    _, Pc = _chain_gain([W["Gamma2"], W["Gamma1"], W["Gamma0"]], W["Gamma3"])
    Q, K, T = Pc[:3, :3], Pc[:3, 3:6], Pc[:3, 6:]
    G3i = np.linalg.inv(W["Gamma3"])
    assert np.allclose(-T @ G3i @ T + W["Gamma0"], 0, atol=1e-8)             # (7.72)
    assert np.allclose(-K @ G3i @ K + W["Gamma1"] + 2 * T @ G3i @ Q, 0, atol=1e-6)  # (7.74)
    assert np.allclose(-Q @ G3i @ Q + 2 * K + W["Gamma2"], 0, atol=1e-5)     # (7.75)
    # (7.77)–(7.79): S = QΓ3⁻¹T, P = TΓ3⁻¹K, R = KΓ3⁻¹Q − T
    assert np.allclose(Pc[3:6, 6:], Q @ G3i @ T, atol=1e-6)
    assert np.allclose(Pc[6:, 6:], T @ G3i @ K, atol=1e-6)
    assert np.allclose(Pc[3:6, 3:6], K @ G3i @ Q - T, atol=1e-6)
    # (7.70) closed form: U = √(Υ0 Υ1) for diagonal weights
    Ks, Pu = _chain_gain([W["Upsilon0"]], W["Upsilon1"])
    assert np.allclose(np.diag(Pu), np.sqrt(np.diag(W["Upsilon0"]) * np.diag(W["Upsilon1"])))


def test_scalar_closed_form_controlled_chain():
    """t = √(γ0γ3), q²/γ3 = 2k + γ2, k²/γ3 = 2qt/γ3 + γ1 (docs/design.md §4.2) match the CARE."""
    g0, g1, g2, g3 = 0.05, 1.0, 400.0, 500.0
    K, P = _chain_gain([np.eye(1) * g2, np.eye(1) * g1, np.eye(1) * g0], np.eye(1) * g3)
    t = np.sqrt(g0 * g3)
    q, k = P[0, 0], P[0, 1]
    assert np.isclose(P[0, 2], t)
    assert np.isclose(q**2 / g3, 2 * k + g2)
    assert np.isclose(k**2 / g3, 2 * q * t / g3 + g1)
    assert np.allclose(K, np.array([[q, k, t]]) / g3)


def test_mechanical_synthesis_matches_private_care():
    ref = thesis_gains_by_care()
    inner = tc.thesis_inner_law()
    assert np.allclose(inner.stabilized.K, ref.Ks, rtol=1e-6)
    assert np.allclose(inner.regulated.K, ref.Kr, rtol=1e-6)
    assert np.allclose(inner.controlled.K, ref.Kc, rtol=1e-6)
    # the inverse of E = blkdiag(Υ1, Σ2, Γ3) quoted from the author's simulator
    Einv = np.r_[1 / np.diag(W["Upsilon1"]), 1 / np.diag(W["Sigma2"]), 1 / np.diag(W["Gamma3"])]
    assert np.allclose(Einv, [0.5, 50, 10, 10, 0.0667, 0.002, 0.002, 0.02], rtol=1e-3)


def test_closed_loop_error_chains_are_hurwitz():
    g = thesis_gains_by_care()
    # controlled: ë = −Kc[ė, e, ∫e] → companion matrix per DOF
    A = np.zeros((9, 9))
    A[:3] = -g.Kc
    A[3:6, :3] = np.eye(3)
    A[6:, 3:6] = np.eye(3)
    assert np.max(np.linalg.eigvals(A).real) < 0
    Ar = np.zeros((6, 6))
    Ar[:3] = -g.Kr
    Ar[3:, :3] = np.eye(3)
    assert np.max(np.linalg.eigvals(Ar).real) < 0
    assert np.all(np.linalg.eigvals(-g.Ks).real < 0)


def test_saturation_flags():
    f = tc.saturation_flags([100, 50, -2, 1.0, 0, 0, 0, 0], np.r_[0, 0, -2, -2, 0, 0, -0.1, -0.1],
                            np.r_[100, 100, 2, 2, 0, 0, 0.1, 0.1])
    assert list(f) == [1, 0, -1, 0, 0, 0, 0, 0]
    # the per-sample (1-D, plain-float) path equals the vectorized one row by row
    rng = np.random.default_rng(3)
    lo = -rng.uniform(0, 2, (50, 8)) * (rng.uniform(size=(50, 8)) > 0.2)
    up = lo + rng.uniform(0, 2, (50, 8)) * (rng.uniform(size=(50, 8)) > 0.2)
    tau = np.clip(rng.uniform(-2.5, 2.5, (50, 8)), lo, up)
    tau[::3] = lo[::3] + 1e-4 * (up[::3] - lo[::3])          # near the lower bound
    F = tc.saturation_flags(tau, lo, up)
    assert np.array_equal(F, np.array([tc.saturation_flags(t, a, b) for t, a, b in zip(tau, lo, up)]))
    assert np.any(F == 1) and np.any(F == -1) and np.any(F == 0)
    # the controller's list form (the kernel called directly) gives the same flags, also
    # without the kernels (then it is saturation_flags itself)
    from sobolev_drake.native import disabled
    from sobolev_drake.tiltrotor.law_checks import saturation_flag_list
    for t, a, b, row in zip(tau, lo, up, F):
        assert saturation_flag_list(t, a, b) == row.tolist()
        with disabled():
            assert saturation_flag_list(t, a, b) == row.tolist()


def test_tilt_schedule_polynomial_derivatives():
    c = [3.0081e-08, 4.5551e-06, -0.00024816, 0.003874, -0.0061735, -0.13061]
    s = tc.tilt_schedule_polynomial(c)
    a0, _, _ = s(0.0)
    assert np.isclose(a0, -0.13061)
    h = 1e-4
    a, da, dda = s(10.0)
    assert np.isclose(da, (s(10 + h)[0] - s(10 - h)[0]) / (2 * h), rtol=1e-6)
    assert np.isclose(dda, (s(10 + h)[1] - s(10 - h)[1]) / (2 * h), rtol=1e-5)
    assert s(50.0) == (s(33.99)[0], 0.0, 0.0)


def test_checked_vector_accepts_exactly_the_finite_vectors():
    """The per-sample check (a float sum first) passes finite vectors — also those whose sum
    overflows — with their floats, and names the argument for NaN, ±inf and +inf next to −inf."""
    import math

    import pytest
    big = np.finfo(float).max
    for x in (np.arange(12.0), np.full(12, big), [1.0, -big, big]):
        arr, lst = tc.checked_vector("reference", x, len(x))
        assert lst == np.asarray(x, dtype=float).tolist() and arr.dtype == np.float64
    for bad in ([1.0, math.nan, 2.0], [math.inf, 0.0, 0.0], [0.0, -math.inf, 0.0],
                [math.inf, -math.inf, 1.0]):
        with pytest.raises(ValueError, match="reference"):
            tc.checked_vector("reference", bad, 3)
