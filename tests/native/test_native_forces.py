"""The compiled force kernel (sobolev_drake/native/forces.c) against the Python scalar tier.

The kernel mirrors the Python scalar tier expression by expression, so the force model, the
propellers and the plant's force system agree to the bit; only the input-affine terms may differ
in the last bit (libm's hypot vs Python's math.hypot).  The scalar tier itself is compared with
the numpy reference in tests/tiltrotor/test_tiltrotor_forces.py.
"""

import importlib

import numpy as np
import pytest
from pydrake.systems.framework import DiagramBuilder

from sobolev_drake.tiltrotor.plant import add_tiltrotor
from sobolev_drake.tiltrotor.params import TiltrotorParams
import sobolev_drake.native as native_pkg
from sobolev_drake.native import kernel
from sobolev_drake.native.forces import force_model
from sobolev_drake.tiltrotor import controller as tc
from sobolev_drake.tiltrotor import law as tl
from sobolev_drake.tiltrotor.allocation import tiltrotor_bounds
from sobolev_drake.tiltrotor.input_affine import (affine_terms_scalar, affine_terms_scalar_python,
                                                cores)
from sobolev_drake.tiltrotor.propulsion import body_kinematics_scalar

K = importlib.import_module("sobolev_drake.native._forces")   # ImportError: not built
EPS = np.finfo(float).eps


@pytest.fixture(autouse=True)
def kernels_on(monkeypatch):
    """These tests compare the kernel with Python, so they switch it on even under
    SOBOLEV_DRAKE_NATIVE=0 (and off where they test the fallback)."""
    monkeypatch.setattr(native_pkg, "_ENABLED", True)


def random_case(rng, k):
    """States over the envelope, including zero air speed of the body (k % 7 == 0) and
    negative forward air speed (reversed flow)."""
    q = rng.normal(size=8) * [0.8, 0.8, 0.5, 0.5, 3.0, 10.0, 10.0, 10.0]
    qd = rng.normal(size=8) * [1.0, 1.0, 1.0, 1.0, 1.0, 15.0, 15.0, 5.0]
    zeta = rng.normal(size=3) * 5.0
    if k % 7 == 0:
        qd[2:5] = 0.0
        qd[5:8] = zeta
    return q.tolist(), qd.tolist(), zeta.tolist()


def test_kernel_is_built_and_selected():
    # CI machines have a C compiler: a missing build is a packaging error, not a fallback case
    assert kernel("forces") is K


@pytest.mark.parametrize("crossflow, reverse_flow", [("independence", "clipped"),
                                                     ("thesis", "clipped"),
                                                     ("independence", "mirrored"),
                                                     ("thesis", "mirrored")])
def test_loads_propellers_and_affine_terms_equal_python(crossflow, reverse_flow):
    params = TiltrotorParams(crossflow=crossflow, reverse_flow=reverse_flow)
    prop, aero = cores(params)
    cap = force_model(prop, aero)
    rng = np.random.default_rng(11)
    worst_affine = 0.0
    for k in range(400):
        ql, qdl, zl = random_case(rng, k)
        delta = (rng.normal(size=4) * 0.3).tolist()
        n = (np.abs(rng.normal(size=2)) * 60 + (0.0 if k % 11 == 0 else 5.0)).tolist()
        kin = body_kinematics_scalar(ql, qdl, zl)
        out, V, cols = aero.loads_scalar(kin, delta, columns=True)
        o2, V2, c2 = K.aero_loads(cap, ql, qdl, zl, delta, True)
        assert o2 == out and V2 == V and c2 == [list(c) for c in cols]       # bit for bit
        o3, _, none = K.aero_loads(cap, ql, qdl, zl, delta, False)
        assert o3 == out and none is None
        pf = prop.propeller_force_scalar(kin, prop.rotors_scalar(ql, qdl, kin), n)
        assert K.propeller_force(cap, ql, qdl, zl, n) == pf
        for torque in ("through_thrust", "passive"):
            a = affine_terms_scalar_python(params, ql, qdl, zl, n, torque)
            B, passive, Vs, vxz, phi = K.affine_terms(cap, ql, qdl, zl, n, torque == "through_thrust")
            for ref, got in ((a.B.ravel(), B), (a.passive, passive), (a.surface_speed, Vs),
                             (a.rotor_vxz, vxz), (a.rotor_phi, phi)):
                err = np.max(np.abs(np.asarray(got) - ref) / (1.0 + np.abs(ref)))
                worst_affine = max(worst_affine, err)
    # The two differ only where hypot rounds differently (by at most one ulp of V_xz); the
    # same expressions then carry that ulp through J, Ct, Cq and Cq/Ct, which amplify it by
    # their condition numbers in J.  Measured: 0.84 ε relative; 64 ε leaves room for those.
    assert worst_affine < 64 * EPS, worst_affine


