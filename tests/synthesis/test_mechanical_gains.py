"""Sobolev gains of the mechanical W2/W∞ controllers and the classic H∞ gains (pure maths)."""

import numpy as np
import pytest

from sobolev_drake.synthesis.hinf_surface import matched_hinf_surface
from sobolev_drake.synthesis.mechanical import (controlled_closed_form, controlled_gains,
                                                hinf_mechanical_gains,
                                                regulated_closed_form,
                                                regulated_gains, sobolev_gains,
                                                stabilized_closed_form, stabilized_gains,
                                                winf_gamma)

# thesis tunings: manipulator (5.3.1), quadrotor reduced (5.3.1), two-wheeled and figure-8
# (5.3.2), tilt-rotor (7.3.2)
CONTROLLED = [
    ([100, 200], [500, 400], [40, 40], [0.0720, 0.0126]),
    ([1, 1, 1, 1], [1, 1, 1, 1], [0.61, 0.6, 0.6, 0.6], [2e-3, 1e-7, 1e-7, 1e-7]),
    ([1000], [300], [2], [0.001]),
    ([10, 10, 10, 10], [12.8, 18.8, 18.8, 12.8], [0.01, 0.1, 0.1, 0.1], [4e-5, 0.08, 0.07, 0.09]),
    ([0.05, 0.05, 0.5], [1, 1, 1], [400, 400, 200], [500, 500, 50]),
]
REGULATED = [([20, 20, 0.01], [15, 15, 400], [0.1, 0.1, 15])]
STABILIZED = [([2, 2], [0.01, 0.01]), ([0.1], [1.1]), ([180, 10], [2, 0.02])]


def _close(lhs_terms, tol=1e-9):
    """max |Σ terms| relative to the largest term (equations mix magnitudes 1e-7 … 1e7)."""
    total = sum(lhs_terms)
    scale = max(np.max(np.abs(t)) for t in lhs_terms)
    return np.max(np.abs(total)) <= tol * max(scale, 1.0)


def _random_spd(rng, n, scale=1.0):
    A = rng.normal(size=(n, n))
    return scale * (A @ A.T + n * np.eye(n))


@pytest.mark.parametrize("weights", CONTROLLED)
def test_controlled_diagonal_satisfies_thesis_equations(weights):
    g = controlled_gains(*weights)
    Y0, Y1, Y2, Y3 = (np.diag(w) for w in weights)
    b = g.blocks
    Q, K, T, R, S, P = (b[k] for k in "QKTRSP")
    Yi = np.linalg.inv(Y3)
    for name in "QKTRSP":  # diagonal weights give diagonal (symmetric) blocks
        assert np.allclose(b[name], np.diag(np.diag(b[name])), atol=1e-9 * np.abs(b[name]).max())
    # (5.32)-(5.37)
    assert _close([-Q @ Yi @ Q, 2 * K, Y2])
    assert _close([-Q @ Yi @ K, T, R])
    assert _close([-Q @ Yi @ T, S])
    assert _close([-K @ Yi @ K, 2 * S, Y1])
    assert _close([-K @ Yi @ T, P])
    assert _close([-T @ Yi @ T, Y0])
    # (5.19)-(5.24) (same set, written with R, S, P eliminated)
    assert _close([-K @ Yi @ K, 2 * Q @ Yi @ T, Y1])
    assert _close([R, -(Q @ Yi @ K - T)])
    # (7.72), (7.74), (7.75), (7.77)-(7.79) of Theorem 12 (controlled block)
    assert _close([-K @ Yi @ K, Y1, 2 * T @ Yi @ Q])
    assert _close([P, -T @ Yi @ K])
    assert _close([R, -(K @ Yi @ Q - T)])
    # positivity conditions of Theorem 1: P > 0 (⇔ Q − K R⁻¹K > 0 and the Schur condition)
    assert np.linalg.eigvalsh(g.P)[0] > 0
    assert np.linalg.eigvalsh(Q - K @ np.linalg.solve(R, K))[0] > 0
    QK = np.block([[Q, K], [K, R]])
    TS = np.vstack([T, S])
    assert np.linalg.eigvalsh(QK - TS @ np.linalg.solve(P, TS.T))[0] > 0
    # closed loop (5.27) is Hurwitz and uses −Y3⁻¹[Q K T]
    n = len(weights[0])
    Acl = np.zeros((3 * n, 3 * n))
    Acl[:n] = -Yi @ np.hstack([Q, K, T])
    Acl[n:2 * n, :n] = np.eye(n)
    Acl[2 * n:, n:2 * n] = np.eye(n)
    assert np.allclose(Acl, g.closed_loop, rtol=1e-12, atol=1e-12 * np.abs(Acl).max())
    assert np.linalg.eigvals(Acl).real.max() < 0
    # scalar closed forms
    for i in range(n):
        cf = controlled_closed_form(*(w[i] for w in weights))
        for name in "QKTRSP":
            assert cf[name] == pytest.approx(b[name][i, i], rel=1e-7)


