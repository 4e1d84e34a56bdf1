"""Allocation of a mechanical law's generalized input u* to rotor commands (thesis 5.3.2).

:class:`RotorAllocation` is the ``allocation`` hook ``(u*, q, q̇) -> τ`` of
:class:`~sobolev_drake.systems.mechanical_controller.MechanicalController` for a vehicle whose
input matrix B(q) maps rotor commands (e.g. Ω²) to generalized forces:

* ``"pinv"`` — the thesis' τ = B†u* (5.118), unlimited;
* ``"clip"`` — B†u* saturated to the box [lo, hi];
* ``"bls"`` — bounded least squares min ‖u* − Bτ‖ s.t. lo ≤ τ ≤ hi ((7.84)–(7.86)).

The kind may be switched between runs, so one diagram serves every variant.

:class:`ForceAllocation` is the same bounded allocation as a LeafSystem for any model and any
number of rotors (:func:`allocate`), with optional rotor-speed inversion Ω = √(τ/k).
"""

from __future__ import annotations

from typing import NoReturn

import numpy as np
from numpy.typing import ArrayLike
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import LeafSystem, ValueProducer
from scipy.optimize import lsq_linear

from sobolev_drake.models.base import check_vector
from sobolev_drake.systems.bounded_ls import bounded_least_squares

__all__ = ["RotorAllocation", "ALLOCATION_KINDS", "allocate", "ForceAllocation"]

#: the allocation kinds :class:`RotorAllocation` accepts
ALLOCATION_KINDS = ("bls", "clip", "pinv")


class RotorAllocation:
    """Allocation callable ``(u*, q, q̇) -> τ`` (module docstring).

    Parameters
    ----------
    model : MechanicalModel
        The controller's model (its ``B(q)``).
    kind : str
        One of :data:`ALLOCATION_KINDS`.
    lo, hi : array_like
        Bounds of τ used by "clip" and "bls".
    max_tilt : float
        A run whose first two coordinates (roll, pitch of a multirotor) exceed this in magnitude
        has lost the vehicle: the call raises, which the closed-loop rig reports as the failure
        (a tumbling vehicle would make the error-controlled integrator crawl).
    """

    def __init__(self, model, kind: str, lo, hi, *, max_tilt: float = 1.4):
        self.model = model
        self.lo, self.hi = np.asarray(lo, float), np.asarray(hi, float)
        self.kind = kind
        self.max_tilt = float(max_tilt)

    @property
    def kind(self) -> str:
        """The allocation in use (settable between runs)."""
        return self._kind

    @kind.setter
    def kind(self, kind: str) -> None:
        if kind not in ALLOCATION_KINDS:
            raise ValueError(f"allocation must be one of {ALLOCATION_KINDS}, got {kind!r}")
        self._kind = kind

    def __call__(self, u, q, qd):
        if max(abs(q[0]), abs(q[1])) > self.max_tilt:
            raise RuntimeError(f"diverged: |ϕ|, |θ| = {abs(q[0]):.3g}, {abs(q[1]):.3g} rad "
                               f"> {self.max_tilt} rad")
        B = self.model.B(q)
        if self._kind == "bls":
            return bounded_least_squares(B, u, self.lo, self.hi)
        tau = np.linalg.pinv(B) @ u
        return np.clip(tau, self.lo, self.hi) if self._kind == "clip" else tau


def allocate(B: ArrayLike, u: ArrayLike, lo: ArrayLike, hi: ArrayLike,
             weights: ArrayLike | None = None) -> np.ndarray:
    """argmin ‖W (u − Bτ)‖ s.t. lo ≤ τ ≤ hi for any number of rotors: the library's bounded
    least squares when the box is finite, scipy's BVLS when a bound is infinite.

    Parameters
    ----------
    B : array_like, shape (n, m)
        Input matrix (generalized force per unit command).
    u : array_like, shape (n,)
        Desired generalized force.
    lo, hi : array_like, shape (m,)
        Command bounds (hi may be +inf).
    weights : array_like, shape (n,), optional
        Row weights W = diag(weights) (e.g. favour the torque rows); default all ones.

    Returns
    -------
    ndarray, shape (m,)

    Examples
    --------
    Two rotors pushing up at ±0.2 m: a 10 N lift and 0.4 N m roll torque, thrust ≤ 6 N each:

    >>> import numpy as np
    >>> from sobolev_drake.systems.rotor_allocation import allocate
    >>> B = np.array([[0.2, -0.2], [1.0, 1.0]])            # rows: roll torque, lift
    >>> allocate(B, [0.4, 10.0], [0, 0], [6, 6]).round(6).tolist()
    [6.0, 4.0]
    >>> allocate(B, [0.4, 20.0], [0, 0], [6, 6]).round(6).tolist()   # saturates
    [6.0, 6.0]
    """
    B, u = np.asarray(B, dtype=float), np.asarray(u, dtype=float)
    if weights is not None:
        w = np.asarray(weights, dtype=float)
        B, u = B * w[:, None], u * w
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    if np.all(np.isfinite(lo)) and np.all(np.isfinite(hi)):
        return bounded_least_squares(B, u, lo, hi)
    return lsq_linear(B, u, bounds=(lo, hi), method="bvls").x


