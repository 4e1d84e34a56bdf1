"""Command line: ``sobolev-drake list | run NAME | demo | reproduce | report | campaign NAME |
campaign-repair DIR``.

Every experiment writes into ``<out>/<experiment-name>/`` (default ``out/``): PNG figures,
markdown + JSON tables, Meshcat recordings as standalone HTML, and ``result.json`` (claims,
metrics, file list) from which ``report`` rebuilds ``<out>/REPRODUCTION.md`` without rerunning.
``reproduce`` and ``report`` write a second copy only where ``--copy-to FILE`` says (``make
reproduce`` / ``make report`` keep the repository's own REPRODUCTION.md so), and no command
replaces a report it did not write (:func:`sobolev_drake.report.check_replaceable`).
``campaign NAME`` runs an experiment's designs over many seeds into ``--out``
(:mod:`sobolev_drake.campaign`).

Exit codes: 0 success (a thesis claim that does not hold is a finding, not an error);
1 an experiment crashed; 2 bad usage (unknown experiment, bad option).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
import traceback
from collections.abc import Sequence
from pathlib import Path
from typing import NoReturn

from sobolev_drake import experiments as exps
from sobolev_drake.errors import SobolevDrakeError
from sobolev_drake.experiments import Claim, ExperimentResult

__all__ = ["main"]


class UsageError(SobolevDrakeError):
    """Bad command-line usage: reported as one line on stderr, exit code 2."""


class _Parser(argparse.ArgumentParser):
    """argparse with one-line usage errors (no usage block, no traceback)."""

    def error(self, message: str) -> NoReturn:
        raise UsageError(message)


def _duration(text: str) -> float:
    """``--duration`` value: a finite number of seconds > 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number of seconds, got {text!r}") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"expected a finite number of seconds > 0, got {text!r}")
    return value


def _out_dir(text: str) -> str:
    """``--out`` value: a folder name (an empty one would silently mean the current folder)."""
    if not text.strip():
        raise argparse.ArgumentTypeError(f"expected a folder, got {text!r} (use --out . for the "
                                         "current folder)")
    return text


def _copy_file(text: str) -> str:
    """``--copy-to`` value: a file name."""
    if not text.strip() or text.endswith(("/", "\\")):
        raise argparse.ArgumentTypeError(f"expected a file name such as REPRODUCTION.md, got {text!r}")
    return text


_COPY_HELP = ("also write the report to FILE, its links relative to FILE's folder (`make "
              "reproduce` passes docs/experiments/REPRODUCTION.md); a FILE sobolev-drake did not write is never "
              "replaced")


def _installed_version() -> str:
    """The installed distribution's version (its metadata), or the package's ``__version__``
    when it runs from a source tree that was not installed."""
    from importlib.metadata import PackageNotFoundError, version
    try:
        return version("sobolev_drake")
    except PackageNotFoundError:
        from sobolev_drake import __version__
        return __version__


