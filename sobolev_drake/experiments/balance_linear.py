"""``balance-linear``: linear W∞ vs classic H∞ on the two-wheeled vehicle (thesis 6.5.2,
Table 6.2).

The linearization of (4.30) at the upright (:mod:`sobolev_drake.models.two_wheeled_linear`),
the four designs of :mod:`._balance_linear_designs` (H∞ input weights by the
equal-settling-time rule), their flights on the nonlinear vehicle
(:mod:`sobolev_drake.rigs.balance_linear`, one diagram per controller kind), the Table 6.2
indices, and the report, diagnostics and variants of the private ``_balance_linear_*`` helpers.

See docs/experiments/balance-linear.md.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Callable, Mapping

import numpy as np

from sobolev_drake.experiments import ExperimentResult, register
from sobolev_drake.experiments._balance_linear_designs import (C_OF, DESIGN_SPECS, DESIGNS, RADIUS, RHO_GRID,
                                                               RHO_TUNED, THESIS_TABLE_6_2, design)
from sobolev_drake.models.two_wheeled_linear import linearize
from sobolev_drake.rigs.balance_linear import (DISTURBANCE_START, BalanceLinearRig, flight_indices,
                                               result_gains, theta_settling_time)
from sobolev_drake.synthesis.designs import FeedbackTable, feedback_kind
from sobolev_drake.tuning import match_parameter


def synthesize_all(lin: tuple[np.ndarray, np.ndarray, np.ndarray], rigs: Mapping[str, BalanceLinearRig], *,
                   search: bool = True, log: Callable[[str], Any] = print) -> dict[str, dict[str, Any]]:
    """W∞ designs with the thesis' weights; H∞ designs by the equal-settling-time rule.

    Parameters
    ----------
    lin : (A, B, D)
        The linear model.
    rigs : mapping
        The :class:`BalanceLinearRig` of each feedback kind, keyed ``"state_feedback"`` and
        ``"output_feedback"`` (older spellings such as ``"sf"``/``"of"`` are mapped).
    search : bool
        Match ρ on the nonlinear rig; False (smoke mode) uses ``RHO_TUNED``, the values a full
        run found (reproducible: the search is deterministic).
    log : callable
        Receives one progress line per controller kind.

    Returns
    -------
    dict
        Label → {"res", "notes", "solve_s", "settling_target", and for H∞ "rho",
        "settling_matched", "search"}.
    """
    from sobolev_drake.synthesis.lmi import SynthesisError
    rigs = FeedbackTable(**{feedback_kind(k, "rigs key"): v for k, v in rigs.items()})
    designs = {}
    for kind, (w_name, h_name) in (("state_feedback", ("W∞", "H∞")),
                                   ("output_feedback", ("W∞-O.F.", "H∞-O.F."))):
        wres, notes, dt = design(w_name, lin)
        ts_w = (theta_settling_time(rigs[kind].run(result_gains(wres), DISTURBANCE_START))
                if search else float("nan"))
        designs[w_name] = {"res": wres, "notes": notes, "solve_s": dt, "settling_target": ts_w}
        cache = {}

        def ts_of_rho(rho, h_name=h_name, kind=kind, cache=cache):
            try:
                cache[rho] = design(h_name, lin, rho=rho)
            except SynthesisError:
                return float("nan")
            return theta_settling_time(rigs[kind].run(result_gains(cache[rho][0]), DISTURBANCE_START))

        if search:
            rho, ts_h, hist = match_parameter(ts_of_rho, ts_w, RHO_GRID[kind], refine=3)
        else:
            rho, ts_h, hist = RHO_TUNED[h_name], float("nan"), []
            cache[rho] = design(h_name, lin, rho=rho)
        r, n, s = cache[rho]
        designs[h_name] = {"res": r, "notes": n, "solve_s": s, "rho": rho, "settling_target": ts_w,
                           "settling_matched": ts_h, "search": [(float(p), float(v)) for p, v in hist]}
        log(f"[balance-linear] {kind}: W∞ settling {ts_w:.3f} s; H∞ rho = {rho:.4g} gives {ts_h:.3f} s "
            f"({len(hist)} search runs)")
    return designs


@register("balance-linear", "Two-wheeled vehicle: linear W∞ vs H∞ (state and output feedback, "
          "disk regions) on the nonlinear Drake model (Table 6.2)", default_duration=25.0,
          thesis_ref="6.5.2, Table 6.2")
def run(out_dir: str | Path, *, duration: float | None = None, record: bool = False, smoke: bool = False,
        diagnose: bool | None = None) -> ExperimentResult:
    """Table 6.2.  ``smoke``: no ρ search (:data:`RHO_TUNED`), 5 s runs (long enough for the
    settling times, before the disturbances), no diagnostics.  ``diagnose`` (default: not
    smoke): O.F. well-posedness table (backend spread, gain growth towards γ*) and, for runs
    of ≥ 20 s, the variant pairs of :mod:`._balance_linear_variants`."""
    from sobolev_drake import viz
    from sobolev_drake.report import write_table
    from ._balance_linear_report import add_claims, plot_runs
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    duration = (DISTURBANCE_START if smoke else 25.0) if duration is None else float(duration)
    diagnose = (not smoke) if diagnose is None else bool(diagnose)
    lin = linearize()
    rigs = FeedbackTable(BalanceLinearRig(), BalanceLinearRig(C_OF))
    designs = synthesize_all(lin, rigs, search=not smoke)
    runs, metrics, rows, th_rows = {}, {}, [], []
    for name in DESIGNS:
        dz = designs[name]
        r = dz["res"]
        kind = DESIGN_SPECS[name].feedback
        d = rigs[kind].run(result_gains(r), duration)
        runs[name] = d
        idx = flight_indices(d)
        cert = r.certificate
        ev = cert.eigenvalues
        m = {"gamma": float(r.gamma), "gamma_opt": float(r.gamma_opt), "achieved": float(cert.achieved),
             "certified": bool(cert.ok), "regularized": bool(r.regularized),
             "norm_Y": float(np.linalg.norm(r.Y, 2)) if r.Y is not None else None,
             "max_abs_eig": float(np.abs(ev).max()), "max_real_eig": float(ev.real.max()),
             "radius": RADIUS[kind], "solver": r.solver, "solve_s": dz["solve_s"], "notes": dz["notes"],
             "rho": dz.get("rho"), "settling_target_s": dz["settling_target"],
             "settling_search": dz.get("search", []), "sim_wall_s": d["wall_s"], **idx}
        if r.K is not None:
            m["K"] = np.asarray(r.K).tolist()
        else:
            m["controller"] = {k: np.asarray(v).tolist() for k, v in zip(("AK", "BK", "CK", "DK"), r.controller)}
        metrics[name] = m
        reg = (f"γ*(1+{(r.gamma / r.gamma_opt - 1):.2g})" if r.regularized else "γ*")
        rows.append([name, dz.get("rho", "—"), f"{r.gamma:.4g} ({reg})", f"{idx['settling_s']:.3f}",
                     idx["ise_theta"], idx["ise_phidot"], idx["iadu"], idx["gain"], f"{idx['max_abs_u']:.0f}",
                     f"{np.abs(ev).max():.1f} ≤ {RADIUS[kind]:g}"])
        th = THESIS_TABLE_6_2[name]
        th_rows.append([name, "—", "—", "similar", *th, "—", f"≤ {RADIUS[kind]:g}"])
    # relative numbers as in the thesis (H∞ = 100 %)
    for a, b in (("H∞", "W∞"), ("H∞-O.F.", "W∞-O.F.")):
        for k in ("ise_theta", "ise_phidot", "iadu", "gain"):
            metrics[b][f"{k}_rel_to_{a}"] = metrics[b][k] / metrics[a][k] if metrics[a][k] else float("nan")
    cols = ["design", "H∞ input weight ρ", "certified γ", "θ settling [s]", "ISE θ", "ISE ϕ̇", "IADU",
            "‖x‖/‖w‖", "max |u| [N m]", "max |eig| ≤ r"]
    md, js, text = write_table(out_dir, "balance-linear_table", cols, rows, thesis_rows=th_rows,
                               title=f"Table 6.2 beside ours (nonlinear plant, {duration:g} s)")
    res = ExperimentResult(name="balance-linear", metrics=metrics, table_markdown=text)
    res.outputs.update({"table_md": md, "table_json": js})
    res.outputs.update(plot_runs(runs, out_dir))
    add_claims(res, metrics, full=duration >= 20.0)
    if diagnose:
        from ._balance_linear_posedness import diagnose as _diagnose
        _diagnose(res, lin, rigs["output_feedback"], designs, out_dir)
        if duration >= 20.0:
            from ._balance_linear_variants import add_variants
            add_variants(res, lin, rigs, designs, duration, out_dir)
    mpath = out_dir / "balance-linear_metrics.json"
    mpath.write_text(json.dumps(metrics, indent=1, default=str), encoding="utf-8")
    res.outputs["metrics_json"] = mpath
    if record:
        rig = BalanceLinearRig(record=True)
        rig.run(result_gains(designs["W∞"]["res"]), duration)
        res.outputs["meshcat_html"] = viz.save_recording_html(rig.meshcat, rig.recorder,
                                                              out_dir / "balance-linear_Winf.html")
    return res
