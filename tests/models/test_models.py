"""Drake models vs the thesis' closed forms: M, C q̇, g, B, Christoffel structure, simulation."""

from __future__ import annotations

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from sobolev_drake.models import arm, quadrotor, two_wheeled

N_STATES = 20
REL_TOL = 1e-9


def rel_err(a, b) -> float:
    a, b = np.asarray(a, float), np.asarray(b, float)
    return float(np.linalg.norm(a - b) / max(np.linalg.norm(b), 1e-12))


def random_states(n, seed, q_scale=np.pi, v_scale=3.0, count=N_STATES):
    rng = np.random.default_rng(seed)
    return [(rng.uniform(-q_scale, q_scale, n), rng.uniform(-v_scale, v_scale, n)) for _ in range(count)]


# --- generic Christoffel checks (used by every model) -------------------------------------------
def christoffel_C_fd(model, q, qdot, h=1e-5):
    """C(q, q̇) from central differences of M via Christoffel symbols of the first kind."""
    n = model.n
    dM = []
    for k in range(n):
        e = np.zeros(n)
        e[k] = h
        dM.append((model.M(q + e) - model.M(q - e)) / (2 * h))
    C = np.zeros((n, n))
    for i in range(n):
        for j in range(n):
            C[i, j] = sum(0.5 * (dM[k][i, j] + dM[j][i, k] - dM[i][j, k]) * qdot[k] for k in range(n))
    Mdot = sum(dM[k] * qdot[k] for k in range(n))
    return C, Mdot


def C_matrix_polarized(model, q, qdot):
    """C(q, q̇) column by column from the polarization identity (model.C_times)."""
    n = model.n
    return np.column_stack([model.C_times(q, qdot, np.eye(n)[j]) for j in range(n)])


def check_christoffel(model, states, tol=1e-6):
    rng = np.random.default_rng(7)
    for q, qdot in states:
        C_fd, Mdot = christoffel_C_fd(model, q, qdot)
        C_pol = C_matrix_polarized(model, q, qdot)
        v = rng.normal(size=model.n)
        scale = max(np.linalg.norm(C_fd), 1.0)
        assert np.linalg.norm(C_pol @ v - C_fd @ v) <= tol * scale * np.linalg.norm(v)
        S = Mdot - 2 * C_pol
        assert np.linalg.norm(S + S.T) <= tol * max(np.linalg.norm(Mdot), 1.0)


def check_closed_forms(model, states):
    for q, qdot in states:
        assert rel_err(model.M(q), model.M_closed_form(q)) <= REL_TOL
        assert rel_err(model.Cqdot(q, qdot), model.Cqdot_closed_form(q, qdot)) <= REL_TOL
        assert rel_err(model.g(q), model.g_closed_form(q)) <= REL_TOL


def check_bad_inputs(model):
    n = model.n
    with pytest.raises(ValueError, match="q must be a vector of length"):
        model.M(np.zeros(n + 1))
    with pytest.raises(ValueError, match="qdot must be finite"):
        model.Cqdot(np.zeros(n), np.full(n, np.nan))
    with pytest.raises(ValueError, match="q must be finite"):
        model.g(np.r_[np.inf, np.zeros(n - 1)])
    with pytest.raises(ValueError, match="v must be a vector of length"):
        model.C_times(np.zeros(n), np.zeros(n), np.zeros(n - 1))


