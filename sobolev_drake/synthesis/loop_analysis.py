"""Analysis of a designed loop: poles, disk/gain/phase margins, S, T, KS, the W∞ channels.

:func:`loop_analysis` takes a synthesis result and the plant it controls and returns a frozen
:class:`LoopAnalysis`: closed-loop and controller poles (fastest, slowest, least damped),
loop-at-a-time and multivariable disk margins at the plant input and output, classic gain and
phase margins per loop, singular values of S, T, KS and of the performance channel w -> z on a
frequency grid, step and impulse responses of the performance channel, and warnings that say
what to change when the loop is faster than the plant warrants.  ``sobolev_drake.analysis_plots``
draws it; :meth:`LoopAnalysis.table` prints it.

Conventions (the synthesis' positive feedback, u = +K y): the plant is G = C2 (sI − A)⁻¹ B2 from
u to y, the controller u = K(s) y.  In the negative-feedback form of python-control the loops
are L_in = −K G (broken at the plant input) and L_out = −G K (at the output), the output
sensitivity S = (I + L_out)⁻¹ (output disturbance d to y), T = I − S, and KS maps d to u.
Loop-at-a-time margins break one channel with the others closed; the multivariable disk margin
(python-control's ``disk_margins``, an upper bound of μ by SLICOT ab13md) perturbs all channels
at once.  Balanced disks (skew 0): a disk margin α gives gain margins [(1 − α/2)/(1 + α/2),
(1 + α/2)/(1 − α/2)] and phase margin ±2 arctan(α/2) (Seiler, Packard, Gahinet 2020).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from ..validation import positive_scalar
from .certificates import as_matrix
from ..optional import python_control
from .interop import generalized_plant, is_linear_system, state_space_matrices
from .problem import GeneralizedPlant, SynthesisResult

__all__ = ["PoleSummary", "LoopMargins", "LoopAnalysis", "loop_analysis", "POLE_FACTOR"]

#: a closed-loop or controller pole faster than POLE_FACTOR x the plant's reference frequency
#: (its fastest mode, at least 1 rad/s) triggers a warning suggesting region=disk(...)
POLE_FACTOR = 100.0
#: frequency points of the singular-value grid and of the margin evaluations
POINTS = 300


@dataclass(frozen=True)
class PoleSummary:
    """Poles of a system and their extremes.

    Attributes
    ----------
    poles : ndarray
        Eigenvalues (rad/s), sorted by modulus (discrete systems: s = ln(z)/dt).
    fastest, slowest : float
        Largest and smallest modulus |λ| (rad/s; natural frequencies).
    min_damping : float
        Smallest damping ratio −Re λ / |λ| (1 for a pole at 0 by convention; negative when
        unstable).
    max_real : float
        Largest real part (< 0: stable).
    """

    poles: np.ndarray
    fastest: float
    slowest: float
    min_damping: float
    max_real: float

    @classmethod
    def of(cls, A: ArrayLike, dt: float | None = None) -> PoleSummary:
        """Summary of the eigenvalues of ``A`` (empty: NaN extremes).

        Parameters
        ----------
        A : array_like, shape (n, n)
            The matrix (a system's state matrix).
        dt : float, optional
            Sample period of a discrete system: its eigenvalues z are reported as the
            equivalent s = ln(z)/dt; deadbeat poles (z = 0) are left out.

        Returns
        -------
        PoleSummary
        """
        lam = np.linalg.eigvals(np.atleast_2d(A)) if np.size(A) else np.zeros(0, complex)
        if dt:
            lam = np.log(lam[np.abs(lam) > 1e-9].astype(complex)) / dt
        lam = lam[np.argsort(np.abs(lam))]
        if lam.size == 0:
            return cls(lam, np.nan, np.nan, np.nan, np.nan)
        mod = np.abs(lam)
        zeta = np.where(mod > 0, -lam.real / np.where(mod > 0, mod, 1.0), 1.0)
        return cls(lam, float(mod.max()), float(mod.min()), float(zeta.min()),
                   float(lam.real.max()))


@dataclass(frozen=True)
class LoopMargins:
    """Margins of the loop broken at the plant input or output.

    Attributes
    ----------
    where : str
        ``"input"`` or ``"output"``.
    disk : ndarray
        Loop-at-a-time balanced disk margin α per channel.
    disk_gain_db, disk_phase_deg : ndarray
        The gain (dB) and phase (degrees) margins the disks guarantee, per channel.
    gain_db, phase_deg : ndarray
        Classic gain margin (dB, inf when no phase crossover) and phase margin (degrees, inf
        when no gain crossover) per channel (python-control ``stability_margins``).
    multivariable_disk, multivariable_gain_db, multivariable_phase_deg : float
        Disk margin for simultaneous perturbations of all channels and its gain/phase margins.
    """

    where: str
    disk: np.ndarray
    disk_gain_db: np.ndarray
    disk_phase_deg: np.ndarray
    gain_db: np.ndarray
    phase_deg: np.ndarray
    multivariable_disk: float
    multivariable_gain_db: float
    multivariable_phase_deg: float


@dataclass(frozen=True)
class LoopAnalysis:
    """What :func:`loop_analysis` found (frozen; arrays are not copied).

    Attributes
    ----------
    plant, closed_loop : PoleSummary
        Poles of the open-loop plant A and of the closed loop (plant and controller).
    controller : PoleSummary or None
        Poles of a dynamic controller (None for a static gain).
    input_margins, output_margins : LoopMargins
        Margins at the plant input (u) and output (y).
    omega : ndarray
        Frequency grid (rad/s) of the singular values.
    sigma : dict
        {"S", "T", "KS", "Tzw" (when the plant is a GeneralizedPlant)}: arrays (k, len(omega))
        of singular values, largest first.
    loop_gain : ndarray, shape (nu, len(omega))
        Complex frequency response of each loop-at-a-time input loop L_i (for Bode plots).
    gamma : float or None
        The result's certified bound on the w -> z norm (None when unknown).
    hinf_norm : float or None
        Peak of sigma["Tzw"] on the grid (a lower bound of the channel norm).
    t : ndarray
        Times (s) of the responses.
    step, impulse : ndarray, shape (nz, nw, len(t)) or None
        Step and impulse responses of w -> z (None without a GeneralizedPlant; the impulse
        response leaves out the Dirac part D_cl δ(t)).
    max_gain : float
        Largest absolute entry of the controller's matrices (DK, CK, BK) / of K.
    reference_frequency : float
        The plant's reference frequency (rad/s) the pole warning compares with.
    warnings : tuple of str
        What looks wrong and the fix (empty when nothing does).
    dt : float or None
        Sample period of a discrete-time loop (None: continuous); its frequency responses are
        evaluated at z = exp(jω dt), ω up to the Nyquist frequency π/dt.
    """

    plant: PoleSummary
    closed_loop: PoleSummary
    controller: PoleSummary | None
    input_margins: LoopMargins
    output_margins: LoopMargins
    omega: np.ndarray
    sigma: dict
    loop_gain: np.ndarray
    gamma: float | None
    hinf_norm: float | None
    t: np.ndarray
    step: np.ndarray | None
    impulse: np.ndarray | None
    max_gain: float
    reference_frequency: float
    warnings: tuple
    dt: float | None = None

    @property
    def stable(self) -> bool:
        """True when every closed-loop pole has a negative real part."""
        return bool(self.closed_loop.max_real < 0)

    def table(self) -> str:
        """A short markdown table of poles and margins.

        Returns
        -------
        str
        """
        def f(x, fmt=".3g"):
            return "—" if x is None or (isinstance(x, float) and np.isnan(x)) else format(x, fmt)

        rows = [("closed loop", self.closed_loop), ("plant", self.plant)]
        if self.controller is not None:
            rows.insert(1, ("controller", self.controller))
        out = ["| poles | fastest [rad/s] | slowest [rad/s] | min damping | max Re [rad/s] |",
               "|---|---|---|---|---|"]
        out += [f"| {name} | {f(p.fastest)} | {f(p.slowest)} | {f(p.min_damping, '.2f')} | "
                f"{f(p.max_real)} |" for name, p in rows]
        out += ["", "| margins | disk α (per loop) | gain [dB] | phase [deg] | "
                "multivariable disk α / gain [dB] / phase [deg] |", "|---|---|---|---|---|"]
        for m in (self.input_margins, self.output_margins):
            out.append(f"| plant {m.where} | {', '.join(f(a, '.2f') for a in m.disk)} | "
                       f"{', '.join(f(a, '.1f') for a in m.disk_gain_db)} | "
                       f"{', '.join(f(a, '.1f') for a in m.disk_phase_deg)} | "
                       f"{f(m.multivariable_disk, '.2f')} / {f(m.multivariable_gain_db, '.1f')} / "
                       f"{f(m.multivariable_phase_deg, '.1f')} |")
        if self.gamma is not None:
            out += ["", f"γ (certified) = {f(self.gamma, '.4g')}, peak of σ(Tzw) on the grid = "
                        f"{f(self.hinf_norm, '.4g')}"]
        out += [f"- warning: {w}" for w in self.warnings]
        return "\n".join(out) + "\n"


def _loop_pieces(result, plant, C):
    """(A, B2, C2, GeneralizedPlant or None) from a GeneralizedPlant or a linear system."""
    if result.dt:      # discrete: ((A, B, C, D), nmeas, ncon) as sampled_data_plant
        if not (isinstance(plant, tuple) and len(plant) == 3 and isinstance(plant[0], tuple)):
            raise TypeError("plant of a discrete result must be ((A, B, C, D), nmeas, ncon), as "
                            f"sd.sampled_data_plant returns; got {type(plant).__name__}")
        gp, D22 = generalized_plant(plant[0], *plant[1:])
        if np.any(D22):
            raise ValueError("plant: D22 (feedthrough of u to y) must be zero")
        return gp.A, gp.B2, gp.C2, gp
    if isinstance(plant, GeneralizedPlant):
        if C is not None:
            raise TypeError("C: a GeneralizedPlant carries its measurement C2; do not pass C")
        return plant.A, plant.B2, plant.C2, plant
    if not is_linear_system(plant) and not (isinstance(plant, tuple) and len(plant) == 4):
        raise TypeError("plant must be a GeneralizedPlant (e.g. sd.winf_plant(...)) or a linear "
                        "system (Drake LinearSystem, python-control StateSpace, (A, B, C, D)), "
                        f"got {type(plant).__name__}")
    A, B, Cs, Ds = state_space_matrices(plant, "plant")
    if result.K is not None:        # state feedback: y = x
        Cm = np.eye(A.shape[0]) if C is None else as_matrix("C", C, (None, A.shape[0]))
    else:
        Cm = Cs if C is None else as_matrix("C", C, (None, A.shape[0]))
        if C is None and np.any(Ds):
            raise ValueError("plant: the measurement has a feedthrough D != 0; the loop needs "
                             "y = C x (pass C)")
    return A, B, Cm, None


def _controller_ss(result, ny, nu, dt):
    ct = python_control("loop_analysis")
    if getattr(result, "K", None) is not None:
        K = as_matrix("result.K", result.K, (nu, ny))
        return ct.ss(np.zeros((0, 0)), np.zeros((0, ny)), np.zeros((nu, 0)), K, dt), K
    AK, BK, CK, DK = (np.asarray(M, float) for M in result.controller)
    if BK.shape[1] != ny or CK.shape[0] != nu:
        raise ValueError(f"result: the controller maps {BK.shape[1]} measurements to "
                         f"{CK.shape[0]} inputs, the plant has ny = {ny}, nu = {nu}")
    return ct.ss(AK, BK, CK, DK, dt), AK


def _response(sys, omega):
    """Frequency response at s = jω, or at z = exp(jω dt) for a discrete system."""
    return np.asarray(sys(np.exp(1j * omega * sys.dt) if sys.isdtime(strict=True) else 1j * omega))


def _sigma(sys, omega):
    resp = _response(sys, omega)
    if resp.ndim == 1:
        resp = resp[None, None, :]
    return np.linalg.svd(np.moveaxis(resp, -1, 0), compute_uv=False).T, resp


def _disk_from_alpha(alpha):
    """Balanced (skew 0) disk margin α -> (gain margin dB, phase margin degrees)."""
    alpha = np.asarray(alpha, float)
    with np.errstate(divide="ignore"):
        gm = np.where(alpha < 2, 20 * np.log10((1 + alpha / 2) / np.maximum(1 - alpha / 2, 1e-300)),
                      np.inf)
    return gm, np.degrees(2 * np.arctan(alpha / 2))


def _margins(where, L, omega):
    """Loop-at-a-time and multivariable margins of the negative-feedback loop L (m x m)."""
    ct = python_control("loop_analysis")
    m = L.ninputs
    eye = ct.ss(np.zeros((0, 0)), np.zeros((0, m)), np.zeros((m, 0)), np.eye(m), L.dt)
    S = eye.feedback(L)
    Sjw = _response(S, omega).reshape(m, m, -1)
    # S_ii = 1/(1 + L_i) with L_i the loop i broken, the others closed (docstring)
    Lii = 1.0 / Sjw[np.arange(m), np.arange(m), :] - 1.0
    disk = 1.0 / np.max(np.abs(Sjw[np.arange(m), np.arange(m), :] - 0.5), axis=1)
    dgm, dpm = _disk_from_alpha(disk)
    gm, pm = np.full(m, np.inf), np.full(m, np.inf)
    for i in range(m):
        g, p, *_ = ct.stability_margins(ct.frd(Lii[i], omega))
        gm[i] = 20 * np.log10(g) if np.isfinite(g) and g > 0 else np.inf
        # |pm|: the closed loop is stable, a negative value is python-control's wrapping
        # of the phase at crossover for open-loop-unstable plants
        pm[i] = abs(p) if np.isfinite(p) else np.inf
    if m == 1:
        mdm, mgm, mpm = float(disk[0]), float(dgm[0]), float(dpm[0])
    else:
        mdm = float(ct.disk_margins(L, omega[::3])[0])
        mgm, mpm = (float(v) for v in _disk_from_alpha(mdm))
    return LoopMargins(where, disk, dgm, dpm, gm, pm, mdm, mgm, mpm), Lii


def _reference_frequency(fastest, bandwidth):
    if bandwidth is not None:
        return positive_scalar("bandwidth", bandwidth)
    return float(max(0.0 if np.isnan(fastest) else fastest, 1.0))


def _speed(summary, dt):
    """Fastest pole of a summary; discrete: the fastest oscillation |Im s| (a decay near z = 0
    is bounded by the sample rate and harmless)."""
    if summary is None or summary.poles.size == 0:
        return 0.0
    return float(np.abs(summary.poles.imag).max() if dt else summary.fastest)


def _warnings(cl, k_poles, ref, pole_factor, max_gain, gain_limit, dt):
    out = []
    limit = pole_factor * ref
    cl_speed, k_speed = _speed(cl, dt), _speed(k_poles, dt)
    worst = max(cl_speed, k_speed)
    if cl.max_real >= 0:
        out.append(f"the closed loop is unstable (pole with real part {cl.max_real:.3g}); "
                   "the controller does not belong to this plant")
    if dt:   # a disk R of the bilinear image s = (2/dt)(z - 1)/(z + 1) keeps z away from -1
        R = 2 / dt * np.tan(min(limit, 0.9 * np.pi / dt) * dt / 2)
        fix = (f"redesign with sd.hinf_discrete(..., region=sd.regions.disk({R:.3g})) (a disk "
               f"of the bilinear image s = (2/dt)(z - 1)/(z + 1): oscillations below about "
               f"{min(limit, 0.9 * np.pi / dt):.3g} rad/s)")
    else:
        fix = (f"redesign with region=sd.regions.disk({limit:.3g}) (poles within {limit:.3g} "
               "rad/s, LMI path) or weight the rates more (larger Gamma1)")
    if worst > limit:
        what = "controller" if k_speed >= cl_speed else "closed-loop"
        kind = "oscillating" if dt else "poles up to"
        out.append(f"{what} {kind} {'poles at ' if dt else ''}{worst:.3g} rad/s, "
                   f"{worst / ref:.3g} x the plant's reference frequency {ref:.3g} rad/s (limit "
                   f"{pole_factor:g} x = {limit:.3g} rad/s): such a loop needs a sample rate "
                   f"and actuators far beyond the plant's; {fix}")
    if gain_limit is not None and max_gain > gain_limit:
        out.append(f"controller gains up to {max_gain:.3g} exceed the bound {gain_limit:.3g}; "
                   f"redesign with a requested gamma above the optimum (gamma=...), a pole "
                   f"region ({fix.split('with ', 1)[1]}) or an input weight (input_weight=...)")
    return tuple(out)


def _grid(poles, omega, dt):
    if omega is not None:
        omega = np.asarray(omega, float)
        if omega.ndim != 1 or omega.size < 2 or np.any(omega <= 0) or not np.all(np.isfinite(omega)):
            raise ValueError(f"omega must be a 1-D array of at least 2 positive frequencies, "
                             f"got shape {omega.shape}")
        return np.sort(omega)
    mod = np.abs(poles)
    mod = mod[mod > 1e-9]
    lo = mod.min() if mod.size else 1.0
    hi = mod.max() if mod.size else 1.0
    if dt:   # up to just below the Nyquist frequency
        return np.logspace(np.log10(lo) - 2, np.log10(np.pi / dt * (1 - 1e-6)), POINTS)
    return np.logspace(np.log10(lo) - 2, np.log10(hi) + 2, POINTS)


def _responses(cl_sys, slow, fast):
    """Step and impulse responses on [0, t_final], t_final from the slowest decay rate."""
    ct = python_control("loop_analysis")
    t_final = min(8.0 / max(slow, 1e-6), 2000.0 * 2 * np.pi / max(fast, 1e-6), 1e4)
    dt = cl_sys.dt if cl_sys.isdtime(strict=True) else 0
    t = dt * np.arange(min(int(np.ceil(t_final / dt)), 2000) + 1) if dt else \
        np.linspace(0.0, t_final, 600)
    step = np.asarray(ct.step_response(cl_sys, t).outputs).reshape(cl_sys.noutputs, cl_sys.ninputs, -1)
    with warnings.catch_warnings():   # D != 0: the impulse's Dirac part is left out (documented)
        warnings.simplefilter("ignore", UserWarning)
        imp = np.asarray(ct.impulse_response(cl_sys, t).outputs).reshape(cl_sys.noutputs,
                                                                           cl_sys.ninputs, -1)
    return t, step, imp


def loop_analysis(result: SynthesisResult, plant: object, *,
                  C: ArrayLike | None = None, omega: ArrayLike | None = None,
                  bandwidth: float | None = None, pole_factor: float = POLE_FACTOR,
                  gain_limit: float | None = None) -> LoopAnalysis:
    """Poles, margins, S/T/KS and performance-channel singular values of a designed loop.

    Parameters
    ----------
    result : SynthesisResult
        A state-feedback (``result.K``, u = +K x) or output-feedback (``result.controller``)
        design; a discrete-time result (``result.dt > 0``, from
        :func:`~sobolev_drake.synthesis.discrete.hinf_discrete`) is analysed in z (poles reported as s = ln(z)/dt, frequencies up to π/dt).
    plant : GeneralizedPlant or linear system
        The plant: a :class:`GeneralizedPlant` (e.g. ``sd.winf_plant(A, B, C, D, Gamma0=...,
        Gamma1=...)``;
        then the performance channel w -> z is analysed too), or a linear system (Drake
        ``LinearSystem``, python-control ``StateSpace``, (A, B, C, D)) whose B is the control
        input and, for output feedback, whose C is the measurement.  For a discrete result:
        ``((A, B, C, D), nmeas, ncon)`` as :func:`~sobolev_drake.synthesis.discrete.
        sampled_data_plant` returns.
    C : array_like, optional
        Measurement y = C x of a linear-system plant (default: the system's C for output
        feedback, the identity for state feedback).
    omega : array_like, optional
        Frequency grid (rad/s); default 300 points two decades around the poles.
    bandwidth : float, optional
        The plant's reference frequency (rad/s) for the pole warning; default its fastest mode,
        at least 1 rad/s.
    pole_factor : float
        Warn when a closed-loop or controller pole is faster than ``pole_factor`` x the
        reference frequency (default :data:`POLE_FACTOR`).
    gain_limit : float, optional
        Warn when a controller matrix entry exceeds it in absolute value.

    Returns
    -------
    LoopAnalysis

    Raises
    ------
    TypeError
        When ``plant`` is neither a GeneralizedPlant nor a linear system, or C is given twice.
    ValueError
        When the controller does not fit the plant or ``omega`` is not a positive grid.

    Examples
    --------
    >>> import numpy as np
    >>> import sobolev_drake as sd
    >>> A, B, D = np.array([[0.0, 1.0], [-1.0, -0.5]]), np.array([[0.0], [1.0]]), np.eye(2)
    >>> P = sd.winf_plant(A, B, D=D, Gamma0=[1, 1], Gamma1=[0.1, 0.1])
    >>> res = sd.winf_state_feedback(A, B, D, Gamma0=[1, 1], Gamma1=[0.1, 0.1], gamma=2.0)
    >>> an = sd.loop_analysis(res, P)
    >>> an.stable, round(an.closed_loop.fastest, 3), round(an.closed_loop.min_damping, 2)
    (True, 3.162, 1.0)
    >>> bool(an.input_margins.disk[0] > 1), an.hinf_norm <= res.gamma, an.warnings
    (True, True, ())
    """
    ct = python_control("loop_analysis")
    pole_factor = positive_scalar("pole_factor", pole_factor)
    if gain_limit is not None:
        gain_limit = positive_scalar("gain_limit", gain_limit)
    A, B2, C2, gp = _loop_pieces(result, plant, C)
    if not isinstance(result, SynthesisResult):
        raise TypeError(f"result must be a SynthesisResult, got {type(result).__name__}")
    if result.controller is None:
        raise ValueError(f"result has no controller to analyse (method {result.method!r})")
    dt = result.dt or None
    n, nu, ny = A.shape[0], B2.shape[1], C2.shape[0]
    K_ss, K_data = _controller_ss(result, ny, nu, dt or 0)
    G = ct.ss(A, B2, C2, np.zeros((ny, nu)), dt or 0)
    L_in, L_out = -K_ss * G, -G * K_ss
    cl_A = G.feedback(K_ss, sign=+1).A if K_ss.nstates else A + B2 @ K_data @ C2
    cl = PoleSummary.of(cl_A, dt)
    k_poles = PoleSummary.of(K_data, dt) if K_ss.nstates else None
    plant_poles = PoleSummary.of(A, dt)
    w = _grid(np.r_[plant_poles.poles, cl.poles], omega, dt)
    in_m, Lii = _margins("input", L_in, w)
    out_m, _ = _margins("output", L_out, w)
    eye = ct.ss(np.zeros((0, 0)), np.zeros((0, ny)), np.zeros((ny, 0)), np.eye(ny), dt or 0)
    S = eye.feedback(L_out)
    sigma = {"S": _sigma(S, w)[0], "T": _sigma(eye - S, w)[0], "KS": _sigma(K_ss * S, w)[0]}
    gamma = getattr(result, "gamma", None)
    hnorm, t, step, imp = None, np.zeros(0), None, None
    if gp is not None:
        Acl, Bcl, Ccl, Dcl = (gp.closed_loop(controller=result.controller) if dt else
                              result.closed_loop(gp))
        tzw = ct.ss(Acl, Bcl, Ccl, Dcl, dt or 0)
        sigma["Tzw"] = _sigma(tzw, w)[0]
        hnorm = float(max(sigma["Tzw"][0].max(), np.linalg.norm(Dcl, 2)))
        t, step, imp = _responses(tzw, -cl.max_real, cl.fastest)
    gains = [K_data] if not K_ss.nstates else list(result.controller)[1:]
    max_gain = float(max(np.abs(np.asarray(M)).max(initial=0.0) for M in gains))
    ref = _reference_frequency(plant_poles.fastest, bandwidth)
    warns = _warnings(cl, k_poles, ref, pole_factor, max_gain, gain_limit, dt)
    return LoopAnalysis(plant_poles, cl, k_poles, in_m, out_m, w, sigma, Lii,
                        None if gamma is None else float(gamma), hnorm, t, step, imp, max_gain,
                        ref, warns, dt)