@pytest.mark.parametrize("reverse_flow", ["clipped", "mirrored"])
def test_kernel_forces_equal_numpy_reference(reverse_flow):
    """The kernel's ϑ_aero and ϑ_P against the readable numpy reference directly (the test
    above goes through the scalar tier, which the kernel matches to the bit)."""
    params = TiltrotorParams(reverse_flow=reverse_flow)
    prop, aero = cores(params)
    cap = force_model(prop, aero)
    rng = np.random.default_rng(12)
    worst = 0.0
    for k in range(200):
        ql, qdl, zl = random_case(rng, k)
        delta = (rng.normal(size=4) * 0.3).tolist()
        n = (np.abs(rng.normal(size=2)) * 60 + 5.0).tolist()
        q, qd, zeta = np.array(ql), np.array(qdl), np.array(zl)
        passive, Bd = aero.terms(q, qd, zeta)
        f, t, _, _ = prop.thrust_and_torque(q, qd, zeta, np.array(n))
        Gf, Gt = prop.unit_columns(q)
        for ref, got in ((passive + Bd @ delta, K.aero_loads(cap, ql, qdl, zl, delta, False)[0]),
                         (Gf @ f + Gt @ t, K.propeller_force(cap, ql, qdl, zl, n))):
            worst = max(worst, np.max(np.abs(np.asarray(got) - ref)) / (1 + np.max(np.abs(ref))))
    # the same sums in another order (matrix products against running sums): a few ulps of
    # the largest term (measured: ≤ 8 ε), as in tests/tiltrotor/test_tiltrotor_forces.py
    assert worst < 256 * EPS, worst / EPS


def test_affine_terms_dispatch_and_fallback(monkeypatch):
    params = TiltrotorParams()
    ql, qdl, zl = random_case(np.random.default_rng(2), 1)
    native = affine_terms_scalar(params, ql, qdl, zl, [50.0, 52.0])
    monkeypatch.setattr(native_pkg, "_ENABLED", False)
    assert kernel("forces") is None and force_model(*cores(params)) is None
    python = affine_terms_scalar_python(params, ql, qdl, zl, [50.0, 52.0])
    # hypot's last bit, as in test_loads_propellers_and_affine_terms_equal_python
    np.testing.assert_allclose(native.B, python.B, rtol=64 * EPS, atol=64 * EPS)
    np.testing.assert_allclose(native.passive, python.passive, rtol=64 * EPS, atol=64 * EPS)


def _forces_diagram(native):
    b = DiagramBuilder()
    h = add_tiltrotor(b, native=native)
    return h, b.Build()


