"""Monte-Carlo cases of the tilt-rotor experiments (``sobolev-drake campaign NAME``).

* ``tiltrotor-hover-linear``: one Table 7.2 design (:data:`~.linear_design.DESIGN_SPECS`)
  flown along the Table 7.1 path (:func:`hover_linear_case`).  A seed draws the von Kármán
  turbulence realization and nothing else; the truth's masses, inertias and the turbulence
  intensity σ may be perturbed (``--perturb``).  The designs are synthesized once per campaign
  on the nominal model (:func:`hover_design`, pinned in the output folder by the runner) and
  the controller keeps it.
* ``tiltrotor-envelope``: the full-envelope mission with the nonlinear W∞ law, scheduled and
  thesis tuning (:func:`envelope_case`).  The mission file's gusts and force pulses are
  deterministic, so a seed draws each pulse's amplitude and time around them
  (:func:`envelope_disturbances`) and the constant wind (:func:`envelope_wind`); masses and
  inertias may be perturbed, the controller keeps the nominal model.

Everything random derives from the case's seed (``Case.rng``), never from its design, so the
designs of one seed meet the same wind: comparisons are paired.  A case takes a
``sobolev_drake.campaign.Case``; the experiments register the campaigns.

See docs/experiments/tiltrotor-hover-linear.md and docs/experiments/tiltrotor-envelope.md.
"""

from __future__ import annotations

import functools
import math
import re
from collections.abc import Sequence
from dataclasses import replace
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    from sobolev_drake.campaign.case import Case
    from sobolev_drake.synthesis.problem import SynthesisResult
    from sobolev_drake.systems.wind import VonKarmanParameters
    from sobolev_drake.tiltrotor.linear_design import HoverDesign
    from sobolev_drake.tiltrotor.params import TiltrotorParams

__all__ = ["HOVER_INDICES", "HOVER_PARAMETERS", "HOVER_RANDOMIZES", "HOVER_SMOKE_DURATION",
           "ENVELOPE_INDICES", "ENVELOPE_PARAMETERS", "ENVELOPE_RANDOMIZES",
           "ENVELOPE_SMOKE_DURATION", "ENVELOPE_DESIGNS", "ENVELOPE_PHASES", "MASS_INERTIA",
           "WIND_SPEED", "envelope_wind", "envelope_percentiles",
           "plant_params", "hover_design", "hover_turbulence", "hover_linear_case",
           "envelope_disturbances", "envelope_case"]

#: vehicle parameters a case may scale (the simulated truth only)
MASS_INERTIA = {"m1": "main-body mass (kg) of the simulated truth",
                "m2": "right thruster-group mass (kg)", "m3": "left thruster-group mass (kg)",
                "I_C1": "main-body inertia tensor (scaled as a whole)",
                "I_C2": "right thruster-group inertia tensor", "I_C3": "left thruster-group inertia tensor"}

HOVER_DURATION = 200.0
#: a smoke case: a few seconds, turbulence switched on from t = 0 (it starts at 30 s in a full
#: case) so that the seed matters
HOVER_SMOKE_DURATION = 5.0
HOVER_INDICES = ("ISE", "IADU", "max tilt [deg]", "max |φ|,|θ| [deg]", "RMS position error [m]",
                 "final position error [m]")
HOVER_PARAMETERS = {**MASS_INERTIA, "sigma": "von Kármán intensities σu, σv, σw (one factor)"}
HOVER_RANDOMIZES = "the von Kármán turbulence realization (noise seed and initial filter state)"

ENVELOPE_DURATION = 250.0
#: the envelope's designs: label -> keyword values of ``simulate_mission`` (the nonlinear W∞
#: law with the plant's trim schedule: the envelope gain schedule, as the experiment flies it,
#: and the thesis' one tuning for every flight mode)
ENVELOPE_DESIGNS = {"scheduled W∞": {"schedule": "plant", "design": "scheduled"},
                    "thesis tuning, §7.3.2": {"schedule": "plant", "design": "thesis"}}