@pytest.mark.parametrize("weights", REGULATED)
def test_regulated_diagonal_satisfies_7_70_7_80(weights):
    g = regulated_gains(*weights)
    S0, S1, S2 = (np.diag(w) for w in weights)
    A, B, C = g.blocks["A"], g.blocks["B"], g.blocks["C"]
    Si = np.linalg.inv(S2)
    assert _close([-B @ Si @ B, S0])                 # (7.71)
    assert _close([-A @ Si @ A, 2 * B, S1])          # (7.73)
    assert _close([C, -B @ Si @ A])                  # (7.76), with Σ2 (thesis prints Γ2)
    assert np.linalg.eigvalsh(A - B @ np.linalg.solve(C, B))[0] > 0   # A − B C⁻¹ B > 0
    assert np.linalg.eigvals(g.closed_loop).real.max() < 0
    for i in range(len(weights[0])):
        cf = regulated_closed_form(*(w[i] for w in weights))
        for name in "ABC":
            assert cf[name] == pytest.approx(g.blocks[name][i, i], rel=1e-8)


@pytest.mark.parametrize("weights", STABILIZED)
def test_stabilized_diagonal_satisfies_5_91(weights):
    g = stabilized_gains(*weights)
    U0, U1 = (np.diag(w) for w in weights)
    U = g.blocks["U"]
    assert _close([-U @ np.linalg.inv(U1) @ U, U0])
    assert np.allclose(g.K, np.linalg.solve(U1, U))
    assert np.linalg.eigvals(g.closed_loop).real.max() < 0
    for i in range(len(weights[0])):
        assert stabilized_closed_form(weights[0][i], weights[1][i])["U"] == pytest.approx(U[i, i])


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_full_weights_block_cares(seed):
    rng = np.random.default_rng(seed)
    n = 3
    Y = [_random_spd(rng, n, s) for s in (5.0, 2.0, 1.0, 0.05)]
    g = controlled_gains(*Y)
    Q, K, T, R, S, P = (g.blocks[k] for k in "QKTRSP")
    Y0, Y1, Y2, Y3 = Y
    Yi = np.linalg.inv(Y3)
    # block form of the CARE: 2K → K + Kᵀ, 2S → S + Sᵀ, transposes where blocks are not symmetric
    assert _close([-Q @ Yi @ Q, K, K.T, Y2])
    assert _close([-Q @ Yi @ K, T, R])
    assert _close([-Q @ Yi @ T, S])
    assert _close([-K.T @ Yi @ K, S, S.T, Y1])
    assert _close([-K.T @ Yi @ T, P])
    assert _close([-T.T @ Yi @ T, Y0])
    assert np.max(np.abs(g.riccati_residual())) < 1e-9 * np.abs(g.P).max()
    assert np.linalg.eigvals(g.closed_loop).real.max() < 0
    assert np.allclose(g.K, Yi @ np.hstack([Q, K, T]))
    Sg = [_random_spd(rng, n, s) for s in (3.0, 1.0, 0.1)]
    r = regulated_gains(*Sg)
    A, B, C = r.blocks["A"], r.blocks["B"], r.blocks["C"]
    Si = np.linalg.inv(Sg[2])
    assert _close([-A @ Si @ A, B, B.T, Sg[1]])
    assert _close([-B.T @ Si @ B, Sg[0]])
    assert _close([C, -A @ Si @ B])
    assert np.linalg.eigvals(r.closed_loop).real.max() < 0
    U = [_random_spd(rng, n, s) for s in (2.0, 0.3)]
    s = stabilized_gains(*U)
    assert _close([-s.blocks["U"] @ np.linalg.inv(U[1]) @ s.blocks["U"], U[0]])


