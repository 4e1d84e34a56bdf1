"""Control allocation (7.84)–(7.89) and thrust inversion (7.90)."""

import math

import cvxpy as cp
import numpy as np
import pytest

from sobolev_drake.systems import bounded_ls as bls
from sobolev_drake.tiltrotor import allocation as al
from sobolev_drake.tiltrotor.allocation import (
    ControlAllocator, UnreachableThrustError, bounded_least_squares, propeller_speed_for_thrust,
    sigmf, tiltrotor_bounds)
from sobolev_drake.tiltrotor.propeller import PropellerCoefficients


def reference_qp(B, u, lo, hi):
    x = cp.Variable(B.shape[1])
    prob = cp.Problem(cp.Minimize(cp.sum_squares(u - B @ x)), [x >= lo, x <= hi])
    prob.solve(solver=cp.CLARABEL, tol_gap_abs=1e-12, tol_gap_rel=1e-12, tol_feas=1e-12, tol_ktratio=1e-10)
    assert prob.status == "optimal"
    return np.asarray(x.value), prob.value


def random_problem(rng, n=8, m=8):
    B = rng.standard_normal((n, m)) * rng.uniform(0.2, 5.0, m)       # mixed column scales
    u = rng.standard_normal(n) * rng.uniform(0.5, 10.0)
    lo = -rng.uniform(0.05, 2.0, m) * rng.integers(0, 2, m)            # some lower bounds at 0
    hi = rng.uniform(0.05, 2.0, m)
    return B, u, lo, hi


def test_matches_reference_qp_on_random_problems():
    rng = np.random.default_rng(2024)
    worst, n_active = 0.0, []
    for _ in range(120):
        B, u, lo, hi = random_problem(rng)
        tau, info = bounded_least_squares(B, u, lo, hi, return_info=True)
        ref, _ = reference_qp(B, u, lo, hi)
        worst = max(worst, np.max(np.abs(tau - ref)))
        assert np.all(tau >= lo) and np.all(tau <= hi)
        assert info["residual"] == pytest.approx(np.linalg.norm(u - B @ tau))
        n_active.append(np.count_nonzero(info["active"]))
    assert worst < 1e-6, worst
    assert 0 < np.mean(n_active) < 8  # the set exercises active and inactive bounds


def test_methods_and_fallbacks_agree():
    rng = np.random.default_rng(7)
    for _ in range(30):
        B, u, lo, hi = random_problem(rng)
        ref, _ = reference_qp(B, u, lo, hi)
        assert np.max(np.abs(bounded_least_squares(B, u, lo, hi, method="osqp") - ref)) < 1e-6
        # primal active-set method on the unscaled problem
        H, g = B.T @ B, B.T @ u
        s, *_ = bls.box_qp_active_set(H, g, lo, hi, max_iter=100)
        assert np.max(np.abs(s - ref)) < 1e-6
        assert np.max(np.abs(bls.bvls_with_regularization(B, u, lo, hi, 0.0) - ref)) < 1e-6


def test_unconstrained_solution_when_no_bound_is_active():
    rng = np.random.default_rng(3)
    for _ in range(50):
        B = rng.standard_normal((8, 8))
        lo, hi = -np.ones(8), np.ones(8)
        tau0 = rng.uniform(-0.9, 0.9, 8)
        u = B @ tau0 + 0.0
        tau, info = bounded_least_squares(B, u, lo, hi, return_info=True)
        assert np.max(np.abs(tau - tau0)) < 1e-7
        assert not np.any(info["active"])
        # Overdetermined, consistent or not: equals the plain least-squares solution.
        B2 = rng.standard_normal((10, 8))
        u2 = rng.standard_normal(10) * 0.3
        ls = np.linalg.lstsq(B2, u2, rcond=None)[0]
        box = np.abs(ls) + 1.0
        assert np.max(np.abs(bounded_least_squares(B2, u2, -box, box) - ls)) < 1e-8


