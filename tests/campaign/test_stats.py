"""sobolev_drake.campaign.stats: Wilson and bootstrap intervals checked against closed forms,
published values and simulation; summaries of synthetic campaigns whose answers are known."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.stats import binom

from sobolev_drake.campaign import stats
from sobolev_drake.campaign.stats import (bootstrap_interval, plot_cdfs, plot_distributions,
                                          summarize, summary_tables, wilson_interval)
from sobolev_drake.report import fmt

Z95 = 1.959963984540054          # standard normal 0.975 quantile (not taken from the module)


def wilson_by_quadratic(k, n, z):
    """The Wilson interval from its definition: the p with |k/n - p| = z sqrt(p(1-p)/n), i.e.
    the roots of (1 + z²/n) p² - (2k/n + z²/n) p + (k/n)² = 0 (independent of the module's
    centre ± half-width form)."""
    ph = k / n
    roots = np.sort(np.roots([1 + z * z / n, -(2 * ph + z * z / n), ph * ph]).real)
    return roots[0], roots[1]


def record(design, seed, success=True, failure="", **indices):
    return {"key": f"{design}/{seed}", "campaign": "test", "design": design, "seed": seed,
            "perturb_values": {}, "indices": indices, "success": success, "failure": failure,
            "wall_s": 0.1}


# --------------------------------------------------------------------------- Wilson

@pytest.mark.parametrize("k, n", [(0, 10), (10, 10), (5, 10), (3, 17), (39, 40), (1, 2)])
def test_wilson_matches_the_roots_of_its_defining_quadratic(k, n):
    # both forms are exact algebra; 1e-12 leaves room for np.roots' rounding only
    low, high = wilson_interval(k, n)
    exp_low, exp_high = wilson_by_quadratic(k, n, Z95)
    assert low == pytest.approx(max(exp_low, 0.0), abs=1e-12)
    assert high == pytest.approx(min(exp_high, 1.0), abs=1e-12)


def test_wilson_published_values_and_exact_endpoints():
    # Newcombe (1998), Stat. Med. 17:857, Table I (method 3, Wilson): 0/10 -> 0 to 0.2775 and
    # 5/10 -> 0.2366 to 0.7634, printed to 4 decimals, hence the 5e-5 tolerance
    assert wilson_interval(0, 10) == (0.0, pytest.approx(0.2775, abs=5e-5))
    assert wilson_interval(5, 10) == (pytest.approx(0.2366, abs=5e-5),
                                      pytest.approx(0.7634, abs=5e-5))
    # 0/n: upper end z²/(n + z²) in closed form; n/n mirrors it and ends exactly at 1
    assert wilson_interval(0, 10)[1] == pytest.approx(Z95 ** 2 / (10 + Z95 ** 2), rel=1e-12)
    low, high = wilson_interval(10, 10)
    assert high == 1.0 and low == pytest.approx(1 - Z95 ** 2 / (10 + Z95 ** 2), rel=1e-12)
    assert wilson_interval(0, 10)[0] == 0.0
    assert wilson_interval(0, 0) == (0.0, 1.0)
    # a lower confidence narrows it: at 90 % z = 1.6448536 (roots again)
    low90, high90 = wilson_interval(5, 10, confidence=0.90)
    assert (low90, high90) == pytest.approx(wilson_by_quadratic(5, 10, 1.6448536269514722),
                                            abs=1e-12)
    assert 0.2366 < low90 and high90 < 0.7634


def test_wilson_accepts_half_successes_between_the_integer_neighbours():
    # a paired comparison passes wins + ties/2; the interval moves monotonically in successes
    assert wilson_interval(5, 10)[0] < wilson_interval(5.5, 10)[0] < wilson_interval(6, 10)[0]
    assert wilson_interval(5.5, 10) == pytest.approx(wilson_by_quadratic(5.5, 10, Z95), abs=1e-12)


def test_wilson_coverage_at_p_0_3_n_40():
    p, n, draws = 0.3, 40, 2000
    covers = {k: wilson_interval(k, n)[0] <= p <= wilson_interval(k, n)[1] for k in range(n + 1)}
    # exact coverage = sum of the binomial pmf over the k whose interval holds p (0.9443 here;
    # Wilson's coverage oscillates around the nominal 0.95 with k's discreteness)
    exact = sum(binom.pmf(k, n, p) for k, c in covers.items() if c)
    assert exact >= 0.93
    # simulated: 2000 draws with a fixed seed; the empirical share has standard error
    # sqrt(0.944 * 0.056 / 2000) = 0.0051, so 0.93 is ~2.8 SE below the exact coverage and
    # the simulation must agree with the exact value within 4 SE = 0.021
    ks = np.random.default_rng(20240501).binomial(n, p, draws)
    empirical = np.mean([covers[k] for k in ks])
    assert empirical >= 0.93
    assert abs(empirical - exact) < 4 * math.sqrt(exact * (1 - exact) / draws)


@pytest.mark.parametrize("args, name", [((-1, 10), "successes"), ((11, 10), "successes"),
                                        ((1, -1), "n"), ((1, 2.5), "n"), ((True, 3), "successes"),
                                        ((float("nan"), 3), "successes"), ((1, 10, 0.0), "confidence"),
                                        ((1, 10, 1.0), "confidence"), ((1, 10, 95), "confidence")])
def test_wilson_rejects_bad_input_naming_the_argument(args, name):
    with pytest.raises(ValueError, match=name):
        wilson_interval(*args)


# --------------------------------------------------------------------------- bootstrap

def test_bootstrap_median_of_a_normal_sample():
    n, sigma = 400, 2.0
    x = np.random.default_rng(2024).normal(0.0, sigma, n)
    low, high = bootstrap_interval(x, np.median)
    # the true median is 0; a 95 % interval misses it on ~1 sample in 20 (seed 7 is one such),
    # hence the fixed sample here and the coverage count below
    assert low < 0.0 < high
    # asymptotically the sample median is normal with sd sqrt(pi/2) sigma / sqrt(n)
    expected = 2 * Z95 * math.sqrt(math.pi / 2) * sigma / math.sqrt(n)
    # 25 %: the bootstrap estimate of a median's spread converges slowly (relative error of
    # order n^(-1/4) ~ 0.22 at n = 400, Hall & Martin 1988) and the 2.5/97.5 % quantiles of
    # 2000 resamples add a few %; over 300 seeds the width/expected ratio had mean 1.00 and
    # sd 0.14, so 25 % is ~1.8 sd (this seed gives a ratio near 1)
    assert (high - low) == pytest.approx(expected, rel=0.25)
    # coverage over 100 fresh samples (1000 resamples each): the count of hits is binomial
    # with sd sqrt(100 * 0.95 * 0.05) = 2.2 if the coverage is nominal, so >= 88 allows 3 sd
    hits = 0
    for k in range(100):
        y = np.random.default_rng(1000 + k).normal(0.0, sigma, n)
        lo, hi = bootstrap_interval(y, np.median, resamples=1000, seed=k)
        hits += lo < 0.0 < hi
    assert hits >= 88


def _hand_written_percentile_bootstrap(x, resamples, seed, confidence=0.95):
    """The interval the package computed before it used scipy.stats.bootstrap: one index matrix
    from default_rng(seed), the median of each row, linear-interpolated quantiles."""
    rng = np.random.default_rng(seed)
    medians = np.median(x[rng.integers(0, x.size, (resamples, x.size))], axis=1)
    return tuple(np.quantile(medians, [(1 - confidence) / 2, (1 + confidence) / 2]))


def test_bootstrap_is_the_hand_written_interval_it_replaced():
    # scipy draws the same indices from the same Generator (rows in batch order); the quantile
    # interpolation differs only in rounding: 1e-12 relative is ~1e4 ulps, far below any
    # difference in the resampling (which would move the bounds by a sample spacing)
    for k in range(10):
        x = np.random.default_rng(k).lognormal(size=5 + 37 * k)
        expected = _hand_written_percentile_bootstrap(x, 700, seed=k)
        assert bootstrap_interval(x, np.median, resamples=700, seed=k) == \
            pytest.approx(expected, rel=1e-12)


def test_bootstrap_is_deterministic_and_drops_non_finite_values():
    x = np.random.default_rng(1).lognormal(size=50)
    first = bootstrap_interval(x, np.median, seed=3)
    assert bootstrap_interval(x, np.median, seed=3) == first
    assert bootstrap_interval(x, np.median, seed=4) != first
    with_bad = np.concatenate([x, [np.nan, np.inf, -np.inf]])
    assert bootstrap_interval(with_bad, np.median, seed=3) == first
    low, high = first
    assert x.min() <= low <= np.median(x) <= high <= x.max()


def test_bootstrap_loop_path_and_chunking_give_the_vectorized_result(monkeypatch):
    # a callable without ``axis`` is applied row by row to the same index matrix
    x = np.random.default_rng(2).normal(size=301)
    vectorized = bootstrap_interval(x, np.median, resamples=500)
    assert bootstrap_interval(x, lambda v: float(np.median(v)), resamples=500) == vectorized
    # memory chunks of 3 rows draw the same indices (numpy's Generator fills sequentially)
    monkeypatch.setattr(stats, "_CHUNK", 3 * x.size)
    assert bootstrap_interval(x, np.median, resamples=500) == vectorized


def test_bootstrap_needs_two_finite_values_and_valid_arguments():
    assert all(math.isnan(v) for v in bootstrap_interval([1.0, np.nan], np.median))
    assert all(math.isnan(v) for v in bootstrap_interval([], np.median))
    assert bootstrap_interval([2.0, 2.0, 2.0], np.mean) == (2.0, 2.0)
    for kwargs, name in [({"confidence": 1.0}, "confidence"), ({"resamples": 0}, "resamples"),
                         ({"resamples": 1.5}, "resamples")]:
        with pytest.raises(ValueError, match=name):
            bootstrap_interval([1.0, 2.0], np.median, **kwargs)
    with pytest.raises(ValueError, match="statistic"):
        bootstrap_interval([1.0, 2.0], "median")
    with pytest.raises(ValueError, match="values"):
        bootstrap_interval(np.ones((3, 2)), np.median)


# --------------------------------------------------------------------------- summarize

def campaign(n=20):
    """B: log-normal indices; A = 0.8 B on every seed; A fails on seed 0 (finite but absurd
    index 1e-9, which must be ignored) and on seed 1 (no indices)."""
    rng = np.random.default_rng(11)
    records = []
    for seed in range(n):
        b = float(rng.lognormal())
        records.append(record("B", seed, ise=b, iadu=1.0))
        if seed == 0:
            records.append(record("A", seed, success=False, failure="diverged", ise=1e-9))
        elif seed == 1:
            records.append(record("A", seed, success=False, failure="timeout"))
        else:
            records.append(record("A", seed, ise=0.8 * b, iadu=1.0))
    return records


def comparison(summary, a, b, index):
    (c,) = [c for c in summary["comparisons"] if (c["a"], c["b"], c["index"]) == (a, b, index)]
    return c


def test_a_uniformly_better_design_wins_every_paired_seed():
    summary = summarize(campaign(), resamples=500)
    assert summary["designs"] == ["B", "A"] and summary["indices"] == ["ise", "iadu"]
    c = comparison(summary, "A", "B", "ise")
    assert c["n_paired"] == 18 and c["wins"] == 18 and c["share_a_better"] == 1.0
    assert c["share_interval"] == pytest.approx(list(wilson_interval(18, 18)), abs=0)
    # 0.8 b / b is 0.8 up to one rounding of the product and one of the quotient (~2e-16)
    assert c["median_ratio"] == pytest.approx(0.8, rel=1e-12)
    assert c["ratio_interval"] == pytest.approx([0.8, 0.8], rel=1e-12)
    back = comparison(summary, "B", "A", "ise")
    assert back["share_a_better"] == 0.0 and back["losses"] == 18
    assert back["median_ratio"] == pytest.approx(1.25, rel=1e-12)


def test_ties_count_half():
    summary = summarize(campaign(), resamples=200)
    c = comparison(summary, "A", "B", "iadu")              # equal (1.0) on every paired seed
    assert (c["wins"], c["ties"], c["losses"]) == (0, 18, 0)
    assert c["share_a_better"] == 0.5
    assert c["share_interval"] == pytest.approx(list(wilson_interval(9, 18)), abs=0)
    # 6 wins, 2 ties, 2 losses over 10 seeds: (6 + 1) / 10, Wilson on 7 of 10
    records = [record("X", s, j=v) for s, v in enumerate([1, 1, 1, 1, 1, 1, 2, 2, 5, 5])]
    records += [record("Y", s, j=3 if s < 6 else 2 if s < 8 else 4) for s in range(10)]
    c = comparison(summarize(records, resamples=200), "X", "Y", "j")
    assert (c["wins"], c["ties"], c["losses"], c["share_a_better"]) == (6, 2, 2, 0.7)
    assert c["share_interval"] == pytest.approx(list(wilson_interval(7, 10)), abs=0)


def test_failed_cases_count_in_the_success_rate_only():
    records = campaign()
    summary = summarize(records, resamples=500)
    a = summary["per_design"]["A"]
    assert (a["n"], a["successes"]) == (20, 18) and a["success_rate"] == 0.9
    assert a["success_interval"] == pytest.approx(list(wilson_interval(18, 20)), abs=0)
    assert a["failures"] == {"diverged": 1, "timeout": 1}
    ise = a["indices"]["ise"]
    ok = [r["indices"]["ise"] for r in records if r["design"] == "A" and r["success"]]
    assert ise["n_finite"] == 18 and min(ok) > 1e-3              # the 1e-9 is not in
    assert ise["median"] == pytest.approx(np.median(ok), rel=1e-15)
    assert ise["q1"] == pytest.approx(np.quantile(ok, 0.25), rel=1e-15)
    assert ise["iqr"] == pytest.approx(np.quantile(ok, 0.75) - np.quantile(ok, 0.25), rel=1e-12)
    assert ise["mean"] == pytest.approx(np.mean(ok), rel=1e-12)
    assert ise["median_interval"] == pytest.approx(
        list(bootstrap_interval(ok, np.median, resamples=500, seed=0)), abs=0)
    b = summary["per_design"]["B"]
    assert b["success_rate"] == 1.0 and b["success_interval"][1] == 1.0
    assert b["indices"]["ise"]["n_finite"] == 20


def test_defaults_options_and_json():
    records = campaign(6) + [record("C", 0, success=False, failure="x", only_failed=1.0)]
    summary = summarize(records, resamples=100)
    assert summary["designs"] == ["B", "A", "C"]                   # first appearance
    assert "only_failed" not in summary["indices"]                 # successful records only
    c = summary["per_design"]["C"]["indices"]["ise"]
    assert c["n_finite"] == 0 and c["median"] is None and c["median_interval"] == [None, None]
    assert comparison(summary, "C", "B", "ise")["n_paired"] == 0
    assert comparison(summary, "C", "B", "ise")["share_interval"] == [0.0, 1.0]
    json.dumps(summary, allow_nan=False)                           # no NaN/inf anywhere
    pairs = {(c["a"], c["b"]) for c in summary["comparisons"]}
    assert len(pairs) == 6 and len(summary["comparisons"]) == 6 * 2
    base = summarize(records, baseline="B", designs=["A", "B", "D"], indices=["ise"],
                     resamples=100)
    assert base["designs"] == ["A", "B", "D"] and base["indices"] == ["ise"]
    assert [(c["a"], c["b"]) for c in base["comparisons"]] == [("A", "B"), ("D", "B")]
    d = base["per_design"]["D"]
    assert d["n"] == 0 and d["success_rate"] is None and d["success_interval"] == [0.0, 1.0]
    # same seed -> same numbers
    assert summarize(records, resamples=100) == summary


def test_duplicate_cases_and_bad_arguments_are_rejected():
    records = campaign(4)
    with pytest.raises(ValueError, match="appears twice"):
        summarize(records + [record("A", 3, ise=1.0)])
    bad = [({"confidence": 1.5}, "confidence"), ({"resamples": 0}, "resamples"),
           ({"seed": -1}, "seed"), ({"seed": 1.5}, "seed"), ({"baseline": "Z"}, "baseline"),
           ({"designs": "AB"}, "designs"), ({"designs": ["A", "A"]}, "designs"),
           ({"indices": [1]}, "indices"), ({"indices": "ise"}, "indices")]
    for kwargs, name in bad:
        with pytest.raises(ValueError, match=name):
            summarize(records, **kwargs)
    with pytest.raises(ValueError, match="records"):
        summarize({"design": "A"})
    with pytest.raises(ValueError, match=r"records\[1\]"):
        summarize([record("A", 0), {"design": "A", "success": True}])


# --------------------------------------------------------------------------- tables, plots

def test_tables_show_the_numbers():
    summary = summarize(campaign(), resamples=300)
    markdown, rows = summary_tables(summary)
    assert "95 % intervals" in markdown and "#### ise" in markdown and "#### iadu" in markdown
    a = summary["per_design"]["A"]
    lo, hi = a["success_interval"]
    rate = f"0.9 [{fmt(lo)}, {fmt(hi)}] (18/20)"
    med = a["indices"]["ise"]
    median = (f"{fmt(med['median'])} [{fmt(med['median_interval'][0])}, "
              f"{fmt(med['median_interval'][1])}]")
    assert rows["indices"]["ise"]["rows"][1] == ["A", rate, "18", median, fmt(med["iqr"])]
    assert f"| A | {rate} | 18 | {median} | {fmt(med['iqr'])} |" in markdown
    # 4 significant digits: Wilson(18, 20) is [0.69897, 0.97213] -> "0.699" (trailing 0 dropped)
    assert (fmt(lo), fmt(hi)) == ("0.699", "0.9721")
    comp = rows["comparisons"]
    assert comp["columns"][3] == "share A better"
    row = comp["rows"][[tuple(r[:3]) for r in comp["rows"]].index(("A", "B", "ise"))]
    assert row[3] == f"1 [{fmt(wilson_interval(18, 18)[0])}, 1]"
    assert row[4] == "18" and row[5] == "0.8 [0.8, 0.8]"
    assert "| A | B | ise | " + row[3] + " | 18 | 0.8 [0.8, 0.8] |" in markdown
    # after a JSON round trip too
    assert summary_tables(json.loads(json.dumps(summary)))[0] == markdown


def _capture_scales(monkeypatch):
    """Replace save_figure to record each axis' (x scale, y scale) before the real save."""
    seen, real = [], stats.save_figure

    def save(fig, path):
        seen.append([(ax.get_xscale(), ax.get_yscale()) for ax in fig.axes if ax.get_visible()])
        return real(fig, path)

    monkeypatch.setattr(stats, "save_figure", save)
    return seen


def test_plots_write_pngs_with_log_axes_for_wide_ranges(tmp_path, monkeypatch):
    records = campaign()
    for r in records:                      # "wide" spans 1e-3 .. 1e3 (> 100x): log axis
        r["indices"]["wide"] = 10.0 ** (r["seed"] % 7 - 3)
    records.append(record("E", 0, success=False, failure="x"))     # no values at all
    summary = summarize(records, resamples=100)
    seen = _capture_scales(monkeypatch)
    box = plot_distributions(records, summary, tmp_path / "box.png")
    cdf = plot_cdfs(records, summary, tmp_path / "sub" / "cdf.png")
    for path in (box, cdf):
        assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and path.stat().st_size > 5000
    assert summary["indices"] == ["ise", "iadu", "wide"]
    # ise spans exp(N(0,1)) over 20 seeds (< 100x here), iadu is constant: linear
    assert seen[0] == [("linear", "linear"), ("linear", "linear"), ("linear", "log")]
    assert seen[1] == [("linear", "linear"), ("linear", "linear"), ("log", "linear")]
