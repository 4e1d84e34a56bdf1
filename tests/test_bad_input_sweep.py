"""Bad input, second sweep ("Reliability II"): messages that used to be numpy/pybind internals
(zero-size reductions, "truth value of an array is ambiguous", AttributeError, IndexError,
LinAlgError) or named the wrong argument now name the argument and show the value.

Each case is (id, call, exception type, the argument named, the value shown); both must appear
in the message.  Then the command line: ``report`` writes into ``--out`` only, never replaces a
report it did not write, explains a malformed ``result.json``, and an empty ``--out`` is refused.
"""

import json

import numpy as np
import pytest

import sobolev_drake as sd
from sobolev_drake import cli, norms, plots, recording_html, report, validation, viz
from sobolev_drake import experiments as exps
from sobolev_drake.report import GENERATED_MARKER, Claim, ExperimentResult, save_result
from sobolev_drake.systems.references import TrajectoryReference

A2 = np.array([[0.0, 1.0], [-1.0, -0.5]])
B2 = np.array([[0.0], [1.0]])
G0, G1 = np.eye(2), 0.1 * np.eye(2)
T = np.linspace(0.0, 1.0, 11)
Z00, Z01, Z20 = np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((2, 0))
PNG = "unused.png"   # every case fails before anything is written


def _curves(curves):
    return plots.plot_semilogy(PNG, curves, ylabel="y")


