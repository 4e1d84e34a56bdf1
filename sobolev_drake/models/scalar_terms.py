"""Euler–Lagrange terms of a :class:`~sobolev_drake.models.base.MechanicalModel` for any Drake
scalar type: ``float``, ``AutoDiffXd`` (Drake's ``Linearize``, gradients) and symbolic
``Expression`` (``ToSymbolic``).

The per-sample paths of the library (``systems.plant_dynamics.PlantDynamics``: the permutation
fast path, the compiled Newton–Euler kernel) are the double specialization; a scalar-converted
system evaluates the same model here instead (the two are tested equal on doubles):

* the terms a model takes from its MultibodyPlant (the base class' ``M``, ``Cqdot``, ``g``)
  come from a copy of the plant converted to the scalar type (``plant.ToScalarType[T]()``),
  whose context gets the model's parameters (copied from ``model.context``);
* a term the model overrides (e.g. the arm's printed inertia matrix) is the model's own method,
  which must then accept numpy arrays of that scalar type (``TypeError`` naming the method
  otherwise);
* B(q): a :class:`~sobolev_drake.models.base.PlantModel`'s actuation matrix is constant, so it
  is read once; any other model's ``B`` is called with the scalar-typed q;
* friction K(q̇): zero for the base class, D q̇ for a PlantModel (joint damping), else the
  model's method.

Small linear algebra helpers (:func:`solve`, :func:`inverse`, :func:`pseudo_inverse`) keep
double inputs on LAPACK and use ``pydrake.math.inv`` for object arrays.
"""

from __future__ import annotations

import contextlib

import numpy as np
from numpy.typing import ArrayLike
import pydrake.math as drake_math
from pydrake.autodiffutils import AutoDiffXd
from pydrake.symbolic import Expression, Variable

from sobolev_drake.models.base import MechanicalModel, PlantModel, check_vector

__all__ = ["ScalarTerms", "scalar_type", "scalar_vector", "quiet", "solve", "inverse",
           "pseudo_inverse"]


def scalar_type(*arrays: ArrayLike) -> type:
    """The Drake scalar type of the entries: ``AutoDiffXd`` or ``Expression`` when any entry is
    one (a ``Variable`` counts as an Expression), else ``float``.

    Parameters
    ----------
    *arrays : array_like
        Arrays (or scalars) to inspect.

    Returns
    -------
    type
        ``float``, ``AutoDiffXd`` or ``Expression``.
    """
    for a in arrays:
        a = np.asarray(a)
        if a.dtype != object:
            continue
        for x in a.flat:
            if isinstance(x, AutoDiffXd):
                return AutoDiffXd
            if isinstance(x, (Expression, Variable)):
                return Expression
    return float


def quiet(scalar: type) -> contextlib.AbstractContextManager[object]:
    """Context that silences numpy's "invalid value" warning for ``Expression`` arithmetic.

    numpy checks the FPU's flags after an object-array loop, and Drake's symbolic arithmetic
    leaves the "invalid" flag set when it simplifies products with free variables, so numpy
    warns about a NaN that does not exist.  Other scalar types keep the warning.

    Parameters
    ----------
    scalar : type
        The scalar type being evaluated.

    Returns
    -------
    context manager
    """
    return np.errstate(invalid="ignore") if scalar is Expression else contextlib.nullcontext()


def scalar_vector(name: str, value: ArrayLike, size: int) -> np.ndarray:
    """``check_vector`` for numbers; an array of Drake scalars (``AutoDiffXd``, ``Expression``,
    numpy dtype object) is checked for its size only and returned as is.

    Parameters
    ----------
    name : str
        Argument name used in the error message.
    value : array_like
        The vector.
    size : int
        Required length.

    Returns
    -------
    ndarray, shape (size,)
        Floats, or the object array unchanged.
    """
    arr = np.asarray(value)
    if arr.dtype != object:
        return check_vector(name, value, size)
    if arr.shape != (size,):
        raise ValueError(f"{name} must be a vector of length {size}, got shape {arr.shape}")
    return arr


