"""Scheduled nonlinear W∞ law over the tilt-rotor's flight envelope (beyond thesis §7.3.2).

The thesis flies the whole envelope with one tuning and says so itself (§7.3.2, last paragraph:
scheduled / LPV designs are future work).  This module schedules the weights of the same law
(7.81) over the forward air speed U of the reference motion:

* **Weights from targets.**  Every DOF is a chain of integrators under the computed-torque law
  (docs/design.md §4.2), so the W∞ optimum for diagonal weights places the error's closed-loop
  poles at the stable spectral factor of the weights (inverse optimal control).  We state the
  target poles and read the weights off (:func:`target_weights`): for a target polynomial
  p(s) = sᵏ + c_{k−1} s^{k−1} + … + c0 and top weight 1,

      p(s) p(−s) = (−1)ᵏ (W0 − W1 s² + W2 s⁴ − …),

  i.e. regulated (k = 2): Σ0 = c0², Σ1 = c1² − 2c0; controlled (k = 3): Γ0 = c0²,
  Γ1 = c1² − 2c0c2, Γ2 = c2² − 2c1.  The gains of those weights are then the coefficients
  themselves (:func:`target_gains`; ``synthesis.mechanical`` CAREs agree, tested).
* **Targets from the actuators** (:data:`REGIMES`, docs/equations.md "Envelope gain schedule"):
  a pair (ω, ζ) per channel and regime.  The rule: a loop is at most 1/4 of the bandwidth of
  the loop that produces its force (position ← attitude/tilt ← thrust, servo, surfaces), with
  ζ = 1 (no overshoot into the bounds) — in hover the horizontal force comes from tilting
  the rotors and rolling (servo loop ω ≈ 3.8 rad/s → position ω ≤ 0.9, taken 0.6 for the roll
  path of y), in cruise from thrust and lift (fast) and the position loop can be stiffer.
  Attitude φ, θ get *stiffness towards the trim* (the thesis only damps their rates, so nothing
  brings a gust-pitched aircraft back and its surfaces lock on their bounds); yaw gets a real
  stiffness (the thesis' ψ pole sits at −0.005 s⁻¹).
* **Blend** between the hover and the cruise regime by a C² smootherstep in U
  (:func:`blend_factor`); (ω, ζ) are blended, so every frozen point is itself a W∞ optimum
  and the gains are C² in U.  The tilt reference is a monotone function of U (the plant's
  trims), so the blend also follows the trim tilt.

:class:`EnvelopeSchedule` is the per-sample q̈_des of :class:`~sobolev_drake.tiltrotor.
controller.TiltrotorWInfLaw` (its ``desired_acceleration`` hook): same partition, same
references, plus the trim pitch θ_trim(U) from the plant's level-flight trims.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from sobolev_drake.tiltrotor.controller import forward_air_speed

__all__ = ["ChannelTarget", "Regime", "REGIMES", "SCHEDULE_SPEEDS", "target_polynomial",
           "target_gains", "target_weights", "blend_factor", "EnvelopeSchedule"]

G = 9.80665


@dataclass(frozen=True)
class ChannelTarget:
    """Target closed-loop poles of one DOF's error chain.

    Parameters
    ----------
    omega : float
        Natural frequency ω (rad/s) of the dominant pair s² + 2ζω s + ω².
    zeta : float
        Its damping ratio ζ (≥ 1/√2 so that every inverse weight is ≥ 0).
    integral : float, default 0
        Controlled chains only: the integral pole at −``integral``·ω.
    """

    omega: float
    zeta: float
    integral: float = 0.0


@dataclass(frozen=True)
class Regime:
    """Targets of one flight regime.

    Parameters
    ----------
    name : str
        The regime ("hover", "cruise", or a blend's label).
    xy, z : ChannelTarget
        Controlled DOF (order 3, with integral): x and y share one target (a turn rotates the
        flight direction through both), z.
    tilt, yaw : ChannelTarget
        Regulated DOF (order 2): both tilt angles αR, αL, and ψ.
    roll, pitch : ChannelTarget
        Attitude φ, θ (order 2) towards the coordinated bank and the trim pitch.
    """

    name: str
    xy: ChannelTarget
    z: ChannelTarget
    tilt: ChannelTarget
    yaw: ChannelTarget
    roll: ChannelTarget
    pitch: ChannelTarget


#: the tilt-servo loop of the thesis (Σ0 = 20, Σ1 = 15, Σ2 = 0.1 → ω = 200^¼ = 3.76 rad/s,
#: ζ = 1.78): kept in every regime, it is the actuator of the hover position loop
THESIS_TILT = ChannelTarget(3.76, 1.78)

#: hover and cruise targets (rule in the module docstring and docs/equations.md)
REGIMES = {
    "hover": Regime("hover", xy=ChannelTarget(0.6, 1.0, 0.25), z=ChannelTarget(1.0, 1.0, 0.25),
                    tilt=ChannelTarget(5.0, 1.0), yaw=ChannelTarget(1.0, 1.0),
                    roll=ChannelTarget(3.0, 1.0), pitch=ChannelTarget(6.0, 1.5)),
    "cruise": Regime("cruise", xy=ChannelTarget(0.9, 1.0, 0.25), z=ChannelTarget(1.0, 1.0, 0.25),
                     tilt=ChannelTarget(5.0, 1.0), yaw=ChannelTarget(1.0, 1.0),
                     roll=ChannelTarget(3.0, 1.0), pitch=ChannelTarget(6.0, 1.5)),
}

#: forward air speeds (m/s) where the blend starts (pure hover below) and ends (pure cruise)
SCHEDULE_SPEEDS = (5.0, 25.0)


def target_polynomial(target: ChannelTarget, order: int) -> NDArray[np.float64]:
    """Monic target polynomial of a chain of ``order`` integrators, highest power first.

    Parameters
    ----------
    target : ChannelTarget
    order : {2, 3}
        2: regulated/attitude chain [ė, e]; 3: controlled chain [ė, e, ∫e].

    Returns
    -------
    ndarray, shape (order + 1,)

    Examples
    --------
    >>> target_polynomial(ChannelTarget(2.0, 1.0), 2).tolist()
    [1.0, 4.0, 4.0]
    """
    if order not in (2, 3):
        raise ValueError(f"order must be 2 or 3, got {order!r}")
    w, z = float(target.omega), float(target.zeta)
    if not (w > 0 and z >= 1 / math.sqrt(2) - 1e-12):
        raise ValueError(f"target needs omega > 0 and zeta >= 1/sqrt(2), got {target}")
    pair = np.array([1.0, 2 * z * w, w * w])
    if order == 2:
        return pair
    r = float(target.integral)
    if not r > 0:
        raise ValueError(f"a controlled chain needs integral > 0, got {target}")
    return np.polymul(pair, [1.0, r * w])


def target_gains(target: ChannelTarget, order: int) -> NDArray[np.float64]:
    """Gains of the chain: the target polynomial's coefficients, in chain-state order.

    Parameters
    ----------
    target : ChannelTarget
    order : {2, 3}

    Returns
    -------
    ndarray, shape (order,)
        [k_ė, k_e] (order 2) or [k_ė, k_e, k_∫e] (order 3): ë* = −k · chain state.

    Examples
    --------
    >>> target_gains(ChannelTarget(2.0, 1.0), 2).tolist()
    [4.0, 4.0]
    """
    return target_polynomial(target, order)[1:]


def target_weights(target: ChannelTarget, order: int) -> NDArray[np.float64]:
    """Weights (top weight 1) whose W∞ optimum has the target poles (spectral factorization).

    Parameters
    ----------
    target : ChannelTarget
    order : {2, 3}

    Returns
    -------
    ndarray, shape (order + 1,)
        (Σ0, Σ1, Σ2 = 1) or (Γ0, Γ1, Γ2, Γ3 = 1), as ``regulated_gains`` / ``controlled_gains``
        take them.

    Raises
    ------
    ValueError
        When a weight would be negative (ζ too small for the integral ratio).

    Examples
    --------
    >>> target_weights(ChannelTarget(2.0, 1.0), 2).tolist()
    [16.0, 8.0, 1.0]
    """
    c = target_polynomial(target, order)[::-1]          # c0, c1, …, 1
    if order == 2:
        w = [c[0] ** 2, c[1] ** 2 - 2 * c[0], 1.0]
    else:
        w = [c[0] ** 2, c[1] ** 2 - 2 * c[0] * c[2], c[2] ** 2 - 2 * c[1], 1.0]
    if min(w) < 0:
        raise ValueError(f"target {target} (order {order}) has no non-negative weights: {w}")
    return np.array(w)


def blend_factor(U: float, speeds: tuple[float, float] = SCHEDULE_SPEEDS) -> float:
    """C² smootherstep 6s⁵ − 15s⁴ + 10s³ of s = (U − U0)/(U1 − U0) clamped to [0, 1].

    Parameters
    ----------
    U : float
        Forward air speed (m/s).
    speeds : (float, float), default :data:`SCHEDULE_SPEEDS`
        (U0, U1): pure hover below U0, pure cruise above U1.

    Returns
    -------
    float
        0 (hover) … 1 (cruise).

    Examples
    --------
    >>> blend_factor(0.0), blend_factor(15.0), blend_factor(40.0)
    (0.0, 0.5, 1.0)
    """
    lo, hi = speeds
    s = min(max((float(U) - lo) / (hi - lo), 0.0), 1.0)
    return s * s * s * (s * (6.0 * s - 15.0) + 10.0)


def _mix(a, b, s):
    return ChannelTarget(a.omega + s * (b.omega - a.omega), a.zeta + s * (b.zeta - a.zeta),
                         a.integral + s * (b.integral - a.integral))


@dataclass
class EnvelopeSchedule:
    """Per-sample q̈_des of the scheduled W∞ law (the ``desired_acceleration`` hook).

    Parameters
    ----------
    pitch_trim : callable
        ``U -> θ_trim`` (rad): pitch of the level-flight trim at forward air speed U (m/s).
    hover, cruise : Regime, optional
        Targets of the two regimes (default :data:`REGIMES`).
    speeds : (float, float), default :data:`SCHEDULE_SPEEDS`
        Blend corridor (m/s).
    coordinated_roll : bool, default True
        Roll reference −atan(a_lat / g) of the reference's lateral acceleration in the heading
        frame (the bank of a coordinated turn); False: roll to 0.
    cascade : bool, default True
        The horizontal accelerations the x, y loops ask for also set the roll reference
        (bank −atan(a_lat/g), every regime) and, weighted by the hover share 1 − s of the
        blend, a tilt increment atan(a_fwd/g): in hover these are the only ways to produce a
        horizontal force (the surfaces have no air speed), which the thesis' law leaves to
        the allocation's leftover.
    """

    pitch_trim: Callable[[float], float]
    hover: Regime = field(default_factory=lambda: REGIMES["hover"])
    cruise: Regime = field(default_factory=lambda: REGIMES["cruise"])
    speeds: tuple[float, float] = SCHEDULE_SPEEDS
    coordinated_roll: bool = True
    cascade: bool = True

    def regime(self, U: float) -> Regime:
        """The blended targets at forward air speed U.

        Parameters
        ----------
        U : float
            Forward air speed of the reference (m/s).

        Returns
        -------
        Regime
            (ω, ζ, integral ratio) of every channel blended by :func:`blend_factor`.
        """
        s = blend_factor(U, self.speeds)
        h, c = self.hover, self.cruise
        return Regime(f"blend {s:.3f}", *(_mix(getattr(h, k), getattr(c, k), s)
                                          for k in ("xy", "z", "tilt", "yaw", "roll", "pitch")))

    def gains(self, U: float) -> dict[str, list[list[float]]]:
        """Gains of the blended targets at U (the coefficients of :func:`target_polynomial`
        written out: per sample, numpy's small-array calls would cost more than the arithmetic).

        Parameters
        ----------
        U : float
            Forward air speed of the reference (m/s).

        Returns
        -------
        dict
            "controlled": 3 rows [k_ė k_e k_∫e] of x y z (1/s, 1/s², 1/s³); "regulated": 3
            rows [k_ė k_e] of αR αL ψ; "attitude": 2 rows [k_ė k_e] of φ θ (lists of floats).
        """
        s = blend_factor(U, self.speeds)
        out = {}
        for group, names in (("controlled", ("xy", "xy", "z")), ("regulated", ("tilt", "tilt", "yaw")),
                             ("attitude", ("roll", "pitch"))):
            rows = []
            for name in names:
                a, b = getattr(self.hover, name), getattr(self.cruise, name)
                w = a.omega + s * (b.omega - a.omega)
                z = a.zeta + s * (b.zeta - a.zeta)
                if group == "controlled":
                    wi = (a.integral + s * (b.integral - a.integral)) * w
                    rows.append([2 * z * w + wi, w * w + 2 * z * w * wi, w * w * wi])
                else:
                    rows.append([2 * z * w, w * w])
            out[group] = rows
        return out

    def attitude_reference(self, U: float, reference: Sequence[float] | np.ndarray) -> tuple[float, float]:
        """Attitude reference without the cascade: the reference's coordinated bank and the
        trim pitch.

        Parameters
        ----------
        U : float
            Forward air speed of the reference (m/s).
        reference : sequence of 12 floats
            The mission reference [x y z ψ | rates | accelerations].

        Returns
        -------
        (float, float)
            (φ_r, θ_r) in rad.
        """
        psi = reference[3]
        a_lat = -math.sin(psi) * reference[8] + math.cos(psi) * reference[9]
        # the body's φ is positive right wing down about the forward axis: a left turn
        # (a_lat > 0 towards +90° of the heading) banks to φ < 0
        phi = -math.atan2(a_lat, G) if self.coordinated_roll else 0.0
        return phi, float(self.pitch_trim(U))

    def __call__(self, q: Sequence[float] | np.ndarray, qdot: Sequence[float] | np.ndarray, e_int: Sequence[float] | np.ndarray,
                 tracked: Sequence[float] | np.ndarray, reference: Sequence[float] | np.ndarray,
                 wind: Sequence[float] | np.ndarray) -> list[float]:
        """q̈_des (list of 8, thesis order) at one sample.

        Parameters
        ----------
        q, qdot : list of float, length 8
        e_int : list of float, length 3
            ∫e of x y z.
        tracked : list of float, length 18
            [x y z αR αL ψ | rates | accelerations] references (the law's stacked reference).
        reference : list of float, length 12
            The mission reference [x y z ψ | rates | accelerations].
        wind : list of float, length 3
            Measured wind (m/s).

        Returns
        -------
        list of float, length 8
            q̈_des [αR αL φ θ ψ x y z] (rad/s², m/s²).
        """
        U, _ = forward_air_speed(reference[4:7], reference[8:11], reference[3], reference[7], wind)
        k = self.gains(U)
        acc = [0.0] * 8
        for j, i in enumerate((5, 6, 7)):           # x y z
            kd, kp, ki = k["controlled"][j]
            acc[i] = (tracked[12 + j] - kd * (qdot[i] - tracked[6 + j])
                      - kp * (q[i] - tracked[j]) - ki * e_int[j])
        for j, i in enumerate((0, 1, 4)):           # αR αL ψ
            kd, kp = k["regulated"][j]
            acc[i] = (tracked[15 + j] - kd * (qdot[i] - tracked[9 + j])
                      - kp * (q[i] - tracked[3 + j]))
        phi_r, theta_r = self.attitude_reference(U, reference)
        if self.cascade:
            psi = reference[3]
            c, s_ = math.cos(psi), math.sin(psi)
            a_fwd, a_lat = c * acc[5] + s_ * acc[6], -s_ * acc[5] + c * acc[6]
            phi_r = -math.atan2(a_lat, G)
            d_alpha = (1.0 - blend_factor(U, self.speeds)) * math.atan2(a_fwd, G)
            for j, i in enumerate((0, 1)):          # the tilt increment, rates not fed forward
                kd, kp = k["regulated"][j]
                acc[i] -= kp * -d_alpha
        for j, (i, ref) in enumerate(((2, phi_r), (3, theta_r))):
            kd, kp = k["attitude"][j]
            acc[i] = -kd * qdot[i] - kp * (q[i] - ref)
        return acc