def _parser() -> argparse.ArgumentParser:
    p = _Parser(prog="sobolev-drake", description="Robust W2/W∞ control experiments on Drake.")
    p.add_argument("--version", action="version", version=f"%(prog)s {_installed_version()}")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)
    sub.add_parser("list", help="list the registered experiments")
    r = sub.add_parser("run", help="run one experiment")
    r.add_argument("name", help="experiment name (see `sobolev-drake list`)")
    r.add_argument("--duration", type=_duration, default=None,
                   help="simulated seconds (default: the experiment's; at most 10x that)")
    r.add_argument("--out", type=_out_dir, default="out",
                   help="output root; files go to OUT/NAME/ (default: out)")
    r.add_argument("--no-record", action="store_true", help="skip Meshcat recordings")
    r.add_argument("--smoke", action="store_true", help="short version (seconds of wall time)")
    d = sub.add_parser("demo", help="run the flagship experiment")
    d.add_argument("--out", type=_out_dir, default="out",
                   help="output root; files go to OUT/NAME/ (default: out)")
    d.add_argument("--smoke", action="store_true", help=argparse.SUPPRESS)
    rp = sub.add_parser("reproduce", help="run every experiment and write OUT/REPRODUCTION.md")
    rp.add_argument("--out", type=_out_dir, default="out", help="output root (default: out)")
    rp.add_argument("--copy-to", type=_copy_file, default=None, metavar="FILE", help=_COPY_HELP)
    rp.add_argument("--smoke", action="store_true", help="short versions (for testing the pipeline)")
    rep = sub.add_parser("report", help="rebuild OUT/REPRODUCTION.md from OUT/*/result.json (no rerun)")
    rep.add_argument("--out", type=_out_dir, default="out",
                     help="output root holding the results (default: out)")
    rep.add_argument("--copy-to", type=_copy_file, default=None, metavar="FILE", help=_COPY_HELP)
    c = sub.add_parser("campaign", help="run an experiment's designs over many seeds (Monte Carlo)")
    c.add_argument("name", help="experiment name with a campaign (see `sobolev-drake list`)")
    c.add_argument("--seeds", type=_count, required=True, help="number of seeds")
    c.add_argument("--first-seed", type=_count0, default=0, help="first seed (default 0)")
    c.add_argument("--workers", type=_count0, default=1,
                   help="worker processes (default 1; 0 runs in this process)")
    c.add_argument("--scheduler", default=None,
                   help="'dask-local' (a LocalCluster of --workers processes) or the address of a "
                        "running Dask scheduler (default: a local process pool)")
    c.add_argument("--perturb", action="append", default=None, metavar="NAME=FRACTION",
                   help="scale parameter NAME by a factor drawn in [1-FRACTION, 1+FRACTION] per seed "
                        "(repeatable; default: the campaign's; --perturb none for none)")
    c.add_argument("--designs", nargs="+", default=None, help="a subset of the designs")
    c.add_argument("--duration", type=_duration, default=None, help="simulated seconds per case")
    c.add_argument("--tasks-per-worker", type=_count, default=20,
                   help="cases per worker process before the pool is renewed (default 20; raise it "
                        "when a campaign's designs are slow to synthesize)")
    c.add_argument("--resume", action="store_true", help="skip the cases already recorded in --out")
    c.add_argument("--smoke", action="store_true", help="short cases (for testing the pipeline)")
    c.add_argument("--no-progress", action="store_true", help="no progress bar")
    c.add_argument("--out", type=_out_dir, required=True, help="output folder of the campaign")
    cr = sub.add_parser("campaign-repair",
                        help="move the lines of a campaign's records.jsonl that are not records "
                             "(or repeat a case) to records.rejected.jsonl, keeping the others")
    cr.add_argument("out", type=_out_dir, help="the campaign's output folder")
    return p