#: a smoke case flies the first 25 s: the first force pulse and (most seeds) the first gust
ENVELOPE_SMOKE_DURATION = 25.0
#: mission phases of scenario 2 (mission file order), one RMS index each
ENVELOPE_PHASES = ("accelerate_climb", "cruise_1", "turn", "cruise_2", "decelerate_descend", "hold")
ENVELOPE_INDICES = (*(f"RMS {p} [m]" for p in ENVELOPE_PHASES), "final position error [m]",
                    "goals missed", "IADU thrust [N]", "IADU servo [N m]", "IADU surfaces [rad]",
                    "time on bounds, all actuators [s]", "max |φ|,|θ| [deg]")
ENVELOPE_PARAMETERS = dict(MASS_INERTIA)
#: amplitude factor range and time shift range (s) of each drawn pulse
PULSE_SCALE, PULSE_SHIFT = (0.5, 1.5), 5.0
#: range of the drawn constant (measured) wind speed (m/s); its direction is uniform
WIND_SPEED = (0.0, 5.0)
ENVELOPE_RANDOMIZES = (f"each wind gust and force pulse of the mission: amplitude × U{PULSE_SCALE}, "
                       f"start shifted by U(±{PULSE_SHIFT:g} s), duration kept; the constant "
                       f"horizontal wind: speed U{WIND_SPEED} m/s, direction U(0°, 360°)")


def plant_params(case: Case) -> TiltrotorParams | None:
    """The simulated truth of ``case``: Table B.1 with its drawn mass and inertia factors.

    Parameters
    ----------
    case : Case
        A campaign case (its ``draws()``).

    Returns
    -------
    TiltrotorParams or None
        None when no mass or inertia is perturbed (the nominal plant, unchanged).
    """
    from sobolev_drake.tiltrotor.params import TiltrotorParams

    factors = {k: f for k, f in case.draws().items() if k in MASS_INERTIA}
    if not factors:
        return None
    base = TiltrotorParams()
    return base.with_(**{k: getattr(base, k) * f for k, f in factors.items()})


@functools.lru_cache(maxsize=None)
def _hover_setup():
    """Nominal trim, linearization and initial error, as the experiment's default run."""
    from sobolev_drake.tiltrotor.hover_flight import initial_error
    from sobolev_drake.tiltrotor.linearization import linearize
    from sobolev_drake.tiltrotor.params import TiltrotorParams
    from sobolev_drake.tiltrotor.trim import tiltrotor_model, trim_hover

    trim = trim_hover(tiltrotor_model(TiltrotorParams()))
    return trim, linearize(trim), initial_error(trim, "zero")


def hover_design_spec(label: str) -> HoverDesign:
    """What defines Table 7.2 design ``label`` (its :class:`~.linear_design.HoverDesign`); the
    campaign pins its fingerprint with the design.

    Parameters
    ----------
    label : str

    Returns
    -------
    HoverDesign
    """
    from sobolev_drake.tiltrotor.linear_design import DESIGN_SPECS

    return DESIGN_SPECS[label]


def check_hover_design(label: str, result: SynthesisResult) -> None:
    """Raise ``ValueError`` unless ``result`` is a controller :func:`hover_design` can return:
    a continuous-time :class:`~sobolev_drake.synthesis.problem.SynthesisResult` whose finite
    controller maps y = C Δx (20 or 18 measurements,
    :func:`~sobolev_drake.tiltrotor.linear_design.measurement_matrix`) to the 4 inputs, a
    state feedback with its 4 × 20 gain.

    Parameters
    ----------
    label : str
        The design (for messages).
    result : SynthesisResult
    """
    from sobolev_drake.synthesis.problem import SynthesisResult
    from sobolev_drake.tiltrotor.linear_design import measurement_matrix

    if not isinstance(result, SynthesisResult) or result.controller is None:
        raise ValueError(f"design {label!r} must be a SynthesisResult with a controller, got "
                         f"{type(result).__name__}")
    c = result.controller
    try:
        measurement_matrix(result)
    except ValueError as exc:
        raise ValueError(f"design {label!r}: {exc}") from None
    if c.nu != 4 or c.dt != 0 or not all(np.all(np.isfinite(m)) for m in c):
        raise ValueError(f"design {label!r} must have a finite continuous-time controller with 4 "
                         f"outputs, got {c.nu} outputs, dt = {c.dt}")
    if result.kind == "state_feedback" and np.shape(result.K) != (4, 20):
        raise ValueError(f"design {label!r}: a state feedback needs K of shape (4, 20), got "
                         f"{np.shape(result.K)}")


