"""The compiled inverse dynamics (sobolev_drake/native/rnea.c) against Drake's.

The kernel is a recursive Newton–Euler pass of its own (body-frame spatial vectors), so it
agrees with MultibodyPlant.CalcInverseDynamics (with the force elements' contribution) to
rounding, not to the bit; the tolerances are relative to the magnitude of the terms
|M| |v̇| + |C v| + |τ_g|.
"""

import importlib

import numpy as np
import pytest
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import (FixedOffsetFrame, MultibodyForces, PrismaticJoint,
                                    RevoluteJoint, RevoluteSpring, RotationalInertia,
                                    SpatialInertia, WeldJoint)

import sobolev_drake.native as native_pkg
from sobolev_drake.tiltrotor.plant import TiltrotorModel
from sobolev_drake.native import kernel
from sobolev_drake.native.rnea import tree_constants, tree_model, unsupported_reason
from sobolev_drake.tiltrotor.law import make_law

K = importlib.import_module("sobolev_drake.native._rnea")   # ImportError: not built

# max |kernel − Drake| / max(|M| |v̇| + |C v| + |τ_g|) over the random states below, when the
# kernel was added: 1.7e-15 (tilt-rotor), 3.4e-15 (test tree), 3.2e-15 (20-link chain),
# 7e-16 (quadrotor, two-wheeled)
TOL = 2e-14


@pytest.fixture(autouse=True)
def kernels_on(monkeypatch):
    """These tests compare the kernel with Drake, so they switch it on even under
    SOBOLEV_DRAKE_NATIVE=0 (and off where they test the fallback)."""
    monkeypatch.setattr(native_pkg, "_ENABLED", True)


def _unit(v):
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


def _inertia(mass, com, moments, products):
    return SpatialInertia.MakeFromCentralInertia(mass, np.asarray(com, dtype=float),
                                                 RotationalInertia(*moments, *products))


def tree_plant(*, time_step=0.0, damping=0.0, extra=None):
    """A branched tree of revolute and prismatic joints with offset, rotated joint frames on
    both sides, skewed axes, off-diagonal inertias, a massless body and a skewed gravity; the
    joints are added out of tree order.  ``extra(plant, bodies)`` adds a feature before
    Finalize (the refusal tests)."""
    plant = MultibodyPlant(time_step)
    base = plant.AddRigidBody("base", _inertia(2.0, [0.1, -0.05, 0.2], (0.05, 0.06, 0.04),
                                               (0.004, -0.003, 0.002)))
    slider = plant.AddRigidBody("slider", _inertia(0.7, [0.0, 0.15, -0.1], (0.02, 0.01, 0.025),
                                                   (-0.001, 0.002, 0.0015)))
    arm = plant.AddRigidBody("arm", _inertia(1.3, [0.3, 0.02, 0.0], (0.01, 0.08, 0.085),
                                             (0.003, 0.0, -0.002)))
    carrier = plant.AddRigidBody("carrier", SpatialInertia.Zero())        # massless
    tip = plant.AddRigidBody("tip", _inertia(0.4, [-0.05, 0.0, 0.12], (0.003, 0.004, 0.002),
                                             (0.0, 0.0005, -0.0004)))

    def frame(name, parent, rpy, xyz):
        if hasattr(parent, "body_frame"):
            parent = parent.body_frame()
        return plant.AddFrame(FixedOffsetFrame(name, parent,
                                               RigidTransform(RollPitchYaw(*rpy), xyz)))

    # out of tree order: the tip's joint first, the root's last
    plant.AddJoint(RevoluteJoint(
        "carrier_tip", frame("F4", carrier, (0.2, 0.0, -0.3), [0.1, 0.0, 0.05]),
        frame("M4", tip, (0.0, 0.5, 0.0), [0.0, -0.02, 0.03]), _unit([0.0, 0.6, 0.8])))
    plant.AddJoint(RevoluteJoint(
        "slider_arm", frame("F2", slider, (0.0, 0.0, 0.7), [0.0, 0.3, 0.0]), arm.body_frame(),
        _unit([0.0, 0.0, 1.0]), damping=damping))
    plant.AddJoint(PrismaticJoint(
        "base_slider", frame("F1", base, (0.1, 0.2, 0.3), [0.2, -0.1, 0.05]),
        frame("M1", slider, (-0.3, 0.1, 0.0), [0.04, 0.0, -0.06]), _unit([1.0, -2.0, 0.5])))
    plant.AddJoint(PrismaticJoint(
        "base_carrier", base.body_frame(), frame("M3", carrier, (0.0, 0.0, 0.4), [0.0, 0.1, 0.0]),
        _unit([0.0, 0.0, 1.0])))
    plant.AddJoint(RevoluteJoint(
        "world_base", frame("F0", plant.world_frame(), (0.3, -0.2, 0.5), [0.1, 0.2, 0.3]),
        frame("M0", base, (-0.1, 0.4, 0.2), [0.05, -0.1, 0.02]), _unit([1.0, 2.0, 2.0])))
    if extra is not None:
        extra(plant, {"base": base, "slider": slider, "arm": arm, "tip": tip})
    plant.mutable_gravity_field().set_gravity_vector([0.4, -0.3, -9.7])
    plant.Finalize()
    return plant


