"""Wind sources: von Kármán statistics and spectrum, seeding, gusts, sums, mission helper."""

import math

import numpy as np
import pytest
from scipy import integrate, signal
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import VectorLogSink

from sobolev_drake.systems.wind import (
    ConstantWind, GustProfile, VonKarmanParameters, VonKarmanTurbulence, WindSum, add_wind,
    discrete_filter, mission_wind_sources, simulate_discrete, von_karman_psd, von_karman_psd_hz,
    von_karman_state_space, von_karman_transfer_functions)


@pytest.fixture(scope="module")
def turbulence_rig():
    """One diagram reused by all Drake-level tests (Python LeafSystems are never freed)."""
    b = DiagramBuilder()
    vk = b.AddSystem(VonKarmanTurbulence())
    log_w = b.AddSystem(VectorLogSink(3, publish_period=0.01))
    log_n = b.AddSystem(VectorLogSink(3, publish_period=0.01))
    b.Connect(vk.GetOutputPort("wind"), log_w.get_input_port())
    b.Connect(vk.GetOutputPort("noise"), log_n.get_input_port())
    diagram = b.Build()

    def run(seed, duration=5.0, stationary=False):
        # A fresh (C++) Simulator per run: a reused one carries the error-controlled
        # integrator's step-size history over, which changes the samples at the 1e-8 level.
        sim = Simulator(diagram)
        ctx = sim.get_mutable_context()
        ctx.SetTime(0.0)
        diagram.SetDefaultContext(ctx)
        vk.seed(ctx, seed, stationary=stationary)
        log_w.FindMutableLog(ctx).Clear()
        log_n.FindMutableLog(ctx).Clear()
        sim.Initialize()
        sim.AdvanceTo(duration)
        return log_w.FindLog(ctx).data().T.copy(), log_n.FindLog(ctx).data().T.copy()

    return vk, run


def test_intensity_pi_normalisation_by_quadrature():
    # ∫0^∞ |H|² dω ≈ σ² for the rational forms (docs/design.md §6): 0.969 σ² and 0.962 σ².
    p = VonKarmanParameters()
    for axis, expected in zip(range(3), (0.9687, 0.9623, 0.9623)):
        val, _ = integrate.quad(lambda w: von_karman_psd(w, p)[0, axis], 0, np.inf, limit=400)
        assert val / p.sigma[axis] ** 2 == pytest.approx(expected, abs=2e-4)


def test_lyapunov_std_matches_quadrature():
    vk_std = VonKarmanTurbulence().stationary_std()
    p = VonKarmanParameters()
    for axis in range(3):
        val, _ = integrate.quad(lambda w: von_karman_psd(w, p)[0, axis], 0, np.inf, limit=400)
        assert vk_std[axis] == pytest.approx(math.sqrt(val), rel=1e-6)


def test_state_space_matches_transfer_functions():
    A, B, C, D = von_karman_state_space()
    tfs = von_karman_transfer_functions()
    for w in (0.01, 0.3, 2.0):
        H = C @ np.linalg.solve(1j * w * np.eye(8) - A, B) + D
        for axis, (num, den) in enumerate(tfs):
            assert H[axis, axis] == pytest.approx(np.polyval(num, 1j * w) / np.polyval(den, 1j * w), rel=1e-10)
        assert np.allclose(H - np.diag(np.diag(H)), 0)


def test_drake_system_equals_discrete_filter(turbulence_rig):
    vk, run = turbulence_rig
    wind, noise = run(seed=11, duration=20.0)
    # The logged noise at t_{k+1} is the sample held on [t_k, t_{k+1}) (logging precedes the
    # periodic update at the same instant), hence the one-sample shift.
    z = simulate_discrete(noise[1:], vk.params)
    n = len(z)
    assert np.max(np.abs(wind[:n] - z)) < 1e-4 * np.max(np.abs(z))
    assert np.std(noise, axis=0) == pytest.approx([1, 1, 1], abs=0.1)  # unit-variance samples


def test_same_seed_same_signal_different_seed_different(turbulence_rig):
    _, run = turbulence_rig
    w1, _ = run(seed=5, stationary=True)
    w2, _ = run(seed=5, stationary=True)
    w3, _ = run(seed=6, stationary=True)
    assert np.array_equal(w1, w2)
    assert np.max(np.abs(w1 - w3)) > 0.1


def test_long_run_std_and_welch_psd():
    p = VonKarmanParameters()
    rng = np.random.default_rng(1234)
    K = int(20000.0 / p.sample_time)
    z = simulate_discrete(rng.standard_normal((K, 3)), p)[int(100 / p.sample_time):]  # drop transient
    std = z.std(axis=0)
    exact = VonKarmanTurbulence(p).stationary_std()
    assert np.all(np.abs(std / np.array(p.sigma) - 1) < 0.10), std
    assert np.all(np.abs(std / exact - 1) < 0.04), (std, exact)
    f, G = signal.welch(z, fs=1 / p.sample_time, nperseg=2**14, axis=0)
    model = von_karman_psd_hz(f, p)
    edges = np.logspace(np.log10(0.01), np.log10(1.0), 9)
    for lo, hi in zip(edges[:-1], edges[1:]):
        band = (f >= lo) & (f < hi)
        ratio = G[band].mean(axis=0) / model[band].mean(axis=0)
        assert np.all(np.abs(ratio - 1) < 0.2), (lo, hi, ratio)


def test_discrete_filter_has_noise_gain():
    p = VonKarmanParameters(sample_time=0.05)
    Ad, Bd, C = discrete_filter(p)
    # Stationary discrete covariance of the ZOH model ≈ continuous one with intensity π.
    from scipy import linalg
    Pd = linalg.solve_discrete_lyapunov(Ad, Bd @ Bd.T)
    std_d = np.sqrt(np.diag(C @ Pd @ C.T))
    assert std_d == pytest.approx(VonKarmanTurbulence(p).stationary_std(), rel=0.02)