def hover_design(label: str) -> SynthesisResult:
    """A Table 7.2 design, synthesized as the experiment's default run does (transient
    regularization, default backends): seconds to minutes.

    A campaign calls it once per design and pins the result (``CampaignDefinition.synthesize``),
    because the dynamic-multiplier optima are singular LMIs whose γ moves in the 4th digit from
    one solve to the next: synthesizing per worker would fly slightly different controllers.

    Parameters
    ----------
    label : str
        A key of :data:`~sobolev_drake.tiltrotor.linear_design.DESIGN_SPECS`.

    Returns
    -------
    SynthesisResult
        What :func:`~sobolev_drake.tiltrotor.linear_design.design` returns: what
        :func:`hover_linear_case` flies, pinned in the design-file encoding.

    Raises
    ------
    DesignFailed
        When the synthesis fails (W∞-O.F.D (thesis LMI) does, after ~40 s); the message names
        the exception, without the solve's wall time, so every record of the design is the same.
    """
    from sobolev_drake.campaign import DesignFailed
    from sobolev_drake.tiltrotor.linear_design import DESIGN_SPECS, design

    if label not in DESIGN_SPECS:
        raise ValueError(f"label must be a Table 7.2 design {tuple(DESIGN_SPECS)}, got {label!r}")
    trim, lin, x0 = _hover_setup()
    try:
        full = design(lin, DESIGN_SPECS[label], initial_state=x0)
    except Exception as exc:  # noqa: BLE001 - the experiment reports it as a table row too
        why = re.sub(r"\s*\[LMI path: [^\]]*\]", "", str(exc).splitlines()[0] if str(exc) else "")
        raise DesignFailed(f"{type(exc).__name__}: {why[:300]}") from exc
    return full


def hover_turbulence(case: Case) -> tuple[int, VonKarmanParameters]:
    """Seed and parameters of the turbulence a hover case flies in (seed and draws only).

    Parameters
    ----------
    case : Case
        A ``tiltrotor-hover-linear`` case.

    Returns
    -------
    (int, VonKarmanParameters)
        Seed of :meth:`~sobolev_drake.systems.wind.VonKarmanTurbulence.seed` (from the
        "turbulence" stream) and the §7.3.1 parameters, σ scaled by the "sigma" draw and, in
        a smoke case, on from t = 0.
    """
    from sobolev_drake.systems.wind import hover_linear_turbulence

    seed = int(case.rng("turbulence").integers(0, 2**31 - 1))
    p = hover_linear_turbulence()
    factor = case.draws().get("sigma")
    if factor is not None:
        p = replace(p, sigma=tuple(float(factor * s) for s in p.sigma))
    if case.smoke:
        p = replace(p, t_on=0.0)
    return seed, p


