"""Statistics of a Monte-Carlo campaign: success rates, index distributions and paired design
comparisons, as JSON, markdown tables and figures.

A campaign flies several designs over the same seeds (a seed fixes one disturbance realization
and parameter draw, the same for every design).  A case is a record dict with "design",
"seed", "success" and "indices" ({name: value}, lower is better).  Why these statistics:

* **Paired comparisons.**  The seed-to-seed spread (a gust hard for every design) usually
  dwarfs the difference between designs, so designs are compared seed by seed: the share of
  seeds on which A's index is below B's and the median of the ratio A/B over the seeds.
* **Wilson score intervals for proportions** (success rates, shares of wins).  n is small and
  good designs succeed almost always (p near 0 or 1), where the normal (Wald) interval
  collapses to zero width and undercovers; Wilson's stays in [0, 1] near nominal coverage.
* **Percentile bootstrap for medians and median ratios** (:func:`scipy.stats.bootstrap`).
  Indices are skewed and heavy-tailed (one near-failure dominates a mean), so medians are
  reported; their sampling distribution has no closed form for an unknown density, the
  (seeded, reproducible) bootstrap needs none.

Failed cases count in the success rate only, not in any index statistic or paired comparison.
"""

from __future__ import annotations

import math
import os
from collections import Counter
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure
from numpy.typing import ArrayLike
from scipy.stats import bootstrap, norm

from sobolev_drake.plots import save_figure
from sobolev_drake.report import fmt, markdown_table

__all__ = ["wilson_interval", "bootstrap_interval", "summarize", "summary_tables",
           "plot_distributions", "plot_cdfs"]

_CHUNK = 4_000_000            # resampled values drawn at once by bootstrap_interval (32 MB)


def _number(value, name, low=0, high=math.inf, *, integer=False, closed=True):
    """``value`` if a real number in [low, high] (open unless ``closed``; an int if ``integer``)."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.number)) or not \
            math.isfinite(value) or not low <= value <= high or (integer and value != int(value)) \
            or (not closed and value in (low, high)):
        kind, (a, b) = "an integer" if integer else "a number", "[]" if closed else "()"
        raise ValueError(f"{name} must be {kind} in {a}{low}, {high}{b}, got {value!r}")
    return int(value) if integer else float(value)


def wilson_interval(successes: float, n: int, confidence: float = 0.95) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion: with p = successes / n and z the
    two-sided normal quantile, ``(p + z²/2n ± z sqrt(p(1-p)/n + z²/4n²)) / (1 + z²/n)``.

    Parameters
    ----------
    successes : float
        Number of successes, 0 ≤ successes ≤ n; need not be an integer (a paired comparison
        passes wins + ties / 2).
    n : int
        Number of trials, ≥ 0.
    confidence : float, default 0.95
        Coverage probability, in (0, 1).

    Returns
    -------
    tuple of float
        (low, high) in [0, 1]; low is exactly 0 when successes = 0, high exactly 1 when
        successes = n; (0.0, 1.0) when n = 0.
    """
    confidence = _number(confidence, "confidence", 0, 1, closed=False)
    n = _number(n, "n", integer=True)
    successes = _number(successes, "successes", 0, n)
    if n == 0:
        return 0.0, 1.0
    z, p = float(norm.ppf(0.5 + confidence / 2)), successes / n
    denom = 1.0 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    low = 0.0 if successes == 0 else max(0.0, centre - half)
    return low, 1.0 if successes == n else min(1.0, centre + half)