def test_window_and_offset():
    p = VonKarmanParameters(t_on=1.0, t_off=2.0, offset=(-3.0, 0.5, 0.0))
    vk = VonKarmanTurbulence(p)
    ctx = vk.CreateDefaultContext()
    vk.seed(ctx, 1, stationary=True)
    f_ctx = vk.filter.GetMyMutableContextFromRoot(ctx)
    x = f_ctx.get_continuous_state_vector().CopyToVector()
    _, _, C, _ = von_karman_state_space(p)
    for t, inside in ((0.5, False), (1.5, True), (2.5, False)):
        ctx.SetTime(t)
        w = vk.GetOutputPort("wind").Eval(ctx)
        expected = np.array(p.offset) + (C @ x if inside else 0)
        assert np.allclose(w, expected)
    assert not vk.filter.HasDirectFeedthrough(0, 0)  # wind depends on state, not on noise


def test_overrides_and_bad_parameters():
    vk = VonKarmanTurbulence(sigma=(2.0, 0.0, 1.0), airspeed=10.0)
    assert vk.params.airspeed == 10.0 and vk.stationary_std()[1] == 0.0
    with pytest.raises(ValueError, match="sigma"):
        VonKarmanTurbulence(sigma=(1.0, 2.0))
    with pytest.raises(ValueError, match="airspeed"):
        VonKarmanTurbulence(airspeed=0.0)
    with pytest.raises(ValueError, match="t_on"):
        VonKarmanTurbulence(t_on=5.0, t_off=1.0)
    with pytest.raises(ValueError, match="noise"):
        simulate_discrete(np.zeros((10, 2)))
    with pytest.raises(ValueError, match="seed"):
        VonKarmanTurbulence().seed(None, -1)


def test_gust_profile_steps_and_smoothing():
    gusts = [{"axis": "y", "value": 5.0, "from": 20.0, "to": 23.0},
             {"axis": "z", "value": -3.0, "from": 50.0, "to": 53.0}]
    g = GustProfile(gusts)
    ctx = g.CreateDefaultContext()
    ctx.SetTime(21.0)
    assert np.allclose(g.GetOutputPort("wind").Eval(ctx), [0, 5, 0])
    ctx.SetTime(51.0)
    assert np.allclose(g.GetOutputPort("wind").Eval(ctx), [0, 0, -3])
    ctx.SetTime(30.0)
    assert np.allclose(g.GetOutputPort("wind").Eval(ctx), 0)
    gs = GustProfile(gusts, rise_time=1.0)
    t = np.linspace(15, 60, 45001)
    vals = np.array([gs.value(ti) for ti in t])
    assert np.trapezoid(vals[:, 1], t) == pytest.approx(15.0, rel=1e-4)  # integral preserved
    assert np.max(np.abs(np.diff(vals[:, 1]))) < 5.0 * 0.01  # no jumps
    assert gs.value(20.0)[1] == pytest.approx(2.5)
    with pytest.raises(ValueError, match="axis"):
        GustProfile([{"axis": "q", "value": 1, "from": 0, "to": 1}])
    with pytest.raises(ValueError, match="keys"):
        GustProfile([{"axis": "x", "value": 1}])
    with pytest.raises(ValueError, match="rise_time"):
        GustProfile(gusts, rise_time=5.0)


def test_constant_wind_sum_and_mission_helper():
    sources = mission_wind_sources("scenario_2_full_envelope")
    b = DiagramBuilder()
    port = add_wind(b, *sources)
    b.ExportOutput(port, "wind")
    d = b.Build()
    ctx = d.CreateDefaultContext()
    ctx.SetTime(21.0)
    assert np.allclose(d.GetOutputPort("wind").Eval(ctx), [-3, 5, 0])
    ctx.SetTime(201.0)
    assert np.allclose(d.GetOutputPort("wind").Eval(ctx), [-3, 0, 3])
    (c,) = mission_wind_sources("scenario_1_helicopter_mode")
    assert np.allclose(c.GetOutputPort("wind").Eval(c.CreateDefaultContext()), [0, 3, 0])
    (vk,) = mission_wind_sources("hover_linear")
    assert vk.params.t_on == 30.0 and vk.params.offset == (-3.0, 0.0, 0.0)
    with pytest.raises(ValueError, match="unknown scenario"):
        mission_wind_sources("nope")
    with pytest.raises(ValueError, match="wind"):
        ConstantWind([1.0, 2.0])
    with pytest.raises(ValueError, match="num_inputs"):
        WindSum(0)
    s = WindSum(2)
    sc = s.CreateDefaultContext()
    s.GetInputPort("wind_0").FixValue(sc, [1, 2, 3])
    s.GetInputPort("wind_1").FixValue(sc, [1, 0, -3])
    assert np.allclose(s.GetOutputPort("wind").Eval(sc), [2, 2, 0])


@pytest.mark.parametrize("length,airspeed", [(5.0, 2.0), (150.0, 33.0), (533.0, 5.1)])
def test_normalisation_is_independent_of_scale_length_and_speed(length, airspeed):
    # s → (L/V) s only rescales frequency, so ∫|H|²dω/σ² and hence std/σ do not depend on L, V.
    p = VonKarmanParameters(sigma=(2.0, 0.5, 7.0), length=(length,) * 3, airspeed=airspeed)
    ratio = VonKarmanTurbulence(p).stationary_std() / np.array(p.sigma)
    assert ratio == pytest.approx([math.sqrt(0.96871), math.sqrt(0.96234), math.sqrt(0.96234)], rel=1e-4)
