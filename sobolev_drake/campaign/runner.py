"""Run a campaign: its cases in worker processes or on a Dask cluster, resumable.

Executors (no scheduler of our own):

* ``workers=0`` — in this process (debugging, tests);
* ``scheduler=None`` — a ``concurrent.futures.ProcessPoolExecutor`` of ``workers`` processes,
  renewed every ``workers × tasks_per_worker`` cases because Python LeafSystems are never freed
  (docs/design.md §8.6);
* ``scheduler="dask-local"`` — a ``distributed.LocalCluster`` of ``workers`` single-threaded
  processes; any other string is the address of a running Dask scheduler.

Each case's record is appended to the store as it arrives (:mod:`.store`); with
``resume=True`` the cases already recorded are skipped.  A campaign that declares
``synthesize`` has its designs synthesized first (one task per design, on the same executor)
and pinned in the store; every case then flies the pinned copy.  A progress bar (tqdm) shows
the rate and the projected finish.
"""

from __future__ import annotations

import datetime
import functools
import importlib
import json
import math
import os
import time
from collections.abc import Sequence
from pathlib import Path

from sobolev_drake.campaign import executors
from sobolev_drake.campaign.case import Case, DesignFailed
from sobolev_drake.campaign.errors import CampaignFolderError, first_line
from sobolev_drake.campaign.registry import CampaignDefinition, get_campaign
from sobolev_drake.campaign.store import CampaignStore
from sobolev_drake.datafile import fingerprint, write_text_atomic

#: most cases one campaign run may hold (seeds × designs): past this, split the seed range
MAX_CASES = 1_000_000

__all__ = ["make_cases", "synthesize_design", "run_case", "run_campaign", "write_summary",
           "claim_statistics"]


def make_cases(name: str, seeds: int, *, first_seed: int = 0, designs: Sequence[str] | None = None,
               perturb: dict | None = None, duration: float | None = None,
               smoke: bool = False) -> list[Case]:
    """The cases of a campaign: every design on every seed.

    Parameters
    ----------
    name : str
        The campaign (experiment) name.
    seeds : int
        Number of seeds (≥ 1): ``first_seed, …, first_seed + seeds − 1``.
    first_seed : int
        First seed.
    designs : sequence of str, optional
        A subset of the campaign's designs (default all).
    perturb : dict, optional
        {parameter: fraction}; None uses the campaign's default, {} none.
    duration : float, optional
        Simulated time per case (s).
    smoke : bool
        Short cases.

    Returns
    -------
    list of Case
        Seed-major order (all designs of seed k before seed k + 1), so an interrupted campaign
        leaves complete pairs.

    Examples
    --------
    >>> from sobolev_drake.campaign import make_cases
    >>> cases = make_cases("manipulator", seeds=2, perturb={"m1": 0.1})
    >>> [case.key for case in cases]
    ['W2/W∞|0', 'H∞|0', 'W2/W∞|1', 'H∞|1']
    >>> cases[0].draws() == cases[1].draws()     # both designs meet the same draw on a seed
    True
    """
    defn = get_campaign(name)
    if not (isinstance(seeds, int) and not isinstance(seeds, bool) and seeds >= 1):
        raise ValueError(f"seeds must be an integer >= 1, got {seeds!r}")
    if not (isinstance(first_seed, int) and not isinstance(first_seed, bool) and first_seed >= 0):
        raise ValueError(f"first_seed must be an integer >= 0, got {first_seed!r}")
    if isinstance(designs, str):
        designs = [designs]
    designs = tuple(dict.fromkeys(defn.designs if designs is None else designs))  # no duplicates
    bad = [d for d in designs if d not in defn.designs]
    if bad or not designs:
        raise ValueError(f"designs must be among {defn.designs}, got {list(designs)!r}")
    if seeds * len(designs) > MAX_CASES:
        raise ValueError(f"seeds: {seeds} seeds × {len(designs)} designs is more than the "
                         f"{MAX_CASES} cases one run may hold; run at most "
                         f"{MAX_CASES // len(designs)} seeds at a time (--first-seed picks the range)")
    perturb = dict(defn.default_perturb if perturb is None else perturb)
    bad = [p for p in perturb if p not in defn.parameters]
    if bad:
        raise ValueError(f"--perturb: campaign {name!r} cannot perturb {bad}; it can perturb "
                         f"{sorted(defn.parameters) or 'nothing'}")
    items = tuple(sorted((k, float(v)) for k, v in perturb.items()))
    _check_duration(name, duration)
    return [Case(name, d, s, items, None if duration is None else float(duration), bool(smoke))
            for s in range(first_seed, first_seed + seeds) for d in designs]


