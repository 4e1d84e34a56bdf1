"""The two-wheeled vehicle (4.30) linearized at the upright, as in thesis 6.5.2.

The wheel angle ϕ is cyclic and dropped: the linear state is x = [θ, ϕ̇, θ̇], the input the motor
torque u, the disturbance w = [wϕ, wθ] (generalized forces, D = [0; M⁻¹]).
:func:`linearize` differentiates the Drake model (Drake's ``FirstOrderTaylorApproximation`` of its
MultibodyPlant, :func:`~sobolev_drake.models.linearization.linearize_mechanical`),
:func:`closed_form_linearization` is the hand Jacobian; :data:`STATE_REDUCTION` maps the plant
state to the linear one.
"""

from __future__ import annotations

import numpy as np

from sobolev_drake.models.linearization import linearize_mechanical
from sobolev_drake.models.two_wheeled import (TwoWheeledModel, TwoWheeledParams,
                                               make_two_wheeled_model)

__all__ = ["STATE_REDUCTION", "linearize", "closed_form_linearization"]

#: plant state [ϕ θ ϕ̇ θ̇] → linear-model state [θ ϕ̇ θ̇] (ϕ is cyclic)
STATE_REDUCTION = np.array([[0, 1.0, 0, 0], [0, 0, 1.0, 0], [0, 0, 0, 1.0]])


def linearize(model: TwoWheeledModel | None = None,
              h: float | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(A, B, D) at the upright: Drake's AutoDiff linearization of the model's plant (the
    friction K(q̇) = k ϕ̇ [1, −1] enters as its matrix).

    The full [ϕ θ ϕ̇ θ̇] linearization is reduced to x = [θ, ϕ̇, θ̇].

    Parameters
    ----------
    model : TwoWheeledModel, optional
        ``make_two_wheeled_model()`` (Table 4.1) by default.
    h : float, optional
        Given: central differences with this step instead (the former method, kept as the
        accuracy reference).

    Returns
    -------
    A : ndarray, shape (3, 3)
    B : ndarray, shape (3, 1)
    D : ndarray, shape (3, 2)
    """
    model = model or make_two_wheeled_model()
    A, B, D = linearize_mechanical(model, np.zeros(2), np.zeros(2), [0.0], h=h)
    keep = [1, 2, 3]
    return A[np.ix_(keep, keep)], B[keep], D[keep]


def closed_form_linearization(params: TwoWheeledParams | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Hand Jacobian of (4.30) at x = 0: [ϕ̈; θ̈] = M0⁻¹([0; m g l] θ − [k; −k] ϕ̇ + F u + w).

    Parameters
    ----------
    params : TwoWheeledParams, optional
        Table 4.1 by default.

    Returns
    -------
    A : ndarray, shape (3, 3)
    B : ndarray, shape (3, 1)
    D : ndarray, shape (3, 2)
    """
    p = params or TwoWheeledParams()
    M0 = np.array([[(p.M + p.m) * p.r ** 2 + p.Ir, p.m * p.l * p.r], [p.m * p.l * p.r, p.m * p.l ** 2 + p.Ip]])
    Mi = np.linalg.inv(M0)
    A = np.zeros((3, 3))
    A[0, 2] = 1.0
    A[1:, 0] = Mi @ np.array([0.0, p.m * p.g * p.l])
    A[1:, 1] = Mi @ np.array([-p.k, p.k])
    B = np.vstack([[0.0], Mi @ np.array([[1.0], [-1.0]])])
    D = np.vstack([np.zeros((1, 2)), Mi])
    return A, B, D
