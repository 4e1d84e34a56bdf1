"""Linear systems in and controllers out: Drake, python-control and scipy interoperability.

Accepted wherever the synthesis takes a plant model:

* Drake ``LinearSystem`` / ``AffineSystem`` (e.g. from ``Linearize`` or ``FirstOrderTaylorApproximation``):
  its A, B, C, D (continuous time only; an affine system's offsets f0, y0 are the operating point, which
  the controller system takes as ``x_op``/``u_op``, see ``systems.linear_controllers.controller_system``);
* python-control ``StateSpace`` (continuous, ``dt == 0``), scipy ``signal.StateSpace``, or a tuple
  ``(A, B, C, D)`` of matrices.

python-control's partition convention for a generalized plant P: inputs [w; u] with the last ``ncon``
inputs the controls, outputs [z; y] with the last ``nmeas`` outputs the measurements.

Sign convention, the same everywhere: u = +K x (state feedback), u = C_K x_K + D_K y (output feedback;
positive, as python-control's ``hinfsyn``; Drake's LQR returns K for u = −K x).
"""

from __future__ import annotations

import warnings
from typing import TYPE_CHECKING, Any

import numpy as np

from .certificates import Certificate, as_matrix, hinf_norm
from .hinf import state_feedback
from .hinf_common import NORM_BRACKET
from .lmi import SynthesisError
from .problem import DynamicController, GeneralizedPlant, SynthesisResult, SynthesisWarning
from .output_feedback import output_feedback
from ..optional import python_control
from ..validation import describe

if TYPE_CHECKING:
    import control
    import scipy.signal
    from numpy.typing import ArrayLike
    from pydrake.systems.primitives import AffineSystem
    LinearSystemLike = AffineSystem | control.StateSpace | scipy.signal.StateSpace | tuple[ArrayLike, ...]

__all__ = ["state_space_matrices", "is_linear_system", "generalized_plant", "to_statespace", "hinf_state_feedback",
           "hinf_output_feedback", "hinfsyn", "HinfsynOutput", "CERTIFICATE_MARGIN", "ILL_POSED_COND"]

#: when an estimate of the closed-loop norm of P with the returned controller exceeds the synthesis gamma,
#: :func:`hinfsyn` publishes (1 + CERTIFICATE_MARGIN) x the largest estimate.  It covers the estimates' own
#: accuracies (the Hamiltonian iteration's bracket 2e-7, ab13dd's tolerance 1e-10), not the spread between
#: them on ill-conditioned loops, which the maximum over the estimates covers (see :func:`hinfsyn`, Notes)
CERTIFICATE_MARGIN = 1e-6
#: the loop of P and K is refused as ill-posed when I − D22 D_K (equivalently I + D_K D22 of
#: the loop shift) has a condition number above this
ILL_POSED_COND = 1e12


def _system_kind(obj):
    """"drake" (methods A(), B(), ...), "statespace" (attributes A, B, C, D) or None."""
    if callable(getattr(obj, "A", None)) and callable(getattr(obj, "C", None)):
        return "drake"
    if not isinstance(obj, np.ndarray) and all(hasattr(obj, k) for k in ("A", "B", "C", "D")):
        return "statespace"
    return None


def is_linear_system(obj: object) -> bool:
    """True for a Drake Linear/AffineSystem, a python-control or scipy StateSpace.

    Parameters
    ----------
    obj : object

    Returns
    -------
    bool
    """
    return _system_kind(obj) is not None