class ForceAllocation(LeafSystem):
    """Desired generalized force → bounded rotor commands, for any model with B(q) (any number
    of rotors; propellers on tilting mounts too, their B(q) following the mount joints), with
    optional rotor-speed inversion.

    .. pydrake_system::

        name: ForceAllocation
        input_ports:
        - generalized_force
        - x
        output_ports:
        - command
        - residual

    ``generalized_force`` = u* (n, model coordinates, e.g. a controller's
    ``generalized_force``), ``x`` = [q; q̇] of the model; ``command`` = τ = :func:`allocate`
    (B(q), u*, lo, hi), or, with ``speed_constants`` k, the rotor speeds Ω = √(τ / k) of a
    command τ = k Ω² (thrust ∝ Ω², thesis (5.123)); ``residual`` = ‖W (u* − Bτ)‖.

    Double only: ``ToAutoDiffXd()``/``ToSymbolic()`` raise (the active set makes τ piecewise in
    u*); linearize with ``MatrixGain(pinv(B))`` in its place, which it equals while no bound
    is active.

    Parameters
    ----------
    model : MechanicalModel
        The model whose ``B(q)`` maps commands to generalized forces.
    lower, upper : array_like, optional
        Command bounds (default the model's ``input_lower``/``input_upper``).
    weights : array_like, shape (n,), optional
        Row weights of the residual.
    speed_constants : array_like, shape (m,), optional
        k_i > 0 of τ_i = k_i Ω_i²: output Ω instead of τ (lower bounds must then be ≥ 0).
    """

    def __init__(self, model, *, lower=None, upper=None, weights=None, speed_constants=None):
        super().__init__()
        n = model.n
        m = int(np.asarray(model.B(np.zeros(n))).shape[1])
        self.model = model
        self.lower = np.broadcast_to(np.asarray(model.input_lower if lower is None else lower,
                                                dtype=float), (m,)).copy()
        self.upper = np.broadcast_to(np.asarray(getattr(model, "input_upper", np.inf)
                                                if upper is None else upper, dtype=float), (m,)).copy()
        if np.any(np.isnan(self.lower)) or np.any(np.isnan(self.upper)) or np.any(self.lower > self.upper):
            raise ValueError(f"lower {self.lower} and upper {self.upper} must be ordered numbers")
        self.weights = None if weights is None else check_vector("weights", weights, n)
        self.speed_constants = None
        if speed_constants is not None:
            k = check_vector("speed_constants", np.broadcast_to(speed_constants, (m,)), m)
            if np.any(k <= 0) or np.any(self.lower < 0):
                raise ValueError(f"speed_constants must be > 0 (got {k}) and lower ≥ 0 (got "
                                 f"{self.lower}): Ω = √(τ/k) needs τ ≥ 0")
            self.speed_constants = k
        self.DeclareVectorInputPort("generalized_force", n)
        self.DeclareVectorInputPort("x", 2 * n)
        self._solve = self.DeclareCacheEntry(
            "allocation (tau, residual)",
            ValueProducer(allocate=lambda: AbstractValue.Make((None, None)), calc=self._calc),
            {self.all_input_ports_ticket()})
        feed = {self._solve.ticket()}
        self.DeclareVectorOutputPort("command", m, lambda c, o: o.SetFromVector(self._command(c)), feed)
        self.DeclareVectorOutputPort("residual", 1, lambda c, o: o.SetFromVector(
            [self._solve.Eval(c)[1]]), feed)

    def _calc(self, context, value):
        u = self.get_input_port(0).Eval(context)
        x = self.get_input_port(1).Eval(context)
        B = np.asarray(self.model.B(x[:self.model.n]), dtype=float)
        tau = allocate(B, u, self.lower, self.upper, self.weights)
        r = u - B @ tau
        value.set_value((tau, float(np.linalg.norm(r if self.weights is None else self.weights * r))))

    def _command(self, context):
        tau = self._solve.Eval(context)[0]
        if self.speed_constants is None:
            return tau
        return np.sqrt(np.maximum(tau, 0.0) / self.speed_constants)

    def _refusal(self, scalar):
        return RuntimeError(f"ForceAllocation does not convert to {scalar}: the bounded solution "
                            "is piecewise in u*; put MatrixGain(np.linalg.pinv(B)) in its place "
                            "instead to linearize")

    def ToAutoDiffXd(self) -> NoReturn:
        """Refused (see the class docstring).

        Raises
        ------
        RuntimeError
            Always.
        """
        raise self._refusal("AutoDiffXd")

    def ToSymbolic(self) -> NoReturn:
        """Refused (see the class docstring).

        Raises
        ------
        RuntimeError
            Always.
        """
        raise self._refusal("Expression")
