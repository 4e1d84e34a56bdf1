"""Problem and result types of the linear H∞/W∞ syntheses.

:class:`GeneralizedPlant` (the plant with its performance and measurement channels),
:class:`DynamicController`, :class:`SynthesisResult` (controller, γ, certificate, diagnostics)
and :class:`SynthesisWarning`; the pipeline that produces them is in ``hinf_common.py``.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from sobolev_drake.errors import SobolevDrakeWarning

from .certificates import Certificate, as_matrix
from .controller import DynamicController
from .regions import LMIRegion

__all__ = ["SynthesisWarning", "GeneralizedPlant", "DynamicController", "DiscreteDesign",
           "SynthesisResult",
           "check_initial_states", "transient_bound"]


class SynthesisWarning(SobolevDrakeWarning):
    """The result is valid but degenerate (feedthrough infimum, regularized, large gains)."""


@dataclass
class GeneralizedPlant:
    """Generalized plant of the H∞/W∞ syntheses (python-control's partition, D22 = 0)::

        x' = A x + B1 w + B2 u,   z = C1 x + D11 w + D12 u,   y = C2 x + D21 w.

    The constructor stores the arrays as given; :meth:`make` validates shapes and values and
    fills defaults (use it).

    Parameters
    ----------
    A : ndarray, shape (n, n)
        State matrix.
    B1, B2 : ndarray, shape (n, nw) and (n, nu)
        Disturbance and control input matrices.
    C1 : ndarray, shape (nz, n)
        Performance output matrix.
    D11, D12 : ndarray, shape (nz, nw) and (nz, nu)
        Feedthroughs of w and u to z.
    C2 : ndarray, shape (ny, n)
        Measurement matrix (the identity for state feedback).
    D21 : ndarray, shape (ny, nw)
        Feedthrough of w to y.

    Attributes
    ----------
    n, nw, nu, nz, ny : int
        Numbers of states, disturbances, controls, performance outputs and measurements.

    Examples
    --------
    A mass-spring-damper pushed by a force w and the input u, z = [x1; u], the full state
    measured (C2 = I by default):

    >>> import sobolev_drake as sd
    >>> P = sd.GeneralizedPlant.make([[0, 1], [-1, -0.5]], B1=[[0], [1]], B2=[[0], [1]],
    ...                              C1=[[1, 0], [0, 0]], D12=[[0], [1]])
    >>> P.n, P.nw, P.nu, P.nz, P.ny
    (2, 1, 1, 2, 2)
    >>> A_cl, B_cl, C_cl, D_cl = P.closed_loop(K=[[-1.0, -1.0]])     # u = +K x
    >>> A_cl
    array([[ 0. ,  1. ],
           [-2. , -1.5]])
    >>> res = sd.hinf_state_feedback(P)
    >>> round(res.gamma, 3), res.certificate.ok
    (0.9, True)
    """

    A: np.ndarray
    B1: np.ndarray
    B2: np.ndarray
    C1: np.ndarray
    D11: np.ndarray
    D12: np.ndarray
    C2: np.ndarray
    D21: np.ndarray

    @classmethod
    def make(cls, A: ArrayLike, B1: ArrayLike, B2: ArrayLike, C1: ArrayLike,
             D11: ArrayLike | None = None, D12: ArrayLike | None = None,
             C2: ArrayLike | None = None, D21: ArrayLike | None = None) -> GeneralizedPlant:
        """Validated plant; D11, D12, D21 default to zero, C2 to the identity (full state).

        Parameters
        ----------
        A, B1, B2, C1 : array_like
            See the class; A non-empty square, at least one w, u and z channel.
        D11, D12 : array_like, optional
            Zero by default.
        C2 : array_like, optional
            Identity by default (state feedback).
        D21 : array_like, optional
            Zero by default.

        Returns
        -------
        GeneralizedPlant
        """
        A = as_matrix("A", A)
        n = A.shape[0]
        as_matrix("A", A, (n, n))
        if n == 0:
            raise ValueError("A must be a non-empty square matrix (the plant has no state), got shape (0, 0)")
        B1 = as_matrix("B1", B1, (n, None))
        B2 = as_matrix("B2", B2, (n, None))
        C1 = as_matrix("C1", C1, (None, n))
        nw, nu, nz = B1.shape[1], B2.shape[1], C1.shape[0]
        for name, size, what in (("B1", nw, "disturbance"), ("B2", nu, "control input"),
                                 ("C1", nz, "performance output")):
            if size == 0:
                raise ValueError(f"{name} must have at least one {what} channel, got none")
        D11 = np.zeros((nz, nw)) if D11 is None else as_matrix("D11", D11, (nz, nw))
        D12 = np.zeros((nz, nu)) if D12 is None else as_matrix("D12", D12, (nz, nu))
        C2 = np.eye(n) if C2 is None else as_matrix("C2", C2, (None, n))
        D21 = np.zeros((C2.shape[0], nw)) if D21 is None else as_matrix("D21", D21, (C2.shape[0], nw))
        return cls(A, B1, B2, C1, D11, D12, C2, D21)

    n = property(lambda s: s.A.shape[0])
    nw = property(lambda s: s.B1.shape[1])
    nu = property(lambda s: s.B2.shape[1])
    nz = property(lambda s: s.C1.shape[0])
    ny = property(lambda s: s.C2.shape[0])

    def closed_loop(self, K: ArrayLike | None = None,
                    controller: DynamicController | tuple[ArrayLike, ...] | None = None
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(A_cl, B_cl, C_cl, D_cl) of w -> z with u = K x or the dynamic controller.

        Parameters
        ----------
        K : array_like, shape (nu, n), optional
            State-feedback gain, u = +K x (takes precedence over ``controller``).
        controller : DynamicController or tuple, optional
            (AK, BK, CK, DK) with x_K' = AK x_K + BK y, u = CK x_K + DK y; the closed-loop
            state is [x; x_K].

        Returns
        -------
        tuple of ndarray
            (A_cl, B_cl, C_cl, D_cl).
        """
        if K is not None:
            K = as_matrix("K", K, (self.nu, self.n))
            return (self.A + self.B2 @ K, self.B1, self.C1 + self.D12 @ K, self.D11)
        AK, BK, CK, DK = controller
        A = np.block([[self.A + self.B2 @ DK @ self.C2, self.B2 @ CK], [BK @ self.C2, AK]])
        B = np.vstack([self.B1 + self.B2 @ DK @ self.D21, BK @ self.D21])
        C = np.hstack([self.C1 + self.D12 @ DK @ self.C2, self.D12 @ CK])
        D = self.D11 + self.D12 @ DK @ self.D21
        return A, B, C, D

    def convex_combination(self, other: GeneralizedPlant, t: float) -> GeneralizedPlant:
        """The plant (1 − t) self + t other, matrix by matrix (polytopic vertices).

        Parameters
        ----------
        other : GeneralizedPlant
            Plant of the same sizes.
        t : float
            Weight of ``other``.

        Returns
        -------
        GeneralizedPlant
        """
        return GeneralizedPlant(*[(1 - t) * a + t * b for a, b in zip(self.as_tuple(), other.as_tuple())])

    def as_tuple(self) -> tuple[np.ndarray, ...]:
        """The eight matrices in constructor order.

        Returns
        -------
        tuple of ndarray
            (A, B1, B2, C1, D11, D12, C2, D21).
        """
        return (self.A, self.B1, self.B2, self.C1, self.D11, self.D12, self.C2, self.D21)


@dataclass(frozen=True)
class DiscreteDesign:
    """What a discrete-time synthesis checked in z (``SynthesisResult.discrete``).

    :func:`~sobolev_drake.synthesis.discrete.hinf_discrete` designs on the bilinear image of
    the discrete plant and certifies the discrete closed loop independently; this record keeps
    that check and the continuous design it came from.

    Attributes
    ----------
    closed_loop : tuple of ndarray
        (A, B, C, D) of the discrete closed loop w_k -> z_k.
    norm_ab13dd, norm_sweep : float
        Independent estimates of its H∞ norm (SLICOT ab13dd with dico='D'; a unit-circle sweep,
        a lower bound).
    spectral_radius : float
        Largest |eigenvalue| of the closed loop (< 1: stable).
    continuous : SynthesisResult
        The certified synthesis of the bilinear-transformed problem (its Lyapunov matrices,
        region and certificate are those of the image in s, not of the loop in z).
    computation_delay : bool
        True when the plant modelled a one-sample computation delay (the controller then runs
        as in :func:`~sobolev_drake.systems.discrete_controller.discrete_controller_system`).
    """

    closed_loop: tuple
    norm_ab13dd: float
    norm_sweep: float
    spectral_radius: float
    continuous: SynthesisResult
    computation_delay: bool = False


@dataclass(frozen=True)
class SynthesisResult:
    """Result of :func:`state_feedback` / :func:`output_feedback` (certified before return).

    Normalization of the Lyapunov matrices (whatever form the LMI was solved in -- the
    symmetric gamma form, see ``hinf.py`` -- and whatever internal scaling): the gamma^2 form
    in the original coordinates.  ``P`` is the closed-loop Lyapunov matrix with

        [[A_cl'P + P A_cl + C_cl'C_cl, P B_cl + C_cl'D_cl], [., D_cl'D_cl - gamma^2 I]] <= 0,

    so V = x_cl'P x_cl gives ||z||^2 <= gamma^2 ||w||^2 + V(x_cl(0)) (thesis (6.33);
    ``certificates.brl_residual`` evaluates the inequality; tested for both kinds).

    * state feedback (x_cl = x): ``X = P^-1`` (the variable of (6.5)/(6.7), K = W X^-1);
      ``Y`` is None;
    * output feedback (x_cl = [x; x_K]): ``Y`` = upper-left n x n block of P and ``X`` = the
      upper-left block of P^-1 (Gahinet-Apkarian variables, [[X, I], [I, Y]] > 0); ``P`` is
      None when the controller order was reduced (I - XY rank deficient).

    ``gamma`` is the certified bound (>= ``gamma_opt``; relaxed when ``regularized``).
    ``gamma_opt`` is the LMI optimum (``method == "lmi"``) or the upper end of the Riccati
    bisection bracket (``method == "riccati"``; on singular problems the Riccati estimate of
    the infimum, an upper bound of it).  ``backend``/``solver`` name what produced the result,
    ``fallback`` why earlier backends or paths were not used, ``attempts`` what was tried.

    Riccati results: ``P`` is the stabilizing solution of the closed loop's bounded-real
    Riccati equation at the design level, ``gamma`` = level x (1 + 1e-6) -- or at
    sqrt(level gamma) where the closed loop's norm is within rounding of the design level, or
    where that fails too the central controller's closed-form solution at the design level (not
    the stabilizing one: a larger storage) (``hinf_riccati._closed_loop_lyapunov``); None when
    none passes the bounded-real check.

    Frozen: a result is what the synthesis certified; :meth:`replace` (``dataclasses.replace``)
    makes a modified copy, e.g. to test a certificate against a changed ``P``.

    Attributes
    ----------
    kind : str
        ``"state_feedback"`` or ``"output_feedback"``.
    gamma : float
        Certified bound on the performance channel's H∞ norm.
    K : ndarray or None
        State-feedback gain, u = +K x (None for output feedback).
    controller : DynamicController or None
        The controller, one type for both kinds: the output-feedback controller, or for state
        feedback the static controller of ``K`` (AK 0 × 0, DK = K; derived from ``K``, so
        ``replace(K=...)`` keeps them together).  None only for the thesis-literal (6.22)
        result, which has gamma only.  ``controller.to_drake()`` and
        ``controller.to_statespace()`` convert it.
    P : ndarray or None
        Closed-loop Lyapunov matrix (see above).
    X, Y : ndarray or None
        Lyapunov variables (see above).
    gamma_opt : float
        LMI optimum or Riccati bracket end, before any regularization (see above).
    feedthrough_bound : float
        Lower bound of gamma set by the feedthroughs (‖D11‖ for state feedback, the Parrott
        bound for output feedback; 0 where the synthesis path did not compute it).
    solver, backend, status : str
        What produced the result and the solver's status text.
    timings : dict
        Seconds per phase (e.g. ``"total"``).
    certificate : Certificate or None
        The independent check (:mod:`~sobolev_drake.synthesis.certificates`); the worst of
        ``certificates``.
    certificates : list of Certificate
        One per plant (polytopic: one per vertex).
    region : LMIRegion or None
        Pole region the closed loop was designed (and certified) for.
    regularized : bool
        True when gamma was relaxed to obtain a well-conditioned controller.
    warnings : list of str
        Degeneracies of the result (empty when well posed).
    transient_bound : float or None
        Σ_i x0_iᵀ P x0_i for the ``initial_states`` of the synthesis (None without them).
    fallback : str
        Why earlier backends were not used by the automatic chain ("" = none).
    method : str
        ``"riccati"`` or ``"lmi"``: which characterization produced the controller;
        ``"thesis_lmi"`` for the thesis-literal LMI forms (``winf_sf_thesis_lmi``,
        ``winf_of_thesis_lmi``, ``winf_disturbance_thesis``), which are not certified.
    attempts : list of str
        What the call tried before this result, in order: "<what>: <seconds> s, <outcome>".
    dt : float
        0.0 for a continuous-time result; the sample period (s) of a discrete-time one
        (:func:`~sobolev_drake.synthesis.discrete.hinf_discrete`), whose controller runs in z
        and whose ``gamma`` bounds the discrete closed loop's H∞ norm.
    discrete : DiscreteDesign or None
        A discrete-time result's check in z and its continuous design (None when ``dt == 0``).
    well_posed : bool
        True when ``warnings`` is empty.
    certified : bool
        True when ``certificate`` is present and passed (False for the thesis-literal forms
        and for ``verify=False`` calls: then ``gamma`` is the solver's value, not a verified
        bound).

    Examples
    --------
    >>> import sobolev_drake as sd
    >>> res = sd.winf_state_feedback([[0, 1], [-1, -0.5]], [[0], [1]], [[1, 0], [0, 1]],
    ...                              Gamma0=[1, 1], Gamma1=[0.1, 0.1], gamma=2.0)
    >>> res.kind, res.method, res.gamma, res.well_posed
    ('state_feedback', 'riccati', 2.0, True)
    >>> res.certificate.ok, res.K.shape, res.controller.nk, bool((res.controller.DK == res.K).all())
    (True, (1, 2), 0, True)
    """

    kind: str  # "state_feedback" | "output_feedback"
    gamma: float  # certified bound on the performance-channel H∞ norm
    K: np.ndarray | None = None
    controller: DynamicController | None = None
    P: np.ndarray | None = None  # closed-loop Lyapunov matrix
    X: np.ndarray | None = None
    Y: np.ndarray | None = None
    gamma_opt: float = np.nan  # optimum (before any regularization); see the class docstring
    feedthrough_bound: float = 0.0
    solver: str = ""
    backend: str = ""
    status: str = ""
    timings: dict = field(default_factory=dict)
    certificate: Certificate | None = None
    certificates: list = field(default_factory=list)  # polytopic: one per vertex
    region: LMIRegion | None = None
    regularized: bool = False
    warnings: list = field(default_factory=list)
    #: sum_i x0_i' P x0_i for the ``initial_states`` of the synthesis (None without them)
    transient_bound: float | None = None
    fallback: str = ""  # automatic backend chain: why earlier backends were not used ("" = none)
    method: str = "lmi"  # "riccati" | "lmi" | "thesis_lmi" (uncertified thesis-literal forms)
    #: what the call tried before this result, in order: "<what>: <seconds> s, <outcome>"
    attempts: list = field(default_factory=list)
    dt: float = 0.0  # 0: continuous time; > 0: the sample period of a discrete-time result
    discrete: DiscreteDesign | None = None  # a discrete-time result's check in z

    def __post_init__(self):
        if self.K is not None:   # state feedback: the controller is the static one of K
            object.__setattr__(self, "controller", DynamicController.static(self.K, self.dt))
        elif self.controller is not None and self.controller.dt != self.dt:
            raise ValueError(f"controller.dt = {self.controller.dt} but the result's dt = "
                             f"{self.dt}: a controller runs at its result's sample period")
        if (self.discrete is None) != (self.dt == 0):
            raise ValueError("a discrete-time result (dt > 0) carries its DiscreteDesign and a "
                             f"continuous one none; got dt = {self.dt} and discrete = "
                             f"{type(self.discrete).__name__}")

    def replace(self, **changes: Any) -> SynthesisResult:
        """A copy with ``changes`` applied (``dataclasses.replace``; the copy is not
        re-certified).

        Parameters
        ----------
        **changes
            Field values of the copy.

        Returns
        -------
        SynthesisResult
        """
        return replace(self, **changes)

    @property
    def well_posed(self) -> bool:
        """True when the result has no warnings (see ``warnings``)."""
        return not self.warnings

    @property
    def certified(self) -> bool:
        """True when the independent certificate is present and passed.

        Derived from ``certificate`` (not stored), so a result and its design file cannot
        disagree.  False for the thesis-literal LMI forms (``method == "thesis_lmi"``) and for
        ``verify=False`` calls.
        """
        return self.certificate is not None and bool(self.certificate.ok)

    def closed_loop(self, plant: GeneralizedPlant) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(A_cl, B_cl, C_cl, D_cl) of w -> z for ``plant`` closed by this result's controller.

        Parameters
        ----------
        plant : GeneralizedPlant
            The plant (e.g. the one designed for, or a perturbed one).

        Returns
        -------
        tuple of ndarray
            See :meth:`GeneralizedPlant.closed_loop`.
        """
        if self.K is None and self.controller is None:
            raise ValueError(f"this {self.kind} result (method {self.method!r}) has no "
                             "controller to close the loop with (winf_of_thesis_lmi gives gamma "
                             "only; use winf_output_feedback for a controller)")
        if self.kind == "state_feedback":
            return plant.closed_loop(K=self.K)
        return plant.closed_loop(controller=self.controller)


def check_initial_states(x0: ArrayLike | None, n: int) -> np.ndarray | None:
    """``initial_states`` keyword -> float array (n, k), or None."""
    if x0 is None:
        return None
    X0 = np.asarray(x0, dtype=float)
    if X0.ndim == 1:
        X0 = X0[:, None]
    if X0.ndim != 2 or X0.shape[0] != n or X0.shape[1] < 1:
        raise ValueError(f"initial_states must have shape ({n},) or ({n}, k), got {np.shape(x0)}")
    if not np.all(np.isfinite(X0)) or not np.any(X0):
        raise ValueError("initial_states must be finite and not all zero")
    return X0


def transient_bound(res: SynthesisResult, X0: np.ndarray) -> float | None:
    """sum_i x0_i' P x0_i: bound on sum_i ||z||^2 from x(0) = x0_i (controller state 0), w = 0."""
    if res.P is None:
        return None
    n = X0.shape[0]
    return float(np.sum(X0 * (res.P[:n, :n] @ X0)))