def inverse(A: ArrayLike) -> np.ndarray:
    """A⁻¹ for a double matrix (LAPACK) or a matrix of Drake scalars (``pydrake.math.inv``).

    Parameters
    ----------
    A : ndarray, shape (k, k)
        Invertible matrix.

    Returns
    -------
    ndarray, shape (k, k)
    """
    A = np.asarray(A)
    return np.linalg.inv(A) if A.dtype != object else drake_math.inv(A)


def solve(A: ArrayLike, b: ArrayLike) -> np.ndarray:
    """A⁻¹ b: LAPACK's ``solve`` when both are double, else :func:`inverse` times b.

    Parameters
    ----------
    A : ndarray, shape (k, k)
        Invertible matrix.
    b : ndarray, shape (k,) or (k, m)
        Right-hand side.

    Returns
    -------
    ndarray
    """
    A, b = np.asarray(A), np.asarray(b)
    if A.dtype != object and b.dtype != object:
        return np.linalg.solve(A, b)
    return inverse(A) @ b


def pseudo_inverse(A: ArrayLike) -> np.ndarray:
    """Moore–Penrose inverse: ``numpy.linalg.pinv`` for doubles; for Drake scalars the
    full-rank closed forms Aᵀ(AAᵀ)⁻¹ (wide) or (AᵀA)⁻¹Aᵀ (tall), equal to it when A has full
    rank (the actuation assumptions of the laws).

    Parameters
    ----------
    A : ndarray, shape (k, m)
        Matrix of full rank.

    Returns
    -------
    ndarray, shape (m, k)
    """
    A = np.asarray(A)
    if A.dtype != object:
        return np.linalg.pinv(A)
    if A.shape[0] == A.shape[1]:
        return inverse(A)
    if A.shape[0] < A.shape[1]:
        return A.T @ inverse(A @ A.T)
    return inverse(A.T @ A) @ A.T