def hover_linear_case(case: Case, result: SynthesisResult) -> dict[str, Any]:
    """Fly one Table 7.2 design of ``case`` on the (perturbed) nonlinear plant in its
    turbulence; success is the experiment's "tracks the path" claim (finite, not stopped,
    |φ|, |θ| < 60°).

    Parameters
    ----------
    case : Case
        A ``tiltrotor-hover-linear`` case (design: a Table 7.2 label).
    result : SynthesisResult
        Its design, from :func:`hover_design`.

    Returns
    -------
    dict
        "indices" (:data:`HOVER_INDICES`), "success", "failure", "peaks" (peak lateral wind).
    """
    from sobolev_drake.tiltrotor.hover_flight import flight_indices, simulate_design

    trim = _hover_setup()[0]
    seed, turbulence = hover_turbulence(case)
    duration = case.duration or (HOVER_SMOKE_DURATION if case.smoke else HOVER_DURATION)
    d = simulate_design(result, trim, duration, seed=seed, turbulence=turbulence,
                        plant_params=plant_params(case))
    idx = flight_indices(d, trim)
    failure = d["stopped"] or ("" if idx["finite"] else "state not finite")
    if not failure and idx["max_attitude_deg"] >= 60.0:
        failure = f"max |φ|,|θ| {idx['max_attitude_deg']:.1f}° ≥ 60°"
    values = (idx["ise"], idx["iadu"], idx["max_tilt_deg"], idx["max_attitude_deg"], idx["rms_pos_m"],
              idx["final_pos_err_m"])
    return {"indices": dict(zip(HOVER_INDICES, values)), "success": not failure, "failure": failure,
            "peaks": {"lateral wind [m/s]": idx["max_lateral_wind_m_s"]}}


def envelope_disturbances(case: Case) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """Wind gusts and force pulses of an envelope case, drawn around the mission file's.

    Each pulse (gusts first, then forces, in file order) draws its amplitude factor and then
    its time shift from the "disturbances" stream (:data:`PULSE_SCALE`, :data:`PULSE_SHIFT`).

    Parameters
    ----------
    case : Case
        A ``tiltrotor-envelope`` case (only its seed is used).

    Returns
    -------
    (list of dict, list of dict)
        Wind gusts and force pulses (``axis``, ``value``, ``from``, ``to``) for
        :func:`~sobolev_drake.tiltrotor.mission.simulate_mission`.
    """
    from sobolev_drake.data import load

    spec = load("tiltrotor_missions")["scenario_2_full_envelope"]
    rng = case.rng("disturbances")
    out = []
    for events in (spec.get("wind_gusts", []), spec.get("force_disturbances", [])):
        drawn = []
        for e in events:
            scale = float(rng.uniform(*PULSE_SCALE))
            shift = float(rng.uniform(-PULSE_SHIFT, PULSE_SHIFT))
            drawn.append({"axis": e["axis"], "value": float(e["value"]) * scale,
                          "from": float(e["from"]) + shift, "to": float(e["to"]) + shift})
        out.append(drawn)
    return out[0], out[1]


def envelope_wind(case: Case) -> NDArray[np.float64]:
    """Constant horizontal wind of an envelope case (its "wind" stream): speed uniform in
    :data:`WIND_SPEED`, direction uniform; measured by the controller (Assumption 19).

    Parameters
    ----------
    case : Case
        A ``tiltrotor-envelope`` case (only its seed is used).

    Returns
    -------
    ndarray, shape (3,)
        Inertial wind (m/s), vertical component 0.
    """
    rng = case.rng("wind")
    speed, heading = float(rng.uniform(*WIND_SPEED)), float(rng.uniform(0.0, 2 * np.pi))
    return np.array([speed * np.cos(heading), speed * np.sin(heading), 0.0])