def state_space_matrices(system: LinearSystemLike, name: str = "system") -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(A, B, C, D) of a continuous-time linear system (see the module docstring).

    Parameters
    ----------
    system : Drake LinearSystem/AffineSystem, control.StateSpace, scipy.signal.StateSpace or
        tuple (A, B, C, D)
    name : str
        Argument name used in error messages.

    Returns
    -------
    tuple of ndarray
        A (n × n), B (n × m), C (p × n), D (p × m).
    """
    kind = _system_kind(system)
    if isinstance(system, tuple) and len(system) == 4:
        A, B, C, D = system
    elif kind == "drake":                                        # Drake (Affine|Linear)System
        period = system.time_period() if hasattr(system, "time_period") else 0.0
        if period:
            raise ValueError(f"{name} must be continuous-time, got a Drake system with time "
                             f"period {period} (discrete plants: sd.hinf_discrete)")
        A, B, C, D = system.A(), system.B(), system.C(), system.D()
    elif kind == "statespace":                                   # python-control / scipy
        dt = getattr(system, "dt", 0)
        if dt not in (0, None):
            raise ValueError(f"{name} must be continuous-time, got dt = {dt} (sd.hinf_discrete)")
        A, B, C, D = system.A, system.B, system.C, system.D
    else:
        raise TypeError(f"{name} must be a Drake LinearSystem/AffineSystem, a python-control or "
                        f"scipy StateSpace, or a tuple (A, B, C, D); got {type(system).__name__}")
    A = as_matrix(f"{name}.A", A)
    n = A.shape[0]
    as_matrix(f"{name}.A", A, (n, n))
    B = as_matrix(f"{name}.B", B, (n, None))
    C = as_matrix(f"{name}.C", C, (None, n))
    D = as_matrix(f"{name}.D", D, (C.shape[0], B.shape[1]))
    return A, B, C, D


def _count(name, value, upper):
    """``value`` as an int in 1 ... upper − 1 (``name`` is "nmeas" or "ncon", ``upper`` the
    plant's number of outputs or inputs: one channel at least stays for z or w)."""
    what = "outputs" if name == "nmeas" else "inputs"
    counted = ("measurements, the last outputs" if name == "nmeas" else
               "controls, the last inputs")
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} must be an integer (the number of {counted} of the plant), "
                        f"got {value!r} ({type(value).__name__})")
    if upper < 2:
        raise ValueError(f"{name}={value} cannot be met: the plant has {upper} {what}, it needs at "
                         f"least 2 ({'z and y' if name == 'nmeas' else 'w and u'})")
    if not 1 <= value < upper:
        raise ValueError(f"{name} must be between 1 and {upper - 1} (the plant has {upper} "
                         f"{what}, at least one of them {'z' if name == 'nmeas' else 'w'}), "
                         f"got {value}")
    return int(value)


def generalized_plant(system: LinearSystemLike, nmeas: int | None = None, ncon: int | None = None) -> tuple[GeneralizedPlant, np.ndarray]:
    """Partition a linear system into a :class:`GeneralizedPlant` (python-control convention).

    Parameters
    ----------
    system : linear system or (A, B, C, D) (see :func:`state_space_matrices`)
        Inputs [w; u], outputs [z; y].
    nmeas : int or None
        Number of measurements (last outputs).  None: state feedback, every output is z and
        y = x.
    ncon : int
        Number of controls (last inputs).

    Returns
    -------
    (GeneralizedPlant, D22)
        The plant with D22 = 0 and the D22 block (zeros for state feedback), which
        :func:`hinfsyn` removes by a loop shift.
    """
    A, B, C, D = state_space_matrices(system, "system")
    if ncon is None:
        raise TypeError("ncon (the number of control inputs, the last inputs of P) is required")
    nu = _count("ncon", ncon, B.shape[1])
    if nmeas is None:
        plant = GeneralizedPlant.make(A, B[:, :-nu], B[:, -nu:], C, D[:, :-nu], D[:, -nu:])
        return plant, np.zeros((A.shape[0], nu))
    ny = _count("nmeas", nmeas, C.shape[0])
    plant = GeneralizedPlant.make(A, B[:, :-nu], B[:, -nu:], C[:-ny], D[:-ny, :-nu],
                                  D[:-ny, -nu:], C[-ny:], D[-ny:, :-nu])
    return plant, D[-ny:, -nu:]


