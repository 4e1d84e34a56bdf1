"""Von Kármán turbulence spectra and filters (pure maths; the Drake source is
:class:`~sobolev_drake.systems.wind.VonKarmanTurbulence`; :mod:`~sobolev_drake.systems.wind`
re-exports these names).

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
:meth:`~sobolev_drake.systems.wind.VonKarmanTurbulence.stationary_std` returns the exact values (Lyapunov equation).

Axis mapping: the thesis applies ζ = [ζx ζy ζz] with ζx from (7.58), ζy from (7.59) and ζz from
(7.60) directly in the inertial frame (Figure 7.10), so u → inertial x, v → y, w → z here too.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike
from scipy import linalg, signal

from sobolev_drake.models.base import check_vector

__all__ = [
    "VonKarmanParameters", "von_karman_transfer_functions", "von_karman_state_space",
    "von_karman_psd", "von_karman_psd_hz", "discrete_filter", "simulate_discrete",
    "hover_linear_turbulence",
]


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


def von_karman_transfer_functions(params: VonKarmanParameters | None = None
                                  ) -> list[tuple[np.ndarray, np.ndarray]]:
    """(num, den) polynomial coefficients (highest power first) of H_u, H_v, H_w (7.58)–(7.60)."""
    p = (params or VonKarmanParameters()).validate()
    return [(float(p.sigma[axis]) * num, den) for axis, (num, den) in enumerate(_unit_sigma_tfs(p))]


def _unit_sigma_tfs(p: VonKarmanParameters) -> list[tuple[np.ndarray, np.ndarray]]:
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


def von_karman_state_space(params: VonKarmanParameters | None = None
                           ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
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


def von_karman_psd(omega: ArrayLike, params: VonKarmanParameters | None = None) -> np.ndarray:
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


def von_karman_psd_hz(f: ArrayLike, params: VonKarmanParameters | None = None) -> np.ndarray:
    """One-sided PSD in (m/s)²/Hz (what ``scipy.signal.welch`` estimates): G(f) = 2π|H(j2πf)|².

    From G(f) df = |H(jω)|² dω with ω = 2πf.
    """
    return 2.0 * math.pi * von_karman_psd(2.0 * math.pi * np.asarray(f, dtype=float), params)


def discrete_filter(params: VonKarmanParameters | None = None
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Exact zero-order-hold discretization (Ad, Bd, C) of the filter with the noise scaling.

    x[k+1] = Ad x[k] + Bd ν[k], ζ[k] = C x[k], for unit-variance samples ν[k] held over Δt;
    Bd already contains √(π/Δt).  Reproduces :class:`~sobolev_drake.systems.wind.VonKarmanTurbulence` at the sample instants.
    """
    p = (params or VonKarmanParameters()).validate()
    A, B, C, _ = von_karman_state_space(p)
    n, m = B.shape
    M = np.zeros((n + m, n + m))
    M[:n, :n], M[:n, n:] = A, B
    E = linalg.expm(M * p.sample_time)
    return E[:n, :n], E[:n, n:] * math.sqrt(math.pi / p.sample_time), C


def simulate_discrete(noise: ArrayLike, params: VonKarmanParameters | None = None,
                      x0: ArrayLike | None = None) -> np.ndarray:
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


def hover_linear_turbulence() -> VonKarmanParameters:
    """Turbulence of section 7.3.1: the thesis' σ, L, V, on 30 ≤ t ≤ 170 s, ζx decremented by 3 m/s."""
    return VonKarmanParameters(t_on=30.0, t_off=170.0, offset=(-3.0, 0.0, 0.0))