def test_plant_force_system_native_equals_python():
    """Both output ports of TiltrotorForces, with a varying subset of the optional inputs fixed
    (the others unconnected, i.e. zero)."""
    hn, dn = _forces_diagram(None)
    hp, dp = _forces_diagram(False)
    assert hn.forces.native and not hp.forces.native
    rng = np.random.default_rng(5)
    for k in range(40):
        ql, qdl, zl = random_case(rng, k)
        inputs = {"u": rng.normal(size=8) * [20, 20, 1, 1, 0.2, 0.2, 0.2, 0.2] + [50, 50, 0, 0, 0, 0, 0, 0],
                  "propeller_speed": rng.uniform(0, 70, 2), "servo_torque": rng.normal(size=2),
                  "surface_deflection": rng.normal(size=4) * 0.2, "wind": np.array(zl),
                  "force_disturbance": rng.normal(size=3) * 10, "disturbance": rng.normal(size=8)}
        fixed = [name for i, name in enumerate(inputs) if (k >> i) & 1 or k % 9 == 0]
        ctxs = []
        for h, d in ((hn, dn), (hp, dp)):
            ctx = d.CreateDefaultContext()
            h.set_state(ctx, d, np.array(ql), np.array(qdl))
            fctx = h.forces.GetMyContextFromRoot(ctx)
            for name in fixed:
                h.forces.GetInputPort(name).FixValue(fctx, inputs[name])
            ctxs.append(fctx)
        fn, fp = ctxs
        for port in ("applied_generalized_force", "generalized_force"):
            a = hn.forces.GetOutputPort(port).Eval(fn)
            b = hp.forces.GetOutputPort(port).Eval(fp)
            assert np.array_equal(a, b), (port, fixed, a - b)
        assert np.array_equal(hn.forces.GetOutputPort("generalized_force").Eval(fn),
                              hn.forces.thesis_force(fn))


def test_native_true_requires_the_kernel(monkeypatch):
    with pytest.raises(ValueError, match="native must be None"):
        add_tiltrotor(DiagramBuilder(), native="yes")
    monkeypatch.setattr(native_pkg, "_ENABLED", False)
    with pytest.raises(RuntimeError, match="kernel is not built"):
        add_tiltrotor(DiagramBuilder(), native=True)
    assert not add_tiltrotor(DiagramBuilder()).forces.native


def test_newton_speed_equals_python():
    prop, aero = cores(TiltrotorParams())
    cap = force_model(prop, aero)
    rng = np.random.default_rng(8)
    found = 0
    for k in range(300):
        f = rng.uniform(-5, 90, 2)
        v, phi = rng.uniform(0, 30, 2), rng.uniform(0, np.pi / 2, 2)
        guess = rng.uniform(0.5, 90, 2) if k % 4 else rng.uniform(30, 60, 2)
        ref = tl.newton_speed_for_thrust(prop.coef, f, v, phi, guess)
        got = K.newton_speed(cap, f, v, phi, guess, 4, 1e-9)
        assert (ref is None) == (got is None)
        if ref is not None:
            found += 1
            assert got == ref.tolist()
    assert found > 50          # the comparison covered converged solves, not only rejections


