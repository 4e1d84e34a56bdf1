"""Loop analysis (synthesis.loop_analysis), its figure, and W∞ weights from bandwidth/damping."""

import warnings

import numpy as np
import pytest

import sobolev_drake as sd
from sobolev_drake.models.arm import make_arm_model
from sobolev_drake.models.linearization import linearize_mechanical
from sobolev_drake.synthesis import SynthesisWarning
from sobolev_drake.synthesis.margins import input_gain_margins


@pytest.fixture(scope="module")
def arm():
    """The two-link arm linearized by Drake at q = (0.3, 0.5) held against gravity."""
    m = make_arm_model()
    q0 = np.array([0.3, 0.5])
    u0 = np.linalg.solve(m.B(q0), m.g(q0))
    return linearize_mechanical(m, q0, np.zeros(2), u0)


def quiet(fn, *a, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SynthesisWarning)
        return fn(*a, **kw)


def test_disk_gain_range_lies_inside_the_exact_uniform_gain_margin():
    # Open-loop-unstable single-input loop: the disk-based gain interval is a guaranteed
    # subset of the exact stability interval (bisection on closed-loop eigenvalues, rtol 1e-6);
    # the 1e-3 slack covers the 300-point frequency grid of the disk margin
    A = np.array([[0.0, 1.0], [4.0, -0.2]])
    B = np.array([[0.0], [1.0]])
    res = sd.winf_state_feedback(A, B, B, Gamma0=[1, 1], Gamma1=[0.1, 0.1], gamma=5.0)
    an = sd.loop_analysis(res, sd.winf_plant(A, B, D=B, Gamma0=[1, 1], Gamma1=[0.1, 0.1]))
    lo, hi = input_gain_margins(A, B, res.K)
    g = 10 ** (an.input_margins.disk_gain_db[0] / 20)
    assert an.stable
    assert 1 / g >= lo * (1 - 1e-3) and g <= hi * (1 + 1e-3)
    # one input: the multivariable disk margin is the loop's own
    assert an.input_margins.multivariable_disk == pytest.approx(an.input_margins.disk[0])


def test_performance_peak_below_certified_gamma_and_poles_match(arm):
    A, B, D = arm
    G0, G1 = [1, 1, 1, 1], [0.1] * 4
    res = sd.winf_state_feedback(A, B, D, Gamma0=G0, Gamma1=G1, gamma=4.0)
    an = sd.loop_analysis(res, sd.winf_plant(A, B, D=D, Gamma0=G0, Gamma1=G1))
    # the grid peak is a lower bound of the norm, itself certified below gamma
    assert an.hinf_norm <= res.gamma
    assert an.hinf_norm >= 0.9 * res.certificate.achieved
    lam = np.linalg.eigvals(A + B @ res.K)
    assert an.closed_loop.fastest == pytest.approx(np.abs(lam).max(), rel=1e-9)
    assert an.step.shape[:2] == (8, D.shape[1]) and an.impulse.shape == an.step.shape
    assert "| closed loop |" in an.table()


def test_fast_poles_warn_with_a_disk_that_removes_them():
    # the D = I case (quadrotor) on one double integrator: the W∞ optimum puts the
    # poles beyond 1e4 rad/s
    A, B = np.array([[0.0, 1.0], [0.0, 0.0]]), np.array([[0.0], [1.0]])
    G0, G1 = sd.winf_weights(5.0, 0.8, dof=1)
    P = sd.winf_plant(A, B, D=np.eye(2), Gamma0=G0, Gamma1=G1)
    res = quiet(sd.winf_state_feedback, A, B, np.eye(2), Gamma0=G0, Gamma1=G1)
    an = sd.loop_analysis(res, P, gain_limit=1e3)
    assert an.closed_loop.fastest > 1e4
    pole_warning = [w for w in an.warnings if "poles up to" in w]
    assert pole_warning and "region=sd.regions.disk(" in pole_warning[0]
    assert any("exceed the bound" in w for w in an.warnings)
    radius = float(pole_warning[0].split("region=sd.regions.disk(")[1].split(")")[0])
    fixed = quiet(sd.winf_state_feedback, A, B, np.eye(2), Gamma0=G0, Gamma1=G1,
                  region=sd.regions.disk(radius))
    assert not [w for w in sd.loop_analysis(fixed, P).warnings if "poles up to" in w]


def test_output_feedback_on_a_linear_system_and_the_figure(tmp_path):
    A = np.array([[0.0, 1.0], [-1.0, -0.5]])
    B, C = np.array([[0.0], [1.0]]), np.array([[1.0, 0.0]])
    res = quiet(sd.winf_output_feedback, A, B, C, B, Gamma0=[1, 1], Gamma1=[0.1, 0.1])
    an = sd.loop_analysis(res, (A, B, C, np.zeros((1, 1))))
    assert an.controller is not None and an.step is None and "Tzw" not in an.sigma
    assert an.stable
    png = sd.plot_loop_analysis(an, tmp_path / "loop.png", title="mass-spring")
    assert png.stat().st_size > 10_000