def check_diagram_dynamics(add_fn, closed_model, states, u_list, w_list, **kwargs):
    """Accelerations of the diagram (plant + adapter) equal the closed-form thesis dynamics
    q̈ = M⁻¹(B u + w − K(q̇) − C q̇ − g), i.e. the adapter maps u, w, friction correctly."""
    builder = DiagramBuilder()
    h = add_fn(builder, **kwargs)
    diagram = builder.Build()
    ctx = diagram.CreateDefaultContext()
    adapter_ctx = h.adapter.GetMyMutableContextFromRoot(ctx)
    derivs = diagram.AllocateTimeDerivatives()
    n = h.model.n
    for (q, qdot), u, w in zip(states, u_list, w_list):
        h.set_state(ctx, diagram, q, qdot)
        h.u.FixValue(adapter_ctx, u)
        h.disturbance.FixValue(adapter_ctx, w)
        diagram.CalcTimeDerivatives(ctx, derivs)
        vdot_drake = derivs.get_vector().CopyToVector()[n:]
        qddot = h.model.to_thesis(vdot_drake)
        m = closed_model
        B = m.B_closed_form(q) if hasattr(m, "B_closed_form") else m.B(q)
        rhs = (B @ u + w - m.friction(qdot) - m.Cqdot_closed_form(q, qdot) - m.g_closed_form(q))
        expected = np.linalg.solve(m.M_closed_form(q), rhs)
        assert rel_err(qddot, expected) <= 1e-8
        np.testing.assert_allclose(h.x.Eval(adapter_ctx), np.r_[q, qdot], rtol=1e-12, atol=1e-12)
    return h


# --- two-link arm ---------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def arm_model():
    return arm.make_arm_model()


def test_arm_closed_forms(arm_model):
    check_closed_forms(arm_model, random_states(2, 1))
    np.testing.assert_array_equal(arm_model.B(np.zeros(2)), np.eye(2))


def test_arm_closed_forms_other_params():
    p = arm.ArmParams(m1=1.3, m2=0.7, l1=0.8, l2=1.4, I1=0.2, I2=0.4, g=9.81)
    check_closed_forms(arm.make_arm_model(p), random_states(2, 2))


def test_arm_thesis_d11_typo_is_a_typo(arm_model):
    # The printed d11 has an extra 2 l1 (l2/2)^2 = 0.5 term: not what the physics (Drake) gives.
    q = np.array([0.3, 0.0])
    p = arm_model.params
    printed = p.m1 * p.lc1**2 + p.m2 * (p.l1**2 + p.lc2**2 + 2 * p.l1 * p.lc2**2 + 2 * p.l1 * p.lc2) + p.I1 + p.I2
    assert abs(arm_model.M(q)[0, 0] - printed) > 0.4
    assert abs(arm_model.M(q)[0, 0] - arm_model.M_closed_form(q)[0, 0]) < 1e-12


def test_arm_christoffel(arm_model):
    check_christoffel(arm_model, random_states(2, 3))


def test_arm_bad_inputs(arm_model):
    check_bad_inputs(arm_model)
    with pytest.raises(ValueError, match=r"ArmParams.m1 must be > 0"):
        arm.make_arm_model(arm.ArmParams(m1=-1.0))


def test_arm_energy_conserved_in_simulation():
    builder = DiagramBuilder()
    h = arm.add_arm(builder)
    diagram = builder.Build()
    sim = Simulator(diagram)
    ctx = sim.get_mutable_context()
    h.u.FixValue(h.adapter.GetMyMutableContextFromRoot(ctx), np.zeros(2))
    h.set_state(ctx, diagram, [0.4, -0.7], [1.0, -0.5])
    plant_ctx = h.plant.GetMyContextFromRoot(ctx)

    def energy():
        return h.plant.CalcKineticEnergy(plant_ctx) + h.plant.CalcPotentialEnergy(plant_ctx)

    x0 = h.x.Eval(h.adapter.GetMyContextFromRoot(ctx))
    np.testing.assert_allclose(x0, [0.4, -0.7, 1.0, -0.5])
    e0 = energy()
    sim.get_mutable_integrator().set_target_accuracy(1e-8)
    sim.AdvanceTo(2.0)
    drift = abs(energy() - e0) / abs(e0)
    assert drift < 1e-6, drift
    q, qdot = h.get_state(sim.get_context())
    assert np.linalg.norm(q - [0.4, -0.7]) > 0.1  # it actually moved


