"""Smoke runs of the chapter-5 mechanical experiments (manipulator, quadrotor-attitude)."""

import json

import numpy as np
import pytest

from sobolev_drake.experiments import get


@pytest.mark.parametrize("name", ["manipulator", "quadrotor-attitude"])
def test_experiment_smoke(name, tmp_path):
    exp = get(name)
    res = exp.run(tmp_path, duration=None, record=False, smoke=True)
    assert res.name == name
    assert res.table_markdown.count("| thesis |") == 2
    data = json.loads((tmp_path / f"{name.replace('-', '_')}.json").read_text())
    # the physical rows and those of the readings of the thesis' rows (both designs in each)
    assert len(data["rows"]) == (4 if name == "manipulator" else 5)
    for ctrl in ("W2/W∞", "H∞"):
        m = res.metrics[ctrl]
        assert all(np.isfinite(v) and v >= 0 for v in m.values())
    assert not any("simulation completed" in c.text for c in res.claims)
    png = [p for p in res.outputs.values() if str(p).endswith(".png")]
    assert png and all(p.stat().st_size > 1000 for p in png)
    if name == "manipulator":  # Theorem 3 on the exact-model W run
        assert res.metrics["theorem3"]["holds"]