def test_bad_input_is_refused_by_name():
    A, B = np.array([[0.0, 1.0], [0.0, 0.0]]), np.array([[0.0], [1.0]])
    res = sd.winf_state_feedback(A, B, B, Gamma0=[1, 1], Gamma1=[0, 1], gamma=10.0)
    with pytest.raises(TypeError, match="plant must be a GeneralizedPlant"):
        sd.loop_analysis(res, "plant")
    with pytest.raises(ValueError, match="omega"):
        sd.loop_analysis(res, (A, B, np.eye(2), np.zeros((2, 1))), omega=[-1.0, 2.0])
    with pytest.raises(ValueError, match="damping must be at least"):
        sd.winf_weights(2.0, 0.5, dof=1)
    with pytest.raises(TypeError, match="dof"):
        sd.winf_weights(2.0, 0.9)


@pytest.mark.parametrize("omega,zeta", [(5.0, 0.8), (20.0, 1.0), ([2.0, 8.0], [0.71, 1.5])])
def test_weights_place_the_poles_with_a_matched_disturbance(arm, omega, zeta):
    # D = [0; M^-1] is matched to the inputs: the design is the LQR of q'' = a exactly at any
    # level (module docstring of synthesis.weights); 1e-6 covers the Riccati solution's accuracy
    A, B, D = arm
    G0, G1 = sd.winf_weights(omega, zeta, dof=2)
    res = quiet(sd.winf_state_feedback, A, B, D, Gamma0=G0, Gamma1=G1)
    lam = np.linalg.eigvals(A + B @ res.K)
    # each degree of freedom closes with s² + 2ζω s + ω² (ζ > 1: two real poles)
    want = np.concatenate([np.roots([1.0, 2 * z * w, w * w]) for w, z in
                           zip(np.broadcast_to(omega, 2), np.broadcast_to(zeta, 2))])
    def ordered(v):   # sort_complex is not robust to rounding in the real parts
        return v[np.lexsort((np.round(v.imag, 4), np.round(v.real, 4)))]
    np.testing.assert_allclose(ordered(lam), ordered(want), rtol=1e-6)


def test_weights_with_unmatched_disturbance_converge_as_gamma_grows(arm):
    # D = I: the worst-case disturbance shifts the poles by O(1/γ²); measured 0.5 % at 10 x
    # the optimum, asserted at 1 %
    A, B, _ = arm
    G0, G1 = sd.winf_weights(5.0, 0.8, dof=2)
    opt = quiet(sd.winf_state_feedback, A, B, np.eye(4), Gamma0=G0, Gamma1=G1)
    res = sd.winf_state_feedback(A, B, np.eye(4), Gamma0=G0, Gamma1=G1, gamma=10 * opt.gamma)
    lam = np.linalg.eigvals(A + B @ res.K)
    np.testing.assert_allclose(np.abs(lam), 5.0, rtol=1e-2)
    np.testing.assert_allclose(-lam.real / np.abs(lam), 0.8, rtol=1e-2)


def test_readme_examples_are_analysed_by_the_diagram_script(tmp_path):
    import importlib.util
    from pathlib import Path
    path = Path(__file__).resolve().parents[2] / "diagrams" / "loop_analysis_readme.py"
    spec = importlib.util.spec_from_file_location("loop_analysis_readme", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    out = module.run(tmp_path)
    assert len(out) == 4
    for name, (an, png, table) in out.items():
        assert an.stable and png.exists() and "plant input" in table
        assert an.hinf_norm <= an.gamma * (1 + 1e-6)
    # the angle-only output feedback's fast controller poles are reported with their fix
    of = out["acrobot W∞ output feedback (angles)"][0]
    assert any("region=sd.regions.disk(" in w for w in of.warnings)


@pytest.mark.parametrize("delay", [False, True])
def test_discrete_loop_nyquist_ringing_is_reported_and_the_suggested_disk_removes_it(arm, delay):
    # the sampled-data W∞ design with y = x noise free: its controller rings at the Nyquist
    # frequency (z near -1, damping 0.01); the warning's bilinear-domain disk removes it
    A, B, D = arm
    G0, G1 = sd.winf_weights(5.0, 0.8, dof=2)
    sdp = sd.sampled_data_plant(sd.winf_plant(A, B, D=D, Gamma0=G0, Gamma1=G1), 0.01, computation_delay=delay)
    res = quiet(sd.hinf_discrete, sdp, None, None, dt=0.01, computation_delay=delay)
    an = sd.loop_analysis(res, sdp)
    assert an.dt == 0.01 and an.stable and an.hinf_norm <= res.gamma
    assert np.all(an.omega < np.pi / 0.01)
    ring = [w for w in an.warnings if "oscillating" in w]
    assert ring and "sd.hinf_discrete(..., region=sd.regions.disk(" in ring[0]
    R = float(ring[0].split("region=sd.regions.disk(")[1].split(")")[0])
    fixed = quiet(sd.hinf_discrete, sdp, None, None, dt=0.01, computation_delay=delay,
                  region=sd.regions.disk(R))
    an2 = sd.loop_analysis(fixed, sdp)
    assert an2.stable and not [w for w in an2.warnings if "oscillating" in w]
    assert an2.controller.min_damping > an.controller.min_damping
