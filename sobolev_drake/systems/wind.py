"""Environment wind sources: von Kármán turbulence, constant wind, gust profiles and their sum.

Every source has one output port ``wind``: the environment wind velocity ζ in the inertial frame
(m/s, size 3, z up), the vector the tilt-rotor aerodynamics subtract from the body velocity.

Von Kármán turbulence (thesis (7.58)–(7.60), the MIL-F-8785C rational approximations)
---------------------------------------------------------------------------------------
With T = L/V for the longitudinal axis and T = 2L/V for the lateral and vertical axes::

    H_u(s) = σ_u √(2L_u/(πV)) (1 + 0.25 T s) / (1 + 1.357 T s + 0.1987 T²s²)
    H_v(s) = σ_v √(2L_v/(πV)) (1 + 2.7478 T s + 0.3398 T²s²)
                              / (1 + 2.9958 T s + 1.9754 T²s² + 0.1539 T³s³)

(H_w like H_v with σ_w, L_w).  |H(jω)|² approximates the von Kármán spectrum written over
ω ∈ [0, ∞), Φ(ω) = σ²(2L/(πV)) / (1 + (1.339 Lω/V)²)^(5/6), whose integral is σ².  For a white
noise n with two-sided intensity N (E[n(t)n(t+τ)] = N δ(τ)) the output variance is
(1/2π)∫_{-∞}^{∞}|H|²N dω = (N/π)∫_0^∞|H|²dω, so the gust has variance σ² only if **N = π**.
A zero-order-held sequence of independent samples of variance q over intervals Δt has spectrum
qΔt·sinc²(ωΔt/2) ≈ qΔt in the filter band, hence the samples must have variance **π/Δt**.
(The thesis says "unit variance, sampling time 0.01 s"; read literally that gives intensity 0.01
and gusts of √(0.01/π) ≈ 6 % of the stated σ (≤ 0.3 m/s), hard to reconcile with the several
m/s excursions on the ±10 m/s axis of its Figure 7.10, so we use the normalisation above.)  Quadrature of the rational forms gives ∫_0^∞|H|²dω = 0.9687 σ² (u) and
0.9623 σ² (v, w): the generated standard deviations are 0.984 σ and 0.981 σ, not exactly σ;
:meth:`VonKarmanTurbulence.stationary_std` returns the exact values (Lyapunov equation).

Axis mapping: the thesis applies ζ = [ζx ζy ζz] with ζx from (7.58), ζy from (7.59) and ζz from
(7.60) directly in the inertial frame (Figure 7.10), so u → inertial x, v → y, w → z here too.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy import linalg, signal
from pydrake.systems.framework import BasicVector_, Diagram, DiagramBuilder, LeafSystem_
from pydrake.systems.scalar_conversion import TemplateSystem

from sobolev_drake.models.base import check_vector
from sobolev_drake.systems.disturbances import HeldGaussianNoise
from sobolev_drake.systems.scalar_time import interval_indicator, smooth_window, template_signature

__all__ = [
    "VonKarmanParameters", "von_karman_transfer_functions", "von_karman_state_space",
    "von_karman_psd", "von_karman_psd_hz", "discrete_filter", "simulate_discrete",
    "VonKarmanTurbulence", "ConstantWind", "GustProfile", "WindSum", "add_wind",
    "hover_linear_turbulence", "mission_wind_sources",
    "VonKarmanFilter_", "ConstantWind_", "GustProfile_", "WindSum_",
]

AXES = {"x": 0, "y": 1, "z": 2}


@dataclass
class VonKarmanParameters:
    """Parameters of (7.58)–(7.60); defaults are the thesis' section 7.3.1 values."""

    sigma: tuple = (1.0, 5.0, 3.0)        # σu, σv, σw [m/s]
    length: tuple = (20.0, 20.0, 20.0)    # Lu, Lv, Lw [m]
    airspeed: float = 5.1                 # V [m/s], speed through the gust field
    sample_time: float = 0.01             # Δt of the held white-noise samples [s]
    t_on: float = -math.inf               # gusts are output only for t_on ≤ t ≤ t_off
    t_off: float = math.inf
    offset: tuple = field(default=(0.0, 0.0, 0.0))  # constant wind added at all times [m/s]

    def validate(self) -> "VonKarmanParameters":
        sig = np.asarray(self.sigma, dtype=float)
        L = np.asarray(self.length, dtype=float)
        if sig.shape != (3,) or np.any(sig < 0) or not np.all(np.isfinite(sig)):
            raise ValueError(f"sigma must be 3 finite non-negative intensities, got {self.sigma}")
        if L.shape != (3,) or np.any(L <= 0) or not np.all(np.isfinite(L)):
            raise ValueError(f"length must be 3 positive scale lengths, got {self.length}")
        if not (np.isfinite(self.airspeed) and self.airspeed > 0):
            raise ValueError(f"airspeed must be positive, got {self.airspeed}")
        if not (np.isfinite(self.sample_time) and self.sample_time > 0):
            raise ValueError(f"sample_time must be positive, got {self.sample_time}")
        if not self.t_on < self.t_off:
            raise ValueError(f"need t_on < t_off, got [{self.t_on}, {self.t_off}]")
        check_vector("offset", self.offset, 3)
        return self


def von_karman_transfer_functions(params: VonKarmanParameters | None = None):
    """(num, den) polynomial coefficients (highest power first) of H_u, H_v, H_w (7.58)–(7.60)."""
    p = (params or VonKarmanParameters()).validate()
    return [(float(p.sigma[axis]) * num, den) for axis, (num, den) in enumerate(_unit_sigma_tfs(p))]