CASES = [
    # --- synthesis: empty plants fail before the weights' checks ("zero-size array to reduction")
    ("winf_state_feedback 0x0", lambda: sd.winf_state_feedback(Z00, Z01, Z01, Z00, Z00), ValueError, "A", "(0, 0)"),
    ("winf_output_feedback 0x0", lambda: sd.winf_output_feedback(Z00, Z01, Z00, Z01, Z00, Z00), ValueError, "A", "(0, 0)"),
    ("hinf_state_feedback_qr 0x0", lambda: sd.hinf_state_feedback_qr(Z00, Z01, Z01, Z00, np.eye(1)), ValueError, "A", "(0, 0)"),
    ("winf_plant no input", lambda: sd.winf_plant(A2, Z20, D=B2, Gamma0=G0, Gamma1=G1), ValueError, "B", "(2, 0)"),
    ("hinf_plant no disturbance", lambda: sd.hinf_plant(A2, B2, D=Z20, Q=G0, R=np.eye(1)), ValueError, "D", "(2, 0)"),
    ("Gamma0 asymmetric shows it", lambda: sd.winf_plant(A2, B2, D=B2, Gamma0=[[1.0, 2.0], [0.0, 1.0]], Gamma1=G1), ValueError,
     "Gamma0 must be symmetric", "[[1., 2.], [0., 1.]]"),
    # --- None is not "complex entries"
    ("to_statespace None", lambda: sd.to_statespace(None), TypeError, "result_or_controller must be a SynthesisResult", "got None"),
    ("ise None", lambda: norms.ise(T, None), TypeError, "e must be", "got None"),
    # --- mechanical gains
    ("controlled_gains empty", lambda: sd.controlled_gains([], 1.0, 1.0, 1.0), ValueError, "Y0", "(0,)"),
    ("regulated_gains empty", lambda: sd.regulated_gains(np.zeros((0, 0)), 1.0, 1.0), ValueError, "S0", "(0, 0)"),
    ("gains norm array", lambda: sd.stabilized_gains(1.0, 1.0, norm=np.array(["W2", "Winf"])), ValueError, "norm", "array(["),
    # --- references, disturbances, controllers
    ("trajectory names None", lambda: sd.PiecewiseTrajectory(None, [[sd.const(0.0)]]), TypeError, "names", "None"),
    ("trajectory pieces int", lambda: sd.PiecewiseTrajectory(["x"], 0), TypeError, "pieces", "0 (int)"),
    ("trajectory piece float", lambda: sd.PiecewiseTrajectory(["x"], [1.5]), TypeError, "pieces[0]", "1.5"),
    ("trajectory description", lambda: sd.PiecewiseTrajectory(["x"], [[sd.const(0.0)]], description=5), TypeError,
     "description", "int"),
    ("TrajectoryReference None", lambda: TrajectoryReference(None), TypeError, "trajectory", "NoneType"),
    ("pulses None", lambda: sd.TimeProfiledForce(2, None), TypeError, "pulses", "None"),
    ("pulse value str", lambda: sd.TimeProfiledForce(2, [{"index": 0, "value": "abc"}]), TypeError,
     "pulses[0]['value']", "'abc'"),
    ("pulse from None", lambda: sd.TimeProfiledForce(2, [{"index": 0, "value": 1.0, "from": None}]), TypeError,
     "pulses[0]['from']", "None"),
    ("controller_system None", lambda: sd.controller_system(None), TypeError, "result", "NoneType"),
    ("controller_system x_op", lambda: sd.controller_system([[1.0, 0.0]], x_op=[0.0, 0.0, 0.0]), ValueError, "x_op", "(1, 3)"),
    ("controller_system u_op", lambda: sd.controller_system([[1.0, 0.0]], u_op="abc"), TypeError, "u_op", "'abc'"),
    ("MechanicalController law", lambda: sd.MechanicalController(law="x"), TypeError, "law", "str"),
    # --- norms
    ("check_time str", lambda: norms.check_time("abc"), TypeError, "t", "'abc'"),
    ("finite_difference order None", lambda: norms.finite_difference(T, T, order=None), TypeError, "order", "None"),
    ("finite_difference order str", lambda: norms.finite_difference(T, T, order="1"), TypeError, "order", "'1'"),
    ("finite_difference order nan", lambda: norms.finite_difference(T, T, order=float("nan")), ValueError, "order", "nan"),
    ("sobolev_norm sigmas None", lambda: norms.sobolev_norm(T, T, None), TypeError, "sigmas", "None"),
    ("sobolev_norm sigmas str", lambda: norms.sobolev_norm(T, T, "ab"), TypeError, "sigmas", "'ab'"),
    ("sobolev_norm sigma entry str", lambda: norms.sobolev_norm(T, T, ["a"]), TypeError, "sigmas[0]", "'a'"),
    ("sobolev_norm derivatives int", lambda: norms.sobolev_norm(T, T, [1.0, 1.0], derivatives=0), TypeError,
     "derivatives", "0 (int)"),
    ("l2_norm names w", lambda: norms.l2_norm(T, 3.0), ValueError, "w must have shape", "()"),
    ("l2_norm sigma str", lambda: norms.l2_norm(T, T, sigma="abc"), TypeError, "sigma", "'abc'"),
    ("empirical_gain w_sigma", lambda: norms.empirical_gain(T, T, T + 1, w_sigma=-1.0), ValueError, "w_sigma", "-1.0"),
    ("settling_time crossing array", lambda: norms.settling_time(T, T, fraction=0.1, crossing=np.array(["a", "b"])),
     ValueError, "crossing", "array(["),
    ("fraction_at_bounds lo nan", lambda: norms.fraction_at_bounds(T, float("nan"), 1.0), ValueError, "lo", "nan"),
    ("fraction_at_bounds rtol negative", lambda: norms.fraction_at_bounds(T, 0.0, 1.0, rtol=-1.0), ValueError, "rtol", "-1.0"),
    ("fraction_at_bounds rtol str", lambda: norms.fraction_at_bounds(T, 0.0, 1.0, rtol="x"), TypeError, "rtol", "'x'"),
    ("fraction_at_bounds no samples", lambda: norms.fraction_at_bounds([], 0.0, 1.0), ValueError, "u", "(0, 1)"),
    # --- plots
    ("save_figure fig None", lambda: plots.save_figure(None, PNG), TypeError, "fig", "NoneType"),
    ("plot path None", lambda: plots.plot_semilogy(None, {}, ylabel="y"), TypeError, "path", "None"),
    ("plot_semilogy curves None", lambda: _curves(None), TypeError, "curves", "None"),
    ("plot_semilogy curve not a pair", lambda: _curves({"a": 1.0}), ValueError, "curves['a']", "1.0"),
    ("plot_paths_3d reference None", lambda: plots.plot_paths_3d(PNG, None, {}), TypeError, "reference", "None"),
    ("plot_paths_3d reference shape", lambda: plots.plot_paths_3d(PNG, np.zeros(5), {}), ValueError, "reference", "(5,)"),
    ("plot_paths_3d flown list", lambda: plots.plot_paths_3d(PNG, np.zeros((5, 3)), [1]), TypeError, "flown", "[1]"),
    ("plot_time_series scalar series", lambda: plots.plot_time_series(T, {"a": 1.0}, PNG), ValueError, "series['a']", "()"),
    ("plot_time_series series str", lambda: plots.plot_time_series(T, "abc", PNG), TypeError, "series", "'abc'"),
    ("compare_plot panels None", lambda: plots.compare_plot(PNG, {}, None), TypeError, "panels", "None"),
    ("compare_plot run without t", lambda: plots.compare_plot(PNG, {"r": {"x": T}}, [("x", lambda r: r["x"], None)]),
     ValueError, "runs['r']", "{'x': array("),
    # --- recordings and Meshcat
    ("meshcat_commands None", lambda: recording_html.meshcat_commands(None), TypeError, "html", "NoneType"),
    ("external_script_sources bytes", lambda: recording_html.external_script_sources(b"<html>"), TypeError, "html", "bytes"),
    ("animates_path path None", lambda: recording_html.animates_path("<html></html>", None), TypeError, "path", "NoneType"),
    ("start_meshcat host", lambda: viz.start_meshcat(host="no such host!"), ValueError, "host", "'no such host!'"),
    ("start_meshcat host None", lambda: viz.start_meshcat(host=None), TypeError, "host", "None"),
    ("camera azimuth nan", lambda: viz.camera_position([0, 0, 0], azimuth_deg=float("nan")), ValueError, "azimuth_deg", "nan"),
    ("camera radius str", lambda: viz.camera_position([0, 0, 0], radius="1"), TypeError, "radius", "'1'"),
    ("camera target str", lambda: viz.camera_position("abc"), TypeError, "target", "'abc'"),
    ("draw_path points str", lambda: viz.draw_path(None, "p", "abc"), TypeError, "points", "'abc'"),
    ("draw_path meshcat None", lambda: viz.draw_path(None, "p", np.zeros((2, 3))), TypeError, "meshcat", "NoneType"),
    # --- the shared helpers
    ("one_of array", lambda: validation.one_of("mode", np.array(["a", "b"]), ("a", "b")), ValueError, "mode", "array(["),
    ("sequence str", lambda: validation.sequence("items", "abc"), TypeError, "items", "'abc'"),
    ("path_like int", lambda: validation.path_like("path", 3), TypeError, "path", "3 (int)"),
]


