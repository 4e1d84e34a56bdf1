"""Discrete-time and sampled-data H∞/W∞ synthesis, certified in z.

A discrete generalized plant P(z) (inputs [w; u], outputs [z; y], python-control's partition) is
mapped to continuous time by the bilinear transform s = α (z − 1)/(z + 1), α = 2/dt, realised
so that it is an exact change of variable of the transfer function:

    A_c = α (A + I)⁻¹ (A − I),  B_c = √(2α) (A + I)⁻¹ B,  C_c = √(2α) C (A + I)⁻¹,
    D_c = D − C (A + I)⁻¹ B,

so P_c(s) = P(z) on the maps jω ↔ e^{jθ} (ω = α tan(θ/2)); stability and H∞ norms are
preserved, and so is the linear-fractional closed loop with any controller.  The continuous
problem is solved by :func:`~sobolev_drake.synthesis.interop.hinfsyn` (its D22 ≠ 0 from the
transform is removed by a loop shift), the controller mapped back by the inverse transform,
and the discrete closed loop is certified independently: spectral radius < 1, and its H∞ norm
by SLICOT ab13dd with ``dico='D'`` and by a sweep of the unit circle; the published γ is the
largest of the continuous certificate and the two estimates (x (1 + 1e-6)).

Sampled-data design (:func:`sampled_data_plant`): a continuous generalized plant with its
input u and disturbance w held by a zero-order hold over each period dt, sampled at t_k = k dt,
is exactly the discrete plant x_{k+1} = Φ x_k + Γ_w w_k + Γ_u u_k, z_k = C1 x_k + D11 w_k +
D12 u_k, y_k = C2 x_k + D21 w_k (Φ = e^{A dt}, Γ = ∫₀^dt e^{As} ds B).  With a one-sample
computation delay the command computed at t_k is applied on [t_{k+1}, t_{k+2}) and the plant
gets the state u_prev.  The certificate Σ|z_k|² ≤ γ² Σ|w_k|² (zero initial state) then holds
for the loop that runs: a continuous plant, a held disturbance, a controller that samples y and
holds u — the tests simulate that hybrid loop in Drake.  The continuous-time z between samples
is not covered (that needs the lifted sampled-data norm).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike
import scipy.linalg

from ..validation import positive_scalar
from ..optional import python_control
from .certificates import Certificate, as_matrix
from .controller import DynamicController
from .interop import hinfsyn
from .problem import DiscreteDesign, GeneralizedPlant, SynthesisResult

__all__ = ["bilinear_to_continuous", "bilinear_to_discrete",
           "discrete_state_space", "sampled_data_plant", "hinf_discrete", "discrete_hinf_norm"]

#: relative margin of the published γ over the independent norm estimates (ab13dd's tolerance
#: 1e-10, the sweep's grid only lowers its estimate)
CERTIFICATE_MARGIN = 1e-6
#: unit-circle points of the sweep (plus the peak refined by a local grid)
SWEEP_POINTS = 4000


def _abcd(A, B, C, D):
    A = as_matrix("A", A)
    n = A.shape[0]
    as_matrix("A", A, (n, n))
    B = as_matrix("B", B, (n, None))
    C = as_matrix("C", C, (None, n))
    return A, B, C, as_matrix("D", D, (C.shape[0], B.shape[1]))


def bilinear_to_continuous(A: ArrayLike, B: ArrayLike, C: ArrayLike, D: ArrayLike,
                           dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Norm-preserving bilinear map of a discrete system to continuous time (module docstring).

    Parameters
    ----------
    A, B, C, D : array_like
        The discrete system.
    dt : float
        Sample period; α = 2/dt.

    Returns
    -------
    tuple of ndarray
        (A_c, B_c, C_c, D_c).

    Raises
    ------
    ValueError
        When A has an eigenvalue at −1 (z = −1 maps to s = ∞).

    Examples
    --------
    >>> import numpy as np
    >>> from sobolev_drake.synthesis.discrete import bilinear_to_continuous, bilinear_to_discrete
    >>> Ac, Bc, Cc, Dc = bilinear_to_continuous([[0.5]], [[1.0]], [[1.0]], [[0.0]], dt=0.1)
    >>> Ac.round(6), Dc.round(6)                          # z = 0.5 <-> s = 20 (0.5-1)/1.5
    (array([[-6.666667]]), array([[-0.666667]]))
    >>> [M.round(12) for M in bilinear_to_discrete(Ac, Bc, Cc, Dc, dt=0.1)]
    [array([[0.5]]), array([[1.]]), array([[1.]]), array([[0.]])]
    """
    A, B, C, D = _abcd(A, B, C, D)
    alpha = 2.0 / positive_scalar("dt", dt)
    E = A + np.eye(A.shape[0])
    if A.size and np.linalg.cond(E) > 1e12:
        raise ValueError("A has an eigenvalue at -1 (Nyquist-frequency pole): the bilinear "
                         "transform maps it to s = infinity")
    Ei = np.linalg.inv(E)
    r = np.sqrt(2 * alpha)
    return alpha * Ei @ (A - np.eye(A.shape[0])), r * Ei @ B, r * C @ Ei, D - C @ Ei @ B


