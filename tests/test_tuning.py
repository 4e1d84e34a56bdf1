"""The one-dimensional tuners: each finds the target of a monotone index, and treats failed
evaluations as the docstring says."""

import numpy as np
import pytest

from sobolev_drake.tuning import bisect_log, match_by_regula_falsi


def test_regula_falsi_finds_target_of_monotone_index():
    for decreasing, f in ((True, lambda w: 5.0 / w ** 1.5), (False, lambda w: 0.3 * w ** 0.7)):
        best, run, hist = match_by_regula_falsi(lambda w: (f(w), {"w": w}), 2.0, 1.0, iters=12,
                                                decreasing=decreasing)
        assert f(best) == pytest.approx(2.0, rel=0.02)
        assert run["w"] == best and len(hist) <= 12


def test_regula_falsi_treats_failed_runs_as_too_large():
    f = lambda w: 1.0 / w  # noqa: E731
    best, _, hist = match_by_regula_falsi(
        lambda w: (f(w), {"failed": "diverged" if w < 0.2 else ""}), 2.0, 0.1, iters=10)
    assert hist[0][1] == np.inf
    assert f(best) == pytest.approx(2.0, rel=0.02)


def test_bisect_log_halves_the_log_bracket():
    # f(p) = log10 p on [1e-2, 1e2], target 0.5: after k midpoints the bracket in log p is
    # 4 ln10 / 2^k wide, so the best midpoint is within that of log p* = 0.5 ln 10
    evaluated = []

    def f(p):
        evaluated.append(p)
        return float(np.log10(p)), "ok"

    p, value, payload = bisect_log(f, 0.5, (1e-2, 1e2), iters=20)
    assert payload == "ok" and evaluated[0] == pytest.approx(1.0)
    assert abs(np.log(p) - 0.5 * np.log(10)) <= 4 * np.log(10) / 2 ** 19
    assert 1e-2 < min(evaluated) and max(evaluated) < 1e2       # the ends are never evaluated


def test_bisect_log_decreasing_index_and_failures():
    # decreasing index; evaluations below p = 0.5 fail (payload None) and count as too large
    def f(p):
        return (np.inf, None) if p < 0.5 else (1.0 / p, p)

    p, value, payload = bisect_log(f, 0.25, (0.01, 100.0), iters=30, increasing=False)
    assert payload == p and value == pytest.approx(0.25, rel=1e-6)
    with pytest.raises(RuntimeError, match="no evaluation"):
        bisect_log(lambda p: (np.inf, None), 1.0, (0.1, 10.0), iters=3)
