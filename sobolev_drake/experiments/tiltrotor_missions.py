"""Tilt-rotor missions of thesis §7.3.2: nonlinear W∞ with control allocation.

* ``tiltrotor-hover``    — scenario 1 (helicopter mode, Table 7.1 path, lateral wind 3 m/s,
  −15 N force pulses along y and z);
* ``tiltrotor-envelope`` — scenario 2 (take-off while accelerating, 33 m/s cruise, 3/4 turn,
  deceleration and landing, head wind and gusts; flagship of ``make demo``).

Wind the controller measures (Assumption 19) is the constant wind; gusts are unmeasured
disturbances (thesis footnote 8).  Force disturbances act at the main-body centre of mass in
the inertial frame (``force_disturbance`` port of the plant).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import (Adder, ConstantVectorSource, TrajectorySource,
                                        VectorLogSink)
from pydrake.trajectories import PiecewisePolynomial

from sobolev_drake.data import load
from sobolev_drake.experiments import Claim, ExperimentResult, register

# --- mission bookkeeping -------------------------------------------------------------------------
HOVER, TRANSITION, CRUISE = "hover", "transition", "cruise"
# Goals we report against (brief of issue 7): RMS position error per phase kind, landing error.
GOAL_RMS = {HOVER: 1.0, TRANSITION: 3.0, CRUISE: 3.0}
GOAL_LANDING = 0.5
SMOKE_DURATION = 10.0


def scenario_1_phases(duration=200.0):
    """Phases of the Table 7.1 path.  The first 10 s are the acquisition of the path from
    q(0) = 0 (the reference starts 20 m away), reported separately and not held to a goal."""
    bounds = [("acquire", 0.0, 10.0, None), ("helix_climb", 10.0, 105.0, HOVER),
              ("translate", 105.0, 125.0, HOVER), ("descend", 125.0, 186.5, HOVER),
              ("landed_hold", 186.5, math.inf, HOVER)]
    return _clip_phases(bounds, duration)


def scenario_2_phases(duration=250.0):
    """Phases of the full-envelope mission (durations from the mission data file)."""
    kinds = {"accelerate_climb": TRANSITION, "cruise_1": CRUISE, "turn": CRUISE,
             "cruise_2": CRUISE, "decelerate_descend": TRANSITION, "hold": HOVER}
    t, bounds = 0.0, []
    for ph in load("tiltrotor_missions")["scenario_2_full_envelope"]["reference"]["phases"]:
        d = ph["duration"]
        end = math.inf if isinstance(d, str) else t + float(d)
        bounds.append((ph["name"], t, end, kinds[ph["name"]]))
        t = end
    return _clip_phases(bounds, duration)


def _clip_phases(bounds, duration):
    out = []
    for name, a, b, kind in bounds:
        if a < duration:
            out.append((name, a, min(b, duration), kind))
    return out


def pulses(events, duration):
    """Zero-order-hold 3-D profile from [{"axis", "value", "from", "to"}] events → (times, values)."""
    axis = {"x": 0, "y": 1, "z": 2}
    knots = sorted({0.0, float(duration)} | {float(e[k]) for e in events for k in ("from", "to")
                                               if float(e[k]) <= duration})
    knots = [k for k in knots if k <= duration]
    values = np.zeros((3, len(knots)))
    for j, tk in enumerate(knots):
        for e in events:
            if float(e["from"]) <= tk < float(e["to"]):
                values[axis[e["axis"]], j] += float(e["value"])
    return np.array(knots), values


def phase_metrics(t, pos, pos_ref, phases):
    """RMS and max of the 3-D position error ‖p − p_r‖ per phase (uniformly sampled logs)."""
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


def effort_metrics(t, tau_bar, speeds, saturation):
    """Control effort and time on actuator bounds.

    Effort: RMS of each actuator signal and IADU ∫|du/dt| dt (finite differences of the
    zero-order-hold logs).  Time on bounds: seconds during which each actuator sat on a bound.
    """
    t = np.asarray(t)
    dt = np.diff(t)
    names = ["fPR", "fPL", "tauSR", "tauSL", "dWR", "dWL", "dTR", "dTL"]
    out = {}
    for i, nm in enumerate(names):
        out[nm] = {"rms": float(np.sqrt(np.mean(tau_bar[i] ** 2))),
                   "iadu": float(np.sum(np.abs(np.diff(tau_bar[i])))),
                   "time_on_bound_s": float(np.sum(dt * (np.abs(saturation[i, :-1]) > 0.5)))}
    for i, nm in enumerate(["nPR", "nPL"]):
        out[nm] = {"rms": float(np.sqrt(np.mean(speeds[i] ** 2))),
                   "max": float(np.max(speeds[i])),
                   "iadu": float(np.sum(np.abs(np.diff(speeds[i]))))}
    return out
