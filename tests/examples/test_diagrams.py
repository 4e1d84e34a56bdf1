"""Smoke tests of the example scripts in diagrams/ (Drake's pendulum, planar gripper and
Acrobot), each run briefly through its ``run(duration, out_dir)``.

On an exact model both the W2 law and Drake's InverseDynamicsController turn the tracking error
of every controlled joint into the linear chain ë = −kd ė − kp e − ki ∫e, started from
(ė(0), e(0), ∫e = 0).  The simulated errors are therefore compared with that chain's exact
solution; the two can only differ by the integration error.  All scripts simulate with Drake's
error-controlled RK3 at accuracy 1e-6 and steps of at most 5 ms (the log period); the error
chains are exponentially stable, so the local errors do not pile up, and 1e-5 (ten times the
accuracy, as in test_from_plant.py) bounds the difference.  Measured: at most 3e-8.
"""

import importlib.util
import math
from pathlib import Path

import numpy as np
from scipy.linalg import expm

import sobolev_drake as sd

DIAGRAMS = Path(__file__).resolve().parents[2] / "diagrams"
DURATION = 2.0
TOL = 1e-5


def load(name):
    spec = importlib.util.spec_from_file_location(f"diagrams_{name}", DIAGRAMS / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def chain_errors(kd, kp, ki, e0, ed0, t):
    """e(t) of ë = −kd ė − kp e − ki ∫e from (ė0, e0, 0), on the uniform grid t; (N, k)."""
    A = np.array([[-kd, -kp, -ki], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    step = expm(A * (t[1] - t[0]))
    x = np.vstack([np.atleast_1d(ed0), np.atleast_1d(e0), np.zeros(np.size(e0))])
    out = []
    for _ in t:
        out.append(x[1])
        x = step @ x
    return np.array(out)


def check_files_and_numbers(result):
    html = Path(result["recording"]).read_text(encoding="utf-8")
    assert len(html) > 10_000 and sd.recording_html.external_script_sources(html) == []
    assert Path(result["plot"]).stat().st_size > 10_000
    for name, row in result["rows"].items():
        assert all(math.isfinite(v) for v in row.values()), (name, row)


def check_against_chain(row, gains, e0, ed0, log_period):
    """ISE and final error of a run equal those of the linear error chain."""
    t = np.linspace(0.0, DURATION, round(DURATION / log_period) + 1)
    e = chain_errors(*gains, np.asarray(e0), np.asarray(ed0), t)
    assert abs(row["final error [rad]"] - np.abs(e[-1]).max()) < TOL
    # ISE: the same trapezoid on the same grid, so only the pointwise difference (< TOL, on
    # errors of at most 1 rad over DURATION s) enters: |ΔISE| < 2 · TOL · DURATION per joint
    assert abs(row["ISE [rad²s]"] - sd.norms.ise(t, e).sum()) < 2 * TOL * DURATION * e.shape[1]


def test_pendulum(tmp_path):
    mod = load("pendulum_tracking")
    result = mod.run(DURATION, tmp_path)
    check_files_and_numbers(result)
    q_r, qd_r, _ = mod.REFERENCE.evaluate(0.0)
    e0, ed0 = mod.X0[0] - q_r, mod.X0[1] - qd_r          # 0.4 rad off, 2 rad/s behind
    check_against_chain(result["rows"]["W2"], mod.GAINS.K[0], e0, ed0, mod.LOG_PERIOD)
    idc = (mod.KD[0], mod.KP[0], mod.KI[0])
    check_against_chain(result["rows"]["Drake IDC"], idc, e0, ed0, mod.LOG_PERIOD)
    # the W2 poles (−7.7 ± 3.2j, −1.44) leave a slow integral tail; Drake's triple pole at
    # −4.64 does not: after 2 s the baseline is closer (both predicted by the chains above)
    assert result["rows"]["Drake IDC"]["final error [rad]"] < result["rows"]["W2"]["final error [rad]"]


def test_pendulum_drake_idc_with_the_w2_gains_is_the_w2_run(monkeypatch):
    mod = load("pendulum_tracking")
    monkeypatch.setattr(mod, "X0", [0.0, 2.0])           # on the reference: θ_r(0), θ̇_r(0)
    t, x, u, _ = mod.closed_loop("W2", 1.0)
    assert np.abs(x[0] - mod.REFERENCE.evaluate(t)[0][:, 0]).max() < TOL
    monkeypatch.setattr(mod, "X0", [0.4, 0.0])
    kd, kp, ki = mod.GAINS.K[0]
    t, x_w2, u_w2, _ = mod.closed_loop("W2", 1.0)
    monkeypatch.setattr(mod, "KP", [kp])
    monkeypatch.setattr(mod, "KI", [ki])
    monkeypatch.setattr(mod, "KD", [kd])
    t, x_idc, u_idc, _ = mod.closed_loop("Drake IDC", 1.0)
    # the same ODE on the same step sequence: only rounding differs (measured 4e-14)
    assert np.abs(x_w2 - x_idc).max() < 1e-9 and np.abs(u_w2 - u_idc).max() < 1e-9


def test_gripper(tmp_path):
    mod = load("gripper_tracking")
    result = mod.run(DURATION, tmp_path)
    check_files_and_numbers(result)
    q_r, qd_r, _ = sd.PiecewiseTrajectory([f"j{i}" for i in range(6)], [mod.WAVE]).evaluate(0.0)
    e0, ed0 = mod.X0[:6] - q_r, mod.X0[6:] - qd_r
    # every joint has the same gains, so the six chains differ only in their start
    check_against_chain(result["rows"]["W2"], mod.GAINS.K[0, ::6], e0, ed0, mod.LOG_PERIOD)
    idc = (mod.KD[0], mod.KP[0], mod.KI[0])
    check_against_chain(result["rows"]["Drake IDC"], idc, e0, ed0, mod.LOG_PERIOD)


def test_acrobot_partition(tmp_path):
    mod = load("acrobot_partition")
    result = mod.run(DURATION, tmp_path)
    check_files_and_numbers(result)
    # Partition(controlled=[1], stabilized=[0]) is refused, naming the shoulder and the way out
    assert all(word in result["refused"] for word in ("'shoulder'", "no input", "uncontrolled"))
    q_r, qd_r, _ = mod.REFERENCE.evaluate(0.0)
    # the reduced model (5.5) is exact, so the elbow error follows the chain as well
    check_against_chain(result["rows"]["W2"], mod.GAINS.K[0], mod.X0[1] - q_r, mod.X0[3] - qd_r,
                        mod.LOG_PERIOD)
    for row in result["rows"].values():
        # the passive shoulder is driven only through the coupling: it does swing (measured
        # 0.44 rad with W2, 0.39 rad with the PID) but stays below the horizontal
        assert 0.1 < row["max shoulder [rad]"] < math.pi / 2


def test_acrobot_upright(tmp_path):
    mod = load("acrobot_upright")
    result = mod.run(DURATION, tmp_path)
    check_files_and_numbers(result)
    assert result["synthesis"].regularized and result["synthesis"].certificate.ok
    # within 2 s both reach their largest excursion (W∞ 0.85 rad at 1.05 s, LQR 0.50 rad at
    # 0.5 s) and neither is near falling (π/2)
    assert result["rows"]["W∞ output feedback (angles)"]["max error [rad]"] < 1.2
    assert result["rows"]["Drake LQR (full state)"]["max error [rad]"] < 0.6
