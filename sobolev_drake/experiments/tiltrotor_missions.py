"""Tilt-rotor missions of thesis §7.3.2: nonlinear W∞ with control allocation.

* ``tiltrotor-hover``    — scenario 1 (helicopter mode, Table 7.1 path, lateral wind, force
  pulses);
* ``tiltrotor-envelope`` — scenario 2 (take-off while accelerating, 33 m/s cruise, turn,
  deceleration and landing, head wind and gusts; flagship of ``make demo``).

The mission (diagram, flight) is :mod:`sobolev_drake.tiltrotor.mission`, its scores
:mod:`sobolev_drake.tiltrotor.mission_metrics`.  Tilt references come from the plant's
level-flight trims or, with ``schedule="data"``, from the mission file's polynomial.
Tracking is scored per phase against goals of our own.

See docs/experiments/tiltrotor-hover.md and docs/experiments/tiltrotor-envelope.md.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Sequence

from sobolev_drake import viz
from sobolev_drake.campaign import CampaignDefinition, register_campaign
from sobolev_drake.experiments import Claim, ExperimentResult, register
from sobolev_drake.report import write_table
from sobolev_drake.tiltrotor import campaigns, tables
from sobolev_drake.tiltrotor.mission import DURATIONS, simulate_mission
from sobolev_drake.tiltrotor.law import DESIGNS as DESIGN_LABELS
from sobolev_drake.tiltrotor.mission_metrics import score_mission
from sobolev_drake.tiltrotor.plots import plot_mission

SMOKE_DURATION = 10.0
NAMES = {1: "tiltrotor-hover", 2: "tiltrotor-envelope"}


def run_mission(scenario: int, out_dir: str | Path, *, duration: float | None = None, record: bool = False,
                smoke: bool = False, schedule: str = "plant", design: str = "thesis",
                compare: Sequence[str] = ()) -> ExperimentResult:
    """Fly mission ``scenario`` (1 or 2), score it, write figures, tables and metrics, check
    the claims; ``schedule``: tilt references, ``design``: the law's weighting
    (:func:`~sobolev_drake.tiltrotor.mission.build_mission`); ``compare``: other designs flown
    on the same mission for the designs table (not claimed)."""
    name = NAMES[scenario]
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    if duration is None:
        duration = SMOKE_DURATION if smoke else DURATIONS[scenario]
    built, data = simulate_mission(scenario, duration, schedule=schedule, record=record,
                                   progress=not smoke, design=design)
    metrics = score_mission(data, scenario, duration)
    metrics["design"] = DESIGN_LABELS[design]
    res = ExperimentResult(name=name, metrics=metrics)
    res.outputs.update(plot_mission(data, out_dir, name, scenario=scenario, duration=duration))
    md, js, text = write_table(out_dir, f"{name}_phases", tables.PHASE_COLUMNS,
                               tables.phase_rows(metrics["phases"]),
                               title=f"{name}: position tracking per phase (duration {duration:g} s)")
    md2, js2, text2 = write_table(out_dir, f"{name}_effort", tables.EFFORT_COLUMNS,
                                  tables.effort_rows(metrics["effort"]),
                                  title=f"{name}: control effort and time on actuator bounds")
    res.table_markdown = text + "\n" + text2 + tables.mission_summary(metrics)
    if compare:
        rows = [tables.design_row(DESIGN_LABELS[design] + " (claimed)", metrics)]
        for other in compare:
            _, d2 = simulate_mission(scenario, duration, schedule=schedule, design=other,
                                     progress=not smoke)
            m2 = score_mission(d2, scenario, duration)
            metrics.setdefault("compared", {})[DESIGN_LABELS[other]] = m2
            rows.append(tables.design_row(DESIGN_LABELS[other], m2))
        md4, js4, text4 = write_table(out_dir, f"{name}_designs", tables.design_columns(metrics),
                                      rows, title=f"{name}: the law's designs on the same mission")
        res.outputs.update({"designs_md": md4, "designs_json": js4})
        res.table_markdown += "\n" + text4
    if scenario == 2 and not smoke:
        md3, js3, text3 = tables.schedule_table(out_dir)
        res.outputs.update({"schedule_md": md3, "schedule_json": js3})
        res.table_markdown += (f"\ntilt reference used: {schedule!r} schedule\n\n" + text3)
        from sobolev_drake.tiltrotor.envelope_analysis import FROZEN_COLUMNS, frozen_point_rows
        md5, js5, text5 = write_table(out_dir, f"{name}_frozen_points", FROZEN_COLUMNS,
                                      frozen_point_rows(),
                                      title="closed loop linearized at level-flight trims "
                                            "(plant by Drake, law by central differences)")
        res.outputs.update({"frozen_md": md5, "frozen_json": js5})
        res.table_markdown += "\n" + text5
    report = out_dir / f"{name}_report.md"
    report.write_text(f"# {name}\n\n" + res.table_markdown)
    (out_dir / f"{name}_metrics.json").write_text(json.dumps(metrics, indent=1))
    res.outputs.update({"phases_md": md, "phases_json": js, "effort_md": md2, "effort_json": js2,
                        "report": report, "metrics_json": out_dir / f"{name}_metrics.json"})
    for r in metrics["phases"]:
        if r["goal_met"] is not None:
            res.claims.append(Claim(f"{r['phase']} ({r['kind']}): RMS position error < "
                                    f"{r['goal_rms_m']:g} m", r["goal_met"],
                                    f"{r['rms_m']:.2f} m"))
    if not smoke and duration >= DURATIONS[scenario]:
        goal = metrics["goal_landing_m"]
        res.claims.append(Claim(f"final point reached within {goal} m",
                                metrics["final_position_error_m"] < goal,
                                f"{metrics['final_position_error_m']:.2f} m"))
    res.claims.append(Claim("attitude within ±60° and state finite",
                            metrics["finite"] and max(metrics["max_abs_roll_deg"],
                                                      metrics["max_abs_pitch_deg"]) < 60, ""))
    if record and built.get("meshcat") is not None:
        viz.draw_reference_and_flown(built["meshcat"], built["reference"], duration, data["x"][5:8])
        # The envelope spans ~2 km: a camera rig keyed to the flown path keeps the aircraft in view.
        viz.follow_camera(built["recorder"], data["t"], data["x"][5:8].T, meshcat=built["meshcat"],
                          radius=1.5, elevation_deg=15.0, azimuth_deg=-120.0)
        html = out_dir / f"{name}.html"
        viz.save_recording_html(built["meshcat"], built["recorder"], html)
        res.outputs["recording"] = html
    return res


@register("tiltrotor-hover", "Tilt-rotor helicopter mode (Table 7.1 path), nonlinear W∞ + "
          "allocation, lateral wind and force pulses", default_duration=200.0,
          thesis_ref="7.3.2 scenario 1, Figs 7.14-7.20")
def run_hover(out_dir: str | Path, *, duration: float | None = None, record: bool = False,
              smoke: bool = False) -> ExperimentResult:
    return run_mission(1, out_dir, duration=duration, record=record, smoke=smoke)


@register("tiltrotor-envelope", "Tilt-rotor full flight envelope: take-off, transition, 33 m/s "
          "cruise, turn, transition, landing; nonlinear W∞ + allocation with wind gusts",
          default_duration=250.0, flagship=10, thesis_ref="7.3.2 scenario 2, Figs 7.21-7.27")
def run_envelope(out_dir: str | Path, *, duration: float | None = None, record: bool = False,
                 smoke: bool = False, schedule: str = "plant", design: str = "scheduled") -> ExperimentResult:
    """``schedule``: "plant" (our level-flight trims, default) or "data" (mission-file
    polynomial, as the thesis author's simulator) for the tilt references; ``design``:
    "scheduled" (the envelope gain schedule, default, claimed) or "thesis" (the thesis tuning
    of §7.3.2).  A full run also flies the other design for the designs table."""
    compare = () if smoke else tuple(d for d in DESIGN_LABELS if d != design)
    return run_mission(2, out_dir, duration=duration, record=record, smoke=smoke,
                       schedule=schedule, design=design, compare=compare)


# the nonlinear W∞ law (scheduled and thesis tuning, paired) under drawn gusts, force pulses
# and constant wind: distributions of the mission's scores, the share of flights flown
# through, the goals missed and the paired comparison
register_campaign("tiltrotor-envelope", CampaignDefinition(
    designs=tuple(campaigns.ENVELOPE_DESIGNS), indices=campaigns.ENVELOPE_INDICES,
    randomizes=campaigns.ENVELOPE_RANDOMIZES, run=campaigns.envelope_case, parameters=campaigns.ENVELOPE_PARAMETERS,
    smoke_duration=campaigns.ENVELOPE_SMOKE_DURATION))
