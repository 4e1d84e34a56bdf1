"""A linear controller of the upright linearization flown on the nonlinear two-wheeled vehicle
(thesis 6.5.2, Table 6.2), and the Table 6.2 indices of a flight.

Scenario: θ(0) = :data:`THETA0`, everything else at rest; wϕ = 2 N m on 5–10 s and
wθ = 2 sin(2πt/5) N m on 15–20 s.  The 2 % settling time of θ (Figure 6.2) is measured before
the disturbances start (:data:`DISTURBANCE_START`).  See docs/experiments/balance-linear.md.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
from pydrake.systems.framework import DiagramBuilder

from sobolev_drake import norms
from sobolev_drake.harness import LoggedLoop
from sobolev_drake.models.two_wheeled import add_two_wheeled
from sobolev_drake.models.two_wheeled_linear import STATE_REDUCTION
from sobolev_drake.simulation import simulate
from sobolev_drake.synthesis.problem import SynthesisResult
from sobolev_drake.systems.disturbances import TimeProfiledForce
from sobolev_drake.systems.linear_controllers import LinearDynamicOutputFeedback, LinearStateFeedback

__all__ = ["THETA0", "DISTURBANCE_START", "SETTLE_FRACTION", "BalanceLinearRig", "result_gains",
           "theta_settling_time", "flight_indices"]

THETA0 = np.pi / 4  # initial tilt of every flight (6.5.2)
DISTURBANCE_START = 5.0  # the disturbances start at t = 5 s
SETTLE_FRACTION = 0.02  # the 2 % band of Figure 6.2


class BalanceLinearRig(LoggedLoop):
    """One nonlinear closed-loop diagram per controller kind, reused for all runs.

    The controller acts on the linear-model state x = [θ, ϕ̇, θ̇] (state feedback) or on
    y = ``output`` x (full-order dynamic output feedback with feedthrough).  Logs ``x`` (the
    plant state [ϕ θ ϕ̇ θ̇]), ``u`` and ``w``.

    Parameters
    ----------
    output : array_like, shape (ny, 3), optional
        The measurement matrix of an output-feedback controller; None for state feedback.
    disturbances : bool
        Apply the disturbance pulses of the scenario.
    record : bool
        Add a Meshcat recorder.
    log_period : float
        Sampling period of the logs (s).
    """

    def __init__(self, output=None, *, disturbances=True, record=False, log_period=0.01):
        b = DiagramBuilder()
        self.h = add_two_wheeled(b)
        n = STATE_REDUCTION.shape[0]
        # gains are placeholders, set per run (set_gains); the OF controller has full order and
        # feedthrough (the synthesized DK is nonzero)
        if output is not None:
            C = np.asarray(output)
            ny = C.shape[0]
            self.ctrl = b.AddSystem(LinearDynamicOutputFeedback(
                np.zeros((n, n)), np.zeros((n, ny)), np.zeros((1, n)), np.zeros((1, ny)),
                S=C @ STATE_REDUCTION, feedthrough=True))
            ctrl_in = self.ctrl.GetInputPort("y")
        else:
            self.ctrl = b.AddSystem(LinearStateFeedback(np.zeros((1, n)), S=STATE_REDUCTION))
            ctrl_in = self.ctrl.GetInputPort("x")
        pulses = [{"index": 0, "value": 2.0, "from": 5.0, "to": 10.0},
                  {"index": 1, "value": lambda t: 2.0 * np.sin(2 * np.pi * t / 5.0), "from": 15.0, "to": 20.0}]
        self.w = b.AddSystem(TimeProfiledForce(2, pulses if disturbances else []))
        b.Connect(self.h.x, ctrl_in)
        b.Connect(self.ctrl.GetOutputPort("u"), self.h.u)
        b.Connect(self.w.get_output_port(), self.h.disturbance)
        self.build(b, (("x", self.h.x), ("u", self.ctrl.GetOutputPort("u")), ("w", self.w.get_output_port())),
                    log_period, record)

    def run(self, gains: dict[str, Any], duration: float, *,
            theta0: float = THETA0) -> dict[str, Any]:
        """Fly the controller ``gains`` for ``duration`` s from θ(0) = ``theta0``.

        Parameters
        ----------
        gains : dict
            Keyword arguments of the controller's ``set_gains`` (see :func:`result_gains`).
        duration : float
            Simulated time (s).
        theta0 : float
            Initial tilt (rad); the controller state starts at 0.

        Returns
        -------
        dict
            The logs ``x``, ``u``, ``w``, the times ``t`` and ``wall_s``.
        """
        ctx = self.context
        ctx.SetTime(0.0)
        ctx.get_mutable_continuous_state_vector().SetFromVector(
            np.zeros(ctx.get_continuous_state_vector().size()))
        self.h.set_state(ctx, self.diagram, [0.0, theta0], [0.0, 0.0])
        self.ctrl.set_gains(self.ctrl.GetMyMutableContextFromRoot(ctx), **gains)
        self.clear_logs(ctx)
        t0 = time.perf_counter()
        simulate(self.diagram, ctx, duration, progress=False, simulator=self.sim, accuracy=1e-4, max_step=0.02)
        data = self.collect(ctx, t0)
        return data


def result_gains(res: SynthesisResult) -> dict[str, Any]:
    """The ``set_gains`` keywords of a synthesis result for :meth:`BalanceLinearRig.run`.

    Parameters
    ----------
    res : SynthesisResult
        A state-feedback (``K``) or output-feedback (``controller``) result.

    Returns
    -------
    dict
        ``{"K": K}`` or ``{"controller": (AK, BK, CK, DK)}``.
    """
    if res.K is not None:
        return {"K": np.asarray(res.K)}
    return {"controller": tuple(np.asarray(m) for m in res.controller)}


def theta_settling_time(d: dict[str, Any], fraction: float = SETTLE_FRACTION) -> float:
    """Settling time of θ of one flight: the last time before :data:`DISTURBANCE_START` with
    |θ| > ``fraction`` · |:data:`THETA0`|, crossing interpolated (Figure 6.2's 2 % criterion).

    Parameters
    ----------
    d : dict
        A result of :meth:`BalanceLinearRig.run` started from :data:`THETA0`.
    fraction : float
        Band half-width relative to θ(0).

    Returns
    -------
    float
    """
    return norms.settling_time(d["t"], d["x"][1], fraction=fraction, reference=THETA0,
                               until=DISTURBANCE_START)


def flight_indices(d: dict[str, Any]) -> dict[str, float]:
    """Table 6.2 indices of one flight (x logged as [ϕ θ ϕ̇ θ̇]).

    ISE θ, ISE ϕ̇, IADU, the θ settling times (2 %, 1 %, 5 %), max |u|, max |θ| and the
    empirical gain ‖x‖/‖w‖ of x = [θ, ϕ̇, θ̇] (whole run and t ≥ 5 s; nan without disturbance).

    Parameters
    ----------
    d : dict
        A result of :meth:`BalanceLinearRig.run`.

    Returns
    -------
    dict
    """
    t, x = d["t"], d["x"]
    xl = x[1:].T  # [θ ϕ̇ θ̇]
    out = {"ise_theta": norms.ise(t, x[1]), "ise_phidot": norms.ise(t, x[2]),
           "iadu": float(np.sum(norms.iadu(t, d["u"].T))),
           "settling_s": theta_settling_time(d), "max_abs_u": float(np.abs(d["u"]).max()),
           "settling_1pct_s": theta_settling_time(d, fraction=0.01),
           "settling_5pct_s": theta_settling_time(d, fraction=0.05),
           "max_abs_theta_deg": float(np.degrees(np.abs(x[1]).max())),
           "finite": bool(np.all(np.isfinite(x)))}
    try:
        out["gain"] = norms.empirical_gain(t, xl, d["w"].T)
        late = t >= 5.0
        out["gain_t_ge_5"] = norms.empirical_gain(t[late], xl[late], d["w"].T[late])
    except ValueError:  # no disturbance in short runs
        out["gain"] = out["gain_t_ge_5"] = float("nan")
    return out
