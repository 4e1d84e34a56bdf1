"""Linearization (7.57) of the tilt-rotor about a trim (thesis 7.3.1).

:func:`linearize` gives (A, B, D) in thesis state order [Δq; Δq̇; ∫Δψ ∫Δx ∫Δy ∫Δz] with inputs
Δu = [ΔnR ΔnL ΔτsR ΔτsL] (and the surfaces on request) and wind Δζ.  Drake's ``Linearize`` needs
AutoDiff, which the Python force systems do not provide, so the Jacobians are central differences
of the *Drake diagram's* ``CalcTimeDerivatives`` (plant + force system), step 1e-6 (truncation
error ~1e-10 relative).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sobolev_drake.tiltrotor.params import params_key
from sobolev_drake.tiltrotor.plant import add_tiltrotor
from sobolev_drake.tiltrotor.trim import Trim, trim_hover

__all__ = ["Linearization", "linearize"]


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

    def __iter__(self):
        """``A, B, D = linearize(...)`` unpacks the matrices."""
        return iter((self.A, self.B, self.D))


class _DerivativeEvaluator:
    """Time derivatives of the Drake diagram (plant + TiltrotorForces) at thesis-ordered inputs."""

    def __init__(self, params=None):
        from pydrake.systems.framework import DiagramBuilder
        b = DiagramBuilder()
        self.h = add_tiltrotor(b, params)
        self.diagram = b.Build()
        self.ctx = self.diagram.CreateDefaultContext()
        self.fctx = self.h.forces.GetMyMutableContextFromRoot(self.ctx)
        self.deriv = self.diagram.AllocateTimeDerivatives()

    def __call__(self, x, n, tau_s, delta, zeta):
        m = self.h.model
        self.h.set_state(self.ctx, self.diagram, x[:8], x[8:16])
        self.h.propeller_speed.FixValue(self.fctx, n)
        self.h.servo_torque.FixValue(self.fctx, tau_s)
        self.h.surface_deflection.FixValue(self.fctx, delta)
        self.h.wind.FixValue(self.fctx, zeta)
        self.diagram.CalcTimeDerivatives(self.ctx, self.deriv)
        d = self.deriv.CopyToVector()
        return np.concatenate([m.to_thesis(d[:8]), m.to_thesis(d[8:])])


_EVALUATORS: dict = {}


def linearize(trim: Trim | None = None, *, params=None, include_surfaces=False, eps=1e-6) -> Linearization:
    """Linearize the Drake diagram about ``trim`` (default: hover trim) with the integral states
    of (7.57).  Central differences of ``CalcTimeDerivatives`` (see module docstring).
    ``params``: default the parameters of the model the trim was computed on.

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
        Central-difference step (state and wind in their units; inputs relative,
        ``eps * max(1, |u|)``).

    Returns
    -------
    Linearization
        (A, B, D) of (7.57) with the integral states and the state/input names; unpacks as
        ``A, B, D``.
    """
    trim = trim_hover() if trim is None else trim
    params = trim.info["model"].params if params is None else params
    key = params_key(params)           # one Drake diagram per parameter value
    if key not in _EVALUATORS:
        _EVALUATORS[key] = _DerivativeEvaluator(params)
    f = _EVALUATORS[key]
    x0 = np.concatenate([trim.q, trim.qdot])
    u0 = trim.u if include_surfaces else trim.u[:4]
    nu = u0.size

    def call(x, u, zeta):
        delta = u[4:8] if include_surfaces else trim.delta
        return f(x, u[0:2], u[2:4], delta, zeta)

    A16 = np.zeros((16, 16))
    B16 = np.zeros((16, nu))
    D16 = np.zeros((16, 3))
    for j in range(16):
        e = np.zeros(16)
        e[j] = eps
        A16[:, j] = (call(x0 + e, u0, trim.zeta) - call(x0 - e, u0, trim.zeta)) / (2 * eps)
    for j in range(nu):
        e = np.zeros(nu)
        e[j] = eps * max(1.0, abs(u0[j]))
        B16[:, j] = (call(x0, u0 + e, trim.zeta) - call(x0, u0 - e, trim.zeta)) / (2 * e[j])
    for j in range(3):
        e = np.zeros(3)
        e[j] = eps
        D16[:, j] = (call(x0, u0, trim.zeta + e) - call(x0, u0, trim.zeta - e)) / (2 * eps)
    A = np.zeros((20, 20))
    A[:16, :16] = A16
    A[16:20, [4, 5, 6, 7]] = np.eye(4)       # d/dt ∫Δψ, ∫Δx, ∫Δy, ∫Δz
    B = np.zeros((20, nu))
    B[:16] = B16
    D = np.zeros((20, 3))
    D[:16] = D16
    from sobolev_drake.tiltrotor.params import ACTUATOR_NAMES, DOF_NAMES
    states = list(DOF_NAMES) + [f"d{n}" for n in DOF_NAMES] + ["int_psi", "int_x", "int_y", "int_z"]
    inputs = ["n_PR", "n_PL", "tau_sR", "tau_sL"] + (list(ACTUATOR_NAMES[4:]) if include_surfaces else [])
    return Linearization(A=A, B=B, D=D, trim=trim, state_names=states, input_names=inputs)

