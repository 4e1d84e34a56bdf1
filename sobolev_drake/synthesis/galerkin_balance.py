"""The SGAA designs of the two-wheeled vehicle (thesis 4.4, Table 4.2): W2, W∞ and H∞ laws by
successive Galerkin approximation on the design model (4.30).

The thesis' settings: complete polynomial basis of degree 4 (4.31) in x = [θ ϕ̇ θ̇], domain
Ω = [−π/4, π/4] × [−3, 3] × [−1.2, 1.2], z = h(x) = x, σ0 = I, σ1 = diag(0.64, 0.1, 0.1), γ = 5,
initial stabilizing control (4.34); the H∞ baseline (Beard & McLain form) has the cost
‖x‖² + ρu² − γ²‖w‖².  The design model is passed in as its vectorized (f, g, k)
(:func:`sobolev_drake.models.two_wheeled_design.design_model`).  :func:`riccati_gain` is the
independent check: the gain of the linearized problem, which the linear part of any solution
of the HJB/HJBI must equal.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

import numpy as np
from numpy.typing import ArrayLike
import scipy.linalg as sla

from .galerkin import (GalerkinProblem, GalerkinResult, HinfCost, InputAffineModel, W2Cost, WinfCost,
                       closed_loop_jacobian)
from .galerkin_basis import Box, PolynomialBasis

__all__ = ["K_THESIS", "BOX_LO", "BOX_HI", "SIGMA0", "SIGMA1", "GAMMA", "SgaaDesign", "W2",
           "WINF", "HINF", "u0", "sgaa_problem", "sgaa_design", "riccati_gain",
           "design_model_response"]

K_THESIS = np.array([11.3132, 1.0022, 3.2589])  # (4.34), u0 = +K x
BOX_LO = np.array([-np.pi / 4, -3.0, -1.2])
BOX_HI = -BOX_LO
SIGMA0 = np.eye(3)
SIGMA1 = np.diag([0.64, 0.1, 0.1])
GAMMA = 5.0
COSTS = ("w2", "winf", "hinf")


@dataclass(frozen=True)
class SgaaDesign:
    """One law of Table 4.2: its cost and its label in the tables.

    Attributes
    ----------
    label : str
        Column label in tables, legends and metrics keys.
    cost : {"w2", "winf", "hinf"}
        W2 (no disturbance, HJB), W∞ (Sobolev weights σ0, σ1, HJBI) or H∞ (Q = I, R = ρ, HJBI).
    """

    label: str
    cost: str

    def __post_init__(self) -> None:
        if self.cost not in COSTS:
            raise ValueError(f"cost must be one of {COSTS}, got {self.cost!r}")

    @property
    def disturbance(self) -> bool:
        """Whether the design has a disturbance player (a game: W∞, H∞)."""
        return self.cost != "w2"


W2 = SgaaDesign("W2", "w2")
WINF = SgaaDesign("W∞", "winf")
HINF = SgaaDesign("H∞", "hinf")


def u0(X: np.ndarray) -> np.ndarray:
    """Initial stabilizing control (4.34), u0 = +K x.

    Parameters
    ----------
    X : ndarray
        States [θ ϕ̇ θ̇] (Q, 3).

    Returns
    -------
    ndarray
        (Q, 1).
    """
    return (X @ K_THESIS)[:, None]


def sgaa_problem(design: SgaaDesign, model: tuple[Callable, Callable, Callable], nodes: int,
                 rho: float | None = None) -> GalerkinProblem:
    """The Galerkin problem of one design with nodes³ Gauss–Legendre nodes on Ω (``nodes`` per axis).

    Parameters
    ----------
    design : SgaaDesign
    model : tuple of callables
        The design model's vectorized (f, g, k).
    nodes : int
        Gauss–Legendre nodes per axis.
    rho : float, optional
        H∞ input weight R = ρ (needed by the H∞ design).

    Returns
    -------
    GalerkinProblem
    """
    f, g, k = model
    h = lambda X: X
    dh = lambda X: np.broadcast_to(np.eye(3), (X.shape[0], 3, 3))
    if design.cost == "w2":
        plant, cost = InputAffineModel(f, g, None, n=3), W2Cost(h, dh, SIGMA0, SIGMA1)
    elif design.cost == "winf":
        plant, cost = InputAffineModel(f, g, k, n=3), WinfCost(h, dh, SIGMA0, SIGMA1, GAMMA)
    else:
        plant, cost = InputAffineModel(f, g, k, n=3), HinfCost(h, np.eye(3), [[rho]], GAMMA)
    return GalerkinProblem(plant, cost, PolynomialBasis(3, 4, names=["θ", "ϕ̇", "θ̇"]),
                           Box(BOX_LO, BOX_HI), quadrature=nodes)


def sgaa_design(design: SgaaDesign, model: tuple[Callable, Callable, Callable], nodes: int = 20,
                rho: float | None = None, **kw: Any) -> GalerkinResult:
    """SGAA design (Algorithms 4.1, 4.2) from the initial control :func:`u0`.

    Parameters
    ----------
    design : SgaaDesign
    model : tuple of callables
        The design model's vectorized (f, g, k).
    nodes : int
        Gauss–Legendre nodes per axis.
    rho : float, optional
        H∞ input weight (needed by the H∞ design).
    **kw
        Passed to ``GalerkinProblem.solve`` (``tol`` defaults to 1e-8).

    Returns
    -------
    GalerkinResult
    """
    kw.setdefault("tol", 1e-8)
    return sgaa_problem(design, model, nodes, rho).solve(u0, **kw)


def riccati_gain(design: SgaaDesign, model: tuple[Callable, Callable, Callable],
                 rho: float | None = None) -> np.ndarray:
    """Gain of the *linearized* problem (game/LQR Riccati equation) — the linear part that any
    solution of the stated HJB/HJBI must have.

    W2/W∞: the cost ½(xᵀσ₀x + ẋᵀσ₁ẋ − γ²wᵀw) is an LQR cost with cross term N = Aᵀσ₁G and
    R = Gᵀσ₁G − diag(0, γ²I); H∞: Q = I, R = diag(ρ, −γ²I).

    Parameters
    ----------
    design : SgaaDesign
    model : tuple of callables
        The design model's vectorized (f, g, k).
    rho : float, optional
        H∞ input weight (needed by the H∞ design).

    Returns
    -------
    ndarray
        The control gain (3,), u = K x.
    """
    f, g, k = model
    A = closed_loop_jacobian(f, 3)
    B, K = g(np.zeros((1, 3)))[0], k(np.zeros((1, 3)))[0]
    G = np.hstack([B, K]) if design.disturbance else B
    if design.cost == "hinf":
        S, N, Q = np.diag([rho, -GAMMA ** 2, -GAMMA ** 2]), np.zeros((3, 3)), np.eye(3)
    else:
        S, N, Q = G.T @ SIGMA1 @ G, A.T @ SIGMA1 @ G, SIGMA0 + A.T @ SIGMA1 @ A
        S[1:, 1:] -= GAMMA ** 2 * np.eye(G.shape[1] - 1)
    P = sla.solve_continuous_are(A, G, Q, S, s=N)
    return -np.linalg.solve(S, G.T @ P + N.T)[0]


def design_model_response(law: GalerkinResult, model: tuple[Callable, Callable, Callable],
                          x0: ArrayLike, T: float = 4.0, dt: float = 0.01
                          ) -> tuple[np.ndarray, np.ndarray]:
    """θ(t) of the design model from ``x0`` (w = 0) under ``law.control`` (RK4).

    Parameters
    ----------
    law : GalerkinResult
        Anything with a vectorized ``control(X)``.
    model : tuple of callables
        The design model's vectorized (f, g, k).
    x0 : array_like
        Initial state [θ ϕ̇ θ̇].
    T : float
        Horizon (s).
    dt : float
        RK4 step (s).

    Returns
    -------
    (t, theta) : tuple of ndarray
    """
    f, g, _ = model
    fun = lambda X: f(X) + g(X)[:, :, 0] * law.control(X)
    X = np.asarray(x0, dtype=float)[None, :].copy()
    t = np.arange(0.0, T + dt / 2, dt)
    th = np.empty(t.size)
    for i in range(t.size):
        th[i] = X[0, 0]
        k1 = fun(X); k2 = fun(X + 0.5 * dt * k1); k3 = fun(X + 0.5 * dt * k2); k4 = fun(X + dt * k3)
        X = X + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return t, th