def test_dispatcher_and_norm_names():
    w = ([1.0], [2.0], [3.0], [0.1])
    a = sobolev_gains(*w, norm="W2")
    b = sobolev_gains(*w, norm="Winf")
    assert a.group == "controlled" and np.array_equal(a.K, b.K)  # W2 ≡ W∞ (Remark 30)
    assert sobolev_gains(1.0, 2.0, 3.0).group == "regulated"
    assert sobolev_gains(1.0, 2.0).group == "stabilized"


def test_bad_weights_raise_clear_errors():
    with pytest.raises(ValueError, match="Y3 must be positive definite"):
        controlled_gains([1], [1], [1], [0])
    with pytest.raises(ValueError, match="Y1 must be positive semidefinite"):
        controlled_gains([1], [-1], [1], [1])
    with pytest.raises(ValueError, match="Y0 must be symmetric"):
        controlled_gains([[1, 2], [0, 1]], np.eye(2), np.eye(2), np.eye(2))
    with pytest.raises(ValueError, match="Y2 must be 2x2"):
        controlled_gains([1, 1], [1, 1], [1, 1, 1], [1, 1])
    with pytest.raises(ValueError, match="S2 must be positive definite"):
        regulated_gains([1], [1], [-1])
    with pytest.raises(ValueError, match="U0 must be positive definite"):
        stabilized_gains([0.0], [1.0])
    with pytest.raises(ValueError, match="4 .*3 .*2"):
        sobolev_gains(1.0)
    with pytest.raises(ValueError, match="norm"):
        controlled_gains(1, 1, 1, 1, norm="H2")
    with pytest.raises(ValueError, match="must be finite"):
        controlled_gains([np.nan], [1], [1], [1])


def test_winf_gamma_is_the_hessian_bound():
    M = np.array([[2.0, 0.3], [0.3, 1.0]])
    E = np.diag([0.5, 0.2])
    gam = winf_gamma(M, E)
    Mi = np.linalg.inv(M)
    Pi = Mi @ E @ Mi
    assert np.linalg.eigvalsh(Pi - gam ** 2 * np.eye(2))[-1] == pytest.approx(0.0, abs=1e-12)
    with pytest.raises(ValueError):
        winf_gamma(np.eye(2), np.eye(3))


def test_hinf_gains_formulas_and_hji():
    w1, w2, w3, wu, gam = 2.0, 3.0, 1.5, 0.4, 1.1
    h = hinf_mechanical_gains(w1, w2, w3, wu, gam)
    c = gam * wu / np.sqrt(gam ** 2 - wu ** 2)
    s = np.sqrt(w2 ** 2 + 2 * w1 * w3)
    assert (h.T11, h.T12, h.T13) == pytest.approx((w1 * c, s * c, w3 * c))
    # HJI on M σ̇ + Cσ = u + T11 w with M = m I, C = 0 (skew part drops out of V̇ anyway):
    # V̇ + ½(x̃ᵀQx̃ + uᵀRu) − ½γ²|T11 w|² ≤ 0 with equality at the worst case T11 w = σ/γ².
    rng = np.random.default_rng(3)
    m = 1.7
    Kb = h.storage_matrix()
    for _ in range(20):
        ed, e, ei, wch = rng.normal(size=4)
        sig = h.sigma(ed, e, ei)
        u = -h.R_inv * sig
        sigdot = (u + wch) / m
        y = np.array([e, ei])
        ydot = np.array([ed, e])
        Vdot = m * sig * sigdot + y @ Kb @ ydot
        stage = 0.5 * (w1 ** 2 * ed ** 2 + w2 ** 2 * e ** 2 + w3 ** 2 * ei ** 2 + wu ** 2 * u ** 2)
        hji = Vdot + stage - 0.5 * gam ** 2 * wch ** 2
        assert hji <= 1e-12
        wst = sig / gam ** 2
        Vdot_w = m * sig * (u + wst) / m + y @ Kb @ ydot
        assert Vdot_w + stage - 0.5 * gam ** 2 * wst ** 2 == pytest.approx(0.0, abs=1e-10)
    assert np.linalg.eigvalsh(Kb)[0] > 0  # storage function positive definite


