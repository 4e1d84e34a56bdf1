"""Fault injection on campaign folders: every scenario loses and duplicates no record, every
refusal names the file, and nothing in a folder can run code.

Scenarios (docs/reliability.md has the table): SIGKILL of the process group, of the main
process alone (its pool workers must die with it) and of one worker (tests/campaign/
test_runner.py); a torn line in the middle; a NUL-filled line and a NUL tail; a designs file
that is valid JSON with the wrong structure, edited, truncated, for a changed specification, or
deleted; a deleted or truncated definition file; a crafted pickle; two concurrent runs; a full
disk (a file-size limit: the write fails part-way, like ENOSPC); unbounded options; Dask
without a scheduler or without workers.
"""

import json
import os
import pickle
import resource
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import fault_campaign
from sobolev_drake.campaign import run_campaign
from sobolev_drake.campaign import executors, runner
from sobolev_drake.campaign.errors import (CampaignFolderError, CampaignLockedError,
                                           ClusterUnavailableError, CorruptRecordsError)
from sobolev_drake.campaign.store import CampaignStore
from sobolev_drake.cli import main
from sobolev_drake.datafile import fingerprint

NAME = fault_campaign.NAME
SCRIPT = Path(fault_campaign.__file__)
QUIET = dict(workers=0, progress=False)
N_SEEDS = 4                      # 8 cases


def campaign(out, seeds=N_SEEDS, **kw):
    return run_campaign(NAME, seeds=seeds, out_dir=out, **{**QUIET, **kw})


def lines(folder):
    return Path(folder, "records.jsonl").read_bytes().splitlines(keepends=True)


def by_key(folder):
    """{key: record without wall time and pid}; asserts no key twice."""
    out = {}
    for line in lines(folder):
        r = json.loads(line)
        assert r["key"] not in out, f"{r['key']} recorded twice"
        r.pop("wall_s"), r.pop("pid")
        out[r["key"]] = r
    return out


def expected_keys(seeds=N_SEEDS):
    return {f"{d}|{s}" for d in ("A", "B") for s in range(seeds)}


@pytest.fixture()
def finished(tmp_path):
    """A finished 8-case campaign: (folder, its records, bytes of records.jsonl)."""
    fault_campaign.SOLVES.clear()
    fault_campaign.SPEC["gain"] = 1.0
    campaign(tmp_path)
    return tmp_path, by_key(tmp_path), (tmp_path / "records.jsonl").read_bytes()


def assert_complete_after_resume(folder, before):
    """Resume: every case recorded exactly once, the earlier records untouched."""
    campaign(folder, resume=True)
    after = by_key(folder)
    assert set(after) == expected_keys() and len(lines(folder)) == len(after)
    assert all(after[k] == v for k, v in before.items() if k in after)


# -- code execution ---------------------------------------------------------------------------

class _Payload:
    def __init__(self, marker):
        self.marker = marker

    def __reduce__(self):                   # what a crafted pickle does on load
        return (Path.touch, (Path(self.marker),))


def test_a_crafted_design_pickle_is_never_loaded(finished):
    folder, before, raw = finished
    marker = folder / "owned"
    (folder / "designs.pkl").write_bytes(pickle.dumps({"A": _Payload(marker)}))
    with pytest.raises(CampaignFolderError, match=r"designs\.pkl.*never loaded"):
        campaign(folder, seeds=N_SEEDS + 1, resume=True)
    assert not marker.exists()
    assert (folder / "records.jsonl").read_bytes() == raw
    assert main(["campaign", NAME, "--seeds", "5", "--workers", "0", "--resume", "--no-progress",
                 "--out", str(folder)]) == 2
    assert not marker.exists()


def test_no_module_of_the_package_unpickles():
    """Nothing the library reads back goes through pickle or numpy's pickle path."""
    package = Path(runner.__file__).parents[1]
    offenders = [str(p.relative_to(package)) for p in package.rglob("*.py")
                 if any(s in p.read_text(encoding="utf-8")
                        for s in ("pickle.load", "allow_pickle=True", "marshal.load", "yaml.load("))]
    assert offenders == []


