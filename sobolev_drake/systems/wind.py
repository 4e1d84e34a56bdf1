"""Environment wind sources: von Kármán turbulence, constant wind, gust profiles and their sum.

Every source has one output port ``wind``: the environment wind velocity ζ in the inertial frame
(m/s, size 3, z up), the vector the tilt-rotor aerodynamics subtract from the body velocity.

The von Kármán spectra, filters and their normalisation are in :mod:`.von_karman` (re-exported
here); this module holds the Drake sources.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np
from scipy import linalg
from pydrake.systems.framework import BasicVector_, Diagram, DiagramBuilder, LeafSystem_
from pydrake.systems.scalar_conversion import TemplateSystem

from sobolev_drake.models.base import check_vector
from sobolev_drake.systems.disturbances import HeldGaussianNoise
from sobolev_drake.systems.scalar_time import interval_indicator, smooth_window, template_signature
if TYPE_CHECKING:
    from pydrake.systems.framework import Context, ContinuousState, OutputPort, System

# the spectra and filters, importable from here as before
from sobolev_drake.systems.von_karman import (VonKarmanParameters, discrete_filter,  # noqa: F401
                                              hover_linear_turbulence, simulate_discrete, von_karman_psd,
                                              von_karman_psd_hz, von_karman_state_space,
                                              von_karman_transfer_functions)

__all__ = [
    "VonKarmanTurbulence", "ConstantWind", "GustProfile", "WindSum", "add_wind",
    "mission_wind_sources", "VonKarmanFilter_", "ConstantWind_", "GustProfile_", "WindSum_",
]

AXES = {"x": 0, "y": 1, "z": 2}


@TemplateSystem.define("VonKarmanFilter_")
def VonKarmanFilter_(T):   # the class for scalar type T (float, AutoDiffXd, Expression)

    class Impl(LeafSystem_[T]):
        """Filter (7.58)–(7.60) of unit-variance samples ν: ẋ = A x + √(π/Δt) B ν, wind =
        offset + [t_on ≤ t ≤ t_off]·C x (offset: numeric parameter 0; A, B, C, window fixed).

        .. pydrake_system::

            name: VonKarmanFilter
            input_ports:
            - noise
            output_ports:
            - wind

        Parameters
        ----------
        params : VonKarmanParameters
            Turbulence parameters (validated).
        """

        def _construct(self, params, converter=None):
            LeafSystem_[T].__init__(self, converter)
            self.params = params.validate()
            self._A, B, self._C, _ = von_karman_state_space(params)
            self._B = B * math.sqrt(math.pi / params.sample_time)
            self._noise = self.DeclareVectorInputPort("noise", 3)
            self.DeclareContinuousState(self._A.shape[0])
            self.DeclareNumericParameter(BasicVector_[T](np.asarray(params.offset, dtype=float)))
            # Output depends on time, state and offset only: no direct feedthrough from the noise.
            self.DeclareVectorOutputPort("wind", 3, self._calc_wind, prerequisites_of_calc={
                self.time_ticket(), self.xc_ticket(), self.all_parameters_ticket()})

        def _construct_copy(self, other, converter=None):
            Impl._construct(self, other.params, converter=converter)

        __signature__ = template_signature(_construct)

        def DoCalcTimeDerivatives(self, context: Context, derivatives: ContinuousState) -> None:
            x = context.get_continuous_state_vector().CopyToVector()
            derivatives.get_mutable_vector().SetFromVector(self._A @ x + self._B @ self._noise.Eval(context))

        def _calc_wind(self, context, output):
            on = interval_indicator(context.get_time(), self.params.t_on, self.params.t_off)
            x = context.get_continuous_state_vector().CopyToVector()
            output.SetFromVector(context.get_numeric_parameter(0).CopyToVector() + on * (self._C @ x))

    return Impl


class VonKarmanTurbulence(Diagram):
    """Von Kármán turbulence (7.58)–(7.60) driven by seeded held Gaussian noise.

    Internals: :class:`~sobolev_drake.systems.disturbances.HeldGaussianNoise` (3 unit-variance
    channels held over Δt, output ``noise``) → 8-state filter ``VonKarmanFilter_`` with input
    gain √(π/Δt) (intensity π, module docstring) → ``wind`` = offset + [t_on ≤ t ≤ t_off]·C x.
    The filter runs from t = 0 regardless of the window (stationary by t_on ≳ 20 s);
    :meth:`seed` can also start it in its stationary distribution.

    .. pydrake_system::

        name: VonKarmanTurbulence
        output_ports:
        - wind
        - noise

    Sample k, held on [kΔt, (k+1)Δt), is a function of (seed, k) (:meth:`seed`), so
    :func:`simulate_discrete` reproduces the output at the sample instants.  Converts to
    AutoDiffXd and Expression (a plain Diagram, same noise; ``SetTimeStateAndParametersFrom``).

    Parameters
    ----------
    params : VonKarmanParameters, optional
        Default: the thesis values.
    seed : int, default 0
        Default seed of the noise (give distinct seeds to independent sources).
    **overrides
        Fields of :class:`VonKarmanParameters` replacing those of ``params``.
    """

    def __init__(self, params: VonKarmanParameters | None = None, *, seed: int = 0,
                 **overrides: Any) -> None:
        super().__init__()
        p = params if params is not None else VonKarmanParameters()
        if overrides:
            p = VonKarmanParameters(**{**p.__dict__, **overrides})
        self.params = p.validate()
        builder = DiagramBuilder()
        self.noise = builder.AddNamedSystem("white_noise", HeldGaussianNoise(3, p.sample_time, seed))
        self.filter = builder.AddNamedSystem("von_karman_filter", VonKarmanFilter_[None](p))
        builder.Connect(self.noise.get_output_port(0), self.filter.GetInputPort("noise"))
        builder.ExportOutput(self.filter.GetOutputPort("wind"), "wind")
        builder.ExportOutput(self.noise.get_output_port(0), "noise")
        builder.BuildInto(self)
        self.set_name("von_karman_turbulence")

    def stationary_covariance(self) -> np.ndarray:
        """Stationary filter-state covariance P (8×8): A P + P Aᵀ + π B Bᵀ = 0."""
        A, B, _, _ = von_karman_state_space(self.params)
        return linalg.solve_continuous_lyapunov(A, -math.pi * B @ B.T)

    def stationary_std(self) -> np.ndarray:
        """Exact standard deviation of each gust component (≈ 0.98 σ, module docstring)."""
        _, _, C, _ = von_karman_state_space(self.params)
        return np.sqrt(np.diag(C @ self.stationary_covariance() @ C.T))

    def seed(self, root_context: Context, seed: int, *, stationary: bool = True) -> None:
        """Seed the noise source in ``root_context`` (the context of the root diagram).

        With ``stationary`` the filter state is drawn from its stationary Gaussian distribution
        (numpy generator seeded with ``seed``), otherwise it starts at zero.
        """
        if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
            raise ValueError(f"seed must be a non-negative integer, got {seed!r}")
        self.noise.set_seed(self.noise.GetMyMutableContextFromRoot(root_context), int(seed))
        x0 = np.zeros(self.filter.num_continuous_states())
        if stationary:
            P = self.stationary_covariance()
            w, V = np.linalg.eigh(0.5 * (P + P.T))
            x0 = V @ (np.sqrt(np.clip(w, 0.0, None)) * np.random.default_rng(int(seed)).standard_normal(len(w)))
        self.filter.GetMyMutableContextFromRoot(root_context).SetContinuousState(x0)


@TemplateSystem.define("ConstantWind_")
def ConstantWind_(T):   # the class for scalar type T (float, AutoDiffXd, Expression)

    class Impl(LeafSystem_[T]):
        """Constant inertial wind ζ (numeric parameter 0); thesis scenario 1 uses ζ = [0, 3, 0].

        .. pydrake_system::

            name: ConstantWind
            output_ports:
            - wind

        Parameters
        ----------
        wind : array_like, shape (3,)
            Default ζ (m/s, inertial frame).
        """

        def _construct(self, wind, converter=None):
            LeafSystem_[T].__init__(self, converter)
            self.wind = check_vector("wind", wind, 3).copy()
            self.DeclareNumericParameter(BasicVector_[T](self.wind))
            self.DeclareVectorOutputPort("wind", 3, lambda c, out: out.SetFromVector(
                c.get_numeric_parameter(0).CopyToVector()), {self.all_parameters_ticket()})

        def _construct_copy(self, other, converter=None):
            Impl._construct(self, other.wind, converter=converter)

        __signature__ = template_signature(_construct)

    return Impl


ConstantWind = ConstantWind_[None]


@TemplateSystem.define("GustProfile_")
def GustProfile_(T):   # the class for scalar type T (float, AutoDiffXd, Expression)

    class Impl(LeafSystem_[T]):
        """Piecewise-constant gusts {axis, value, from, to} (the json ``wind_gusts``) → ``wind``.

        ``rise_time`` > 0 replaces each step by a half-cosine ramp of that length centred on the
        step (same time integral; at most any gust's duration).  Overlapping gusts on one axis
        add.  The gust values are numeric parameter 0 (one per gust); axes and times are fixed.

        .. pydrake_system::

            name: GustProfile
            output_ports:
            - wind

        Parameters
        ----------
        gusts : sequence of dict
            ``{"axis": "x"|"y"|"z", "value": m/s, "from": t0, "to": t1}``.
        rise_time : float, default 0.0
            Length of the cosine ramps (s).
        """

        def _construct(self, gusts, *, rise_time=0.0, converter=None):
            LeafSystem_[T].__init__(self, converter)
            if not (np.isfinite(rise_time) and rise_time >= 0):
                raise ValueError(f"rise_time must be a finite non-negative number, got {rise_time}")
            self._gusts = []
            for i, g in enumerate(gusts):
                try:
                    axis, value, t0, t1 = g["axis"], float(g["value"]), float(g["from"]), float(g["to"])
                except (KeyError, TypeError) as exc:
                    raise ValueError(f"gusts[{i}] must be a mapping with keys axis, value, from, to; got {g!r}") from exc
                if axis not in AXES:
                    raise ValueError(f"gusts[{i}]['axis'] must be one of 'x', 'y', 'z', got {axis!r}")
                if not np.isfinite(value):
                    raise ValueError(f"gusts[{i}]['value'] must be a finite wind speed (m/s), got {value!r}")
                if not t0 < t1:
                    raise ValueError(f"gusts[{i}] needs from < to, got [{t0}, {t1}]")
                if rise_time > t1 - t0:
                    raise ValueError(f"rise_time {rise_time} exceeds the duration of gusts[{i}] ({t1 - t0} s)")
                self._gusts.append((AXES[axis], value, t0, t1))
            self.gusts = [{"axis": "xyz"[a], "value": v, "from": t0, "to": t1} for a, v, t0, t1 in self._gusts]
            self._rise = float(rise_time)
            if self._gusts:
                self.DeclareNumericParameter(BasicVector_[T]([g[1] for g in self._gusts]))
            self.DeclareVectorOutputPort("wind", 3, self._calc, prerequisites_of_calc={
                self.time_ticket(), self.all_parameters_ticket()})

        def _construct_copy(self, other, converter=None):
            Impl._construct(self, other.gusts, rise_time=other._rise, converter=converter)

        __signature__ = template_signature(_construct)

        def _wind(self, t, values):
            w = [0.0, 0.0, 0.0]
            for (axis, _, t0, t1), value in zip(self._gusts, values):
                w[axis] = w[axis] + value * smooth_window(t, t0, t1, self._rise)
            return w

        def value(self, t: float) -> np.ndarray:
            """Wind at time t with the default gust values (numpy; the port's float path).

            Parameters
            ----------
            t : float
                Time (s).

            Returns
            -------
            ndarray, shape (3,)
            """
            return np.array(self._wind(float(t), [g[1] for g in self._gusts]))

        def _calc(self, context, output):
            values = context.get_numeric_parameter(0).CopyToVector() if self._gusts else ()
            output.SetFromVector(self._wind(context.get_time(), values))

    return Impl


GustProfile = GustProfile_[None]


@TemplateSystem.define("WindSum_")
def WindSum_(T):   # the class for scalar type T (float, AutoDiffXd, Expression)

    class Impl(LeafSystem_[T]):
        """Sum of ``num_inputs`` wind inputs ``wind_0`` … ``wind_{N−1}`` → output ``wind``.

        .. pydrake_system::

            name: WindSum
            input_ports:
            - wind_0
            - ...
            - wind_{N-1}
            output_ports:
            - wind

        Parameters
        ----------
        num_inputs : int
            N ≥ 1.
        """

        def _construct(self, num_inputs, converter=None):
            LeafSystem_[T].__init__(self, converter)
            if isinstance(num_inputs, bool) or not isinstance(num_inputs, (int, np.integer)) or num_inputs < 1:
                raise ValueError(f"num_inputs must be a positive integer, got {num_inputs!r}")
            self.num_inputs, self._inputs = int(num_inputs), [
                self.DeclareVectorInputPort(f"wind_{i}", 3) for i in range(num_inputs)]
            self.DeclareVectorOutputPort("wind", 3, lambda c, out: out.SetFromVector(   # per entry:
                [sum(v) for v in zip(*(p.Eval(c) for p in self._inputs))]))    # no numpy object loop

        def _construct_copy(self, other, converter=None):
            Impl._construct(self, other.num_inputs, converter=converter)

        __signature__ = template_signature(_construct)

    return Impl


WindSum = WindSum_[None]


def add_wind(builder: DiagramBuilder, *sources: System) -> OutputPort:
    """Add wind ``sources`` (systems with a ``wind`` output) to ``builder``; return the total
    port (one source's own, or a :class:`WindSum` of several)."""
    if not sources:
        raise ValueError("add_wind needs at least one wind source")
    for s in sources:
        if not s.HasOutputPort("wind"):
            raise ValueError(f"system {s.get_name()!r} has no output port 'wind'")
        builder.AddSystem(s)
    if len(sources) == 1:
        return sources[0].GetOutputPort("wind")
    total = builder.AddSystem(WindSum(len(sources)))
    for i, s in enumerate(sources):
        builder.Connect(s.GetOutputPort("wind"), total.GetInputPort(f"wind_{i}"))
    return total.GetOutputPort("wind")


def mission_wind_sources(scenario: str, *, turbulence: VonKarmanParameters | None = None,
                         gust_rise_time: float = 0.0) -> list[System]:
    """Wind sources of a tilt-rotor mission from ``tiltrotor_missions.json``.

    ``scenario``: a key of that file (``"scenario_1_helicopter_mode"``,
    ``"scenario_2_full_envelope"``) or ``"hover_linear"`` for section 7.3.1 (von Kármán on
    30 ≤ t ≤ 170 s with ζx decremented by 3 m/s — applied at all times here, the thesis is not
    explicit).  ``turbulence`` adds a von Kármán source to the json scenarios (or replaces the
    defaults of ``hover_linear``).  Pass the result to :func:`add_wind`.
    """
    from sobolev_drake.data import load

    if scenario == "hover_linear":
        return [VonKarmanTurbulence(turbulence or hover_linear_turbulence())]
    missions = load("tiltrotor_missions")
    if scenario not in missions or not isinstance(missions[scenario], dict) or "constant_wind" not in missions[scenario]:
        choices = [k for k, v in missions.items() if isinstance(v, dict) and "constant_wind" in v] + ["hover_linear"]
        raise ValueError(f"unknown scenario {scenario!r}; choose one of {choices}")
    spec = missions[scenario]
    sources = [ConstantWind(spec["constant_wind"])]
    if spec.get("wind_gusts"):
        sources.append(GustProfile(spec["wind_gusts"], rise_time=gust_rise_time))
    if turbulence is not None:
        sources.append(VonKarmanTurbulence(turbulence))
    return sources
