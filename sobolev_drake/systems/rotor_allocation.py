"""Allocation of a mechanical law's generalized input u* to rotor commands (thesis 5.3.2).

:class:`RotorAllocation` is the ``allocation`` hook ``(u*, q, q̇) -> τ`` of
:class:`~sobolev_drake.systems.mechanical_controller.MechanicalController` for a vehicle whose
input matrix B(q) maps rotor commands (e.g. Ω²) to generalized forces:

* ``"pinv"`` — the thesis' τ = B†u* (5.118), unlimited;
* ``"clip"`` — B†u* saturated to the box [lo, hi];
* ``"bls"`` — bounded least squares min ‖u* − Bτ‖ s.t. lo ≤ τ ≤ hi ((7.84)–(7.86)).

The kind may be switched between runs, so one diagram serves every variant.
"""

from __future__ import annotations

import numpy as np

from sobolev_drake.systems.bounded_ls import bounded_least_squares

__all__ = ["RotorAllocation", "ALLOCATION_KINDS"]

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