def test_warm_start_changes_nothing_but_iterations():
    rng = np.random.default_rng(5)
    for _ in range(30):
        B, u, lo, hi = random_problem(rng)
        tau, info = bounded_least_squares(B, u, lo, hi, return_info=True)
        tau2, info2 = bounded_least_squares(B, u, lo, hi, warm_start=info["active"], return_info=True)
        assert np.max(np.abs(tau - tau2)) < 1e-12 and info2["iterations"] == 1
        tau3 = bounded_least_squares(B, u, lo, hi, warm_start=-np.ones(8, dtype=int))
        assert np.max(np.abs(tau - tau3)) < 1e-9


def test_rank_deficient_problems():
    rng = np.random.default_rng(11)
    for _ in range(40):
        B, u, lo, hi = random_problem(rng)
        B[:, 4:] = 0.0                                       # surfaces with no authority
        B[:, 3] = B[:, 2]                                    # duplicated column
        tau, info = bounded_least_squares(B, u, lo, hi, return_info=True)
        _, best = reference_qp(B, u, lo, hi)
        assert info["residual"] ** 2 == pytest.approx(best, rel=1e-7, abs=1e-9)
        assert np.all(tau >= lo) and np.all(tau <= hi)
        # Zero columns: the regularization keeps them at the "do nothing" command clip(0, lo, hi).
        assert np.allclose(tau[4:], np.clip(0.0, lo[4:], hi[4:]), atol=1e-9)
        # Without regularization the singular subproblem falls back to BVLS, same optimum.
        tau0, info0 = bounded_least_squares(B, u, lo, hi, regularization=0.0, return_info=True)
        assert info0["method"] == "lsq_linear_bvls"
        assert info0["residual"] ** 2 == pytest.approx(best, rel=1e-7, abs=1e-9)


def test_fixed_variables_and_scalar_bounds():
    rng = np.random.default_rng(1)
    B = rng.standard_normal((8, 8))
    u = rng.standard_normal(8)
    lo, hi = -np.ones(8), np.ones(8)
    lo[2] = hi[2] = 0.3
    tau = bounded_least_squares(B, u, lo, hi)
    assert tau[2] == 0.3
    ref, _ = reference_qp(B, u, lo, hi)
    assert np.max(np.abs(tau - ref)) < 1e-6
    assert np.allclose(bounded_least_squares(B, u, -1.0, 1.0), bounded_least_squares(B, u, -np.ones(8), np.ones(8)))


def test_bad_inputs_raise_clear_errors():
    B, u = np.eye(8), np.ones(8)
    with pytest.raises(ValueError, match="B must be"):
        bounded_least_squares(np.ones(8), u, -1, 1)
    with pytest.raises(ValueError, match="u must be a vector of length n = 8"):
        bounded_least_squares(B, np.ones(7), -1, 1)
    with pytest.raises(ValueError, match="lo and hi must be vectors of length m = 8"):
        bounded_least_squares(B, u, -np.ones(7), np.ones(8))
    with pytest.raises(ValueError, match="lo <= hi"):
        bounded_least_squares(B, u, np.ones(8), -np.ones(8))
    with pytest.raises(ValueError, match="finite"):
        bounded_least_squares(B, np.full(8, np.nan), -1, 1)
    with pytest.raises(ValueError, match="finite"):
        bounded_least_squares(B, u, -np.inf, 1)
    with pytest.raises(ValueError, match="method"):
        bounded_least_squares(B, u, -1, 1, method="magic")
    with pytest.raises(ValueError, match="warm_start"):
        bounded_least_squares(B, u, -1, 1, warm_start=[0, 1])
    with pytest.raises(ValueError, match="regularization"):
        bounded_least_squares(B, u, -1, 1, regularization=-1.0)


