"""Disturbance sources: time-profiled generalized forces and Cartesian forces mapped by Jᵀ.

* :class:`TimeProfiledForce` — output ``generalized_force`` (size n, thesis order): a sum of
  pulses {index, value, from, to} (``value`` a number or a callable of t, active on
  ``from ≤ t < to``; omit from/to for "always"), e.g. the manipulator's w1(t) = 40 N m on
  10 ≤ t ≤ 20 s and w2(t) = −40 sin(2πt/10) on 25 ≤ t ≤ 35 s (thesis 5.3.1).
* :class:`CartesianForceAtBody` — maps an inertial force f^I at a point P of a body (and
  optionally an inertial torque τ^I on the body) to generalized forces,
  ϑ = J_P(q)ᵀ f^I + W_D(q)ᵀ τ^I  (thesis (3.41), (3.43)), with Drake's spatial-velocity
  Jacobian (q̇ = v for every model of this library, so ∂v/∂q̇ = ∂p/∂q (3.42)).
* :func:`pulses_from_mission` — pulse list from the ``force_disturbances`` of
  ``tiltrotor_missions.json`` (inertial forces at the main-body centre of mass; on the x, y, z
  coordinates of the tilt-rotor they *are* generalized forces because those coordinates are
  the inertial translations of the body whose origin carries the force).
"""

from __future__ import annotations

import math
from typing import Callable, Sequence

import numpy as np
from pydrake.multibody.tree import BodyIndex, JacobianWrtVariable
from pydrake.systems.framework import BasicVector, LeafSystem

from sobolev_drake.models.base import check_vector
from sobolev_drake.validation import sequence

__all__ = ["TimeProfiledForce", "CartesianForceAtBody", "pulses_from_mission", "normalize_pulse"]


def _pulse_number(k, key, value, what) -> float:
    """``pulses[k][key]`` as a float; a TypeError naming it if it is not a number."""
    try:
        return float(value)
    except (TypeError, ValueError):
        raise TypeError(f"pulses[{k}][{key!r}] must be {what}, got {value!r}") from None


def normalize_pulse(pulse, n: int, k: int = 0) -> dict:
    """Check one pulse and return {index, value, from, to} (value float or callable)."""
    if not isinstance(pulse, dict):
        raise TypeError(f"pulses[{k}] must be a dict {{index, value, from, to}}, got {type(pulse).__name__}")
    unknown = set(pulse) - {"index", "value", "from", "to", "axis", "label"}
    if unknown:
        raise ValueError(f"pulses[{k}] has unknown keys {sorted(unknown)}")
    if "index" not in pulse or "value" not in pulse:
        raise ValueError(f"pulses[{k}] needs 'index' and 'value', got {sorted(pulse)}")
    idx = pulse["index"]
    if isinstance(idx, (bool, np.bool_)) or not isinstance(idx, (int, np.integer)) or not 0 <= idx < n:
        raise ValueError(f"pulses[{k}]['index'] must be an integer in [0, {n}), got {idx!r}")
    value = pulse["value"]
    if not callable(value):
        value = _pulse_number(k, "value", value, "a number or a callable of t")
        if not math.isfinite(value):
            raise ValueError(f"pulses[{k}]['value'] must be finite, got {value}")
    t_from = _pulse_number(k, "from", pulse.get("from", -math.inf), "a time in seconds")
    t_to = _pulse_number(k, "to", pulse.get("to", math.inf), "a time in seconds")
    if not t_from < t_to:
        raise ValueError(f"pulses[{k}] needs from < to, got from={t_from}, to={t_to}")
    return {"index": int(idx), "value": value, "from": t_from, "to": t_to}


class TimeProfiledForce(LeafSystem):
    """Generalized force w(t) (thesis order, size n) as a sum of time pulses.

    Parameters
    ----------
    n : int
        Size of the output (number of generalized coordinates).
    pulses : sequence of dict, optional
        ``{"index": i, "value": v or v(t), "from": t0, "to": t1}``, active on t0 ≤ t < t1
        (from/to default to −∞/+∞); see :func:`normalize_pulse`.
    function : callable, optional
        t ↦ (n,) vector added to the pulses.

    ``value(t)`` evaluates the same thing in numpy; ``switch_times`` lists the pulse edges
    (where the integrator meets a discontinuity).
    """

    def __init__(self, n: int, pulses: Sequence[dict] = (), *, function: Callable | None = None):
        super().__init__()
        if not isinstance(n, (int, np.integer)) or n <= 0:
            raise ValueError(f"n must be a positive integer, got {n!r}")
        self.n = int(n)
        self.pulses = [normalize_pulse(p, self.n, k)
                       for k, p in enumerate(sequence("pulses", pulses, "pulse dicts"))]
        if function is not None and not callable(function):
            raise TypeError("function must be callable t -> (n,) vector")
        self.function = function
        if function is not None:
            f0 = np.asarray(function(0.0), dtype=float)
            if f0.shape != (self.n,):
                raise ValueError(f"function(t) must return shape ({self.n},), got {f0.shape}")
        self.switch_times = sorted({p[k] for p in self.pulses for k in ("from", "to") if math.isfinite(p[k])})
        self.DeclareVectorOutputPort("generalized_force", self.n, self._calc,
                                     prerequisites_of_calc={self.time_ticket()})

    def value(self, t: float) -> np.ndarray:
        """w(t): the active pulses plus ``function(t)``.

        Parameters
        ----------
        t : float
            Time.

        Returns
        -------
        ndarray, shape (n,)
            Generalized force, thesis order.
        """
        w = np.zeros(self.n)
        for p in self.pulses:
            if p["from"] <= t < p["to"]:
                v = p["value"]
                w[p["index"]] += float(v(t)) if callable(v) else v
        if self.function is not None:
            w += np.asarray(self.function(t), dtype=float)
        return w

    def _calc(self, context, output: BasicVector):
        output.SetFromVector(self.value(context.get_time()))


