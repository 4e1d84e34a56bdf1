"""``quadrotor-figure8``: quadrotor figure-8 with the input-coupling law on an untilted truth,
W2/W∞ vs classic nonlinear H∞ (thesis 5.3.2, Table 5.9).

The controller's model has rotors tilted 5°, the simulated quadrotor none.  Allocations of u*
(:mod:`~sobolev_drake.systems.rotor_allocation`): ``"pinv"`` (the thesis' unlimited B†u*, the
headline table), ``"bls"`` and ``"clip"`` within Ω² ∈ [0, 4·hover] (docs/design.md §8.1).  The
H∞ law is tuned to the same IADU; Fig. 5.7's ‖B⊥(w − d)‖² is computed from the logs.

See docs/experiments/quadrotor-figure8.md.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Sequence

import numpy as np

from sobolev_drake import norms, plots, report
from sobolev_drake.experiments import Claim, ExperimentResult, register
from sobolev_drake.models.quadrotor import QuadrotorParams, add_quadrotor, make_quadrotor_model
from sobolev_drake.report import percent_of, percent_rows
from sobolev_drake.rigs.mechanical import (bperp_signal, build_loop, compare_with_matched_hinf, run_loop,
                                           tracked_errors)
from sobolev_drake.synthesis.mechanical import controlled_gains, stabilized_gains
from sobolev_drake.systems.mechanical_law import MechanicalLaw
from sobolev_drake.systems.disturbances import TimeProfiledForce
from sobolev_drake.systems.hinf_baseline import matched_hinf_law
from sobolev_drake.systems.mechanical_controller import Partition, SobolevLaw
from sobolev_drake.systems.reference_catalogue import trajectory
from sobolev_drake.systems.references import TrajectoryReference
from sobolev_drake.systems.rotor_allocation import RotorAllocation

PARTITION = Partition(controlled=[2, 3, 4, 5], stabilized=[0, 1])   # q = [ϕ θ ψ x y z]
GAMMAS = ([10, 10, 10, 10], [12.8, 18.8, 18.8, 12.8], [0.01, 0.1, 0.1, 0.1],
          [4e-5, 0.08, 0.07, 0.09])                                  # Γ0..Γ3, order [ψ x y z]
UPSILONS = ([2, 2], [0.01, 0.01])                                    # Υ0, Υ1
Q0 = np.array([0.0, 0.0, 0.0, 7.0, 0.0, 1.0])
NAMES = ["ψ", "x", "y", "z"]
THESIS = {"W2/W∞": {"IADU": 2.4e4, "ISE x": 0.496, "ISE y": 0.030, "ISE z": 0.313, "ISE ψ": 9.5e-5},
          "H∞": {"IADU": 2.4e4, "ISE x": 1.105, "ISE y": 0.102, "ISE z": 0.404, "ISE ψ": 4.6e-4}}
COLS = ["IADU", "ISE x", "ISE y", "ISE z", "ISE ψ"]


def sobolev_inner() -> SobolevLaw:
    return SobolevLaw(controlled_gains(*GAMMAS), stabilized=stabilized_gains(*UPSILONS))


def reference() -> TrajectoryReference:
    """Table 5.8 in the controlled-DOF order [ψ x y z]."""
    return TrajectoryReference(trajectory("table_5_8").subset(["psi", "x", "y", "z"]))


def disturbance() -> TimeProfiledForce:
    return TimeProfiledForce(6, [
        {"index": 4, "value": 10.0, "from": 10.0, "to": 15.0},
        {"index": 5, "value": lambda t: 10.0 * np.sin(0.4 * np.pi * t), "from": 25.0, "to": 30.0},
    ])


def indices(run: dict[str, Any], law: MechanicalLaw) -> dict[str, float]:
    """IADU of the rotor speeds Ω = √(Ω²) and the ISE of each tracked DOF."""
    e, _ = tracked_errors(run, law)
    out = {"IADU": float(norms.iadu(run["t"], np.sqrt(np.clip(run["u"], 0.0, None))).sum())}
    for j, name in enumerate(NAMES):
        out[f"ISE {name}"] = float(norms.ise(run["t"], e[:, j]))
    return out


def position_error(run: dict[str, Any], law: MechanicalLaw) -> np.ndarray:
    e, _ = tracked_errors(run, law)
    return np.linalg.norm(e[:, 1:], axis=1)


@register("quadrotor-figure8", "Quadrotor figure-8, input-coupling law, untilted truth: W2/W∞ vs H∞ "
          "(Table 5.9)", default_duration=40.0, thesis_ref="5.3.2, Tables 5.8-5.9, Figs. 5.6-5.8")
def run(out_dir: str | Path, *, duration: float | None = None, record: bool = False, smoke: bool = False,
        allocation: str = "pinv", limited: Sequence[str] = ("bls",), truth_tilt: float = 0.0,
        tune_iters: int = 7, on_reference: bool = True) -> ExperimentResult:
    """Headline comparison with ``allocation`` (default: the thesis' unlimited B†), H∞ tuned to
    the same IADU; then, for each allocation in ``limited``, the W2/W∞ law and the tuned H∞ law
    again with the rotor limits Ω² ∈ [0, 4·hover], from the thesis' initial state and (with
    ``on_reference``) from the reference state at t = 0 (separates the start transient from
    the tracking itself)."""
    out_dir = Path(out_dir)
    duration = float(duration or (0.3 if smoke else 40.0))
    params = QuadrotorParams()
    hover = params.hover_input()
    lo, hi = np.zeros(4), 4 * hover * np.ones(4)
    model = make_quadrotor_model(params)                       # tilted 5°: the controller's model
    alloc = RotorAllocation(model, allocation, lo, hi)
    limited = tuple(k for k in limited if k != allocation)
    for k in limited:
        RotorAllocation(model, k, lo, hi)                       # validate names early
    w_inner = sobolev_inner()
    loop = build_loop(lambda b: add_quadrotor(b, params, tilt=float(truth_tilt)), model, PARTITION,
                      w_inner, reference(), disturbance(), allocation=alloc, record=record)
    law = loop.controller.law
    outputs, claims = {}, []
    qd0 = np.zeros(6)
    # same IADU as W2/W∞ (thesis rule); if that run diverged, the thesis' printed IADU instead
    cmp = compare_with_matched_hinf(loop, w_inner, duration, Q0, qd0, lambda r: indices(r, law),
                                    target_if_w_failed=THESIS["H∞"]["IADU"],
                                    iters=1 if smoke else int(tune_iters),
                                    record_to=out_dir / "quadrotor_figure8_w.html" if record else None)
    w_run, w_idx, h_run, h_idx, wu, hist, surface, target = (
        cmp.w_run, cmp.w_indices, cmp.hinf_run, cmp.hinf_indices, cmp.omega_u, cmp.history, cmp.surface,
        cmp.target)
    if record:
        outputs["meshcat W2/W∞"] = cmp.recording
    runs = {f"W2/W∞ [{allocation}]": w_run, f"H∞ [{allocation}]": h_run}
    idx = {f"W2/W∞ [{allocation}]": w_idx, f"H∞ [{allocation}]": h_idx}
    qr, qdr, _ = reference().evaluate(0.0)
    starts = {"": (Q0, qd0), ", on ref": (np.r_[0.0, 0.0, qr], np.r_[0.0, 0.0, qdr])}
    for kind in limited:
        alloc.kind = kind
        for suffix, (q0, v0) in starts.items() if on_reference else list(starts.items())[:1]:
            key = f"{kind}{suffix}"
            runs[f"W2/W∞ [{key}]"] = run_loop(loop, w_inner, duration, q0, v0, label=f"W2/W∞ {key}")
            runs[f"H∞ [{key}]"] = run_loop(loop, matched_hinf_law(surface, wu), duration, q0, v0,
                                           label=f"H∞ {key}")
            for c in ("W2/W∞", "H∞"):
                idx[f"{c} [{key}]"] = indices(runs[f"{c} [{key}]"], law)
    alloc.kind = allocation
    rows = []
    for name, v in idx.items():
        base = idx["H∞" + name[name.index(" ["):]]
        r = runs[name]
        if r["failed"]:  # indices of a truncated run mean nothing: say what happened instead
            rows.append([f"{name} — {r['failed'][:70]}", *(["—"] * len(COLS))])
        else:
            rows.append([name, *(percent_of(v[c], base[c]) for c in COLS)])
    th = percent_rows(THESIS, "H∞", COLS)
    th += [None] * (len(rows) - 2)                             # the thesis ran B† only
    md, js, table = report.write_table(
        out_dir, "quadrotor_figure8", ["controller [allocation]", *COLS], rows, thesis_rows=th,
        title=f"Table 5.9 (quadrotor figure-8, input coupling, model tilt 5°, truth tilt "
              f"{np.rad2deg(truth_tilt):g}°, {duration:g} s; pinv = thesis B†u* unlimited, "
              f"bls/clip = Ω² ∈ [0, 4·hover])")
    outputs.update({"table (md)": md, "table (json)": js})
    for r in runs.values():
        r["bperp_t"], r["bperp"] = bperp_signal(r, model, law, 100 if smoke else 1500)
    head = dict(list(runs.items())[:2])
    outputs["errors and stabilized DOF"] = plots.compare_plot(
        out_dir / "quadrotor_figure8_errors.png", runs,
        [("position error [m]", lambda r: np.clip(position_error(r, law), 0, 5), None),
         ("ψ − ψr [rad]", lambda r: tracked_errors(r, law)[0][:, 0], None),
         ("ϕ, θ [rad]", lambda r: r["x"][:, :2], ["ϕ", "θ"])],
        title="Quadrotor figure-8 (thesis Fig. 5.8)", vlines=(10, 15, 25, 30))
    outputs["inputs and disturbances"] = plots.compare_plot(
        out_dir / "quadrotor_figure8_inputs.png", head,
        [("Ω² / hover", lambda r: r["u"] / hover, ["1", "2", "3", "4"]),
         ("w [N]", lambda r: r["w"][:, [4, 5]], ["δy", "δz"])],
        title="Quadrotor figure-8 inputs (thesis Fig. 5.7)", vlines=(10, 15, 25, 30))
    outputs["B-perp signal"] = plots.plot_semilogy(
        out_dir / "quadrotor_figure8_bperp.png",
        {k: (r["bperp_t"], r["bperp"]) for k, r in runs.items()}, ylabel="‖B⊥(w − d)‖²")
    outputs["trajectory"] = plots.plot_paths_3d(
        out_dir / "quadrotor_figure8_xy.png", next(iter(runs.values()))["ref"][:, 1:4],
        {k: r["x"][:, 3:6] for k, r in runs.items()})
    sat = {k: norms.fraction_at_bounds(r["u"], lo, hi) for k, r in runs.items()}
    t_late = min(5.0, 0.5 * duration)
    for name, r in runs.items():
        if r["failed"]:
            claims.append(Claim(f"{name} simulation completed", False, r["failed"]))
        pe = position_error(r, law)
        late = r["t"] >= t_late
        ok = bool(not r["failed"] and late.any() and np.all(pe[late] < 0.5))
        claims.append(Claim(f"{name}: tracks the figure-8 (position error < 0.5 m after "
                            f"t = {t_late:g} s)", ok,
                            f"max {pe[late].max() if late.any() else np.nan:.3g} m, final {pe[-1]:.3g} m"))
        claims.append(Claim(f"{name}: rotor commands inside [0, 4·hover] (not on or beyond a bound "
                            "more than 5 % of the time)", sat[name] < 0.05,
                            f"{100 * sat[name]:.1f} % of samples, Ω² range "
                            f"[{r['u'].min():.3g}, {r['u'].max():.3g}] (hover {hover:.3g})"))
        claims.append(Claim(f"{name}: roll/pitch stay small (|ϕ|, |θ| < 0.5 rad)",
                            bool(np.abs(r["x"][:, :2]).max() < 0.5),
                            f"max |ϕ|, |θ| = {np.abs(r['x'][:, :2]).max(axis=0).round(3).tolist()} rad"))
    claims.append(Claim("H∞ tuned to the same IADU as W2/W∞ (within 2 %)"
                        + (" — W2/W∞ diverged: target = thesis IADU 2.4e4" if w_run["failed"] else ""),
                        abs(h_idx["IADU"] / target - 1) < 0.02,
                        f"W {w_idx['IADU']:.4g}, H∞ {h_idx['IADU']:.4g}, ωu = {wu:.4g}; search "
                        f"{[(round(a, 6), round(b, 1)) for a, b in hist]}"))
    for c in COLS[1:]:
        claims.append(Claim(f"[{allocation}] W2/W∞ has a smaller {c} than H∞ "
                            f"(thesis {100 * THESIS['W2/W∞'][c] / THESIS['H∞'][c]:.0f} %)",
                            w_idx[c] < h_idx[c], f"{100 * w_idx[c] / h_idx[c]:.0f} %"))
    metrics = {**idx, "hinf_omega_u": wu, "hinf_surface": surface, "hinf_search": hist,
               "allocation": allocation, "limited": list(limited), "truth_tilt": float(truth_tilt),
               "duration": duration, "outside_box_fraction": sat,
               "bperp_max": {k: float(r["bperp"].max()) for k, r in runs.items()},
               "failed": {k: r["failed"] for k, r in runs.items()}}
    return ExperimentResult("quadrotor-figure8", outputs, metrics, claims, table)

