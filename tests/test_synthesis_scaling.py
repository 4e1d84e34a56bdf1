"""Automatic scaling of the state-feedback LMI (hinf.balance_scaling / scale_plant).

A well-posed plant is rewritten in badly scaled coordinates (diagonal state similarity with
entries 1e-3..1e3, inputs multiplied by 1e-5): the H-infinity problem is the same, so the
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
    return hinf_plant(A, B, D, np.eye(n), np.eye(nu))


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
