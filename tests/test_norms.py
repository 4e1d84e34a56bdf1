"""Norms and indices against closed-form integrals."""

import numpy as np
import pytest

from sobolev_drake import norms


def nonuniform_grid(a, b, n, seed=0):
    """A deliberately irregular grid: random steps varying by a factor ~10."""
    rng = np.random.default_rng(seed)
    steps = rng.uniform(0.1, 1.0, n - 1)
    t = np.concatenate([[0.0], np.cumsum(steps)])
    return a + (b - a) * t / t[-1]


def test_sine_all_orders_with_supplied_derivatives():
    t = nonuniform_grid(0.0, 2 * np.pi, 4000)
    z = np.sin(t)
    # ‖sin‖² on [0, 2π] = π for every derivative order
    terms = norms.sobolev_norm_terms(t, z, [1.0, 2.0, 3.0], derivatives=[np.cos(t), -np.sin(t)])
    np.testing.assert_allclose(terms, [np.pi, 2 * np.pi, 3 * np.pi], rtol=1e-5)
    val = norms.sobolev_norm(t, z, [1.0, 2.0, 3.0], derivatives=[np.cos(t), -np.sin(t)])
    assert val == pytest.approx(np.sqrt(6 * np.pi), rel=1e-5)


def test_polynomial_finite_difference_is_exact_for_quadratics():
    # np.gradient with edge_order=2 is exact for quadratics on any grid
    t = nonuniform_grid(0.0, 1.0, 3001, seed=1)
    z = t ** 2
    d1 = norms.finite_difference(t, z, 1)
    np.testing.assert_allclose(d1, 2 * t, atol=1e-9)
    terms = norms.sobolev_norm_terms(t, z, [1.0, 1.0])
    # ∫ t⁴ = 1/5, ∫ (2t)² = 4/3 (trapezoid error only)
    np.testing.assert_allclose(terms, [1 / 5, 4 / 3], rtol=1e-5)


def test_finite_difference_accuracy_second_order():
    """Stated tolerance: on a smooth signal the FD norm has relative error < 1e-4 for
    ~1000 samples per unit of (frequency·time); halving h divides the error by ~4."""
    errs = []
    for n in (500, 1000):
        t = nonuniform_grid(0.0, 2 * np.pi, n, seed=2)
        exact = np.sqrt(np.pi + 0.5 * np.pi + 0.25 * np.pi)
        fd = norms.sobolev_norm(t, np.sin(t), [1.0, 0.5, 0.25])
        errs.append(abs(fd - exact) / exact)
    assert errs[1] < 1e-4
    assert errs[0] / errs[1] > 2.5  # second order (≈ 4), with margin for the irregular grid


def test_matrix_weight_and_vector_weight():
    t = nonuniform_grid(0.0, 2 * np.pi, 5000, seed=3)
    z = np.column_stack([np.sin(t), np.cos(t)])
    sigma = np.array([[2.0, 1.0], [1.0, 2.0]])
    # zᵀσz = 2 + sin 2t  → ∫ = 4π
    assert norms.sobolev_norm(t, z, [sigma], squared=True) == pytest.approx(4 * np.pi, rel=1e-6)
    # diagonal given as a vector
    assert norms.sobolev_norm(t, z, [[3.0, 1.0]], squared=True) == pytest.approx(4 * np.pi, rel=1e-6)


def test_ise_iae_iadu():
    t = nonuniform_grid(0.0, 2 * np.pi, 6000, seed=4)
    e = np.column_stack([np.sin(t), 2 * t])
    np.testing.assert_allclose(norms.ise(t, e), [np.pi, 4 * (2 * np.pi) ** 3 / 3], rtol=1e-5)
    assert norms.iae(t, np.sin(t)) == pytest.approx(4.0, rel=1e-5)
    # total variation of sin over a period is 4 (exact up to sampling of the extrema)
    assert norms.iadu(t, np.sin(t)) == pytest.approx(4.0, rel=1e-5)
    # a step of height 3 has total variation 3, whatever the grid
    u = np.where(t < 1.0, 0.0, 3.0)
    assert norms.iadu(t, u) == pytest.approx(3.0)
    assert norms.iadu(t, np.column_stack([u, -u])).tolist() == [3.0, 3.0]