def pulses_from_mission(entries: Sequence[dict], dof_names: Sequence[str]) -> list[dict]:
    """Pulse dicts from mission-json entries ``{"axis": name, "value", "from", "to"}``.

    ``dof_names`` gives the thesis coordinate names (e.g. the tilt-rotor's
    ``["alpha_R", "alpha_L", "phi", "theta", "psi", "x", "y", "z"]``); ``axis`` is looked up there.
    """
    names = list(dof_names)
    out = []
    for k, e in enumerate(entries):
        axis = e.get("axis")
        if axis not in names:
            raise ValueError(f"force_disturbances[{k}]['axis'] = {axis!r} is not a coordinate; known: {names}")
        pulse = {"index": names.index(axis), "value": e["value"], "from": e["from"], "to": e["to"]}
        out.append(normalize_pulse(pulse, len(names), k))
    return out


class CartesianForceAtBody(LeafSystem):
    """Generalized force ϑ = J_Pᵀ f^I (+ W_Dᵀ τ^I) of an inertial force at a body point (3.41).

    Parameters
    ----------
    model : a :class:`~sobolev_drake.models.base.MechanicalModel` (its plant is used for the
        kinematics through a private context; the coordinate map gives the thesis order).
    body : name of a body (its body frame is used) or of a frame of ``model.plant``.
    p_BQ : point of application in that frame (default its origin).
    with_torque : if True the ``force`` input has size 6, [τ^I; f^I] (Drake's spatial order).
    order : ``"thesis"`` (input ``x`` = [q; q̇] thesis order, output thesis order) or
        ``"drake"`` (input = the plant's state port, output in Drake's velocity order, ready for
        ``applied_generalized_force``).

    Ports: inputs ``x`` (2n), ``force`` (3 or 6, inertial frame); output ``generalized_force`` (n).
    """

    def __init__(self, model, body: str, *, p_BQ=(0.0, 0.0, 0.0), with_torque: bool = False,
                 order: str = "thesis"):
        super().__init__()
        if order not in ("thesis", "drake"):
            raise ValueError(f"order must be 'thesis' or 'drake', got {order!r}")
        self.model = model
        self.plant = model.plant
        self.n = model.n
        self.order = order
        self.with_torque = bool(with_torque)
        self.p_BQ = np.asarray(p_BQ, dtype=float).reshape(-1)
        if self.p_BQ.shape != (3,) or not np.all(np.isfinite(self.p_BQ)):
            raise ValueError(f"p_BQ must be a finite 3-vector, got {p_BQ!r}")
        if self.plant.HasBodyNamed(body):
            self.frame = self.plant.GetBodyByName(body).body_frame()
        elif self.plant.HasFrameNamed(body):
            self.frame = self.plant.GetFrameByName(body)
        else:
            bodies = [self.plant.get_body(BodyIndex(i)).name() for i in range(self.plant.num_bodies())]
            raise ValueError(f"body {body!r} is neither a body nor a frame of the plant; bodies: {bodies}")
        self._ctx = self.plant.CreateDefaultContext()
        self.DeclareVectorInputPort("x", 2 * self.n)
        self.DeclareVectorInputPort("force", 6 if self.with_torque else 3)
        self.DeclareVectorOutputPort("generalized_force", self.n, self._calc)

    def jacobian(self, q, *, thesis: bool = True) -> np.ndarray:
        """6×n Jacobian [W_D; J_P] (angular rows first) at configuration q (thesis or Drake order)."""
        q = check_vector("q", q, self.n)   # a NaN position aborts Drake's process, not just the call
        self.plant.SetPositions(self._ctx, self.model.to_drake(q) if thesis else q)
        world = self.plant.world_frame()
        J = self.plant.CalcJacobianSpatialVelocity(self._ctx, JacobianWrtVariable.kV, self.frame,
                                                   self.p_BQ, world, world)
        return J @ self.model.T if thesis else J

    def generalized_force(self, q, force, torque=None, *, thesis: bool = True) -> np.ndarray:
        """ϑ = J_Pᵀ f + W_Dᵀ τ for configuration q (thesis order by default)."""
        f = np.asarray(force, dtype=float).reshape(3)
        J = self.jacobian(q, thesis=thesis)
        tau = J[3:].T @ f
        if torque is not None:
            tau = tau + J[:3].T @ np.asarray(torque, dtype=float).reshape(3)
        return tau

    def _calc(self, context, output: BasicVector):
        x = self.get_input_port(0).Eval(context)
        F = self.get_input_port(1).Eval(context)
        q = x[: self.n]
        thesis = self.order == "thesis"
        if self.with_torque:
            out = self.generalized_force(q, F[3:], F[:3], thesis=thesis)
        else:
            out = self.generalized_force(q, F, thesis=thesis)
        output.SetFromVector(out)