def _check_duration(name, duration):
    """The rule ``sobolev-drake run`` applies: a finite duration > 0, and within the
    experiment's own bounds where it has a default duration."""
    if duration is None:
        return
    if isinstance(duration, bool) or not isinstance(duration, (int, float)) or not (
            math.isfinite(duration) and duration > 0):
        raise ValueError(f"duration must be a finite number of seconds > 0, got {duration!r}")
    exp = importlib.import_module("sobolev_drake.experiments").REGISTRY.get(name)
    if exp is not None:                     # campaigns registered without an experiment: no rule
        exp.check_duration(duration)


def synthesize_design(name: str, label: str) -> dict:
    """Synthesize one design of a campaign that declares ``synthesize`` (in whatever process
    holds the call).

    Parameters
    ----------
    name : str
        The campaign name.
    label : str
        One of its designs.

    Returns
    -------
    dict
        {"design": the synthesized design} or, when the synthesis raised, {"failure": str}
        ("synthesis failed: …", the exception's type and first message line).
    """
    defn = get_campaign(name)
    if defn.synthesize is None:
        raise ValueError(f"campaign {name!r} declares no synthesize; its cases build their own controllers")
    try:
        return {"design": defn.synthesize(label)}
    except DesignFailed as exc:
        return {"failure": f"synthesis failed: {first_line(exc)}"}
    except Exception as exc:  # noqa: BLE001 - every case of the design records it
        return {"failure": f"synthesis failed: {type(exc).__name__}: {first_line(exc)}"}


@functools.lru_cache(maxsize=None)
def _design_in_process(name, label):
    # run_case without a pinned design: synthesize once per process
    return synthesize_design(name, label)



def run_case(case: Case, pinned: dict | None = None) -> dict:
    """Run one case (in whatever process holds it) and return its record.

    A case that raises is a failed record (its exception type and first message line), not a
    lost one: the campaign counts it in the design's success rate.

    Parameters
    ----------
    case : Case
    pinned : dict, optional
        For a campaign that declares ``synthesize``: the case's design as
        :func:`synthesize_design` returned it (the campaign's pinned copy).  None synthesizes
        it in this process (once per process and design).

    Returns
    -------
    dict
        "key", "campaign", "design", "seed", "perturb_values", "indices", "success",
        "failure", "peaks", "wall_s", "pid".
    """
    t0 = time.perf_counter()
    defn = get_campaign(case.campaign)
    try:
        if defn.synthesize is None:
            out = dict(defn.run(case))
        else:
            if pinned is None:
                pinned = _design_in_process(case.campaign, case.design)
            out = ({"success": False, "failure": pinned["failure"]} if "failure" in pinned
                   else dict(defn.run(case, pinned["design"])))
    except Exception as exc:  # noqa: BLE001 - recorded as the case's failure
        out = {"success": False, "indices": {}, "failure": f"{type(exc).__name__}: {first_line(exc)}"}
    return {"key": case.key, "campaign": case.campaign, "design": case.design, "seed": case.seed,
            "perturb_values": case.draws(), "indices": {k: float(v) for k, v in out.get("indices", {}).items()},
            "success": bool(out.get("success", False)), "failure": str(out.get("failure", "")),
            "peaks": {k: float(v) for k, v in out.get("peaks", {}).items()},
            "wall_s": time.perf_counter() - t0, "pid": os.getpid()}


def _design_specs(defn, labels):
    """{label: fingerprint of what defines the design} (its label when none is declared)."""
    return {label: fingerprint(defn.design_spec(label) if defn.design_spec else label)
            for label in labels}


def _pin_designs(name, defn, labels, store, done, executor, workers, scheduler):
    """The pinned designs of ``labels``: those in the store (validated), the others synthesized
    (in parallel on the executor) and added to it.  A design with records but no pinned copy
    is refused: synthesizing it again could fly another controller."""
    specs = _design_specs(defn, defn.designs)
    pinned = store.load_designs(name, specs, check=defn.check_design)
    missing = [label for label in labels if label not in pinned]
    flown = sorted({r["design"] for r in done.values()} & set(missing))
    if flown:
        state = "is missing" if not store.designs_path.exists() else f"does not pin {flown}"
        raise CampaignFolderError(
            f"{store.designs_path} {state}, but the folder holds records flown with the pinned "
            f"design(s) {flown}; restore the file (synthesizing again could fly another "
            "controller), or choose another --out")
    if missing:
        results = dict(executor(_synthesize_labelled, [(name, label) for label in missing],
                                workers, scheduler, len(missing)))
        for label, entry in results.items():
            if "design" in entry and defn.check_design is not None:
                defn.check_design(label, entry["design"])   # the declared structure must hold
        pinned.update(results)
        store.save_designs(name, pinned, specs)
        pinned = store.load_designs(name, specs, check=defn.check_design)   # fly what is on disk
    return pinned


