"""Result tables of the tilt-rotor experiments: ours beside Table 7.2 (linear hover designs,
§7.3.1), and the per-phase tracking, effort and tilt-schedule tables of the missions (§7.3.2).

Rows are lists of cells for :func:`sobolev_drake.report.write_table`.

See docs/experiments/tiltrotor-hover-linear.md, docs/experiments/tiltrotor-hover.md and
docs/experiments/tiltrotor-envelope.md.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from sobolev_drake.report import write_table

if TYPE_CHECKING:
    from sobolev_drake.tiltrotor.linear_design import HoverDesign

__all__ = ["THESIS_TABLE_7_2", "TABLE_7_2_COLUMNS", "table_7_2_title", "thesis_cells",
           "gamma_cell", "design_cells", "flight_row", "synthesis_failed_row", "sim_failed_row",
           "LITERAL_NOISE_COLUMNS", "literal_noise_row", "PHASE_COLUMNS", "phase_rows",
           "EFFORT_COLUMNS", "effort_rows", "mission_summary", "schedule_table",
           "design_columns", "design_row"]

#: Table 7.2: Table 7.2 column -> (ISE, IADU)
THESIS_TABLE_7_2 = {"W∞": (21.4, 2182.0), "W∞-D": (10.9, 1541.8), "W∞-O.F.": (60.7, 1376.2),
                    "W∞-O.F.D": (39.2, 1317.3)}

TABLE_7_2_COLUMNS = ["design", "γ (✓ certified)", "‖T_ζz‖∞", "‖T_vz‖∞", "delay margin [ms]",
                     "synthesis [s]", "ISE", "IADU", "ISE (thesis)", "IADU (thesis)", "notes"]


def table_7_2_title(duration: float) -> str:
    """Caption of the table beside Table 7.2.

    Parameters
    ----------
    duration : float
        Flight duration (s).

    Returns
    -------
    str
    """
    return (f"Table 7.2 beside ours (duration {duration:g} s; ‖T_ζz‖∞: wind → W∞ channel, "
            f"‖T_vz‖∞: von Kármán noise → W∞ channel; delay margin: uniform delay on the four "
            f"inputs that destabilizes the linear loop)")


def thesis_cells(spec: HoverDesign) -> tuple[float, float] | tuple[str, str]:
    """The thesis' (ISE, IADU) of a design's Table 7.2 column, or dashes.

    Parameters
    ----------
    spec : HoverDesign
        The design (:mod:`sobolev_drake.tiltrotor.linear_design`).

    Returns
    -------
    tuple
    """
    return THESIS_TABLE_7_2[spec.column] if spec.column else ("-", "-")


def gamma_cell(metrics: dict[str, Any]) -> str:
    """γ column: value, ✓ when certified, or why it is not a bound.

    Parameters
    ----------
    metrics : dict
        Scores of a design (:func:`~sobolev_drake.tiltrotor.linear_design.design_metrics`:
        ``gamma``, ``certified``, ``achieved``).

    Returns
    -------
    str
    """
    if metrics.get("certified") is None:
        return f"{metrics['gamma']:.4g} (solver value, not a bound)"
    if metrics["certified"]:
        return f"{metrics['gamma']:.4g} ✓"
    return f"{metrics['gamma']:.4g} ✗ (‖T‖∞ = {metrics['achieved']:.4g})"


def design_cells(name: str, metrics: dict[str, Any]) -> list[str]:
    """The first columns of a synthesized design's row of :data:`TABLE_7_2_COLUMNS`
    (design … synthesis).

    Parameters
    ----------
    name : str
        Row label.
    metrics : dict
        Its scores (:func:`~sobolev_drake.tiltrotor.linear_design.design_metrics`).

    Returns
    -------
    list of str
    """
    tau = metrics.get("delay_margin_s")
    margin = "-" if tau is None else ("∞" if np.isinf(tau) else f"{1e3 * tau:.3g}")
    return [name, gamma_cell(metrics), f"{metrics['gamma_wind']:.4g}", f"{metrics['gamma_common']:.4g}", margin,
            f"{metrics['solve_s']:.1f}"]


def flight_row(spec: HoverDesign, metrics: dict[str, Any], idx: dict[str, Any],
               stopped: str) -> list[str | float]:
    """Row of a flown design: its cells, ISE, IADU, the thesis' and the notes.

    Parameters
    ----------
    spec : HoverDesign
        The design.
    metrics : dict
        Its scores (``notes``; :func:`~sobolev_drake.tiltrotor.linear_design.design_metrics`).
    idx : dict
        Flight indices (``ise``, ``iadu``).
    stopped : str
        Why the flight stopped early ("" when it did not).

    Returns
    -------
    list
    """
    return [*design_cells(spec.label, metrics), f"{idx['ise']:.1f}", f"{idx['iadu']:.1f}",
            *thesis_cells(spec), "; ".join(([stopped.upper()] if stopped else []) + metrics["notes"])[:300]]


def synthesis_failed_row(spec: HoverDesign, error: str) -> list[str | float]:
    """Row of a design whose synthesis failed.

    Parameters
    ----------
    spec : HoverDesign
        The design.
    error : str
        The failure.

    Returns
    -------
    list
    """
    return [spec.label, "synthesis failed", "-", "-", "-", "-", "-", "-", *thesis_cells(spec), error[:200]]


def sim_failed_row(spec: HoverDesign, metrics: dict[str, Any], error: str) -> list[str | float]:
    """Row of a design whose flight raised.

    Parameters
    ----------
    spec : HoverDesign
        The design.
    metrics : dict
        Its scores (:func:`~sobolev_drake.tiltrotor.linear_design.design_metrics`).
    error : str
        The failure.

    Returns
    -------
    list
    """
    return [*design_cells(spec.label, metrics), "sim failed", "-", *thesis_cells(spec), error[:200]]


LITERAL_NOISE_COLUMNS = ["design", "flight", "RMS position [m]", "final [m]", "max |φ|,|θ| [°]",
                         "max tilt [°]", "ISE", "IADU"]


def literal_noise_row(name: str, m: dict[str, Any]) -> list[str]:
    """Row of the literal-noise table (:data:`LITERAL_NOISE_COLUMNS`).

    Parameters
    ----------
    name : str
        Row label.
    m : dict
        Flight indices, or ``{"sim_error": ...}``.

    Returns
    -------
    list
    """
    if "sim_error" in m:
        return [name, "sim failed: " + m["sim_error"][:120], *["-"] * 6]
    return [name, m["stopped"] or "flies to the end", f"{m['rms_pos_m']:.2f}", f"{m['final_pos_err_m']:.2f}",
            f"{m['max_attitude_deg']:.1f}", f"{m['max_tilt_deg']:.1f}", f"{m['ise']:.1f}", f"{m['iadu']:.1f}"]


def _fmt(v, nd=2):
    return "-" if v is None else (f"{v:.{nd}f}" if isinstance(v, float) else str(v))


PHASE_COLUMNS = ["phase", "kind", "from [s]", "to [s]", "RMS ‖e‖ [m]", "max ‖e‖ [m]",
                 "goal RMS [m]", "goal met"]


def phase_rows(phases: Sequence[dict[str, Any]]) -> list[list[str]]:
    """Rows of the per-phase tracking table (:data:`PHASE_COLUMNS`).

    Parameters
    ----------
    phases : list of dict
        :func:`~sobolev_drake.tiltrotor.mission_metrics.phase_metrics`.

    Returns
    -------
    list of list
    """
    return [[r["phase"], r["kind"], _fmt(r["from_s"], 1), _fmt(r["to_s"], 1), _fmt(r["rms_m"]),
             _fmt(r["max_m"]), _fmt(r["goal_rms_m"], 1), _fmt(r["goal_met"])] for r in phases]


EFFORT_COLUMNS = ["actuator", "unit", "RMS [unit]", "IADU ∫|du| [unit]", "time on bound [s]"]


def effort_rows(effort: dict[str, dict[str, float]]) -> list[list[str]]:
    """Rows of the effort table (:data:`EFFORT_COLUMNS`).

    Parameters
    ----------
    effort : dict
        :func:`~sobolev_drake.tiltrotor.mission_metrics.effort_metrics`.

    Returns
    -------
    list of list
    """
    from sobolev_drake.tiltrotor.mission_metrics import ACTUATOR_LABELS
    return [[*ACTUATOR_LABELS.get(k, (k, "-")), _fmt(v["rms"], 3), _fmt(v["iadu"], 2),
             _fmt(v.get("time_on_bound_s"), 2)] for k, v in effort.items()]


def design_columns(metrics: dict[str, Any]) -> list[str]:
    """Columns of the designs table: one RMS per phase of ``metrics``, final error, time on
    bounds, attitude (units in every header).

    Parameters
    ----------
    metrics : dict
        :func:`~sobolev_drake.tiltrotor.mission_metrics.score_mission` of the claimed design.

    Returns
    -------
    list of str
    """
    return (["design"] + [f"RMS {r['phase']} [m]" for r in metrics["phases"]]
            + ["final error [m]", "time on bounds, all actuators [s]", "max |φ|,|θ| [°]"])


def design_row(label: str, metrics: dict[str, Any]) -> list[str]:
    """Row of the designs table (:func:`design_columns`).

    Parameters
    ----------
    label : str
        The design.
    metrics : dict
        Its :func:`~sobolev_drake.tiltrotor.mission_metrics.score_mission`.

    Returns
    -------
    list
    """
    bounds = sum(v.get("time_on_bound_s", 0.0) for v in metrics["effort"].values())
    return ([label] + [_fmt(r["rms_m"]) for r in metrics["phases"]]
            + [_fmt(metrics["final_position_error_m"]), _fmt(bounds, 1),
               _fmt(max(metrics["max_abs_roll_deg"], metrics["max_abs_pitch_deg"]), 1)])


def mission_summary(metrics: dict[str, Any]) -> str:
    """One paragraph: final position error against its goal, attitude extremes, allocation
    residual.

    Parameters
    ----------
    metrics : dict
        :func:`~sobolev_drake.tiltrotor.mission_metrics.score_mission`.

    Returns
    -------
    str
    """
    return (f"\nfinal position error {metrics['final_position_error_m']:.3f} m "
            f"(goal < {metrics['goal_landing_m']} m); max |φ| {metrics['max_abs_roll_deg']:.1f}°, "
            f"max |θ| {metrics['max_abs_pitch_deg']:.1f}°, allocation residual RMS "
            f"{metrics['rms_allocation_residual']:.3g} (max {metrics['max_allocation_residual']:.3g})\n")


def schedule_table(out_dir: str | os.PathLike, speeds: Sequence[float] = (0, 5, 10, 15, 20, 24, 27, 30, 33, 34)
                   ) -> tuple[Path, Path, str]:
    """Tilt reference α(V): the plant's level-flight trims beside the mission file's polynomial.

    Parameters
    ----------
    out_dir : path-like
        Folder of ``tiltrotor-tilt-schedule.md`` / ``.json``.
    speeds : sequence of float
        Forward speeds (m/s).

    Returns
    -------
    (Path, Path, str)
        As :func:`sobolev_drake.report.write_table`.
    """
    from sobolev_drake.tiltrotor.tilt_schedule import tilt_reference_polynomial, tilt_schedule
    rows = []
    for tr in tilt_schedule(np.asarray(speeds, dtype=float)):
        a_poly = float(tilt_reference_polynomial(tr.V))
        rows.append([f"{tr.V:g}", f"{tr.q[0]:.4f}", f"{a_poly:.4f}", f"{a_poly - tr.q[0]:+.4f}",
                     f"{tr.q[3]:.4f}", f"{tr.n[0]:.2f}"])
    return write_table(out_dir, "tiltrotor-tilt-schedule",
                       ["V [m/s]", "α trim (plant) [rad]", "α polynomial (data) [rad]",
                        "difference [rad]", "θ trim [rad]", "n trim [rev/s]"], rows,
                       title="Tilt reference: plant level-flight trims vs mission-file polynomial")