def bilinear_to_discrete(A: ArrayLike, B: ArrayLike, C: ArrayLike, D: ArrayLike,
                         dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Inverse of :func:`bilinear_to_continuous`.

    Parameters
    ----------
    A, B, C, D : array_like
        The continuous system.
    dt : float
        Sample period; α = 2/dt.

    Returns
    -------
    tuple of ndarray
        (A_d, B_d, C_d, D_d).

    Raises
    ------
    ValueError
        When A has an eigenvalue at α = 2/dt.
    """
    A, B, C, D = _abcd(A, B, C, D)
    alpha = 2.0 / positive_scalar("dt", dt)
    F = alpha * np.eye(A.shape[0]) - A
    if A.size and np.linalg.cond(F) > 1e12:
        raise ValueError(f"A has an eigenvalue at 2/dt = {alpha:g}: not mappable to discrete time")
    Fi = np.linalg.inv(F)
    r = np.sqrt(2 * alpha)
    return (alpha * np.eye(A.shape[0]) + A) @ Fi, r * Fi @ B, r * C @ Fi, D + C @ Fi @ B


def discrete_state_space(system: object, dt: float | None = None
                         ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, float]:
    """(A, B, C, D, dt) of a discrete-time linear system.

    Parameters
    ----------
    system : Drake LinearSystem with time_period > 0, python-control StateSpace with dt > 0,
        or tuple (A, B, C, D)
    dt : float, optional
        Sample period; required for a tuple, checked against the system's otherwise.

    Returns
    -------
    tuple
        (A, B, C, D, dt).

    Raises
    ------
    ValueError
        When the system is continuous-time or the periods disagree.
    """
    if isinstance(system, tuple) and len(system) == 4:
        own = None
        A, B, C, D = system
    elif callable(getattr(system, "A", None)):                      # Drake
        own = system.time_period() if hasattr(system, "time_period") else 0.0
        A, B, C, D = system.A(), system.B(), system.C(), system.D()
    elif all(hasattr(system, k) for k in ("A", "B", "C", "D")):      # python-control / scipy
        own = getattr(system, "dt", 0) or 0
        A, B, C, D = system.A, system.B, system.C, system.D
    else:
        raise TypeError("system must be a discrete Drake LinearSystem, a python-control "
                        f"StateSpace with dt > 0 or a tuple (A, B, C, D); got {type(system).__name__}")
    if own is not None:
        if own is True or not own:
            raise ValueError(f"system must be discrete-time with a numeric period, got period "
                             f"{own!r} (use sd.hinfsyn for continuous-time plants)")
        if dt is not None and not np.isclose(float(dt), float(own), rtol=1e-12):
            raise ValueError(f"dt = {dt} disagrees with the system's period {own}")
        dt = own
    if dt is None:
        raise TypeError("dt (the sample period, s) is required for a tuple (A, B, C, D)")
    return (*_abcd(A, B, C, D), positive_scalar("dt", dt))


def sampled_data_plant(plant: GeneralizedPlant, dt: float, *, computation_delay: bool = False
                       ) -> tuple[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray], int, int]:
    """Zero-order-hold discretization of a continuous generalized plant (module docstring).

    Parameters
    ----------
    plant : GeneralizedPlant
        Continuous plant (w and u held over each period, z and y sampled).
    dt : float
        Sample period (s).
    computation_delay : bool
        Model a one-sample computation delay (the plant state gains u_prev).

    Returns
    -------
    tuple
        ((A, B, C, D), nmeas, ncon): the discrete plant with inputs [w; u] and outputs
        [z; y] (python-control's partition), for :func:`hinf_discrete` (with ``dt``).

    Raises
    ------
    TypeError
        When ``plant`` is not a GeneralizedPlant.

    Examples
    --------
    A double integrator pushed by a force, its position measured with noise (w = [force;
    noise]), z = [position; u], run at 100 Hz with a one-sample computation delay:

    >>> import sobolev_drake as sd
    >>> P = sd.GeneralizedPlant.make([[0, 1], [0, 0]], B1=[[0, 0], [1, 0]], B2=[[0], [1]],
    ...                              C1=[[1, 0], [0, 0]], D12=[[0], [1]], C2=[[1, 0]],
    ...                              D21=[[0, 0.1]])
    >>> (A, B, C, D), nmeas, ncon = sd.sampled_data_plant(P, 0.01, computation_delay=True)
    >>> A.round(5).tolist()                         # state [x; u_prev]
    [[1.0, 0.01, 5e-05], [0.0, 1.0, 0.01], [0.0, 0.0, 0.0]]
    >>> res = sd.hinf_discrete(((A, B, C, D), nmeas, ncon), None, None, dt=0.01,
    ...                        computation_delay=True)
    >>> bool(res.discrete.norm_ab13dd <= res.gamma), res.discrete.computation_delay
    (True, True)
    """
    if not isinstance(plant, GeneralizedPlant):
        raise TypeError(f"plant must be a GeneralizedPlant, got {type(plant).__name__}")
    dt = positive_scalar("dt", dt)
    n, nw, nu, nz, ny = plant.n, plant.nw, plant.nu, plant.nz, plant.ny
    M = np.zeros((n + nw + nu, n + nw + nu))
    M[:n, :n], M[:n, n:n + nw], M[:n, n + nw:] = plant.A, plant.B1, plant.B2
    E = scipy.linalg.expm(M * dt)
    Phi, Gw, Gu = E[:n, :n], E[:n, n:n + nw], E[:n, n + nw:]
    if not computation_delay:
        A, B = Phi, np.hstack([Gw, Gu])
        C = np.vstack([plant.C1, plant.C2])
        D = np.block([[plant.D11, plant.D12], [plant.D21, np.zeros((ny, nu))]])
    else:   # state [x; u_prev]: the applied input is the previous command
        A = np.block([[Phi, Gu], [np.zeros((nu, n + nu))]])
        B = np.block([[Gw, np.zeros((n, nu))], [np.zeros((nu, nw)), np.eye(nu)]])
        C = np.block([[plant.C1, plant.D12], [plant.C2, np.zeros((ny, nu))]])
        D = np.block([[plant.D11, np.zeros((nz, nu))], [plant.D21, np.zeros((ny, nu))]])
    return (A, B, C, D), ny, nu


def discrete_hinf_norm(A: ArrayLike, B: ArrayLike, C: ArrayLike, D: ArrayLike, *,
                       points: int = SWEEP_POINTS) -> tuple[float, float]:
    """H∞ norm of a stable discrete system: (ab13dd estimate, unit-circle sweep peak).

    Parameters
    ----------
    A, B, C, D : array_like
        The discrete system (any period: the norm does not depend on it).
    points : int
        Sweep points on [0, π] (log-spaced near 0, then refined around the peak).

    Returns
    -------
    tuple of float
        (ab13dd's norm, the sweep's peak); the second is a lower bound.
    """
    from slycot import ab13dd
    A, B, C, D = _abcd(A, B, C, D)
    n, m, p = A.shape[0], B.shape[1], C.shape[0]
    gpeak, _ = ab13dd("D", "I", "N", "D" if np.any(D) else "Z", n, m, p, A, np.eye(n), B, C, D)

    def peak(theta):
        z = np.exp(1j * theta)
        G = C @ np.linalg.solve(z[:, None, None] * np.eye(n) - A, np.broadcast_to(B, (z.size, n, m))) + D
        s = np.linalg.svd(G, compute_uv=False)[:, 0]
        return s, theta[np.argmax(s)]

    theta = np.unique(np.r_[0.0, np.logspace(-6, np.log10(np.pi), points)])
    s, th = peak(theta)
    fine = np.clip(th + np.linspace(-1, 1, 401) * (np.pi / points) * 4, 0, np.pi)
    return float(gpeak), float(max(s.max(), peak(fine)[0].max()))


def hinf_discrete(plant: object, nmeas: int | None, ncon: int | None, *, dt: float | None = None,
                  computation_delay: bool = False, **options: Any) -> SynthesisResult:
    """H∞ (or W∞) output-feedback controller of a discrete plant, certified in z.

    Parameters
    ----------
    plant : discrete linear system or (A, B, C, D)
        Inputs [w; u], outputs [z; y] (python-control's partition): a Drake ``LinearSystem``
        with ``time_period > 0``, a python-control ``StateSpace`` with ``dt > 0``, a tuple
        with ``dt``, or the output of :func:`sampled_data_plant` (then ``nmeas``/``ncon``
        come with it).
    nmeas, ncon : int or None
        Number of measurements (last outputs) and controls (last inputs); None takes them
        from a :func:`sampled_data_plant` output.
    dt : float, optional
        Sample period (required for a tuple).
    computation_delay : bool
        Record that the plant models a one-sample computation delay (sampled-data plants).
    **options
        Passed to :func:`~sobolev_drake.synthesis.interop.hinfsyn` (``method``,
        ``time_limit``, ``gamma``, ...).

    Returns
    -------
    SynthesisResult
        ``dt`` the sample period; ``controller`` the discrete controller (``controller.dt =
        dt``), x_K[k+1] = AK x_K[k] + BK y_k, u_k = CK x_K[k] + DK y_k; ``gamma`` certified on
        the discrete closed loop (the largest of the continuous certificate and the two
        independent estimates in ``discrete``, x (1 + 1e-6)); ``certificate`` the check in z;
        ``discrete`` (:class:`~sobolev_drake.synthesis.problem.DiscreteDesign`) the closed
        loop, the two norm estimates, the spectral radius and the continuous design, whose
        method, solver, warnings and ``attempts`` (e.g. an LMI fallback of the default chain)
        the result repeats.  ``P``, ``X``, ``Y`` are None (the Lyapunov matrices of the
        bilinear image are in ``discrete.continuous``).

    Raises
    ------
    SynthesisError
        When the independent discrete check finds an unstable closed loop.

    Examples
    --------
    A lightly damped oscillator sampled at 100 Hz, w and u entering together, z = [x1; u],
    y = x1 + 0.1 w:

    >>> import control
    >>> import sobolev_drake as sd
    >>> Pc = control.ss([[0, 1], [-4, -0.2]], [[0, 0], [1, 1]],
    ...                 [[1, 0], [0, 0], [1, 0]], [[0, 0], [0, 1], [0.1, 0]])
    >>> P = control.c2d(Pc, 0.01)                       # inputs [w; u], outputs [z; y]
    >>> res = sd.hinf_discrete(P, nmeas=1, ncon=1)
    >>> res.dt, res.controller.dt, res.discrete.spectral_radius < 1, res.certified
    (0.01, 0.01, True, True)
    >>> d = res.discrete
    >>> bool(d.norm_ab13dd <= res.gamma and abs(d.norm_ab13dd - d.norm_sweep) < 1e-4)
    True
    """
    ct = python_control("hinf_discrete")
    if isinstance(plant, tuple) and len(plant) == 3 and isinstance(plant[0], tuple):
        plant, ny, nu = plant          # from sampled_data_plant
        nmeas = ny if nmeas is None else nmeas
        ncon = nu if ncon is None else ncon
    A, B, C, D, dt = discrete_state_space(plant, dt)
    Pc = ct.ss(*bilinear_to_continuous(A, B, C, D, dt))
    out = hinfsyn(Pc, nmeas, ncon, **options)
    cont = out.result
    Kc = out[0]
    AK, BK, CK, DK = bilinear_to_discrete(Kc.A, Kc.B, Kc.C, Kc.D, dt)
    cl = ct.ss(A, B, C, D, dt).lft(ct.ss(AK, BK, CK, DK, dt))
    Acl, Bcl, Ccl, Dcl = (np.asarray(M) for M in (cl.A, cl.B, cl.C, cl.D))
    ev = np.linalg.eigvals(Acl) if Acl.size else np.zeros(0)
    rho = float(np.abs(ev).max(initial=0.0))
    if not rho < 1:
        from .lmi import SynthesisError
        raise SynthesisError(f"the discrete closed loop is not stable (spectral radius {rho:.6g}) "
                             "although its bilinear image was certified")
    n_ab, n_sw = discrete_hinf_norm(Acl, Bcl, Ccl, Dcl)
    gamma = max(float(out[2]), n_ab * (1 + CERTIFICATE_MARGIN), n_sw * (1 + CERTIFICATE_MARGIN))
    # the certificate of the loop in z: stable (max_real_eig = ln ρ / dt, the slowest decay
    # rate, < 0), achieved = ab13dd's discrete norm, eigenvalues in z
    cert = Certificate(True, float(np.log(rho) / dt) if rho > 0 else -np.inf, n_ab, gamma,
                       CERTIFICATE_MARGIN, solver_status=cont.status, eigenvalues=ev)
    return SynthesisResult(
        "output_feedback", gamma, controller=DynamicController(AK, BK, CK, DK, dt),
        gamma_opt=cont.gamma_opt, feedthrough_bound=cont.feedthrough_bound, solver=cont.solver,
        backend=cont.backend, status=cont.status, timings=dict(cont.timings), certificate=cert,
        certificates=[cert], regularized=cont.regularized, warnings=list(cont.warnings),
        fallback=cont.fallback, method=cont.method, attempts=list(cont.attempts), dt=float(dt),
        discrete=DiscreteDesign((Acl, Bcl, Ccl, Dcl), n_ab, n_sw, rho, cont,
                                bool(computation_delay)))