def _as_plant(plant, nmeas, ncon, kind):
    if plant is None:
        raise TypeError(f"{kind}: plant must be a GeneralizedPlant or a linear system (python-control "
                        "StateSpace, Drake LinearSystem or (A, B, C, D)), got None")
    if isinstance(plant, GeneralizedPlant):
        if nmeas is not None or ncon is not None:
            raise TypeError("nmeas/ncon partition a linear system; a GeneralizedPlant is "
                            "already partitioned")
        return plant
    plant, D22 = generalized_plant(plant, nmeas, ncon)
    if np.any(D22):
        raise ValueError(f"{kind}: D22 (measurement feedthrough of u) must be zero here; "
                         "hinfsyn removes a non-zero D22 by a loop shift")
    return plant


def hinf_state_feedback(plant: GeneralizedPlant | LinearSystemLike, *, ncon: int | None = None, **options: Any) -> SynthesisResult:
    """H∞ state feedback u = +K x of a generalized plant, certified.

    Parameters
    ----------
    plant : GeneralizedPlant or linear system
        A linear system (see :func:`state_space_matrices`) has inputs [w; u] and outputs z;
        then ``ncon`` counts the controls (the last inputs).
    ncon : int, optional
        Number of controls when ``plant`` is a linear system.
    **options
        Passed to :func:`~sobolev_drake.synthesis.hinf.state_feedback` (``method``,
        ``time_limit``, ``gamma``, ``region``, ...).

    Returns
    -------
    SynthesisResult
    """
    return state_feedback(_as_plant(plant, None, ncon, "hinf_state_feedback"), **options)


def hinf_output_feedback(plant: GeneralizedPlant | LinearSystemLike, *, nmeas: int | None = None,
                         ncon: int | None = None, **options: Any) -> SynthesisResult:
    """H∞ dynamic output feedback u = C_K x_K + D_K y of a generalized plant, certified.

    Parameters
    ----------
    plant : GeneralizedPlant or linear system
        A linear system has inputs [w; u] and outputs [z; y], partitioned by ``nmeas`` and
        ``ncon`` (python-control's convention, see :func:`hinfsyn`).
    nmeas, ncon : int, optional
        Numbers of measurements (last outputs) and controls (last inputs) of a linear system.
    **options
        Passed to :func:`~sobolev_drake.synthesis.hinf.output_feedback`.

    Returns
    -------
    SynthesisResult
    """
    if plant is None:
        _as_plant(plant, nmeas, ncon, "hinf_output_feedback")
    if not isinstance(plant, GeneralizedPlant) and nmeas is None:
        raise TypeError("nmeas (the number of measurements, the last outputs of the plant) is "
                        "required for a linear system")
    return output_feedback(_as_plant(plant, nmeas, ncon, "hinf_output_feedback"), **options)


def _shift_d22(controller: DynamicController, D22) -> DynamicController:
    """Controller for y = ... + D22 u from one designed for y − D22 u (loop shift)."""
    AK, BK, CK, DK = controller
    R = np.eye(DK.shape[0]) + DK @ D22
    cond = np.linalg.cond(R)
    if not cond <= ILL_POSED_COND:
        raise SynthesisError(f"hinfsyn: the loop with D22 is ill-posed: I + D_K D22 has condition "
                             f"number {cond:.3g} (above {ILL_POSED_COND:g}) for the designed D_K "
                             f"{_short(DK)} and D22 {_short(D22)}")
    Ri = np.linalg.inv(R)
    return DynamicController(AK - BK @ D22 @ Ri @ CK, BK - BK @ D22 @ Ri @ DK, Ri @ CK, Ri @ DK)


def _short(M):
    """A matrix for an error message: its entries if small, else its shape and norm."""
    M = np.asarray(M)
    return (np.array2string(M, precision=4, max_line_width=200).replace("\n", "")
            if M.size <= 6 else f"(shape {M.shape}, norm {np.linalg.norm(M, 2):.4g})")