def drake_terms(plant, ctx, x, vdot):
    """(Drake's inverse dynamics with the force elements, magnitude of its terms)."""
    plant.SetPositionsAndVelocities(ctx, x)
    forces = MultibodyForces(plant)
    plant.CalcForceElementsContribution(ctx, forces)
    tau = plant.CalcInverseDynamics(ctx, vdot, forces)
    scale = (np.abs(plant.CalcMassMatrix(ctx)) @ np.abs(vdot) + np.abs(plant.CalcBiasTerm(ctx))
             + np.abs(plant.CalcGravityGeneralizedForces(ctx)))
    return tau, max(1.0, float(np.max(scale)))


def random_state(rng, n, k):
    """Angles (and slides) over ±π, every fourth state over ±4π with fast rates; velocities up
    to tens of rad/s (m/s), accelerations likewise."""
    wide = k % 4 == 0
    q = rng.uniform(-np.pi, np.pi, n) * (4.0 if wide else 1.0)
    v = rng.normal(size=n) * (30.0 if wide else 3.0)
    vdot = rng.normal(size=n) * (50.0 if wide else 5.0)
    return np.concatenate([q, v]), vdot


def worst_error(plant, ctx, capsule, count, seed, order=None):
    rng = np.random.default_rng(seed)
    n = plant.num_positions()
    worst = 0.0
    for k in range(count):
        x, vdot = random_state(rng, n, k)
        tau, scale = drake_terms(plant, ctx, x, vdot)
        if order is None:
            got = K.inverse_dynamics(capsule, x, vdot)
        else:       # the caller's order: value of Drake coordinate i at index order[i]
            q, v = np.empty(n), np.empty(n)
            q[order], v[order] = x[:n], x[n:]
            a = np.empty(n)
            a[order] = vdot
            got = np.asarray(K.inverse_dynamics(capsule, q, v, a))[order]
        worst = max(worst, float(np.max(np.abs(np.asarray(got) - tau))) / scale)
    return worst


def test_kernel_is_built_and_selected():
    # CI machines have a C compiler: a missing build is a packaging error, not a fallback case
    assert kernel("rnea") is K


def test_tiltrotor_equals_drake():
    model = TiltrotorModel()
    capsule = tree_model(model.plant, model.context)
    assert capsule is not None
    assert worst_error(model.plant, model.context, capsule, 600, seed=1) < TOL


def test_general_tree_equals_drake_in_any_coordinate_order():
    plant = tree_plant()
    ctx = plant.CreateDefaultContext()
    assert unsupported_reason(plant) is None
    # the joints were added out of order: Drake's coordinates are not the bodies' order
    assert tree_constants(plant)["dof"] != list(range(5))
    assert worst_error(plant, ctx, tree_model(plant), 600, seed=2) < TOL
    order = [3, 0, 4, 2, 1]
    capsule = tree_model(plant, ctx, coordinates=order)
    assert worst_error(plant, ctx, capsule, 100, seed=3, order=np.array(order)) < TOL
    with pytest.raises(ValueError, match="permutation"):
        tree_model(plant, coordinates=[0, 0, 1, 2, 3])


def test_long_chain_equals_drake():
    """20 alternating revolute/prismatic links (more than the kernel's on-stack buffers)."""
    plant = MultibodyPlant(0.0)
    parent = plant.world_frame()
    rng = np.random.default_rng(9)
    for i in range(20):
        body = plant.AddRigidBody(f"link{i}", _inertia(0.5 + 0.1 * i, rng.normal(size=3) * 0.1,
                                                       (0.02, 0.03, 0.04), (0.001, 0.0, -0.002)))
        F = plant.AddFrame(FixedOffsetFrame(f"F{i}", parent, RigidTransform(
            RollPitchYaw(*rng.normal(size=3)), rng.normal(size=3) * 0.2)))
        joint = RevoluteJoint if i % 2 == 0 else PrismaticJoint
        plant.AddJoint(joint(f"j{i}", F, body.body_frame(), _unit(rng.normal(size=3))))
        parent = body.body_frame()
    plant.Finalize()
    assert worst_error(plant, plant.CreateDefaultContext(), tree_model(plant), 100, seed=10) < TOL


