"""Tilt-rotor generalized forces: propellers, servos, aerodynamics, input-affine form (7.62)."""

import numpy as np
import pytest
from pydrake.multibody.tree import JacobianWrtVariable
from pydrake.systems.framework import DiagramBuilder

from sobolev_drake.data import load
from sobolev_drake.tiltrotor.plant import TiltrotorModel, add_tiltrotor
from sobolev_drake.tiltrotor.aerodynamics import AerodynamicSurfaces, AeroModel
from sobolev_drake.tiltrotor.input_affine import (force_disturbance_generalized, generalized_force,
                                                input_affine, thrust_inputs)
from sobolev_drake.tiltrotor.propeller import PropellerCoefficients
from sobolev_drake.tiltrotor.propulsion import (PropellerForces, PropulsionModel,
                                                body_kinematics_scalar)

RHO, D = 1.21, 0.6096


@pytest.fixture(scope="module")
def model():
    return TiltrotorModel()


def random_state(rng):
    q = np.concatenate([rng.uniform(-0.6, 0.6, 5), rng.normal(size=3)])
    qd = np.concatenate([rng.normal(size=5) * 0.5, rng.normal(size=3) * 6 + [8, 0, 0]])
    return q, qd, rng.normal(size=3) * 3


def test_propeller_coefficients_vectorized_and_clamped():
    c = PropellerCoefficients()
    assert c.ct(0, 0) == pytest.approx(0.0829) and c.cq(0, 0) == pytest.approx(0.0053)
    J = np.linspace(0, 0.75, 7)[:, None]
    phi = np.linspace(0, np.pi / 2, 5)[None, :]
    assert c.ct(J, phi).shape == (7, 5) and c.cq(J, phi).shape == (7, 5)
    v = np.array([[0, 0, 10.0], [10.0, 0, 0], [0, 3.0, -100.0], [0, 0, 0]])
    J, phi = c.advance_ratio_and_inflow(v, np.array([50.0, 50.0, 50.0, 50.0]))
    np.testing.assert_allclose(J, [10 / (50 * D), 10 / (50 * D), 0.75, 0.0])
    np.testing.assert_allclose(phi, [0, np.pi / 2, np.pi / 2, 0])
    with pytest.raises(ValueError, match="v_rel_rotor_frame"):
        c.advance_ratio_and_inflow(np.zeros(2), 50.0)


def test_static_thrust_and_servo(model):
    q, qd = np.zeros(8), np.zeros(8)
    prop = PropulsionModel(model.params)
    f, t, J, phi = prop.thrust_and_torque(q, qd, np.zeros(3), np.array([40.0, 0.0]))
    assert f[0] == pytest.approx(RHO * D ** 4 * 40.0 ** 2 * 0.0829, rel=1e-12)
    assert t[0] == pytest.approx(RHO * D ** 5 * 40.0 ** 2 * 0.0053, rel=1e-12)
    assert f[1] == 0.0 and t[1] == 0.0
    th = generalized_force(model, q, qd, np.zeros(3), [40.0, 0.0], [0.5, 0.0], np.zeros(4))
    beta = model.params.beta
    assert th[7] == pytest.approx(f[0] * np.cos(beta), rel=1e-12)       # rotor axis Rx(−β) e_z
    assert th[0] == pytest.approx(0.5 * np.cos(beta) + t[0] * np.sin(beta), rel=1e-12)