def test_a_design_file_cannot_name_an_object_to_build(finished):
    folder, _, _ = finished
    doc = json.loads((folder / "designs.json").read_text(encoding="utf-8"))
    doc["designs"]["A"]["design"]["K"] = {"__array__": "object", "shape": [1], "data": ["os.system"]}
    doc["checksum"] = "0" * 64
    (folder / "designs.json").write_text(json.dumps(doc), encoding="utf-8")
    with pytest.raises(CampaignFolderError, match=r"designs\.json.*array"):
        campaign(folder, seeds=N_SEEDS + 1, resume=True)


# -- damaged records ---------------------------------------------------------------------------

@pytest.mark.parametrize("damage", ["torn", "nul", "duplicate"])
def test_a_bad_line_in_the_middle_stops_the_run_and_repair_keeps_every_record(finished, damage, capsys):
    folder, before, _ = finished
    rows = lines(folder)
    victim = json.loads(rows[3])["key"]
    if damage == "torn":
        rows[3] = rows[3][:25] + b"\n"            # a write cut short, then more appends
    elif damage == "nul":
        rows[3] = b"\x00" * (len(rows[3]) - 1) + b"\n"   # a block lost on disk
    else:
        rows.append(rows[5])                       # the same case written by two runs
    (folder / "records.jsonl").write_bytes(b"".join(rows))
    damaged = (folder / "records.jsonl").read_bytes()
    with pytest.raises(CorruptRecordsError, match=r"records\.jsonl:(4|9): .*campaign-repair"):
        campaign(folder, resume=True)
    with pytest.raises(FileExistsError):          # a new run without --resume: refused too
        campaign(folder)
    assert (folder / "records.jsonl").read_bytes() == damaged   # nothing deleted
    capsys.readouterr()
    assert main(["campaign-repair", str(folder)]) == 0
    assert "moved 1 line(s)" in capsys.readouterr().out
    side = [json.loads(x) for x in (folder / "records.rejected.jsonl").read_text(
        encoding="utf-8").splitlines()]
    assert len(side) == 1 and side[0]["line"] in (4, 9) and side[0]["reason"]
    kept = by_key(folder)
    assert len(kept) == 8 - (damage != "duplicate")
    assert all(before[k] == v for k, v in kept.items())
    if damage != "duplicate":
        assert victim not in kept
    assert_complete_after_resume(folder, before)


def test_a_torn_or_nul_tail_is_set_aside_not_deleted(finished):
    folder, before, raw = finished
    tail = b'{"key": "A|9", "design": "A", "se' + b"\x00" * 40
    (folder / "records.jsonl").write_bytes(raw + tail)
    assert_complete_after_resume(folder, before)
    assert (folder / "records.torn").read_bytes() == tail + b"\n"


def test_a_last_record_missing_only_its_newline_is_kept(finished):
    folder, before, raw = finished
    (folder / "records.jsonl").write_bytes(raw[:-1])
    fault_campaign.SOLVES.clear()
    campaign(folder, resume=True)
    assert by_key(folder) == {k: v for k, v in before.items()} and fault_campaign.SOLVES == []


def test_a_bad_first_line_never_lets_a_new_run_wipe_the_folder(finished):
    folder, _, raw = finished
    (folder / "records.jsonl").write_bytes(b"garbage\n" + raw)
    with pytest.raises(FileExistsError, match=r"records\.jsonl already holds 9 record line"):
        campaign(folder)
    assert (folder / "records.jsonl").read_bytes() == b"garbage\n" + raw


# -- damaged definition files -----------------------------------------------------------------

