"""Plant-side evaluations a mechanical control law needs at every sample: M(q), the bias
h = C q̇ + g + friction, B(q) and inverse dynamics, with the per-state caches and fast paths
that make them cheap (thesis (5.26)).

When the model keeps the base class' Drake evaluations and its coordinate map is a
permutation, states are written once into Drake's order and results read back by index
(bit-identical to the matrix products); inverse dynamics then uses a recursive Newton–Euler
pass (the compiled kernel when available, else Drake's CalcInverseDynamics).
"""

from __future__ import annotations

from types import ModuleType

import numpy as np
from numpy.typing import ArrayLike

from sobolev_drake.models.base import MechanicalModel
from sobolev_drake.native.rnea import cached_tree_kernel

__all__ = ["PlantDynamics"]


class PlantDynamics:
    """Cached dynamics of a :class:`~sobolev_drake.models.base.MechanicalModel` (module
    docstring).

    Parameters
    ----------
    model : MechanicalModel
        The controller's model of the plant.

    Attributes
    ----------
    fast : bool
        The model uses the base class' Drake evaluations of M, C q̇ and g.
    permutation : tuple or None
        :meth:`permutation_maps` of the model's coordinate map when ``fast``, else None.
    """

    def __init__(self, model):
        self.model = model
        self.n = model.n
        cls = type(model)
        self.fast = all(getattr(cls, k) is getattr(MechanicalModel, k) for k in ("M", "Cqdot", "g"))
        self.permutation = self.permutation_maps(getattr(model, "T", None)) if self.fast else None
        self._cache = {}

    def mass_and_bias(self, q: ArrayLike, qdot: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """(M(q), h = C q̇ + g + friction) at one state.

        One context update when the model uses the base class' Drake evaluations (the common
        case), else the model's own methods.  The last result is cached (a controller asks for
        u and u* at the same state); callers must not mutate the returned arrays.

        Parameters
        ----------
        q, qdot : array_like, shape (n,)
            Generalized coordinates and velocities, thesis order.

        Returns
        -------
        (ndarray, ndarray)
            M (n × n) and h (n,), thesis order.
        """
        key = (np.asarray(q, float).tobytes(), np.asarray(qdot, float).tobytes())
        if self._cache.get("dyn_key") == key:
            return self._cache["dyn"]
        out = self._dynamics_eval(q, qdot)
        self._cache["dyn_key"], self._cache["dyn"] = key, out
        return out

    def inverse_dynamics(self, q: ArrayLike, qdot: ArrayLike, acc: ArrayLike) -> np.ndarray:
        """M(q) acc + C(q, q̇) q̇ + g(q) (+ friction): the generalized force for a desired
        acceleration (full-state form of (5.26)); M, h cached per (q, q̇).

        Parameters
        ----------
        q, qdot : array_like, shape (n,)
            Generalized coordinates and velocities, thesis order.
        acc : array_like, shape (n,)
            Desired acceleration q̈.

        Returns
        -------
        ndarray, shape (n,)
            Generalized force, thesis order.
        """
        M, h = self.mass_and_bias(q, qdot)
        return M @ acc + h

    def recursive_inverse_dynamics(self, q: ArrayLike, qdot: ArrayLike, acc: ArrayLike) -> np.ndarray:
        """:meth:`inverse_dynamics` by a recursive Newton–Euler pass (gravity through the
        plant's force elements, no mass matrix): equal to rounding, much cheaper when only the
        force is needed once per state (the tilt-rotor law's u* per sample).  Models without the
        permutation fast path (own M, C q̇, g) use :meth:`inverse_dynamics`.  A per-sample path:
        the caller validates q, q̇ and ``acc`` (the laws do, once per sample).

        The pass is the compiled kernel ``native/rnea.c`` when it is built, switched on and
        covering the plant (``sobolev_drake.native.rnea``), else Drake's CalcInverseDynamics
        (:meth:`recursive_inverse_dynamics_drake`; ``benchmarks/speed_tiers.py`` times both).

        Parameters
        ----------
        q, qdot : ndarray, shape (n,)
            Generalized coordinates and velocities, thesis order (validated by the caller).
        acc : ndarray, shape (n,)
            Desired acceleration q̈.

        Returns
        -------
        ndarray, shape (n,)
            Generalized force, thesis order (friction included).
        """
        if self.permutation is None:
            return self.inverse_dynamics(q, qdot, acc)
        compiled = cached_tree_kernel(self._cache, self.model, self.permutation[0][:self.n])
        if compiled is None:
            return self.recursive_inverse_dynamics_drake(q, qdot, acc)
        tau = np.array(compiled[0].inverse_dynamics(compiled[1], q, qdot, acc))   # thesis order
        return tau if self.model.frictionless else tau + self.model.friction(qdot)

    def compiled_inverse_dynamics(self) -> tuple[ModuleType, object] | None:
        """(kernel module, capsule) of the compiled Newton–Euler pass in thesis order, or None
        (kernel not built or switched off, a plant it does not cover, no permutation map).

        ``module.inverse_dynamics(capsule, x, acc)`` with x = [q; q̇] returns M q̈ + C q̇ + g as
        a list (no friction): the per-sample call of a float fast path, bound once.

        Returns
        -------
        tuple or None
        """
        if self.permutation is None:
            return None
        return cached_tree_kernel(self._cache, self.model, self.permutation[0][:self.n])

    def recursive_inverse_dynamics_drake(self, q: ArrayLike, qdot: ArrayLike, acc: ArrayLike) -> np.ndarray:
        """:meth:`recursive_inverse_dynamics` by Drake's CalcInverseDynamics (the kernel's
        reference; ``benchmarks/speed_tiers.py``: ≈ 2× faster than :meth:`inverse_dynamics`).

        Requires a permutation coordinate map (``ValueError`` otherwise).

        Parameters
        ----------
        q, qdot : ndarray, shape (n,)
            Generalized coordinates and velocities, thesis order.
        acc : array_like, shape (n,)
            Desired acceleration q̈.

        Returns
        -------
        ndarray, shape (n,)
            Generalized force, thesis order (friction included).
        """
        if self.permutation is None:
            raise ValueError("recursive_inverse_dynamics_drake needs a permutation coordinate map")
        m = self.model
        plant, ctx = m.plant, m.context
        to_drake, to_thesis, _ = self.permutation
        plant.SetPositionsAndVelocities(ctx, np.concatenate([q, qdot])[to_drake])
        forces = self._cache.get("mbf")
        if forces is None:
            from pydrake.multibody.tree import MultibodyForces
            forces = self._cache["mbf"] = MultibodyForces(plant)
        plant.CalcForceElementsContribution(ctx, forces)     # gravity (and any force elements)
        tau = plant.CalcInverseDynamics(ctx, np.asarray(acc, float)[to_drake[:self.n]], forces)
        return tau[to_thesis] if m.frictionless else tau[to_thesis] + m.friction(qdot)

    def input_matrix(self, q: ArrayLike) -> np.ndarray:
        """B(q) of the model, cached for the last q.

        Parameters
        ----------
        q : array_like, shape (n,)
            Generalized coordinates, thesis order.

        Returns
        -------
        ndarray, shape (n, m)
        """
        key = np.asarray(q, float).tobytes()
        if self._cache.get("B_key") != key:
            self._cache["B_key"], self._cache["B"] = key, np.asarray(self.model.B(q), dtype=float)
        return self._cache["B"]

    @staticmethod
    def permutation_maps(T: ArrayLike | None
                         ) -> tuple[np.ndarray, np.ndarray, tuple[np.ndarray, np.ndarray]] | None:
        """Index maps of a coordinate permutation, or None when ``T`` is not one.

        Parameters
        ----------
        T : array_like or None
            The model's coordinate map, q_drake = T q_thesis.

        Returns
        -------
        tuple or None
            (index of [q; q̇] in Drake order, index of thesis order into Drake vectors, ``np.ix_``
            of the thesis-order mass matrix) when ``T`` is a permutation matrix, else None.
        """
        if T is None:
            return None
        T = np.asarray(T, dtype=float)
        n = T.shape[0]
        if (T.ndim != 2 or T.shape != (n, n) or not np.all((T == 0.0) | (T == 1.0))
                or not np.all(T.sum(axis=0) == 1.0) or not np.all(T.sum(axis=1) == 1.0)):
            return None
        to_thesis = np.argmax(T, axis=0)          # q_thesis[j] = q_drake[to_thesis[j]]
        to_drake = np.argsort(to_thesis)          # q_drake[i] = q_thesis[to_drake[i]]
        return (np.concatenate([to_drake, to_drake + n]), to_thesis, np.ix_(to_thesis, to_thesis))

    def _dynamics_eval(self, q, qdot):
        m = self.model
        if self.permutation is not None:
            # T is a permutation: index arrays give bit-identical results to the products
            # below at a fraction of the per-sample cost (one state write, no 8×8 matmuls)
            plant, ctx = m.plant, m.context
            to_drake, to_thesis, ix = self.permutation
            plant.SetPositionsAndVelocities(ctx, np.concatenate([q, qdot])[to_drake])
            M = plant.CalcMassMatrix(ctx)[ix]
            h = (plant.CalcBiasTerm(ctx) - plant.CalcGravityGeneralizedForces(ctx))[to_thesis]
        elif self.fast:
            plant, ctx, T = m.plant, m.context, m.T
            plant.SetPositions(ctx, T @ q)
            plant.SetVelocities(ctx, T @ qdot)
            M = T.T @ plant.CalcMassMatrix(ctx) @ T
            h = T.T @ (plant.CalcBiasTerm(ctx) - plant.CalcGravityGeneralizedForces(ctx))
        else:
            M, h = m.M(q), m.Cqdot(q, qdot) + m.g(q)
        return M, h + m.friction(qdot)
