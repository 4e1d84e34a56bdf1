"""The command line: list, run (smoke), demo, reproduce, and usage errors."""

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


@pytest.mark.parametrize("argv", [[], ["fly"], ["run"], ["run", "models-tour", "--duration", "abc"]])
def test_bad_usage_exit_2(argv, capsys):
    assert cli.main(argv) == 2


def test_negative_duration(capsys):
    assert cli.main(["run", "models-tour", "--duration", "-1"]) == 2
    assert "--duration must be positive" in capsys.readouterr().err


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
    assert cli.main(["reproduce", "--smoke", "--out", "o2"]) == 1  # one experiment crashed
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
    with pytest.raises(TypeError, match="not ExperimentResult"):
        cli.main(["run", "zz-bad", "--out", str(tmp_path)])
