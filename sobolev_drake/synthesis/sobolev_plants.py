"""The generalized plants of the W∞ and classic H∞ channels (:mod:`~sobolev_drake.synthesis.sobolev`
synthesizes on them and re-exports :func:`winf_plant`, :func:`hinf_plant`).

For xdot = A x + B u + D w (6.1) the W^{1,2,Gamma} cost ||x||^2_Gamma0 + ||xdot||^2_Gamma1 is the
L2 norm of z = [Gamma0^1/2 x ; Gamma1^1/2 xdot] (:func:`winf_plant`); classic H∞ is
z = [Q^1/2 x ; R^1/2 u] (:func:`hinf_plant`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from .certificates import as_matrix, check_weight, sqrtm_psd
from .problem import GeneralizedPlant

__all__ = ["plant_matrices", "winf_plant", "hinf_plant"]


def plant_matrices(A: ArrayLike, B: ArrayLike, D: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(A, B, D) of x' = A x + B u + D w (6.1) as float matrices, checked: A square and not empty, B
    and D with n rows and at least one column.

    Parameters
    ----------
    A, B, D : array_like
        State, control-input and disturbance matrices.

    Returns
    -------
    (A, B, D) : tuple of ndarray
    """
    A = as_matrix("A", A)
    n = A.shape[0]
    as_matrix("A", A, (n, n))
    if n == 0:   # before the weights, whose checks would fail on empty matrices
        raise ValueError(f"A must be a non-empty square matrix (the plant has no state), got "
                         f"shape {A.shape}")
    B, D = as_matrix("B", B, (n, None)), as_matrix("D", D, (n, None))
    for name, M, what in (("B", B, "control input"), ("D", D, "disturbance")):
        if M.shape[1] == 0:
            raise ValueError(f"{name} must have at least one {what} column, got shape {M.shape}")
    return A, B, D


def winf_plant(A: ArrayLike, B: ArrayLike, D: ArrayLike, Gamma0: ArrayLike, Gamma1: ArrayLike,
               C: ArrayLike | None = None) -> GeneralizedPlant:
    """Generalized plant of the W∞ channel z = [Gamma0^1/2 x ; Gamma1^1/2 xdot].

    Parameters
    ----------
    A, B, D : array_like
        x' = A x + B u + D w (6.1).
    Gamma0, Gamma1 : array_like
        Positive semidefinite weights of x and x' (n × n, or a vector for a diagonal).
    C : array_like, optional
        Measurement y = C x (default: the full state).

    Returns
    -------
    GeneralizedPlant

    Examples
    --------
    >>> import sobolev_drake as sd
    >>> A, B, D = [[0, 1], [-1, -0.5]], [[0], [1]], [[1, 0], [0, 1]]
    >>> P = sd.winf_plant(A, B, D, Gamma0=[1, 1], Gamma1=[0.1, 0.1])
    >>> P.nz, P.nw, P.nu, P.ny          # z = [x; 0.1^1/2 x'], y = x
    (4, 2, 1, 2)
    >>> P.D12.ravel().round(4)          # u enters z through x' = ... + B u
    array([0.    , 0.    , 0.    , 0.3162])
    """
    A, B, D = plant_matrices(A, B, D)
    n, nu, nw = A.shape[0], B.shape[1], D.shape[1]
    G0 = sqrtm_psd(check_weight("Gamma0", Gamma0, n, definite=False))
    G1 = sqrtm_psd(check_weight("Gamma1", Gamma1, n, definite=False))
    C1 = np.vstack([G0, G1 @ A])
    D11 = np.vstack([np.zeros((n, nw)), G1 @ D])
    D12 = np.vstack([np.zeros((n, nu)), G1 @ B])
    C2 = np.eye(n) if C is None else as_matrix("C", C, (None, n))
    return GeneralizedPlant.make(A, D, B, C1, D11, D12, C2, None)


def hinf_plant(A: ArrayLike, B: ArrayLike, D: ArrayLike, Q: ArrayLike, R: ArrayLike,
               C: ArrayLike | None = None) -> GeneralizedPlant:
    """Generalized plant of the classic H∞ channel z = [Q^1/2 x ; R^1/2 u].

    Parameters
    ----------
    A, B, D : array_like
        x' = A x + B u + D w.
    Q, R : array_like
        Weights of x (positive semidefinite) and u (positive definite).
    C : array_like, optional
        Measurement y = C x (default: the full state).

    Returns
    -------
    GeneralizedPlant

    Examples
    --------
    >>> import sobolev_drake as sd
    >>> A, B, D = [[0, 1], [-1, -0.5]], [[0], [1]], [[1, 0], [0, 1]]
    >>> P = sd.hinf_plant(A, B, D, Q=[1, 1], R=[1], C=[[1, 0]])
    >>> P.nz, P.nw, P.nu, P.ny          # z = [x; u], y = x1
    (3, 2, 1, 1)
    """
    A, B, D = plant_matrices(A, B, D)
    n, nu = A.shape[0], B.shape[1]
    Qh = sqrtm_psd(check_weight("Q", Q, n, definite=False))
    Rh = sqrtm_psd(check_weight("R", R, nu, definite=True))
    C1 = np.vstack([Qh, np.zeros((nu, n))])
    D12 = np.vstack([np.zeros((n, nu)), Rh])
    C2 = np.eye(n) if C is None else as_matrix("C", C, (None, n))
    return GeneralizedPlant.make(A, D, B, C1, None, D12, C2, None)
