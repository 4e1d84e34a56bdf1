"""The campaign runner: cases, the record store, executors giving identical numbers, and resume
after a killed worker or a killed campaign."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from sobolev_drake.campaign import Case, make_cases, run_campaign, run_case
from sobolev_drake.campaign.store import CampaignStore

SMOKE = dict(smoke=True, progress=False)


def records(folder):
    """{key: record without its wall time and process id}, and the raw number of lines."""
    lines = Path(folder, "records.jsonl").read_text(encoding="utf-8").splitlines()
    out = {}
    for line in lines:
        r = json.loads(line)
        r.pop("wall_s"), r.pop("pid")
        out[r["key"]] = r
    return out, len(lines)


def test_cases_are_seed_major_and_validated():
    cases = make_cases("manipulator", 2, first_seed=5, smoke=True)
    assert [c.key for c in cases] == ["W2/W∞|5", "H∞|5", "W2/W∞|6", "H∞|6"]
    assert cases[0].perturb == (("I1", 0.1), ("I2", 0.1), ("m1", 0.1), ("m2", 0.1))
    with pytest.raises(ValueError, match="seeds must be"):
        make_cases("manipulator", 0)
    with pytest.raises(ValueError, match="designs must be among"):
        make_cases("manipulator", 1, designs=["LQR"])
    with pytest.raises(ValueError, match="cannot perturb.*'rotor'"):
        make_cases("manipulator", 1, perturb={"rotor": 0.1})
    with pytest.raises(KeyError, match="no campaign 'nope'"):
        make_cases("nope", 1)
    with pytest.raises(ValueError, match="seed must be a non-negative"):
        Case("manipulator", "H∞", -1)


def test_draws_depend_on_the_seed_only():
    a, b = make_cases("manipulator", 1, first_seed=3)
    assert a.design != b.design and a.draws() == b.draws()
    assert a.rng("disturbance").uniform() == b.rng("disturbance").uniform()
    other = make_cases("manipulator", 1, first_seed=4)[0]
    assert other.draws() != a.draws()
    assert a.rng("disturbance").uniform() != a.rng("turbulence").uniform()   # independent streams
    # factors inside the asked box
    assert all(0.9 <= f <= 1.1 for f in a.draws().values())


def test_a_failing_case_is_a_failed_record_not_a_crash():
    rec = run_case(Case("manipulator", "H∞", 0, duration=float("inf")))   # rejected by the loop
    assert rec["success"] is False and rec["failure"] and rec["indices"] == {}


def test_store_sets_a_partial_line_aside_and_refuses_overwrites(tmp_path):
    store = CampaignStore(tmp_path)
    config = {"campaign": "manipulator", "designs": ["H∞"], "perturb": [], "duration": None,
              "smoke": True}
    record = {"key": "H∞|0", "design": "H∞", "seed": 0, "success": True}
    with store.locked():
        assert store.start(config, resume=False) == {}
        store.append(record)
        with open(store.records_path, "ab") as f:
            f.write(b'{"key": "H\xe2\x88\x9e|1", "x"')          # died while writing
        assert list(store.load()) == ["H∞|0"]
        assert store.records_path.read_bytes().endswith(b"}\n")  # fragment set aside
        assert store.torn_path.read_bytes() == b'{"key": "H\xe2\x88\x9e|1", "x"\n'
        with pytest.raises(FileExistsError, match="--resume"):
            store.start(config, resume=False)
        with pytest.raises(ValueError, match="different campaign definition.*smoke"):
            store.start({**config, "smoke": False}, resume=True)
        store.append({**record, "x": 2})
        with pytest.raises(ValueError, match=r"records\.jsonl:2: case H∞\|0 already recorded on line 1"):
            store.load()
    with pytest.raises(RuntimeError, match="needs the folder's lock"):
        store.start(config, resume=True)


def test_process_pool_and_dask_local_give_the_numbers_of_the_inline_run(tmp_path):
    pytest.importorskip("distributed")
    kw = dict(seeds=2, **SMOKE)
    run_campaign("manipulator", workers=0, out_dir=tmp_path / "inline", **kw)
    run_campaign("manipulator", workers=2, out_dir=tmp_path / "pool", **kw)
    summary = run_campaign("manipulator", workers=2, scheduler="dask-local",
                           out_dir=tmp_path / "dask", **kw)
    inline, n = records(tmp_path / "inline")
    assert n == 4 and inline == records(tmp_path / "pool")[0] == records(tmp_path / "dask")[0]
    # the statistics depend on the records alone, not on the order they arrived in
    written = {k: (tmp_path / k / "summary.json").read_bytes() for k in ("inline", "pool", "dask")}
    assert written["inline"] == written["pool"] == written["dask"]
    assert summary["cases"] == 4 and (tmp_path / "dask" / "summary.json").exists()
    # the thesis' claims, as paired statistics: two seeds, each claim compared on both
    claims = summary["claims"]
    assert [c["index"] for c in claims] == ["ISE q1", "ISE q2"]
    assert all(c["n_paired"] == 2 and c["statement"] for c in claims)
    assert "Thesis claims over the campaign" in (tmp_path / "dask" / "summary.md").read_text(
        encoding="utf-8")


def _campaign(out, *extra):
    return [sys.executable, "-m", "sobolev_drake", "campaign", "manipulator", "--seeds", "6",
            "--smoke", "--no-progress", "--out", str(out), *extra]


def _wait_for_records(path, n, proc, timeout=120):
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        if path.exists() and path.read_text(encoding="utf-8").count("\n") >= n:
            return
        if proc.poll() is not None:
            pytest.fail(f"campaign ended before {n} records: {proc.stderr.read()}")
        time.sleep(0.05)
    pytest.fail(f"no {n} records after {timeout} s")


@pytest.mark.parametrize("kill", ["worker", "campaign"])
def test_resume_after_a_kill_loses_and_duplicates_nothing(tmp_path, kill):
    env = {**os.environ, "MPLBACKEND": "Agg"}
    proc = subprocess.Popen(_campaign(tmp_path, "--workers", "1"), env=env, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True)
    _wait_for_records(tmp_path / "records.jsonl", 2, proc)
    if kill == "worker":          # the worker process that wrote the first record
        first = json.loads((tmp_path / "records.jsonl").read_text(encoding="utf-8").splitlines()[0])
        os.kill(first["pid"], signal.SIGKILL)
        _, err = proc.communicate(timeout=120)
        assert proc.returncode == 1 and "--resume" in err
    else:                         # the whole campaign (the machine, say)
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(timeout=60)
    before, _ = records(tmp_path)
    assert 2 <= len(before) < 12
    done = subprocess.run(_campaign(tmp_path, "--workers", "1", "--resume"), env=env, text=True,
                          capture_output=True, timeout=300)
    assert done.returncode == 0, done.stderr
    after, lines = records(tmp_path)
    expected = {c.key for c in make_cases("manipulator", 6, smoke=True)}
    assert lines == len(after) == 12 and set(after) == expected          # none lost, none twice
    assert all(after[k] == v for k, v in before.items())                # old records untouched
    assert f"({12 - len(before)} run now" in done.stdout


def test_the_process_pool_is_renewed_without_losing_cases(tmp_path):
    # 2 seeds × 2 designs, two cases per worker and round: two pools in turn
    summary = run_campaign("manipulator", seeds=2, workers=1, tasks_per_worker=2,
                           out_dir=tmp_path, **SMOKE)
    recs, lines = records(tmp_path)
    assert summary["ran"] == lines == len(recs) == 4
    assert len({json.loads(line)["pid"] for line in (tmp_path / "records.jsonl").read_text(
        encoding="utf-8").splitlines()}) == 2                    # each round its own process


def test_a_running_scheduler_is_reached_by_its_address(tmp_path):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        run_campaign("manipulator", seeds=1, workers=1, scheduler=cluster.scheduler_address,
                     out_dir=tmp_path / "remote", **SMOKE)
    run_campaign("manipulator", seeds=1, workers=0, out_dir=tmp_path / "inline", **SMOKE)
    assert records(tmp_path / "remote")[0] == records(tmp_path / "inline")[0]


def test_designs_are_synthesized_once_and_pinned_across_resumes(tmp_path):
    """A solver whose answer moves from one solve to the next (as singular LMI optima do):
    every case of a campaign, resumed or not, flies the one pinned copy."""
    from sobolev_drake.campaign import CampaignDefinition, DesignFailed, register_campaign

    solves = []

    def synthesize(label):
        solves.append(label)
        if label == "broken":
            raise DesignFailed("no feasible point")
        return {"gain": 1.0 + 1e-4 * len(solves)}          # a different optimum every solve

    def run(case, design):
        return {"indices": {"J": design["gain"] * (1 + case.seed)}, "success": True}

    register_campaign("test-pinned", CampaignDefinition(
        designs=("stable", "broken"), indices=("J",), randomizes="nothing", run=run,
        synthesize=synthesize))
    run_campaign("test-pinned", seeds=2, out_dir=tmp_path, workers=0, progress=False)
    assert sorted(solves) == ["broken", "stable"]
    run_campaign("test-pinned", seeds=4, out_dir=tmp_path, workers=0, progress=False, resume=True)
    assert sorted(solves) == ["broken", "stable"]          # the resume solved nothing again
    recs, lines = records(tmp_path)
    assert lines == 8
    gains = {r["indices"]["J"] / (1 + r["seed"]) for r in recs.values() if r["design"] == "stable"}
    assert len(gains) == 1                                  # one controller for all four seeds
    broken = [r for r in recs.values() if r["design"] == "broken"]
    assert all(not r["success"] and r["failure"] == "synthesis failed: no feasible point" for r in broken)
    # a new campaign in the same folder is refused; in a fresh folder it synthesizes anew
    run_campaign("test-pinned", seeds=1, out_dir=tmp_path / "again", workers=0, progress=False)
    assert len(solves) == 4


def test_run_case_without_a_pinned_design_synthesizes_in_process():
    from sobolev_drake.campaign import synthesize_design
    with pytest.raises(ValueError, match="declares no synthesize"):
        synthesize_design("manipulator", "H∞")