def test_empirical_gain():
    t = np.linspace(0.0, 10.0, 2001)
    w = np.sin(t)
    z = 3.0 * w
    assert norms.empirical_gain(t, z, w) == pytest.approx(3.0, rel=1e-12)
    # initial-condition term subtracted from ‖z‖²
    nz2 = norms.sobolev_norm(t, z, [1.0], squared=True)
    g = norms.empirical_gain(t, z, w, initial_term=0.75 * nz2)
    assert g == pytest.approx(1.5, rel=1e-12)
    with pytest.raises(ValueError, match="zero L2 norm"):
        norms.empirical_gain(t, z, 0 * w)


@pytest.mark.parametrize("t, z, msg", [
    ([0.0, 1.0, 1.0], [1, 2, 3], "strictly increasing"),
    ([0.0, 2.0, 1.0], [1, 2, 3], "strictly increasing"),
    ([0.0, 1.0, 2.0], [1, 2], "2 samples but t has 3"),
    ([[0.0, 1.0]], [1, 2], "1-D"),
    ([0.0, np.nan], [1, 2], "finite"),
    ([0.0], [1], "at least 2"),
])
def test_bad_inputs(t, z, msg):
    with pytest.raises(ValueError, match=msg):
        norms.ise(t, z)


def test_bad_weights_and_derivatives():
    t = np.linspace(0, 1, 11)
    z = np.column_stack([t, t])
    with pytest.raises(ValueError, match="positive semidefinite"):
        norms.sobolev_norm(t, z, [np.diag([1.0, -1.0])])
    with pytest.raises(ValueError, match="sigmas\\[0\\]"):
        norms.sobolev_norm(t, z, [np.eye(3)])
    with pytest.raises(ValueError, match="derivatives must list"):
        norms.sobolev_norm(t, z, [1.0, 1.0], derivatives=[z, z])
    with pytest.raises(ValueError, match="transpose"):
        norms.ise(t, z.T)
    with pytest.raises(ValueError, match="sequence"):
        norms.sobolev_norm(t, z, 1.0)


def test_settling_time_of_an_exponential_decay():
    # y = e^{-t}: |y| leaves the 2 % band for good at t* = ln 50.  The interpolated crossing is
    # exact to the chord error of e^{-t} over one step, ≤ dt² max|y''| / 8 / |y'| ~ dt²/8;
    # the next-sample criterion lands on the first sample after t*, within one step.
    from sobolev_drake.norms import settling_time
    dt = 1e-3
    t = np.arange(0.0, 10.0, dt)
    y = np.exp(-t)
    exact = np.log(50.0)
    assert abs(settling_time(t, y, fraction=0.02) - exact) <= dt ** 2
    nxt = settling_time(t, y, fraction=0.02, crossing="next_sample")
    assert exact < nxt <= exact + dt
    # band relative to a given reference, counted only up to ``until``
    assert abs(settling_time(t, y, fraction=0.01, reference=2.0) - np.log(50.0)) <= dt ** 2
    assert settling_time(t, y, fraction=0.02, until=2.0) == pytest.approx(2.0, abs=dt)
    assert settling_time(t, 0.001 * y, fraction=0.5, reference=1.0) == 0.0   # never outside
    with pytest.raises(ValueError, match="crossing"):
        settling_time(t, y, fraction=0.02, crossing="last")
    with pytest.raises(ValueError, match="fraction"):
        settling_time(t, y, fraction=-0.1)


def test_fraction_at_bounds_counts_samples_with_any_input_on_a_bound():
    # 4 samples of 2 inputs in [0, 10]: sample 1 has an input on the lower bound, sample 2 one
    # beyond the upper bound, sample 3 one within rtol·10 of it; sample 0 is inside
    u = np.array([[1.0, 2.0], [0.0, 5.0], [3.0, 11.0], [4.0, 10.0 - 5e-6]])
    assert norms.fraction_at_bounds(u, 0.0, 10.0) == 0.75
    assert norms.fraction_at_bounds(u, 0.0, 10.0, rtol=1e-7) == 0.5
    # one input, symmetric box
    assert norms.fraction_at_bounds(np.array([-5.0, 0.0, 4.9, 5.0]), -5.0, 5.0) == 0.5
