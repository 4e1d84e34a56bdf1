"""Linearization (7.57) of the tilt-rotor about a trim (thesis 7.3.1).

:func:`linearize` gives (A, B, D) in thesis state order [Δq; Δq̇; ∫Δψ ∫Δx ∫Δy ∫Δz] with inputs
Δu = [ΔnR ΔnL ΔτsR ΔτsL] (and the surfaces on request) and wind Δζ.  The Jacobians are Drake's
``FirstOrderTaylorApproximation`` (``Linearize`` without its equilibrium check: a level-flight
trim moves) of :func:`trim_diagram`, MultibodyPlant +
:class:`~sobolev_drake.tiltrotor.plant.TiltrotorForces`, i.e. AutoDiffXd through the plant and
the library's force systems (``TiltrotorForces_[AutoDiffXd]``).  ``method="central_difference"``
keeps the former central differences of the same diagram's ``CalcTimeDerivatives`` (step 1e-6,
the same numbers as before to the bit), which agree with it to their own accuracy
(``tests/tiltrotor/test_drake_native_tiltrotor.py``).  The W∞ syntheses amplify the difference
(~1e-8 on entries of size 1–20): the hover design's gain moves by ~3e-4 relative, its γ by 1e-7.

Where the forces have kinks the AutoDiffXd derivative is the central one along each state
coordinate, like the central differences': at the hover trim the rotors see no inflow, where
the thrust is not differentiable in the air velocity
(:func:`~sobolev_drake.tiltrotor.generic_forces.propeller_force_generic`), and in level flight
the sideslip is 0, a sample of the piecewise-linear β tables (``ScalarMath.lerp_rows``).

:func:`trim_diagram` is also the system to hand to Drake's ``LinearQuadraticRegulator(system,
context, Q, R)`` (``diagrams/tiltrotor_lqr_hover.py``).
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from pydrake.systems.framework import DiagramBuilder, OutputPortSelection
from pydrake.systems.primitives import (ConstantVectorSource, Demultiplexer,
                                        FirstOrderTaylorApproximation)

from sobolev_drake.tiltrotor.params import ACTUATOR_NAMES, DOF_NAMES, TiltrotorParams, params_key
from sobolev_drake.tiltrotor.plant import TiltrotorHandles, add_tiltrotor
from sobolev_drake.tiltrotor.trim import Trim, trim_hover

if TYPE_CHECKING:
    from pydrake.systems.framework import Context, Diagram

__all__ = ["Linearization", "linearize", "trim_diagram", "TRIM_INPUTS", "METHODS"]

#: the force-system inputs :func:`trim_diagram` can export, with their sizes
TRIM_INPUTS = {"propeller_speed": 2, "servo_torque": 2, "surface_deflection": 4, "wind": 3}
#: how :func:`linearize` differentiates
METHODS = ("drake", "central_difference")


@dataclass
class Linearization:
    """ẋ = A Δx + B Δu + D Δζ of (7.57), thesis order.

    Δx = [Δq (8); Δq̇ (8); ∫Δψ ∫Δx ∫Δy ∫Δz], Δu = [ΔnR ΔnL ΔτsR ΔτsL] (+ [Δδ] with
    ``include_surfaces``), Δζ = wind (inertial, m/s).

    Attributes
    ----------
    A : ndarray, shape (20, 20)
        State matrix (thesis state order ``state_names``).
    B : ndarray, shape (20, 4) or (20, 8)
        Input matrix (columns ``input_names``: ΔnR, ΔnL in rev/s, ΔτsR, ΔτsL in N m, and
        the deflections Δδ in rad with ``include_surfaces``).
    D : ndarray, shape (20, 3)
        Wind-disturbance matrix (columns: inertial Δζ x, y, z in m/s).
    trim : Trim
        The operating point linearized about.
    state_names : list of str
        Names of the 20 states: the coordinates, their rates (``d`` prefix) and
        ``int_psi``, ``int_x``, ``int_y``, ``int_z``.
    input_names : list of str
        Names of the input columns of ``B``.
    """

    A: np.ndarray
    B: np.ndarray
    D: np.ndarray
    trim: Trim
    state_names: list
    input_names: list

    def __iter__(self) -> Iterator[np.ndarray]:
        """``A, B, D = linearize(...)`` unpacks the matrices."""
        return iter((self.A, self.B, self.D))


def trim_diagram(trim: Trim | None = None, *, params: TiltrotorParams | None = None,
                 inputs: Sequence[str] = ("propeller_speed", "servo_torque")
                 ) -> tuple[Diagram, Context, TiltrotorHandles]:
    """The tilt-rotor as one Drake system at a trim, ready for ``Linearize`` or
    ``LinearQuadraticRegulator(system, context, Q, R)``.

    MultibodyPlant + SceneGraph + :class:`~sobolev_drake.tiltrotor.plant.TiltrotorForces`
    (:func:`~sobolev_drake.tiltrotor.plant.add_tiltrotor`); the force inputs named in
    ``inputs`` are stacked, in that order, in the one exported input port ``u``; the others
    of :data:`TRIM_INPUTS` are held at the trim by constant sources.  Its continuous state is
    the plant's, in Drake's order (``handles.model.T`` maps it to the thesis order); its output
    port ``x`` is the thesis-ordered state.  Every system in it converts to AutoDiffXd.

    Parameters
    ----------
    trim : Trim, optional
        Operating point (default :func:`~sobolev_drake.tiltrotor.trim.trim_hover`).
    params : TiltrotorParams, optional
        Parameters of the plant; default those of ``trim.info["model"]``.
    inputs : sequence of str, default ("propeller_speed", "servo_torque")
        Keys of :data:`TRIM_INPUTS` making up the port ``u``.

    Returns
    -------
    diagram : Diagram
        The system.
    context : Context
        Its context at the trim: state (q, q̇) and ``u`` fixed at the trim's values.
    handles : TiltrotorHandles
        Of the plant inside (:func:`~sobolev_drake.tiltrotor.plant.add_tiltrotor`).
    """
    trim = trim_hover() if trim is None else trim
    params = trim.info["model"].params if params is None else params
    inputs = tuple(inputs)
    if not inputs or len(set(inputs)) != len(inputs) or any(k not in TRIM_INPUTS for k in inputs):
        raise ValueError(f"inputs must be distinct keys of {tuple(TRIM_INPUTS)}, got {inputs!r}")
    values = {"propeller_speed": trim.n, "servo_torque": trim.tau_s,
              "surface_deflection": trim.delta, "wind": trim.zeta}
    b = DiagramBuilder()
    h = add_tiltrotor(b, params)
    demux = b.AddSystem(Demultiplexer([TRIM_INPUTS[k] for k in inputs]))
    b.ExportInput(demux.get_input_port(), "u")
    for i, name in enumerate(inputs):
        b.Connect(demux.get_output_port(i), getattr(h, name))
    for name in TRIM_INPUTS:
        if name not in inputs:
            src = b.AddSystem(ConstantVectorSource(np.asarray(values[name], float)))
            b.Connect(src.get_output_port(), getattr(h, name))
    b.ExportOutput(h.x, "x")
    diagram = b.Build()
    context = diagram.CreateDefaultContext()
    h.set_state(context, diagram, trim.q, trim.qdot)
    diagram.get_input_port(0).FixValue(context, np.concatenate([values[k] for k in inputs]))
    return diagram, context, h


_DIAGRAMS: dict = {}


def _jacobians(trim, params, method, eps):
    """(J_x (16 × 16), J_v (16 × 11)) of the thesis-ordered derivatives in the thesis state
    and v = [n, τs, δ, ζ], by Drake or central differences (relative step for n, τs, δ)."""
    key = params_key(params)           # one Drake diagram per parameter value
    if key not in _DIAGRAMS:
        _DIAGRAMS[key] = trim_diagram(trim, params=params, inputs=tuple(TRIM_INPUTS))
    diagram, ctx, h = _DIAGRAMS[key]
    perm = np.argmax(h.model.T, axis=0)              # q_thesis[j] = q_drake[perm[j]]
    perm16 = np.concatenate([perm, perm + 8])
    x0 = np.concatenate([trim.q, trim.qdot])
    v0 = np.concatenate([trim.n, trim.tau_s, trim.delta, trim.zeta])
    if method == "drake":
        h.set_state(ctx, diagram, trim.q, trim.qdot)
        diagram.get_input_port(0).FixValue(ctx, v0)
        # FirstOrderTaylorApproximation is Linearize without its equilibrium check: a
        # level-flight trim moves (ẋ = V), its Jacobians are still those of (7.57)
        lin = FirstOrderTaylorApproximation(
            diagram, ctx, input_port_index=diagram.get_input_port(0).get_index(),
            output_port_index=OutputPortSelection.kNoOutput)
        return lin.A()[np.ix_(perm16, perm16)], lin.B()[perm16]
    deriv = diagram.AllocateTimeDerivatives()
    model = h.model

    def f(x, v):
        h.set_state(ctx, diagram, x[:8], x[8:16])
        diagram.get_input_port(0).FixValue(ctx, v)
        diagram.CalcTimeDerivatives(ctx, deriv)
        d = deriv.CopyToVector()
        return np.concatenate([model.to_thesis(d[:8]), model.to_thesis(d[8:])])

    Jx, Jv = np.zeros((16, 16)), np.zeros((16, 11))
    for j in range(16):
        e = np.zeros(16)
        e[j] = eps
        Jx[:, j] = (f(x0 + e, v0) - f(x0 - e, v0)) / (2 * eps)
    for j in range(11):
        e = np.zeros(11)
        e[j] = eps * max(1.0, abs(v0[j])) if j < 8 else eps
        Jv[:, j] = (f(x0, v0 + e) - f(x0, v0 - e)) / (2 * e[j])
    return Jx, Jv


def linearize(trim: Trim | None = None, *, params: TiltrotorParams | None = None,
              include_surfaces: bool = False, eps: float = 1e-6,
              method: str = "drake") -> Linearization:
    """Linearize the Drake diagram about ``trim`` (default: hover trim) with the integral states
    of (7.57): Drake's ``FirstOrderTaylorApproximation`` (AutoDiffXd) of :func:`trim_diagram`, or central
    differences of its ``CalcTimeDerivatives`` (module docstring).

    Parameters
    ----------
    trim : Trim, optional
        Operating point (default :func:`trim_hover`).
    params : TiltrotorParams, optional
        Parameters of the Drake diagram differentiated; default those of
        ``trim.info["model"]``.
    include_surfaces : bool, default False
        Also linearize with respect to the four surface deflections δ (B gets 8 columns).
    eps : float, default 1e-6
        Central-difference step of ``method="central_difference"`` (state and wind in their
        units; inputs relative, ``eps * max(1, |u|)``); unused by ``"drake"``.
    method : {"drake", "central_difference"}, default "drake"
        Drake's AutoDiffXd derivatives, or the former central differences.

    Returns
    -------
    Linearization
        (A, B, D) of (7.57) with the integral states and the state/input names; unpacks as
        ``A, B, D``.
    """
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    if method == "central_difference" and not (np.isfinite(eps) and eps > 0):
        raise ValueError(f"eps must be a finite step > 0, got {eps!r}")
    trim = trim_hover() if trim is None else trim
    params = trim.info["model"].params if params is None else params
    Jx, Jv = _jacobians(trim, params, method, eps)
    nu = 8 if include_surfaces else 4
    A = np.zeros((20, 20))
    A[:16, :16] = Jx
    A[16:20, [4, 5, 6, 7]] = np.eye(4)       # d/dt ∫Δψ, ∫Δx, ∫Δy, ∫Δz
    B = np.zeros((20, nu))
    B[:16] = Jv[:, :nu]
    D = np.zeros((20, 3))
    D[:16] = Jv[:, 8:11]
    states = list(DOF_NAMES) + [f"d{n}" for n in DOF_NAMES] + ["int_psi", "int_x", "int_y", "int_z"]
    inputs = ["n_PR", "n_PL", "tau_sR", "tau_sL"] + (list(ACTUATOR_NAMES[4:]) if include_surfaces else [])
    return Linearization(A=A, B=B, D=D, trim=trim, state_names=states, input_names=inputs)
