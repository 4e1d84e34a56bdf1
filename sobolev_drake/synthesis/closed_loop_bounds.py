"""Closed loops of a linear plant with a filtered disturbance, and what (6.33) certifies about
their initial-condition response (thesis 6.5.1).

The plant ẋ = A x + B u + D w, whose disturbance w = C_d d is the output of the filter
ḋ = A_d d + B_d v driven by v, is closed by a static state feedback u = K x or by a dynamic
controller on y = x or y = C x.  The closed loop has the state ξ = [x; d; x_K] and the input v.
The certified bound (6.33) ‖z‖² ≤ γ²‖v‖² + V(ξ(0)) has the initial-condition term
V(ξ(0)) = s ξ(0)ᵀ P ξ(0); its scale s is recovered from the bounded-real inequality itself
(:func:`brl_scale`), so the bound holds whatever normalization of P the synthesis stored.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike
import scipy.linalg as sla

from .designs import feedback_kind
from .sobolev import augmented_disturbance_plant, winf_plant

if TYPE_CHECKING:
    from sobolev_drake.synthesis.problem import SynthesisResult

#: the gain K (state feedback) or the controller (AK, BK, CK, DK) of a LoopDesign
LoopData = np.ndarray | tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]

__all__ = ["FilteredDisturbancePlant", "LoopDesign", "closed_loop_matrices", "initial_state",
           "initial_condition_energy", "brl_scale", "lyapunov_bound",
           "consistent_controller_state"]

#: measurements a loop may read: the whole state x or the output y = C x
MEASUREMENTS = ("state", "output")
#: older spellings of (feedback, measured), accepted on construction
LOOP_ALIASES = {"of_x": ("output_feedback", "state"), "of_y": ("output_feedback", "output")}


@dataclass(frozen=True, eq=False)
class FilteredDisturbancePlant:
    """ẋ = A x + B u + D C_d d, ḋ = A_d d + B_d v, y = C x, weighted by Γ0, Γ1 (system (6.41)
    is one).

    Attributes
    ----------
    A, B, D : ndarray
        Plant dynamics, control input and disturbance input.
    AD, BD, CD : ndarray
        Disturbance filter: its dynamics, its input v, its output w.
    C : ndarray
        Measurement of the output-feedback designs.
    gamma0, gamma1 : ndarray
        Diagonal W∞ weights of x and ẋ in z = [Γ0^½ x; Γ1^½ ẋ].
    """

    A: np.ndarray
    B: np.ndarray
    D: np.ndarray
    AD: np.ndarray
    BD: np.ndarray
    CD: np.ndarray
    C: np.ndarray
    gamma0: np.ndarray
    gamma1: np.ndarray


@dataclass(frozen=True)
class LoopDesign:
    """How one design closes the loop, and its label in the tables.

    Attributes
    ----------
    label : str
        Row label in tables, legends and metrics keys.
    feedback : {"state_feedback", "output_feedback"}
        Static state feedback u = K x, or a dynamic controller (AK, BK, CK, DK).  Older
        spellings are mapped on construction: ``"sf"`` (and the others of
        :func:`~sobolev_drake.synthesis.designs.feedback_kind`), and ``"of_x"`` / ``"of_y"``,
        which also set ``measured`` to ``"state"`` / ``"output"``.
    disturbance_model : bool
        Designed on the plant augmented with the disturbance filter (its P lives on [x; d; x_K]).
    measured : {"state", "output"}, optional
        What the controller reads: y = x or y = C x.  Default: ``"state"`` for state
        feedback, ``"output"`` for output feedback; a state feedback reads the state.
    """

    label: str
    feedback: str
    disturbance_model: bool = False
    measured: str | None = None

    def __post_init__(self) -> None:
        feedback, measured = LOOP_ALIASES.get(self.feedback, (self.feedback, self.measured))
        if self.feedback in LOOP_ALIASES and self.measured not in (None, measured):
            raise ValueError(f"feedback {self.feedback!r} measures the {measured}, got "
                             f"measured={self.measured!r}")
        feedback = feedback_kind(feedback)
        if measured is None:
            measured = "state" if feedback == "state_feedback" else "output"
        if measured not in MEASUREMENTS or (feedback == "state_feedback" and measured != "state"):
            raise ValueError(f"measured must be one of {MEASUREMENTS} ('state' for a state "
                             f"feedback), got {measured!r} for {feedback!r}")
        object.__setattr__(self, "feedback", feedback)
        object.__setattr__(self, "measured", measured)


def _vector(name, v, n):
    v = np.asarray(v, dtype=float).ravel()
    if v.shape != (n,):
        raise ValueError(f"{name} must have {n} entries, got shape {np.shape(v)}")
    return v


def closed_loop_matrices(plant: FilteredDisturbancePlant, design: LoopDesign, data: LoopData
                         ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Closed loop with state [x; d; x_K], input v, outputs x, u, w.

    Parameters
    ----------
    plant : FilteredDisturbancePlant
    design : LoopDesign
    data : ndarray or tuple
        The gain K (``design.feedback == "state_feedback"``) or the controller (AK, BK, CK, DK).

    Returns
    -------
    (Acl, Bcl, Cx, Cu, Cw) : tuple of ndarray
    """
    n, nd = plant.A.shape[0], plant.AD.shape[0]
    if design.feedback == "state_feedback":
        AK, BK, CK, DK = (np.zeros((0, 0)), np.zeros((0, n)), np.zeros((plant.B.shape[1], 0)),
                          np.asarray(data))
        Cy = np.eye(n)
    else:
        AK, BK, CK, DK = data
        Cy = np.eye(n) if design.measured == "state" else plant.C
    nk = AK.shape[0]
    # u = CK xK + DK Cy x
    Ux = DK @ Cy
    Acl = np.block([[plant.A + plant.B @ Ux, plant.D @ plant.CD, plant.B @ CK],
                    [np.zeros((nd, n)), plant.AD, np.zeros((nd, nk))],
                    [BK @ Cy, np.zeros((nk, nd)), AK]])
    Bcl = np.vstack([np.zeros((n, 1)), plant.BD, np.zeros((nk, 1))])
    Cx = np.hstack([np.eye(n), np.zeros((n, nd + nk))])
    Cu = np.hstack([Ux, np.zeros((1, nd)), CK])
    Cw = np.hstack([np.zeros((1, n)), plant.CD, np.zeros((1, nk))])
    return Acl, Bcl, Cx, Cu, Cw


