"""Scores of a tilt-rotor mission flight (thesis §7.3.2): tracking per phase, effort, bounds.

Tracking is scored per phase against goals of our own (:data:`GOAL_RMS`, :data:`GOAL_LANDING`);
the thesis gives figures, not numbers.

See docs/experiments/tiltrotor-hover.md and docs/experiments/tiltrotor-envelope.md.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from sobolev_drake.tiltrotor.mission import CRUISE, HOVER, TRANSITION, mission_phases

__all__ = ["GOAL_RMS", "GOAL_LANDING", "GOAL_LANDING_BY_SCENARIO", "ACTUATORS", "ACTUATOR_LABELS",
           "phase_metrics", "effort_metrics", "score_mission"]

#: goal on the RMS position error per phase kind (m); transition and cruise were 3 m while
#: the thesis tuning was the only design (it misses them), 1 m since the envelope schedule
GOAL_RMS = {HOVER: 1.0, TRANSITION: 1.0, CRUISE: 1.0}
#: goal on the final position error (m), per scenario (hover mission, full envelope)
GOAL_LANDING_BY_SCENARIO = {1: 0.5, 2: 0.25}
#: the hover mission's (scenario 1) landing goal (m)
GOAL_LANDING = GOAL_LANDING_BY_SCENARIO[1]
#: names of the allocated inputs τ̄ (7.62), in order
ACTUATORS = ["fPR", "fPL", "tauSR", "tauSL", "dWR", "dWL", "dTR", "dTL"]
#: one display name and the SI unit of every actuator key (tables and figures use these):
#: thrusts, servo torques, the four surfaces (wing / tail right / left), propeller speeds
ACTUATOR_LABELS = {"fPR": ("f_PR", "N"), "fPL": ("f_PL", "N"), "tauSR": ("τ_sR", "N m"),
                   "tauSL": ("τ_sL", "N m"), "dWR": ("δ_WR", "rad"), "dWL": ("δ_WL", "rad"),
                   "dTR": ("δ_TR", "rad"), "dTL": ("δ_TL", "rad"), "nPR": ("n_R", "rev/s"),
                   "nPL": ("n_L", "rev/s")}


def phase_metrics(t: ArrayLike, pos: ArrayLike, pos_ref: ArrayLike,
                  phases: Sequence[tuple[str, float, float, str | None]]) -> list[dict[str, Any]]:
    """RMS and max of the 3-D position error ‖p − p_r‖ per phase (uniformly sampled logs).

    Parameters
    ----------
    t : array_like, shape (N,)
        Sample times.
    pos, pos_ref : array_like, shape (3, N)
        Flown and reference positions.
    phases : list of (str, float, float, str or None)
        (name, start, end, kind), e.g. :func:`~sobolev_drake.tiltrotor.mission.mission_phases`.

    Returns
    -------
    list of dict
        Per phase with samples: ``phase``, ``kind``, ``from_s``, ``to_s``, ``rms_m``,
        ``max_m``, ``goal_rms_m`` (None without a goal) and ``goal_met``.
    """
    t = np.asarray(t)
    err = np.linalg.norm(np.asarray(pos) - np.asarray(pos_ref), axis=0)
    rows = []
    for name, a, b, kind in phases:
        m = (t >= a) & (t < b) if b < t[-1] else (t >= a)
        if not np.any(m):
            continue
        e = err[m]
        rows.append({"phase": name, "kind": kind or "-", "from_s": a, "to_s": min(b, t[-1]),
                     "rms_m": float(np.sqrt(np.mean(e**2))), "max_m": float(np.max(e)),
                     "goal_rms_m": GOAL_RMS.get(kind) if kind else None})
    for r in rows:
        r["goal_met"] = None if r["goal_rms_m"] is None else bool(r["rms_m"] < r["goal_rms_m"])
    return rows


def effort_metrics(t: ArrayLike, tau_bar: np.ndarray, speeds: np.ndarray,
                   saturation: np.ndarray) -> dict[str, dict[str, float]]:
    """Control effort and time on actuator bounds.

    Effort: RMS of each actuator signal and IADU ∫|du/dt| dt (finite differences of the
    zero-order-hold logs).  Time on bounds: seconds during which each actuator sat on a bound.

    Parameters
    ----------
    t : array_like, shape (N,)
        Sample times.
    tau_bar : ndarray, shape (8, N)
        Allocated inputs (:data:`ACTUATORS`).
    speeds : ndarray, shape (2, N)
        Propeller speeds (rev/s).
    saturation : ndarray, shape (8, N)
        Nonzero (±1) where an input sat on a bound.

    Returns
    -------
    dict
        Actuator name -> {``rms``, ``iadu``, ``time_on_bound_s``}; ``nPR``, ``nPL`` ->
        {``rms``, ``max``, ``iadu``}.
    """
    t = np.asarray(t)
    dt = np.diff(t)
    out = {}
    for i, nm in enumerate(ACTUATORS):
        out[nm] = {"rms": float(np.sqrt(np.mean(tau_bar[i] ** 2))),
                   "iadu": float(np.sum(np.abs(np.diff(tau_bar[i])))),
                   "time_on_bound_s": float(np.sum(dt * (np.abs(saturation[i, :-1]) > 0.5)))}
    for i, nm in enumerate(["nPR", "nPL"]):
        out[nm] = {"rms": float(np.sqrt(np.mean(speeds[i] ** 2))),
                   "max": float(np.max(speeds[i])),
                   "iadu": float(np.sum(np.abs(np.diff(speeds[i]))))}
    return out


def score_mission(data: dict[str, np.ndarray], scenario: int, duration: float) -> dict[str, Any]:
    """Metrics of a mission flight: per-phase errors, landing error, effort, bounds,
    attitude/tilt extremes.

    Parameters
    ----------
    data : dict
        Logs of :func:`~sobolev_drake.tiltrotor.mission.simulate_mission`.
    scenario : {1, 2}
        The mission.
    duration : float
        Its duration (s).

    Returns
    -------
    dict
        ``phases``, ``effort``, ``final_position_error_m``, ``goal_landing_m``
        (:data:`GOAL_LANDING_BY_SCENARIO`), ``max_abs_roll_deg``,
        ``max_abs_pitch_deg``, ``tilt_range_deg``, ``max_allocation_residual``,
        ``rms_allocation_residual``, ``finite``, ``duration_s``, ``bounds_check``.
    """
    t, q = data["t"], data["x"][:8]
    phases = mission_phases(scenario, duration)
    rows = phase_metrics(t, q[5:8], data["reference"][0:3], phases)
    effort = effort_metrics(t, data["tau_bar"], data["propeller_speed"], data["saturation"])
    land = float(np.linalg.norm(q[5:8, -1] - data["reference"][0:3, -1]))
    finite = bool(np.all(np.isfinite(data["x"])))
    tau, dmax = data["tau_bar"], 5 * np.pi / 36
    bounds_check = {
        "tau_within_bounds": bool(np.all(tau[:2] >= -1e-9) and np.all(tau[:2] <= 100 + 1e-9)
                                  and np.all(np.abs(tau[2:4]) <= 2 + 1e-9)
                                  and np.all(np.abs(tau[4:]) <= dmax + 1e-9)),
        "speeds_nonnegative": bool(np.all(data["propeller_speed"] >= 0)),
        "max_speed_rev_s": float(np.max(data["propeller_speed"]))}
    return {"phases": rows, "effort": effort, "final_position_error_m": land,
            "goal_landing_m": GOAL_LANDING_BY_SCENARIO[scenario],
            "max_abs_roll_deg": float(np.degrees(np.max(np.abs(q[2])))),
            "max_abs_pitch_deg": float(np.degrees(np.max(np.abs(q[3])))),
            "tilt_range_deg": [float(np.degrees(np.min(q[:2]))), float(np.degrees(np.max(q[:2])))],
            "max_allocation_residual": float(np.max(data["allocation_residual"])),
            "rms_allocation_residual": float(np.sqrt(np.mean(data["allocation_residual"] ** 2))),
            "finite": finite, "duration_s": float(t[-1]), "bounds_check": bounds_check}
