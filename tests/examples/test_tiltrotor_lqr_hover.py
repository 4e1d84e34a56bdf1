"""The tilt-rotor example of diagrams/: Drake's ``LinearQuadraticRegulator(system, context,
Q, R)`` on the library's plant diagram (MultibodyPlant + TiltrotorForces) at the hover trim,
beside the library's W∞ hover design, both flown on the nonlinear plant."""

import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest

import sobolev_drake as sd

SCRIPT = Path(__file__).resolve().parents[2] / "diagrams" / "tiltrotor_lqr_hover.py"


@pytest.fixture(scope="module")
def example():
    spec = importlib.util.spec_from_file_location("tiltrotor_lqr_hover", SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_drake_lqr_and_the_winf_design_hold_the_hover(example, tmp_path):
    result = example.run(duration=3.0, out_dir=tmp_path)
    # Drake's gain stabilizes Drake's linearization of the same diagram (measured max real
    # part −0.35), and the W∞ design is certified on its own linearization
    assert result["lqr"]["eigenvalues"].real.max() < 0
    assert type(result["winf"]) is sd.SynthesisResult and result["winf"].certified
    html = Path(result["recording"]).read_text(encoding="utf-8")
    assert len(html) > 10_000 and sd.recording_html.external_script_sources(html) == []
    assert Path(result["plot"]).stat().st_size > 10_000
    start = float(np.linalg.norm(example.OFFSET[5:8]))
    for name, row in result["rows"].items():
        assert all(math.isfinite(v) for v in row.values()), (name, row)
        # both fly: the position error shrinks (measured at 3 s: 0.02 m LQR, 0.28 m W∞, from
        # 0.77 m) and the attitude stays far from the 90° at which a flight is lost
        # (measured 10° and 15°)
        assert row["final ‖e‖ [m]"] < start and row["max ‖e‖ [m]"] < 1.5 * start, (name, row)
        assert row["max |φ|,|θ| [°]"] < 45.0, (name, row)
