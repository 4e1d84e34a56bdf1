"""C² junction smoothing of piecewise references (issue #33, build item 3)."""

import numpy as np
import pytest
from pydrake.autodiffutils import AutoDiffXd

from sobolev_drake.systems.reference_catalogue import tiltrotor_mission_reference, trajectory
from sobolev_drake.systems.reference_smoothing import (blend_coordinates, smooth_junctions,
                                                       smootherstep)
from sobolev_drake.systems.references import (PiecewiseTrajectory, TrajectoryReference, const,
                                              poly, sine)

EPS = 1e-6          # one-sided probe distance (s)
DIFF = 1e-3         # step of the one-sided difference that bounds the next derivative


def half_window(tr, h=1.0):
    gaps = np.diff(tr.breakpoints)
    return min(h, 0.4 * float(gaps.min())) if gaps.size else h


def one_sided_gaps(tr, c):
    """|f(c + ε) − f(c − ε)| for f = q, q̇, q̈, and the tolerance each may reach if f is C¹
    on both sides: 2ε·max|f′| (mean value theorem), f′ bounded by the larger of q̇, q̈ and a
    one-sided difference of q̈ (step DIFF, both points on the same side) with a factor 2 of
    margin for its O(DIFF) error, plus float rounding 1e-9·(1 + |f|)."""
    lo, hi = tr.evaluate(c - EPS), tr.evaluate(c + EPS)
    gaps = [np.abs(b - a) for a, b in zip(lo, hi)]
    jerk = np.maximum(np.abs(tr.evaluate(c - EPS)[2] - tr.evaluate(c - EPS - DIFF)[2]),
                      np.abs(tr.evaluate(c + EPS + DIFF)[2] - tr.evaluate(c + EPS)[2])) / DIFF
    nxt = [np.abs(lo[1]) + np.abs(hi[1]), np.abs(lo[2]) + np.abs(hi[2]), 2.0 * jerk]
    tols = [2 * EPS * n + 1e-9 * (1 + np.abs(f)) for n, f in zip(nxt, lo)]
    return gaps, tols


@pytest.mark.parametrize("name", ["envelope_mission", "table_5_5", "table_7_1"])  # those with junctions
def test_smoothed_reference_is_c2_at_every_window_end(name):
    tr = trajectory(name)
    h = half_window(tr)
    sm = smooth_junctions(tr, h)
    np.testing.assert_allclose(sm.breakpoints, np.ravel([[b - h, b + h] for b in tr.breakpoints]))
    for c in sm.breakpoints:
        gaps, tols = one_sided_gaps(sm, c)
        for order, (g, tol) in enumerate(zip(gaps, tols)):
            assert np.all(g <= tol), (name, c, order, g, tol)
    # inside the windows too (the old junction is now interior): continuous to second order
    for b in tr.breakpoints:
        gaps, tols = one_sided_gaps(sm, b)
        assert all(np.all(g <= tol) for g, tol in zip(gaps, tols)), (name, b)


def test_the_check_detects_the_unsmoothed_steps():
    # the same probe fails on the tabulated envelope mission: 2.59 m/s² lateral step at 86 s
    tr = trajectory("envelope_mission")
    gaps, tols = one_sided_gaps(tr, 86.0)
    assert np.max(gaps[2] - tols[2]) > 2.0
    sm = smooth_junctions(tr, 2.0)
    assert {r["class"] for r in sm.smoothness(tol=1e-6)} == {"C2+"}
    assert {r["class"] for r in tr.smoothness(tol=1e-6)} != {"C2+"}


@pytest.mark.parametrize("name", ["envelope_mission", "table_5_5", "table_7_1"])
def test_equal_to_the_original_outside_the_windows_exactly(name):
    tr = trajectory(name)
    h = half_window(tr)
    sm = smooth_junctions(tr, h)
    t = np.linspace(-5.0, float(tr.breakpoints[-1]) + 30.0, 4001)
    outside = np.all(np.abs(t[:, None] - tr.breakpoints[None, :]) > h, axis=1)
    for a, b in zip(tr.evaluate(t[outside]), sm.evaluate(t[outside])):
        np.testing.assert_array_equal(a, b)
    for s in t[outside][::50]:
        assert tr.evaluate_scalar(float(s)) == sm.evaluate_scalar(float(s))
    # and it does change something inside (the windows are not empty)
    inside = t[~outside]
    assert not np.array_equal(tr.evaluate(inside)[2], sm.evaluate(inside)[2])