def test_arm_set_state_rejects_bad_sizes():
    builder = DiagramBuilder()
    h = arm.add_arm(builder)
    diagram = builder.Build()
    ctx = diagram.CreateDefaultContext()
    with pytest.raises(ValueError, match="qdot must be a vector of length 2"):
        h.set_state(ctx, diagram, [0, 0], [0, 0, 0])
    with pytest.raises(ValueError, match="q must be finite"):
        h.set_state(ctx, diagram, [np.nan, 0], [0, 0])
    h.set_state(ctx, diagram, [0, 0], [0, 0])
    h.u.FixValue(h.adapter.GetMyMutableContextFromRoot(ctx), [np.inf, 0.0])
    with pytest.raises(ValueError, match="u \\(actuator command\\) must be finite"):
        diagram.CalcTimeDerivatives(ctx, diagram.AllocateTimeDerivatives())


def test_arm_diagram_dynamics(arm_model):
    rng = np.random.default_rng(11)
    states = random_states(2, 12, count=5)
    check_diagram_dynamics(arm.add_arm, arm_model, states,
                           [rng.normal(size=2) * 10 for _ in states], [rng.normal(size=2) for _ in states])


# --- two-wheeled vehicle --------------------------------------------------------------------------
@pytest.fixture(scope="module")
def tw_model():
    return two_wheeled.make_two_wheeled_model()


def test_two_wheeled_closed_forms(tw_model):
    states = random_states(2, 21)
    check_closed_forms(tw_model, states)
    p = tw_model.params
    assert (p.Ir, p.Ip, p.k, p.m, p.M, p.l, p.r, p.g) == (0.0421, 0.201, 0.00215, 2.75, 3.75, 0.1435, 0.25, 9.8)
    # the individual entries of (4.30)
    q = np.array([0.0, 0.0])
    assert abs(tw_model.M(q)[0, 0] - ((p.M + p.m) * p.r**2 + p.Ir)) < 1e-12
    assert abs(tw_model.M(q)[1, 1] - (p.m * p.l**2 + p.Ip)) < 1e-12
    np.testing.assert_array_equal(tw_model.B(q), [[1.0], [-1.0]])
    np.testing.assert_allclose(tw_model.friction([2.0, 5.0]), [2 * p.k, -2 * p.k])
    assert not tw_model.frictionless        # per-sample laws must add its K(q̇)


def test_two_wheeled_closed_forms_other_params():
    p = two_wheeled.TwoWheeledParams(Ir=0.03, Ip=0.1, k=0.01, m=1.5, M=2.0, l=0.3, r=0.1, g=9.81)
    check_closed_forms(two_wheeled.make_two_wheeled_model(p), random_states(2, 22))


def test_two_wheeled_christoffel(tw_model):
    check_christoffel(tw_model, random_states(2, 23))


def test_two_wheeled_bad_inputs(tw_model):
    check_bad_inputs(tw_model)
    with pytest.raises(ValueError, match=r"TwoWheeledParams.r must be > 0"):
        two_wheeled.make_two_wheeled_model(two_wheeled.TwoWheeledParams(r=0.0))
    with pytest.raises(ValueError, match=r"TwoWheeledParams.k must be >= 0"):
        two_wheeled.TwoWheeledParams(k=-1.0).validate()


def test_two_wheeled_diagram_dynamics_with_friction(tw_model):
    rng = np.random.default_rng(24)
    states = random_states(2, 25, count=5)
    check_diagram_dynamics(two_wheeled.add_two_wheeled, tw_model, states,
                           [rng.normal(size=1) for _ in states], [rng.normal(size=2) for _ in states])


def test_two_wheeled_friction_dissipates_energy():
    """u = w = 0: the energy decreases at the rate −k ϕ̇ (ϕ̇ − θ̇) (power of K(q̇))."""
    builder = DiagramBuilder()
    h = two_wheeled.add_two_wheeled(builder)
    diagram = builder.Build()
    sim = Simulator(diagram)
    ctx = sim.get_mutable_context()
    h.set_state(ctx, diagram, [0.0, 0.1], [4.0, 0.0])
    plant_ctx = h.plant.GetMyContextFromRoot(ctx)

    def energy():
        return h.plant.CalcKineticEnergy(plant_ctx) + h.plant.CalcPotentialEnergy(plant_ctx)

    k = h.model.params.k
    e0 = energy()
    ts = np.linspace(0, 0.3, 61)
    power = []
    sim.get_mutable_integrator().set_target_accuracy(1e-9)
    for t in ts:
        sim.AdvanceTo(t)
        _, qd = h.get_state(ctx)
        power.append(-k * qd[0] * (qd[0] - qd[1]))
    # trapezoid of the friction power vs the energy change
    dissipated = float(np.sum(0.5 * (np.array(power[1:]) + power[:-1]) * np.diff(ts)))
    assert dissipated < 0
    assert abs((energy() - e0) - dissipated) <= 1e-3 * abs(dissipated)


