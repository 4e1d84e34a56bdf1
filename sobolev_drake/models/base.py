"""Euler–Lagrange view of a MultibodyPlant in the thesis' generalized coordinates.

Drake's generalized coordinates are related to the thesis' by a constant invertible map
``q_drake = T q_thesis`` (a permutation for the flying bodies, a permutation with scales where a
model uses e.g. a prismatic axle ``x = r ϕ``).  Because the flying bodies use the x, y, z, yaw,
pitch, roll joint chain of DESIGN §3, ``q̇ = v`` and Drake's

* ``CalcMassMatrix``                   is M(q),
* ``CalcBiasTerm``                     is C(q, q̇) q̇,
* ``CalcGravityGeneralizedForces``     is −g(q),

so the thesis' quantities are ``M_th = Tᵀ M T``, ``h_th = Tᵀ h`` and generalized forces map as
``τ_drake = T⁻ᵀ τ_th``.
"""

from __future__ import annotations

import numpy as np
from pydrake.multibody.plant import MultibodyPlant


def check_vector(name: str, value, size: int) -> np.ndarray:
    """Return ``value`` as a float vector of length ``size`` or raise a clear ``ValueError``.

    Rejects wrong sizes and non-finite entries (NaN/inf), naming the argument.  Called at every
    integrator stage by the controllers: the common case is one shape test and one reduction.
    """
    if getattr(value, "dtype", None) is not None and value.dtype.kind == "c":
        raise TypeError(f"{name} must be real, got complex entries")  # astype would drop .imag
    arr = np.asarray(value, dtype=float)
    if arr.shape == (size,) and np.isfinite(arr).all():
        return arr
    if arr.shape != (size,):
        raise ValueError(f"{name} must be a vector of length {size}, got shape {arr.shape}")
    raise ValueError(f"{name} must be finite, got {arr}")


class MechanicalModel:
    """M(q), C(q,q̇)q̇, g(q) and C(q,q̇)v of a MultibodyPlant in the thesis' coordinates.

    Parameters
    ----------
    plant : finalized ``MultibodyPlant`` (double) whose q̇ = v.
    coordinate_map : (n, n) matrix T with ``q_drake = T q_thesis`` (default identity).
    dof_names : thesis names of the generalized coordinates, in thesis order.
    name : human-readable model name.

    All public methods take and return thesis-ordered vectors.  One private context is reused,
    so instances are cheap to query but not thread-safe.
    """

    def __init__(self, plant: MultibodyPlant, *, coordinate_map=None, dof_names=None, name="model"):
        if not plant.is_finalized():
            raise ValueError("plant must be finalized before wrapping it in a MechanicalModel")
        if plant.num_positions() != plant.num_velocities():
            raise ValueError("MechanicalModel needs q̇ = v (no quaternion floating base); "
                             f"got nq = {plant.num_positions()}, nv = {plant.num_velocities()}")
        self.plant = plant
        self.name = name
        self.n = plant.num_positions()
        T = np.eye(self.n) if coordinate_map is None else np.asarray(coordinate_map, dtype=float)
        if T.shape != (self.n, self.n) or abs(np.linalg.det(T)) < 1e-12:
            raise ValueError(f"coordinate_map must be an invertible {self.n}x{self.n} matrix")
        self.T = T
        self.T_inv = np.linalg.inv(T)
        self.dof_names = list(dof_names) if dof_names is not None else [f"q{i}" for i in range(self.n)]
        if len(self.dof_names) != self.n:
            raise ValueError(f"dof_names must have {self.n} entries, got {len(self.dof_names)}")
        self.context = plant.CreateDefaultContext()

    # --- coordinate maps -------------------------------------------------------------------
    def to_drake(self, q_thesis) -> np.ndarray:
        """Thesis-ordered coordinates (or velocities) → Drake's."""
        return self.T @ np.asarray(q_thesis, dtype=float)

    def to_thesis(self, q_drake) -> np.ndarray:
        """Drake-ordered coordinates (or velocities) → thesis order."""
        return self.T_inv @ np.asarray(q_drake, dtype=float)

    def force_to_drake(self, tau_thesis) -> np.ndarray:
        """Thesis generalized force → Drake generalized force (τ_d = T⁻ᵀ τ_th)."""
        return self.T_inv.T @ np.asarray(tau_thesis, dtype=float)

    def force_to_thesis(self, tau_drake) -> np.ndarray:
        """Drake generalized force → thesis generalized force (τ_th = Tᵀ τ_d)."""
        return self.T.T @ np.asarray(tau_drake, dtype=float)

    def _set(self, q, qdot=None):
        q = check_vector("q", q, self.n)
        self.plant.SetPositions(self.context, self.T @ q)
        if qdot is not None:
            qdot = check_vector("qdot", qdot, self.n)
            self.plant.SetVelocities(self.context, self.T @ qdot)

    # --- Euler–Lagrange terms ----------------------------------------------------------------
    def M(self, q) -> np.ndarray:
        """Inertia matrix M(q) (thesis order)."""
        self._set(q)
        return self.T.T @ self.plant.CalcMassMatrix(self.context) @ self.T

    def Cqdot(self, q, qdot) -> np.ndarray:
        """Coriolis/centripetal vector C(q, q̇) q̇ (Drake's bias term)."""
        self._set(q, qdot)
        return self.T.T @ self.plant.CalcBiasTerm(self.context)

    def g(self, q) -> np.ndarray:
        """Gravity vector g(q) as in M q̈ + C q̇ + g = τ (i.e. minus Drake's gravity forces)."""
        self._set(q)
        return -self.T.T @ self.plant.CalcGravityGeneralizedForces(self.context)

    def C_times(self, q, qdot, v) -> np.ndarray:
        """C(q, q̇) v for any v by polarization (DESIGN §3).

        With Christoffel symbols (a, b) ↦ C(q, a) b is symmetric bilinear, hence
        C(q, q̇) v = ¼ [c(q̇ + v) − c(q̇ − v)] with c(a) = C(q, a) a.
        """
        qdot = check_vector("qdot", qdot, self.n)
        v = check_vector("v", v, self.n)
        return 0.25 * (self.Cqdot(q, qdot + v) - self.Cqdot(q, qdot - v))

    def B(self, q) -> np.ndarray:
        """Input matrix B(q) (thesis order, columns = actuator inputs). Overridden per model."""
        raise NotImplementedError(f"{self.name} does not define an input matrix")

    #: True when K(q̇) ≡ 0, so per-sample paths may skip adding it (a model overriding
    #: :meth:`friction` with a non-zero K must leave this False).
    frictionless: bool = False

    def friction(self, qdot) -> np.ndarray:
        """Velocity-dependent generalized friction K(q̇) (thesis order, on the left-hand side of
        M q̈ + C q̇ + K(q̇) + g = B u + w, cf. (4.30)).  Zero unless a model overrides it."""
        check_vector("qdot", qdot, self.n)
        return np.zeros(self.n)
