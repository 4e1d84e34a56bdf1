"""Linear hover feedback flown on the nonlinear Drake quadrotor along the Table 6.3 path
(thesis 6.5.3), and the Table 6.4 indices of a flight.

Scenario: q(0) = :data:`Q0`, q̇(0) = 0; δy = 10 N on 10–15 s and δz = 10 sin(0.4πt) N on
25–30 s; Ω² = Ω²_hover + K(x̂ − x̂_r) clipped to [0, :data:`U_MAX_FACTOR` Ω²_hover].  A flight
whose tilt exceeds :data:`DIVERGED_TILT` is stopped.  The simulated vehicle, the disturbance
(:func:`disturbance_pulses`) and q(0) may be changed (a campaign's draws) while the controller
keeps the nominal trim.  See docs/experiments/quadrotor-polytopic.md.
"""

from __future__ import annotations

import time
from dataclasses import replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike
from pydrake.systems.framework import DiagramBuilder, EventStatus
from pydrake.systems.primitives import MatrixGain

from sobolev_drake.campaign.case import Case
from sobolev_drake.harness import LoggedLoop
from sobolev_drake.models.quadrotor import QuadrotorParams, add_quadrotor
from sobolev_drake.norms import iadu, ise
from sobolev_drake.simulation import simulate
from sobolev_drake.systems.disturbances import TimeProfiledForce
from sobolev_drake.systems.linear_controllers import LinearStateFeedback
from sobolev_drake.systems.reference_catalogue import table_6_3

__all__ = ["check_campaign_design", "Q0", "U_MAX_FACTOR", "DIVERGED_TILT", "QuadrotorHoverRig", "disturbance_pulses", "drawn_scenario",
           "flight_indices", "CAMPAIGN_INDICES", "campaign_flight"]

#: initial configuration [ϕ θ ψ x y z] of every flight
Q0 = np.array([0, 0, 0, 4.0, 0, 1.0])
U_MAX_FACTOR = 4.0  # Ω² ≤ 4 Ω²_hover (rotor speed ≤ 2 × hover), docs/design.md §8.1
DIVERGED_TILT = np.radians(80.0)  # a run is stopped (and its ISE set to inf) beyond this tilt


def disturbance_pulses(step: float = 10.0, step_from: float = 10.0, sine: float = 10.0,
                       sine_omega: float = 0.4 * np.pi,
                       sine_from: float = 25.0) -> list[dict[str, Any]]:
    """The scenario's generalized-force pulses (defaults): δy = ``step`` N for 5 s from
    ``step_from``, then δz = ``sine`` sin(``sine_omega`` t) N for 5 s from ``sine_from``.

    Parameters
    ----------
    step : float
        Amplitude of the δy step (N).
    step_from : float
        Start of the step (s).
    sine : float
        Amplitude of the δz sine (N).
    sine_omega : float
        Angular frequency of the sine (rad/s).
    sine_from : float
        Start of the sine (s).

    Returns
    -------
    list of dict
        Pulses for ``TimeProfiledForce(6, pulses)``.
    """
    return [{"index": 4, "value": float(step), "from": float(step_from), "to": float(step_from) + 5.0},
            {"index": 5, "value": lambda t: sine * np.sin(sine_omega * t), "from": float(sine_from),
             "to": float(sine_from) + 5.0}]


def drawn_scenario(rng_initial: np.random.Generator,
                   rng_disturbance: np.random.Generator) -> tuple[np.ndarray, list[dict[str, Any]]]:
    """A random version of the scenario (a campaign seed's): q(0) = :data:`Q0` + ±0.1 rad on
    each angle and ±0.5 m on each position; step and sine amplitudes 5–15 N, their start
    times ±2 s around 10 s and 25 s and the sine's frequency ±25 % around 0.2 Hz (uniform).

    Parameters
    ----------
    rng_initial : numpy.random.Generator
        Draws q(0) (six numbers).
    rng_disturbance : numpy.random.Generator
        Draws the disturbance (five numbers).

    Returns
    -------
    (ndarray, list of dict)
        q(0) for :meth:`QuadrotorHoverRig.run` and ``pulses`` for :class:`QuadrotorHoverRig`.
    """
    q0 = Q0 + np.r_[rng_initial.uniform(-0.1, 0.1, 3), rng_initial.uniform(-0.5, 0.5, 3)]
    r = rng_disturbance
    return q0, disturbance_pulses(r.uniform(5, 15), r.uniform(8, 12), r.uniform(5, 15),
                                  0.4 * np.pi * r.uniform(0.75, 1.25), r.uniform(23, 27))