def test_tiltrotor_bounds_and_sigmoid():
    lo, hi = tiltrotor_bounds(0.0)
    assert np.allclose(lo[:4], [0, 0, -2, -2]) and np.allclose(hi[:4], [100, 100, 2, 2])
    dmax = 5 * math.pi / 36
    assert np.max(hi[4:]) < 1e-9 and np.allclose(lo[4:], -hi[4:])
    for v, frac in ((12.0, 0.5), (30.0, 1.0)):
        _, hi = tiltrotor_bounds(v)
        assert np.allclose(hi[4:], frac * dmax, rtol=1e-6)
    for v in np.linspace(0, 8, 17):  # near-zero surface authority below ≈ 8 m/s
        assert np.max(tiltrotor_bounds(v)[1][4:]) <= dmax * 3.4e-4
    lo, hi = tiltrotor_bounds([0.0, 12.0, 30.0, 5.0])
    assert hi[5] == pytest.approx(dmax / 2) and hi[6] == pytest.approx(dmax, rel=1e-6)
    assert sigmf(12.0) == 0.5 and np.isfinite(sigmf(-1e5)) and sigmf(1e5) == 1.0
    assert sigmf(0.0) == pytest.approx(1 / (1 + math.exp(24)))
    with pytest.raises(ValueError, match="v_air"):
        tiltrotor_bounds([1.0, 2.0])
    with pytest.raises(ValueError, match="v_air"):
        tiltrotor_bounds(-1.0)


def test_surfaces_get_no_authority_at_low_airspeed():
    rng = np.random.default_rng(9)
    B = rng.standard_normal((8, 8))
    B[:, 4:] *= 50.0                                   # strong surfaces: they would be used if allowed
    u = 30.0 * rng.standard_normal(8)
    for v in (0.0, 4.0, 8.0):
        tau = bounded_least_squares(B, u, *tiltrotor_bounds(v))
        assert np.max(np.abs(tau[4:])) <= 5 * math.pi / 36 * sigmf(8.0) + 1e-15
    tau = bounded_least_squares(B, u, *tiltrotor_bounds(33.0))
    assert np.max(np.abs(tau[4:])) > 0.1


def test_control_allocator_system():
    rng = np.random.default_rng(4)
    B, u, _, _ = random_problem(rng)
    alloc = ControlAllocator()                         # tilt-rotor bounds from airspeed
    ctx = alloc.CreateDefaultContext()
    alloc.GetInputPort("u_star").FixValue(ctx, u)
    alloc.GetInputPort("B").FixValue(ctx, B.ravel())   # row-major
    for v in (0.0, 20.0):
        alloc.GetInputPort("airspeed").FixValue(ctx, [v])
        tau = alloc.GetOutputPort("tau").Eval(ctx)
        expected = bounded_least_squares(B, u, *tiltrotor_bounds(v))
        assert np.max(np.abs(tau - expected)) < 1e-12
        assert alloc.GetOutputPort("residual").Eval(ctx)[0] == pytest.approx(np.linalg.norm(u - B @ tau))
    lo, hi = -np.ones(8), np.ones(8)
    const = ControlAllocator(8, 8, (lo, hi))
    c2 = const.CreateDefaultContext()
    const.GetInputPort("u_star").FixValue(c2, u)
    const.GetInputPort("B").FixValue(c2, B.ravel())
    assert np.allclose(const.GetOutputPort("tau").Eval(c2), bounded_least_squares(B, u, lo, hi))
    via_port = ControlAllocator(6, 3, "input")
    c3 = via_port.CreateDefaultContext()
    B3 = rng.standard_normal((6, 3))
    via_port.GetInputPort("u_star").FixValue(c3, np.ones(6))
    via_port.GetInputPort("B").FixValue(c3, B3.ravel())
    via_port.GetInputPort("bounds").FixValue(c3, np.r_[-0.1 * np.ones(3), 0.1 * np.ones(3)])
    assert np.allclose(via_port.GetOutputPort("tau").Eval(c3),
                       bounded_least_squares(B3, np.ones(6), -0.1, 0.1))
    with pytest.raises(ValueError, match="bounds must be"):
        ControlAllocator(8, 8, bounds=3.0)
    with pytest.raises(ValueError, match="n must be a positive integer"):
        ControlAllocator(0, 8)
    with pytest.raises(ValueError, match="length m = 4"):
        ControlAllocator(8, 4, (lo, hi))


