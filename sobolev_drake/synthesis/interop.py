"""Linear systems in and controllers out: Drake, python-control and scipy interoperability.

Accepted wherever the synthesis takes a plant model:

* Drake ``LinearSystem`` / ``AffineSystem`` (e.g. from ``Linearize`` or
  ``FirstOrderTaylorApproximation``): its A, B, C, D (continuous time only; an affine
  system's offsets f0, y0 are the operating point, which the controller system takes as
  ``x_op``/``u_op``, see ``systems.linear_controllers.controller_system``);
* python-control ``StateSpace`` (continuous, ``dt == 0``) and scipy ``signal.StateSpace``;
* a tuple ``(A, B, C, D)`` of matrices.

python-control's partition convention for a generalized plant P: inputs [w; u] with the last
``ncon`` inputs the controls, outputs [z; y] with the last ``nmeas`` outputs the measurements.

Sign convention, the same everywhere in sobolev_drake: u = +K x for state feedback and
u = C_K x_K + D_K y for dynamic output feedback (positive feedback, as python-control's
``hinfsyn`` controller; Drake's ``LinearQuadraticRegulator`` returns K for u = −K x).
"""

from __future__ import annotations

import numpy as np

from .certificates import as_matrix
from .hinf import state_feedback
from .problem import DynamicController, GeneralizedPlant, SynthesisResult
from .output_feedback import output_feedback

__all__ = ["state_space_matrices", "is_linear_system", "generalized_plant", "to_statespace",
           "hinf_state_feedback", "hinf_output_feedback", "hinfsyn", "HinfsynOutput"]


def _system_kind(obj):
    """"drake" (methods A(), B(), ...), "statespace" (attributes A, B, C, D) or None."""
    if callable(getattr(obj, "A", None)) and callable(getattr(obj, "C", None)):
        return "drake"
    if not isinstance(obj, np.ndarray) and all(hasattr(obj, k) for k in ("A", "B", "C", "D")):
        return "statespace"
    return None


def is_linear_system(obj) -> bool:
    """True for a Drake Linear/AffineSystem, a python-control or scipy StateSpace.

    Parameters
    ----------
    obj : object

    Returns
    -------
    bool
    """
    return _system_kind(obj) is not None


def state_space_matrices(system, name="system"):
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
                             f"period {period}")
        A, B, C, D = system.A(), system.B(), system.C(), system.D()
    elif kind == "statespace":                                   # python-control / scipy
        dt = getattr(system, "dt", 0)
        if dt not in (0, None):
            raise ValueError(f"{name} must be continuous-time, got dt = {dt}")
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
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} must be an integer, got {value!r}")
    if not 1 <= value < upper:
        raise ValueError(f"{name} must be between 1 and {upper - 1} (the plant has {upper} "
                         f"{'outputs' if name == 'nmeas' else 'inputs'}), got {value}")
    return int(value)


def generalized_plant(system, nmeas=None, ncon=None):
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
    A, B, C, D = state_space_matrices(system, "P")
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


def hinf_state_feedback(plant, *, ncon=None, **options):
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


def hinf_output_feedback(plant, *, nmeas=None, ncon=None, **options):
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
    if not isinstance(plant, GeneralizedPlant) and nmeas is None:
        raise TypeError("nmeas (the number of measurements, the last outputs of the plant) is "
                        "required for a linear system")
    return output_feedback(_as_plant(plant, nmeas, ncon, "hinf_output_feedback"), **options)


def _shift_d22(controller: DynamicController, D22) -> DynamicController:
    """Controller for y = ... + D22 u from one designed for y − D22 u (loop shift)."""
    AK, BK, CK, DK = controller
    R = np.eye(DK.shape[0]) + DK @ D22
    if np.linalg.cond(R) > 1e12:
        raise ValueError("the loop with D22 is ill-posed: I + D_K D22 is singular")
    Ri = np.linalg.inv(R)
    return DynamicController(AK - BK @ D22 @ Ri @ CK, BK - BK @ D22 @ Ri @ DK, Ri @ CK, Ri @ DK)


def to_statespace(result_or_controller):
    """python-control ``StateSpace`` of a controller (input y or x, output u; u = +K x).

    Parameters
    ----------
    result_or_controller : SynthesisResult, DynamicController or gain matrix K

    Returns
    -------
    control.StateSpace
        Static gain (no state) for state feedback.
    """
    import control   # optional dependency (pip install sobolev_drake[control])
    obj = result_or_controller
    if isinstance(obj, SynthesisResult):
        obj = obj.K if obj.kind == "state_feedback" else obj.controller
    if isinstance(obj, DynamicController):
        return control.ss(obj.AK, obj.BK, obj.CK, obj.DK)
    K = as_matrix("K", obj)
    return control.ss(np.zeros((0, 0)), np.zeros((0, K.shape[1])), np.zeros((K.shape[0], 0)), K)


class HinfsynOutput(tuple):
    """``(K, CL, gamma, rcond)`` as ``control.hinfsyn`` returns them, plus ``.result``.

    Parameters
    ----------
    K : control.StateSpace
        Controller y → u (positive feedback, u = C_K x_K + D_K y).
    CL : control.StateSpace
        Closed loop w → z.
    gamma : float
        The certified bound.
    rcond : ndarray, shape (4,)
        Reciprocal condition numbers of [D12, D21, X, Y] (X, Y the solution's Lyapunov
        blocks; NaN where absent).
    result : SynthesisResult
        The full result with its certificate (not part of the tuple).

    Attributes
    ----------
    K, CL, gamma, rcond
        The tuple's entries by name.
    result : SynthesisResult
        As above.
    """

    def __new__(cls, K, CL, gamma, rcond, result):
        out = super().__new__(cls, (K, CL, gamma, rcond))
        out.result = result
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


def hinfsyn(P, nmeas, ncon, **options):
    """H∞ output-feedback synthesis with python-control's calling convention, certified.

    Parameters
    ----------
    P : control.StateSpace, Drake LinearSystem/AffineSystem, scipy StateSpace or (A, B, C, D)
        Generalized plant, inputs [w; u], outputs [z; y] (D22 ≠ 0 allowed: removed by a loop
        shift and put back into the controller).
    nmeas : int
        Number of measurements y (the last outputs).
    ncon : int
        Number of controls u (the last inputs).
    **options
        Passed to :func:`~sobolev_drake.synthesis.hinf.output_feedback` (``method``,
        ``time_limit``, ``gamma``, ``region``, ...).

    Returns
    -------
    HinfsynOutput
        Unpacks as ``K, CL, gamma, rcond`` like ``control.hinfsyn``; ``.result`` is the
        :class:`SynthesisResult` (certificate, warnings, attempts).
    """
    import control   # optional dependency, for the StateSpace objects returned
    plant, D22 = generalized_plant(P, nmeas, ncon)
    res = output_feedback(plant, **options)
    controller = res.controller if not np.any(D22) else _shift_d22(res.controller, D22)
    K = control.ss(*controller)
    CL = control.ss(*plant.closed_loop(controller=res.controller))
    X, Y = res.X, res.Y
    rcond = np.array([_rcond(plant.D12), _rcond(plant.D21), _rcond(X), _rcond(Y)])
    return HinfsynOutput(K, CL, float(res.gamma), rcond, res)