class QuadrotorHoverRig(LoggedLoop):
    """The nonlinear closed loop of the scenario above (one diagram, reused for every run).

    Logs ``x``, ``x_ref`` (x̂_r), ``u`` (clipped Ω²), ``u_raw`` and ``w``.

    Parameters
    ----------
    record : bool
        Add a Meshcat recorder.
    log_period : float
        Sampling period of the logs (s).
    params : QuadrotorParams, optional
        The vehicle; ``QuadrotorParams.chapter6_nominal()`` by default.
    truth : QuadrotorParams, optional
        The simulated vehicle when it differs from ``params`` (the controller's trim Ω²_hover
        and limits stay those of ``params``).
    pulses : list of dict, optional
        The disturbance, :func:`disturbance_pulses` by default.
    """

    def __init__(self, *, record=False, log_period=0.01, params=None, truth=None, pulses=None):
        p = params or QuadrotorParams.chapter6_nominal()
        self.hover = p.hover_input()
        b = DiagramBuilder()
        self.h = add_quadrotor(b, truth or p)
        self.ctrl = b.AddSystem(LinearStateFeedback(np.zeros((4, 12)), u_r=np.full(4, self.hover),
                                                    reference_port=True, u_min=0.0,
                                                    u_max=U_MAX_FACTOR * self.hover))
        self.ref = b.AddSystem(table_6_3())
        sel = np.zeros((12, 9))  # [p_r; ṗ_r; p̈_r] → x̂_r = [0 0 0 p_r 0 0 0 ṗ_r]
        sel[3:6, 0:3] = np.eye(3)
        sel[9:12, 3:6] = np.eye(3)
        to_x = b.AddSystem(MatrixGain(sel))
        self.w = b.AddSystem(TimeProfiledForce(6, disturbance_pulses() if pulses is None else pulses))
        b.Connect(self.ref.GetOutputPort("reference"), to_x.get_input_port())
        b.Connect(to_x.get_output_port(), self.ctrl.GetInputPort("x_r"))
        b.Connect(self.h.x, self.ctrl.GetInputPort("x"))
        b.Connect(self.ctrl.GetOutputPort("u"), self.h.u)
        b.Connect(self.w.get_output_port(), self.h.disturbance)
        self.build(b, (("x", self.h.x), ("x_ref", to_x.get_output_port()), ("u", self.ctrl.GetOutputPort("u")),
                        ("u_raw", self.ctrl.GetOutputPort("u_raw")), ("w", self.w.get_output_port())),
                    log_period, record)

    def run(self, K: ArrayLike, duration: float, q0: ArrayLike | None = None) -> dict[str, Any]:
        """Fly Ω² = Ω²_hover + K (x̂ − x̂_r) for ``duration`` s from q(0) = ``q0``, q̇(0) = 0.

        Parameters
        ----------
        K : array_like, shape (4, 12)
            State-feedback gain in Ω² units.
        duration : float
            Simulated time (s); the run stops earlier beyond :data:`DIVERGED_TILT`.
        q0 : array_like, shape (6,), optional
            Initial configuration [ϕ θ ψ x y z]; :data:`Q0` by default.

        Returns
        -------
        dict
            The logs (see the class), ``t``, ``wall_s``, ``hover`` (Ω²_hover) and ``diverged``.
        """
        ctx = self.context
        ctx.SetTime(0.0)
        self.h.set_state(ctx, self.diagram, Q0 if q0 is None else np.asarray(q0, float), np.zeros(6))
        self.ctrl.set_gains(self.ctrl.GetMyMutableContextFromRoot(ctx), np.asarray(K))
        self.clear_logs(ctx)
        t0 = time.perf_counter()
        self.sim.set_monitor(self._monitor)  # stops diverging runs (saturated, tumbling) early
        try:
            simulate(self.diagram, ctx, duration, progress=False, simulator=self.sim, accuracy=1e-4,
                     max_step=0.02)
        finally:
            self.sim.clear_monitor()
        data = self.collect(ctx, t0)
        data["hover"] = self.hover
        data["diverged"] = bool(ctx.get_time() < duration - 1e-9)
        return data

    def _monitor(self, root_context):
        q, _ = self.h.get_state(root_context)
        if np.max(np.abs(q[:2])) > DIVERGED_TILT:
            return EventStatus.ReachedTermination(None, "tilt beyond DIVERGED_TILT")
        return EventStatus.Succeeded()


