"""Linearization of a :class:`~sobolev_drake.models.base.MechanicalModel` by Drake.

Shared by the linear experiments (balance-linear, quadrotor-polytopic).  ẋ = f(x, u, w) with
x = [q; q̇] (thesis order), f = [q̇; M(q)⁻¹(B(q) u + w − C(q,q̇)q̇ − g(q) − K(q̇))].

:func:`linearize_mechanical` differentiates the model's MultibodyPlant with Drake's
``FirstOrderTaylorApproximation`` (AutoDiffXd; issue #31).  The plant a model simulates is the
MultibodyPlant driven by the thesis force adapter (``ThesisForceAdapter``), which is a
double-only Python system, so the linearized diagram is built here instead: a clone of the
model's plant (it converts to AutoDiffXd natively) with the adapter's input mapping as Drake
systems,

* q-independent B: a ``MatrixGain`` T⁻ᵀ [B, I] from [u; w] to the plant's generalized force;
* a body-fixed actuator wrench (``body_wrench``, e.g. the quadrotor's rotors, whose B(q) turns
  with the body): Drake's ``Propeller`` system (six unit "propellers" along the body axes, the
  wrench W u as their commands) on the plant's spatial-force input, so ∂(B(q)u₀)/∂q is Drake's;
* the friction K(q̇), linear in the library's models, as the matrix K added to A afterwards.

Models replacing the plant's M, C q̇ or g by their own reading (``follows_own_equations``) and
models with another B(q) or a nonlinear friction are refused by name; for them the central
differences of the model's own equations remain (``h=``), as the accuracy reference of the
tests (:func:`central_jacobian`).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.plant import Propeller, PropellerInfo
from pydrake.systems.framework import DiagramBuilder, OutputPortSelection
from pydrake.systems.primitives import FirstOrderTaylorApproximation, MatrixGain
from scipy.linalg import block_diag

from sobolev_drake.models.base import MechanicalModel, check_vector
from sobolev_drake.validation import real_matrix

__all__ = ["mechanical_rhs", "central_jacobian", "linearize_mechanical"]


def mechanical_rhs(model: MechanicalModel, q: ArrayLike, qdot: ArrayLike, u: ArrayLike,
                   w: ArrayLike) -> np.ndarray:
    """ẋ = [q̇; M(q)⁻¹(B(q) u + w − C(q,q̇)q̇ − g(q) − K(q̇))] in thesis order (cf. (4.30)).

    Parameters
    ----------
    model : MechanicalModel
        The model.
    q, qdot : array_like, shape (n,)
        Configuration and velocity (thesis order).
    u : array_like
        Actuator inputs.
    w : array_like, shape (n,)
        Generalized disturbance force.

    Returns
    -------
    ndarray, shape (2n,)
    """
    tau = model.B(q) @ np.atleast_1d(u) + w - model.Cqdot(q, qdot) - model.g(q) - model.friction(qdot)
    return np.r_[qdot, np.linalg.solve(model.M(q), tau)]


def central_jacobian(fun: Callable[[np.ndarray], np.ndarray], n: int, h: float) -> np.ndarray:
    """Columns (fun(h e_i) − fun(−h e_i)) / 2h, i = 1..n: the Jacobian of ``fun`` at 0.

    Parameters
    ----------
    fun : callable
        Vector function of an n-vector.
    n : int
        Number of columns.
    h : float
        Step (> 0).

    Returns
    -------
    ndarray, shape (len(fun(0)), n)
    """
    if not h > 0:
        raise ValueError(f"step h must be positive, got {h!r}")
    return np.column_stack([(fun(h * e) - fun(-h * e)) / (2 * h) for e in np.eye(n)])


def linearize_mechanical(model: MechanicalModel, q0: ArrayLike, qdot0: ArrayLike, u0: ArrayLike,
                         w0: ArrayLike | None = None, *,
                         body_wrench: tuple[str, ArrayLike] | None = None, h: float | None = None,
                         h_u: float | None = None,
                         h_w: float | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(A, B, D) of ẋ = f(x, u, w) at (q0, q̇0, u0, w0), by Drake (or central differences).

    State x = [q; q̇] in thesis order (size 2n), u the actuator vector of ``model.B`` (size m),
    w the generalized disturbance force (size n), so A is 2n × 2n, B 2n × m, D 2n × n
    (D = [0; M(q0)⁻¹]).  The point need not be an equilibrium: the Jacobians are of f itself.
    By default Drake's ``FirstOrderTaylorApproximation`` differentiates the model's plant
    (module docstring; exact to rounding).

    Parameters
    ----------
    model : MechanicalModel
        The model (its plant is cloned, never modified).
    q0, qdot0 : array_like, shape (n,)
        Configuration and velocity of the point (thesis order).
    u0 : array_like, shape (m,)
        Actuator inputs of the point.
    w0 : array_like, shape (n,), optional
        Disturbance of the point (zero by default).
    body_wrench : (str, array_like (6, m)), optional
        ``(body name, W)``: B(q) u is the generalized force of the wrench W u applied at the
        origin of that body, in body axes (rows torque, then force), e.g. the quadrotor's
        ``("body", model.body_wrench_matrix())``.  Without it B must not depend on q.
    h : float, optional
        Given (or ``h_u`` / ``h_w`` given): central differences of the model's own equations
        with state step ``h`` (default 1e-6) instead of Drake; the accuracy reference.
    h_u, h_w : float, optional
        Input / disturbance steps of the central differences (default ``h``; f is affine in u
        and w, so large steps are exact and avoid round-off).

    Returns
    -------
    A : ndarray, shape (2n, 2n)
    B : ndarray, shape (2n, m)
    D : ndarray, shape (2n, n)
    """
    n = model.n
    q0 = check_vector("q0", q0, n)
    qdot0 = check_vector("qdot0", qdot0, n)
    u0 = np.atleast_1d(np.asarray(u0, dtype=float))
    w0 = np.zeros(n) if w0 is None else check_vector("w0", w0, n)
    if h is None and h_u is None and h_w is None:
        return _drake_linearization(model, q0, qdot0, u0, w0, body_wrench)
    h = 1e-6 if h is None else h
    x0 = np.r_[q0, qdot0]

    def f(x, u, w):
        return mechanical_rhs(model, x[:n], x[n:], u, w)

    A = central_jacobian(lambda dx: f(x0 + dx, u0, w0), 2 * n, h)
    B = central_jacobian(lambda du: f(x0, u0 + du, w0), u0.size, h if h_u is None else h_u)
    D = central_jacobian(lambda dw: f(x0, u0, w0 + dw), n, h if h_w is None else h_w)
    return A, B, D


