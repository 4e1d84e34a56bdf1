"""One result type: every linear synthesis of the curated namespace (``sd.__all__`` names
``<norm>_<state|output>_feedback[_qr]``) returns a frozen SynthesisResult.  ``hinfsyn`` keeps
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
    "hinf_state_feedback": lambda f: f(sd.hinf_plant(A, B, D, np.eye(2), [[1.0]])),
    "hinf_output_feedback": lambda f: f(sd.hinf_plant(A, B, D, np.eye(2), [[1.0]], C)),
}
SYNTHESES = [n for n in sd.__all__ if re.fullmatch(r"(winf|hinf)_(state|output)_feedback(_qr)?", n)]


def test_the_walk_sees_every_linear_synthesis():
    assert sorted(SYNTHESES) == sorted(CALLS)


@pytest.mark.parametrize("name", SYNTHESES)
def test_each_returns_the_one_frozen_result_type(name):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sd.SobolevDrakeWarning)
        res = CALLS[name](getattr(sd, name))
    assert type(res) is sd.SynthesisResult and res.certificate.ok
    assert (res.K is None) == (res.kind == "output_feedback")
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