def envelope_case(case: Case) -> dict[str, Any]:
    """Fly the full-envelope mission of ``case`` (nonlinear W∞ law of its design) on the (perturbed) plant
    under its drawn disturbances and score it as the experiment does.

    Success is the experiment's hard claim: the mission is flown through with a finite state
    and |φ|, |θ| < 60°.  Its tracking goals (RMS per phase,
    :data:`~sobolev_drake.tiltrotor.mission_metrics.GOAL_RMS`; landing error below
    :data:`~sobolev_drake.tiltrotor.mission_metrics.GOAL_LANDING_BY_SCENARIO` over the full mission) are
    the index "goals missed" (0: all met) and named in "failure" of a failed case: the
    thesis tuning misses several phase goals on every draw, and the statistics are taken over
    the successful cases only.

    Parameters
    ----------
    case : Case
        A ``tiltrotor-envelope`` case (design: a key of :data:`ENVELOPE_DESIGNS`).

    Returns
    -------
    dict
        "indices" (:data:`ENVELOPE_INDICES`; a phase not reached is NaN), "success",
        "failure" (why, with the goals missed; empty on success).
    """
    from sobolev_drake.tiltrotor.mission import simulate_mission
    from sobolev_drake.tiltrotor.mission_metrics import score_mission

    gusts, forces = envelope_disturbances(case)
    duration = case.duration or (ENVELOPE_SMOKE_DURATION if case.smoke else ENVELOPE_DURATION)
    _, data = simulate_mission(2, duration, plant_params=plant_params(case), wind_gusts=gusts,
                               force_disturbances=forces, constant_wind=envelope_wind(case),
                               **ENVELOPE_DESIGNS[case.design])
    m = score_mission(data, 2, duration)
    rms = {r["phase"]: r["rms_m"] for r in m["phases"]}
    land, e = m["final_position_error_m"], m["effort"]
    attitude = max(m["max_abs_roll_deg"], m["max_abs_pitch_deg"])
    missed = [f"{r['phase']} RMS {r['rms_m']:.2f} m ≥ {r['goal_rms_m']:g} m" for r in m["phases"]
              if r["goal_met"] is False]
    if not case.smoke and duration >= ENVELOPE_DURATION and not land < m["goal_landing_m"]:
        missed.append(f"landing error {land:.2f} m ≥ {m['goal_landing_m']} m")
    values = [*(rms.get(p, np.nan) for p in ENVELOPE_PHASES), land, float(len(missed)),
              e["fPR"]["iadu"] + e["fPL"]["iadu"], e["tauSR"]["iadu"] + e["tauSL"]["iadu"],
              sum(e[k]["iadu"] for k in ("dWR", "dWL", "dTR", "dTL")),
              sum(v.get("time_on_bound_s", 0.0) for v in e.values()), attitude]
    flown = m["finite"] and attitude < 60.0
    failure = "" if flown else "; ".join([f"max |φ|,|θ| {attitude:.1f}° (≥ 60° or state not finite)",
                                           *missed])
    return {"indices": dict(zip(ENVELOPE_INDICES, values)), "success": flown, "failure": failure}


def envelope_percentiles(records: Sequence[dict[str, Any]], design: str, q: float = 0.95, *,
                         confidence: float = 0.95, seed: int = 0) -> dict[str, dict[str, Any]]:
    """Per index, the ``q`` quantile of ``design``'s successful cases with a bootstrap interval
    (``campaign.stats.bootstrap_interval``): the tail the envelope goals are stated on.

    Parameters
    ----------
    records : sequence of dict
        Campaign records (``design``, ``success``, ``indices``).
    design : str
        The design summarized.
    q : float, default 0.95
        Quantile in (0, 1).
    confidence : float, default 0.95
        Coverage of the bootstrap interval.
    seed : int, default 0
        Seed of the bootstrap.

    Returns
    -------
    dict
        index -> {"n", "quantile", "interval" [low, high]} (NaN values dropped).

    Examples
    --------
    >>> recs = [{"design": "a", "success": True, "indices": {"e [m]": float(v)}} for v in range(101)]
    >>> envelope_percentiles(recs, "a")["e [m]"]["quantile"]
    95.0
    """
    from sobolev_drake.campaign.stats import bootstrap_interval

    if not 0 < q < 1:
        raise ValueError(f"q must be in (0, 1), got {q!r}")
    ok = [r for r in records if r.get("design") == design and r.get("success")]
    names = list(dict.fromkeys(k for r in ok for k in (r.get("indices") or {})))
    out = {}
    for name in names:
        v = np.array([r["indices"].get(name, np.nan) for r in ok], dtype=float)
        v = v[np.isfinite(v)]
        stat = (lambda x: float(np.quantile(x, q)))
        out[name] = {"n": int(v.size), "quantile": float(np.quantile(v, q)) if v.size else math.nan,
                     "interval": list(bootstrap_interval(v, stat, confidence=confidence, seed=seed))}
    return out
