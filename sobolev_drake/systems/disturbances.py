"""Disturbance sources: time-profiled generalized forces, Cartesian forces mapped by Jᵀ, noise.

* :class:`TimeProfiledForce` — output ``generalized_force`` (size n, thesis order): a sum of
  pulses {index, value, from, to} (``value`` a number or a callable of t, active on
  ``from ≤ t < to``; omit from/to for "always"), e.g. the manipulator's w1(t) = 40 N m on
  10 ≤ t ≤ 20 s and w2(t) = −40 sin(2πt/10) on 25 ≤ t ≤ 35 s (thesis 5.3.1).
* :class:`CartesianForceAtBody` — maps an inertial force f^I at a point P of a body (and
  optionally an inertial torque τ^I on the body) to generalized forces,
  ϑ = J_P(q)ᵀ f^I + W_D(q)ᵀ τ^I  (thesis (3.41), (3.43)), with Drake's spatial-velocity
  Jacobian (q̇ = v for every model of this library, so ∂v/∂q̇ = ∂p/∂q (3.42)).
* :class:`HeldGaussianNoise` — zero-order-held unit Gaussian samples, a reproducible function
  of (seed, sample index): the white noise of the von Kármán turbulence.
* :func:`pulses_from_mission` — pulse list from the ``force_disturbances`` of
  ``tiltrotor_missions.json`` (inertial forces at the main-body centre of mass; on the x, y, z
  coordinates of the tilt-rotor they *are* generalized forces because those coordinates are
  the inertial translations of the body whose origin carries the force).

Every system is scalar-convertible (``ToAutoDiffXd``, ``ToSymbolic``; pydrake's
``TemplateSystem``) and keeps its numbers in the Context (pulse amplitudes and the seed are
numeric parameters, the noise's sample index is discrete state).
"""

from __future__ import annotations

import contextlib
import math
from functools import lru_cache
from typing import Any, Callable, Sequence

import numpy as np
from numpy.typing import ArrayLike
from pydrake.common.value import AbstractValue
from pydrake.multibody.tree import BodyIndex, JacobianWrtVariable
from pydrake.symbolic import Expression
from pydrake.systems.framework import BasicVector_, Context, LeafSystem_, ValueProducer
from pydrake.systems.scalar_conversion import TemplateSystem

from sobolev_drake.models.base import check_vector
from sobolev_drake.systems.scalar_time import (interval_indicator, is_symbolic, probe_scalar_type,
                                               scalar_value, template_signature)
from sobolev_drake.validation import positive_scalar, sequence

__all__ = ["TimeProfiledForce", "CartesianForceAtBody", "HeldGaussianNoise", "pulses_from_mission",
           "normalize_pulse", "gaussian_samples", "TimeProfiledForce_", "CartesianForceAtBody_",
           "HeldGaussianNoise_"]


def _pulse_number(k, key, value, what) -> float:
    """``pulses[k][key]`` as a float; a TypeError naming it if it is not a number."""
    try:
        return float(value)
    except (TypeError, ValueError):
        raise TypeError(f"pulses[{k}][{key!r}] must be {what}, got {value!r}") from None


def normalize_pulse(pulse: dict[str, Any], n: int, k: int = 0) -> dict:
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