def test_blend_derivatives_are_the_time_derivatives():
    # analytic q̇, q̈ of the blend against central differences: truncation δ²/6·max|q⁗| with
    # |q⁗| ≲ 600 here (w⁗ ∝ 1/h⁴ times the pieces' gap) → 1e-8, rounding 1e-16·|q̇|/δ ≈ 1e-10
    c = blend_coordinates(sine(2.0, 0.7, phase=0.3), poly([1.0, -0.5, 0.25, 0.1]), 3.0, 2.0)
    t = np.linspace(3.05, 4.95, 40)
    d = 1e-5
    f, df, ddf = c(t)
    np.testing.assert_allclose((c(t + d)[0] - c(t - d)[0]) / (2 * d), df, atol=1e-7)
    np.testing.assert_allclose((c(t + d)[1] - c(t - d)[1]) / (2 * d), ddf, atol=1e-7)
    # float fast path and vectorized form agree
    for s in t[::7]:
        np.testing.assert_allclose(c.scalar(float(s)), [v[0] for v in c(np.array([s]))], rtol=1e-14)


def test_smootherstep_end_values():
    for s, expected in ((0.0, (0.0, 0.0, 0.0)), (2.0, (1.0, 0.0, 0.0))):
        np.testing.assert_allclose(smootherstep(s, 0.0, 2.0), expected, atol=1e-15)


def test_any_scalar_type_through_the_leaf_system():
    sm = smooth_junctions(trajectory("envelope_mission"), 2.0)
    t = 85.3   # inside the 86 s window
    q, qd, qdd = sm.evaluate(t)
    ad = AutoDiffXd(t, np.array([1.0]))
    qa, qda, _ = sm.evaluate_any(ad)
    np.testing.assert_allclose([v.value() for v in qa], q, rtol=1e-14)
    # dq/dt from the autodiff chain rule is the analytic q̇
    np.testing.assert_allclose([v.derivatives()[0] for v in qa], qd, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose([v.derivatives()[0] for v in qda], qdd, rtol=1e-12, atol=1e-12)
    ref = TrajectoryReference(sm)
    assert ref.ToAutoDiffXd() is not None and ref.ToSymbolic() is not None


def test_mission_reference_option():
    off = tiltrotor_mission_reference(2)
    on = tiltrotor_mission_reference(2, smooth_reference=2.0)
    assert off.trajectory.breakpoints.size == 5 and on.trajectory.breakpoints.size == 10
    # the lateral acceleration rises through the window instead of stepping (2.59 m/s²)
    _, _, a = on.trajectory.evaluate(np.array([84.0, 86.0, 88.0]))
    np.testing.assert_allclose(np.hypot(a[[0, 2], 0], a[[0, 2], 1]), [0.0, 33 * 2 * np.pi / 80],
                               atol=1e-9)


@pytest.mark.parametrize("bad", [0.0, -1.0, float("nan"), float("inf"), "1", None, 10.0])
def test_bad_half_window_is_refused_naming_the_argument(bad):
    tr = trajectory("envelope_mission")   # shortest phase 20 s: h must be < 10
    with pytest.raises((TypeError, ValueError), match="half_window"):
        smooth_junctions(tr, bad)
    if bad is not None:
        with pytest.raises((TypeError, ValueError), match="smooth_reference"):
            tiltrotor_mission_reference(2, smooth_reference=bad)


def test_bad_trajectory_and_coordinates_refused():
    with pytest.raises(TypeError, match="trajectory"):
        smooth_junctions("envelope", 1.0)
    with pytest.raises(TypeError, match="left"):
        blend_coordinates(1.0, const(0.0), 0.0, 1.0)
    with pytest.raises(ValueError, match="width"):
        blend_coordinates(const(0.0), const(1.0), 0.0, 0.0)
    one = PiecewiseTrajectory(["x"], [[const(1.0)]])
    assert smooth_junctions(one, 1.0) is one