def _closed_loop(plant: GeneralizedPlant, D22, controller):
    """(A, B, C, D) of w → z for ``plant`` with measurement feedthrough ``D22`` (y = C2 x +
    D21 w + D22 u) closed by u = C_K x_K + D_K y; state [x; x_K].  The algebraic loop is
    y = (I − D22 D_K)^-1 (C2 x + D21 w + D22 C_K x_K); SynthesisError when I − D22 D_K is
    singular or worse conditioned than ``ILL_POSED_COND``."""
    A, B1, B2, C1, D11, D12, C2, D21 = plant.as_tuple()
    AK, BK, CK, DK = controller
    E = np.eye(plant.ny) - D22 @ DK
    cond = np.linalg.cond(E)
    if not cond <= ILL_POSED_COND:
        raise SynthesisError(f"hinfsyn: the loop of P with the returned controller is ill-posed: "
                             f"I − D22 D_K has condition number {cond:.3g} (above "
                             f"{ILL_POSED_COND:g}) for D22 {_short(D22)} and D_K {_short(DK)}")
    Ey = np.linalg.solve(E, np.hstack([C2, D22 @ CK, D21]))  # y = Ey [x; x_K; w]
    Eu = DK @ Ey + np.hstack([np.zeros((plant.nu, plant.n)), CK, np.zeros((plant.nu, plant.nw))])
    n, nk = plant.n, AK.shape[0]
    Acl = np.block([[A + B2 @ Eu[:, :n], B2 @ Eu[:, n:n + nk]],
                    [BK @ Ey[:, :n], AK + BK @ Ey[:, n:n + nk]]])
    Bcl = np.vstack([B1 + B2 @ Eu[:, n + nk:], BK @ Ey[:, n + nk:]])
    Ccl = np.hstack([C1 + D12 @ Eu[:, :n], D12 @ Eu[:, n:n + nk]])
    Dcl = D11 + D12 @ Eu[:, n + nk:]
    return Acl, Bcl, Ccl, Dcl


def _norm_estimates(label, Acl, Bcl, Ccl, Dcl, out):
    """Add the closed loop's norm estimates to ``out``; return the largest real part of its
    eigenvalues (the estimates only when that is negative).

    The own Hamiltonian iteration on the realization as given and on its real Schur form (an
    orthogonal similarity: the same norm in exact arithmetic, another rounding), and SLICOT
    ab13dd through python-control when slycot is installed."""
    control = python_control("hinfsyn")
    import scipy.linalg as sla
    ev = np.linalg.eigvals(Acl) if Acl.size else np.zeros(0)
    mre = float(ev.real.max()) if ev.size else -np.inf
    if mre >= 0:
        out[f"{label}: unstable"] = np.inf
        return mre
    # the Hamiltonian iteration returns a lower bound within NORM_BRACKET of the norm
    out[f"Hamiltonian iteration, {label}"] = float(hinf_norm(Acl, Bcl, Ccl, Dcl)[0]) * NORM_BRACKET
    if Acl.size:
        T, Z = sla.schur(Acl, output="real")
        out[f"Hamiltonian iteration, Schur form, {label}"] = float(
            hinf_norm(T, Z.T @ Bcl, Ccl @ Z, Dcl)[0]) * NORM_BRACKET
    if control.exception.slycot_check():
        out[f"SLICOT ab13dd, {label}"] = float(
            control.linfnorm(control.ss(Acl, Bcl, Ccl, Dcl), tol=1e-10)[0])
    return mre