def flight_indices(d: dict[str, Any]) -> dict[str, float | bool]:
    """Table 6.4 indices of one flight of :class:`QuadrotorHoverRig`.

    ISE ∫eᵀe over the 12 error states (inf for a diverged run), IADU ∫Σ|dΩ_i/dt| with
    Ω_i = √Ω_i², the position ISE, the time in saturation, the Ω² range, the final position
    error and the maximum tilt.

    Parameters
    ----------
    d : dict
        A result of :meth:`QuadrotorHoverRig.run`.

    Returns
    -------
    dict
    """
    t, e = d["t"], (d["x"] - d["x_ref"]).T
    omega = np.sqrt(np.maximum(d["u"], 0.0))
    raw, hi = d["u_raw"], U_MAX_FACTOR * d["hover"]
    sat = np.any((raw < 0.0) | (raw > hi), axis=0)
    dt = np.diff(t, append=t[-1])
    diverged = d.get("diverged", False)
    return {"ise": float("inf") if diverged else float(np.sum(ise(t, e))), "diverged": diverged,
            "iadu": float(np.sum(iadu(t, omega.T))),
            "ise_position": float(np.sum(ise(t, e[:, 3:6]))),
            "saturation_s": float(np.sum(dt[sat])), "min_omega2": float(raw.min()), "max_omega2": float(raw.max()),
            "final_position_error_m": float(np.linalg.norm(e[-1, 3:6])),
            "max_tilt_deg": float(np.degrees(np.abs(d["x"][:2]).max())),
            "finite": bool(np.all(np.isfinite(d["x"])) and not diverged)}


#: the indices of a campaign record (lower is better): {record name: key of :func:`flight_indices`}
CAMPAIGN_INDICES = {"ISE": "ise", "IADU": "iadu", "saturated [s]": "saturation_s", "ISE position": "ise_position",
                    "final position error [m]": "final_position_error_m", "max tilt [deg]": "max_tilt_deg"}


def check_campaign_design(label: str, result: object) -> None:
    """Raise ``ValueError`` unless ``result`` is what a campaign's synthesis pins: a
    state-feedback :class:`~sobolev_drake.synthesis.problem.SynthesisResult` whose ``K`` is a
    finite 4 × 12 float gain (what :func:`campaign_flight` flies).

    Parameters
    ----------
    label : str
        The design (for the message).
    result : object
    """
    from sobolev_drake.synthesis.problem import SynthesisResult

    K = result.K if isinstance(result, SynthesisResult) else None
    if not (isinstance(K, np.ndarray) and K.shape == (4, 12) and K.dtype.kind == "f"
            and np.all(np.isfinite(K))):
        raise ValueError(f"design {label!r} must be a state-feedback SynthesisResult with a finite "
                         f"4 × 12 gain, got {type(result).__name__} with K {getattr(K, 'shape', K)}")


def campaign_flight(K: ArrayLike, duration: float, case: Case) -> dict[str, Any]:
    """Fly K on the scenario a campaign case draws, and return the case's record.

    The truth is ``QuadrotorParams.chapter6_nominal()`` with the parameters of
    ``case.draws()`` scaled (the controller keeps the nominal trim and limits); q(0) and the
    disturbance come from :func:`drawn_scenario` on the case's "initial" and "disturbance"
    streams.  Nothing depends on the design, so designs flown on one seed are paired.

    Parameters
    ----------
    K : array_like, shape (4, 12)
        State-feedback gain in Ω² units.
    duration : float
        Simulated time (s).
    case : sobolev_drake.campaign.Case
        Gives ``draws()`` ({parameter: factor}) and ``rng(stream)``.

    Returns
    -------
    dict
        "indices" ({name of :data:`CAMPAIGN_INDICES`: value}), "success" (finite and not
        diverged, :data:`DIVERGED_TILT`) and "failure".
    """
    nominal = QuadrotorParams.chapter6_nominal()
    truth = replace(nominal, **{k: getattr(nominal, k) * f for k, f in case.draws().items()})
    q0, pulses = drawn_scenario(case.rng("initial"), case.rng("disturbance"))
    idx = flight_indices(QuadrotorHoverRig(truth=truth, pulses=pulses).run(K, duration, q0))
    return {"indices": {k: idx[v] for k, v in CAMPAIGN_INDICES.items()}, "success": idx["finite"],
            "failure": "" if idx["finite"] else "diverged (tilt beyond DIVERGED_TILT or non-finite state)"}
