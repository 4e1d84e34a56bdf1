"""W∞ (weighted Sobolev) performance channels on the generalized-plant synthesis.

For xdot = A x + B u + D w (6.1) the W^{1,2,Gamma} cost ||x||^2_Gamma0 + ||xdot||^2_Gamma1 is the
L2 norm of z = [Gamma0^1/2 x ; Gamma1^1/2 xdot], i.e. the generalized plant

    C1 = [Gamma0^1/2 ; Gamma1^1/2 A],  D11 = [0 ; Gamma1^1/2 D],  D12 = [0 ; Gamma1^1/2 B],

whose bounded-real-lemma LMI is (6.7) (state feedback) and (6.22) (output feedback, y = C x)
after a Schur complement. Classic H∞ is z = [Q^1/2 x ; R^1/2 u].

Disturbance model (6.28)/(6.34): ddot = Ad d + Bd v, w = Cd d. The thesis' LMIs (6.31)/(6.36)
keep V = x'Px and replace the -gamma^2 I block by -gamma^2 L' diag(Upsilon0, Upsilon1) L with
L = [[Cd, 0], [Cd Ad, Cd Bd]] acting on (d, v); that block is singular whenever L has a kernel
(always when n_d + n_v > 2 n_w), so the strict LMI is infeasible (docs/design.md §8.3). They are
implemented faithfully here (:func:`winf_disturbance_thesis`) together with a diagnosis
(:func:`disturbance_model_degeneracy`), and a well-posed alternative
(:func:`winf_disturbance_augmented`): filter states in the plant, Lyapunov function on (x, d),
d not measured, synthesized with the output-feedback LMI; its gain is from v to z.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from ..validation import state_input_disturbance
from .certificates import as_matrix, check_weight, sqrtm_psd
from .hinf import GeneralizedPlant, output_feedback, state_feedback
from .interop import is_linear_system, state_space_matrices
from .lmi import InfeasibleLMIError
from .problem import SynthesisResult
from .thesis_lmi import winf_of_thesis_lmi, winf_sf_thesis_lmi

if TYPE_CHECKING:   # a linear system given as A (see state_space_matrices)
    import control
    import scipy.signal
    from numpy.typing import ArrayLike
    from pydrake.systems.primitives import AffineSystem
    MatrixOrSystem = ArrayLike | AffineSystem | control.StateSpace | scipy.signal.StateSpace

__all__ = [
    "winf_plant", "hinf_plant", "winf_state_feedback", "winf_output_feedback",
    "hinf_state_feedback_qr", "hinf_output_feedback_qr", "winf_sf_thesis_lmi",
    "winf_of_thesis_lmi", "DegeneracyReport", "disturbance_model_degeneracy",
    "winf_disturbance_thesis", "augmented_disturbance_plant", "winf_disturbance_augmented",
]


def _plant(A, B, D, C, *, measured):
    """(A, B, D, C) from matrices or from a linear system given as ``A`` (its B, and its C as
    the measurement when ``measured``; D defaults to B, a disturbance at the inputs)."""
    if not is_linear_system(A):
        if B is None or D is None:
            raise TypeError("B and D are required when A is a matrix (or pass a linear system "
                            "as A: a Drake LinearSystem, a python-control StateSpace)")
        return (*state_input_disturbance(A, B, D), C)
    if B is not None:
        raise TypeError("B comes from the linear system given as A; do not pass it again")
    A, B, Cs, Ds = state_space_matrices(A, "A")
    if measured and C is None:
        if np.any(Ds):
            raise ValueError("the linear system's measurement has a feedthrough D ≠ 0; the "
                             "W∞ plant measures y = C x (pass C explicitly)")
        C = Cs
    return (*state_input_disturbance(A, B, B if D is None else D), C)


def _measured_plant(A, B, D, C):
    """:func:`_plant` for output feedback: C is required (given, or the linear system's)."""
    A, B, D, C = _plant(A, B, D, C, measured=True)
    if C is None:
        raise TypeError("C (the measurement y = C x) is required")
    return A, B, D, C


def _require_weights(name0, W0, name1, W1):
    for name, W in ((name0, W0), (name1, W1)):
        if W is None:
            raise TypeError(f"{name} is required")


def _required_d(fn, D):
    """D, or the TypeError of a call in the former order (A, B, D, ...) that landed D on C."""
    if D is None:
        raise TypeError(f"D (the disturbance matrix of x' = A x + B u + D w) is required: "
                        f"{fn} takes python-control's order (A, B, C, D) with C = None for the "
                        f"full state, and its weights by name; a call in the former order "
                        f"{fn}(A, B, D, ...) puts D in C's place")
    return D


def winf_plant(A: ArrayLike, B: ArrayLike, C: ArrayLike | None = None, D: ArrayLike | None = None,
               *, Gamma0: ArrayLike | None = None,
               Gamma1: ArrayLike | None = None) -> GeneralizedPlant:
    """Generalized plant of the W∞ channel z = [Gamma0^1/2 x ; Gamma1^1/2 xdot].

    Arguments in python-control's order (A, B, C, D), as :func:`winf_output_feedback`; the
    weights by name (a call in the former order ``(A, B, D, Gamma0, Gamma1, C)`` is refused
    with a TypeError instead of being read as another plant).

    Parameters
    ----------
    A, B : array_like
        x' = A x + B u + D w (6.1).
    C : array_like or None
        Measurement y = C x (None: the full state, for state feedback).
    D : array_like
        Disturbance matrix of (6.1) (required).
    Gamma0, Gamma1 : array_like
        Positive semidefinite weights of x and x' (n × n, or a vector for a diagonal;
        keyword-only, required).

    Returns
    -------
    GeneralizedPlant

    Raises
    ------
    TypeError
        When D or a weight is missing (e.g. a call in the former argument order).

    Examples
    --------
    >>> import sobolev_drake as sd
    >>> A, B, D = [[0, 1], [-1, -0.5]], [[0], [1]], [[1, 0], [0, 1]]
    >>> P = sd.winf_plant(A, B, D=D, Gamma0=[1, 1], Gamma1=[0.1, 0.1])
    >>> P.nz, P.nw, P.nu, P.ny          # z = [x; 0.1^1/2 x'], y = x
    (4, 2, 1, 2)
    >>> P.D12.ravel().round(4)          # u enters z through x' = ... + B u
    array([0.    , 0.    , 0.    , 0.3162])
    >>> sd.winf_plant(A, B, [[1, 0]], D, Gamma0=[1, 1], Gamma1=[0.1, 0.1]).ny    # y = x1
    1
    """
    _require_weights("Gamma0", Gamma0, "Gamma1", Gamma1)
    A, B, D = state_input_disturbance(A, B, _required_d("winf_plant", D))
    n, nu, nw = A.shape[0], B.shape[1], D.shape[1]
    G0 = sqrtm_psd(check_weight("Gamma0", Gamma0, n, definite=False))
    G1 = sqrtm_psd(check_weight("Gamma1", Gamma1, n, definite=False))
    C1 = np.vstack([G0, G1 @ A])
    D11 = np.vstack([np.zeros((n, nw)), G1 @ D])
    D12 = np.vstack([np.zeros((n, nu)), G1 @ B])
    C2 = np.eye(n) if C is None else as_matrix("C", C, (None, n))
    return GeneralizedPlant.make(A, D, B, C1, D11, D12, C2, None)


def hinf_plant(A: ArrayLike, B: ArrayLike, C: ArrayLike | None = None, D: ArrayLike | None = None,
               *, Q: ArrayLike | None = None, R: ArrayLike | None = None) -> GeneralizedPlant:
    """Generalized plant of the classic H∞ channel z = [Q^1/2 x ; R^1/2 u].

    Arguments as :func:`winf_plant`: python-control's order (A, B, C, D), weights by name.

    Parameters
    ----------
    A, B : array_like
        x' = A x + B u + D w.
    C : array_like or None
        Measurement y = C x (None: the full state).
    D : array_like
        Disturbance matrix (required).
    Q, R : array_like
        Weights of x (positive semidefinite) and u (positive definite); keyword-only, required.

    Returns
    -------
    GeneralizedPlant

    Raises
    ------
    TypeError
        When D or a weight is missing (e.g. a call in the former argument order).

    Examples
    --------
    >>> import sobolev_drake as sd
    >>> A, B, D = [[0, 1], [-1, -0.5]], [[0], [1]], [[1, 0], [0, 1]]
    >>> P = sd.hinf_plant(A, B, [[1, 0]], D, Q=[1, 1], R=[1])
    >>> P.nz, P.nw, P.nu, P.ny          # z = [x; u], y = x1
    (3, 2, 1, 1)
    """
    _require_weights("Q", Q, "R", R)
    A, B, D = state_input_disturbance(A, B, _required_d("hinf_plant", D))
    n, nu = A.shape[0], B.shape[1]
    Qh = sqrtm_psd(check_weight("Q", Q, n, definite=False))
    Rh = sqrtm_psd(check_weight("R", R, nu, definite=True))
    C1 = np.vstack([Qh, np.zeros((nu, n))])
    D12 = np.vstack([np.zeros((n, nu)), Rh])
    C2 = np.eye(n) if C is None else as_matrix("C", C, (None, n))
    return GeneralizedPlant.make(A, D, B, C1, None, D12, C2, None)


def winf_state_feedback(A: MatrixOrSystem, B: ArrayLike | None = None, D: ArrayLike | None = None,
                        Gamma0: ArrayLike | None = None, Gamma1: ArrayLike | None = None,
                        **options: Any) -> SynthesisResult:
    """Full-state W∞ controller (6.7), certified; u = +K x.

    Parameters
    ----------
    A : array_like or linear system
        The n × n state matrix, or a Drake LinearSystem/AffineSystem (e.g. from
        ``Linearize``) / python-control StateSpace whose A and B are used (then omit ``B``).
    B, D : array_like
        Input and disturbance matrices of x' = A x + B u + D w; with a linear system ``D``
        defaults to its B (a disturbance entering with the inputs).
    Gamma0, Gamma1 : array_like
        Sobolev weights of x and x' (required).
    **options
        Passed to :func:`~sobolev_drake.synthesis.hinf.state_feedback` (``method``,
        ``time_limit``, ``gamma``, ``region``, ...).

    Returns
    -------
    SynthesisResult
        ``K`` with u = +K x (no minus sign), certified ``gamma``.

    Examples
    --------
    A mass-spring-damper with a disturbance on each state, position and velocity weighted by
    1 and their rates by 0.1:

    >>> import numpy as np
    >>> import sobolev_drake as sd
    >>> A = np.array([[0.0, 1.0], [-1.0, -0.5]])
    >>> B = np.array([[0.0], [1.0]])
    >>> res = sd.winf_state_feedback(A, B, np.eye(2), Gamma0=[1, 1], Gamma1=[0.1, 0.1])
    >>> round(res.gamma, 3), res.certificate.ok, res.well_posed
    (1.049, True, True)

    The optimum needs large gains; a requested level gives a moderate one (u = +K x):

    >>> res = sd.winf_state_feedback(A, B, np.eye(2), Gamma0=[1, 1], Gamma1=[0.1, 0.1],
    ...                              gamma=2.0)
    >>> np.round(res.K, 3)
    array([[-3.075, -3.951]])
    >>> np.sort(np.linalg.eigvals(A + B @ res.K).real).round(3)
    array([-3.162, -1.289])
    """
    _require_weights("Gamma0", Gamma0, "Gamma1", Gamma1)
    A, B, D, _ = _plant(A, B, D, None, measured=False)
    return state_feedback(winf_plant(A, B, None, D, Gamma0=Gamma0, Gamma1=Gamma1), **options)


def winf_output_feedback(A: MatrixOrSystem, B: ArrayLike | None = None, C: ArrayLike | None = None,
                         D: ArrayLike | None = None, Gamma0: ArrayLike | None = None,
                         Gamma1: ArrayLike | None = None, **options: Any) -> SynthesisResult:
    """Dynamic output-feedback W∞ controller (6.22) with y = C x, certified.

    Parameters
    ----------
    A : array_like or linear system
        The state matrix, or a linear system whose A, B and C (the measurement) are used.
    B, C, D : array_like
        x' = A x + B u + D w, y = C x; with a linear system ``D`` defaults to its B.
    Gamma0, Gamma1 : array_like
        Sobolev weights of x and x' (required).
    **options
        Passed to :func:`~sobolev_drake.synthesis.hinf.output_feedback`.

    Returns
    -------
    SynthesisResult
        ``controller`` (A_K, B_K, C_K, D_K) with x_K' = A_K x_K + B_K y, u = C_K x_K + D_K y.

    Examples
    --------
    The position of a mass-spring-damper measured, y = x1.  A noise-free measurement makes
    the problem singular (rank D21 = 0): the synthesis regularizes it and says so with a
    :class:`~sobolev_drake.synthesis.problem.SynthesisWarning`, silenced here:

    >>> import warnings
    >>> import sobolev_drake as sd
    >>> from sobolev_drake.synthesis import SynthesisWarning
    >>> A, B, C, D = [[0, 1], [-1, -0.5]], [[0], [1]], [[1, 0]], [[1, 0], [0, 1]]
    >>> with warnings.catch_warnings():
    ...     warnings.simplefilter("ignore", SynthesisWarning)
    ...     res = sd.winf_output_feedback(A, B, C, D, Gamma0=[1, 1], Gamma1=[0.1, 0.1])
    >>> round(res.gamma, 2), res.certificate.ok, res.regularized
    (1.09, True, True)
    >>> res.warnings[0].split(":")[0]
    'singular problem (rank D21 = 0 < 1)'
    >>> [M.shape for M in res.controller]           # (A_K, B_K, C_K, D_K), full order
    [(2, 2), (2, 1), (1, 2), (1, 1)]
    """
    _require_weights("Gamma0", Gamma0, "Gamma1", Gamma1)
    A, B, D, C = _measured_plant(A, B, D, C)
    return output_feedback(winf_plant(A, B, C, D, Gamma0=Gamma0, Gamma1=Gamma1), **options)


def hinf_state_feedback_qr(A: MatrixOrSystem, B: ArrayLike | None = None, D: ArrayLike | None = None,
                           Q: ArrayLike | None = None, R: ArrayLike | None = None,
                           **options: Any) -> SynthesisResult:
    """Classic H∞ state feedback with z = [Q^1/2 x; R^1/2 u], certified; u = +K x.

    Parameters
    ----------
    A, B, D : array_like or linear system
        As for :func:`winf_state_feedback`.
    Q, R : array_like
        Weights of x and u (required).
    **options
        Passed to :func:`~sobolev_drake.synthesis.hinf.state_feedback`.

    Returns
    -------
    SynthesisResult

    Examples
    --------
    >>> import numpy as np
    >>> import sobolev_drake as sd
    >>> A, B = np.array([[0.0, 1.0], [-1.0, -0.5]]), np.array([[0.0], [1.0]])
    >>> res = sd.hinf_state_feedback_qr(A, B, np.eye(2), Q=[1, 1], R=[1])
    >>> round(res.gamma, 3), res.certificate.ok
    (1.476, True)
    >>> res = sd.hinf_state_feedback_qr(A, B, np.eye(2), Q=[1, 1], R=[1], gamma=2.0)
    >>> np.round(res.K, 3)
    array([[-0.866, -1.416]])
    """
    _require_weights("Q", Q, "R", R)
    A, B, D, _ = _plant(A, B, D, None, measured=False)
    return state_feedback(hinf_plant(A, B, None, D, Q=Q, R=R), **options)


def hinf_output_feedback_qr(A: MatrixOrSystem, B: ArrayLike | None = None, C: ArrayLike | None = None,
                            D: ArrayLike | None = None, Q: ArrayLike | None = None, R: ArrayLike | None = None,
                            **options: Any) -> SynthesisResult:
    """Classic H∞ dynamic output feedback with z = [Q^1/2 x; R^1/2 u] and y = C x, certified.

    Parameters
    ----------
    A, B, C, D : array_like or linear system
        As for :func:`winf_output_feedback`.
    Q, R : array_like
        Weights of x and u (required).
    **options
        Passed to :func:`~sobolev_drake.synthesis.hinf.output_feedback`.

    Returns
    -------
    SynthesisResult

    Examples
    --------
    As for :func:`winf_output_feedback`, y = C x is noise free, so the result is regularized
    (and a SynthesisWarning says so):

    >>> import warnings
    >>> import sobolev_drake as sd
    >>> from sobolev_drake.synthesis import SynthesisWarning
    >>> A, B, C, D = [[0, 1], [-1, -0.5]], [[0], [1]], [[1, 0]], [[1, 0], [0, 1]]
    >>> with warnings.catch_warnings():
    ...     warnings.simplefilter("ignore", SynthesisWarning)
    ...     res = sd.hinf_output_feedback_qr(A, B, C, D, Q=[1, 1], R=[1])
    >>> round(res.gamma, 2), res.certificate.ok, res.regularized
    (1.56, True, True)
    """
    _require_weights("Q", Q, "R", R)
    A, B, D, C = _measured_plant(A, B, D, C)
    return output_feedback(hinf_plant(A, B, C, D, Q=Q, R=R), **options)


# --------------------------------------------------------------------------- disturbance model
@dataclass
class DegeneracyReport:
    kernel_dim: int  # dim ker L
    singular: bool
    weight: np.ndarray  # L' diag(Upsilon0, Upsilon1) L, the (d, v) weight of (6.31)/(6.36)
    message: str


def _dist(Ad, Bd, Cd, Ups0, Ups1):
    Ad = as_matrix("Ad", Ad)
    nd = Ad.shape[0]
    as_matrix("Ad", Ad, (nd, nd))
    Bd = as_matrix("Bd", Bd, (nd, None))
    Cd = as_matrix("Cd", Cd, (None, nd))
    nw = Cd.shape[0]
    U0 = check_weight("Upsilon0", Ups0, nw, definite=False)
    U1 = check_weight("Upsilon1", Ups1, nw, definite=False)
    return Ad, Bd, Cd, U0, U1


def disturbance_model_degeneracy(Ad: ArrayLike, Bd: ArrayLike, Cd: ArrayLike, Upsilon0: ArrayLike,
                                 Upsilon1: ArrayLike) -> DegeneracyReport:
    """Diagnose the (d, v) block of (6.31)/(6.36): -gamma^2 L' diag(Ups0, Ups1) L."""
    Ad, Bd, Cd, U0, U1 = _dist(Ad, Bd, Cd, Upsilon0, Upsilon1)
    nd, nv = Bd.shape
    L = np.block([[Cd, np.zeros((Cd.shape[0], nv))], [Cd @ Ad, Cd @ Bd]])
    Wt = L.T @ np.block([[U0, np.zeros_like(U0)], [np.zeros_like(U1), U1]]) @ L
    ev = np.linalg.eigvalsh(Wt)
    k = int(np.sum(ev <= 1e-10 * max(1.0, ev.max())))
    msg = (f"L' diag(Ups0, Ups1) L is {nd + nv}x{nd + nv} with a {k}-dimensional kernel: the strict "
           f"LMI (6.31)/(6.36) is infeasible and its non-strict version degenerates"
           if k else "the (d, v) weight is positive definite: (6.31)/(6.36) are well posed")
    return DegeneracyReport(k, k > 0, Wt, msg)


def winf_disturbance_thesis(A: ArrayLike, B: ArrayLike, D: ArrayLike, Ad: ArrayLike, Bd: ArrayLike,
                            Cd: ArrayLike, Gamma0: ArrayLike, Gamma1: ArrayLike, Upsilon0: ArrayLike,
                            Upsilon1: ArrayLike, *, C: ArrayLike | None = None, strict: bool = True,
                            **kw: Any) -> SynthesisResult:
    """(6.31) (C None: state feedback) or (6.36) (output feedback y = C x) as written.

    The exogenous input is (d, v) entering through B1 = [D Cd, 0]; the -gamma^2 I block is
    replaced by -gamma^2 L' diag(Ups0, Ups1) L. With ``strict=True`` (the thesis' "< 0") the
    problem is infeasible whenever that weight is singular; an InfeasibleLMIError carrying the
    degeneracy report's message is raised. ``strict=False`` solves the non-strict problem and
    returns the (uncertified) result; its gamma is not a verified bound.

    Returns
    -------
    SynthesisResult
        ``method="thesis_lmi"``, no certificate (``certified`` is False); ``warnings`` ends
        with the degeneracy report's message (the report: :func:`disturbance_model_degeneracy`).

    Raises
    ------
    InfeasibleLMIError
        ``strict=True`` and the (d, v) weight is singular, or the solver failed.
    """
    A, B, D = state_input_disturbance(A, B, D)
    Ad, Bd, Cd, U0, U1 = _dist(Ad, Bd, Cd, Upsilon0, Upsilon1)
    rep = disturbance_model_degeneracy(Ad, Bd, Cd, U0, U1)
    n, nv = A.shape[0], Bd.shape[1]
    DCd = np.hstack([D @ Cd, np.zeros((n, nv))])
    plant = winf_plant(A, B, C, DCd, Gamma0=Gamma0, Gamma1=Gamma1)
    fn = state_feedback if C is None else output_feedback
    Wt = rep.weight
    if strict and rep.singular:
        # strictness: the (d, v) diagonal block must itself be < 0, impossible on ker L;
        # we still ask the solver, so the infeasibility is demonstrated, not assumed
        try:
            r = fn(plant, input_weight=Wt, regularize=False, verify=False, **kw)
        except InfeasibleLMIError as e:
            raise InfeasibleLMIError(f"{e}; {rep.message}", e.status) from None
        worst = max(np.linalg.eigvalsh(-r.gamma ** 2 * Wt))
        raise InfeasibleLMIError(f"strict LMI not satisfiable: (d, v) block has eigenvalue {worst:.3g} "
                                 f">= 0 (solver returned status {r.status}); {rep.message}", "infeasible")
    r = fn(plant, input_weight=Wt, regularize=False, verify=False, margin=0.0, **kw)
    return r.replace(warnings=r.warnings + [rep.message], method="thesis_lmi", certificate=None,
                     certificates=[])


def augmented_disturbance_plant(A: ArrayLike, B: ArrayLike, D: ArrayLike, Ad: ArrayLike, Bd: ArrayLike,
                                Cd: ArrayLike, Gamma0: ArrayLike, Gamma1: ArrayLike, *,
                                C: ArrayLike | None = None) -> GeneralizedPlant:
    """Plant with state (x, d), input v, z = [Gamma0^1/2 x; Gamma1^1/2 xdot], y = C x (d unmeasured).

    ``C`` is keyword-only, as in :func:`winf_disturbance_augmented` and
    :func:`winf_disturbance_thesis`.
    """
    A, B, D = state_input_disturbance(A, B, D)
    nw_ = as_matrix("Cd", Cd).shape[0]
    Ad, Bd, Cd, _, _ = _dist(Ad, Bd, Cd, np.zeros((nw_, nw_)), np.zeros((nw_, nw_)))
    n, nd, nu, nv = A.shape[0], Ad.shape[0], B.shape[1], Bd.shape[1]
    G0 = sqrtm_psd(check_weight("Gamma0", Gamma0, n, definite=False))
    G1 = sqrtm_psd(check_weight("Gamma1", Gamma1, n, definite=False))
    Aa = np.block([[A, D @ Cd], [np.zeros((nd, n)), Ad]])
    B1 = np.vstack([np.zeros((n, nv)), Bd])
    B2 = np.vstack([B, np.zeros((nd, nu))])
    C1 = np.vstack([np.hstack([G0, np.zeros((n, nd))]), G1 @ np.hstack([A, D @ Cd])])
    D12 = np.vstack([np.zeros((n, nu)), G1 @ B])
    Cm = np.eye(n) if C is None else as_matrix("C", C, (None, n))
    C2 = np.hstack([Cm, np.zeros((Cm.shape[0], nd))])
    return GeneralizedPlant.make(Aa, B1, B2, C1, None, D12, C2, None)


def winf_disturbance_augmented(A: ArrayLike, B: ArrayLike, D: ArrayLike, Ad: ArrayLike, Bd: ArrayLike,
                               Cd: ArrayLike, Gamma0: ArrayLike, Gamma1: ArrayLike, *,
                               C: ArrayLike | None = None, **kw: Any) -> SynthesisResult:
    """Well-posed disturbance-model W∞ design (output-feedback LMI on (x, d)).

    The gain certified is from v (L2) to z = [Gamma0^1/2 x; Gamma1^1/2 xdot]; the controller
    is dynamic (it estimates d from the measured x or y = C x).
    """
    return output_feedback(augmented_disturbance_plant(A, B, D, Ad, Bd, Cd, Gamma0, Gamma1, C=C), **kw)