@pytest.mark.parametrize("name, call, exc, argument, value", CASES, ids=[c[0] for c in CASES])
def test_message_names_argument_and_value(name, call, exc, argument, value):
    with pytest.raises(exc) as info:
        call()
    message = str(info.value)
    assert argument in message and value in message, message
    assert "\n" not in message


def test_start_meshcat_names_host_and_port_when_it_cannot_listen():
    first = viz.start_meshcat()
    with pytest.raises(RuntimeError, match=rf"host 'localhost', port {first.port()}"):
        viz.start_meshcat(port=first.port())


def test_zero_state_weight_is_not_a_singular_matrix_error():
    """Q = 0 (z weighs u only): the closed loop's transfer function is 0, whose H∞ norm the
    certificate used to compute with a singular matrix."""
    result = sd.hinf_state_feedback_qr(A2, B2, B2, 0.0, np.eye(1))
    assert np.allclose(result.K, 0.0) and result.gamma < 1e-100


def test_describe_is_one_line():
    assert validation.describe(np.eye(2)) == "array([[1., 0.], [0., 1.]])"


# --------------------------------------------------------------------------- command line

def _results(root, names=("alpha",)):
    for name in names:
        save_result(ExperimentResult(name, outputs={"plot": root / name / "plot.png"},
                                     claims=[Claim("it works", True)]), root / name)
    return root


def _fail(argv, capsys):
    """Run the CLI expecting exit 2; return its one-line stderr."""
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    return err


def test_report_writes_into_out_only(tmp_path, monkeypatch, capsys):
    out = _results(tmp_path / "res")
    monkeypatch.chdir(tmp_path)
    assert cli.main(["report", "--out", "res"]) == 0
    text = (out / "REPRODUCTION.md").read_text(encoding="utf-8")
    assert text.splitlines()[0] == GENERATED_MARKER and "## alpha" in text
    assert "[plot](alpha/plot.png)" in text                  # links relative to --out
    assert not (tmp_path / "REPRODUCTION.md").exists()       # the current folder is left alone
    assert cli.main(["report", "--out", "res"]) == 0         # its own file is replaced
    # the explicit copy (what `make report` writes at the repository root), links relative to it
    assert cli.main(["report", "--out", "res", "--copy-to", "REPRODUCTION.md"]) == 0
    assert "[plot](res/alpha/plot.png)" in (tmp_path / "REPRODUCTION.md").read_text(encoding="utf-8")
    assert "res/REPRODUCTION.md and REPRODUCTION.md" in capsys.readouterr().out


