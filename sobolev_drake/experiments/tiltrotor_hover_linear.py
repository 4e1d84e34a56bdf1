"""``tiltrotor-hover-linear``: linear W∞ designs for the tilt-rotor in helicopter mode, flown on the
nonlinear plant (thesis §7.3.1, Table 7.2).

The composition: trim and linearization, the syntheses of :mod:`sobolev_drake.tiltrotor.linear_design` (the
thesis' disturbance-model LMIs are degenerate, docs/design.md §8.3, and are flown beside their well-posed
form), the flights of :mod:`sobolev_drake.tiltrotor.hover_flight` along the Table 7.1 path in von Kármán
wind, the tables of :mod:`sobolev_drake.tiltrotor.tables` and the claims.  The turbulence is σ-normalized
(docs/design.md §6); a second table flies the noise read literally.

See docs/experiments/tiltrotor-hover-linear.md.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from sobolev_drake import viz
from sobolev_drake.campaign import CampaignDefinition, register_campaign
from sobolev_drake.experiments import Claim, ExperimentResult, register
from sobolev_drake.report import write_table
from sobolev_drake.tiltrotor import campaigns, tables
from sobolev_drake.tiltrotor.hover_flight import (flight_indices, hover_reference, initial_error,
                                                  literal_noise_flight, simulate_design)
from sobolev_drake.tiltrotor.linear_controller import check_velocity_reference
from sobolev_drake.tiltrotor.linear_design import DESIGN_SPECS, DESIGNS, design, design_metrics, measurement_matrix
from sobolev_drake.tiltrotor.plots import plot_hover_flights

#: smoke mode: the cheapest certified design only (state feedback, ~10 s synthesis)
SMOKE_DESIGNS = ("W∞",)
SMOKE_DURATION = 10.0
#: (plain design, its disturbance-model counterpart) pairs of the Table 7.2 claims
DM_PAIRS = (("W∞", "W∞-D"), ("W∞", "W∞-D (thesis LMI)"), ("W∞-O.F.", "W∞-O.F.D"),
            ("W∞-O.F.", "W∞-O.F.D (thesis LMI)"))


@register("tiltrotor-hover-linear", "Tilt-rotor hover: linear W∞ state/output feedback and "
          "disturbance-model (von Kármán) designs flown on the nonlinear plant (Table 7.2)",
          default_duration=200.0, thesis_ref="7.3.1, Table 7.2")
def run(out_dir: str | Path, *, duration: float | None = None, record: bool = False, smoke: bool = False,
        designs: tuple[str, ...] | list[str] | None = None, record_design: str | None = None,
        backend: str | None = None, velocity_reference: str = "zero", regularization: str = "transient",
        sensitivity: bool | None = None, crossflow: str = "independence") -> ExperimentResult:
    """Synthesize ``designs`` (labels; default: all of DESIGNS, smoke: SMOKE_DESIGNS), fly each
    on the nonlinear plant, write the table beside Table 7.2, plots and metrics.

    ``record``: Meshcat recording of ``record_design`` (default the first).  ``velocity_reference``:
    "zero" (thesis, Δq̇ = q̇) or "path"; ``regularization``: "transient" (minimize Δx(0)ᵀ P Δx(0)
    at the certified γ) or "gain" (least gain); ``sensitivity`` (default: not in smoke mode): fly
    every design again with the noise read literally; ``crossflow``: the plant's crossflow model
    (``TiltrotorParams.crossflow``) for trim, linearization and flights."""
    check_velocity_reference(velocity_reference)  # before minutes of synthesis
    if regularization not in ("transient", "gain"):
        raise ValueError(f"regularization must be 'transient' or 'gain', got {regularization!r}")
    from sobolev_drake.tiltrotor.params import TiltrotorParams
    from sobolev_drake.tiltrotor.linearization import linearize
    from sobolev_drake.tiltrotor.trim import hover_wind_limit, tiltrotor_model, trim_hover

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    designs = tuple(designs) if designs is not None else (SMOKE_DESIGNS if smoke else DESIGNS)
    bad = [d for d in designs if d not in DESIGN_SPECS]
    if bad:
        raise ValueError(f"designs must be names from {DESIGNS}, got {bad}")
    duration = (SMOKE_DURATION if smoke else 200.0) if duration is None else float(duration)
    record_design = record_design or designs[0]
    sensitivity = (not smoke) if sensitivity is None else bool(sensitivity)
    # validates the name before minutes of synthesis; the model (and the linearization's
    # diagram) is shared by every run with the same parameters
    model = tiltrotor_model(TiltrotorParams(crossflow=crossflow))
    trim = trim_hover(model)
    lin = linearize(trim)
    x0 = initial_error(trim, velocity_reference) if regularization == "transient" else None
    res = ExperimentResult(name="tiltrotor-hover-linear")
    rows, srows, all_data, gains = [], [], {}, {}
    wind_limit = hover_wind_limit(90.0, model=model)  # steady lateral wind it can hover in, heading held
    metrics = {"setup": {"velocity_reference": velocity_reference, "regularization": regularization,
                         "initial_error": None if x0 is None else x0.tolist(),
                         "crossflow": crossflow,
                         "hover_wind_limit_lateral_m_s": wind_limit.limit,
                         "hover_wind_limit_reason": wind_limit.reason}}
    mjson = out_dir / "tiltrotor-hover-linear_metrics.json"
    meshcat = None

    def write_outputs():  # tables and metrics; also after every design (interrupted runs)
        mjson.write_text(json.dumps(metrics, indent=1, default=str))
        if srows:
            write_table(out_dir, "tiltrotor-hover-linear_literal_noise", tables.LITERAL_NOISE_COLUMNS,
                        srows, title=f"Sensitivity: the same controllers with the noise read literally "
                                     f"(σ × √(Δt/π), gusts ≈ 6 % of σ), {duration:g} s")
        return write_table(out_dir, "tiltrotor-hover-linear_table", tables.TABLE_7_2_COLUMNS, rows,
                           title=tables.table_7_2_title(duration))

    for spec in (DESIGN_SPECS[d] for d in designs):
        name, recorded = spec.label, record and spec.label == record_design
        try:
            ctrl = design(lin, spec, backend=backend, initial_state=x0)
        except Exception as exc:  # report a failed synthesis instead of aborting the table
            metrics[name] = {"error": f"{type(exc).__name__}: {exc}"}
            rows.append(tables.synthesis_failed_row(spec, str(exc)))
            continue
        m = design_metrics(lin, ctrl)   # the metrics start with the design's scores
        i = sum(k.endswith("_name") for k in gains)
        mats = {"K": ctrl.K} if ctrl.K is not None else dict(zip(("AK", "BK", "CK", "DK"), ctrl.controller))
        gains.update({f"d{i}_name": np.array(name), f"d{i}_kind": np.array(ctrl.kind), f"d{i}_C": measurement_matrix(ctrl),
                      **{f"d{i}_{k}": np.asarray(v) for k, v in mats.items()}})
        if recorded:
            meshcat = viz.start_meshcat()
        try:
            d = simulate_design(ctrl, trim, duration, meshcat=meshcat if recorded else None,
                                velocity_reference=velocity_reference)
        except Exception as exc:  # e.g. the integrator gives up on a diverging closed loop
            m["sim_error"] = f"{type(exc).__name__}: {exc}"
            metrics[name] = m
            rows.append(tables.sim_failed_row(spec, m, m["sim_error"]))
            continue
        idx = flight_indices(d, trim)
        all_data[name] = d
        m.update(idx, sim_wall_s=d["wall_s"], stopped=d["stopped"], sim_end_s=float(d["t"][-1]))
        metrics[name] = m
        rows.append(tables.flight_row(spec, m, idx, d["stopped"]))
        if sensitivity:
            m["literal_noise"] = literal_noise_flight(ctrl, trim, duration, velocity_reference)
            srows.append(tables.literal_noise_row(name, m["literal_noise"]))
        if recorded and d["recorder"] is not None:
            viz.draw_reference_and_flown(meshcat, hover_reference(), duration, d["x"][5:8])
            html = out_dir / "tiltrotor-hover-linear.html"
            viz.save_recording_html(meshcat, d["recorder"], html)
            res.outputs["recording"] = html
        write_outputs()
    md, js, text = write_outputs()
    if all_data:
        res.outputs.update(plot_hover_flights(all_data, out_dir))
    res.outputs.update({"table_md": md, "table_json": js, "metrics_json": mjson})
    if gains:
        # controllers (u = u_trim + K Δx, or AK..DK on y = C Δx) for independent re-checks
        np.savez(out_dir / "tiltrotor-hover-linear_controllers.npz", **gains)
        res.outputs["controllers_npz"] = out_dir / "tiltrotor-hover-linear_controllers.npz"
    if srows:
        res.outputs["literal_noise_md"] = out_dir / "tiltrotor-hover-linear_literal_noise.md"
    res.metrics, res.table_markdown = metrics, text
    add_claims(res, metrics, smoke or duration < 200.0)
    return res


def add_claims(res: ExperimentResult, metrics: dict[str, dict], smoke: bool) -> None:
    """Thesis claims of §7.3.1 checked on our runs (the comparisons only with the full duration)."""
    base = {k: m for k, m in metrics.items() if "ise" in m}
    th = tables.THESIS_TABLE_7_2

    def tracks(m):  # held?, measured detail
        wind = m.get("max_lateral_wind_m_s")
        return (m["finite"] and m["max_attitude_deg"] < 60 and not m.get("stopped"),
                f"RMS position {m['rms_pos_m']:.2f} m, final {m['final_pos_err_m']:.2f} m, "
                f"max |φ|,|θ| {m['max_attitude_deg']:.1f}°"
                + ("" if wind is None else f", peak lateral wind {wind:.1f} m/s"))

    for name, m in base.items():
        res.claims.append(Claim(
            f"{name}: tracks the Table 7.1 path on the nonlinear plant (finite, |φ|, |θ| < 60°)",
            *tracks(m)))
        lit = m.get("literal_noise")
        if lit and "ise" in lit:
            held, detail = tracks(lit)
            res.claims.append(Claim(
                f"{name}: tracks the path with the noise read literally (gusts ≈ 6 % of σ)", held,
                detail + (f"; {lit['stopped']}" if lit.get("stopped") else "")))
    if smoke:
        return
    for ref, dm in DM_PAIRS:
        if ref in base and dm in base and not (base[ref]["stopped"] or base[dm]["stopped"]):
            t_dm, t_ref = th[DESIGN_SPECS[dm].column], th[DESIGN_SPECS[ref].column]
            ri, ru = base[dm]["ise"] / base[ref]["ise"], base[dm]["iadu"] / base[ref]["iadu"]
            res.claims.append(Claim(
                f"{dm} has smaller ISE and IADU than {ref} (thesis {t_dm[0] / t_ref[0]:.0%} / "
                f"{t_dm[1] / t_ref[1]:.0%})", ri < 1 and ru < 1, f"ours {ri:.0%} / {ru:.0%}"))
    if "W∞" in base and "W∞-O.F." in base and not (base["W∞"]["stopped"] or base["W∞-O.F."]["stopped"]):
        a, b = base["W∞"], base["W∞-O.F."]
        res.claims.append(Claim("W∞-O.F. has larger ISE but smaller IADU than W∞ (thesis 60.7 vs "
                                "21.4, 1376 vs 2182)", b["ise"] > a["ise"] and b["iadu"] < a["iadu"],
                                f"ours ISE {b['ise']:.1f} vs {a['ise']:.1f}, IADU {b['iadu']:.0f} vs "
                                f"{a['iadu']:.0f}"))


# every Table 7.2 design on every turbulence seed (each synthesized once per campaign, pinned)
register_campaign("tiltrotor-hover-linear", CampaignDefinition(
    designs=DESIGNS, indices=campaigns.HOVER_INDICES, randomizes=campaigns.HOVER_RANDOMIZES,
    run=campaigns.hover_linear_case, synthesize=campaigns.hover_design,
    design_spec=campaigns.hover_design_spec, check_design=campaigns.check_hover_design,
    parameters=campaigns.HOVER_PARAMETERS,
    smoke_duration=campaigns.HOVER_SMOKE_DURATION,
    claims=(*((f"{dm} has a smaller {i} than {ref} (Table 7.2)", dm, ref, i) for ref, dm in DM_PAIRS
              for i in ("ISE", "IADU")),
            ("W∞-O.F. has a smaller IADU than W∞ (Table 7.2)", "W∞-O.F.", "W∞", "IADU"))))
