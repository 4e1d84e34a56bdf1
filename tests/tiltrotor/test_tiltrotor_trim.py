"""Tilt-rotor trims (hover beside the thesis, level flight 0–34 m/s) and linearization (7.57)."""

import numpy as np
import pytest

from sobolev_drake.tiltrotor.linearization import linearize
from sobolev_drake.tiltrotor.tilt_schedule import (tilt_reference_polynomial, tilt_schedule,
                                                   write_tilt_schedule_report)
from sobolev_drake.tiltrotor.trim import THESIS_HOVER, balance, trim_hover, trim_level_flight
from sobolev_drake.tiltrotor.input_affine import generalized_force


@pytest.fixture(scope="module")
def hover():
    return trim_hover()


def test_hover_trim_beside_thesis(hover):
    assert hover.success and hover.residual_norm < 1e-8
    th = THESIS_HOVER
    assert hover.q[3] == pytest.approx(th["theta"], abs=1e-3)
    np.testing.assert_allclose(hover.q[:2], [th["alpha_R"], th["alpha_L"]], atol=1e-3)
    np.testing.assert_allclose(hover.n, th["n"], atol=0.1)
    np.testing.assert_allclose(hover.tau_s, th["tau_s"], atol=1e-3)
    # the thrust line is vertical: θ + α = 0 and no roll
    assert abs(hover.q[3] + hover.q[0]) < 1e-9 and abs(hover.q[2]) < 1e-9
    # independent check of the residual with the force functions
    r = balance(None, hover.q, hover.qdot, hover.zeta, hover.n, hover.tau_s, hover.delta)
    assert np.abs(r).max() < 1e-8


def test_level_flight_trims_exist_over_the_envelope():
    trims = tilt_schedule(np.arange(0.0, 34.5, 2.0))
    assert all(t.success for t in trims), [(t.V, t.residual_norm) for t in trims]
    alpha = np.array([t.q[0] for t in trims])
    assert np.all(np.diff(alpha) > 0)                      # rotors tilt forward with speed
    assert np.all(np.array([t.n[0] for t in trims]) > 20)
    # at low speed the schedule agrees with the mission polynomial (trim-derived in the thesis)
    low = np.array([t.V for t in trims]) <= 14
    np.testing.assert_allclose(alpha[low], tilt_reference_polynomial(np.array([t.V for t in trims])[low]),
                               atol=0.02)
    with pytest.raises(ValueError, match="V must be"):
        trim_level_flight(-1.0)


def test_prescribed_tilt_trim_uses_ruddervators():
    t = trim_level_flight(15.0, alpha=float(tilt_reference_polynomial(15.0)))
    assert t.success and t.residual_norm < 1e-8
    assert t.delta[2] == pytest.approx(t.delta[3], abs=1e-8) and abs(t.delta[2]) < 0.4363


def test_schedule_report(tmp_path):
    trims = tilt_schedule(np.array([0.0, 10.0, 20.0]))
    md, js, png = write_tilt_schedule_report(tmp_path, trims)
    assert md.exists() and js.exists() and png.stat().st_size > 1000
    assert "| 10 |" in md.read_text()


def test_linearization_matches_numpy_model(hover):
    lin = linearize(hover)
    A, B, D = lin.A, lin.B, lin.D
    assert A.shape == (20, 20) and B.shape == (20, 4) and D.shape == (20, 3)
    np.testing.assert_allclose(A[:8, 8:16], np.eye(8), atol=1e-8)
    np.testing.assert_allclose(A[16:, [4, 5, 6, 7]], np.eye(4))
    model = lin.trim.info["model"]
    Minv = np.linalg.inv(model.M(hover.q))
    h = 1e-5
    cols = []
    for j in range(4):
        du = np.zeros(4)
        du[j] = h
        u_p, u_m = hover.u[:4] + du, hover.u[:4] - du
        fp = generalized_force(model, hover.q, hover.qdot, hover.zeta, u_p[:2], u_p[2:], hover.delta)
        fm = generalized_force(model, hover.q, hover.qdot, hover.zeta, u_m[:2], u_m[2:], hover.delta)
        cols.append(Minv @ (fp - fm) / (2 * h))
    np.testing.assert_allclose(B[8:16], np.column_stack(cols), rtol=1e-5, atol=1e-6)
    # thrust increase lifts the aircraft: ∂z̈/∂n = 2 f / (n m) cos(θ+α)·cos β
    f = hover.thrust[0]
    assert B[15, 0] == pytest.approx(2 * f / hover.n[0] / 7.6 * np.cos(model.params.beta), rel=2e-2)
    # wind along x pushes back through the fuselage drag only weakly at hover
    assert abs(D[13, 0]) < 0.1
    # (A, B) stabilizable: every unstable mode is controllable (PBH test)
    for lam in np.linalg.eigvals(A):
        if lam.real >= -1e-9:
            rank = np.linalg.matrix_rank(np.hstack([A - lam * np.eye(20), B]), tol=1e-7)
            assert rank == 20, lam


