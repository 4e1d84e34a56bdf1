"""Tilt-rotor rigid-body model: URDF, inertia matrix (7.16), Christoffel structure, free motion."""

from importlib import resources

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from sobolev_drake.tiltrotor.plant import TiltrotorModel, _build_plant, thesis_coordinate_map, tiltrotor_urdf
from sobolev_drake.tiltrotor.params import R_IB, W_eta, TiltrotorParams, rot_x, rot_y


@pytest.fixture(scope="module")
def model():
    return TiltrotorModel()


def skew(v):
    return np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])


def M_thesis(p: TiltrotorParams, q):
    """Block formulas (7.16), written independently of the code under test."""
    ay = np.array([0.0, 1.0, 0.0])
    ayR, ayL = rot_x(-p.beta).T @ ay, rot_x(p.beta).T @ ay
    RA2 = rot_y(q[0]) @ rot_x(-p.beta)
    RA3 = rot_y(q[1]) @ rot_x(p.beta)
    R, W = R_IB(q), W_eta(q)
    S2, S3, S1 = skew(p.d_A_C), skew(p.d_A_C), skew(p.d_B_C1)
    r2 = p.d_B_A2 + RA2 @ p.d_A_C
    r3 = p.d_B_A3 + RA3 @ p.d_A_C
    M = np.zeros((8, 8))
    M[0, 0] = ayR @ (p.I_C2 - p.m2 * S2 @ S2) @ ayR
    M[1, 1] = ayL @ (p.I_C3 - p.m3 * S3 @ S3) @ ayL
    M[2:5, 0] = W.T @ (RA2 @ p.I_C2 - p.m2 * skew(r2) @ RA2 @ S2) @ ayR
    M[2:5, 1] = W.T @ (RA3 @ p.I_C3 - p.m3 * skew(r3) @ RA3 @ S3) @ ayL
    M[2:5, 2:5] = W.T @ (p.I_C1 + RA2 @ p.I_C2 @ RA2.T + RA3 @ p.I_C3 @ RA3.T - p.m1 * S1 @ S1
                         - p.m2 * skew(r2) @ skew(r2) - p.m3 * skew(r3) @ skew(r3)) @ W
    M[5:8, 0] = -p.m2 * R @ RA2 @ S2 @ ayR
    M[5:8, 1] = -p.m3 * R @ RA3 @ S3 @ ayL
    M[5:8, 2:5] = -R @ (p.m1 * S1 + p.m2 * skew(r2) + p.m3 * skew(r3)) @ W
    M[5:8, 5:8] = p.mass * np.eye(3)
    return np.tril(M) + np.tril(M, -1).T


def test_total_mass_and_shipped_urdf(model):
    assert model.plant.CalcTotalMass(model.context) == pytest.approx(7.6, abs=1e-12)
    shipped = (resources.files("sobolev_drake") / "urdf" / "tiltrotor.urdf").read_text()
    assert shipped == tiltrotor_urdf(), "urdf/tiltrotor.urdf is out of date: regenerate it"
    T = thesis_coordinate_map(model.plant)
    assert np.allclose(T @ T.T, np.eye(8)) and set(T.sum(axis=0)) == {1.0}


def test_inertia_matrix_matches_716(model):
    rng = np.random.default_rng(1)
    for _ in range(20):
        q = rng.uniform(-1.2, 1.2, 8)
        M = model.M(q)
        assert np.allclose(M, M.T, atol=1e-12)
        assert np.linalg.eigvalsh(M).min() > 1e-4
        np.testing.assert_allclose(M, M_thesis(model.params, q), atol=1e-12)


def test_Mdot_minus_2C_is_skew(model):
    rng = np.random.default_rng(2)
    h = 1e-6
    for _ in range(5):
        q, qd = rng.uniform(-1, 1, 8), rng.normal(size=8)
        Mdot = (model.M(q + h * qd) - model.M(q - h * qd)) / (2 * h)
        C = np.column_stack([model.C_times(q, qd, e) for e in np.eye(8)])
        assert np.allclose(C @ qd, model.Cqdot(q, qd), atol=1e-10)
        N = Mdot - 2 * C
        assert np.abs(N + N.T).max() < 1e-7


def test_gravity_vector(model):
    q = np.array([0.3, -0.2, 0.1, 0.2, 0.5, 1.0, 2.0, 3.0])
    g = model.g(q)
    assert g[7] == pytest.approx(7.6 * 9.8)
    assert np.allclose(g[5:7], 0.0)


def _free_plant():
    b = DiagramBuilder()
    plant, _ = _build_plant(TiltrotorParams(), b)
    d = b.Build()
    return plant, d


def test_energy_conserved_without_forces():
    plant, d = _free_plant()
    sim = Simulator(d)
    ctx = sim.get_mutable_context()
    pc = plant.GetMyMutableContextFromRoot(ctx)
    plant.get_applied_generalized_force_input_port().FixValue(pc, np.zeros(8))
    rng = np.random.default_rng(3)
    plant.SetPositions(pc, rng.uniform(-0.5, 0.5, 8))
    plant.SetVelocities(pc, rng.normal(size=8))
    sim.get_mutable_integrator().set_target_accuracy(1e-10)

    def energy():
        return plant.CalcKineticEnergy(pc) + plant.CalcPotentialEnergy(pc)

    E0 = energy()
    sim.AdvanceTo(2.0)
    assert abs(energy() - E0) < 1e-6 * max(1.0, abs(E0))


def test_gravity_drop_is_half_g_t_squared():
    plant, d = _free_plant()
    sim = Simulator(d)
    ctx = sim.get_mutable_context()
    pc = plant.GetMyMutableContextFromRoot(ctx)
    plant.get_applied_generalized_force_input_port().FixValue(pc, np.zeros(8))
    model = TiltrotorModel(plant=plant)
    q0 = np.array([-0.3, 0.2, 0.1, 0.15, 0.4, 1.0, -2.0, 10.0])
    plant.SetPositions(pc, model.to_drake(q0))
    sim.get_mutable_integrator().set_target_accuracy(1e-10)
    sim.AdvanceTo(1.0)
    q = model.to_thesis(plant.GetPositions(pc))
    assert q[7] == pytest.approx(10.0 - 0.5 * 9.8, abs=1e-8)
    np.testing.assert_allclose(q[:7], q0[:7], atol=1e-8)


def test_visual_geometry_for_meshcat():
    from pydrake.geometry import Role
    from sobolev_drake.tiltrotor.plant import add_tiltrotor
    b = DiagramBuilder()
    h = add_tiltrotor(b)
    inspector = h.scene_graph.model_inspector()
    counts = {}
    for name in ("body", "thruster_right", "thruster_left"):
        fid = h.plant.GetBodyFrameIdOrThrow(h.plant.GetBodyByName(name).index())
        counts[name] = len(inspector.GetGeometries(fid, Role.kIllustration))
    assert counts["body"] >= 6 and counts["thruster_right"] == counts["thruster_left"] >= 2
