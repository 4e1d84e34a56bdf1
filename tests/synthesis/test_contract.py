"""One result type: every linear synthesis of the curated namespace (``sd.__all__`` names
``<norm>_<state|output>_feedback[_qr]`` and ``hinf_discrete``) returns a frozen SynthesisResult
whose ``controller`` is one type (DynamicController; a state-feedback gain is the static one).  ``hinfsyn`` keeps
python-control's return value (its ``.result`` is the SynthesisResult) and the mechanical
``*_gains`` design nonlinear laws (SobolevGains), so they are outside this contract."""

import dataclasses
import re
import warnings

import numpy as np
import pytest

import sobolev_drake as sd

A, B, D = [[0.0, 1.0], [-1.0, -0.5]], [[0.0], [1.0]], [[1.0, 0.0], [0.0, 1.0]]
C = [[1.0, 0.0]]
CALLS = {
    "winf_state_feedback": lambda f: f(A, B, D, Gamma0=[1, 1], Gamma1=[0.1, 0.1]),
    "winf_output_feedback": lambda f: f(A, B, C, D, Gamma0=[1, 1], Gamma1=[0.1, 0.1]),
    "hinf_state_feedback_qr": lambda f: f(A, B, D, Q=np.eye(2), R=[[1.0]]),
    "hinf_output_feedback_qr": lambda f: f(A, B, C, D, Q=np.eye(2), R=[[1.0]]),
    "hinf_state_feedback": lambda f: f(sd.hinf_plant(A, B, D=D, Q=np.eye(2), R=[[1.0]])),
    "hinf_output_feedback": lambda f: f(sd.hinf_plant(A, B, C, D, Q=np.eye(2), R=[[1.0]])),
    # the plant sampled at 10 Hz: inputs [w; u], outputs [z; y] (z = [x1; u], y = x1 + 0.1 w1)
    "hinf_discrete": lambda f: f(_sampled_plant(), 1, 1),
}
SYNTHESES = [n for n in sd.__all__
             if re.fullmatch(r"(winf|hinf)_(state|output)_feedback(_qr)?|hinf_discrete", n)]


def _sampled_plant():
    import control
    return control.c2d(control.ss(A, np.hstack([D, B]), [[1, 0], [0, 0], [1, 0]],
                                  [[0, 0, 0], [0, 0, 1], [0.1, 0, 0]]), 0.1)


def test_the_walk_sees_every_linear_synthesis():
    assert sorted(SYNTHESES) == sorted(CALLS)


@pytest.mark.parametrize("name", SYNTHESES)
def test_each_returns_the_one_frozen_result_type(name):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sd.SobolevDrakeWarning)
        res = CALLS[name](getattr(sd, name))
    assert type(res) is sd.SynthesisResult and res.certificate.ok
    assert (res.K is None) == (res.kind == "output_feedback")
    # one controller type, converting to python-control and Drake with the result's dt
    K = res.controller
    assert type(K) is sd.DynamicController and K.dt == res.dt == (0.1 if res.discrete else 0.0)
    if res.K is not None:
        assert K.nk == 0 and np.array_equal(K.DK, res.K)
    ss, drake = K.to_statespace(), K.to_drake()
    assert ss.dt == res.dt and drake.time_period() == res.dt
    np.testing.assert_array_equal(ss.D, K.DK)
    np.testing.assert_array_equal(drake.D(), K.DK)
    with pytest.raises(dataclasses.FrozenInstanceError):
        res.gamma = 0.0
    assert res.replace(gamma=2 * res.gamma).gamma == 2 * res.gamma and res.gamma < 2 * res.gamma


def test_the_readme_example_says_what_was_done_in_one_line_per_call():
    """The README's first synthesis example (the Acrobot upright, W∞ state feedback on the
    feedthrough bound, output feedback with noise-free angles, state feedback in a disk) printed
    five SynthesisWarnings; each call now states what it did in one line."""
    from pydrake.examples import AcrobotPlant
    from pydrake.systems.primitives import Linearize
    acrobot = AcrobotPlant()
    context = acrobot.CreateDefaultContext()
    context.SetContinuousState([np.pi, 0.0, 0.0, 0.0])
    acrobot.get_input_port(0).FixValue(context, [0.0])
    lin = Linearize(acrobot, context)
    weights = dict(Gamma0=np.eye(4), Gamma1=0.1 * np.eye(4))
    calls = [lambda: sd.winf_state_feedback(lin, **weights),
             lambda: sd.winf_output_feedback(lin, C=np.eye(4)[:2], **weights),
             lambda: sd.winf_state_feedback(lin, **weights, region=sd.regions.disk(250.0))]
    for call in calls:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            res = call()
        assert len(caught) == 1 and res.warnings == [str(caught[0].message)]
        assert res.regularized and res.certificate.ok


# The thesis-literal LMI forms return the same type, marked uncertified (method "thesis_lmi",
# no certificate).  (6.31) with a first-order disturbance filter d' = -d + v, w = d: n_d + n_v
# = 2 n_w, so its (d, v) weight is definite and the strict LMI is well posed (the thesis' own
# second-order filter is degenerate, tests/synthesis/test_synthesis_sobolev.py).
def _disturbance_thesis(f):
    return f([[0.0, 50.0], [-50.0, -50.0]], B, B, [[-1.0]], [[1.0]], [[1.0]], [10.0, 10.0],
             [1.0, 1.0], 1.0, 1.0)