class ScalarTerms:
    """M(q), C(q, q̇) q̇, g(q), K(q̇), B(q) and C(q, q̇) v of a model for one scalar type (module
    docstring).

    Parameters
    ----------
    model : MechanicalModel
        The model (double, as every model of the library).
    scalar : type, default float
        ``float``, ``pydrake.autodiffutils.AutoDiffXd`` or ``pydrake.symbolic.Expression``:
        the entries of the arrays the methods are given.

    Notes
    -----
    The converted plant and its context are made at the first call that needs them and
    reused: a copy of the model's plant, which is never modified after finalization, so the
    copy cannot go stale.  One instance is not thread-safe (the context is reused), like the
    model itself.
    """

    def __init__(self, model, scalar=float):
        if not isinstance(model, MechanicalModel):
            raise TypeError(f"model must be a MechanicalModel, got {type(model).__name__}")
        self.model, self.scalar, self.n = model, scalar, model.n
        self._plant = None
        cls = type(model)
        self._own = {k: getattr(cls, k) is not getattr(MechanicalModel, k)
                     for k in ("M", "Cqdot", "g", "friction")}

    # --- the plant's terms ------------------------------------------------------------------
    def _plant_context(self):
        if self._plant is None:
            plant = self.model.plant
            if self.scalar is not float:
                plant = plant.ToScalarType[self.scalar]()
            context = plant.CreateDefaultContext()
            context.SetTimeStateAndParametersFrom(self.model.context)
            self._plant = (plant, context)
        return self._plant

    def plant_terms(self, q: ArrayLike,
                    qdot: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(M, C q̇, g) of the model's MultibodyPlant in thesis order: what the base class'
        ``M``, ``Cqdot`` and ``g`` return, whatever the model overrides.

        Parameters
        ----------
        q, qdot : ndarray, shape (n,)
            Generalized coordinates and velocities, thesis order.

        Returns
        -------
        M : ndarray, shape (n, n)
        Cqdot, g : ndarray, shape (n,)
        """
        plant, context = self._plant_context()
        T = self.model.T
        plant.SetPositionsAndVelocities(context, np.concatenate([T @ q, T @ qdot]))
        M = T.T @ plant.CalcMassMatrix(context) @ T
        return (M, T.T @ plant.CalcBiasTerm(context),
                -(T.T @ plant.CalcGravityGeneralizedForces(context)))

    def _call(self, name, *args):
        try:
            return np.asarray(getattr(self.model, name)(*args))
        except (TypeError, ValueError) as exc:
            raise TypeError(
                f"{type(self.model).__name__}.{name} cannot evaluate {self.scalar.__name__} "
                f"arrays ({exc}); write it with numpy operations on object arrays (np.cos, "
                "np.sin and products work on AutoDiffXd and Expression), or keep the system "
                "in double (no ToAutoDiffXd/ToSymbolic, no Linearize)") from exc

    # --- the model's equations --------------------------------------------------------------
    def mass_and_bias(self, q: ArrayLike, qdot: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """(M(q), h = C(q, q̇) q̇ + g(q) + K(q̇)) of the model's equations.

        Parameters
        ----------
        q, qdot : ndarray, shape (n,)
            Generalized coordinates and velocities, thesis order.

        Returns
        -------
        (ndarray, ndarray)
            M (n × n) and h (n,).
        """
        own = self._own
        if own["M"] and own["Cqdot"] and own["g"]:
            M, h = self._call("M", q), self._call("Cqdot", q, qdot) + self._call("g", q)
        else:
            M, Cqdot, g = self.plant_terms(q, qdot)
            M = self._call("M", q) if own["M"] else M
            Cqdot = self._call("Cqdot", q, qdot) if own["Cqdot"] else Cqdot
            h = Cqdot + (self._call("g", q) if own["g"] else g)
        return M, h + self.friction(qdot)

    def Cqdot(self, q: ArrayLike, qdot: ArrayLike) -> np.ndarray:
        """C(q, q̇) q̇ of the model.

        Parameters
        ----------
        q, qdot : ndarray, shape (n,)
            Generalized coordinates and velocities, thesis order.

        Returns
        -------
        ndarray, shape (n,)
        """
        if self._own["Cqdot"]:
            return self._call("Cqdot", q, qdot)
        return self.plant_terms(q, qdot)[1]

    def C_times(self, q: ArrayLike, qdot: ArrayLike, v: ArrayLike) -> np.ndarray:
        """C(q, q̇) v by polarization, as ``MechanicalModel.C_times``.

        Parameters
        ----------
        q, qdot, v : ndarray, shape (n,)
            Coordinates, velocities and the vector multiplied by C(q, q̇).

        Returns
        -------
        ndarray, shape (n,)
        """
        return 0.25 * (self.Cqdot(q, qdot + v) - self.Cqdot(q, qdot - v))

    def friction(self, qdot: ArrayLike) -> np.ndarray:
        """K(q̇): zeros (base class), D q̇ (PlantModel) or the model's ``friction``.

        Parameters
        ----------
        qdot : ndarray, shape (n,)
            Generalized velocities, thesis order.

        Returns
        -------
        ndarray, shape (n,)
        """
        if not self._own["friction"] or self.model.frictionless:
            return np.zeros(self.n)
        if type(self.model).friction is PlantModel.friction:
            return self.model.damping * qdot
        return self._call("friction", qdot)

    def input_matrix(self, q: ArrayLike) -> np.ndarray:
        """B(q): a PlantModel's constant actuation matrix, else the model's ``B``.

        Parameters
        ----------
        q : ndarray, shape (n,)
            Generalized coordinates, thesis order.

        Returns
        -------
        ndarray, shape (n, number of inputs)
        """
        if type(self.model).B is PlantModel.B:
            return self.model.B(np.zeros(self.n))
        return self._call("B", q)