def initial_state(plant: FilteredDisturbancePlant, design: LoopDesign, data: LoopData,
                  x0: ArrayLike, xk0: ArrayLike | None = None) -> np.ndarray:
    """Closed-loop state [x; d; x_K] at t = 0 (d(0) = 0).

    Parameters
    ----------
    plant : FilteredDisturbancePlant
    design : LoopDesign
    data : ndarray or tuple
        The gain K or the controller (AK, BK, CK, DK).
    x0 : array_like
        Plant initial state.
    xk0 : array_like, optional
        Controller initial state (default 0).

    Returns
    -------
    ndarray
    """
    n, nd = plant.A.shape[0], plant.AD.shape[0]
    nk = 0 if design.feedback == "state_feedback" else np.asarray(tuple(data)[0]).shape[0]
    xi = np.zeros(n + nd + nk)
    xi[:n] = _vector("x0", x0, n)
    if xk0 is not None:
        xi[n + nd:] = _vector("xk0", xk0, nk)
    return xi


def initial_condition_energy(plant: FilteredDisturbancePlant, design: LoopDesign, data: LoopData,
                             x0: ArrayLike, xk0: ArrayLike | None = None) -> float:
    """‖z‖² = ∫ |Γ0^½ x|² + |Γ1^½ ẋ|² dt of the response to ξ(0) (v = 0), exactly, from the
    observability Gramian of the closed loop.

    Parameters
    ----------
    plant : FilteredDisturbancePlant
    design : LoopDesign
    data : ndarray or tuple
        The gain K or the controller (AK, BK, CK, DK).
    x0 : array_like
        Plant initial state.
    xk0 : array_like, optional
        Controller initial state (default 0).

    Returns
    -------
    float
    """
    Acl, _, Cx, _, _ = closed_loop_matrices(plant, design, data)
    Cz = np.vstack([np.sqrt(np.diag(plant.gamma0))[:, None] * Cx,
                    np.sqrt(np.diag(plant.gamma1))[:, None] * (Cx @ Acl)])
    Wo = sla.solve_continuous_lyapunov(Acl.T, -Cz.T @ Cz)
    xi = initial_state(plant, design, data, x0, xk0)
    return float(xi @ Wo @ xi)


def _performance_plant(plant, design, res, nk):
    """The generalized plant a result was designed on (P's size tells a disturbance-model design)."""
    Cm = plant.C if design.measured == "output" else None
    n, nd = plant.A.shape[0], plant.AD.shape[0]
    if np.asarray(res.P).shape[0] == n + nd + nk:
        return augmented_disturbance_plant(plant.A, plant.B, plant.D, plant.AD, plant.BD, plant.CD,
                                           plant.gamma0, plant.gamma1, C=Cm)
    return winf_plant(plant.A, plant.B, Cm, plant.D, Gamma0=plant.gamma0, Gamma1=plant.gamma1)