def test_parameters_are_read_from_the_context():
    """Masses, centres of mass and frame poses changed in a context: the capsule built from
    that context follows them, the one from the defaults does not."""
    plant = tree_plant()
    ctx = plant.CreateDefaultContext()
    plant.GetBodyByName("arm").SetMass(ctx, 2.5)
    plant.GetBodyByName("tip").SetCenterOfMassInBodyFrame(ctx, [0.1, -0.2, 0.05])
    plant.GetFrameByName("F2").SetPoseInParentFrame(
        ctx, RigidTransform(RollPitchYaw(0.4, 0.1, -0.2), [0.1, 0.2, -0.1]))
    assert worst_error(plant, ctx, tree_model(plant, ctx), 100, seed=4) < TOL
    assert worst_error(plant, ctx, tree_model(plant), 20, seed=4) > 1e-3


def test_library_models_in_scope_equal_drake():
    from sobolev_drake.models.quadrotor import make_quadrotor_model
    from sobolev_drake.models.two_wheeled import make_two_wheeled_model

    for model in (make_quadrotor_model(), make_two_wheeled_model()):
        capsule = tree_model(model.plant, model.context)
        assert capsule is not None
        assert worst_error(model.plant, model.context, capsule, 100, seed=5) < TOL


def test_recursive_inverse_dynamics_with_and_without_kernel(monkeypatch):
    """The law's per-sample u* uses the kernel when it is on (no Drake call) and Drake's
    CalcInverseDynamics under native.disabled(), also after the capsule was cached."""
    ml = make_law(TiltrotorModel()).mech_law
    drake_calls = []
    reference = ml.dynamics.recursive_inverse_dynamics_drake
    monkeypatch.setattr(ml.dynamics, "recursive_inverse_dynamics_drake",
                        lambda *a: drake_calls.append(1) or reference(*a))
    rng = np.random.default_rng(6)
    for k in range(50):
        x, acc = random_state(rng, 8, k)
        q, qd = x[:8], x[8:]
        fast = ml.dynamics.recursive_inverse_dynamics(q, qd, acc)
        assert ml.dynamics._cache["rnea"] is not None and not drake_calls
        with native_pkg.disabled():
            slow = ml.dynamics.recursive_inverse_dynamics(q, qd, acc)
        assert drake_calls == [1]
        drake_calls.clear()
        assert np.array_equal(slow, reference(q, qd, acc))
        full = ml.dynamics.inverse_dynamics(q, qd, acc)          # M q̈ + C q̇ + g, thesis order
        scale = 1.0 + np.max(np.abs(full))
        assert np.max(np.abs(fast - slow)) < TOL * scale
        assert np.max(np.abs(fast - full)) < 1e-12 * scale


def test_friction_is_added_when_the_model_has_it():
    class RubbingTiltrotor(TiltrotorModel):
        frictionless = False

        def friction(self, qdot):
            return 0.3 * np.asarray(qdot, dtype=float) + 0.1

    ml = make_law(RubbingTiltrotor()).mech_law
    rng = np.random.default_rng(8)
    q, qd, acc = rng.normal(size=8), rng.normal(size=8), rng.normal(size=8)
    fast = ml.dynamics.recursive_inverse_dynamics(q, qd, acc)
    assert ml.dynamics._cache["rnea"] is not None
    full = ml.dynamics.inverse_dynamics(q, qd, acc)
    assert np.max(np.abs(fast - full)) < 1e-12 * (1.0 + np.max(np.abs(full)))


def _add_spring(plant, bodies):
    plant.AddForceElement(RevoluteSpring(plant.GetJointByName("slider_arm"), 0.0, 5.0))


def _add_actuator_with_rotor(plant, bodies):
    actuator = plant.AddJointActuator("motor", plant.GetJointByName("slider_arm"))
    actuator.set_default_rotor_inertia(1e-4)
    actuator.set_default_gear_ratio(50.0)


def _add_welded_body(plant, bodies):
    extra = plant.AddRigidBody("payload", _inertia(0.1, [0, 0, 0], (1e-4, 1e-4, 1e-4), (0, 0, 0)))
    plant.AddJoint(WeldJoint("weld", bodies["arm"].body_frame(), extra.body_frame(),
                             RigidTransform([0.3, 0.0, 0.0])))


def _add_free_body(plant, bodies):
    plant.AddRigidBody("free", _inertia(0.1, [0, 0, 0], (1e-4, 1e-4, 1e-4), (0, 0, 0)))


