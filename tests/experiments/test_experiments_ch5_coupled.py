"""Chapter-5 input-coupling experiments (thesis 5.3.2): balance-coupled and quadrotor-figure8."""

import numpy as np
import pytest
from scipy.linalg import expm

from sobolev_drake.experiments import balance_coupled as bc
from sobolev_drake.experiments import quadrotor_figure8 as q8
from sobolev_drake.rigs.mechanical import build_loop, left_annihilator, run_loop, tracked_errors
from sobolev_drake.systems.rotor_allocation import RotorAllocation
from sobolev_drake.models.quadrotor import add_quadrotor, make_quadrotor_model
from sobolev_drake.systems.disturbances import TimeProfiledForce
from sobolev_drake.systems.references import PiecewiseTrajectory, TrajectoryReference, const


def test_left_annihilator_of_tilted_quadrotor():
    model = make_quadrotor_model()
    rng = np.random.default_rng(3)
    for _ in range(5):
        q = np.r_[rng.uniform(-0.6, 0.6, 3), rng.uniform(-5, 5, 3)]
        B = model.B(q)
        Bp = left_annihilator(B)
        assert Bp.shape == (2, 6)                       # n − rank B = 6 − 4
        assert np.abs(Bp @ B).max() < 1e-10 * np.abs(B).max()
        np.testing.assert_allclose(Bp @ Bp.T, np.eye(2), atol=1e-12)
    # two-wheeled vehicle: B = [1, −1]ᵀ → B⊥ ∝ [1, 1] (used by balance-coupled)
    Bp = left_annihilator(np.array([[1.0], [-1.0]]))
    np.testing.assert_allclose(np.abs(Bp), [[2 ** -0.5, 2 ** -0.5]], atol=1e-12)


def test_untilted_quadrotor_has_no_lateral_input_direction():
    """Why the thesis needs the 5° tilt (Assumption 7): at ϕ = θ = 0 the untilted rotors give no
    x/y force, the tilted ones do (a small one, through sin 5°)."""
    q = np.zeros(6)
    B0 = make_quadrotor_model(tilt=0.0).B(q)
    B5 = make_quadrotor_model().B(q)
    assert np.abs(B0[3:5]).max() < 1e-12
    assert np.linalg.matrix_rank(B5[3:5]) == 2


def test_exact_tilted_model_follows_linear_closed_loop_586():
    """Exact (tilted) model, τ = B†u* without limits, w = 0, hover reference with ψ and z
    errors: d and u* stay in range(B) (the symmetric collective/yaw rotor patterns produce no
    lateral force), so the controlled errors follow (5.86), ẋc = (A − BK)xc, exactly."""
    model = make_quadrotor_model()
    ref = TrajectoryReference(PiecewiseTrajectory(["psi", "x", "y", "z"],
                                                  [[const(0.0), const(0.0), const(0.0), const(1.0)]]))
    inner = q8.sobolev_inner()
    alloc = RotorAllocation(model, "pinv", np.zeros(4), np.ones(4))
    loop = build_loop(lambda b: add_quadrotor(b), model, q8.PARTITION, inner, ref,
                      TimeProfiledForce(6, []), allocation=alloc)
    q0 = np.array([0.0, 0.0, 0.1, 0.0, 0.0, 1.3])
    run = run_loop(loop, inner, 0.5, q0, np.zeros(6), accuracy=1e-7, max_step=0.005)
    assert not run["failed"]
    law = loop.controller.law
    e, ed = tracked_errors(run, law)
    gains = inner.controlled
    Acl, n = gains.closed_loop, 4
    x0 = np.concatenate([ed[0], e[0], run["ei"][0]])
    pred = np.array([expm(Acl * t) @ x0 for t in run["t"]])
    # the stabilized DOF and the lateral position stay at rest
    assert np.abs(run["x"][:, [0, 1, 3, 4]]).max() < 1e-6
    np.testing.assert_allclose(e, pred[:, n:2 * n], atol=2e-4)
    np.testing.assert_allclose(run["ei"], pred[:, 2 * n:], atol=2e-4)
    # and the error actually moved (the test is not trivially satisfied)
    assert abs(e[-1, 3]) < 0.5 * abs(e[0, 3])


def test_figure8_projection_defect_is_what_breaks_586():
    """On the figure-8 start the B† allocation cannot realize u*: (I − BB†)u* ≠ 0, i.e. the
    thesis' closed loop (5.86) does not hold exactly; the defect lies in the B⊥ directions."""
    model = make_quadrotor_model()
    law_inner = q8.sobolev_inner()
    from sobolev_drake.systems.mechanical_controller import MechanicalLaw
    law = MechanicalLaw(model, q8.PARTITION, law_inner)
    qr, qdr, qddr = q8.reference().evaluate(0.0)
    u = law.generalized_input(q8.Q0, np.zeros(6), np.zeros(4), np.r_[qr, qdr, qddr])
    B = model.B(q8.Q0)
    defect = u - B @ (np.linalg.pinv(B) @ u)
    Bp = left_annihilator(B)
    assert np.linalg.norm(defect) > 1e-3 * np.linalg.norm(u)
    np.testing.assert_allclose(Bp.T @ (Bp @ defect), defect, atol=1e-9 * np.linalg.norm(u))


def test_bad_allocation_name():
    with pytest.raises(ValueError, match="allocation"):
        RotorAllocation(make_quadrotor_model(), "magic", np.zeros(4), np.ones(4))
    alloc = RotorAllocation(make_quadrotor_model(), "bls", np.zeros(4), np.ones(4))
    with pytest.raises(RuntimeError, match="diverged"):  # a lost vehicle stops the run
        alloc(np.zeros(6), np.r_[1.5, 0, 0, 0, 0, 0], np.zeros(6))


@pytest.mark.parametrize("module", [bc, q8])
def test_smoke_runs_give_finite_tables(module, tmp_path):
    res = module.run(tmp_path, smoke=True)
    tables = [v for v in res.metrics.values() if isinstance(v, dict) and set(v) == set(module.COLS)]
    assert len(tables) >= 2
    for v in tables:
        vals = np.array(list(v.values()), dtype=float)
        assert np.all(np.isfinite(vals)) and np.all(vals >= 0)
    thesis_iadu = module.THESIS["W2/W∞"]["IADU"]
    assert f"{thesis_iadu:.4g}" in res.table_markdown   # thesis numbers beside ours
    assert res.claims and all(isinstance(c.held, bool) for c in res.claims)
    for path in res.outputs.values():
        assert path.exists()


def test_balance_allocation_is_bounded_least_squares():
    """The closed-form single-input allocation equals the general bounded LS solver and, inside
    the limit, the thesis' B†u* (5.118)."""
    from sobolev_drake.tiltrotor.allocation import bounded_least_squares

    B = np.array([[1.0], [-1.0]])
    alloc = bc.make_allocation(5.0)
    free = bc.make_allocation(None)
    rng = np.random.default_rng(0)
    for u in rng.normal(scale=8.0, size=(20, 2)):
        ref = bounded_least_squares(B, u, [-5.0], [5.0])
        np.testing.assert_allclose(alloc(u, None, None), ref, atol=1e-9)
        np.testing.assert_allclose(free(u, None, None), np.linalg.pinv(B) @ u, atol=1e-12)
    with pytest.raises(ValueError, match="torque_limit"):
        bc.run(".", smoke=True, torque_limit=-1.0)
