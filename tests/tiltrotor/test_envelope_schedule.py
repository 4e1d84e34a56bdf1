"""The envelope gain schedule of the tilt-rotor W∞ law (tiltrotor.gain_schedule): the weights
read off the target poles give those poles through the library's CAREs, the blend is C² and the
gains continuous, every frozen point of the schedule is a stable closed loop (Drake
linearization of the plant), and the thesis row is untouched."""

import math

import numpy as np
import pytest

from sobolev_drake.synthesis.mechanical import controlled_gains, regulated_gains
from sobolev_drake.tiltrotor.gain_schedule import (REGIMES, SCHEDULE_SPEEDS, ChannelTarget,
                                                   EnvelopeSchedule, blend_factor, target_gains,
                                                   target_polynomial, target_weights)

TARGETS = [ChannelTarget(0.6, 1.0, 0.25), ChannelTarget(1.0, 1.0, 0.25), ChannelTarget(0.9, 1.3, 0.5)]


@pytest.mark.parametrize("target", TARGETS)
def test_inverse_weights_give_the_target_poles_through_the_care(target):
    # scipy's CARE on a 3-state chain with weights of order 1: gains to ~1e-9 relative
    w = target_weights(target, 3)
    K = controlled_gains(*w).K.ravel()
    assert K == pytest.approx(target_gains(target, 3), rel=1e-7)
    poles = np.linalg.eigvals(controlled_gains(*w).closed_loop)
    assert np.sort_complex(poles) == pytest.approx(np.sort_complex(np.roots(target_polynomial(target, 3))),
                                                   abs=1e-6)
    pair = ChannelTarget(target.omega, target.zeta)
    assert regulated_gains(*target_weights(pair, 2)).K.ravel() == pytest.approx(target_gains(pair, 2),
                                                                                 rel=1e-7)


def test_targets_without_nonnegative_weights_are_refused():
    with pytest.raises(ValueError, match="zeta"):
        target_polynomial(ChannelTarget(1.0, 0.5), 2)
    with pytest.raises(ValueError, match="integral"):
        target_polynomial(ChannelTarget(1.0, 1.0), 3)
    with pytest.raises(ValueError, match="order"):
        target_polynomial(ChannelTarget(1.0, 1.0), 4)


def test_blend_is_c2_and_the_gains_continuous():
    lo, hi = SCHEDULE_SPEEDS
    h = 1e-4
    for U in (lo, hi):
        # first and second one-sided differences vanish at the corridor's ends (C²): the
        # quintic's terms are O(h³) there
        assert abs(blend_factor(U + h) - blend_factor(U - h)) < 1e-9
    U = np.linspace(-5.0, 40.0, 4501)
    s = np.array([blend_factor(u) for u in U])
    assert s[0] == 0.0 and s[-1] == 1.0 and np.all(np.diff(s) >= 0)
    # the slope of the smootherstep is at most 15/8 per corridor width
    assert np.max(np.diff(s) / np.diff(U)) <= 15 / 8 / (hi - lo) + 1e-9
    sched = EnvelopeSchedule(lambda U: 0.0)
    k = np.array([np.concatenate([np.ravel(v) for v in sched.gains(u).values()]) for u in U])
    assert np.max(np.abs(np.diff(k, axis=0))) < 0.05     # no jump over a 1 cm/s step
    assert sched.gains(0.0) == sched.gains(lo) and sched.gains(40.0) == sched.gains(hi)


def test_attitude_reference_banks_into_the_turn_and_holds_trim_pitch():
    sched = EnvelopeSchedule(lambda U: -0.1)
    ref = [0.0] * 12
    ref[3], ref[9] = 0.0, 2.59          # heading +x, acceleration towards +y (a left turn)
    phi, theta = sched.attitude_reference(33.0, ref)
    assert phi == pytest.approx(-math.atan2(2.59, 9.80665)) and theta == -0.1


@pytest.fixture(scope="module")
def frozen():
    from sobolev_drake.tiltrotor.envelope_analysis import frozen_point
    return {(d, V): frozen_point(V, d) for d in ("scheduled", "thesis") for V in (0.0, 5.0, 15.0, 30.0)}


def test_every_frozen_point_of_the_schedule_is_stable(frozen):
    for V in (0.0, 5.0, 15.0, 30.0):
        fp = frozen[("scheduled", V)]
        # the slowest designed pole is the integral of x at 0.25·0.6 = 0.15 1/s; the
        # coupling leaves > 0.04 1/s everywhere (margin ≫ the 1e-6 linearization step)
        assert fp.spectral_abscissa < -0.03, (V, fp.poles[:4])
        assert fp.min_damping > 0.3, (V, fp.poles[:4])


def test_cruise_frozen_point_has_the_designed_poles(frozen):
    # above the corridor the allocation realizes u* exactly: the poles are the targets'
    fp = frozen[("scheduled", 30.0)]
    c = REGIMES["cruise"]
    assert fp.spectral_abscissa == pytest.approx(-c.xy.integral * c.xy.omega, abs=1e-3)


def test_thesis_tuning_leaves_attitude_without_stiffness(frozen):
    # the finding, kept on the page: the thesis law only damps φ̇, θ̇ (two poles at 0
    # in cruise) and its hover pitch mode is barely damped
    assert frozen[("thesis", 30.0)].spectral_abscissa > -1e-6
    assert frozen[("thesis", 0.0)].min_damping < 0.2


def test_thesis_law_is_the_one_without_a_schedule():
    from sobolev_drake.tiltrotor.law import make_law
    from sobolev_drake.tiltrotor.trim import tiltrotor_model
    model = tiltrotor_model()
    assert make_law(model).desired_acceleration is None
    assert isinstance(make_law(model, design="scheduled").desired_acceleration, EnvelopeSchedule)
    with pytest.raises(ValueError, match="design"):
        make_law(model, design="lpv")
    with pytest.raises(ValueError, match="gain_schedule"):
        make_law(model, gain_schedule=EnvelopeSchedule(lambda U: 0.0))


#: state at t = 3 s of the envelope mission with the thesis tuning, flown by the code before
#: the schedule existed (commit b37fd04): the thesis row must keep giving the same flight
THESIS_STATE_3S = [-1.4707529133364830e-01, -1.4707529133364816e-01, 1.2898430577484629e-17,
                   2.7886576003364666e-01, 8.2658568153510242e-17, 2.2138198046988761e-01,
                   -8.9281516738301495e-16, 1.0182558468586140e+00, 1.0485938652714872e-02,
                   1.0485938652714575e-02, -9.7979559261288508e-17, 3.3113726862497722e-02,
                   -1.3456146263082162e-17, 9.5955162619493928e-01, -5.4127343073181245e-16,
                   3.0634958923563615e-01]


def test_thesis_row_flies_as_before():
    from sobolev_drake.tiltrotor.mission import simulate_mission
    _, d = simulate_mission(2, 3.0, design="thesis")
    # same code path and integrator: equal to the last bits on one machine; 1e-9 leaves room
    # for another BLAS/libm (states are O(1))
    assert d["x"][:, -1] == pytest.approx(THESIS_STATE_3S, abs=1e-9)
    _, s = simulate_mission(2, 3.0, design="scheduled")
    assert np.max(np.abs(s["x"][:, -1] - THESIS_STATE_3S)) > 1e-3     # the schedule differs