@TemplateSystem.define("TimeProfiledForce_")
def TimeProfiledForce_(T):   # the class for scalar type T (float, AutoDiffXd, Expression)

    class Impl(LeafSystem_[T]):
        """Generalized force w(t) (thesis order, size n) as a sum of time pulses.

        The amplitudes are the numeric parameter 0 (one entry per pulse: the value of a
        constant pulse, the gain, default 1, of a callable one); the pulse windows, indices and
        callables are fixed at construction.  ``value(t)`` evaluates w(t) with the default
        amplitudes in numpy; ``switch_times`` lists the pulse edges (where the integrator meets
        a discontinuity).  AutoDiffXd/symbolic versions call the callables with a time of that
        type: write them with ``numpy``/``pydrake.math`` functions (``np.sin`` works on every
        scalar type, ``math.sin`` only on floats); conversion probes them and refuses clearly.

        .. pydrake_system::

            name: TimeProfiledForce
            output_ports:
            - generalized_force

        Parameters
        ----------
        n : int
            Size of the output (number of generalized coordinates).
        pulses : sequence of dict, optional
            ``{"index": i, "value": v or v(t), "from": t0, "to": t1}``, active on t0 ≤ t < t1
            (from/to default to −∞/+∞); see :func:`normalize_pulse`.
        function : callable, optional
            t ↦ (n,) vector added to the pulses.

        Examples
        --------
        A force of 1.5 on DOF 0 during 1 ≤ t < 2 and sin t on DOF 1 from t = 0 on:

        >>> import numpy as np
        >>> import sobolev_drake as sd
        >>> w = sd.TimeProfiledForce(2, [{"index": 0, "value": 1.5, "from": 1.0, "to": 2.0},
        ...                              {"index": 1, "value": np.sin, "from": 0.0}])
        >>> w.value(1.5).round(4), w.value(2.0).round(4), w.switch_times
        (array([1.5   , 0.9975]), array([0.    , 0.9093]), [0.0, 1.0, 2.0])
        >>> context = w.CreateDefaultContext()
        >>> context.SetTime(1.5)
        >>> w.get_output_port().Eval(context).round(4)      # the Drake output port
        array([1.5   , 0.9975])
        """

        def _construct(self, n, pulses=(), *, function=None, converter=None):
            LeafSystem_[T].__init__(self, converter)
            if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n <= 0:
                raise ValueError(f"n must be a positive integer, got {n!r}")
            self.n = int(n)
            self._pulses = tuple(normalize_pulse(p, self.n, k)
                                 for k, p in enumerate(sequence("pulses", pulses, "pulse dicts")))
            if function is not None and not callable(function):
                raise TypeError(f"function must be callable t -> ({self.n},) vector, got {function!r}")
            self.function = function
            if function is not None:
                f0 = np.asarray(function(0.0), dtype=float)
                if f0.shape != (self.n,):
                    raise ValueError(f"function(t) must return shape ({self.n},), got {f0.shape}")
            self.switch_times = sorted({p[k] for p in self._pulses for k in ("from", "to")
                                        if math.isfinite(p[k])})
            self._amplitudes = [1.0 if callable(p["value"]) else p["value"] for p in self._pulses]
            if self._pulses:
                self.DeclareNumericParameter(BasicVector_[T](self._amplitudes))
            if T is not float:
                self._probe_callables()
            self.DeclareVectorOutputPort("generalized_force", self.n, self._calc,
                                         prerequisites_of_calc={self.time_ticket(),
                                                                self.all_parameters_ticket()})

        def _construct_copy(self, other, converter=None):
            Impl._construct(self, other.n, other.pulses, function=other.function,
                            converter=converter)

        __signature__ = template_signature(_construct)

        @property
        def pulses(self) -> list:
            """The normalized pulses {index, value, from, to} (copies; amplitudes are defaults)."""
            return [dict(p) for p in self._pulses]

        def _probe_callables(self):
            what = [(f"pulses[{k}]['value'] = {p['value']!r}", p["value"], p["from"])
                    for k, p in enumerate(self._pulses) if callable(p["value"])]
            for name, fn, t0 in what + ([(f"function = {self.function!r}", self.function, 0.0)]
                                        if self.function else []):
                probe_scalar_type(T, "TimeProfiledForce", name, fn, t0 if math.isfinite(t0) else 0.0,
                                  "write it with numpy or pydrake.math functions, which accept any scalar "
                                  "(e.g. lambda t: -40 * np.sin(0.2 * np.pi * t)), or keep the float system")

        def _force(self, t, amplitudes):
            """w(t) for a time of any scalar type (list of n scalars); float t is the fast path."""
            fast, w = isinstance(t, float), [0.0] * self.n
            for p, a in zip(self._pulses, amplitudes):
                on = ((1.0 if p["from"] <= t < p["to"] else 0.0) if fast
                      else interval_indicator(t, p["from"], p["to"], closed=(True, False)))
                if not is_symbolic(on) and on == 0.0:
                    continue   # inactive: skip (a callable is not evaluated outside its window)
                v = p["value"]
                if callable(v):
                    a = a * (float(v(t)) if fast else np.asarray(v(t), dtype=object)[()])
                w[p["index"]] = w[p["index"]] + (a if fast else on * a)
            if self.function is not None:
                f = np.asarray(self.function(t), dtype=float if fast else object)
                w = [wi + fi for wi, fi in zip(w, f)]
            return w

        def value(self, t: float) -> np.ndarray:
            """w(t): the active pulses (default amplitudes) plus ``function(t)``.

            Parameters
            ----------
            t : float
                Time.

            Returns
            -------
            ndarray, shape (n,)
                Generalized force, thesis order.
            """
            return np.asarray(self._force(float(t), self._amplitudes), dtype=float)

        def _calc(self, context, output):
            amplitudes = context.get_numeric_parameter(0).CopyToVector() if self._pulses else ()
            # numpy's object-dtype ufuncs in a callable (np.sin(t)) report an FE_INVALID flag left
            # set by earlier non-numpy code (seen in Drake symbolic runs): spurious for Expressions
            with np.errstate(invalid="ignore") if T is Expression else contextlib.nullcontext():
                output.SetFromVector(self._force(context.get_time(), amplitudes))

    return Impl