def _edit_designs(folder, edit, fix_checksum=True):
    path = folder / "designs.json"
    doc = json.loads(path.read_text(encoding="utf-8"))
    edit(doc)
    if fix_checksum:
        from sobolev_drake.datafile import from_tree
        doc["checksum"] = fingerprint(from_tree(doc["designs"]))
    path.write_text(json.dumps(doc), encoding="utf-8")


def _reshape(doc):
    k = doc["designs"]["A"]["design"]["K"]
    k["shape"], k["data"] = [3, 3], [1.0] * 9


@pytest.mark.parametrize("damage, message", [
    ("wrong structure", r"designs\.json: design 'A' is not what the synthesis produces \(K must"),
    ("edited", r"designs\.json: its content does not match its checksum"),
    ("truncated", r"designs\.json:\d+:\d+: the pinned designs is not valid JSON"),
    ("empty", r"designs\.json: the pinned designs is empty"),
    ("other campaign", r"designs\.json: pins the designs of campaign 'manipulator'"),
    ("changed spec", r"designs\.json: the specification of design '[AB]' has changed"),
    ("deleted", r"designs\.json is missing, but the folder holds records"),
])
def test_a_damaged_designs_file_is_refused_naming_it(finished, damage, message):
    folder, before, raw = finished
    path = folder / "designs.json"
    if damage == "wrong structure":
        _edit_designs(folder, _reshape)
    elif damage == "edited":
        _edit_designs(folder, _reshape, fix_checksum=False)
    elif damage == "truncated":
        path.write_bytes(path.read_bytes()[:len(path.read_bytes()) // 2])
    elif damage == "empty":
        path.write_bytes(b"")
    elif damage == "other campaign":
        _edit_designs(folder, lambda doc: doc.update(campaign="manipulator"))
    elif damage == "changed spec":
        fault_campaign.SPEC["gain"] = 2.0           # the code now defines the designs otherwise
    else:
        path.unlink()
    fault_campaign.SOLVES.clear()
    with pytest.raises(CampaignFolderError, match=message):
        campaign(folder, seeds=N_SEEDS + 1, resume=True)
    assert fault_campaign.SOLVES == []            # never silently synthesized again
    assert (folder / "records.jsonl").read_bytes() == raw
    assert by_key(folder) == before


@pytest.mark.parametrize("damage", ["deleted", "truncated", "nul"])
def test_a_damaged_definition_file_is_refused_naming_it(finished, damage, capsys):
    folder, _, raw = finished
    path = folder / "campaign.json"
    if damage == "deleted":
        path.unlink()
    elif damage == "truncated":
        path.write_bytes(path.read_bytes()[:30])
    else:
        path.write_bytes(b"\x00" * 64)
    capsys.readouterr()
    code = main(["campaign", NAME, "--seeds", "5", "--workers", "0", "--resume", "--no-progress",
                 "--out", str(folder)])
    err = capsys.readouterr().err
    assert code == 2 and "campaign.json" in err and "--resume" not in err.split("campaign.json")[-1]
    assert (folder / "records.jsonl").read_bytes() == raw


def test_a_resume_with_another_definition_is_refused(finished, capsys):
    folder, _, raw = finished
    code = main(["campaign", NAME, "--seeds", "5", "--workers", "0", "--resume", "--no-progress",
                 "--smoke", "--out", str(folder)])
    assert code == 2 and "campaign.json: --resume with a different campaign definition (smoke: False "\
        "before, True now)" in capsys.readouterr().err
    assert (folder / "records.jsonl").read_bytes() == raw


# -- concurrency, kills, full disk ------------------------------------------------------------

def test_a_second_campaign_on_a_held_folder_is_refused_naming_the_holder(tmp_path):
    store = CampaignStore(tmp_path)
    with store.locked():
        with pytest.raises(CampaignLockedError, match=rf"in use by another campaign \(pid {os.getpid()} on"):
            campaign(tmp_path)
    campaign(tmp_path)                              # released with the holder
    assert set(by_key(tmp_path)) == expected_keys()


def _script(out, *extra, seeds=N_SEEDS):
    return [sys.executable, str(SCRIPT), "campaign", NAME, "--seeds", str(seeds), "--workers", "0",
            "--no-progress", "--out", str(out), *extra]


def _wait_lines(path, n, proc, timeout=60):
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        if path.exists() and path.read_bytes().count(b"\n") >= n:
            return
        assert proc.poll() is None, proc.communicate()
        time.sleep(0.02)
    pytest.fail(f"no {n} records after {timeout} s")


def _env(case_seconds):
    return {**os.environ, "MPLBACKEND": "Agg", "FAULT_CASE_SECONDS": str(case_seconds)}


def test_two_concurrent_campaigns_do_the_work_once(tmp_path):
    gate = tmp_path.parent / f"{tmp_path.name}.gate"      # holds the first run after seed 0
    gate.write_text("", encoding="utf-8")
    first = subprocess.Popen(_script(tmp_path, seeds=10), env={**_env(0), "FAULT_GATE": str(gate)},
                             text=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        _wait_lines(tmp_path / "records.jsonl", 1, first)
        second = subprocess.run(_script(tmp_path, "--resume", seeds=10), env=_env(0), text=True,
                                capture_output=True, timeout=120)
    finally:
        gate.unlink()
    assert second.returncode == 2, second.stderr
    assert f"in use by another campaign (pid {first.pid} on" in second.stderr
    assert first.wait(timeout=120) == 0
    assert set(by_key(tmp_path)) == expected_keys(10) and len(lines(tmp_path)) == 20


@pytest.mark.parametrize("target", ["group", "main"])
def test_sigkill_then_resume_loses_and_duplicates_nothing(tmp_path, target):
    proc = subprocess.Popen(_script(tmp_path, seeds=10), env=_env(0.1), start_new_session=True,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    _wait_lines(tmp_path / "records.jsonl", 3, proc)
    (os.killpg if target == "group" else os.kill)(proc.pid, signal.SIGKILL)
    proc.wait(timeout=30)
    before = by_key(tmp_path)
    done = subprocess.run(_script(tmp_path, "--resume", seeds=10), env=_env(0), text=True,
                          capture_output=True, timeout=120)
    assert done.returncode == 0, done.stderr
    after = by_key(tmp_path)
    assert set(after) == expected_keys(10) and len(lines(tmp_path)) == 20
    assert all(after[k] == v for k, v in before.items())


def _limit_file_size(limit):
    def apply():
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
    return apply


def test_a_full_disk_keeps_every_whole_record_and_resumes(tmp_path):
    # the file-size limit makes a write fail part-way, as a full disk does (EFBIG for ENOSPC)
    probe = tmp_path / "probe"
    campaign(probe, seeds=1)
    per_line = max(len(x) for x in lines(probe))
    bigger = max((probe / f).stat().st_size for f in ("designs.json", "campaign.json"))
    whole = bigger // per_line + 2                         # the other files still fit
    limit = whole * per_line + per_line // 2               # record whole + 1 is cut short
    out = tmp_path / "full"
    proc = subprocess.run(_script(out, seeds=10), env=_env(0), text=True, capture_output=True,
                          timeout=120, preexec_fn=_limit_file_size(limit))
    assert proc.returncode == 1, proc.stderr
    assert "cannot write" in proc.stderr and "records.jsonl" in proc.stderr and "--resume" in proc.stderr
    before = by_key(out)                                     # whole lines only, none cut
    assert len(before) == whole and (out / "records.jsonl").read_bytes().endswith(b"\n")
    done = subprocess.run(_script(out, "--resume", seeds=10), env=_env(0), text=True,
                          capture_output=True, timeout=120)
    assert done.returncode == 0, done.stderr
    after = by_key(out)
    assert set(after) == expected_keys(10) and all(after[k] == v for k, v in before.items())


def _alive(pid):
    try:
        state = Path(f"/proc/{pid}/stat").read_text().split(")")[-1].split()[0]
    except (FileNotFoundError, ProcessLookupError):
        return False
    return state not in ("Z", "X")


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_pool_workers_die_with_a_killed_campaign_process(tmp_path):
    env = {**os.environ, "MPLBACKEND": "Agg"}
    argv = [sys.executable, "-m", "sobolev_drake", "campaign", "manipulator", "--seeds", "3",
            "--smoke", "--no-progress", "--workers", "2", "--out", str(tmp_path)]
    proc = subprocess.Popen(argv, env=env, start_new_session=True, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    _wait_lines(tmp_path / "records.jsonl", 1, proc, timeout=180)
    worker = json.loads(lines(tmp_path)[0])["pid"]
    assert _alive(worker)
    os.kill(proc.pid, signal.SIGKILL)              # the main process only (an OOM kill)
    proc.wait(timeout=30)
    t0 = time.monotonic()
    while _alive(worker) and time.monotonic() - t0 < 30:
        time.sleep(0.1)
    orphan = _alive(worker)
    if orphan:
        os.kill(worker, signal.SIGKILL)
    assert not orphan, "a pool worker outlived the campaign process"
    before = by_key(tmp_path)
    done = subprocess.run(argv + ["--resume"], env=env, text=True, capture_output=True, timeout=300)
    assert done.returncode == 0, done.stderr
    after = by_key(tmp_path)
    assert len(after) == 6 == len(lines(tmp_path)) and all(after[k] == v for k, v in before.items())


# -- options ------------------------------------------------------------------------------------

def test_duplicate_design_labels_count_once(tmp_path, capsys):
    campaign(tmp_path, seeds=1, designs=["A", "A"])
    assert set(by_key(tmp_path)) == {"A|0"}
    code = main(["campaign", NAME, "--seeds", "2", "--workers", "0", "--designs", "A", "A",
                 "--resume", "--no-progress", "--out", str(tmp_path)])
    assert code == 0 and set(by_key(tmp_path)) == {"A|0", "A|1"}


@pytest.mark.parametrize("argv, message", [
    (["--seeds", "1000000000000"], "seeds: 1000000000000 seeds × 2 designs is more than"),
    (["--out", ""], "argument --out: expected a folder, got ''"),
    (["--scheduler", " "], "scheduler must be None, 'dask-local' or a Dask scheduler address"),
])
def test_unbounded_or_empty_options_are_refused_at_once(tmp_path, argv, message, capsys):
    argv = ["campaign", NAME, "--workers", "0", "--no-progress", *(["--seeds", "1"] if "--seeds" not in argv else []),
            *(["--out", str(tmp_path / "x")] if "--out" not in argv else []), *argv]
    t0 = time.monotonic()
    assert main(argv) == 2
    assert time.monotonic() - t0 < 30             # refused before anything is built
    assert message in capsys.readouterr().err


@pytest.mark.parametrize("duration, message", [(1e12, "is longer than experiment 'manipulator' can use"),
                                               (1e-9, "is too short for experiment 'manipulator'")])
def test_campaign_durations_follow_the_rule_of_run(tmp_path, duration, message):
    with pytest.raises(ValueError, match=message):
        run_campaign("manipulator", seeds=1, out_dir=tmp_path, duration=duration, **QUIET)
    assert not (tmp_path / "records.jsonl").exists()


def test_workers_are_capped_at_the_cpus_and_the_pending_cases(capsys):
    cpus = os.cpu_count()
    assert executors.worker_count(1000, None, 10_000) == cpus
    assert f"--workers 1000 capped at {cpus}" in capsys.readouterr().err
    assert executors.worker_count(8, None, 3) == min(3, cpus)
    assert executors.worker_count(1000, "tcp://somewhere:8786", 10) == 1000   # a remote cluster's own


def test_a_file_in_place_of_the_folder_is_refused(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("mine", encoding="utf-8")
    assert main(["campaign", NAME, "--seeds", "1", "--workers", "0", "--no-progress",
                 "--out", str(blocker / "sub")]) == 2
    assert "cannot write" in capsys.readouterr().err and blocker.read_text(encoding="utf-8") == "mine"


# -- Dask -----------------------------------------------------------------------------------------

def test_an_unreachable_scheduler_is_a_clear_error_in_bounded_time(tmp_path, monkeypatch):
    pytest.importorskip("distributed")
    monkeypatch.setattr(executors, "DASK_CONNECT_TIMEOUT", 3.0)
    t0 = time.monotonic()
    with pytest.raises(ClusterUnavailableError, match=r"cannot reach a Dask scheduler at 'tcp://127\.0\.0\.1:9' within 3 s"):
        campaign(tmp_path, workers=1, scheduler="tcp://127.0.0.1:9", progress=False)
    assert time.monotonic() - t0 < 60


def test_a_scheduler_without_workers_is_a_clear_error(tmp_path, monkeypatch):
    distributed = pytest.importorskip("distributed")
    monkeypatch.setattr(executors, "DASK_CONNECT_TIMEOUT", 2.0)
    with distributed.LocalCluster(n_workers=0, processes=True, dashboard_address=None) as cluster:
        with pytest.raises(ClusterUnavailableError, match="has no worker after 2 s"):
            run_campaign("manipulator", seeds=1, out_dir=tmp_path, workers=1, smoke=True,
                         scheduler=cluster.scheduler_address, progress=False)


# -- summaries ------------------------------------------------------------------------------------

def test_summaries_do_not_depend_on_the_order_records_arrived_in(finished, tmp_path_factory):
    folder, _, _ = finished
    records = [json.loads(x) for x in lines(folder)]
    outs = []
    for seed in range(3):
        order = np.random.default_rng(seed).permutation(len(records))
        out = tmp_path_factory.mktemp(f"order{seed}")
        runner.write_summary(NAME, [records[i] for i in order], ["A", "B"], out,
                             extra={"cases": 8})
        outs.append((out / "summary.json").read_bytes())
    assert outs[0] == outs[1] == outs[2]


def test_a_cluster_that_loses_every_worker_stops_the_run_keeping_the_finished_cases(tmp_path, monkeypatch):
    distributed = pytest.importorskip("distributed")
    import threading

    from sobolev_drake.campaign.errors import ClusterLostError

    monkeypatch.setattr(executors, "DASK_WORKERLESS_TIMEOUT", 3.0)
    records = tmp_path / "records.jsonl"
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        def lose_the_workers():
            t0 = time.monotonic()
            while time.monotonic() - t0 < 120:
                if records.exists() and records.read_bytes().count(b"\n") >= 1:
                    break
                time.sleep(0.05)
            cluster.scale(0)

        killer = threading.Thread(target=lose_the_workers, daemon=True)
        killer.start()
        t0 = time.monotonic()
        with pytest.raises(ClusterLostError, match="has had no worker for 3 s"):
            run_campaign("manipulator", seeds=20, out_dir=tmp_path, workers=1, smoke=True,
                         scheduler=cluster.scheduler_address, progress=False)
        assert time.monotonic() - t0 < 150
        killer.join()
    kept = by_key(tmp_path)
    assert 1 <= len(kept) < 40 and len(kept) == len(lines(tmp_path))


def test_the_fault_table_names_existing_tests():
    import re

    root = Path(__file__).resolve().parents[2]
    text = (root / "docs" / "reliability.md").read_text(encoding="utf-8")
    named = re.findall(r"`(tests/[\w/]+\.py)::(\w+)`", text)
    assert len(named) >= 20
    for path, name in named:
        source = (root / path).read_text(encoding="utf-8")
        assert re.search(rf"^def {name}\(", source, re.M), f"docs/reliability.md names {path}::{name}"
