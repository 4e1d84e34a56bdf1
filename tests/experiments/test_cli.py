"""The command line: list, run (smoke), demo, reproduce, and usage errors."""

import json
import re

import pytest

from sobolev_drake import cli
from sobolev_drake import experiments as exps


def test_list(capsys):
    assert cli.main(["list"]) == 0
    out = capsys.readouterr().out
    assert "models-tour" in out


def test_unknown_experiment_exit_2(capsys):
    assert cli.main(["run", "no-such-experiment"]) == 2
    err = capsys.readouterr().err
    assert "unknown experiment 'no-such-experiment'" in err
    assert "models-tour" in err  # lists the known names


@pytest.mark.parametrize("argv, message", [
    ([], "required: command"),
    (["fly"], "invalid choice: 'fly'"),
    (["run"], "required: name"),
    (["run", "models-tour", "--duration", "abc"], "expected a number of seconds, got 'abc'"),
    (["run", "models-tour", "--duration", "-1"], "finite number of seconds > 0, got '-1'"),
    (["run", "models-tour", "--duration", "0"], "finite number of seconds > 0, got '0'"),
    (["run", "models-tour", "--duration", "inf"], "finite number of seconds > 0, got 'inf'"),
    (["run", "models-tour", "--duration", "nan"], "finite number of seconds > 0, got 'nan'"),
    (["run", "manipulator", "--duration", "1e6"], "longer than experiment 'manipulator' can use (at most 400 s"),
    (["run", "linear-simple", "--duration", "1e12"], "longer than experiment 'linear-simple' can use"),
    (["run", "manipulator", "--duration", "1e-300"], "too short for experiment 'manipulator' (at least 0.4 s"),
    (["run", "linear-simple", "--duration", "1e-9"], "too short for experiment 'linear-simple'"),
    (["run", "models-tour", "--smoke", "--out", "/proc/x"], "--out: cannot write to"),
    (["run", "models-tour", "--bogus"], "unrecognized arguments: --bogus"),
    (["report", "--out", "/no/such/dir"], "no */result.json under"),
])
def test_bad_usage_exit_2_one_line(argv, message, capsys):
    """Usage and output-path problems: exit 2 and a single line on stderr, no traceback."""
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert message in err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err


def test_out_is_a_file(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    assert cli.main(["run", "models-tour", "--smoke", "--out", str(blocker)]) == 2
    assert "--out: cannot write to" in capsys.readouterr().err


def test_every_experiment_bounds_its_duration():
    for exp in exps.discover().values():
        assert exp.max_duration is not None and exp.max_duration >= exp.default_duration
        assert 0 < exp.min_duration < exp.default_duration


@pytest.mark.parametrize("kw, pattern", [(dict(name=""), "name must be a non-empty string"),
                                         (dict(name="x", default_duration=-5.0), "default_duration must be"),
                                         (dict(name="x", max_duration=float("inf")), "max_duration must be")])
def test_register_checks_its_arguments(kw, pattern):
    name = kw.pop("name")
    with pytest.raises(ValueError, match=pattern):
        exps.register(name, "summary", **kw)


@pytest.fixture(scope="module")
def tour_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("cli")
    assert cli.main(["run", "models-tour", "--smoke", "--out", str(out)]) == 0
    return out / "models-tour"


def test_run_models_tour_smoke_outputs(tour_dir):
    html = sorted(tour_dir.glob("*.html"))
    png = sorted(tour_dir.glob("*.png"))
    assert {p.stem for p in html} >= {"two_wheeled", "arm", "quadrotor"}
    assert len(png) == len(html)
    for p in html:
        text = p.read_text()
        assert not re.search(r"<script[^>]*\bsrc\s*=\s*[\"']?(https?:)?//", text, re.I), p.name
        assert "set_animation" in text  # the viewer code; the animation itself is base64 data
    for p in png:
        assert p.read_bytes()[:4] == b"\x89PNG"
    table = (tour_dir / "models_tour_energy.md").read_text()
    assert "| arm |" in table


def test_demo_and_reproduce(tmp_path, monkeypatch, capsys):
    tour = exps.get("models-tour")
    monkeypatch.setattr(exps, "flagship", lambda: tour)
    assert cli.main(["demo", "--smoke", "--out", str(tmp_path / "o")]) == 0
    out = capsys.readouterr().out
    assert "Demo 'models-tour' finished" in out and ".html" in out
    assert (tmp_path / "o" / "models-tour" / "REPORT.md").is_file()

    def broken(out_dir, **kw):
        raise RuntimeError("boom")

    fake = exps.Experiment("zz-broken", "always fails", broken)
    monkeypatch.setattr(exps, "discover", lambda: {"models-tour": tour, "zz-broken": fake})
    monkeypatch.chdir(tmp_path)
    assert cli.main(["reproduce", "--smoke", "--out", "o2", "--copy-to", "REPRODUCTION.md"]) == 1  # one crashed
    rep = (tmp_path / "o2" / "REPRODUCTION.md").read_text()
    assert "zz-broken" in rep and "RuntimeError: boom" in rep and "NOT held" in rep
    assert "models-tour/arm.html" in rep
    local = (tmp_path / "REPRODUCTION.md").read_text()
    assert "o2/models-tour/arm.html" in local  # links relative to the current directory


def test_report_rebuilds_from_result_json(tour_dir, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert cli.main(["report", "--out", str(tmp_path / "empty")]) == 2
    assert (tour_dir / "result.json").is_file()
    assert cli.main(["report", "--out", str(tour_dir.parent)]) == 0
    rep = (tour_dir.parent / "REPRODUCTION.md").read_text()
    assert "## models-tour" in rep and "arm without friction" in rep
    assert "(models-tour/arm.html)" in rep


def test_experiment_must_return_result(tmp_path, monkeypatch, capsys):
    fake = exps.Experiment("zz-bad", "returns None", lambda out_dir, **kw: None)
    monkeypatch.setattr(exps, "get", lambda name: fake)
    assert cli.main(["run", "zz-bad", "--out", str(tmp_path)]) == 1
    assert "not ExperimentResult" in capsys.readouterr().err


def test_crashing_experiment_exits_1_with_its_report(tmp_path, monkeypatch, capsys):
    def boom(out_dir, **kw):
        raise RuntimeError("integrator diverged")
    fake = exps.Experiment("zz-crash", "crashes", boom, default_duration=1.0)
    monkeypatch.setattr(exps, "get", lambda name: fake)
    assert cli.main(["run", "zz-crash", "--out", str(tmp_path)]) == 1
    err = capsys.readouterr().err
    assert "RuntimeError: integrator diverged" in err
    data = json.loads((tmp_path / "zz-crash" / "result.json").read_text())
    assert data["claims"] == [{"text": "experiment ran to completion", "held": False,
                               "detail": "RuntimeError: integrator diverged"}]