def _synthesize_labelled(name, label):
    return label, synthesize_design(name, label)


def run_campaign(name: str, *, seeds: int, out_dir: str | os.PathLike, first_seed: int = 0,
                 designs: Sequence[str] | None = None, workers: int = 1,
                 scheduler: str | None = None, perturb: dict | None = None, resume: bool = False,
                 duration: float | None = None, smoke: bool = False, progress: bool = True,
                 tasks_per_worker: int = 20) -> dict:
    """Run (or finish) a campaign and write its records, summary, tables and plots.

    The folder is locked for the run (:meth:`CampaignStore.locked`): a second campaign on it
    is refused, naming the process that holds it.

    Parameters
    ----------
    name : str
        The campaign (experiment) name.
    seeds : int
        Number of seeds (seeds × designs ≤ :data:`MAX_CASES`).
    out_dir : str or Path
        Output folder: ``records.jsonl``, ``campaign.json``, ``designs.json``,
        ``summary.json``, ``runs.jsonl``, tables, plots.
    first_seed : int
        First seed.
    designs : sequence of str, optional
        Subset of the designs (a repeated label counts once).
    workers : int
        Worker processes (0: run in this process); a process pool or ``"dask-local"`` starts
        at most one per CPU and per pending case.
    scheduler : str, optional
        None (process pool), "dask-local" or a Dask scheduler address.  An address that does
        not answer, or a cluster without workers, stops the run within
        :data:`~sobolev_drake.campaign.executors.DASK_CONNECT_TIMEOUT` s; a cluster that loses
        every worker mid-run stops it after
        :data:`~sobolev_drake.campaign.executors.DASK_WORKERLESS_TIMEOUT` s.
    perturb : dict, optional
        {parameter: fraction} (None: the campaign's default).
    resume : bool
        Skip cases already recorded in ``out_dir``.
    duration : float, optional
        Simulated time per case (s), within the experiment's bounds (as ``sobolev-drake run``).
    smoke : bool
        Short cases.
    progress : bool
        Show a progress bar on stderr.
    tasks_per_worker : int
        Cases per worker process before the pool is renewed (process pool only).

    Returns
    -------
    dict
        The summary (:func:`sobolev_drake.campaign.stats.summarize`, as written to
        ``summary.json``) with "out_dir", "ran" (cases run now) and "wall_s" added.

    Raises
    ------
    FileExistsError
        The folder holds another campaign and ``resume`` is False.
    CampaignFolderError
        A file of the folder is damaged or describes another campaign (see
        :mod:`sobolev_drake.campaign.store`).
    CampaignLockedError
        Another process runs a campaign in the folder.
    ClusterUnavailableError, ClusterLostError
        The Dask cluster cannot be reached, or lost its workers.
    """
    if not (isinstance(workers, int) and not isinstance(workers, bool) and workers >= 0):
        raise ValueError(f"workers must be an integer >= 0, got {workers!r}")
    if scheduler is not None and not (isinstance(scheduler, str) and scheduler.strip()):
        raise ValueError(f"scheduler must be None, 'dask-local' or a Dask scheduler address, "
                         f"got {scheduler!r}")
    if workers == 0 and scheduler is not None:
        raise ValueError("workers=0 runs in this process; a scheduler needs workers >= 1")
    if not (isinstance(tasks_per_worker, int) and not isinstance(tasks_per_worker, bool)
            and tasks_per_worker >= 1):
        raise ValueError(f"tasks_per_worker must be an integer >= 1, got {tasks_per_worker!r}")
    cases = make_cases(name, seeds, first_seed=first_seed, designs=designs, perturb=perturb,
                       duration=duration, smoke=smoke)
    first = cases[0]
    config = {"campaign": name, "designs": sorted({c.design for c in cases}),
              "perturb": [list(p) for p in first.perturb], "duration": first.duration,
              "smoke": first.smoke}
    store = CampaignStore(out_dir)
    defn = get_campaign(name)
    with store.locked():
        done = store.start(config, resume=resume)
        todo = [c for c in cases if c.key not in done]
        executor = executors.pick(workers, scheduler)
        n_workers = executors.worker_count(workers, scheduler, len(todo))
        started = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
        t0 = time.perf_counter()
        calls = [(c,) for c in todo]
        if defn.synthesize is not None and todo:
            pinned = _pin_designs(name, defn, sorted({c.design for c in todo}), store, done,
                                  executor, n_workers, scheduler)
            calls = [(c, pinned[c.design]) for c in todo]
        bar = None
        if progress and todo:
            from tqdm import tqdm
            bar = tqdm(total=len(todo), desc=f"campaign {name}", unit="case", smoothing=0.1)
        try:
            for record in executor(run_case, calls, n_workers, scheduler, tasks_per_worker):
                store.append(record)
                if bar is not None:
                    bar.update(1)
        finally:
            if bar is not None:
                bar.close()
        wall = time.perf_counter() - t0
        keys = {c.key for c in cases}
        records = [r for r in store.load().values() if r["key"] in keys]
        summary = write_summary(name, records, [d for d in defn.designs if d in config["designs"]],
                                Path(out_dir), extra={"cases": len(cases), "config": config})
        store.log_run({"started": started, "wall_s": round(wall, 3), "ran": len(todo),
                       "cases": len(cases), "seeds": [first_seed, first_seed + seeds - 1],
                       "executor": "inline" if workers == 0 else (scheduler or "processes"),
                       "workers": n_workers, "pid": os.getpid()})
    summary.update({"out_dir": str(out_dir), "ran": len(todo), "wall_s": wall})
    return summary


