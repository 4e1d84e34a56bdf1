"""The quadrotor linearized at hover, thesis (6.44)–(6.45), and its ±10 % parameter polytope
(section 6.5.3, Corollary 1).

State x̂ = [ϕ θ ψ x y z ϕ̇ θ̇ ψ̇ ẋ ẏ ż], input the rotor commands Ω_i² (B in Ω² units),
disturbance the generalized force w (D = [0; M⁻¹]).  :func:`linearize` differentiates the
Drake model (Drake's ``FirstOrderTaylorApproximation`` of its MultibodyPlant with the rotor
wrenches applied by Drake's ``Propeller``, so the thrust turning with the body, ẍ = g θ, is
Drake's), :func:`closed_form_linearization` is the hand Jacobian of (5.123);
:func:`vertices` evaluates the latter at the corners of an interval box of m and the inertias.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from sobolev_drake.models.linearization import linearize_mechanical
from sobolev_drake.models.quadrotor import QuadrotorModel, QuadrotorParams, make_quadrotor_model
from sobolev_drake.synthesis.polytopic import interval_vertices

__all__ = ["UNCERTAIN", "SPREAD", "linearize", "closed_form_linearization", "input_scale",
           "hinf_input_weight", "vertices"]

#: the uncertain parameters of section 6.5.3 and their relative spread (±10 %)
UNCERTAIN = ("m", "Ixx", "Iyy", "Izz")
SPREAD = 0.1


def _params():
    return QuadrotorParams.chapter6_nominal()


def linearize(params: QuadrotorParams | None = None, *,
              tilt: float | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(A, B, D) at hover of the Drake quadrotor, by Drake's AutoDiff linearization of its
    plant; the rotor inputs act as the body-fixed wrench ``model.body_wrench_matrix()``.

    Parameters
    ----------
    params : QuadrotorParams, optional
        The vehicle; ``QuadrotorParams.chapter6_nominal()`` by default.
    tilt : float, optional
        Rotor tilt angle passed to ``make_quadrotor_model`` (its default when None).

    Returns
    -------
    A : ndarray, shape (12, 12)
    B : ndarray, shape (12, 4)
        Per unit Ω_i².
    D : ndarray, shape (12, 6)
    """
    model = make_quadrotor_model(params or _params(), tilt=tilt)
    u0 = np.full(4, model.params.hover_input())
    return linearize_mechanical(model, np.zeros(6), np.zeros(6), u0,
                                body_wrench=("body", model.body_wrench_matrix()))


def closed_form_linearization(m: float, Ixx: float, Iyy: float, Izz: float,
                              params: QuadrotorParams | None = None,
                              **_: object) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Hover Jacobian of (5.123), thesis (6.44)–(6.45).

    A has ẍ = g θ, ÿ = −g ϕ; B = [0; M0⁻¹ B0]; D = [0; M0⁻¹] with M0 = diag(Ixx, Iyy, Izz, m, m, m).

    Parameters
    ----------
    m, Ixx, Iyy, Izz : float
        Mass and principal inertias of this linearization.
    params : QuadrotorParams, optional
        The remaining parameters (g, b, d, l, α); ``chapter6_nominal()`` by default.
    **_
        Other parameters of a polytope vertex, ignored.

    Returns
    -------
    A : ndarray, shape (12, 12)
    B : ndarray, shape (12, 4)
    D : ndarray, shape (12, 6)
    """
    p = replace(params or _params(), m=m, Ixx=Ixx, Iyy=Iyy, Izz=Izz)
    B0 = QuadrotorModel.B0_closed_form(_B0Holder(p))
    Mi = np.diag(1.0 / np.array([Ixx, Iyy, Izz, m, m, m]))
    A = np.zeros((12, 12))
    A[:6, 6:] = np.eye(6)
    A[9, 1], A[10, 0] = p.g, -p.g
    return A, np.vstack([np.zeros((6, 4)), Mi @ B0]), np.vstack([np.zeros((6, 6)), Mi])


class _B0Holder:  # the attributes QuadrotorModel.B0_closed_form reads, without a Drake plant
    reaction_torque = "thesis"

    def __init__(self, p):
        self.params, self.tilt = p, p.alpha


def input_scale(params: QuadrotorParams | None = None) -> float:
    """Ω²_hover of the vehicle: the unit of the normalized input Ω²/Ω²_hover.

    Parameters
    ----------
    params : QuadrotorParams, optional
        ``chapter6_nominal()`` by default.

    Returns
    -------
    float
    """
    return (params or _params()).hover_input()


def hinf_input_weight(rho: float, params: QuadrotorParams | None = None) -> np.ndarray:
    """R on Ω² of an H∞ design weighting the normalized input Ω²/Ω²_hover by ρ: ρ / Ω²_hover².

    Parameters
    ----------
    rho : float
        Weight on the normalized input (> 0).
    params : QuadrotorParams, optional
        ``chapter6_nominal()`` by default.

    Returns
    -------
    ndarray, shape (4, 4)
    """
    if rho is None or not rho > 0:
        raise ValueError(f"the H∞ design needs a positive input weight rho, got {rho!r}")
    return float(rho) / input_scale(params) ** 2 * np.eye(4)


def vertices(names: Sequence[str] = UNCERTAIN, spread: float = SPREAD,
             params: QuadrotorParams | None = None
             ) -> list[tuple[dict[str, float], tuple[np.ndarray, np.ndarray, np.ndarray]]]:
    """Closed-form linearizations at the 2^k corners of the parameter box (Corollary 1).

    Parameters
    ----------
    names : sequence of str
        The uncertain parameters among :data:`UNCERTAIN` (the others stay nominal).
    spread : float
        Relative half-width of each interval.
    params : QuadrotorParams, optional
        The nominal vehicle; ``chapter6_nominal()`` by default.

    Returns
    -------
    list of (dict, (A, B, D))
        Parameter values of each corner and its linearization (B in Ω² units).
    """
    p = params or _params()
    nominal = {k: getattr(p, k) for k in UNCERTAIN}

    def fn(**kw):
        return closed_form_linearization(**kw, params=p)
    return interval_vertices(fn, nominal, {k: spread for k in names})