def _unit_sigma_tfs(p: VonKarmanParameters):
    tfs = []
    for axis in range(3):
        L, V = float(p.length[axis]), float(p.airspeed)
        gain = math.sqrt(2.0 * L / (math.pi * V))
        if axis == 0:
            T = L / V
            num = gain * np.array([0.25 * T, 1.0])
            den = np.array([0.1987 * T**2, 1.357 * T, 1.0])
        else:
            T = 2.0 * L / V
            num = gain * np.array([0.3398 * T**2, 2.7478 * T, 1.0])
            den = np.array([0.1539 * T**3, 1.9754 * T**2, 2.9958 * T, 1.0])
        tfs.append((num, den))
    return tfs


def von_karman_state_space(params: VonKarmanParameters | None = None):
    """Block-diagonal realization (A, B, C, D) of diag(H_u, H_v, H_w): 8 states, 3 inputs, 3 outputs.

    Input: white noise of two-sided intensity π per channel (see module docstring); output:
    gust velocity [ζx, ζy, ζz] without offset/window.  D = 0 (strictly proper forms).  Also the
    disturbance model for the W∞-D designs of section 7.3.1.
    """
    p = (params or VonKarmanParameters()).validate()
    blocks = []
    for sigma, (num, den) in zip(p.sigma, _unit_sigma_tfs(p)):
        a, b, c, _ = signal.tf2ss(num, den)  # realize the σ = 1 form so σ = 0 stays well defined
        blocks.append((a, b, c * float(sigma)))
    A, B, C = (linalg.block_diag(*[blk[i] for blk in blocks]) for i in range(3))
    return A, B, C, np.zeros((3, 3))


def von_karman_psd(omega, params: VonKarmanParameters | None = None) -> np.ndarray:
    """|H(jω)|² per axis, shape (len(omega), 3): the one-sided PSD per rad/s of the gusts.

    With noise intensity π the two-sided output PSD is π|H|², so the variance
    (1/2π)∫_{-∞}^{∞} π|H|² dω equals ∫_0^∞ |H(jω)|² dω.
    """
    w = np.atleast_1d(np.asarray(omega, dtype=float))
    out = np.empty((w.size, 3))
    for axis, (num, den) in enumerate(von_karman_transfer_functions(params)):
        h = np.polyval(num, 1j * w) / np.polyval(den, 1j * w)
        out[:, axis] = np.abs(h) ** 2
    return out


def von_karman_psd_hz(f, params: VonKarmanParameters | None = None) -> np.ndarray:
    """One-sided PSD in (m/s)²/Hz (what ``scipy.signal.welch`` estimates): G(f) = 2π|H(j2πf)|².

    From G(f) df = |H(jω)|² dω with ω = 2πf.
    """
    return 2.0 * math.pi * von_karman_psd(2.0 * math.pi * np.asarray(f, dtype=float), params)


def discrete_filter(params: VonKarmanParameters | None = None):
    """Exact zero-order-hold discretization (Ad, Bd, C) of the filter with the noise scaling.

    x[k+1] = Ad x[k] + Bd ν[k], ζ[k] = C x[k], for unit-variance samples ν[k] held over Δt;
    Bd already contains √(π/Δt).  Reproduces :class:`VonKarmanTurbulence` at the sample instants.
    """
    p = (params or VonKarmanParameters()).validate()
    A, B, C, _ = von_karman_state_space(p)
    n, m = B.shape
    M = np.zeros((n + m, n + m))
    M[:n, :n], M[:n, n:] = A, B
    E = linalg.expm(M * p.sample_time)
    return E[:n, :n], E[:n, n:] * math.sqrt(math.pi / p.sample_time), C


def simulate_discrete(noise, params: VonKarmanParameters | None = None, x0=None) -> np.ndarray:
    """Gust samples ζ[k] (shape (K, 3), no offset/window) for unit-variance samples ``noise`` (K, 3).

    Pure numpy/scipy (``lfilter`` per axis is used when x0 is None — fast for long runs).
    """
    p = (params or VonKarmanParameters()).validate()
    nu = np.asarray(noise, dtype=float)
    if nu.ndim != 2 or nu.shape[1] != 3:
        raise ValueError(f"noise must have shape (K, 3), got {nu.shape}")
    Ad, Bd, C = discrete_filter(p)
    if x0 is None:
        out = np.empty_like(nu)
        for axis, s in enumerate([slice(0, 2), slice(2, 5), slice(5, 8)]):
            if not np.any(C[axis, s]):  # σ = 0 on this axis
                out[:, axis] = 0.0
                continue
            # per-axis ZOH transfer function from ν[k] to ζ[k]: C (zI − Ad)⁻¹ Bd
            num, den = signal.ss2tf(Ad[s, s], Bd[s, axis:axis + 1], C[axis:axis + 1, s], np.zeros((1, 1)))
            out[:, axis] = signal.lfilter(num[0], den, nu[:, axis])
        return out
    x = np.array(x0, dtype=float)
    out = np.empty_like(nu)
    for k in range(nu.shape[0]):
        out[k] = C @ x
        x = Ad @ x + Bd @ nu[k]
    return out


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

        def DoCalcTimeDerivatives(self, context, derivatives):
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

    def __init__(self, params: VonKarmanParameters | None = None, *, seed: int = 0, **overrides):
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

    def seed(self, root_context, seed: int, *, stationary: bool = True) -> None:
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


def add_wind(builder, *sources):
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


def hover_linear_turbulence() -> VonKarmanParameters:
    """Turbulence of section 7.3.1: the thesis' σ, L, V, on 30 ≤ t ≤ 170 s, ζx decremented by 3 m/s."""
    return VonKarmanParameters(t_on=30.0, t_off=170.0, offset=(-3.0, 0.0, 0.0))


def mission_wind_sources(scenario: str, *, turbulence: VonKarmanParameters | None = None,
                         gust_rise_time: float = 0.0) -> list:
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