def _integer_at_least(low: int, what: str):
    """argparse type: an integer >= ``low`` (``what`` names the expectation in the message)."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = None
        if value is None or value < low:
            raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}")
        return value
    return parse


_count = _integer_at_least(1, "a positive integer")
_count0 = _integer_at_least(0, "an integer >= 0")


def _perturbations(items):
    """--perturb NAME=FRACTION list -> {NAME: FRACTION} (None: the campaign's default)."""
    if items is None:
        return None
    out = {}
    for item in items:
        if item == "none":
            continue
        name, sep, frac = item.partition("=")
        try:
            value = float(frac)
        except ValueError:
            value = math.nan
        if not sep or not name or not (0.0 <= value < 1.0):
            raise ValueError(f"--perturb expects NAME=FRACTION with 0 <= FRACTION < 1, got {item!r}")
        out[name] = value
    return out


def _cmd_campaign(args) -> int:
    from sobolev_drake.campaign import run_campaign
    from sobolev_drake.campaign.errors import CampaignError, ClusterLostError
    from sobolev_drake.campaign.registry import UnknownCampaignError

    _writable_dir(Path(args.out))
    try:
        summary = run_campaign(args.name, seeds=args.seeds, first_seed=args.first_seed,
                               designs=args.designs, workers=args.workers, scheduler=args.scheduler,
                               perturb=_perturbations(args.perturb), resume=args.resume,
                               duration=args.duration, smoke=args.smoke,
                               progress=not args.no_progress, out_dir=args.out,
                               tasks_per_worker=args.tasks_per_worker)
    except ClusterLostError as err:
        print(f"sobolev-drake: campaign {args.name!r} stopped: {err}; the finished cases are in "
              f"{Path(args.out) / 'records.jsonl'}; give the cluster workers and rerun with --resume",
              file=sys.stderr)
        return 1
    except (UnknownCampaignError, ValueError, FileExistsError, CampaignError) as err:
        # nothing to resume: the folder or the options must change first
        print(f"sobolev-drake: {err}", file=sys.stderr)
        return 2
    except OSError as err:    # e.g. a full disk while appending: every whole line is kept
        print(f"sobolev-drake: campaign {args.name!r} stopped: cannot write "
              f"{err.filename or args.out} ({err.strerror or err}); the finished cases are in "
              f"{Path(args.out) / 'records.jsonl'}; make room and rerun with --resume", file=sys.stderr)
        return 1
    except Exception as err:  # a worker or the cluster died: what finished is on disk
        print(f"sobolev-drake: campaign {args.name!r} interrupted ({type(err).__name__}: {err}); "
              f"the finished cases are in {Path(args.out) / 'records.jsonl'}; rerun with --resume",
              file=sys.stderr)
        return 1
    out = Path(args.out)
    print(f"campaign {args.name}: {summary['cases']} cases ({summary['ran']} run now, "
          f"{summary['wall_s']:.1f} s); summary in {out / 'summary.json'} and {out / 'summary.md'}")
    return 0


def _cmd_campaign_repair(args) -> int:
    from sobolev_drake.campaign.errors import CampaignError
    from sobolev_drake.campaign.store import CampaignStore

    folder = Path(args.out)
    if not (folder / "records.jsonl").is_file():
        raise UsageError(f"campaign-repair: {str(folder)!r} holds no records.jsonl (give the "
                         "campaign's --out folder)")
    try:
        store = CampaignStore(folder)
        with store.locked():
            done = store.repair()
    except CampaignError as err:
        raise UsageError(str(err)) from None
    if done["rejected"]:
        print(f"{folder / 'records.jsonl'}: kept {done['kept']} records, moved {done['rejected']} "
              f"line(s) to {done['side_file']}; resume the campaign to rerun those cases")
    else:
        print(f"{folder / 'records.jsonl'}: all {done['kept']} lines are records; nothing moved")
    return 0


def _print_outputs(result: ExperimentResult, stream=sys.stdout) -> None:
    kinds = {"recording": (".html",), "plots": (".png", ".svg", ".pdf"), "tables": (".md", ".json")}
    for kind, exts in kinds.items():
        files = [str(p) for p in result.outputs.values() if Path(p).suffix.lower() in exts]
        if files:
            print(f"  {kind}: " + ", ".join(files), file=stream)
    for c in result.claims:
        print(f"  [{'held' if c.held else 'NOT held'}] {c.text}" + (f" ({c.detail})" if c.detail else ""),
              file=stream)


def _writable_dir(path: Path) -> Path:
    """Create ``path`` (and parents) and check a file can be written there; UsageError if not."""
    if path.exists() and not path.is_dir():
        raise UsageError(f"--out: {str(path)!r} exists and is not a folder")
    try:
        path.mkdir(parents=True, exist_ok=True)
        probe = path / ".sobolev-drake-write-test"
        probe.write_text("")
        probe.unlink()
    except OSError as err:
        raise UsageError(f"--out: cannot write to {str(path)!r} ({err.strerror or err})") from None
    return path


def _run(exp, out_root: Path, *, duration=None, record=True, smoke=False) -> ExperimentResult:
    out_dir = out_root / exp.name          # callers checked that the output root is writable
    out_dir.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    print(f"== {exp.name}: {exp.summary}" + (" [smoke]" if smoke else ""), file=sys.stderr)
    result = exp.run(out_dir, duration=duration, record=record, smoke=smoke)
    if not isinstance(result, ExperimentResult):
        raise TypeError(f"experiment {exp.name!r} returned {type(result).__name__}, not ExperimentResult")
    from sobolev_drake.report import save_result

    save_result(result, out_dir)
    print(f"== {exp.name} done in {time.perf_counter() - t0:.1f} s → {out_dir}", file=sys.stderr)
    return result


def _cmd_list() -> int:
    reg = exps.discover()
    if not reg:
        print("no experiments registered")
        return 0
    width = max(len(n) for n in reg)
    for name in sorted(reg):
        e = reg[name]
        flag = " *demo*" if e.flagship > 0 and e is exps.flagship() else ""
        ref = f" [{e.thesis_ref}]" if e.thesis_ref else ""
        print(f"{name:<{width}}  {e.summary}{ref}{flag}")
    return 0


def _crash_result(name: str, err: BaseException, out_dir: Path | None) -> ExperimentResult:
    """Print the traceback and record the crash as a failed claim (in ``out_dir`` if given)."""
    traceback.print_exc()
    result = ExperimentResult(name, claims=[Claim("experiment ran to completion", False,
                                                  f"{type(err).__name__}: {err}")])
    if out_dir is not None:
        from sobolev_drake.report import save_result

        save_result(result, out_dir)
    return result


def _cmd_run(args) -> int:
    try:
        exp = exps.get(args.name)
    except exps.UnknownExperimentError as err:
        raise UsageError(str(err)) from None
    try:
        exp.check_duration(args.duration, "--duration")
    except ValueError as err:
        raise UsageError(str(err)) from None
    out_dir = _writable_dir(Path(args.out) / exp.name)
    try:
        result = _run(exp, Path(args.out), duration=args.duration, record=not args.no_record,
                      smoke=args.smoke)
    except Exception as err:  # a crash is exit 1 with the failure recorded, not a bare traceback
        _crash_result(exp.name, err, out_dir)
        print(f"sobolev-drake: experiment {exp.name!r} crashed ({type(err).__name__}: {err}); "
              f"recorded in {out_dir / 'result.json'}", file=sys.stderr)
        return 1
    _print_outputs(result)
    return 0


def _cmd_demo(args) -> int:
    try:
        exp = exps.flagship()
    except exps.UnknownExperimentError as err:
        print(f"sobolev-drake: {err}", file=sys.stderr)
        return 2
    from sobolev_drake.report import write_reproduction

    out_root = Path(args.out)
    out_dir = _writable_dir(out_root / exp.name)
    _replaceable(out_dir / "REPORT.md", "--out")
    try:
        result = _run(exp, out_root, smoke=args.smoke)
    except Exception as err:
        result = _crash_result(exp.name, err, out_dir)
        write_reproduction([result], out_dir / "REPORT.md", title=f"Demo: {exp.name}")
        print(f"sobolev-drake: the demo crashed ({type(err).__name__}: {err}); report in "
              f"{out_dir / 'REPORT.md'}", file=sys.stderr)
        return 1
    report = write_reproduction([result], out_root / exp.name / "REPORT.md", title=f"Demo: {exp.name}")
    print(f"Demo '{exp.name}' finished. Outputs in {out_root / exp.name}/")
    _print_outputs(result)
    print(f"  report: {report}")
    html = [p for p in result.outputs.values() if Path(p).suffix == ".html"]
    if html:
        print(f"Open {html[0]} in a browser to replay the flight (works offline).")
    return 0


def _cmd_reproduce(args) -> int:
    out_root = _writable_dir(Path(args.out))
    targets = _report_targets(out_root, args.copy_to)   # checked before hours of running
    results, crashed = [], []
    for name, exp in sorted(exps.discover().items()):
        try:
            results.append(_run(exp, out_root, smoke=args.smoke))
        except Exception as err:  # one broken experiment must not hide the others' results
            crashed.append(name)
            results.append(_crash_result(name, err, None))
    written = _write_reports(results, targets, out_root)
    print("wrote " + " and ".join(str(p) for p in written))
    if crashed:
        print(f"sobolev-drake: {len(crashed)} experiment(s) crashed: {', '.join(crashed)}", file=sys.stderr)
        return 1
    return 0


def _cmd_report(args) -> int:
    from sobolev_drake.report import load_result

    out_root = Path(args.out)
    files = sorted(out_root.glob("*/result.json"))
    if not files:
        print(f"sobolev-drake: no */result.json under {out_root}; run experiments first", file=sys.stderr)
        return 2
    results = []
    for f in files:
        try:
            results.append(load_result(f))
        except OSError as err:
            raise UsageError(f"cannot read {f} ({err.strerror or err})") from None
        except ValueError as err:   # the message names the file (and line/column for bad JSON)
            raise UsageError(f"{err}; fix or delete it, or rerun its experiment "
                             f"(sobolev-drake run {f.parent.name})") from None
    _writable_dir(out_root)
    targets = _report_targets(out_root, args.copy_to)
    written = _write_reports(results, targets, out_root)
    print("wrote " + " and ".join(str(p) for p in written) + f" from {len(results)} result(s)")
    return 0


def _replaceable(path: Path, option: str) -> Path:
    """``path`` if a report may be written there (absent or ours), else a UsageError."""
    from sobolev_drake.report import check_replaceable

    try:
        return check_replaceable(path)
    except FileExistsError as err:
        raise UsageError(f"{err} (choose another {option})") from None


def _report_targets(out_root: Path, copy_to) -> list:
    """OUT/REPRODUCTION.md and the ``--copy-to`` file, each checked to be replaceable."""
    targets = [_replaceable(out_root / "REPRODUCTION.md", "--out")]
    if copy_to is not None:
        copy = Path(copy_to)
        if copy.resolve() == targets[0].resolve():
            return targets
        try:
            copy.parent.mkdir(parents=True, exist_ok=True)
        except OSError as err:
            raise UsageError(f"--copy-to: cannot write to {str(copy)!r} ({err.strerror or err})") from None
        targets.append(_replaceable(copy, "--copy-to"))
    return targets


def _write_reports(results, targets, out_root: Path) -> list:
    """Write the report to every target; an unwritable one is a UsageError naming it."""
    from sobolev_drake.report import write_reproduction

    campaigns, why = _campaign_sections(out_root), exps.thesis_differences()
    written = []
    for t in targets:
        try:
            written.append(write_reproduction(results, t, campaigns=campaigns, differences=why))
        except OSError as err:   # FileExistsError included: replaced by a foreign file meanwhile
            raise UsageError(f"cannot write {t} ({err.strerror or err})") from None
    return written


def _campaign_sections(out_root: Path) -> list:
    """The summary.md of every campaign under OUT/campaigns/ (in name order)."""
    return [p.read_text(encoding="utf-8") for p in sorted(out_root.glob("campaigns/*/summary.md"))]


_COMMANDS = {"list": lambda args: _cmd_list(), "run": _cmd_run, "demo": _cmd_demo,
             "reproduce": _cmd_reproduce, "report": _cmd_report,
             "campaign": _cmd_campaign, "campaign-repair": _cmd_campaign_repair}


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``sobolev-drake``; returns the exit code (0 ok, 1 crash, 2 usage)."""
    try:
        args = _parser().parse_args(argv)
        return _COMMANDS[args.command](args)
    except SystemExit as exc:  # --help / --version
        return int(exc.code or 0)
    except UsageError as err:
        print(f"sobolev-drake: error: {err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("sobolev-drake: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    raise SystemExit(main())
