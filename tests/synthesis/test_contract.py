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