def write_summary(name: str, records: list[dict], designs: list[str], out_dir: Path,
                  extra: dict | None = None) -> dict:
    """Statistics, tables and plots of a campaign's records.

    Parameters
    ----------
    name : str
        The campaign name.
    records : list of dict
        Its records.
    designs : list of str
        Design order.
    out_dir : Path
        Output folder.
    extra : dict, optional
        Added to the summary.

    Returns
    -------
    dict
        The summary, also written to ``summary.json``: a function of the records' content
        only (sorted by design and seed), so any executor gives the same bytes.
    """
    from sobolev_drake.campaign import stats

    defn = get_campaign(name)
    summary = stats.summarize(records, designs=designs, indices=list(defn.indices))
    records = sorted(records, key=lambda r: (str(r["design"]), r["seed"]))   # not arrival order
    summary.update({"campaign": name, "randomizes": defn.randomizes, **(extra or {})})
    md, rows = stats.summary_tables(summary)
    summary["claims"] = claim_statistics(defn, summary)
    n_seeds = len({r["seed"] for r in records})
    head = [f"## Campaign {name}", "", f"{n_seeds} seeds; a seed randomizes {defn.randomizes}"
            + (f"; parameters scaled per seed: {', '.join(f'{k} ±{100 * v:g} %' for k, v in summary['config']['perturb'])}"
               if summary.get("config", {}).get("perturb") else "") + ".", ""]
    if summary["claims"]:
        head += ["Thesis claims over the campaign (share of paired seeds where the claim holds, "
                 f"{100 * summary['confidence']:g} % Wilson interval):", ""]
        head += [f"- {c['text']}: {c['statement']}" for c in summary["claims"]] + [""]
    write_text_atomic(out_dir / "summary.md", "\n".join(head) + md + "\n")
    write_text_atomic(out_dir / "summary.json", json.dumps(summary, indent=2, default=float))
    if records:
        stats.plot_distributions(records, summary, out_dir / "distributions.png")
        stats.plot_cdfs(records, summary, out_dir / "cdfs.png")
    return summary


def claim_statistics(defn: CampaignDefinition, summary: dict) -> list[dict]:
    """Each of the campaign's claims "A has the smaller index than B" as a paired statistic.

    Parameters
    ----------
    defn : CampaignDefinition
        The campaign (its ``claims``).
    summary : dict
        From :func:`sobolev_drake.campaign.stats.summarize`.

    Returns
    -------
    list of dict
        "text", "a", "b", "index", "share", "interval", "n_paired", "median_ratio",
        "statement" (one readable line).
    """
    out = []
    for text, a, b, index in defn.claims:
        if a not in summary["designs"] or b not in summary["designs"]:
            continue                              # a campaign run on a subset of the designs
        comp = next((c for c in summary["comparisons"]
                     if (c["a"], c["b"], c["index"]) == (a, b, index)), None)
        if comp is None or comp["share_a_better"] is None:
            out.append({"text": text, "a": a, "b": b, "index": index, "share": None,
                        "interval": [0.0, 1.0], "n_paired": 0, "median_ratio": None,
                        "statement": "no paired seeds"})
            continue
        lo, hi = comp["share_interval"]
        ratio = comp["median_ratio"]
        out.append({"text": text, "a": a, "b": b, "index": index, "share": comp["share_a_better"],
                    "interval": [lo, hi], "n_paired": comp["n_paired"], "median_ratio": ratio,
                    "statement": f"holds on {100 * comp['share_a_better']:.0f} % "
                                 f"[{100 * lo:.0f}, {100 * hi:.0f}] of {comp['n_paired']} paired seeds"
                                 + (f"; median {index} ratio {a}/{b} = {ratio:.3g}" if ratio is not None else "")})
    return out