def test_wing_lift_matches_hand_computation(model):
    aero = AeroModel(model.params)
    tab = load("tiltrotor_aero_tables")
    grid = np.deg2rad(-90 + 0.5 * np.arange(361))
    V, a = 15.0, np.deg2rad(-4.3)            # body moving forward and down: α_NED = +4.3°
    qd = np.zeros(8)
    qd[5], qd[7] = V * np.cos(a), V * np.sin(a)
    F, M, *_ = aero.surface_loads(np.zeros(8), qd, np.zeros(3))
    cl = np.interp(-a, grid, tab["tables"]["wing"]["lift_alpha"])
    cd = np.interp(-a, grid, tab["tables"]["wing"]["drag_alpha"]) + tab["tables"]["wing"]["drag_beta"][180]
    cm = np.interp(-a, grid, tab["tables"]["wing"]["pitch_moment_alpha"])
    kappa_s = 0.5 * RHO * V ** 2 * 0.125 / 2
    lift_dir, vel_dir = np.array([-np.sin(a), 0, np.cos(a)]), np.array([np.cos(a), 0, np.sin(a)])
    np.testing.assert_allclose(F[1], kappa_s * (cl * lift_dir - cd * vel_dir), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(F[1], F[2], atol=1e-12)
    assert M[1, 1] == pytest.approx(-kappa_s * 0.1366 * cm, rel=1e-12)
    assert F[1] @ vel_dir < 0 and F[1][2] > 0                              # drag opposes, lift up
    lift = kappa_s * cl
    assert lift == pytest.approx(0.5 * 1.21 * 225 * 0.0625 * cl)


def test_crossflow_independence_principle():
    """Sideways flight (u = w = 0, β = 90°): only the β tables act with crossflow="independence";
    the thesis form adds α-table terms (wing lift from spanwise flow, flat-plate drag) and jumps
    with the sign of a tiny w, the independence form is continuous there."""
    from sobolev_drake.tiltrotor.params import TiltrotorParams
    tab = load("tiltrotor_aero_tables")["tables"]
    V = 12.0
    qd = np.zeros(8)
    qd[6] = V                                                   # body moving along +y, no wind
    indep, thesis = AeroModel(TiltrotorParams()), AeroModel(TiltrotorParams(crossflow="thesis"))
    F, M, *_ = indep.surface_loads(np.zeros(8), qd, np.zeros(3))
    kappa_s = 0.5 * RHO * V ** 2 * 0.125 / 2
    # x_w = e_y (air-relative velocity), y_w = −e_x; β_NED = −90°: table sample 0
    side, drag = tab["wing"]["side_force_beta"][0], tab["wing"]["drag_beta"][0]
    np.testing.assert_allclose(F[1], kappa_s * np.array([-side, -drag, 0.0]), rtol=1e-12, atol=1e-12)
    assert abs(M[1, 1]) < 1e-15                                 # no α-table pitch moment
    Ft, *_ = thesis.surface_loads(np.zeros(8), qd, np.zeros(3))
    lift0 = np.interp(0.0, np.deg2rad(-90 + 0.5 * np.arange(361)), tab["wing"]["lift_alpha"])
    assert Ft[1][2] == pytest.approx(kappa_s * lift0, rel=1e-12) and lift0 > 0.3
    # total side force at 12 m/s: β tables alone vs the thesis' sum (≈ 7×, see the module doc)
    def gen(model, w):
        qe = qd.copy()
        qe[7] = w
        return model.generalized_force(np.zeros(8), qe, np.zeros(3), np.zeros(4))
    # w → 0±: α flips between ±90°.  The thesis form jumps by ~10 N (flat-plate drag, lift and
    # pitch moment switch sides); the independence form keeps only the side force's direction,
    # which rotates with α (|c_y(±90°)| ≤ 0.07: 0.2 N here)
    assert np.abs(gen(thesis, 1e-6) - gen(thesis, -1e-6)).max() > 5.0
    assert np.abs(gen(indep, 1e-6) - gen(indep, -1e-6)).max() < 0.5
    gi, gt = gen(indep, 0.0), gen(thesis, 1e-6)
    assert gi[6] < 0 and 5 < gt[6] / gi[6] < 10                  # side force opposes the motion; 7-9×
    # β = 0: both forms agree exactly (level flight, hover trim)
    qf = np.zeros(8)
    qf[5], qf[7] = 15.0, -1.0
    np.testing.assert_allclose(indep.generalized_force(np.zeros(8), qf, np.zeros(3), np.zeros(4)),
                               thesis.generalized_force(np.zeros(8), qf, np.zeros(3), np.zeros(4)), rtol=1e-14)
    with pytest.raises(ValueError, match="crossflow must be one of"):
        TiltrotorParams(crossflow="cosine")


def _mirror_state(q, qd, zeta):
    P = np.eye(8)[[1, 0, 2, 3, 4, 5, 6, 7]]
    s = np.array([1, 1, -1, 1, -1, 1, -1, 1.0])
    return s * (P @ q), s * (P @ qd), zeta * [1, -1, 1]


def test_mirror_symmetry(model):
    rng = np.random.default_rng(5)
    s = np.array([1, 1, -1, 1, -1, 1, -1, 1.0])
    for _ in range(10):
        q, qd, zeta = random_state(rng)
        n, ts, de = rng.uniform(20, 60, 2), rng.normal(size=2), rng.uniform(-0.3, 0.3, 4)
        th = generalized_force(model, q, qd, zeta, n, ts, de)
        qm, qdm, zm = _mirror_state(q, qd, zeta)
        thm = generalized_force(model, qm, qdm, zm, n[::-1], ts[::-1], de[[1, 0, 3, 2]])
        np.testing.assert_allclose(thm, s * th[[1, 0, 2, 3, 4, 5, 6, 7]], atol=1e-10)


def test_input_affine_identity(model):
    rng = np.random.default_rng(6)
    for _ in range(60):
        q, qd, zeta = random_state(rng)
        n, ts, de = rng.uniform(15, 70, 2), rng.normal(size=2), rng.uniform(-0.4, 0.4, 4)
        B, passive = input_affine(model, q, qd, zeta, n=n)
        tau_bar = np.concatenate([thrust_inputs(model, q, qd, zeta, n), ts, de])
        theta = generalized_force(model, q, qd, zeta, n, ts, de)
        np.testing.assert_allclose(B @ tau_bar + passive, theta, rtol=0, atol=1e-9)
        B2, passive2 = input_affine(model, q, qd, zeta, n=n, torque="passive")
        np.testing.assert_allclose(B2 @ tau_bar + passive2, theta, rtol=0, atol=1e-9)
        np.testing.assert_allclose(B2[:, 2:], B[:, 2:], atol=0)
    # the model's B() is the same map (default n: the thesis hover speed)
    np.testing.assert_allclose(model.B(q, qd, zeta), input_affine(model, q, qd, zeta)[0], atol=0)


def test_forces_agree_with_drake_jacobians(model):
    """Closed-form generalized forces = Drake's Jacobianᵀ × spatial forces at the frames."""
    plant, ctx, W = model.plant, model.context, model.plant.world_frame()
    prop, aero = PropulsionModel(model.params), AeroModel(model.params)
    rng = np.random.default_rng(7)
    for _ in range(5):
        q, qd, zeta = random_state(rng)
        n = rng.uniform(20, 60, 2)
        model._set(q, qd)

        def gen(frame, F, T):
            J = plant.CalcJacobianSpatialVelocity(ctx, JacobianWrtVariable.kV, plant.GetFrameByName(frame),
                                                  np.zeros(3), W, W)
            return model.T.T @ (J.T @ np.concatenate([T, F]))
        f, t, _, _ = prop.thrust_and_torque(q, qd, zeta, n)
        g = np.zeros(8)
        for k, fr in enumerate(("frame_PR", "frame_PL")):
            X = plant.GetFrameByName(fr).CalcPoseInWorld(ctx)
            z = X.rotation().matrix()[:, 2]
            g += gen(fr, f[k] * z, t[k] * z)
            v = plant.GetFrameByName(fr).CalcSpatialVelocityInWorld(ctx).translational()
            np.testing.assert_allclose(X.rotation().matrix().T @ (v - zeta),
                                       prop.rotor_air_velocity(q, qd, zeta)[k], atol=1e-10)
        np.testing.assert_allclose(g, prop.propeller_force(q, qd, zeta, n), atol=1e-10)
        F, M, *_ = aero.surface_loads(q, qd, zeta)
        R = plant.GetFrameByName("frame_C1").CalcPoseInWorld(ctx).rotation().matrix()
        g = sum(gen(fr, R @ F[k], R @ M[k]) for k, fr in
                enumerate(("frame_F", "frame_WR", "frame_WL", "frame_TR", "frame_TL", "frame_C1")))
        np.testing.assert_allclose(g, aero.generalized_force(q, qd, zeta, np.zeros(4)), atol=1e-10)
        Fd = rng.normal(size=3)
        np.testing.assert_allclose(gen("frame_C1", Fd, np.zeros(3)),
                                   force_disturbance_generalized(model, q, Fd), atol=1e-10)


def test_leaf_systems_match_combined_plant_forces(model):
    b = DiagramBuilder()
    h = add_tiltrotor(b)
    pf = b.AddSystem(PropellerForces())
    af = b.AddSystem(AerodynamicSurfaces())
    for s in (pf, af):
        b.Connect(h.x, s.GetInputPort("x"))
    d = b.Build()
    ctx = d.CreateDefaultContext()
    rng = np.random.default_rng(8)
    q, qd, zeta = random_state(rng)
    n, ts, de, fdist = rng.uniform(20, 60, 2), rng.normal(size=2), rng.uniform(-0.3, 0.3, 4), rng.normal(size=3)
    h.set_state(ctx, d, q, qd)
    fc, pc, ac = (s.GetMyMutableContextFromRoot(ctx) for s in (h.forces, pf, af))
    h.u.FixValue(fc, np.concatenate([n, ts, de]))
    h.wind.FixValue(fc, zeta)
    h.force_disturbance.FixValue(fc, fdist)
    for port, val in (("wind", zeta), ("propeller_speed", n), ("servo_torque", ts)):
        pf.GetInputPort(port).FixValue(pc, val)
    af.GetInputPort("wind").FixValue(ac, zeta)
    af.GetInputPort("surface_deflection").FixValue(ac, de)
    total = (pf.GetOutputPort("generalized_force").Eval(pc) + af.GetOutputPort("generalized_force").Eval(ac)
             + force_disturbance_generalized(model, q, fdist))
    np.testing.assert_allclose(h.generalized_force.Eval(fc), total, atol=1e-12)
    # handles.x (C++ Selector) and the force system's own x port: the thesis-ordered state, exactly
    xc = h.x.get_system().GetMyContextFromRoot(ctx)
    np.testing.assert_array_equal(h.x.Eval(xc), np.concatenate([q, qd]))
    np.testing.assert_array_equal(h.forces.GetOutputPort("x").Eval(fc), np.concatenate([q, qd]))
    # separate command ports add to u; the generalized disturbance w adds to ϑ
    w = rng.normal(size=8)
    h.u.FixValue(fc, np.concatenate([n - 5.0, ts, de]))
    h.propeller_speed.FixValue(fc, [5.0, 5.0])
    h.disturbance.FixValue(fc, w)
    np.testing.assert_allclose(h.generalized_force.Eval(fc), total + w, atol=1e-12)
    drake_tau = h.forces.GetOutputPort("applied_generalized_force").Eval(fc)
    np.testing.assert_allclose(drake_tau, model.force_to_drake(total + w), atol=1e-12)


def test_bad_inputs_raise(model):
    with pytest.raises(ValueError, match="q must be a vector of length 8"):
        input_affine(model, np.zeros(7), np.zeros(8), np.zeros(3))
    with pytest.raises(ValueError, match="zeta"):
        input_affine(model, np.zeros(8), np.zeros(8), np.zeros(2))
    with pytest.raises(ValueError, match="torque must be"):
        input_affine(model, np.zeros(8), np.zeros(8), np.zeros(3), torque="x")
    with pytest.raises(TypeError, match="TiltrotorModel"):
        input_affine(object(), np.zeros(8), np.zeros(8), np.zeros(3))


# The scalar tier and the numpy reference evaluate the same expressions with their sums in
# another order (numpy's matrix products against Python's running sums), so they differ by the
# rounding of those sums: a few ulps of the largest term.  Tolerance:
# ROUNDING_ULPS·ε·(1 + max|x|) (measured: ≤ 2.3 ε·max|ϑ| on the states below); the margin
# covers BLAS kernels with FMA.
EPS = np.finfo(float).eps
ROUNDING_ULPS = 256


def assert_equal_to_rounding(got, ref):
    np.testing.assert_allclose(got, ref, rtol=0, atol=ROUNDING_ULPS * EPS * (1 + np.abs(ref).max()))


@pytest.mark.parametrize("reverse_flow", ["clipped", "mirrored"])
def test_scalar_tier_equals_numpy_reference(model, reverse_flow):
    """propeller_force and generalized_force (the scalar tier) equal the numpy reference
    G_f f + G_t λt (7.32) and ϑ_passive + B_δ δ (B.12)–(B.15)."""
    prop, aero = PropulsionModel(model.params), AeroModel(model.params.with_(reverse_flow=reverse_flow))
    rng = np.random.default_rng(9)
    for i in range(100):
        q, qd, zeta = random_state(rng)
        qd[5:8] *= rng.choice([-1.0, 1.0], 3)            # flows from behind and below too
        n = rng.uniform(0, 70, 2) if i % 10 else np.array([0.0, 30.0])
        de = rng.uniform(-0.4, 0.4, 4)
        f, t, _, _ = prop.thrust_and_torque(q, qd, zeta, n)
        Gf, Gt = prop.unit_columns(q)
        assert_equal_to_rounding(prop.propeller_force(q, qd, zeta, n), Gf @ f + Gt @ t)
        passive, Bd = aero.terms(q, qd, zeta)
        assert_equal_to_rounding(aero.generalized_force(q, qd, zeta, de), passive + Bd @ de)


def test_aerodynamic_static_stability_signs(model):
    """The NED → z-up conversions give the textbook signs in forward flight at 15 m/s:
    side force opposes sideslip, weathercock yaw, stable dihedral roll, nose-down pitch and more
    lift when the angle of attack grows."""
    aero = AeroModel(model.params)
    q, zeta = np.zeros(8), np.zeros(3)

    def force(v):
        qd = np.zeros(8)
        qd[5:8] = v
        return aero.generalized_force(q, qd, zeta, np.zeros(4))
    base = force([15.0, 0, 0])
    slip = force([15.0, 1.5, 0]) - base          # moving left: relative wind from the left
    assert slip[6] < 0 and slip[4] > 0 and slip[2] > 0
    aoa = force([15.0, 0, -1.5]) - base          # moving down: α_NED grows
    assert aoa[7] > 0 and aoa[3] > 0              # more lift, nose-down moment (θ > 0 is nose down)
    assert base[5] < 0                            # drag


def test_scalar_input_affine_terms_equal_numpy_formulation(model):
    """The controller's one-pass scalar terms (B, ϑ_passive, surface air speeds, rotor inflow)
    equal the numpy formulation (input_affine_vectorized, AeroModel.terms, surface_air_data,
    rotor_air_velocity) for both torque placements, including stopped rotors."""
    from sobolev_drake.tiltrotor.input_affine import input_affine_terms, input_affine_vectorized
    prop, aero = PropulsionModel(model.params), AeroModel(model.params)
    rng = np.random.default_rng(21)
    for i in range(60):
        q, qd, zeta = random_state(rng)
        q[:2] = rng.uniform(-1.7, 1.7, 2)                  # tilts from backward to past vertical
        n = None if i % 4 == 0 else (np.array([0.0, 35.0]) if i % 7 == 0 else rng.uniform(5, 90, 2))
        for torque in ("through_thrust", "passive"):
            B0, p0 = input_affine_vectorized(model, q, qd, zeta, n, torque=torque)
            t = input_affine_terms(model, q, qd, zeta, n, torque=torque)
            # as assert_equal_to_rounding, but B's thrust columns carry d·Cq/Ct, which magnifies
            # the rounding of Ct where it is small (measured: 69 ε·max|B|): 1024 ulps
            tol = 1024 * EPS
            np.testing.assert_allclose(t.B, B0, rtol=0, atol=tol * (1 + np.abs(B0).max()))
            np.testing.assert_allclose(t.passive, p0, rtol=0, atol=tol * (1 + np.abs(p0).max()))
        np.testing.assert_allclose(t.surface_speed, aero.surface_air_data(q, qd, zeta)[1], rtol=1e-13)
        v = prop.rotor_air_velocity(q, qd, zeta)
        np.testing.assert_allclose(t.rotor_vxz, np.hypot(v[:, 0], v[:, 2]), rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(t.rotor_phi, np.abs(np.clip(np.arctan2(v[:, 0], v[:, 2]),
                                                               -np.pi / 2, np.pi / 2)), atol=1e-12)
        # the scalar tier's deflection columns and passive force against AeroModel.terms
        kin = body_kinematics_scalar(q.tolist(), qd.tolist(), zeta.tolist())
        p1, V1, cols = aero.loads_scalar(kin, [0.0] * 4, columns=True)
        p2, Bd2 = aero.terms(q, qd, zeta)
        assert_equal_to_rounding(np.array(cols).T, Bd2[2:8])
        assert_equal_to_rounding(np.array(p1), p2)
        assert_equal_to_rounding(np.array(V1), aero.surface_air_data(q, qd, zeta)[1])
    with pytest.raises(ValueError, match="q must be a vector of length 8"):
        input_affine_terms(model, np.zeros(7), np.zeros(8), np.zeros(3))
    with pytest.raises(ValueError, match="zeta must be finite"):
        input_affine_terms(model, np.zeros(8), np.zeros(8), [0.0, np.nan, 0.0])


def test_plant_force_system_with_force_disturbance_matches_formula(model):
    """TiltrotorForces' scalar force-disturbance mapping equals force_disturbance_generalized,
    and the whole thesis force equals generalized_force + that mapping."""
    b = DiagramBuilder()
    h = add_tiltrotor(b)
    d = b.Build()
    ctx = d.CreateDefaultContext()
    fctx = h.forces.GetMyContextFromRoot(ctx)
    rng = np.random.default_rng(4)
    for _ in range(5):
        q, qd, zeta = random_state(rng)
        n, ts, de, fd = rng.uniform(20, 70, 2), rng.normal(size=2), rng.normal(size=4) * 0.2, rng.normal(size=3) * 10
        h.set_state(ctx, d, q, qd)
        for port, val in ((h.propeller_speed, n), (h.servo_torque, ts), (h.surface_deflection, de),
                          (h.wind, zeta), (h.force_disturbance, fd)):
            port.FixValue(fctx, val)
        expect = generalized_force(model, q, qd, zeta, n, ts, de) + force_disturbance_generalized(model, q, fd)
        np.testing.assert_allclose(h.forces.thesis_force(fctx), expect, rtol=1e-11, atol=1e-10)


def test_scalar_propeller_coefficients_equal_vectorized():
    """ct_cq_scalar and the per-φ quartic in J (Newton thrust inversion) equal the vectorized
    Ct, Cq of the data file."""
    c = PropellerCoefficients()
    for J in np.linspace(0.0, 0.75, 7):
        for phi in np.linspace(0.0, np.pi / 2, 5):
            ct, cq = c.ct_cq_scalar(float(J), float(phi))
            assert ct == pytest.approx(float(c.ct(J, phi)), rel=1e-13, abs=1e-15)
            assert cq == pytest.approx(float(c.cq(J, phi)), rel=1e-13, abs=1e-15)
            c4, c3, c2, c1, c0 = c.ct_in_J(float(phi))
            assert (((c4 * J + c3) * J + c2) * J + c1) * J + c0 == pytest.approx(ct, rel=1e-12, abs=1e-15)


def test_actuator_input_cache_follows_port_changes(model):
    """The force system caches the summed actuator inputs (recomputed only when an actuator
    port changes, not per state or time change); a new port value must change the force."""
    b = DiagramBuilder()
    h = add_tiltrotor(b)
    d = b.Build()
    ctx = d.CreateDefaultContext()
    rng = np.random.default_rng(11)
    q, qd, zeta = random_state(rng)
    h.set_state(ctx, d, q, qd)
    fc = h.forces.GetMyMutableContextFromRoot(ctx)
    h.wind.FixValue(fc, zeta)
    h.propeller_speed.FixValue(fc, [40.0, 45.0])
    h.surface_deflection.FixValue(fc, [0.1, -0.1, 0.05, 0.0])
    f1 = h.generalized_force.Eval(fc).copy()
    k = h.forces.input_evaluations
    h.set_state(ctx, d, q + 0.01, qd)          # state change: forces recomputed, inputs not
    ctx.SetTime(1.0)
    f2 = h.generalized_force.Eval(fc).copy()
    assert h.forces.input_evaluations == k and not np.allclose(f1, f2)
    h.set_state(ctx, d, q, qd)
    for port, val in ((h.propeller_speed, [50.0, 45.0]), (h.servo_torque, [0.5, -0.5]),
                      (h.surface_deflection, [0.0, 0.0, 0.2, 0.1]), (h.u, np.full(8, 0.01))):
        port.FixValue(fc, val)
        f3 = h.generalized_force.Eval(fc).copy()
        assert not np.allclose(f3, f1)
        # same as a fresh context with the same inputs
        fresh = d.CreateDefaultContext()
        h.set_state(fresh, d, q, qd)
        ff = h.forces.GetMyMutableContextFromRoot(fresh)
        for p in (h.wind, h.propeller_speed, h.servo_torque, h.surface_deflection, h.u):
            if p.HasValue(fc):
                p.FixValue(ff, p.Eval(fc))
        np.testing.assert_array_equal(h.generalized_force.Eval(ff), f3)
        f1 = f3


def test_state_selector_rejects_non_permutations():
    from sobolev_drake.models.handles import add_state_selector
    b = DiagramBuilder()
    h = add_tiltrotor(b)
    with pytest.raises(ValueError, match="permutation of range\\(16\\)"):
        add_state_selector(b, h.plant.get_state_output_port(), [0] * 16, "bad")
    with pytest.raises(ValueError, match="permutation"):
        add_state_selector(b, h.plant.get_state_output_port(), range(15), "short")


def _flow_circle(aero, V, thetas):
    """Generalized aerodynamic force with the body moving through still air at speed V in
    direction θ of its x–z plane (u = V cos θ, w = V sin θ; no sideslip, level attitude)."""
    out = []
    for th in thetas:
        qd = np.zeros(8)
        qd[5], qd[7] = V * np.cos(th), -V * np.sin(th)   # body z down = −world z at level
        out.append(aero.generalized_force(np.zeros(8), qd, np.zeros(3), np.zeros(4)))
    return np.array(out)


def test_reverse_flow_models():
    """Flying backwards (u < 0): "clipped" (the thesis' form) reads the ±90° table entries and
    jumps where w changes sign; "mirrored" (default) reads the tables at atan2(w, |u|) with the wind axes along
    the flow: continuous over the whole circle of flow directions, equal in forward flow,
    and its drag opposes the air-relative motion of every surface with positive drag data."""
    from sobolev_drake.tiltrotor.params import TiltrotorParams
    clipped, mirrored = AeroModel(TiltrotorParams(reverse_flow="clipped")), AeroModel(TiltrotorParams())
    assert TiltrotorParams().reverse_flow == "mirrored"
    V = 10.0
    back = np.radians([179.999, 180.001])                 # w changes sign in reverse flow
    jump_c = np.abs(np.diff(_flow_circle(clipped, V, back), axis=0)).max()
    jump_m = np.abs(np.diff(_flow_circle(mirrored, V, back), axis=0)).max()
    assert jump_c > 5.0 and jump_m < 1e-2
    # the whole circle: neighbouring directions 0.05° apart differ by O(0.05°) only
    thetas = np.radians(np.arange(-180.0, 180.0, 0.05))
    g = _flow_circle(mirrored, V, thetas)
    scale = np.abs(g).max()
    assert np.abs(np.diff(g, axis=0)).max() < 0.01 * scale
    # forward flow (|θ| ≤ 90°): identical to the clipped (thesis-form) model
    fwd = np.radians(np.linspace(-89.0, 89.0, 41))
    np.testing.assert_allclose(_flow_circle(mirrored, V, fwd), _flow_circle(clipped, V, fwd),
                               rtol=1e-12, atol=1e-12)
    # drag dissipates: F·v ≤ 0 per surface (F, wings, tails: their drag data are positive)
    rng = np.random.default_rng(4)
    for _ in range(200):
        qd = np.zeros(8)
        qd[5:8] = rng.normal(size=3) * 8.0
        qd[2:5] = rng.normal(size=3) * 0.3
        q = np.r_[rng.uniform(-0.5, 0.5, 2), rng.uniform(-0.6, 0.6, 3), np.zeros(3)]
        v, *_ = mirrored.surface_air_data(q, qd, np.zeros(3))
        F, *_ = mirrored.surface_loads(q, qd, np.zeros(3))
        assert np.all(np.einsum("ij,ij->i", F[:5], v[:5]) <= 1e-9)
    with pytest.raises(ValueError, match="reverse_flow must be one of"):
        TiltrotorParams(reverse_flow="reversed")


def _spinning_tiltrotor(seed, native=None):
    """(handles, diagram, root context, force-system context, q, q̇, ζ): a random state, the
    propeller speeds fixed, nothing else connected."""
    b = DiagramBuilder()
    h = add_tiltrotor(b, native=native)
    d = b.Build()
    ctx = d.CreateDefaultContext()
    q, qd, zeta = random_state(np.random.default_rng(seed))
    h.set_state(ctx, d, q, qd)
    fc = h.forces.GetMyMutableContextFromRoot(ctx)
    h.propeller_speed.FixValue(fc, [40.0, 45.0])
    return h, d, ctx, fc, q, qd, zeta


@pytest.mark.parametrize("native", [None, False])
def test_optional_inputs_fixed_after_the_inputs_were_cached(native):
    """The actuator-input cache also records which of wind, force_disturbance and disturbance
    have a value; a port fixed *after* that record was made must act on the very next
    evaluation, equal to a fresh context (whether or not Drake recomputes the record then)."""
    h, d, ctx, fc, q, qd, zeta = _spinning_tiltrotor(5, native)
    before = h.generalized_force.Eval(fc).copy()
    late = ((h.wind, zeta), (h.force_disturbance, [1.0, -2.0, 0.5]),
            (h.disturbance, np.linspace(-0.3, 0.4, 8)))
    for port, value in late:
        port.FixValue(fc, value)
        after = h.generalized_force.Eval(fc).copy()
        assert not np.allclose(after, before), port.get_name()
        fresh = d.CreateDefaultContext()
        h.set_state(fresh, d, q, qd)
        ff = h.forces.GetMyMutableContextFromRoot(fresh)
        for p in (h.propeller_speed, *(p for p, _ in late)):
            if p.HasValue(fc):
                p.FixValue(ff, p.Eval(fc))
        np.testing.assert_array_equal(h.generalized_force.Eval(ff), after)
        before = after


def test_input_record_of_a_cloned_context_stays_its_own():
    """A clone starts with its source's cached input record; fixing a port in one of them
    afterwards changes that context's force only."""
    h, d, ctx, fc, q, qd, zeta = _spinning_tiltrotor(8)
    before = h.generalized_force.Eval(fc).copy()
    clone = ctx.Clone()
    cc = h.forces.GetMyMutableContextFromRoot(clone)
    h.wind.FixValue(cc, zeta)
    h.servo_torque.FixValue(cc, [0.3, -0.2])
    changed = h.generalized_force.Eval(cc).copy()
    np.testing.assert_array_equal(h.generalized_force.Eval(fc), before)
    assert not np.allclose(changed, before)
    h.propeller_speed.FixValue(fc, [50.0, 41.0])            # the source moves on alone
    assert not np.allclose(h.generalized_force.Eval(fc), before)
    np.testing.assert_array_equal(h.generalized_force.Eval(cc), changed)