_FALLBACK = "pass h= for central differences of the model's own equations"


def _refuse_own_equations(model):
    own = [name for name in ("M", "Cqdot", "g")
           if getattr(type(model), name) is not getattr(MechanicalModel, name)]
    if own or getattr(model, "follows_own_equations", False):
        raise ValueError(
            f"model {model.name!r} ({type(model).__name__}) replaces its plant's equations "
            f"({', '.join(own) or 'follows_own_equations'}), and Drake's linearization "
            f"differentiates the MultibodyPlant, not them: {_FALLBACK}, or use the model's "
            "closed-form linearization")


def _friction_matrix(model, qdot0):
    """K with K(q̇) = K q̇ (columns K(e_i), exact for a linear friction, which is checked)."""
    n = model.n
    K = np.column_stack([model.friction(e) for e in np.eye(n)])
    for v in (np.zeros(n), qdot0, np.linspace(-1.0, 2.0, n)):
        got, want = model.friction(v), K @ v
        if not np.allclose(got, want, rtol=1e-10, atol=1e-10 * (np.abs(K).max() * np.abs(v).max())):
            raise ValueError(f"model {model.name!r}: the friction K(q̇) is not linear in q̇ "
                             f"(K({v.tolist()}) = {got.tolist()}, the linear map gives "
                             f"{want.tolist()}), so it cannot enter as a matrix: {_FALLBACK}")
    return K


