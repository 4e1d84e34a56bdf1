"""Automatic scaling of the state-feedback LMI (hinf.balance_scaling / scale_plant).

A well-posed plant is rewritten in badly scaled coordinates (diagonal state similarity with
entries 1e-3..1e3, inputs multiplied by 1e-5): the H∞ problem is the same, so the
optimal gamma must match and the controller, mapped back, must pass the certificate computed
in the badly scaled (original) coordinates.
"""

import numpy as np
import pytest

from sobolev_drake.synthesis.certificates import hinf_norm
from sobolev_drake.synthesis.hinf import (GeneralizedPlant, balance_scaling, scale_plant,
                                          state_feedback)
from sobolev_drake.synthesis.regions import disk
from sobolev_drake.synthesis.sobolev import hinf_plant


def _plant(seed=3, n=6, nu=2, nw=2):
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((n, n)) + 0.5 * np.eye(n)  # open-loop unstable
    B = rng.standard_normal((n, nu))
    D = rng.standard_normal((n, nw))
    return hinf_plant(A, B, D=D, Q=np.eye(n), R=np.eye(nu))


def _badly_scaled(p, S, su):
    """Same system in coordinates x = S x_bad, u = su u_bad (w, z unchanged)."""
    Si = 1.0 / S
    return GeneralizedPlant(Si[:, None] * p.A * S, Si[:, None] * p.B1, Si[:, None] * p.B2 * su,
                            p.C1 * S, p.D11, p.D12 * su, p.C2 * S, p.D21)


S_BAD = np.logspace(-3, 3, 6)
SU_BAD = 1e-5


def test_scale_plant_is_exact_similarity():
    p = _plant()
    bad = _badly_scaled(p, S_BAD, SU_BAD)
    T, Su = balance_scaling([bad])
    assert np.all(np.log2(T) == np.round(np.log2(T))) and np.all(np.log2(Su) == np.round(np.log2(Su)))
    q = scale_plant(bad, T, Su)
    # any gain on the scaled plant gives the same closed-loop norm as its image on the original
    rng = np.random.default_rng(0)
    Ks = rng.standard_normal((q.nu, q.n))
    K = Su[:, None] * Ks / T
    assert np.allclose(np.sort_complex(np.linalg.eigvals(q.A + q.B2 @ Ks)),
                       np.sort_complex(np.linalg.eigvals(bad.A + bad.B2 @ K)), rtol=1e-8, atol=1e-8)
    # balancing brings the entries of the badly scaled A back to a moderate range
    spread = lambda M: np.log10(np.abs(M[M != 0]).max() / np.abs(M[M != 0]).min())
    assert spread(q.A) < spread(bad.A) - 4


def test_badly_scaled_plant_same_gamma_and_certified():
    p = _plant()
    ref = state_feedback(p, scaling=False)
    bad = _badly_scaled(p, S_BAD, SU_BAD)
    r = state_feedback(bad)
    assert r.certificate.ok and not r.regularized
    assert r.gamma == pytest.approx(ref.gamma, rel=1e-4)
    # independent check in the original (badly scaled) coordinates
    assert hinf_norm(*bad.closed_loop(K=r.K))[0] <= r.gamma * (1 + 1e-4)
    # the two controllers are the same map up to the coordinate change
    assert hinf_norm(*p.closed_loop(K=SU_BAD * r.K / S_BAD))[0] <= r.gamma * (1 + 1e-4)
    # X maps back as X = T Xs T: the Lyapunov inequality holds in original coordinates
    Acl = bad.A + bad.B2 @ r.K
    assert np.linalg.eigvalsh(r.P).min() > 0
    L = Acl.T @ r.P + r.P @ Acl
    assert np.linalg.eigvalsh(L / np.sqrt(np.outer(np.diag(r.P), np.diag(r.P)))).max() < 0