THESIS_CALLS = {
    "winf_sf_thesis_lmi": lambda f: f(A, B, D, [1, 1], [0.1, 0.1]),
    "winf_of_thesis_lmi": lambda f: f(A, B, C, D, [1, 1], [0.1, 0.1]),
    "winf_disturbance_thesis": _disturbance_thesis,
}


@pytest.mark.parametrize("name", sorted(THESIS_CALLS))
def test_thesis_literal_forms_return_the_one_type_uncertified(name):
    from sobolev_drake.synthesis import sobolev
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sd.SobolevDrakeWarning)
        res = THESIS_CALLS[name](getattr(sobolev, name))
    assert type(res) is sd.SynthesisResult
    assert res.method == "thesis_lmi" and res.certificate is None and not res.certified
    assert np.isfinite(res.gamma) and res.gamma > 0 and res.warnings
    assert (res.K is None) == (res.kind == "output_feedback")
    with pytest.raises(dataclasses.FrozenInstanceError):
        res.gamma = 0.0


def test_thesis_state_feedback_matches_the_certified_optimum():
    """(6.7) written out and the generalized-plant LMI have the same optimum (both Clarabel,
    relative accuracy ~1e-8 on gamma^2, so 1e-5 on gamma is loose); the certified path's
    result says it is certified, the thesis form's does not."""
    from sobolev_drake.synthesis.sobolev import winf_sf_thesis_lmi
    thesis = winf_sf_thesis_lmi(A, B, D, [1, 1], [0.1, 0.1])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sd.SobolevDrakeWarning)
        ref = sd.winf_state_feedback(A, B, D, Gamma0=[1, 1], Gamma1=[0.1, 0.1], method="lmi",
                                     regularize=False)
    assert ref.certified and not thesis.certified
    assert abs(thesis.gamma - ref.gamma_opt) <= 1e-5 * ref.gamma_opt


def test_an_output_feedback_thesis_result_saves_and_refuses_to_close_a_loop(tmp_path):
    """(6.22) gives gamma only: the design file keeps it (uncertified, no controller) and
    closed_loop says why it cannot close a loop instead of failing on None."""
    from sobolev_drake.synthesis.sobolev import winf_of_thesis_lmi
    res = winf_of_thesis_lmi(A, B, C, D, [1, 1], [0.1, 0.1])
    back = sd.load_result(sd.save_result(res, tmp_path / "thesis.json"))
    assert back.gamma == res.gamma and back.method == "thesis_lmi" and not back.certified
    with pytest.raises(ValueError, match="no controller"):
        back.closed_loop(sd.winf_plant(A, B, C, D, Gamma0=[1, 1], Gamma1=[0.1, 0.1]))


def test_one_vocabulary_for_the_feedback_kind():
    """"state_feedback"/"output_feedback" (SynthesisResult.kind) is the one spelling; the
    older "sf"/"of"/"dyn" and the short "state"/"output" are mapped at the boundaries, and an
    unknown kind is refused naming the argument."""
    from sobolev_drake.synthesis import FEEDBACKS, feedback_kind
    from sobolev_drake.synthesis.designs import FeedbackTable, LinearDesign
    assert [feedback_kind(v) for v in ("sf", "state", "state_feedback")] == [FEEDBACKS[0]] * 3
    assert [feedback_kind(v) for v in ("of", "dyn", "output", "output_feedback")] == [FEEDBACKS[1]] * 4
    for bad in ("lqr", "SF", None, 1):
        with pytest.raises(ValueError, match=r"^kind must be 'state_feedback' or 'output_feedback'"):
            feedback_kind(bad, "kind")
    assert LinearDesign("W∞-O.F.", "winf", "of").feedback == "output_feedback"
    assert LinearDesign("W∞", "winf").feedback == "state_feedback"
    with pytest.raises(ValueError, match="feedback must be"):
        LinearDesign("W∞", "winf", "static")
    table = FeedbackTable(40.0, 150.0)
    assert (table["sf"], table["output_feedback"], "dyn" in table, "lqr" in table) == (40.0, 150.0, True, False)
    with pytest.raises(KeyError, match="key must be"):
        table["lqr"]
    # the result kinds the syntheses return use the same words
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sd.SobolevDrakeWarning)
        assert {CALLS[n](getattr(sd, n)).kind for n in ("winf_state_feedback",
                                                         "winf_output_feedback")} == set(FEEDBACKS)