# --- quadrotor ------------------------------------------------------------------------------------
def quad_states(seed, count=N_STATES):
    """Random states away from the Euler singularity |θ| = π/2."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(count):
        q = np.r_[rng.uniform(-np.pi, np.pi), rng.uniform(-1.3, 1.3), rng.uniform(-np.pi, np.pi),
                  rng.uniform(-5, 5, 3)]
        out.append((q, rng.uniform(-3, 3, 6)))
    return out


@pytest.fixture(scope="module")
def quad_model():
    return quadrotor.make_quadrotor_model()


def test_quadrotor_table_5_4(quad_model):
    p = quad_model.params
    assert (p.Ixx, p.Iyy, p.Izz, p.m, p.l, p.g, p.b, p.d) == (0.0363, 0.0363, 0.0615, 2.2, 0.21, 9.8, 2.9e-5, 6e-6)
    assert abs(quad_model.tilt - np.deg2rad(5)) < 1e-15
    assert quad_model.dof_names == ["phi", "theta", "psi", "x", "y", "z"]
    # thesis order [ϕ θ ψ x y z] vs Drake's joint order [x y z ψ θ ϕ]
    np.testing.assert_array_equal(quad_model.to_drake([1, 2, 3, 4, 5, 6]), [4, 5, 6, 3, 2, 1])


@pytest.mark.parametrize("tilt", [None, 0.0])
def test_quadrotor_closed_forms(tilt):
    check_closed_forms(quadrotor.make_quadrotor_model(tilt=tilt), quad_states(31))


def test_quadrotor_closed_forms_chapter6_params():
    check_closed_forms(quadrotor.make_quadrotor_model(quadrotor.QuadrotorParams.chapter6_nominal()),
                       quad_states(32, count=5))


@pytest.mark.parametrize("tilt,mode", [(None, "thesis"), (0.0, "thesis"), (None, "axial"), (0.3, "axial")])
def test_quadrotor_B_from_jacobians_equals_5_123(tilt, mode):
    model = quadrotor.make_quadrotor_model(tilt=tilt, reaction_torque=mode)
    for q, _ in quad_states(33):
        B, Bc = model.B(q), model.B_closed_form(q)
        assert rel_err(model.B_per_rotor_jacobians(q), B) <= REL_TOL
        # block-wise: torque rows are ~1e-6, force rows ~1e-5
        assert rel_err(B[:3], Bc[:3]) <= REL_TOL
        assert rel_err(B[3:], Bc[3:]) <= REL_TOL


def test_quadrotor_B_at_level_attitude(quad_model):
    p, a = quad_model.params, quad_model.tilt
    B = quad_model.B(np.zeros(6))
    lb = p.l * p.b * np.cos(a)
    np.testing.assert_allclose(B[0], [0, lb, 0, -lb], atol=1e-20)
    np.testing.assert_allclose(B[2], p.d * np.cos(a) * np.array([1, -1, 1, -1]), rtol=1e-12)
    np.testing.assert_allclose(B[3], p.b * np.sin(a) * np.array([-1, 0, 1, 0]), rtol=1e-12, atol=1e-20)
    np.testing.assert_allclose(B[5], np.full(4, p.b * np.cos(a)), rtol=1e-12)
    # the axial drag torque differs from (5.123) by d sin α in the roll/pitch rows
    Bax = quadrotor.make_quadrotor_model(reaction_torque="axial").B(np.zeros(6))
    np.testing.assert_allclose(np.abs(Bax[:2] - B[:2]).sum(axis=0), np.full(4, p.d * np.sin(a)), rtol=1e-9)


def test_quadrotor_christoffel(quad_model):
    check_christoffel(quad_model, quad_states(34))


def test_quadrotor_diagram_dynamics(quad_model):
    rng = np.random.default_rng(35)
    states = quad_states(36, count=5)
    hover = quad_model.params.hover_input()
    check_diagram_dynamics(quadrotor.add_quadrotor, quad_model, states,
                           [hover * rng.uniform(0.5, 1.5, 4) for _ in states],
                           [rng.normal(size=6) for _ in states])


def test_quadrotor_untilted_truth_and_hover():
    builder = DiagramBuilder()
    h = quadrotor.add_quadrotor(builder, tilt=0.0)
    diagram = builder.Build()
    assert h.model.tilt == 0.0
    np.testing.assert_allclose(h.model.B(np.zeros(6))[3:5], 0.0, atol=1e-20)
    sim = Simulator(diagram)
    ctx = sim.get_mutable_context()
    hover = h.model.params.hover_input()
    h.u.FixValue(h.adapter.GetMyMutableContextFromRoot(ctx), np.full(4, hover))
    h.set_state(ctx, diagram, [0, 0, 0.4, 1, 2, 3], np.zeros(6))
    sim.AdvanceTo(1.0)
    q, qdot = h.get_state(ctx)
    np.testing.assert_allclose(q, [0, 0, 0.4, 1, 2, 3], atol=1e-9)
    np.testing.assert_allclose(qdot, 0, atol=1e-9)
    # a plant built untilted cannot be wrapped as a tilted model
    with pytest.raises(ValueError, match="tilted by"):
        quadrotor.QuadrotorModel(h.plant, tilt=np.deg2rad(5))


def test_quadrotor_bad_inputs(quad_model):
    check_bad_inputs(quad_model)
    with pytest.raises(ValueError, match="q must be a vector of length 6"):
        quad_model.B(np.zeros(4))
    with pytest.raises(ValueError, match="reaction_torque"):
        quadrotor.make_quadrotor_model(reaction_torque="sideways")
    with pytest.raises(ValueError, match="tilt alpha"):
        quadrotor.make_quadrotor_model(tilt=2.0)
    with pytest.raises(ValueError, match="triangle"):
        quadrotor.make_quadrotor_model(quadrotor.QuadrotorParams(Izz=1.0))


def test_model_rejects_plant_built_with_other_params(arm_model, tw_model):
    with pytest.raises(ValueError, match="differs from the closed form"):
        arm.TwoLinkArmModel(arm_model.plant, arm.ArmParams(m2=2.0))
    with pytest.raises(ValueError, match="differs from the closed form"):
        two_wheeled.TwoWheeledModel(tw_model.plant, two_wheeled.TwoWheeledParams(l=0.2))
    # same parameters: accepted (a second view of the same plant)
    assert arm.TwoLinkArmModel(arm_model.plant).n == 2


def test_quadrotor_energy_conserved_tumbling():
    """u = 0, spinning and translating start: the Coriolis terms must conserve energy."""
    builder = DiagramBuilder()
    h = quadrotor.add_quadrotor(builder)
    diagram = builder.Build()
    sim = Simulator(diagram)
    ctx = sim.get_mutable_context()
    h.set_state(ctx, diagram, [0.2, -0.3, 0.5, 0, 0, 10], [2.0, -1.0, 3.0, 1.0, 0.5, 2.0])
    plant_ctx = h.plant.GetMyContextFromRoot(ctx)

    def energy():
        return h.plant.CalcKineticEnergy(plant_ctx) + h.plant.CalcPotentialEnergy(plant_ctx)

    e0 = energy()
    sim.get_mutable_integrator().set_target_accuracy(1e-8)
    sim.AdvanceTo(0.5)
    assert abs(energy() - e0) / abs(e0) < 1e-6
    q, _ = h.get_state(ctx)
    assert np.linalg.norm(q[:3] - [0.2, -0.3, 0.5]) > 0.5  # it tumbled