def test_hinf_bad_input():
    with pytest.raises(ValueError, match="gamma > omega_u"):
        hinf_mechanical_gains(1, 1, 1, 2.0, 1.5)
    with pytest.raises(ValueError, match="omega1 must be > 0"):
        hinf_mechanical_gains(0, 1, 1, 1, 2)
    with pytest.raises(ValueError, match="omega2 must be >= 0"):
        hinf_mechanical_gains(1, -1, 1, 1, 2)


def test_matched_hinf_surface_is_the_slow_factor_of_the_w_design():
    # one DOF: the surface polynomial s² + (ω2² + 2ω1ω3)^½ s/ω1 + ω3/ω1 equals the slow factor
    # s² + (k/q) s + t/q of the W closed loop
    g = controlled_gains([100], [500], [40], [0.072])
    w1, w2, w3 = matched_hinf_surface(g)
    q, k, t = (g.blocks[n][0, 0] for n in "QKT")
    s = np.sqrt(w2 ** 2 + 2 * w1 * w3)
    assert w1 == 1.0
    assert s / w1 == pytest.approx(k / q) and w3 / w1 == pytest.approx(t / q)


@pytest.mark.parametrize("surface", [(1.0, 9.55, 17.44), (2.0, 3.0, 1.5)])
def test_scaled_surface_scales_the_error_polynomial(surface):
    from sobolev_drake.synthesis.hinf_surface import scaled_surface

    def roots(s):
        w1, w2, w3 = s
        return np.sort_complex(np.roots([1.0, np.sqrt(w2 ** 2 + 2 * w1 * w3) / w1, w3 / w1]))

    # default: the same dynamics a times faster, i.e. every root times a (ω1 kept)
    for a in (0.855, 1.0, 3.0):
        scaled = scaled_surface(surface, a)
        assert scaled[0] == surface[0]
        np.testing.assert_allclose(roots(scaled), a * roots(surface), rtol=1e-12, atol=1e-12)
    # separate factors: the coefficients themselves (the balance-coupled reading's surface)
    w1, w2, w3 = scaled_surface(surface, 3.75, 16.0)
    s0 = np.sqrt(surface[1] ** 2 + 2 * surface[0] * surface[2]) / surface[0]
    assert np.sqrt(w2 ** 2 + 2 * w1 * w3) / w1 == pytest.approx(3.75 * s0, rel=1e-14)
    assert w3 / w1 == pytest.approx(16.0 * surface[2] / surface[0], rel=1e-14)
    hinf_mechanical_gains(w1, w2, w3, 0.7, 1.4)             # a valid classic H∞ surface


def test_scaled_surface_rejects_what_no_surface_represents():
    from sobolev_drake.synthesis.hinf_surface import scaled_surface
    with pytest.raises(ValueError, match="c1_factor must be"):
        scaled_surface((1.0, 1.0, 1.0), 0.0)
    with pytest.raises(ValueError, match="c0_factor must be"):
        scaled_surface((1.0, 1.0, 1.0), 1.0, float("nan"))
    with pytest.raises(ValueError, match="surface must be"):
        scaled_surface((-1.0, 1.0, 1.0), 1.0)
    # c1² = 3 before; c1 × 1, c0 × 2 gives c1² = 3 < 2c0 = 4
    with pytest.raises(ValueError, match="needs c1² >= 2c0"):
        scaled_surface((1.0, 1.0, 1.0), 1.0, 2.0)