def test_thrust_inversion_round_trip_over_full_range():
    pc = PropellerCoefficients()
    J, phi = np.meshgrid(np.linspace(0.0, 0.75, 16), np.linspace(0.0, math.pi / 2, 9))
    rng = np.random.default_rng(0)
    n = rng.uniform(1.0, 100.0, J.shape)
    v_xz = J * n * pc.diameter
    f = pc.thrust(n, J, phi)
    ok = f > 1e-6                                          # Ct(J→0.75, φ≈0) ≤ 0: no positive thrust
    assert ok.mean() > 0.95
    n_hat = propeller_speed_for_thrust(f[ok], v_xz[ok], phi[ok], coefficients=pc)
    assert np.max(np.abs(n_hat - n[ok]) / n[ok]) < 1e-6
    # Thrust at the recovered speed (with J recomputed from n_hat) reproduces the request.
    J_hat = np.clip(v_xz[ok] / (n_hat * pc.diameter), 0, 0.75)
    assert np.max(np.abs(pc.thrust(n_hat, J_hat, phi[ok]) - f[ok])) < 1e-6
    # Hover trim of the thesis: n = 51.9 rev/s per rotor at J = 0.
    f_hover = pc.thrust(51.9, 0.0, 0.0)
    assert propeller_speed_for_thrust([f_hover, f_hover]) == pytest.approx([51.9, 51.9], rel=1e-9)
    assert propeller_speed_for_thrust(0.0, 10.0, 0.3) == 0.0


def test_thrust_inversion_errors_and_clipping():
    with pytest.raises(UnreachableThrustError, match="unreachable.*achievable range"):
        propeller_speed_for_thrust(200.0)
    with pytest.raises(UnreachableThrustError, match="unreachable"):
        propeller_speed_for_thrust([10.0, -5.0], [0.0, 0.0], [0.0, 0.0])
    assert propeller_speed_for_thrust(200.0, on_unreachable="clip") == pytest.approx(100.0)
    assert propeller_speed_for_thrust(-1.0, on_unreachable="clip") == 0.0
    with pytest.raises(ValueError, match="v_xz"):
        propeller_speed_for_thrust(10.0, -1.0)
    with pytest.raises(ValueError, match="finite"):
        propeller_speed_for_thrust(np.nan)
    with pytest.raises(ValueError, match="on_unreachable"):
        propeller_speed_for_thrust(1.0, on_unreachable="ignore")
    with pytest.raises(ValueError):
        propeller_speed_for_thrust([1.0, 2.0], [0.0, 0.0, 0.0])  # shapes do not broadcast
    with pytest.raises(ValueError, match="v_rel_rotor_frame"):
        al.rotor_inflow(np.zeros((2, 2)))
    v_xz, phi = al.rotor_inflow([[3.0, 9.0, 4.0], [-1.0, 0.0, -1.0]])
    assert np.allclose(v_xz, [5.0, math.sqrt(2)]) and np.allclose(phi, [math.atan2(3, 4), math.pi / 2])


