"""Command line: ``sobolev-drake list | run NAME | demo | reproduce | report``.

Every experiment writes into ``<out>/<experiment-name>/`` (default ``out/``): PNG figures,
markdown + JSON tables, Meshcat recordings as standalone HTML, and ``result.json`` (claims,
metrics, file list) from which ``report`` rebuilds REPRODUCTION.md without rerunning.

Exit codes: 0 success (a thesis claim that does not hold is a finding, not an error);
1 an experiment crashed; 2 bad usage (unknown experiment, bad option).
"""

from __future__ import annotations

import argparse
import shutil
import sys
import time
import traceback
from pathlib import Path

from sobolev_drake import experiments as exps
from sobolev_drake.experiments import Claim, ExperimentResult

__all__ = ["main"]


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="sobolev-drake", description="Robust W2/W∞ control experiments on Drake.")
    sub = p.add_subparsers(dest="command", required=True)
    sub.add_parser("list", help="list the registered experiments")
    r = sub.add_parser("run", help="run one experiment")
    r.add_argument("name", help="experiment name (see `sobolev-drake list`)")
    r.add_argument("--duration", type=float, default=None, help="simulated seconds (default: the experiment's)")
    r.add_argument("--out", default="out", help="output root; files go to OUT/NAME/ (default: out)")
    r.add_argument("--no-record", action="store_true", help="skip Meshcat recordings")
    r.add_argument("--smoke", action="store_true", help="short version (seconds of wall time)")
    d = sub.add_parser("demo", help="run the flagship experiment")
    d.add_argument("--out", default="out")
    d.add_argument("--smoke", action="store_true", help=argparse.SUPPRESS)
    rp = sub.add_parser("reproduce", help="run every experiment and write REPRODUCTION.md")
    rp.add_argument("--out", default="out")
    rp.add_argument("--smoke", action="store_true", help="short versions (for testing the pipeline)")
    rep = sub.add_parser("report", help="rebuild REPRODUCTION.md from OUT/*/result.json (no rerun)")
    rep.add_argument("--out", default="out")
    return p


def _print_outputs(result: ExperimentResult, stream=sys.stdout) -> None:
    kinds = {"recording": (".html",), "plots": (".png", ".svg", ".pdf"), "tables": (".md", ".json")}
    for kind, exts in kinds.items():
        files = [str(p) for p in result.outputs.values() if Path(p).suffix.lower() in exts]
        if files:
            print(f"  {kind}: " + ", ".join(files), file=stream)
    for c in result.claims:
        print(f"  [{'held' if c.held else 'NOT held'}] {c.text}" + (f" ({c.detail})" if c.detail else ""),
              file=stream)


def _run(exp, out_root: Path, *, duration=None, record=True, smoke=False) -> ExperimentResult:
    out_dir = out_root / exp.name
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


def _cmd_run(args) -> int:
    try:
        exp = exps.get(args.name)
    except exps.UnknownExperimentError as err:
        print(f"sobolev-drake: {err}", file=sys.stderr)
        return 2
    if args.duration is not None and not args.duration > 0:
        print(f"sobolev-drake: --duration must be positive, got {args.duration}", file=sys.stderr)
        return 2
    result = _run(exp, Path(args.out), duration=args.duration, record=not args.no_record, smoke=args.smoke)
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
    result = _run(exp, out_root, smoke=args.smoke)
    report = write_reproduction([result], out_root / exp.name / "REPORT.md", title=f"Demo: {exp.name}")
    print(f"Demo '{exp.name}' finished. Outputs in {out_root / exp.name}/")
    _print_outputs(result)
    print(f"  report: {report}")
    html = [p for p in result.outputs.values() if Path(p).suffix == ".html"]
    if html:
        print(f"Open {html[0]} in a browser to replay the flight (works offline).")
    return 0


def _cmd_reproduce(args) -> int:
    from sobolev_drake.report import write_reproduction

    out_root = Path(args.out)
    results, crashed = [], []
    for name, exp in sorted(exps.discover().items()):
        try:
            results.append(_run(exp, out_root, smoke=args.smoke))
        except Exception as err:  # one broken experiment must not hide the others' results
            traceback.print_exc()
            crashed.append(name)
            results.append(ExperimentResult(name, claims=[Claim("experiment ran to completion", False,
                                                                f"{type(err).__name__}: {err}")]))
    path = write_reproduction(results, out_root / "REPRODUCTION.md")
    # same content with links relative to the current directory
    local = write_reproduction(results, Path.cwd() / "REPRODUCTION.md")
    print(f"wrote {path} and {local.name}")
    if crashed:
        print(f"sobolev-drake: {len(crashed)} experiment(s) crashed: {', '.join(crashed)}", file=sys.stderr)
        return 1
    return 0


def _cmd_report(args) -> int:
    from sobolev_drake.report import load_result, write_reproduction

    out_root = Path(args.out)
    files = sorted(out_root.glob("*/result.json"))
    if not files:
        print(f"sobolev-drake: no */result.json under {out_root}; run experiments first", file=sys.stderr)
        return 2
    results = [load_result(f) for f in files]
    path = write_reproduction(results, out_root / "REPRODUCTION.md")
    local = write_reproduction(results, Path.cwd() / "REPRODUCTION.md")
    print(f"wrote {path} and {local.name} from {len(results)} result(s)")
    return 0


def main(argv=None) -> int:
    parser = _parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # argparse exits 2 on bad usage, 0 on --help
        return int(exc.code or 0)
    if args.command == "list":
        return _cmd_list()
    if args.command == "run":
        return _cmd_run(args)
    if args.command == "demo":
        return _cmd_demo(args)
    if args.command == "reproduce":
        return _cmd_reproduce(args)
    if args.command == "report":
        return _cmd_report(args)
    parser.error(f"unknown command {args.command!r}")  # unreachable (argparse validates)
    return 2


if __name__ == "__main__":
    raise SystemExit(main())