def test_badly_scaled_plant_with_disk_region():
    p = _plant(seed=5)
    reg = disk(50.0)
    ref = state_feedback(p, region=reg, scaling=False)
    r = state_feedback(_badly_scaled(p, S_BAD, SU_BAD), region=reg)
    assert r.certificate.ok
    assert r.gamma == pytest.approx(ref.gamma, rel=1e-4)
    bad = _badly_scaled(p, S_BAD, SU_BAD)
    assert np.abs(np.linalg.eigvals(bad.A + bad.B2 @ r.K)).max() < 50.0


def test_explicit_scaling_and_bad_input():
    p = _plant()
    T, Su = np.full(p.n, 2.0), np.full(p.nu, 0.5)
    r = state_feedback(p, scaling=(T, Su))
    assert r.certificate.ok
    assert r.gamma == pytest.approx(state_feedback(p, scaling=False).gamma, rel=1e-4)
    with pytest.raises(ValueError, match="scaling"):
        state_feedback(p, scaling=(np.ones(p.n + 1), Su))
    with pytest.raises(ValueError, match="scaling"):
        state_feedback(p, scaling=(-T, Su))


# --------------------------------------------------------------------------- output feedback
def _of_plant(seed, n=5, sensor_noise=0.1):
    """W∞ plant with measurement noise (as tests/synthesis/test_synthesis.py's random plants)."""
    from sobolev_drake.synthesis.sobolev import winf_plant
    rng = np.random.default_rng(seed)
    nu, nw, ny = 1 + n % 2, 1 + (n // 2) % 2, max(1, n // 2)
    A = rng.normal(size=(n, n))
    A -= (np.linalg.eigvals(A).real.max() - 0.5) * np.eye(n)
    B, D, C = rng.normal(size=(n, nu)), rng.normal(size=(n, nw)), rng.normal(size=(ny, n))
    p = winf_plant(A, B, C, D, Gamma0=np.diag(rng.uniform(0.5, 2, n)), Gamma1=np.diag(rng.uniform(0.01, 0.2, n)))
    B1 = np.hstack([p.B1, np.zeros((n, ny))])
    D11 = np.hstack([p.D11, np.zeros((p.nz, ny))])
    D21 = np.hstack([np.zeros((ny, nw)), sensor_noise * np.eye(ny)])
    return GeneralizedPlant.make(p.A, B1, p.B2, p.C1, D11, p.D12, p.C2, D21)


def _badly_scaled_of(p, S, su, sy):
    """Same system in coordinates x = S x_bad, u = su u_bad, y = sy y_bad (w, z unchanged)."""
    q = _badly_scaled(p, S, su)
    return GeneralizedPlant(q.A, q.B1, q.B2, q.C1, q.D11, q.D12, q.C2 / sy[:, None], q.D21 / sy[:, None])


def test_output_scaling_is_exact():
    p = _of_plant(3)
    bad = _badly_scaled_of(p, np.logspace(-3, 3, p.n), SU_BAD, np.logspace(3, -3, p.ny))
    T, Su, Sy = balance_scaling([bad], outputs=True)
    for v in (T, Su, Sy):
        assert np.all(np.log2(v) == np.round(np.log2(v)))
    q = scale_plant(bad, T, Su, Sy)
    # rows of [C2 D21] are unit-sized after scaling (up to the power-of-two rounding)
    rows = np.linalg.norm(np.hstack([q.C2, q.D21]), axis=1)
    assert np.all((rows > 0.7) & (rows < 1.42))
    # a controller of the scaled plant, mapped back, gives the same closed loop w -> z
    from sobolev_drake.synthesis.hinf import DynamicController
    from sobolev_drake.synthesis.scaling import unscale_controller
    rng = np.random.default_rng(1)
    cs = DynamicController(rng.normal(size=(2, 2)) - 3 * np.eye(2), rng.normal(size=(2, q.ny)),
                           rng.normal(size=(q.nu, 2)), rng.normal(size=(q.nu, q.ny)))
    c = unscale_controller(cs, Su, Sy)
    Gs = q.closed_loop(controller=cs)
    G = bad.closed_loop(controller=c)
    assert np.allclose(np.sort_complex(np.linalg.eigvals(Gs[0])), np.sort_complex(np.linalg.eigvals(G[0])),
                       rtol=1e-8, atol=1e-8)
    s = 0.7j
    tf = lambda A, B, C, D: C @ np.linalg.solve(s * np.eye(A.shape[0]) - A, B) + D
    assert np.allclose(tf(*Gs), tf(*G), rtol=1e-8, atol=1e-10)


@pytest.mark.parametrize("seed, region", [(0, None), (3, None), (4, disk(30.0))])
def test_badly_scaled_output_feedback_same_gamma_and_certified(seed, region):
    from sobolev_drake.synthesis.hinf import output_feedback
    p = _of_plant(seed)
    ref = output_feedback(p, scaling=False, region=region)
    S, sy = np.logspace(-3, 3, p.n), np.logspace(3, -3, p.ny)
    bad = _badly_scaled_of(p, S, SU_BAD, sy)
    r = output_feedback(bad, region=region)
    assert r.certificate.ok and not r.regularized
    assert r.gamma_opt == pytest.approx(ref.gamma_opt, rel=1e-4)
    # independent check on the original (badly scaled) plant
    cl = bad.closed_loop(controller=r.controller)
    assert hinf_norm(*cl)[0] <= r.gamma * (1 + 1e-4)
    if region is not None:
        assert np.all(region.contains(np.linalg.eigvals(cl[0]), 1e-6 * 30))
    # the same controller expressed for the well-scaled plant: u = su u_bad, y = sy y_bad
    AK, BK, CK, DK = r.controller
    c_good = (AK, BK / sy, SU_BAD * CK, SU_BAD * DK / sy)
    assert hinf_norm(*p.closed_loop(controller=c_good))[0] <= r.gamma * (1 + 1e-4)
    # X, Y, P mapped back to original coordinates: P > 0 and the closed-loop Lyapunov
    # inequality holds; the upper-left blocks of P^-1 and P are X and Y
    assert np.linalg.eigvalsh(r.P).min() > 0
    L = cl[0].T @ r.P + r.P @ cl[0]
    dsc = 1.0 / np.sqrt(np.diag(r.P))
    ev = np.linalg.eigvalsh(dsc[:, None] * L * dsc)
    # LMI path: strictly negative (the LMI margin).  Riccati path: P solves the closed loop's
    # bounded-real Riccati equation, so A'P + PA = -C'C - (...) <= 0 has exact zeros in the
    # directions z does not see; it is accepted at BRL_TOL = 1e-7 relative (measured 5e-9 /
    # 60.6 under Haswell and Zen kernels, < 0 under the others)
    assert ev.max() < (0 if r.method == "lmi" else 1e-7 * np.abs(ev).max())
    assert np.allclose(r.P[:p.n, :p.n], r.Y, rtol=1e-6, atol=0)
    assert np.allclose(np.linalg.inv(r.P)[:p.n, :p.n], r.X, rtol=1e-5, atol=1e-12 * np.abs(r.X).max())


def test_output_feedback_explicit_scaling_and_bad_input():
    from sobolev_drake.synthesis.hinf import output_feedback
    p = _of_plant(0, n=3)
    T, Su, Sy = np.full(p.n, 2.0), np.full(p.nu, 0.5), np.full(p.ny, 4.0)
    r = output_feedback(p, scaling=(T, Su, Sy))
    assert r.certificate.ok
    assert r.gamma_opt == pytest.approx(output_feedback(p, scaling=False).gamma_opt, rel=1e-4)
    with pytest.raises(ValueError, match="scaling"):
        output_feedback(p, scaling=(T, Su))  # Sy missing
    with pytest.raises(ValueError, match="scaling"):
        output_feedback(p, scaling=(T, Su, -Sy))
    with pytest.raises(ValueError, match="scaling"):
        output_feedback(p, scaling=(T, Su, np.ones(p.ny + 1)))