def test_airplane_mode_trim_on_the_polynomial_tilt():
    """At 33 m/s the mission tilt (1.55 rad, rotors forward) trims with a nose-up attitude,
    n ≈ 77 rev/s and an elevator close to (slightly beyond) the ±25° limit."""
    t = trim_level_flight(33.0, alpha=float(tilt_reference_polynomial(33.0)))
    assert t.success and t.residual_norm < 1e-8
    assert -0.3 < t.q[3] < -0.1 and 60 < t.n[0] < 90
    assert abs(t.delta[2] - t.delta[3]) < 1e-8 and -0.6 < t.delta[2] < -0.4


def test_linearization_unpacks(hover):
    A, B, D = linearize(hover)
    assert A.shape == (20, 20) and B.shape == (20, 4) and D.shape == (20, 3)
    lin = linearize(hover, include_surfaces=True)
    assert lin.B.shape == (20, 8) and len(lin.input_names) == 8
    assert np.abs(lin.B[:, 4:]).max() < 1e-9          # no air speed at hover: surfaces inert


def test_hover_wind_limit_crosswind_vs_thesis_crossflow():
    """Heading-held hover in a steady lateral wind: with the thesis' crossflow form the attitude
    passes 60° at ≈ 12.5 m/s (flat-plate α-table drag in sideways flow); with the independence
    principle the trims exist to ≈ 21 m/s, mirror-symmetric, and headwind is no limit.  The
    thesis' form is both literal readings (crossflow and reverse flow): its crossflow terms with
    the mirrored reverse flow jump at u = 0, which a heading-held hover in crosswind sits on."""
    from sobolev_drake.tiltrotor.plant import TiltrotorModel
    from sobolev_drake.tiltrotor.params import TiltrotorParams
    from sobolev_drake.tiltrotor.trim import hover_wind_limit

    right, left = hover_wind_limit(90.0), hover_wind_limit(270.0)
    assert 19.0 < right.limit < 23.0 and abs(right.limit - left.limit) < 0.1
    assert all(t.success and t.residual_norm < 1e-8 for t in right.trims)
    att = right.attitude_deg()
    assert att[0] == pytest.approx(np.degrees(THESIS_HOVER["theta"]), abs=0.1) and att.max() <= 60.0
    r = right.trims[16]                                   # 8 m/s: the trim balances independently
    np.testing.assert_allclose(balance(None, r.q, r.qdot, r.zeta, r.n, r.tau_s, r.delta), 0, atol=1e-8)
    assert hover_wind_limit(180.0, max_speed=15.0).limit == np.inf
    thesis = hover_wind_limit(90.0, model=TiltrotorModel(TiltrotorParams(crossflow="thesis",
                                                                         reverse_flow="clipped")))
    assert 12.0 < thesis.limit < 13.0 and "passes 60°" in thesis.reason
    assert thesis.attitude_deg()[-1] > 55.0
    with pytest.raises(ValueError, match="attitude_limit_deg"):
        hover_wind_limit(90.0, attitude_limit_deg=95.0)
    with pytest.raises(ValueError, match="step must be finite and positive"):
        hover_wind_limit(90.0, step=0.0)