def test_surface_bounds_equal_python_and_reject_bad_speed(monkeypatch):
    rng = np.random.default_rng(3)
    speeds = [rng.uniform(0, 40, 4) for _ in range(50)] + [np.zeros(4), np.full(4, 12.0), 7.5]
    native = [tiltrotor_bounds(v) for v in speeds]
    with pytest.raises(ValueError, match="non-negative"):
        tiltrotor_bounds([1.0, -1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="non-negative"):
        tiltrotor_bounds([1.0, np.nan, 2.0, 3.0])
    monkeypatch.setattr(native_pkg, "_ENABLED", False)
    for v, (lo, hi) in zip(speeds, native):
        lo_p, hi_p = tiltrotor_bounds(v)
        assert np.array_equal(lo, lo_p) and np.array_equal(hi, hi_p)


def test_make_model_rejects_bad_constants():
    prop, aero = cores(TiltrotorParams())
    cap = force_model(prop, aero)
    assert cap is not None
    with pytest.raises(KeyError, match="missing"):
        K.make_model({"samples": 10.0})
    for samples in (1.0, float("nan"), 2.5):     # was a SystemError (no exception set) / UB
        with pytest.raises(ValueError, match="samples must be an integer"):
            K.make_model({"samples": samples})
    with pytest.raises(ValueError, match="alpha_tab"):
        K.make_model({"samples": 10.0, "points": [0.0] * 18, "half_rho_s": [0.0] * 6,
                      "alpha_tab": [0.0] * 3})
    with pytest.raises(ValueError, match="must have 16 entries"):
        K.plant_force(cap, np.zeros(15), [0.0] * 8, None, None, None, np.zeros(8), True)
    with pytest.raises(ValueError, match="writable contiguous float64"):
        K.plant_force(cap, np.zeros(16), [0.0] * 8, None, None, None, np.zeros(8)[::-1].copy()[:7], True)


def test_mission_states_equal_with_and_without_kernels(monkeypatch):
    """Two seconds of the envelope mission: the compiled and the Python paths fly the same
    trajectory (to rounding: the affine terms' hypot may differ in the last bit)."""
    from sobolev_drake.tiltrotor.mission import simulate_mission

    def final_state():
        built, _ = simulate_mission(2, 2.0)
        return built["simulator"].get_context().get_continuous_state_vector().CopyToVector()

    native_run = final_state()
    with native_pkg.disabled():
        python = final_state()
    # Only hypot's last bit differs per sample; the stable closed loop keeps that at rounding
    # level over the 200 samples (measured 5.6e-16 with states up to 0.64).  1e-12 leaves
    # room for another libm and still fails on any real difference between the paths.
    assert np.max(np.abs(native_run - python)) < 1e-12 * (1 + np.max(np.abs(python)))


def test_saturation_flags_equal_python():
    rng = np.random.default_rng(9)
    rows = []
    for _ in range(200):
        lo = -rng.uniform(0, 2, 8) * (rng.uniform(size=8) > 0.2)
        up = lo + rng.uniform(0, 2, 8) * (rng.uniform(size=8) > 0.2)
        tau = np.clip(rng.uniform(-2.5, 2.5, 8), lo, up)
        tau[rng.uniform(size=8) > 0.7] = (lo + 5e-4 * (up - lo))[0]
        rows.append((tau, lo, up, tc.saturation_flags(tau, lo, up)))
    with native_pkg.disabled():
        for tau, lo, up, flags in rows:
            assert np.array_equal(flags, tc.saturation_flags(tau, lo, up))
    assert len({f.tobytes() for *_, f in rows}) > 20


def test_nan_air_data_raises_like_python():
    """A NaN state or wind must not index the tables (C: undefined behaviour); both paths raise
    ValueError."""
    prop, aero = cores(TiltrotorParams())
    cap = force_model(prop, aero)
    q, qd, zeta = [0.0] * 8, [0.0] * 5 + [10.0, 0.0, 0.0], [0.0, float("nan"), 0.0]
    with pytest.raises(ValueError, match="NaN"):
        K.aero_loads(cap, q, qd, zeta, [0.0] * 4, False)
    with pytest.raises(ValueError):
        aero.loads_scalar(body_kinematics_scalar(q, qd, zeta), [0.0] * 4)
    with pytest.raises(ValueError, match="NaN"):
        K.affine_terms(cap, q, qd, zeta, [50.0, 50.0], True)
    state = np.zeros(16)
    state[8:] = np.nan                 # every velocity, so the body air speed too
    with pytest.raises(ValueError, match="NaN"):
        K.plant_force(cap, state, [0.0] * 8, None, None, None, np.zeros(8), True)


def test_switching_off_after_first_use_reaches_every_dispatch():
    """native.disabled() after the kernels were used (and their model capsules cached) still
    gives the Python paths: the affine terms, make_law (no fused path) and the plant forces."""
    from sobolev_drake.tiltrotor.plant import TiltrotorModel
    from sobolev_drake.tiltrotor import input_affine

    params = TiltrotorParams()
    ql, qdl, zl = random_case(np.random.default_rng(4), 1)
    affine_terms_scalar(params, ql, qdl, zl, [50.0, 50.0])          # caches the capsule
    assert input_affine.native_core(params) is not None
    with native_pkg.disabled():
        assert input_affine.native_core(params) is None
        assert tl.make_law(TiltrotorModel(params)).fused_sample is None
        assert not add_tiltrotor(DiagramBuilder(), params).forces.native