TimeProfiledForce = TimeProfiledForce_[None]


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


@TemplateSystem.define("CartesianForceAtBody_")
def CartesianForceAtBody_(T):   # the class for scalar type T (float, AutoDiffXd, Expression)

    class Impl(LeafSystem_[T]):
        """Generalized force ϑ = J_Pᵀ f^I (+ W_Dᵀ τ^I) of an inertial force at a body point (3.41).

        Inputs ``x`` (2n: [q; q̇]) and ``force`` (3, or 6 = [τ^I; f^I] in Drake's spatial
        order, inertial frame); output ``generalized_force`` (n).  The plant context that
        evaluates the Jacobian is a Drake cache entry of this system's Context (positions from
        ``x``), so contexts are independent; the AutoDiffXd/symbolic versions use the plant
        converted to that scalar type.  :meth:`jacobian` and :meth:`generalized_force` are the
        float helpers (their own private plant context).

        .. pydrake_system::

            name: CartesianForceAtBody
            input_ports:
            - x
            - force
            output_ports:
            - generalized_force

        Parameters
        ----------
        model : MechanicalModel
            Its plant gives the kinematics; its coordinate map the thesis order.
        body : str
            Name of a body (its body frame is used) or of a frame of ``model.plant``.
        p_BQ : array_like, shape (3,), default (0, 0, 0)
            Point of application in that frame.
        with_torque : bool, default False
            If True the ``force`` input has size 6, [τ^I; f^I].
        order : {"thesis", "drake"}, default "thesis"
            "thesis": input ``x`` = [q; q̇] and output in thesis order; "drake": input = the
            plant's state port, output in Drake's velocity order (``applied_generalized_force``).
        """

        def _construct(self, model, body, *, p_BQ=(0.0, 0.0, 0.0), with_torque=False,
                       order="thesis", converter=None):
            LeafSystem_[T].__init__(self, converter)
            if order not in ("thesis", "drake"):
                raise ValueError(f"order must be 'thesis' or 'drake', got {order!r}")
            self.model, self.plant, self.n, self.order = model, model.plant, model.n, order
            self.with_torque, self._body = bool(with_torque), body
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
            self._plant_T = self.plant if T is float else self.plant.ToScalarType[T]()
            self._frame_T = self._plant_T.get_frame(self.frame.index())
            x = self.DeclareVectorInputPort("x", 2 * self.n)
            self.DeclareVectorInputPort("force", 6 if self.with_torque else 3)
            self._plant_context = self.DeclareCacheEntry(
                "plant context at q", ValueProducer(
                    allocate=lambda: AbstractValue.Make(self._plant_T.CreateDefaultContext()),
                    calc=self._calc_plant_context), {x.ticket()})
            self.DeclareVectorOutputPort("generalized_force", self.n, self._calc,
                                         prerequisites_of_calc={self.all_input_ports_ticket()})

        def _construct_copy(self, other, converter=None):
            Impl._construct(self, other.model, other._body, p_BQ=other.p_BQ,
                            with_torque=other.with_torque, order=other.order, converter=converter)

        __signature__ = template_signature(_construct)

        def jacobian(self, q: ArrayLike, *, thesis: bool = True) -> np.ndarray:
            """6×n Jacobian [W_D; J_P] (angular rows first) at configuration q.

            Parameters
            ----------
            q : array_like, shape (n,)
                Configuration (thesis or Drake order).
            thesis : bool, default True
                Whether q and the Jacobian's columns are in thesis order.

            Returns
            -------
            ndarray, shape (6, n)
            """
            q = check_vector("q", q, self.n)   # a NaN position aborts Drake's process, not just the call
            self.plant.SetPositions(self._ctx, self.model.to_drake(q) if thesis else q)
            world = self.plant.world_frame()
            J = self.plant.CalcJacobianSpatialVelocity(self._ctx, JacobianWrtVariable.kV, self.frame,
                                                       self.p_BQ, world, world)
            return J @ self.model.T if thesis else J

        def generalized_force(self, q: ArrayLike, force: ArrayLike, torque: ArrayLike | None = None,
                              *, thesis: bool = True) -> np.ndarray:
            """ϑ = J_Pᵀ f + W_Dᵀ τ for configuration q.

            Parameters
            ----------
            q : array_like, shape (n,)
                Configuration.
            force : array_like, shape (3,)
                Inertial force f^I at the point.
            torque : array_like, shape (3,), optional
                Inertial torque τ^I on the body.
            thesis : bool, default True
                Thesis (else Drake) order of q and ϑ.

            Returns
            -------
            ndarray, shape (n,)
            """
            f = np.asarray(force, dtype=float).reshape(3)
            J = self.jacobian(q, thesis=thesis)
            tau = J[3:].T @ f
            if torque is not None:
                tau = tau + J[:3].T @ np.asarray(torque, dtype=float).reshape(3)
            return tau

        def _calc_plant_context(self, context, value):
            q = self.get_input_port(0).Eval(context)[: self.n]
            if T is not Expression:   # a NaN position aborts Drake's process, not just the call
                check_vector("x[:n] (positions)", q if T is float else [v.value() for v in q], self.n)
            q_drake = self.model.T @ q if self.order == "thesis" else q
            self._plant_T.SetPositions(value.get_mutable_value(), q_drake)

        def _calc(self, context, output):
            F = self.get_input_port(1).Eval(context)
            world = self._plant_T.world_frame()
            J = self._plant_T.CalcJacobianSpatialVelocity(
                self._plant_context.Eval(context), JacobianWrtVariable.kV, self._frame_T,
                self.p_BQ, world, world)
            if self.order == "thesis":
                J = J @ self.model.T
            f, tau = (F[3:], F[:3]) if self.with_torque else (F, None)
            out = J[3:].T @ f
            output.SetFromVector(out if tau is None else out + J[:3].T @ tau)

    return Impl


