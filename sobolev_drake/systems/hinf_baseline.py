"""The classic nonlinear H∞ baseline of the chapter-5 comparisons, matched to a W2/W∞ design.

The surface comes from :func:`sobolev_drake.synthesis.hinf_surface.matched_hinf_surface`; the one
free weight, the σ-gain 1/ωu², is then searched (e.g. with
:func:`sobolev_drake.tuning.match_by_regula_falsi`) so that a named index matches the W2/W∞ run.
γ = 2ωu: the law does not depend on γ, only its certificate does.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from sobolev_drake.synthesis.mechanical import SobolevGains, hinf_mechanical_gains
from sobolev_drake.systems.mechanical_law import HinfLaw, MechanicalLaw

__all__ = ["matched_hinf_law", "omega_u_guess"]


def matched_hinf_law(surface: tuple[float, float, float], omega_u: float) -> HinfLaw:
    """The H∞ inner law on ``surface`` = (ω1, ω2, ω3) with input weight ωu and γ = 2ωu.

    Parameters
    ----------
    surface : (float, float, float)
        From :func:`~sobolev_drake.synthesis.hinf_surface.matched_hinf_surface`.
    omega_u : float
        ωu > 0.

    Returns
    -------
    HinfLaw
    """
    w1, w2, w3 = surface
    return HinfLaw(hinf_mechanical_gains(w1, w2, w3, omega_u, 2.0 * omega_u))


def omega_u_guess(law: MechanicalLaw, gains: SobolevGains, q0: ArrayLike, qd0: ArrayLike) -> float:
    """First ωu of the search: 1/ωu² ≈ the W law's ė gain in force units.

    The mean over the controlled DOF of diag(M̄)·diag(Y3⁻¹Q), M̄ the reduced inertia (5.5) for a
    reduced partition or the tracked block of M otherwise, at (q0, q̇0).

    Parameters
    ----------
    law : MechanicalLaw
        The controller's law (its model and partition).
    gains : SobolevGains
        The W2/W∞ gains of the controlled DOF.
    q0, qd0 : array_like
        Initial configuration and velocity.

    Returns
    -------
    float
    """
    if law.partition.mode == "reduced":
        Mbar = law.reduced_model(np.asarray(q0, float), np.asarray(qd0, float))[0]
    else:
        M = law.model.M(np.asarray(q0, float))
        Mbar = M[np.ix_(law.ic, law.ic)]
    kd = np.diag(gains.blocks["Q"]) / np.diag(gains.weights["Y3"])
    return float(1.0 / np.sqrt(np.mean(np.diag(Mbar) * kd)))