def bootstrap_interval(values: ArrayLike, statistic: Callable[..., Any], *, confidence: float = 0.95,
                       resamples: int = 2000, seed: int = 0) -> tuple[float, float]:
    """Percentile bootstrap interval: the (1 ∓ confidence)/2 quantiles of ``statistic`` over
    ``resamples`` resamples (with replacement) of the finite values, by
    :func:`scipy.stats.bootstrap` (``method="percentile"``).

    Parameters
    ----------
    values : array_like
        1-D sample; NaN and infinite entries are dropped.
    statistic : callable
        ``statistic(x) -> float`` for a 1-D array ``x``; when it takes ``axis`` (``np.median``,
        ``np.mean``) all resamples of a batch are reduced in one vectorized call.
    confidence : float, default 0.95
        Coverage probability, in (0, 1).
    resamples : int, default 2000
        Number of bootstrap resamples, ≥ 1.
    seed : int, default 0
        Seed of ``np.random.default_rng``; the interval is a deterministic function of the inputs.

    Returns
    -------
    tuple of float
        (low, high); (nan, nan) when fewer than 2 entries are finite.  Resamples whose
        statistic is not finite are left out of the quantiles.

    Examples
    --------
    >>> import numpy as np
    >>> x = np.random.default_rng(1).normal(size=200)
    >>> low, high = bootstrap_interval(x, np.median, seed=3)
    >>> bool(low < np.median(x) < high)
    True
    """
    confidence = _number(confidence, "confidence", 0, 1, closed=False)
    resamples = _number(resamples, "resamples", 1, integer=True)
    if not callable(statistic):
        raise ValueError(f"statistic must be callable, got {statistic!r}")
    x = np.asarray(values, dtype=float)
    if x.ndim > 1:
        raise ValueError(f"values must be 1-D, got shape {x.shape}")
    x = x[np.isfinite(x)]
    if x.size < 2:
        return math.nan, math.nan
    res = bootstrap((x,), statistic, n_resamples=int(resamples), batch=max(1, _CHUNK // x.size),
                    confidence_level=confidence, method="percentile",
                    rng=np.random.default_rng(seed), vectorized=_takes_axis(statistic))
    low, high = res.confidence_interval
    if not (math.isfinite(low) and math.isfinite(high)):      # some resamples' statistic is NaN
        stats = res.bootstrap_distribution[np.isfinite(res.bootstrap_distribution)]
        if stats.size == 0:
            return math.nan, math.nan
        low, high = np.quantile(stats, [(1 - confidence) / 2, (1 + confidence) / 2])
    return float(low), float(high)


def _takes_axis(statistic) -> bool:
    """Whether ``statistic(samples, axis=-1)`` reduces each row (``np.median``, ``np.mean``)."""
    probe = np.arange(6.0).reshape(2, 3)
    try:
        return np.shape(statistic(probe, axis=-1)) == (2,)
    except TypeError:
        return False


def _num(x):
    """JSON-safe float (a tuple -> list): None for NaN/inf, so ``allow_nan=False`` works."""
    return [_num(v) for v in x] if isinstance(x, tuple) else \
        float(x) if x is not None and math.isfinite(x) else None


def _names(value, what):
    names = list(value) if isinstance(value, Iterable) and not isinstance(value, str) else [1]
    if not all(isinstance(v, str) for v in names) or len(set(names)) < len(names):
        raise ValueError(f"{what} must be a sequence of distinct names (str), got {value!r}")
    return names


def _cases(records):
    """{design: {seed: record}}, designs in first-seen order and seeds sorted; checks keys and
    duplicates."""
    if isinstance(records, (str, bytes, Mapping)) or not isinstance(records, Iterable):
        raise ValueError(f"records must be a sequence of dicts, got {type(records).__name__}")
    cases = {}
    for i, r in enumerate(records):
        if not isinstance(r, Mapping) or not {"design", "seed", "success"} <= r.keys():
            raise ValueError(f"records[{i}] must be a dict with 'design', 'seed', 'success'")
        seeds = cases.setdefault(r["design"], {})
        if r["seed"] in seeds:
            raise ValueError(f"records: design {r['design']!r} seed {r['seed']!r} appears twice "
                             f"(keys {seeds[r['seed']].get('key')!r} and {r.get('key')!r})")
        seeds[r["seed"]] = r
    # every statistic is taken over seeds in seed order, never arrival order: sums (means)
    # round the same whichever executor finished the cases first
    return {d: dict(sorted(seeds.items(), key=lambda kv: _seed_order(kv[0]))) for d, seeds in cases.items()}


def _seed_order(seed):
    return (0, seed, "") if isinstance(seed, (int, np.integer)) else (1, 0, repr(seed))


def _successful(seeds, name):
    """{seed: index value} of the successful cases with a finite value of index ``name``."""
    out = {seed: (r.get("indices") or {}).get(name) for seed, r in seeds.items() if r["success"]}
    return {seed: float(v) for seed, v in out.items()
            if isinstance(v, (int, float, np.number)) and math.isfinite(v)}


def _distribution(values, boot):
    v = np.asarray(values, dtype=float)
    q1, med, q3 = np.quantile(v, [0.25, 0.5, 0.75]) if v.size else (math.nan,) * 3
    return {"n_finite": int(v.size), "median": _num(med), "q1": _num(q1), "q3": _num(q3),
            "iqr": _num(q3 - q1), "median_interval": _num(bootstrap_interval(v, np.median, **boot)),
            "mean": _num(v.mean()) if v.size else None}


def _compare(a, b, design_a, design_b, name, confidence, boot):
    seeds = [s for s in a if s in b]
    va, vb = np.array([a[s] for s in seeds]), np.array([b[s] for s in seeds])
    n, wins, ties = len(seeds), int(np.sum(va < vb)), int(np.sum(va == vb))
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = va / vb
    ratio, score = ratio[np.isfinite(ratio)], wins + ties / 2       # a tie is half a win
    return {"a": design_a, "b": design_b, "index": name, "n_paired": n, "wins": wins,
            "ties": ties, "losses": n - wins - ties, "share_a_better": score / n if n else None,
            "share_interval": _num(wilson_interval(score, n, confidence)), "n_ratio": ratio.size,
            "median_ratio": _num(np.median(ratio)) if ratio.size else None,
            "ratio_interval": _num(bootstrap_interval(ratio, np.median, **boot))}


def summarize(records: Iterable[Mapping], *, designs: Sequence[str] | None = None,
              indices: Sequence[str] | None = None, baseline: str | None = None,
              confidence: float = 0.95, resamples: int = 2000, seed: int = 0) -> dict:
    """Success rates, index distributions and paired comparisons of a campaign's cases.

    Parameters
    ----------
    records : sequence of dict
        Finished cases, with "design", "seed", "success" and optionally "indices", "key",
        "failure".  A (design, seed) pair appearing twice raises ``ValueError``.
    designs : sequence of str, optional
        Designs to summarize, in this order (default: order of first appearance); records of
        other designs are ignored, a listed design without records has n = 0.
    indices : sequence of str, optional
        Index names (default: those of the successful records, in first-seen order).
    baseline : str, optional
        Compare every other design with this one only (default: every ordered pair).
    confidence : float, default 0.95
        Coverage of every interval, in (0, 1).
    resamples : int, default 2000
        Bootstrap resamples per interval.
    seed : int, default 0
        Seed of every bootstrap (each interval reuses it), so the summary is reproducible.

    Returns
    -------
    dict
        JSON-serializable (undefined numbers None, intervals [low, high]): "designs",
        "indices", "baseline", "confidence", "resamples", "seed"; "per_design": {design: {"n",
        "successes", "success_rate", "success_interval" (Wilson), "failures" ({text: count}),
        "indices": {index: {"n_finite", "median", "q1", "q3", "iqr", "median_interval"
        (bootstrap), "mean"}}}} over successful cases with finite values; "comparisons":
        [{"a", "b", "index", "n_paired" (seeds where both succeeded with finite values),
        "wins", "ties", "losses", "share_a_better" = (wins + ties/2) / n_paired,
        "share_interval" (Wilson with successes = wins + ties/2), "n_ratio" (paired seeds with
        B ≠ 0), "median_ratio" (of A/B), "ratio_interval" (bootstrap)}] per pair and index.
    """
    confidence = _number(confidence, "confidence", 0, 1, closed=False)
    resamples = _number(resamples, "resamples", 1, integer=True)
    seed = _number(seed, "seed", integer=True)
    cases = _cases(records)
    designs = list(cases) if designs is None else _names(designs, "designs")
    if baseline is not None and baseline not in designs:
        raise ValueError(f"baseline {baseline!r} is not one of the designs {designs}")
    if indices is None:
        indices = list(dict.fromkeys(k for d in designs for r in cases.get(d, {}).values()
                                     if r["success"] for k in (r.get("indices") or {})))
    indices = _names(indices, "indices")
    boot = {"confidence": confidence, "resamples": resamples, "seed": seed}
    values = {d: {i: _successful(cases.get(d, {}), i) for i in indices} for d in designs}
    per_design = {}
    for d in designs:
        seeds = cases.get(d, {})
        n, ok = len(seeds), sum(bool(r["success"]) for r in seeds.values())
        failures = Counter(str(r.get("failure") or "unknown") for r in seeds.values()
                           if not r["success"])
        per_design[d] = {"n": n, "successes": ok, "success_rate": ok / n if n else None,
                         "success_interval": _num(wilson_interval(ok, n, confidence)),
                         "failures": dict(failures),
                         "indices": {i: _distribution(list(values[d][i].values()), boot)
                                     for i in indices}}
    comparisons = [_compare(values[a][i], values[b][i], a, b, i, confidence, boot)
                   for a in designs for b in designs if a != b and baseline in (None, b)
                   for i in indices]
    return {"designs": designs, "indices": indices, "baseline": baseline,
            "confidence": confidence, "resamples": resamples, "seed": seed,
            "per_design": per_design, "comparisons": comparisons}


def _with_interval(value, interval):
    return fmt(None) if value is None else \
        f"{fmt(value)} [{fmt(interval[0])}, {fmt(interval[1])}]"


def summary_tables(summary: dict) -> tuple[str, dict]:
    """Markdown tables of a :func:`summarize` result (4 significant digits, "—" if undefined).

    Parameters
    ----------
    summary : dict
        What :func:`summarize` returned (also after a JSON round trip).

    Returns
    -------
    markdown : str
        One table per index (design, success rate [interval] (successes/n), n finite, median
        [interval], IQR) and one of the paired comparisons (A, B, index, share A better
        [interval], paired seeds, median ratio A/B [interval]).
    rows : dict
        The same as data, cells as shown: {"indices": {index: {"columns", "rows"}},
        "comparisons": {"columns", "rows"}} (e.g. for ``report.write_table``).
    """
    tables = {"indices": {}}
    parts = [f"### Campaign statistics ({fmt(100 * summary['confidence'])} % intervals)"]
    columns = ["design", "success rate", "n finite", "median", "IQR"]
    for index in summary["indices"]:
        rows = []
        for d in summary["designs"]:
            s, st = summary["per_design"][d], summary["per_design"][d]["indices"][index]
            rows.append([str(d), f"{_with_interval(s['success_rate'], s['success_interval'])} "
                         f"({s['successes']}/{s['n']})", str(st["n_finite"]),
                         _with_interval(st["median"], st["median_interval"]), fmt(st["iqr"])])
        tables["indices"][index] = {"columns": columns, "rows": rows}
        parts += ["", f"#### {index}", "", markdown_table(columns, rows)]
    columns = ["A", "B", "index", "share A better", "paired seeds", "median ratio A/B"]
    rows = [[str(c["a"]), str(c["b"]), str(c["index"]),
             _with_interval(c["share_a_better"], c["share_interval"]), str(c["n_paired"]),
             _with_interval(c["median_ratio"], c["ratio_interval"])]
            for c in summary["comparisons"]]
    parts += ["", "#### Paired comparisons (lower index is better; a tie counts half)", "",
              markdown_table(columns, rows) if rows else "(no pairs of designs)"]
    return "\n".join(parts) + "\n", {**tables, "comparisons": {"columns": columns, "rows": rows}}


def _panels(records, summary, path, draw, log_axis):
    """One panel per index, ``draw(ax, index, {design: finite values}, {design: n cases})``;
    a log ``log_axis`` ("x" or "y") when all values are positive and span more than 100×."""
    cases = _cases(records)
    designs, indices = summary["designs"], summary["indices"]
    n_cases = {d: len(cases.get(d, {})) for d in designs}
    nrows, ncols = -(-max(1, len(indices)) // 3), min(3, max(1, len(indices)))
    fig = Figure(figsize=(4.2 * ncols, 3.4 * nrows))   # no pyplot: no backend chosen
    axes = fig.subplots(nrows, ncols, squeeze=False)
    for ax in axes.flat[len(indices):]:
        ax.set_visible(False)
    fig.suptitle("" if indices else "(no index in the summary)")
    for ax, index in zip(axes.flat, indices):
        by_design = {d: np.array(list(_successful(cases.get(d, {}), index).values()))
                     for d in designs}
        draw(ax, index, by_design, n_cases)
        v = np.concatenate([np.empty(0), *by_design.values()])
        if v.size and v.min() > 0 and v.max() / v.min() > 100:
            getattr(ax, f"set_{log_axis}scale")("log")
        ax.grid(True, alpha=0.3)
    fig.tight_layout()
    return save_figure(fig, path)


def plot_distributions(records: Iterable[Mapping], summary: dict, path: str | os.PathLike) -> Path:
    """Box plots of each index per design over jittered points of the successful cases, one
    panel per index (log y axis when all values are positive and span more than 100×).

    Parameters
    ----------
    records : sequence of dict
        The campaign's cases (as given to :func:`summarize`).
    summary : dict
        :func:`summarize` result (gives the designs, their order and the indices).
    path : str or Path
        PNG file to write.

    Returns
    -------
    Path
        ``path``.
    """
    rng = np.random.default_rng(0)                    # the jitter, reproducible

    def draw(ax, index, by_design, n_cases):
        pos = [k for k, v in enumerate(by_design.values(), 1) if v.size]
        if pos:
            ax.boxplot([v for v in by_design.values() if v.size], positions=pos, widths=0.5,
                       showfliers=False, medianprops={"color": "k"})
        for k, v in enumerate(by_design.values(), 1):
            ax.plot(k + rng.uniform(-0.15, 0.15, v.size), v, "o", ms=3, alpha=0.5,
                    color=f"C{(k - 1) % 10}")
        ax.set_xticks(range(1, len(by_design) + 1), [str(d) for d in by_design], rotation=30,
                      ha="right", fontsize=8)
        ax.set_xlim(0.4, len(by_design) + 0.6)
        ax.set_title(index)

    return _panels(records, summary, path, draw, "y")


def plot_cdfs(records: Iterable[Mapping], summary: dict, path: str | os.PathLike) -> Path:
    """Empirical CDF of each index per design, one panel per index (log x axis when all
    values are positive and span more than 100×).  A design's CDF is over all its cases, a
    failed case (or a missing or infinite value) counting as worse than any value: a curve
    ends at the share of cases that succeeded with a finite value (failures are the gap to 1).

    Parameters
    ----------
    records : sequence of dict
        The campaign's cases (as given to :func:`summarize`).
    summary : dict
        :func:`summarize` result (gives the designs, their order and the indices).
    path : str or Path
        PNG file to write.

    Returns
    -------
    Path
        ``path``.
    """
    def draw(ax, index, by_design, n_cases):
        for k, (d, v) in enumerate(by_design.items()):
            if v.size:
                x, y = np.sort(v), np.arange(1, v.size + 1) / n_cases[d]
                ax.step(np.r_[x[0], x], np.r_[0.0, y], where="post", color=f"C{k % 10}",
                        label=f"{d} ({v.size}/{n_cases[d]})")
        ax.set_ylim(0, 1.02)
        ax.set_xlabel(index)
        ax.set_ylabel("share of cases ≤ x")
        if any(v.size for v in by_design.values()):
            ax.legend(fontsize=7, loc="lower right")

    return _panels(records, summary, path, draw, "x")
