"""The Acrobot example of diagrams/: Drake's Acrobot, linearized upright, balanced on the
nonlinear plant by the default W∞ output-feedback call measuring only the two angles."""

import importlib.util
from pathlib import Path

import numpy as np
import pytest

SCRIPT = Path(__file__).resolve().parents[2] / "diagrams" / "acrobot_upright.py"


@pytest.fixture(scope="module")
def example():
    spec = importlib.util.spec_from_file_location("acrobot_upright", SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_default_output_feedback_balances_the_acrobot(example, tmp_path):
    result = example.run(duration=15.0, out_dir=tmp_path)
    res, rows, notes = result["synthesis"], result["rows"], result["notes"]
    # the singular problem (angles measured without noise) is regularized, and says so
    assert res.method == "riccati" and res.regularized and res.certificate.ok
    assert any("singular problem" in n for n in notes)
    # bounded controller: the LMI optimum's controller had a feedthrough of 953 and
    # unstable poles at +78.6 +- 680j; this one is strictly proper with stable poles
    assert np.linalg.eigvals(res.controller.AK).real.max() < 0
    winf = rows["W∞ output feedback (angles)"]
    # flies: the excursion stays far from falling (pi/2) and the error has decayed at 15 s
    # (slowest closed-loop pole -1/s; measured max 0.85 rad, 3e-5 rad at 15 s)
    assert winf["max error [rad]"] < 1.2
    assert winf["final error [rad]"] < 1e-2
    assert rows["Drake LQR (full state)"]["final error [rad]"] < 1e-6