def _certify_on_p(P, plant, D22, controller, K, nmeas, ncon, gamma):
    """Certificate of the controller returned by :func:`hinfsyn` on the plant P as given
    (D22 included) and the gamma to publish (see :func:`hinfsyn`, Notes)."""
    estimates = {}
    closed = _closed_loop(plant, D22, controller)
    mre = _norm_estimates("closed by formula", *closed, estimates)
    if np.isfinite(mre) and mre < 0:
        # the same loop as python-control closes it (P.lft(K)): the closure users check
        lft = P.lft(K, ncon, nmeas)
        mre = max(mre, _norm_estimates("closed by python-control's lft", lft.A, lft.B, lft.C,
                                       lft.D, estimates))
    ev = np.linalg.eigvals(closed[0]) if closed[0].size else np.zeros(0)
    achieved = max(estimates.values())
    failures = []
    if not mre < 0:
        failures.append(f"the closed loop of P with the returned controller is unstable: max "
                        f"Re(eig) = {mre:.3g}")
        published = np.inf
    elif achieved <= gamma:
        published = float(gamma)   # the synthesis' bound holds for P as given too
    else:
        published = achieved * (1 + CERTIFICATE_MARGIN)
    cert = Certificate(mre < 0, mre, achieved, published, CERTIFICATE_MARGIN,
                       solver_status="hinfsyn: closed loop of P as given", eigenvalues=ev,
                       failures=failures)
    return cert, estimates, closed


def to_statespace(result_or_controller: SynthesisResult | DynamicController | ArrayLike) -> control.StateSpace:
    """python-control ``StateSpace`` of a controller (input y or x, output u; u = +K x).

    Parameters
    ----------
    result_or_controller : SynthesisResult, DynamicController or gain matrix K

    Returns
    -------
    control.StateSpace
        Static gain (no state) for state feedback.

    Examples
    --------
    >>> import sobolev_drake as sd
    >>> sd.to_statespace([[-1.0, -2.0]]).D     # a state-feedback gain: a static system
    array([[-1., -2.]])
    """
    obj = result_or_controller
    if isinstance(obj, SynthesisResult):
        obj = obj.controller            # one type for both kinds (a gain: the static one)
    if isinstance(obj, DynamicController):
        return obj.to_statespace()
    if obj is None or np.ndim(obj) != 2 or np.size(obj) == 0:
        raise TypeError("result_or_controller must be a SynthesisResult, a DynamicController or a "
                        f"non-empty gain matrix K (2-D), got {describe(obj)}")
    return DynamicController.static(as_matrix("result_or_controller", obj)).to_statespace()


class HinfsynOutput(tuple):
    """``(K, CL, gamma, rcond)`` as ``control.hinfsyn`` returns them, plus the certificate.

    Parameters
    ----------
    K : control.StateSpace
        Controller y → u (positive feedback, u = C_K x_K + D_K y).
    CL : control.StateSpace
        Closed loop w → z of P (D22 included) with K.
    gamma : float
        The bound certified on that closed loop (see :func:`hinfsyn`, Notes).
    rcond : ndarray, shape (4,)
        Reciprocal condition numbers of [D12, D21, X, Y] (X, Y the solution's Lyapunov blocks; NaN where absent).
    result : SynthesisResult
        The synthesis of the loop-shifted plant (D22 removed), with its certificate (not part of the tuple).
    certificate : Certificate
        The check of K on P itself: stability, the largest norm estimate (``achieved``) and ``gamma``.
    norm_estimates : dict
        Every estimate of the closed-loop norm behind ``certificate.achieved``, by method and closure (own
        Hamiltonian iteration, SLICOT ab13dd; loop closed by formula and by python-control's ``lft``).

    Attributes
    ----------
    K, CL, gamma, rcond
        The tuple's entries by name.
    result, certificate, norm_estimates
        As above.
    """

    def __new__(cls, K: control.StateSpace, CL: control.StateSpace, gamma: float, rcond: np.ndarray, result: SynthesisResult,
                certificate: Certificate | None = None, norm_estimates: dict[str, float] | None = None) -> HinfsynOutput:
        out = super().__new__(cls, (K, CL, gamma, rcond))
        out.result = result
        out.certificate = certificate
        out.norm_estimates = {} if norm_estimates is None else dict(norm_estimates)
        return out

    K = property(lambda s: s[0])
    CL = property(lambda s: s[1])
    gamma = property(lambda s: s[2])
    rcond = property(lambda s: s[3])