@pytest.mark.parametrize("speed", [0.0, 20.0])
def test_allocation_and_inversion_reproduce_tiltrotor_trim(speed):
    """End to end with the plant's input-affine map: at a level-flight trim (q̈ = 0) the
    generalized input u* = C q̇ + g − ϑ_passive must be allocated back to the trim's thrusts,
    servo torques and δ = 0 (hover: B has rank 4, the surface columns vanish), and (7.90) must
    return the trim's propeller speeds."""
    trim_mod = pytest.importorskip("sobolev_drake.tiltrotor.trim")
    ia = pytest.importorskip("sobolev_drake.tiltrotor.input_affine")
    model = trim_mod.tiltrotor_model()
    tr = trim_mod.trim_hover() if speed == 0 else trim_mod.trim_level_flight(speed)
    assert tr.success
    B, passive = ia.input_affine(model, tr.q, tr.qdot, tr.zeta, n=tr.n)
    u = model.Cqdot(tr.q, tr.qdot) + model.g(tr.q) - passive
    tau, info = bounded_least_squares(B, u, *tiltrotor_bounds(speed), return_info=True)
    assert info["residual"] < 1e-9
    assert np.allclose(tau[:2], tr.thrust, rtol=1e-9)
    assert np.allclose(tau[2:4], tr.tau_s, atol=1e-9)
    assert np.allclose(tau[4:], tr.delta, atol=1e-9)
    prop, _ = ia.cores(model.params)
    v_xz, phi = al.rotor_inflow(prop.rotor_air_velocity(tr.q, tr.qdot, tr.zeta))
    assert np.allclose(propeller_speed_for_thrust(tau[:2], v_xz, phi), tr.n, rtol=1e-8)


def test_underdetermined_picks_range_scaled_minimum_norm():
    # n < m with no active bound: the exact solution of minimum norm in the scaled variables
    # s = (τ̄ − clip(0, lo, hi)) / ((hi − lo)/2) (module docstring of allocation).
    rng = np.random.default_rng(0)
    B = rng.standard_normal((4, 8))
    u = 0.3 * rng.standard_normal(4)
    lo, hi = -2.0 * np.ones(8), np.r_[3.0 * np.ones(4), 1.0 * np.ones(4)]
    tau, info = bounded_least_squares(B, u, lo, hi, return_info=True)
    D = np.diag((hi - lo) / 2)
    assert info["residual"] < 1e-12
    assert np.max(np.abs(tau - D @ np.linalg.pinv(B @ D) @ u)) < 1e-12


def test_fast_default_path_equals_general_path(monkeypatch):
    """The default call (PDAS, ε > 0, open boxes) runs the compiled kernel or, without it, the
    Python tier ``_bls_fast_python`` of the same algorithm; either must reproduce the general
    numpy path (the reference) — solution, active set, iterations — including nearly zero
    (surface-like) columns, warm-started or not."""
    rng = np.random.default_rng(17)
    probs = []
    for k in range(120):
        B, u, lo, hi = random_problem(rng)
        if k % 3 == 0:
            B[:, 4:] *= 1e-9                           # surfaces at low air speed
        if k % 4 == 0:
            lo[4:], hi[4:] = -1e-5, 1e-5               # and their nearly closed boxes
        probs.append((B, u, lo, hi))
    fast = [bounded_least_squares(*p, return_info=True) for p in probs]
    warm = [bounded_least_squares(*p, warm_start=f[1]["active"], return_info=True)
            for p, f in zip(probs, fast)]
    from sobolev_drake.systems import bounded_ls
    monkeypatch.setattr(bounded_ls, "_bls_fast", lambda *a, **k: None)
    for p, (tf, inf), (tw, _) in zip(probs, fast, warm):
        tg, ing = bounded_least_squares(*p, return_info=True)
        # The Python tier makes the reference's LAPACK calls (measured: ≤ 2.5 ε apart); the
        # kernel solves with its own LU and SVD loops, so its τ̄ differs by the forward error
        # of those 8×8 solves, cond(H_ff)·ε·|s| (measured: 2.1e2 ε).  1e-13 ≈ 450 ε.
        assert np.max(np.abs(tf - tg)) <= 1e-13 * (1 + np.max(np.abs(tg)))
        assert np.array_equal(inf["active"], ing["active"]) and inf["iterations"] == ing["iterations"]
        assert inf["residual"] == pytest.approx(ing["residual"], rel=1e-12, abs=1e-14)
        assert np.max(np.abs(tw - tg)) < 1e-9
