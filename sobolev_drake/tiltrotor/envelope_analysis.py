"""Frozen-point closed-loop analysis of the tilt-rotor W∞ law across the flight envelope.

At a level-flight trim of forward speed V the plant is linearized by Drake
(:func:`~sobolev_drake.tiltrotor.linearization.linearize`, AutoDiffXd through the
MultibodyPlant and the force systems): ẋ = A Δx + B Δu with Δx = [Δq; Δq̇; ∫Δψ ∫Δx ∫Δy ∫Δz]
and Δu = [ΔnR ΔnL ΔτsR ΔτsL Δδ].  The law is linearized about the same point: its sample map
(q, q̇, ∫e) ↦ (n, τs, δ) at the reference of the trim motion (x_r = V t, hover altitude, ψ_r = 0)
is differentiated by central differences, because its bounded allocation is an active-set solve
and its thrust inversion a root search, which Drake cannot convert to AutoDiffXd
(``TiltrotorWInfController.conversion_refusal``); about an interior trim the active set does
not change over the step, so the map is smooth there.  The closed loop is A + B K on the 19
states the law uses (∫Δψ has no feedback in either design, it is dropped).

This is the robust-control engineer's check of a gain schedule: every frozen point must be
stable, with margins that do not collapse between the design regimes.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from sobolev_drake.tiltrotor.gain_schedule import EnvelopeSchedule
    from sobolev_drake.tiltrotor.plant import TiltrotorModel

__all__ = ["FrozenPoint", "frozen_point", "ANALYSIS_SPEEDS", "FROZEN_COLUMNS", "frozen_point_rows"]

#: forward speeds (m/s) of the frozen points the experiment and the tests analyse
ANALYSIS_SPEEDS = (0.0, 5.0, 10.0, 15.0, 20.0, 25.0, 30.0)
#: states kept: q (8), q̇ (8), ∫Δx ∫Δy ∫Δz (∫Δψ has no feedback)
_KEEP = tuple(range(16)) + (17, 18, 19)


@dataclass
class FrozenPoint:
    """Closed-loop linearization of one design at one trim.

    Attributes
    ----------
    speed : float
        Forward speed V (m/s) of the level-flight trim.
    design : str
        ``"thesis"`` or ``"scheduled"``.
    poles : ndarray of complex, shape (19,)
        Eigenvalues of A + B K (1/s), sorted by real part (largest first).
    K : ndarray, shape (8, 19)
        The law's linearized feedback Δu = K Δx.
    """

    speed: float
    design: str
    poles: np.ndarray
    K: np.ndarray

    @property
    def spectral_abscissa(self) -> float:
        """max Re(pole) (1/s): < 0 means the frozen point is stable."""
        return float(np.max(self.poles.real))

    @property
    def min_damping(self) -> float:
        """Smallest damping ratio −Re p / |p| over the poles (1 for a real stable pole)."""
        p = self.poles[np.abs(self.poles) > 1e-9]
        return float(np.min(-p.real / np.abs(p)))


def _law_inputs(law, x, n_trim, reference, wind):
    step = law.step(x[:8], x[8:16], reference, wind, x[16:19], n_prev=n_trim)
    return np.concatenate([step.propeller_speed, step.tau_bar[2:8]])


def frozen_point(speed: float, design: str = "thesis", *, model: TiltrotorModel | None = None,
                 step: float = 1e-6, gain_schedule: EnvelopeSchedule | None = None) -> FrozenPoint:
    """Closed-loop poles of ``design`` linearized at the level-flight trim of ``speed``.

    Parameters
    ----------
    speed : float
        Forward speed V (m/s), 0 for hover; still air.
    design : {"thesis", "scheduled"}, default "thesis"
        The law's weighting (:data:`~sobolev_drake.tiltrotor.law.DESIGNS`).
    model : TiltrotorModel, optional
        Plant and controller model (default Table B.1).
    step : float, default 1e-6
        Central-difference step of the law's linearization (rad, m, rad/s, m/s, m·s).
    gain_schedule : EnvelopeSchedule, optional
        With ``design="scheduled"``: this schedule instead of the default one.

    Returns
    -------
    FrozenPoint
    """
    from sobolev_drake.tiltrotor.law import make_law
    from sobolev_drake.tiltrotor.linearization import linearize
    from sobolev_drake.tiltrotor.trim import tiltrotor_model, trim_hover, trim_level_flight

    speed = float(speed)
    if not (np.isfinite(speed) and 0.0 <= speed <= 34.0):
        raise ValueError(f"speed must be within the trimmed range 0–34 m/s, got {speed!r}")
    model = tiltrotor_model() if model is None else model
    trim = trim_hover(model) if speed == 0.0 else trim_level_flight(speed, model=model)
    if not trim.success:
        raise ValueError(f"no level-flight trim at V = {speed} m/s: {trim.info.get('message')}")
    lin = linearize(trim, include_surfaces=True)
    law = make_law(model, design=design, gain_schedule=gain_schedule)
    wind = np.asarray(trim.zeta, dtype=float)
    reference = np.zeros(12)
    reference[0:3] = trim.q[5:8]
    reference[4:7] = trim.qdot[5:8]
    x0 = np.concatenate([trim.q, trim.qdot, np.zeros(3)])
    K = np.zeros((8, 19))
    for j in range(19):
        dx = np.zeros(19)
        dx[j] = step
        up = _law_inputs(law, x0 + dx, trim.n, reference, wind)
        dn = _law_inputs(law, x0 - dx, trim.n, reference, wind)
        K[:, j] = (up - dn) / (2 * step)
    keep = list(_KEEP)
    A = lin.A[np.ix_(keep, keep)]
    B = lin.B[keep]
    poles = np.linalg.eigvals(A + B @ K)
    return FrozenPoint(speed, design, poles[np.argsort(-poles.real)], K)


#: columns of the frozen-point table (units in every header)
FROZEN_COLUMNS = ["V [m/s]", "design", "max Re(pole) [1/s]", "min damping ratio [-]",
                  "slowest poles [1/s]"]


def frozen_point_rows(speeds: Sequence[float] = ANALYSIS_SPEEDS,
                      designs: Sequence[str] = ("scheduled", "thesis")) -> list[list[str]]:
    """Rows of the frozen-point table (:data:`FROZEN_COLUMNS`): every design at every speed.

    Parameters
    ----------
    speeds : sequence of float, default :data:`ANALYSIS_SPEEDS`
        Forward speeds of the level-flight trims (m/s).
    designs : sequence of str
        Designs of :data:`~sobolev_drake.tiltrotor.law.DESIGNS`.

    Returns
    -------
    list of list
    """
    rows = []
    for V in speeds:
        for d in designs:
            fp = frozen_point(V, d)
            slow = ", ".join(f"{p.real:.3g}{p.imag:+.3g}j" if abs(p.imag) > 1e-9 else f"{p.real:.3g}"
                             for p in fp.poles[:3])
            rows.append([f"{V:g}", d, f"{fp.spectral_abscissa:.4f}", f"{fp.min_damping:.3f}", slow])
    return rows