CartesianForceAtBody = CartesianForceAtBody_[None]

NOISE_BLOCK = 512   # samples drawn per Philox counter block (and memoized together)


@lru_cache(maxsize=32)
def _gaussian_block(seed: int, block: int, size: int) -> np.ndarray:
    gen = np.random.Generator(np.random.Philox(key=seed, counter=[0, block % 2**64, 0, 0]))
    out = gen.standard_normal((NOISE_BLOCK, size))
    out.flags.writeable = False
    return out


def gaussian_samples(seed: int, k: int, size: int) -> np.ndarray:
    """Sample ``k`` of the seeded unit Gaussian sequence of :class:`HeldGaussianNoise`.

    A pure function of (seed, k, size): Philox (counter-based) keyed by the seed, the counter
    selecting blocks of ``NOISE_BLOCK`` samples, so any sample is drawn without the ones
    before it and equally in every scalar type and process.

    Parameters
    ----------
    seed : int
        Non-negative seed.
    k : int
        Sample index (the sample held on [kΔt, (k+1)Δt)).
    size : int
        Number of channels.

    Returns
    -------
    ndarray, shape (size,)
        Independent standard normal draws (read-only).
    """
    return _gaussian_block(int(seed), int(k) // NOISE_BLOCK, int(size))[int(k) % NOISE_BLOCK]


def _check_seed(seed):
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or not 0 <= seed < 2**53:
        raise ValueError(f"seed must be an integer in [0, 2**53), got {seed!r}")
    return int(seed)


@TemplateSystem.define("HeldGaussianNoise_")
def HeldGaussianNoise_(T):   # the class for scalar type T (float, AutoDiffXd, Expression)

    class Impl(LeafSystem_[T]):
        """Unit-variance Gaussian samples held over ``sample_time``: a reproducible RandomSource.

        The sample held on [kΔt, (k+1)Δt) is :func:`gaussian_samples` (seed, k): the seed is
        numeric parameter 0, k is discrete state (set by a periodic update at kΔt, as Drake's
        ``RandomSource(kGaussian, size, Δt)`` draws), so the noise is the same in every
        context with the same seed and time, in every scalar type (constants, zero
        derivatives).  Seed with :meth:`set_seed` (Drake's ``SetRandomContext`` cannot reach a
        Python system and leaves the draws unchanged).

        .. pydrake_system::

            name: HeldGaussianNoise
            output_ports:
            - noise

        Parameters
        ----------
        size : int
            Number of independent channels.
        sample_time : float
            Δt (s).
        seed : int, default 0
            Default seed (parameter value of new contexts).
        """

        def _construct(self, size, sample_time, seed=0, converter=None):
            LeafSystem_[T].__init__(self, converter)
            if isinstance(size, bool) or not isinstance(size, (int, np.integer)) or size < 1:
                raise ValueError(f"size must be a positive integer, got {size!r}")
            self.size, self.sample_time = int(size), positive_scalar("sample_time (s)", sample_time)
            self.default_seed = _check_seed(seed)
            self.DeclareNumericParameter(BasicVector_[T]([float(self.default_seed)]))
            self.DeclareDiscreteState(1)
            self.DeclarePeriodicDiscreteUpdateEvent(self.sample_time, 0.0, self._update)
            self.DeclareVectorOutputPort("noise", self.size, self._calc,
                                         prerequisites_of_calc={self.xd_ticket(), self.all_parameters_ticket()})

        def _construct_copy(self, other, converter=None):
            Impl._construct(self, other.size, other.sample_time, other.default_seed, converter=converter)

        __signature__ = template_signature(_construct)

        def _index(self, t) -> int:
            return math.floor(scalar_value(t) / self.sample_time + 1e-9)   # kΔt may round below k

        def _update(self, context, discrete_state):
            discrete_state.get_mutable_vector(0).SetFromVector([self._index(context.get_time())])

        def set_seed(self, context: Context, seed: int) -> None:
            """Use ``seed`` in ``context`` (this system's), holding the sample of its time.

            Parameters
            ----------
            context : Context
                This system's context (``GetMyMutableContextFromRoot`` in a diagram).
            seed : int
                Non-negative integer below 2**53.
            """
            context.get_mutable_numeric_parameter(0).SetFromVector([float(_check_seed(seed))])
            context.get_mutable_discrete_state(0).SetFromVector([self._index(context.get_time())])

        def _calc(self, context, output):
            seed = scalar_value(context.get_numeric_parameter(0).GetAtIndex(0), "seed")
            k = scalar_value(context.get_discrete_state(0).GetAtIndex(0), "sample index")
            if seed != int(seed):
                raise ValueError(f"{self.GetSystemPathname()}: seed parameter must be an integer, got {seed}")
            output.SetFromVector(gaussian_samples(_check_seed(int(seed)), int(k), self.size))

    return Impl


HeldGaussianNoise = HeldGaussianNoise_[None]
