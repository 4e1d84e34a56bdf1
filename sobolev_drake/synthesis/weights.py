"""W∞ weights from a desired bandwidth and damping per degree of freedom.

For a mechanical state x = (q, q̇) (n degrees of freedom, thesis order) the W∞ channel
z = [Γ0^½ x; Γ1^½ ẋ] (6.1), with Γ1 weighting only the accelerations q̈, costs

    ∫ r ω⁴ q² + r·2ω²(2ζ² − 1) q̇² + r q̈² dt        (per degree of freedom)

with Γ0 = diag(r ω⁴, r·2ω²(2ζ² − 1)) and Γ1 = diag(0, r).  When the inputs act on every degree
of freedom (the lower block B_v of B is square and invertible), q̈ = A_q q + A_v q̇ + B_v u + D_v w
can be any signal, so the design is the linear-quadratic regulator of the double integrators
q̈ = a with weights (ω⁴, 2ω²(2ζ² − 1)) on (q, q̇) and 1 on a.  Its Riccati equation has the
closed-form solution a = −ω² q − 2ζω q̇: every degree of freedom closes with the
characteristic polynomial s² + 2ζω s + ω², natural frequency ω and damping ζ (the
integrator-chain algebra of ``synthesis.mechanical``, order 2).  r scales the whole cost and
only changes γ.

Limits, and what the tests measure (tests/synthesis/test_loop_analysis.py):

* ζ ≥ 1/√2: the q̇ weight must be non-negative.  This is Kalman's return-difference
  inequality |1 + L(jω)| ≥ 1 of every LQR loop, which a double integrator closed with
  ζ < 1/√2 violates: no positive semidefinite weights give a lighter damping.
* A disturbance matched to the inputs (D in the range of B, e.g. D = B or D = [0; M⁻¹]): the
  worst case is absorbed by the same acceleration and the poles are exactly (ω, ζ) at every
  γ above the optimum (measured to 1e-9 on the arm).  An unmatched disturbance (D = I) moves
  them with the level: at the optimum the W∞ design puts poles near 1e5 rad/s (the issue's
  quadrotor case), at 2 × γ_opt within 15 %, at 10 × γ_opt within 1 % of (ω, ζ).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from ..validation import positive_scalar, real_vector

__all__ = ["winf_weights"]


def _per_dof(name, value, n):
    v = real_vector(name, np.atleast_1d(np.asarray(value, dtype=float)))
    if v.size == 1 and n is not None:
        v = np.full(n, v[0])
    if n is not None and v.size != n:
        raise ValueError(f"{name} must be a scalar or have one entry per degree of freedom "
                         f"({n}), got {v.size} entries")
    return v


def winf_weights(bandwidth: float | ArrayLike, damping: float | ArrayLike, *, dof: int | None = None,
                 effort: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Γ0, Γ1 for a W∞ design whose degrees of freedom close at (bandwidth, damping).

    Parameters
    ----------
    bandwidth : float or array_like
        Desired natural frequency ω (rad/s) of each degree of freedom (> 0).
    damping : float or array_like
        Desired damping ratio ζ of each degree of freedom, at least 1/√2 (module docstring).
    dof : int, optional
        Number of degrees of freedom n when both ``bandwidth`` and ``damping`` are scalars.
    effort : float
        Overall scale r of the cost (> 0); it changes γ, not the poles.

    Returns
    -------
    Gamma0, Gamma1 : ndarray, shape (2n,)
        Diagonals of the weights of x = (q, q̇) and ẋ = (q̇, q̈), for
        :func:`~sobolev_drake.synthesis.sobolev.winf_state_feedback` (which accepts vectors
        as diagonal weights).

    Raises
    ------
    ValueError
        When a bandwidth is not positive, a damping is below 1/√2, or the sizes disagree.

    Examples
    --------
    A fully actuated two-joint arm linearized with gravity, both joints asked for 5 rad/s at
    damping 0.8, disturbance forces entering with the inputs:

    >>> import numpy as np
    >>> import sobolev_drake as sd
    >>> A = np.array([[0, 0, 1, 0], [0, 0, 0, 1], [1.5, -0.6, 0, 0], [0.8, 3.6, 0, 0.0]])
    >>> B = np.array([[0, 0], [0, 0], [0.5, -0.6], [-0.6, 1.7]])
    >>> Gamma0, Gamma1 = sd.winf_weights(5.0, 0.8, dof=2)
    >>> Gamma0, Gamma1
    (array([625., 625.,  14.,  14.]), array([0., 0., 1., 1.]))
    >>> res = sd.winf_state_feedback(A, B, B, Gamma0=Gamma0, Gamma1=Gamma1, gamma=10.0)
    >>> lam = np.linalg.eigvals(A + B @ res.K)
    >>> np.round(np.abs(lam), 6), np.round(-lam.real / np.abs(lam), 6)
    (array([5., 5., 5., 5.]), array([0.8, 0.8, 0.8, 0.8]))
    """
    effort = positive_scalar("effort", effort)
    if dof is not None:
        if isinstance(dof, (bool, np.bool_)) or not isinstance(dof, (int, np.integer)) or dof < 1:
            raise ValueError(f"dof must be a positive integer (the number of degrees of freedom), "
                             f"got {dof!r}")
    n = dof
    if n is None:
        sizes = {np.size(bandwidth), np.size(damping)} - {1}
        if not sizes:
            raise TypeError("dof (the number of degrees of freedom) is required when bandwidth "
                            "and damping are both scalars")
        n = sizes.pop()
    omega = _per_dof("bandwidth", bandwidth, n)
    zeta = _per_dof("damping", damping, n)
    if np.any(omega <= 0):
        raise ValueError(f"bandwidth must be positive (rad/s), got {omega}")
    if np.any(zeta < np.sqrt(0.5) - 1e-12):
        raise ValueError(f"damping must be at least 1/sqrt(2) = 0.7071 (LQR return-difference "
                         f"inequality; see sobolev_drake.synthesis.weights), got {zeta}")
    g0 = np.r_[effort * omega ** 4, effort * np.maximum(2 * omega ** 2 * (2 * zeta ** 2 - 1), 0.0)]
    g1 = np.r_[np.zeros(n), np.full(n, effort)]
    return g0, g1