@pytest.mark.parametrize("where", ["out", "copy"])
def test_report_refuses_to_replace_a_foreign_reproduction_md(where, tmp_path, monkeypatch, capsys):
    out = _results(tmp_path / "res")
    monkeypatch.chdir(tmp_path)
    foreign = out / "REPRODUCTION.md" if where == "out" else tmp_path / "REPRODUCTION.md"
    original = b"# My notes\n\nnot generated\r\n\xe2\x9c\x93\n"
    foreign.write_bytes(original)
    argv = ["report", "--out", "res"] + (["--copy-to", "REPRODUCTION.md"] if where == "copy" else [])
    err = _fail(argv, capsys)
    assert f"refusing to replace {foreign.relative_to(tmp_path)}" in err
    assert "move or delete it" in err and ("--out" if where == "out" else "--copy-to") in err
    assert foreign.read_bytes() == original
    if where == "copy":   # nothing written at all: the targets are checked first
        assert not (out / "REPRODUCTION.md").exists()


def test_report_replaces_a_report_written_before_the_marker(tmp_path, monkeypatch, capsys):
    out = _results(tmp_path / "res")
    legacy = ("# Reproduction of the thesis experiments\n\nGenerated 2026-01-01 00:00 UTC by "
              "`sobolev-drake`. 1 experiment(s); claims held: 0/1.\n")
    (out / "REPRODUCTION.md").write_text(legacy, encoding="utf-8")
    assert cli.main(["report", "--out", str(out)]) == 0
    assert (out / "REPRODUCTION.md").read_text(encoding="utf-8").startswith(GENERATED_MARKER)


def test_write_reproduction_refuses_a_foreign_file(tmp_path):
    path = tmp_path / "R.md"
    path.write_text("mine\n")
    with pytest.raises(FileExistsError, match="refusing to replace .*R.md"):
        report.write_reproduction([], path)
    assert path.read_text() == "mine\n"


@pytest.mark.parametrize("content, expected", [
    ('{\n "name": "x",\n oops\n}', "not valid JSON at line 3, column 2"),
    ("[1, 2]", "expected a JSON object, got a JSON array"),
    ('{"name": "x", "outputs": []}', "'outputs' must be a JSON object"),
    ('{"name": "x", "metrics": [1]}', "'metrics' must be a JSON object"),
    ('{"claims": []}', "the key 'name' is missing"),
    ('{"name": "x", "claims": [1]}', "claims[0] must be an object with 'text' and 'held'"),
    (b"\xff\xfe", "not UTF-8 text"),
])
def test_report_on_malformed_result_json_names_the_file(content, expected, tmp_path, capsys):
    bad = tmp_path / "res" / "beta" / "result.json"
    _results(tmp_path / "res")
    bad.parent.mkdir(parents=True)
    bad.write_bytes(content if isinstance(content, bytes) else content.encode())
    err = _fail(["report", "--out", str(tmp_path / "res")], capsys)
    assert str(bad) in err and expected in err and "sobolev-drake run beta" in err
    assert not (tmp_path / "res" / "REPRODUCTION.md").exists()


@pytest.mark.parametrize("argv", [["run", "models-tour", "--smoke"], ["demo", "--smoke"], ["reproduce", "--smoke"],
                                  ["report"]])
@pytest.mark.parametrize("out", ["", "  "])
def test_empty_out_is_refused(argv, out, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    err = _fail(argv + ["--out", out], capsys)
    assert f"argument --out: expected a folder, got {out!r}" in err
    assert list(tmp_path.iterdir()) == []


def test_reproduce_checks_its_targets_before_running(tmp_path, monkeypatch, capsys):
    ran = []
    fake = exps.Experiment("zz-fake", "records that it ran", lambda out_dir, **kw: ran.append(out_dir))
    monkeypatch.setattr(exps, "discover", lambda: {"zz-fake": fake})
    monkeypatch.chdir(tmp_path)
    (tmp_path / "REPRODUCTION.md").write_text("mine\n")
    err = _fail(["reproduce", "--out", "o", "--copy-to", "REPRODUCTION.md"], capsys)
    assert "refusing to replace REPRODUCTION.md" in err and not ran
    assert (tmp_path / "REPRODUCTION.md").read_text() == "mine\n"


def test_demo_checks_its_report_before_running(tmp_path, monkeypatch, capsys):
    ran = []
    fake = exps.Experiment("zz-fake", "records that it ran", lambda out_dir, **kw: ran.append(out_dir))
    monkeypatch.setattr(exps, "flagship", lambda: fake)
    (tmp_path / "zz-fake").mkdir()
    (tmp_path / "zz-fake" / "REPORT.md").write_text("mine\n")
    err = _fail(["demo", "--out", str(tmp_path)], capsys)
    assert "REPORT.md" in err and not ran
