"""Thesis 5.3.2, Table 5.7: two-wheeled self-balanced vehicle with input coupling.

Plant (4.30), Table 4.1 (friction k ϕ̇ included); controller model = a separate TwoWheeledModel
with the same parameters (the law compensates the friction).  Partition qc = θ (controlled, with
integral action), qs = ϕ (stabilized, q̇s → 0); generalized input u* (5.73), applied motor torque
τ = B†u* with B = F = [1, −1]ᵀ (5.118), i.e. τ = (u*_ϕ − u*_θ)/2.  Tuning Υ0 = 0.1, Υ1 = 1.1,
Γ0 = 1000, Γ1 = 300, Γ2 = 2, Γ3 = 0.001 (W2 ≡ W∞, Remark 36).  θ(0) = π/4, the rest 0,
reference θ_r = 0; disturbances wϕ = 4 sin(2πt/5) N m on 7 ≤ t ≤ 14 s and wθ = 4 N m on
22 ≤ t ≤ 32 s (printed "22 ≤ t ≥ 32"); duration 40 s (not printed).  H∞ baseline: same ISE of θ
(the thesis' rule for this table).  No torque limit (none printed).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from sobolev_drake import norms, report, viz
from sobolev_drake.experiments import Claim, ExperimentResult, register
from sobolev_drake.experiments._mechanical_common import (build_loop, compare_plot, hinf_inner,
                                                          hinf_surface, omega_u_guess, pct,
                                                          run_loop, tracked_errors, tune)
from sobolev_drake.models.two_wheeled import add_two_wheeled, make_two_wheeled_model
from sobolev_drake.synthesis.mechanical import controlled_gains, stabilized_gains
from sobolev_drake.systems.disturbances import TimeProfiledForce
from sobolev_drake.systems.mechanical_controller import Partition, SobolevLaw
from sobolev_drake.systems.references import PiecewiseTrajectory, TrajectoryReference, const

PARTITION = Partition(controlled=[1], stabilized=[0])  # θ | ϕ
Q0, QD0 = np.array([0.0, np.pi / 4]), np.zeros(2)
THESIS = {"W2/W∞": {"IADU": 79.5, "ISE θ": 0.047, "ISE ϕ̇": 4.975e4},
          "H∞": {"IADU": 108.3, "ISE θ": 0.0468, "ISE ϕ̇": 5.032e4}}
COLS = ["IADU", "ISE θ", "ISE ϕ̇"]


def gains():
    return SobolevLaw(controlled=controlled_gains(1000, 300, 2, 0.001),
                      stabilized=stabilized_gains(0.1, 1.1))


def reference() -> TrajectoryReference:
    return TrajectoryReference(PiecewiseTrajectory(["theta"], [[const(0.0)]],
                                                   description="upright: theta_r = 0"))


def disturbance() -> TimeProfiledForce:
    return TimeProfiledForce(2, [
        {"index": 0, "value": lambda t: 4.0 * np.sin(2 * np.pi * t / 5), "from": 7.0, "to": 14.0},
        {"index": 1, "value": 4.0, "from": 22.0, "to": 32.0},
    ])


def indices(run):
    t = run["t"]
    return {"IADU": float(norms.iadu(t, run["u"]).sum()),
            "ISE θ": float(norms.ise(t, run["x"][:, 1])),
            "ISE ϕ̇": float(norms.ise(t, run["x"][:, 2]))}


@register("balance-coupled", "Two-wheeled vehicle with input coupling: W2/W∞ vs H∞ (Table 5.7)",
          default_duration=40.0, thesis_ref="5.3.2, Table 5.7, Fig. 5.5")
def run(out_dir, *, duration=None, record=False, smoke=False) -> ExperimentResult:
    out_dir = Path(out_dir)
    duration = float(duration or (2.0 if smoke else 40.0))
    w_inner = gains()
    loop = build_loop(add_two_wheeled, make_two_wheeled_model(), PARTITION, w_inner, reference(),
                      disturbance(), record=record)
    law = loop.controller.law
    outputs, claims = {}, []
    w_run = run_loop(loop, w_inner, duration, Q0, QD0, label="W2/W∞")
    if record:
        outputs["meshcat W2/W∞"] = viz.save_recording_html(loop.meshcat, loop.recorder,
                                                           out_dir / "balance_coupled_w.html")
    w_idx = indices(w_run)
    surface = hinf_surface(w_inner.controlled)

    def evaluate(wu):
        r = run_loop(loop, hinf_inner(surface, wu), duration, Q0, QD0, label="H∞")
        return indices(r)["ISE θ"], r

    wu, h_run, hist = tune(evaluate, w_idx["ISE θ"], omega_u_guess(law, w_inner.controlled, Q0, QD0),
                           iters=2 if smoke else 8, decreasing=False)
    h_idx = indices(h_run)
    rows = [[k, *(pct(idx[c], h_idx[c]) for c in COLS)] for k, idx in (("W2/W∞", w_idx), ("H∞", h_idx))]
    th = [[k, *(pct(THESIS[k][c], THESIS["H∞"][c]) for c in COLS)] for k in ("W2/W∞", "H∞")]
    md, js, table = report.write_table(out_dir, "balance_coupled", ["controller", *COLS], rows,
                                       thesis_rows=th,
                                       title=f"Table 5.7 (two-wheeled, input coupling, {duration:g} s)")
    outputs.update({"table (md)": md, "table (json)": js})
    runs = {"W2/W∞": w_run, "H∞": h_run}
    outputs["states and input"] = compare_plot(
        out_dir / "balance_coupled.png", runs,
        [("θ [rad]", lambda r: r["x"][:, 1], None),
         ("ϕ̇ [rad/s]", lambda r: r["x"][:, 2], None),
         ("u [N m]", lambda r: r["u"], None),
         ("w [N m]", lambda r: r["w"], ["wϕ", "wθ"])],
        title="Two-wheeled vehicle, input coupling (thesis Fig. 5.5)", vlines=(7, 14, 22, 32))
    for name, r in runs.items():
        if r["failed"]:
            claims.append(Claim(f"{name} simulation completed", False, r["failed"]))
        claims.append(Claim(f"{name} keeps the vehicle upright (|θ| < π/2) and θ → 0 at the end",
                            bool(np.max(np.abs(r["x"][:, 1])) < np.pi / 2
                                 and abs(r["x"][-1, 1]) < 0.05),
                            f"max |θ| {np.max(np.abs(r['x'][:, 1])):.3g}, final θ {r['x'][-1, 1]:.3g}"))
    claims.append(Claim("H∞ tuned to the same ISE θ as W2/W∞ (within 2 %)",
                        abs(h_idx["ISE θ"] / w_idx["ISE θ"] - 1) < 0.02,
                        f"W {w_idx['ISE θ']:.4g}, H∞ {h_idx['ISE θ']:.4g}, ωu = {wu:.4g}; search "
                        f"{[(round(a, 5), round(b, 5)) for a, b in hist]}"))
    claims.append(Claim("W2/W∞ needs less control variation (IADU) than H∞ at equal ISE θ "
                        "(thesis 73 %)", w_idx["IADU"] < h_idx["IADU"],
                        f"{100 * w_idx['IADU'] / h_idx['IADU']:.0f} %"))
    e, _ = tracked_errors(w_run, law)
    metrics = {"W2/W∞": w_idx, "H∞": h_idx, "hinf_omega_u": wu, "hinf_surface": surface,
               "hinf_search": hist, "duration": duration, "final_theta_W": float(e[-1, 0])}
    return ExperimentResult("balance-coupled", outputs, metrics, claims, table)