def _constant_input_matrix(model, q0):
    B0 = model.B(q0)
    for q in (q0 + 0.5, q0 - np.linspace(0.3, 0.7, model.n)):
        change = np.abs(model.B(q) - B0).max()
        if change > 1e-12 * np.abs(B0).max():
            raise ValueError(
                f"model {model.name!r}: B(q) depends on q (max |B(q) − B(q0)| = {change:.3g} at "
                f"q = {q.tolist()}); give body_wrench=(body name, W) if it is a body-fixed "
                f"actuator wrench, or {_FALLBACK}")
    return B0


def _axis_frame(k):
    """A pose at the body origin whose z axis is body axis k (0, 1, 2 = x, y, z)."""
    return RigidTransform(RotationMatrix(np.roll(np.eye(3), 2 - k, axis=1)), np.zeros(3))


def _drake_linearization(model, q0, qdot0, u0, w0, body_wrench):
    _refuse_own_equations(model)
    n, Tinv_T = model.n, model.T_inv.T
    B0 = model.B(q0)
    m = B0.shape[1]
    u0 = check_vector("u0", u0, m)
    K = _friction_matrix(model, qdot0)
    builder = DiagramBuilder()
    plant = builder.AddSystem(model.plant.Clone())
    if body_wrench is None:
        _constant_input_matrix(model, q0)
        gain = builder.AddSystem(MatrixGain(Tinv_T @ np.hstack([B0, np.eye(n)])))
        builder.Connect(gain.get_output_port(), plant.get_applied_generalized_force_input_port())
        builder.ExportInput(gain.get_input_port(), "uw")
    else:
        try:
            body_name, W = body_wrench
        except (TypeError, ValueError):
            raise TypeError("body_wrench must be a (body name, W) pair, got "
                            f"{type(body_wrench).__name__}") from None
        W = real_matrix("body_wrench W", W, (6, m))
        body = plant.GetBodyByName(body_name).index()
        props = builder.AddSystem(Propeller(
            [PropellerInfo(body, _axis_frame(k), 0.0, 1.0) for k in range(3)]
            + [PropellerInfo(body, _axis_frame(k), 1.0, 0.0) for k in range(3)]))
        to_props = builder.AddSystem(MatrixGain(np.hstack([W, np.zeros((6, n))])))
        to_force = builder.AddSystem(MatrixGain(np.hstack([np.zeros((n, m)), Tinv_T])))
        builder.Connect(plant.get_body_poses_output_port(), props.get_body_poses_input_port())
        builder.Connect(to_props.get_output_port(), props.get_command_input_port())
        builder.Connect(props.get_spatial_forces_output_port(),
                        plant.get_applied_spatial_force_input_port())
        builder.Connect(to_force.get_output_port(), plant.get_applied_generalized_force_input_port())
        builder.ExportInput(to_props.get_input_port(), "uw")
        builder.ConnectInput("uw", to_force.get_input_port())
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    plant_context = plant.GetMyMutableContextFromRoot(context)
    plant_context.SetStateAndParametersFrom(model.context)   # e.g. a PlantModel's damping
    plant.SetPositionsAndVelocities(plant_context, np.r_[model.to_drake(q0), model.to_drake(qdot0)])
    diagram.get_input_port(0).FixValue(context, np.r_[u0, w0 - model.friction(qdot0)])
    taylor = FirstOrderTaylorApproximation(diagram, context,
                                           input_port_index=diagram.get_input_port(0).get_index(),
                                           output_port_index=OutputPortSelection.kNoOutput)
    P, P_inv = block_diag(model.T, model.T), block_diag(model.T_inv, model.T_inv)
    A = P_inv @ taylor.A() @ P
    BD = P_inv @ taylor.B()
    B, D = BD[:, :m], BD[:, m:]
    A[:, n:] -= D @ K            # the friction −K q̇ enters like the disturbance w
    if not np.allclose(B, D @ B0, rtol=1e-9, atol=1e-12 * np.abs(B).max()):
        raise ValueError(f"body_wrench {body_wrench[0]!r} does not reproduce model.B(q0) of "
                         f"model {model.name!r} (∂f/∂u = {B.tolist()}, [0; M⁻¹B(q0)] = "
                         f"{(D @ B0).tolist()}): check the body and the rows (torque, force)")
    return A, B, D