def _rcond(M):
    if M is None or not np.size(M):
        return np.nan
    s = np.linalg.svd(np.atleast_2d(M), compute_uv=False)
    return float(s[-1] / s[0]) if s[0] > 0 else 0.0


def _required_count(name, value):
    """None refused with what hinfsyn needs instead (the range is checked with the plant)."""
    if value is None:
        what = ("the number of measurements y, the last outputs of P" if name == "nmeas" else
                "the number of controls u, the last inputs of P")
        extra = (" (hinfsyn is output feedback; for state feedback u = K x use "
                 "hinf_state_feedback(P, ncon=...))" if name == "nmeas" else "")
        raise TypeError(f"{name} must be an integer, {what}, as in control.hinfsyn(P, nmeas, "
                        f"ncon); got None{extra}")


def hinfsyn(P: LinearSystemLike, nmeas: int, ncon: int, **options: Any) -> HinfsynOutput:
    """H∞ output-feedback synthesis with python-control's calling convention, certified on P.

    Parameters
    ----------
    P : control.StateSpace, Drake LinearSystem/AffineSystem, scipy StateSpace or (A, B, C, D)
        Generalized plant, inputs [w; u], outputs [z; y] (D22 ≠ 0 allowed: removed by a loop
        shift and put back into the controller).
    nmeas : int
        Number of measurements y (the last outputs), 1 ... (outputs of P) − 1.  Required, as
        in ``control.hinfsyn``: None raises TypeError (it does not mean state feedback here;
        use :func:`hinf_state_feedback`).
    ncon : int
        Number of controls u (the last inputs), 1 ... (inputs of P) − 1.  Required.
    **options
        Passed to :func:`~sobolev_drake.synthesis.hinf.output_feedback` (``method``,
        ``time_limit``, ``gamma``, ``region``, ``verify``, ...).

    Returns
    -------
    HinfsynOutput
        Unpacks as ``K, CL, gamma, rcond`` like ``control.hinfsyn``; ``.result`` is the
        :class:`SynthesisResult` of the (loop-shifted) synthesis, ``.certificate`` and
        ``.norm_estimates`` the check on P.

    Raises
    ------
    TypeError
        ``nmeas`` or ``ncon`` None or not an integer.
    ValueError
        ``nmeas``/``ncon`` outside 1 ... (outputs/inputs of P) − 1; a bad P.
    SynthesisError
        No certified controller; the loop of P with the controller is ill-posed
        (I − D22 D_K worse conditioned than ``ILL_POSED_COND``); or, with ``verify`` (the
        default), the returned controller does not stabilize P.

    Notes
    -----
    The synthesis runs on P with D22 removed (y − D22 u is measured instead of y) and the controller is
    mapped back by the loop shift.  The two closed loops are equal in exact arithmetic, not in floating
    point: on singular plants (rank-deficient D12 or D21) the controllers near the infimum can have gains
    of 1e5-1e7, the shift cancels terms of that size, and the closed loop of the returned controller was
    measured 0.33 % above the certified gamma of the shifted design (50-digit evaluation of the same
    matrices).  So the returned K is certified again on P as given: the loop, with its algebraic loop (I −
    D22 D_K)^-1, is closed twice -- by formula and by python-control's ``P.lft(K)`` --, each closure must
    be stable, and its H∞ norm is estimated by the own Hamiltonian iteration (``certificates.hinf_norm``,
    Bruinsma & Steinbuch) on the realization and on its real Schur form, and, when slycot is installed, by
    SLICOT ab13dd (``control.linfnorm``), which shares no code with the synthesis or the own iteration
    (the Hamiltonian values are the upper ends of their brackets).  The published gamma is the synthesis
    gamma when no estimate exceeds it, else (1 + CERTIFICATE_MARGIN) x the largest estimate: never below
    any of them.  An excess above the margin goes into ``result.warnings`` and a
    :class:`SynthesisWarning`; one below it is estimator noise (LMI designs, whose gamma is the
    Hamiltonian norm of the shifted loop: ab13dd measured 5e-13 above) and only the published gamma shows
    it.  There is no re-synthesis: the excess is rounding, which a design at a lower level (larger gains)
    would not reduce.  On ill-conditioned loops (eigenvector condition 1e7 and more) the double-precision
    estimates disagree far beyond their tolerances -- measured against 50-digit values of the same
    matrices: ab13dd up to 0.9 % above, the Hamiltonian iteration up to 9e-5 below on the realization as
    given (a peak missed) and from 9e-6 below to 7e-5 above on the Schur form --, hence the maximum over
    methods and realizations rather than one number trusted alone; the price is a gamma raised by the
    largest overestimate. Measured on random regular plants (D22 = 0 and ≠ 0): the estimates agree to 2e-7
    on the stable, lightly damped and feedthrough families (the synthesis gamma is published); on unstable
    and badly scaled ones they spread up to 2.4e-5 and gamma is raised by up to that much.  Without slycot
    the bound rests on the two Hamiltonian estimates.

    Examples
    --------
    >>> import control, sobolev_drake as sd
    >>> P = control.ss([[0, 1], [-1, -0.5]], [[0, 0, 0], [1, 0, 1]],        # inputs w1, w2, u
    ...                [[1, 0], [0, 0], [1, 0]], [[0, 0, 0], [0, 0, 1], [0, 1, 0]])  # z1, z2, y
    >>> K, CL, gamma, rcond = sd.hinfsyn(P, nmeas=1, ncon=1)
    >>> round(gamma, 3), K.nstates, bool(all(CL.poles().real < 0))
    (1.14, 2, True)
    """
    control = python_control("hinfsyn")
    _required_count("nmeas", nmeas)
    _required_count("ncon", ncon)
    plant, D22 = generalized_plant(P, nmeas, ncon)
    verify = options.get("verify", True)
    res = output_feedback(plant, **options)
    controller = res.controller if not np.any(D22) else _shift_d22(res.controller, D22)
    K = control.ss(*controller)
    Pss = control.ss(*state_space_matrices(P, "P"))
    cert, estimates, closed = _certify_on_p(Pss, plant, D22, controller, K, int(nmeas),
                                            int(ncon), res.gamma)
    if cert.failures and verify:
        raise SynthesisError("hinfsyn: " + "; ".join(cert.failures) + " (the synthesis "
                             f"certified gamma {res.gamma:.6g} on the loop-shifted plant)")
    if np.isfinite(cert.gamma) and cert.achieved > res.gamma * (1 + CERTIFICATE_MARGIN):
        msg = (f"hinfsyn: the returned controller's closed loop on P (D22 included) has norm "
               f"estimate {cert.achieved:.8g}, above the synthesis' certified gamma "
               f"{res.gamma:.8g} by {cert.achieved / res.gamma - 1:.2e} (relative; floating-point "
               f"error of the loop shift or of the norm estimates on an ill-conditioned loop, "
               f"see hinfsyn's Notes); gamma published: {cert.gamma:.8g}")
        res = res.replace(warnings=res.warnings + [msg])
        warnings.warn(msg, SynthesisWarning, stacklevel=2)
    CL = control.ss(*closed)
    X, Y = res.X, res.Y
    rcond = np.array([_rcond(plant.D12), _rcond(plant.D21), _rcond(X), _rcond(Y)])
    return HinfsynOutput(K, CL, float(cert.gamma), rcond, res, cert, estimates)
