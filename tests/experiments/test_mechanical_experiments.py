"""Smoke runs of the chapter-5 mechanical experiments (manipulator, quadrotor-attitude) and the
shared tuning harness."""

import json

import numpy as np
import pytest

from sobolev_drake.experiments import get
from sobolev_drake.experiments._mechanical_common import hinf_surface, tune
from sobolev_drake.synthesis.mechanical import controlled_gains


def test_hinf_surface_matches_slow_factor_of_w_design():
    g = controlled_gains([100], [500], [40], [0.072])
    w1, w2, w3 = hinf_surface(g)
    q, k, t = (g.blocks[n][0, 0] for n in "QKT")
    s = np.sqrt(w2 ** 2 + 2 * w1 * w3)
    assert s / w1 == pytest.approx(k / q) and w3 / w1 == pytest.approx(t / q)


def test_tune_finds_target_of_monotone_index():
    for decreasing, f in ((True, lambda w: 5.0 / w ** 1.5), (False, lambda w: 0.3 * w ** 0.7)):
        best, run, hist = tune(lambda w: (f(w), {"w": w}), 2.0, 1.0, iters=12, decreasing=decreasing)
        assert f(best) == pytest.approx(2.0, rel=0.02)
        assert run["w"] == best and len(hist) <= 12


def test_tune_treats_failed_runs_as_too_large():
    f = lambda w: 1.0 / w  # noqa: E731
    best, _, hist = tune(lambda w: (f(w), {"failed": "diverged" if w < 0.2 else ""}), 2.0, 0.1,
                         iters=10)
    assert hist[0][1] == np.inf
    assert f(best) == pytest.approx(2.0, rel=0.02)


@pytest.mark.parametrize("name", ["manipulator", "quadrotor-attitude"])
def test_experiment_smoke(name, tmp_path):
    exp = get(name)
    res = exp.run(tmp_path, duration=None, record=False, smoke=True)
    assert res.name == name
    assert res.table_markdown.count("thesis") == 2
    data = json.loads((tmp_path / f"{name.replace('-', '_')}.json").read_text())
    assert len(data["rows"]) == 2
    for ctrl in ("W2/W∞", "H∞"):
        m = res.metrics[ctrl]
        assert all(np.isfinite(v) and v >= 0 for v in m.values())
    assert not any("simulation completed" in c.text for c in res.claims)
    png = [p for p in res.outputs.values() if str(p).endswith(".png")]
    assert png and all(p.stat().st_size > 1000 for p in png)
    if name == "manipulator":  # Theorem 3 on the exact-model W run
        assert res.metrics["theorem3"]["holds"]
