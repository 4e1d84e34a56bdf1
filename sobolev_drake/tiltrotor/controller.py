"""Nonlinear W∞ controller with control allocation for the tilt-rotor UAV (thesis §7.3.2).

The generalized coordinates q = [αR αL φ θ ψ x y z] (thesis order) are partitioned (7.63) in

* stabilized  q_s = [φ θ]          — only q̇_s → 0 is asked (W^{1,2}, weights Υ0, Υ1),
* regulated   q_r = [αR αL ψ]      — set-point tracking without integral (W^{2,2}, Σ0, Σ1, Σ2),
* controlled  q_c = [x y z]        — tracking with integral action (W^{3,2}, Γ0 … Γ3).

The thesis text lists q_r = [ψ αR αL], but its Σ weights are only symmetric in the two tilt
angles in the order [αR αL ψ] (Σ0 = diag(20, 20, 0.01), …), which is the order used here.

Theorem 12 / (7.81): with the state x = [q̇_s, ė_r, ė_c, e_c, e_r, ∫e_c] the optimal
generalized input is (k = g, so the worst-case disturbance (7.83) vanishes and W2 = W∞)

    u* = M(q) q̈_des + C(q, q̇) q̇ + g(q) − ϑ_passive(q, q̇, ζ),

    q̈_s,des = −Υ1⁻¹ U q̇_s,
    q̈_r,des = q̈_r,ref − Σ2⁻¹ (A ė_r + B e_r),
    q̈_c,des = q̈_c,ref − Γ3⁻¹ (Q ė_c + K e_c + T ∫e_c),

where U, A, B, Q, K, T solve the Riccati equations (7.70)–(7.75), i.e. the CARE of one chain of
integrators per group (docs/design.md §4.2).  The gains are *received* here
(``synthesis.mechanical`` computes them); this module never re-derives them.

The applied actuator vector τ̄ = [fPR fPL τsR τsL δWR δWL δTR δTL] solves the bounded least
squares allocation (7.84)–(7.89); the propeller forces are then mapped to propeller speeds by
inverting f = ρ d⁴ n² Ct(J, φ) (7.90).

The controller is sampled (zero-order hold, period ``period``): every update computes the
law, the allocation and the thrust inversion once and stores the result in discrete state, so
the outputs depend on state only (no algebraic loop) and the expensive allocation runs at the
sampling rate instead of at every integrator stage.

:func:`sobolev_drake.tiltrotor.law.make_law` composes the law from the plant model,
the allocation and the propeller data.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike
from pydrake.systems.framework import BasicVector, LeafSystem

from sobolev_drake.models.base import check_vector
from sobolev_drake.synthesis.mechanical import controlled_gains, regulated_gains, stabilized_gains
from sobolev_drake.systems.mechanical_controller import MechanicalLaw, Partition, SobolevLaw
from sobolev_drake.tiltrotor.law_checks import checked_vector, saturation_flag_list, saturation_flags
from sobolev_drake.tiltrotor.references import (TiltSchedule, forward_air_speed, regulated_reference,
                                                regulated_values, tilt_schedule_polynomial,
                                                tracked_reference)
from sobolev_drake.tiltrotor.scalars import DoubleOnly

__all__ = [
    "N_Q", "THESIS_WEIGHTS", "PARTITION", "thesis_inner_law", "tilt_schedule_polynomial",
    "forward_air_speed", "regulated_reference", "tracked_reference", "saturation_flags",
    "ControlStep", "TiltrotorWInfLaw", "TiltrotorWInfController", "checked_vector", "TiltSchedule",
]

# Thesis-order index sets of the partition (7.63).
STABILIZED = np.array([2, 3])        # φ θ
REGULATED = np.array([0, 1, 4])      # αR αL ψ
CONTROLLED = np.array([5, 6, 7])     # x y z
_CONTROLLED_IDX = tuple(CONTROLLED.tolist())
N_Q = 8
N_TAU = 8

# Thesis tuning of §7.3.2 (text after Remark 50).
THESIS_WEIGHTS = {
    "Upsilon0": np.diag([180.0, 10.0]),
    "Upsilon1": np.diag([2.0, 0.02]),
    "Sigma0": np.diag([20.0, 20.0, 0.01]),
    "Sigma1": np.diag([15.0, 15.0, 400.0]),
    "Sigma2": np.diag([0.1, 0.1, 15.0]),
    "Gamma0": np.diag([0.05, 0.05, 0.5]),
    "Gamma1": np.eye(3),
    "Gamma2": np.diag([400.0, 400.0, 200.0]),
    "Gamma3": np.diag([500.0, 500.0, 50.0]),
}

#: the partition (7.63) for ``systems.mechanical_controller.MechanicalLaw``
PARTITION = Partition(controlled=tuple(CONTROLLED), regulated=tuple(REGULATED),
                      stabilized=tuple(STABILIZED))


def thesis_inner_law(weights: dict[str, ArrayLike] | None = None) -> SobolevLaw:
    """:class:`SobolevLaw` of the thesis tuning (gains from ``synthesis.mechanical`` CAREs).

    Parameters
    ----------
    weights : dict, optional
        Υ0, Υ1, Σ0–Σ2, Γ0–Γ3 as in :data:`THESIS_WEIGHTS` (the default).

    Returns
    -------
    SobolevLaw
        Gains of the controlled, regulated and stabilized groups.
    """
    W = THESIS_WEIGHTS if weights is None else weights
    return SobolevLaw(controlled=controlled_gains(W["Gamma0"], W["Gamma1"], W["Gamma2"], W["Gamma3"]),
                      regulated=regulated_gains(W["Sigma0"], W["Sigma1"], W["Sigma2"]),
                      stabilized=stabilized_gains(W["Upsilon0"], W["Upsilon1"]))


@dataclass
class ControlStep:
    """Everything one evaluation of the law produced (for logging and tests).

    Attributes
    ----------
    qdd_des, u_star : ndarray, shape (8,)
        Desired accelerations and the generalized input u* (7.81).
    B, theta_passive : ndarray
        Input matrix (8, 8) and ϑ_passive (8,) of (7.62).
    tau_bar, lo, up : ndarray, shape (8,)
        Allocated actuator vector τ̄ and its bounds (7.84)–(7.89).
    propeller_speed : ndarray, shape (2,)
        Propeller speeds (rev/s) of the thrusts (7.90).
    residual : float
        ‖u* − Bτ̄‖.
    ref_r : tuple
        (q, q̇, q̈) references of the regulated DOF [αR αL ψ].
    """

    qdd_des: np.ndarray
    u_star: np.ndarray
    B: np.ndarray
    theta_passive: np.ndarray
    tau_bar: np.ndarray
    lo: np.ndarray
    up: np.ndarray
    propeller_speed: np.ndarray
    residual: float
    ref_r: tuple = field(default=())


class TiltrotorWInfLaw:
    """The pure (numpy) law: references → q̈_des → u* → allocation → propeller speeds.

    q̈_des and u* come from the shared :class:`MechanicalLaw` with the partition (7.63)
    (:data:`PARTITION`); ϑ_passive enters as its ``extra`` term.

    Parameters
    ----------
    mech_law : :class:`MechanicalLaw` on the controller's tilt-rotor model with :data:`PARTITION`.
    input_affine : ``f(model, q, qdot, zeta) -> (B 8×8, ϑ_passive 8)`` (plant engineer's map).
    allocate : ``f(B, u, lo, up) -> τ̄`` bounded least squares (7.84).
    bounds : ``f(q, qdot, zeta) -> (lo, up)`` (7.85)–(7.89).
    thrust_to_speed : ``f(thrust (2,), q, qdot, zeta, n_guess=None) -> n (2,)`` inverting (7.90).
    tilt_schedule : ``f(U) -> (α, α', α'')`` for the regulated tilt references.
    """

    def __init__(self, mech_law: MechanicalLaw, *,
                 input_affine: Callable[..., tuple[ArrayLike, ArrayLike]],
                 allocate: Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray], ArrayLike],
                 bounds: Callable[[np.ndarray, np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]],
                 thrust_to_speed: Callable[..., ArrayLike], tilt_schedule: TiltSchedule) -> None:
        if not isinstance(mech_law, MechanicalLaw):
            raise TypeError("mech_law must be a MechanicalLaw")
        p = mech_law.partition
        if (p.controlled, p.regulated, p.stabilized) != (PARTITION.controlled, PARTITION.regulated,
                                                         PARTITION.stabilized):
            raise ValueError(f"mech_law must use the tilt-rotor partition {PARTITION}, got {p}")
        if not isinstance(mech_law.law, SobolevLaw):
            raise TypeError("mech_law.law must be a SobolevLaw (W∞ = W2 here, k = g)")
        for name, f in [("input_affine", input_affine), ("allocate", allocate),
                        ("bounds", bounds), ("thrust_to_speed", thrust_to_speed),
                        ("tilt_schedule", tilt_schedule)]:
            if not callable(f):
                raise TypeError(f"{name} must be callable")
        self.mech_law, self.model = mech_law, mech_law.model
        self.input_affine, self.allocate, self.bounds = input_affine, allocate, bounds
        self.thrust_to_speed, self.tilt_schedule = thrust_to_speed, tilt_schedule
        # Optional fused form of everything after q̈_des (set by make_law with the compiled
        # kernels): used while the four callables are still the ones it was made for.
        self.fused_sample = None
        # Optional compiled form of the controller's whole update (``tiltrotor.compiled_sample``,
        # set by make_law): used by TiltrotorWInfController while the pieces are unchanged.
        self.compiled_sample = None
        # Optional q̈_des of another weighting of the same law (e.g. the envelope gain schedule,
        # ``tiltrotor.gain_schedule``): ``f(q, q̇, ∫e, tracked, reference, wind) -> list of 8``
        self.desired_acceleration = None

    def step(self, q: ArrayLike, qdot: ArrayLike, reference: ArrayLike, wind: ArrayLike,
             integral_ec: ArrayLike, n_prev: ArrayLike | None = None) -> ControlStep:
        """One evaluation of the law.

        Parameters
        ----------
        q, qdot : array_like, shape (8,)
            Generalized coordinates and velocities, thesis order.
        reference : array_like, shape (12,)
            [x y z ψ | ẋ ẏ ż ψ̇ | ẍ ÿ z̈ ψ̈].
        wind : array_like, shape (3,)
            Measured wind, inertial axes (m/s).
        integral_ec : array_like, shape (3,)
            Integral of the controlled-DOF error.
        n_prev : array_like, shape (2,), optional
            Last propeller speeds: the torque/thrust ratio Cq/Ct(J, φ) of B's thrust columns
            and the Newton start of the thrust inversion.

        Returns
        -------
        ControlStep
            Everything the evaluation produced.
        """
        q, ql = checked_vector("q", q, N_Q)
        qdot, qdl = checked_vector("qdot", qdot, N_Q)
        _, r = checked_vector("reference", reference, 12)
        wind, wl = checked_vector("wind", wind, 3)
        _, iel = checked_vector("e_int", integral_ec, len(CONTROLLED))
        al, ald, aldd, psi, psid, psidd = regulated_values(self.tilt_schedule, r[4:8], r[8:12],
                                                           (r[3], r[7], r[11]), wl)
        ref_r = (np.array([al, al, psi]), np.array([ald, ald, psid]), np.array([aldd, aldd, psidd]))
        # tracked_reference((p, v, a)[:3], ref_r) assembled directly
        tracked = (r[0:3] + [al, al, psi] + r[4:7] + [ald, ald, psid]
                   + r[8:11] + [aldd, aldd, psidd])
        # q̈_des in floats and u* by recursive Newton–Euler: the per-sample path (equal to
        # desired_acceleration / inverse_dynamics to rounding)
        acc = self.desired_acceleration
        qdd = np.array(self.mech_law.desired_acceleration_scalar(ql, qdl, iel, tracked)
                       if acc is None else acc(ql, qdl, iel, tracked, r, wl))
        fused = self.fused_sample
        if (fused is not None and fused.parts == (self.input_affine, self.bounds, self.allocate,
                                                  self.thrust_to_speed)):
            return fused(q, qdot, ql, qdl, wl, n_prev, qdd, ref_r)
        if n_prev is None or min(np.asarray(n_prev, dtype=float).tolist()) <= 0:
            B, theta = self.input_affine(self.model, q, qdot, wind)
        else:
            B, theta = self.input_affine(self.model, q, qdot, wind, n=n_prev)
        # u* = M q̈_des + C q̇ + g − ϑ_passive (7.81), i.e. MechanicalLaw.generalized_input with
        # extra = ϑ_passive, without recomputing q̈_des
        u = (self.mech_law.dynamics.recursive_inverse_dynamics(q, qdot, qdd)
             - check_vector("theta_passive", theta, N_Q))
        lo, up = self.bounds(q, qdot, wind)
        tau = np.asarray(self.allocate(B, u, lo, up), dtype=float)
        n = np.asarray(self.thrust_to_speed(tau[:2], q, qdot, wind, n_guess=n_prev), dtype=float)
        r = u - B @ tau
        res = math.sqrt(float(r @ r))                   # ‖u* − Bτ̄‖
        return ControlStep(qdd, u, np.asarray(B), np.asarray(theta), tau, lo, up, n, res, ref_r)


class TiltrotorWInfController(DoubleOnly, LeafSystem):
    """Sampled nonlinear W∞ controller with allocation (7.81)–(7.90) as a Drake LeafSystem.

    .. pydrake_system::

        name: TiltrotorWInfController
        input_ports:
        - x
        - reference
        - wind_measured
        output_ports:
        - propeller_speed
        - servo_torque
        - surface_deflection
        - actuator_command
        - tau_bar
        - u_star
        - allocation_residual
        - integral_error
        - saturation
        - sample_record

    ``x`` (16, thesis order [q; q̇]), ``reference`` (12, [x y z ψ] positions, rates,
    accelerations), ``wind_measured`` (3, inertial m/s; Assumption 19 — gusts are *not* in it);
    ``propeller_speed`` (2, rev/s), ``servo_torque`` (2, N m), ``surface_deflection`` (4, rad
    [δWR δWL δTR δTL]), ``actuator_command`` (8, the same three in the order of the plant's ``u``
    port, [n τs δ]: one connection instead of three), ``tau_bar`` (8), ``u_star`` (8), ``allocation_residual`` (1, ‖u* − Bτ̄‖),
    ``integral_error`` (3), ``saturation`` (8, ±1 on a bound), ``sample_record`` (30, all in one
    vector, :meth:`split_record`): zero-order holds of the last update.  Double only
    (:class:`~sobolev_drake.tiltrotor.scalars.DoubleOnly`).

    Parameters
    ----------
    law : TiltrotorWInfLaw
        The law evaluated at every update.
    period : float, default 0.01
        Sample period (s).
    computation_delay : bool, default False
        Apply each sample's propeller, servo and surface commands one period later (the
        first sample is applied at once); the other outputs report the sample computed.
    initial_tau, initial_speed : array_like, optional
        τ̄ (8) and propeller speeds (2) of a context not yet initialized (zero by default);
        ``Simulator.Initialize`` takes the first sample at once.
    """

    conversion_refusal = ("its allocation is an active-set solve and its thrust inversion a root "
                          "search; linearize the hover loop with LinearHoverController instead")
    # discrete state: group 0 [∫e_c | τ̄ | n | u* | residual | saturation] (the record); group 1
    # the plant-facing command [n τs δ] (the plant's u order; with computation_delay the
    # previous record's); group 2 the bookkeeping [time stamp | the allocation's active set].
    # Groups 0 and 1 are state output ports (copied by Drake in C++: no Python output callback
    # per sample); the update writes three groups, each in one pybind call
    _I = slice(0, 3)        # ∫e_c
    _TAU = slice(3, 11)     # τ̄
    _N = slice(11, 13)      # propeller speeds
    _U = slice(13, 21)      # u*
    _RES = slice(21, 22)    # residual
    _SAT = slice(22, 30)    # +1 on upper bound, −1 on lower bound, 0 inside
    _SIZE = 30
    #: record slices of the plant-facing outputs: n, τs (τ̄[2:4]) and δ (τ̄[4:8])
    _HELD = (_N, slice(5, 7), slice(7, 11))
    #: record entries of ``actuator_command``: the held slices joined, [n τs δ] (the plant's ``u``)
    _COMMAND = np.r_[_HELD]
    #: where each plant-facing output sits in ``actuator_command``
    _COMMAND_PARTS = {"propeller_speed": slice(0, 2), "servo_torque": slice(2, 4),
                      "surface_deflection": slice(4, 8)}

    def __init__(self, law: TiltrotorWInfLaw, *, period: float = 0.01,
                 initial_tau: ArrayLike | None = None, initial_speed: ArrayLike | None = None,
                 computation_delay: bool = False) -> None:
        super().__init__()
        self.computation_delay = bool(computation_delay)
        if not isinstance(law, TiltrotorWInfLaw):
            raise TypeError("law must be a TiltrotorWInfLaw")
        if not (np.isfinite(period) and period > 0):
            raise ValueError(f"period must be a positive finite number, got {period}")
        self.law, self.period = law, float(period)
        self.x_port = self.DeclareVectorInputPort("x", 2 * N_Q)
        self.reference_port = self.DeclareVectorInputPort("reference", 12)
        self.wind_port = self.DeclareVectorInputPort("wind_measured", 3)
        init = np.zeros(self._SIZE)
        if initial_tau is not None:
            init[self._TAU] = check_vector("initial_tau", initial_tau, N_TAU)
        if initial_speed is not None:
            init[self._N] = check_vector("initial_speed", initial_speed, 2)
        self._state = self.DeclareDiscreteState(BasicVector(init))
        self._command = self.DeclareDiscreteState(BasicVector(init[self._COMMAND]))
        # [stamp | active set]: the time of the last sample (−inf: none; the first sample is
        # taken at initialization, so the outputs are never the placeholder, and the periodic
        # event at that same time finds it stamped and leaves it) and the allocation's last
        # active set (−1, 0, +1 per actuator; NaN: none yet), its warm start on both paths
        # (through make_law's allocate.warm_start on the Python path)
        self._book = self.DeclareDiscreteState(BasicVector(np.r_[-np.inf, np.full(N_TAU, np.nan)]))
        compiled = law.compiled_sample
        self._compiled = compiled if compiled is not None and compiled.matches(law) else None
        self._sample = None if self._compiled is None else self._compiled.kernel(self.period)
        self.DeclareInitializationDiscreteUpdateEvent(self._update)
        self.DeclarePeriodicDiscreteUpdateEvent(self.period, 0.0, self._update)
        # group numbers as ints: DiscreteValues.set_value(int, array) is one pybind call (a
        # BasicVector's SetFromVector from a list costs several times more)
        self._groups = tuple(int(i) for i in (self._state, self._command, self._book))
        command = {self.discrete_state_ticket(self._command)}
        for name, sl in self._COMMAND_PARTS.items():
            self.DeclareVectorOutputPort(name, sl.stop - sl.start, self._slicer(self._command, sl),
                                         prerequisites_of_calc=command)
        self.DeclareStateOutputPort("actuator_command", self._command)
        dep = {self.discrete_state_ticket(self._state)}
        for name in ("tau_bar", "u_star", "allocation_residual", "integral_error", "saturation"):
            sl = self.RECORD_FIELDS[name]
            self.DeclareVectorOutputPort(name, sl.stop - sl.start, self._slicer(self._state, sl),
                                         prerequisites_of_calc=dep)
        # everything above in one port copied by Drake in C++ (a log sink on it costs no Python
        # call per sample); split with :meth:`split_record`
        self.DeclareStateOutputPort("sample_record", self._state)

    #: fields of the ``sample_record`` port (30) and their slices
    RECORD_FIELDS = {"integral_error": _I, "tau_bar": _TAU, "propeller_speed": _N, "u_star": _U,
                     "allocation_residual": _RES, "saturation": _SAT}

    @classmethod
    def split_record(cls, record: ArrayLike) -> dict[str, np.ndarray]:
        """Named parts of ``sample_record`` values, as in :attr:`RECORD_FIELDS`.

        Parameters
        ----------
        record : array_like, shape (30, ...)
            Rows = the 30 record entries, e.g. a log's ``data()`` of shape 30 × samples.

        Returns
        -------
        dict
            Field name → its rows.
        """
        record = np.asarray(record)
        if record.shape[:1] != (cls._SIZE,):
            raise ValueError(f"record must have {cls._SIZE} rows (the sample_record port), "
                             f"got shape {record.shape}")
        return {name: record[sl] for name, sl in cls.RECORD_FIELDS.items()}

    def _slicer(self, group, sl):
        def calc(context, output):
            output.SetFromVector(context.get_discrete_state(group).value()[sl])
        return calc

    def _update(self, context, discrete_state):
        # Drake hands the handler the current discrete state to overwrite
        # (LeafSystem::DispatchDiscreteVariableUpdateHandler copies it in), so the old values
        # are read from ``discrete_state`` itself: one pybind call per group
        i_state, i_command, i_book = self._groups
        t = context.get_time()
        book = discrete_state.get_mutable_value(i_book)          # [stamp | active set]
        stamp = book[0]
        if stamp == t:
            return                                   # this sample was taken at initialization
        book[0] = t
        x = self.x_port.Eval(context)
        ref = self.reference_port.Eval(context)
        wind = self.wind_port.Eval(context)
        rec = discrete_state.get_mutable_value(i_state)
        old = rec.copy()
        active = book[1:]
        delayed = self.computation_delay and stamp != -np.inf   # the previous sample goes out
        sample = self._sample
        if sample is not None and self._compiled.matches(self.law):
            # the whole update in one compiled call (tiltrotor.compiled_sample), the record and
            # the active set written in place (it reads all its inputs first); declined samples
            # (False) write nothing and take the Python path below
            if sample(x, ref, wind, old, active, rec, active):
                discrete_state.set_value(i_command, (old if delayed else rec)[self._COMMAND])
                return
        warm = getattr(self.law.allocate, "warm_start", None)
        if type(warm) is dict:
            warm["active"] = None if np.isnan(active).any() else active.copy()
        step = self.law.step(x[:N_Q], x[N_Q:], ref, wind, old[self._I], n_prev=old[self._N])
        if type(warm) is dict and warm["active"] is not None:
            active[:] = warm["active"]
        # layout [∫e_c | τ̄ | n | u* | residual | saturation], assembled from float lists (a
        # few numpy calls on 3-vectors cost more than the arithmetic); forward-Euler integral
        # of the controlled-DOF error over one sample
        tau, n = step.tau_bar, np.asarray(step.propeller_speed, dtype=float)
        xl, rl, h = x.tolist(), ref.tolist(), self.period
        ie = [e + h * (xl[c] - r) for e, c, r in zip(old[self._I].tolist(), _CONTROLLED_IDX, rl)]
        rec[:] = (ie + tau.tolist() + n.tolist() + step.u_star.tolist() + [step.residual]
                  + saturation_flag_list(tau, step.lo, step.up))
        discrete_state.set_value(i_command, (old if delayed else rec)[self._COMMAND])