def _disable_gravity(plant, bodies):
    plant.set_gravity_enabled(bodies["base"].model_instance(), False)


@pytest.mark.parametrize("build, reason", [
    (lambda: tree_plant(damping=0.2), "damping"),
    (lambda: tree_plant(time_step=1e-3), "discrete"),
    (lambda: tree_plant(extra=_add_spring), "RevoluteSpring"),
    (lambda: tree_plant(extra=_add_actuator_with_rotor), "reflected inertia"),
    (lambda: tree_plant(extra=_add_welded_body), "weld"),
    (lambda: tree_plant(extra=_add_free_body), "quaternion_floating"),
    (lambda: tree_plant(extra=_disable_gravity), "gravity is disabled"),
])
def test_refuses_what_it_does_not_model(build, reason):
    plant = build()
    assert reason in unsupported_reason(plant)
    assert tree_model(plant) is None


def test_refuses_context_damping_and_locks_and_defers_to_drake():
    plant = tree_plant()
    ctx = plant.CreateDefaultContext()
    assert tree_model(plant, ctx) is not None
    plant.GetJointByName("slider_arm").SetDamping(ctx, 0.5)
    assert "damping" in unsupported_reason(plant, ctx)
    ctx = plant.CreateDefaultContext()
    plant.GetJointByName("base_slider").Lock(ctx)
    assert "locked" in unsupported_reason(plant, ctx)
    assert tree_model(plant, ctx) is None


def test_disabled_not_built_or_refused_gives_none(monkeypatch):
    plant = tree_plant()
    with native_pkg.disabled():
        assert tree_model(plant) is None
    assert tree_model(tree_plant(damping=1.0)) is None
    monkeypatch.setitem(native_pkg._CACHE, "rnea", None)        # as if it were not built
    assert tree_model(plant) is None
    ml = make_law(TiltrotorModel()).mech_law
    q, qd, acc = np.full(8, 0.1), np.full(8, 0.2), np.full(8, 0.3)
    assert np.array_equal(ml.dynamics.recursive_inverse_dynamics(q, qd, acc),
                          ml.dynamics.recursive_inverse_dynamics_drake(q, qd, acc))
    assert ml.dynamics._cache["rnea"] is None


def test_bad_arguments_raise_naming_them():
    plant = tree_plant()
    cap = tree_model(plant)
    x, a = np.zeros(10), np.zeros(5)
    with pytest.raises(ValueError, match="x must have 10 entries, got 9"):
        K.inverse_dynamics(cap, x[:9], a)
    with pytest.raises(ValueError, match="vdot must have 5 entries"):
        K.inverse_dynamics(cap, x, [0.0] * 6)
    with pytest.raises(ValueError, match="q must have 5 entries"):
        K.inverse_dynamics(cap, np.zeros(4), np.zeros(5), a)
    with pytest.raises(ValueError, match="v must have 5 entries"):
        K.inverse_dynamics(cap, np.zeros(5), np.zeros(6), a)
    with pytest.raises(TypeError, match="x must be a sequence"):
        K.inverse_dynamics(cap, None, a)
    with pytest.raises(TypeError, match="takes"):
        K.inverse_dynamics(cap, x)
    with pytest.raises((TypeError, ValueError)):
        K.inverse_dynamics(object(), x, a)             # not the kernel's capsule
    # ints and lists are read as floats; non-finite values propagate, nothing crashes
    assert K.inverse_dynamics(cap, list(range(10)), [0] * 5) == K.inverse_dynamics(
        cap, np.arange(10.0), np.zeros(5))
    out = K.inverse_dynamics(cap, np.full(10, np.nan), np.full(5, np.inf))
    assert len(out) == 5 and not np.isfinite(out).any()


def test_make_model_rejects_bad_constants():
    good = tree_constants(tree_plant())
    for key, value, match in [
        ("n", 0, "n must be in"),
        ("parent", [-1, 1, 0, 0, 2], "precede"),
        ("dof", [0, 1, 1, 2, 3], "permutation"),
        ("joint_type", [0, 1, 2, 0, 1], "joint_type"),
        ("axis", [2.0] + good["axis"][1:], "unit vector"),
        ("mass", [float("nan")] + good["mass"][1:], "finite"),
        ("R_PF", good["R_PF"][:-1], "R_PF must have 45 entries"),
    ]:
        with pytest.raises(ValueError, match=match):
            K.make_model({**good, key: value})
    bad = dict(good)
    del bad["gravity"]
    with pytest.raises(KeyError, match="missing gravity"):
        K.make_model(bad)
    with pytest.raises(TypeError):
        K.make_model([])