def brl_scale(Acl: np.ndarray, Bcl: np.ndarray, Ccl: np.ndarray, Dcl: np.ndarray, P: np.ndarray,
              gamma: float, tol: float = 1e-7) -> float:
    """Smallest s > 0 such that s P satisfies the γ²-form bounded-real inequality
    [[He(sP Acl) + CclᵀCcl, sP Bcl + CclᵀDcl], [., DclᵀDcl − γ² I]] ≤ 0 (relative ``tol``).

    Then V = s ξᵀPξ gives ‖z‖² ≤ γ²‖in‖² + V(ξ(0)) ((6.33)).  Synthesis results may store P in
    the γ² form (s = 1) or the symmetric γ form (s = γ); this finds the scale from the
    inequality itself.  The matrix is affine in s, so its largest eigenvalue is convex in s:
    golden-section search for the minimum, then bisection for the lower end of the feasible
    interval.

    Parameters
    ----------
    Acl, Bcl, Ccl, Dcl : ndarray
        The closed loop from its input to z.
    P : ndarray
        Lyapunov matrix of the synthesis result (any positive scaling).
    gamma : float
        The gain bound.
    tol : float
        Tolerance on the largest eigenvalue, relative to the largest entry.

    Returns
    -------
    float

    Raises
    ------
    ValueError
        When no s satisfies the inequality.
    """
    P = 0.5 * (P + P.T)
    nw = Bcl.shape[1]
    M0 = np.block([[Ccl.T @ Ccl, Ccl.T @ Dcl], [Dcl.T @ Ccl, Dcl.T @ Dcl - gamma ** 2 * np.eye(nw)]])
    M1 = np.block([[Acl.T @ P + P @ Acl, P @ Bcl], [Bcl.T @ P, np.zeros((nw, nw))]])

    def raw(logs):  # convex in s, hence unimodal (quasi-convex) in log s
        return np.linalg.eigvalsh(M0 + np.exp(logs) * M1).max()

    def lam(logs):  # relative, for the tolerance test
        Ms = M0 + np.exp(logs) * M1
        return np.linalg.eigvalsh(Ms).max() / max(np.abs(Ms).max(), 1e-300)

    lo, hi = np.log(1e-12), np.log(1e12)
    g = (np.sqrt(5) - 1) / 2
    for _ in range(200):  # golden section for the minimum of raw
        a, b = hi - g * (hi - lo), lo + g * (hi - lo)
        if raw(a) <= raw(b):
            hi = b
        else:
            lo = a
    best = 0.5 * (lo + hi)
    if lam(best) > tol:
        raise ValueError(f"no scaling of P satisfies the bounded-real inequality at gamma = {gamma:.6g} "
                         f"(best relative eigenvalue {lam(best):.3g})")
    lo = np.log(1e-12)
    if lam(lo) <= tol:
        return float(np.exp(lo))
    hi = best
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if lam(mid) <= tol else (mid, hi)
    return float(np.exp(hi))


def lyapunov_bound(plant: FilteredDisturbancePlant, design: LoopDesign, data: LoopData,
                   res: SynthesisResult, x0: ArrayLike, xk0: ArrayLike | None = None) -> float:
    """V(ξ(0)) = s ξ0ᵀ P ξ0, the initial-condition term of (6.33): ‖z‖² ≤ γ²‖v‖² + V, with s
    from :func:`brl_scale` (so V is a certified bound whatever P's normalization).

    For the disturbance-model designs P lives on [x; d; x_K]; for the others on [x; x_K]
    (d is outside their design model; it starts at 0 anyway).

    Parameters
    ----------
    plant : FilteredDisturbancePlant
    design : LoopDesign
    data : ndarray or tuple
        The gain K or the controller (AK, BK, CK, DK).
    res : SynthesisResult
        The design's result (P, γ, ``closed_loop``).
    x0 : array_like
        Plant initial state.
    xk0 : array_like, optional
        Controller initial state (default 0).

    Returns
    -------
    float
    """
    n, nd = plant.A.shape[0], plant.AD.shape[0]
    xi = initial_state(plant, design, data, x0, xk0)
    P = np.asarray(res.P)
    nk = xi.size - n - nd
    cl = res.closed_loop(_performance_plant(plant, design, res, nk))
    if P.shape[0] != xi.size:  # no disturbance states in the design: drop d
        xi = np.concatenate([xi[:n], xi[n + nd:]])
    return brl_scale(*cl, P, res.gamma) * float(xi @ P @ xi)


def consistent_controller_state(plant: FilteredDisturbancePlant, res: SynthesisResult,
                                x0: ArrayLike) -> np.ndarray:
    """x_K(0) minimizing V([x0; 0; x_K]) for a disturbance-model design (P on [x; d; x_K]).

    This is the controller state that makes the certified bound (6.33) on the initial-condition
    response smallest; for y = x it is a linear function of the measured x(0).

    Parameters
    ----------
    plant : FilteredDisturbancePlant
    res : SynthesisResult
        A dynamic-controller result with its closed-loop Lyapunov matrix P.
    x0 : array_like
        Plant initial state.

    Returns
    -------
    ndarray
    """
    if res.kind != "output_feedback" or res.controller is None or res.P is None:
        raise ValueError("res must be a dynamic-controller result with its closed-loop Lyapunov matrix P")
    n, nd = plant.A.shape[0], plant.AD.shape[0]
    P = np.asarray(res.P)
    nk = res.controller.AK.shape[0]
    m = P.shape[0] - nk
    if m != n + nd:
        raise ValueError(f"res.P must be the Lyapunov matrix on [x; d; x_K] (size {n + nd + nk}), "
                         f"got {P.shape}")
    xd = np.concatenate([_vector("x0", x0, n), np.zeros(nd)])
    return -np.linalg.solve(P[m:, m:], P[m:, :m] @ xd)