@pytest.mark.parametrize("name", SYNTHESES)
def test_each_takes_the_one_options_type(name):
    """options= reaches the synthesis (the LMI path in a disk, visible in the result); the
    same knob given again as a keyword must agree, and a conflicting one is refused."""
    disk = sd.regions.disk(60.0)
    opts = sd.SynthesisOptions(method="lmi", region=disk, rtol=1e-3)
    fn = getattr(sd, name)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sd.SobolevDrakeWarning)
        res = CALLS[name](lambda *a, **k: fn(*a, **k, options=opts))
        again = CALLS[name](lambda *a, **k: fn(*a, **k, options=opts, method="lmi"))
    # a discrete result's region is its bilinear image's (the continuous design's)
    designed = res.discrete.continuous if res.discrete else res
    assert res.method == "lmi" and designed.region is disk and res.certificate.ok
    assert designed.certificate.region_ok and again.method == "lmi"
    with pytest.raises(ValueError, match=r"^method='riccati' conflicts with options.method='lmi'"):
        CALLS[name](lambda *a, **k: fn(*a, **k, options=opts, method="riccati"))
    with pytest.raises(TypeError, match="options must be a SynthesisOptions, got dict"):
        CALLS[name](lambda *a, **k: fn(*a, **k, options={"method": "lmi"}))


def test_options_are_validated_when_built():
    with pytest.raises(ValueError, match="method must be one of"):
        sd.SynthesisOptions(method="fast")
    with pytest.raises(ValueError, match="time_limit"):
        sd.SynthesisOptions(time_limit=0.0)
    with pytest.raises(ValueError, match="regularize must be"):
        sd.SynthesisOptions(regularize="yes")
    with pytest.raises(TypeError, match="region must be an LMIRegion"):
        sd.SynthesisOptions(region=50.0)
    with pytest.raises(dataclasses.FrozenInstanceError):
        sd.SynthesisOptions().method = "lmi"


def test_the_controller_follows_k_and_refuses_what_does_not_fit():
    """A state-feedback result's controller is derived from K (a replaced K carries it along);
    a controller whose period differs from its result's, or whose matrices do not fit
    together, is refused naming the argument."""
    res = CALLS["winf_state_feedback"](sd.winf_state_feedback)
    doubled = res.replace(K=2 * res.K)
    np.testing.assert_array_equal(doubled.controller.DK, 2 * res.K)
    np.testing.assert_array_equal(res.controller.DK, res.K)
    # the static controller closes the same loop as K (u = +K x, y = x)
    P = sd.winf_plant(A, B, D=D, Gamma0=[1, 1], Gamma1=[0.1, 0.1])
    np.testing.assert_allclose(P.closed_loop(controller=res.controller)[0],
                               P.closed_loop(K=res.K)[0], rtol=0, atol=0)
    of = CALLS["winf_output_feedback"](sd.winf_output_feedback)
    with pytest.raises(ValueError, match="controller.dt = 0.1 but the result's dt = 0.0"):
        of.replace(controller=sd.DynamicController(*of.controller, dt=0.1))
    with pytest.raises(ValueError, match=r"^BK must have shape \(2, 1\)"):
        sd.DynamicController(np.eye(2), np.ones((2, 2)), np.ones((1, 2)), np.ones((1, 1)))
    with pytest.raises(ValueError, match="dt must be 0"):
        sd.DynamicController.static([[1.0]], dt=-0.1)


def test_plants_and_syntheses_take_python_controls_order():
    """winf_plant / hinf_plant take (A, B, C, D) like the *_output_feedback functions (C was
    last); their weights are keyword-only, so a call written in the former order (A, B, D,
    weights, C) raises instead of building another plant (with D = I and a square C it
    would otherwise read D as C and the weights as D)."""
    import inspect
    for plant_fn, synth in ((sd.winf_plant, sd.winf_output_feedback),
                            (sd.hinf_plant, sd.hinf_output_feedback_qr)):
        head = list(inspect.signature(plant_fn).parameters)[:4]
        assert head == list(inspect.signature(synth).parameters)[:4] == ["A", "B", "C", "D"]
    I2, w = np.eye(2), dict(Gamma0=[1, 1], Gamma1=[0.1, 0.1])
    new = sd.winf_plant(A, B, I2, D, **w)
    assert new.ny == 2 and np.array_equal(new.B1, D)
    former = [lambda: sd.winf_plant(A, B, D, [1, 1], [0.1, 0.1]),
              lambda: sd.winf_plant(A, B, D, [1, 1], [0.1, 0.1], I2),
              lambda: sd.hinf_plant(A, B, D, np.eye(2), [[1.0]], C)]
    for call in former:
        with pytest.raises(TypeError, match="positional argument"):
            call()
    with pytest.raises(TypeError, match=r"^D \(the disturbance matrix .* is required: winf_plant "
                                        r"takes python-control's order \(A, B, C, D\)"):
        sd.winf_plant(A, B, I2, **w)          # the former (A, B, D, Gamma0=, Gamma1=) with D = I
    with pytest.raises(TypeError, match="D .* is required: hinf_plant"):
        sd.hinf_plant(A, B, D, Q=np.eye(2), R=[[1.0]])
    from sobolev_drake.synthesis.sobolev import augmented_disturbance_plant
    with pytest.raises(TypeError, match="positional argument"):   # C is keyword-only there too
        augmented_disturbance_plant(A, B, D, [[-1.0]], [[1.0]], [[1.0], [0.0]], [1, 1], [0, 0], C)
