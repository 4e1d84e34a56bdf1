"""State feedback u = u*(x) from a successive-Galerkin design (W2 (4.8), W∞ (4.20), H∞).

:class:`GalerkinController` evaluates the control law of a
:class:`~sobolev_drake.synthesis.galerkin.GalerkinResult` (or any object with a vectorized
``control(X) -> (Q, nu)`` method) at the current state.  The basis gradient and the model terms
are evaluated vectorized over all basis functions (no Python loop over terms).

The plant state (e.g. the thesis' [ϕ θ ϕ̇ θ̇] of the two-wheeled vehicle) is mapped to the
design state by ``x_design = selection @ x + offset`` (e.g. ``selection`` picking [θ ϕ̇ θ̇]);
``u_limits`` optionally saturates the output.  ``period`` samples the controller with its
first command computed at initialization (:mod:`~sobolev_drake.systems.control_output`).

Scalar conversion (issue #31): the controller is a ``TemplateSystem`` and converts to
AutoDiffXd and Expression when its law's ``control(X)`` evaluates on object arrays of those
types (checked once at construction).  A ``GalerkinResult`` does when the functions of its
design do: its polynomial basis, the model's f, g, k and the cost's ∇h written with
dtype-preserving NumPy code (its saddle decision is then solved by elimination in the scalar
type, :meth:`~sobolev_drake.synthesis.galerkin.GalerkinResult.decision`); Drake's
``Linearize`` of the controller at the origin then gives ``law.feedback_gain()`` (times the
selection).  A law whose functions are double only (e.g. they fill ``np.empty`` float arrays)
refuses conversion: Drake's error names the system ("... GalerkinController ... does not
support scalar conversion"), and :attr:`GalerkinController.conversion_refusal` names the
function that failed.  For a linear analysis of such a law use its gain at the origin,
``LinearStateFeedback(law.feedback_gain(), S=selection, x_r=-offset)``, which converts.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike
from pydrake.symbolic import Expression, Variable
from pydrake.systems.framework import LeafSystem_, SystemScalarConverter
from pydrake.systems.scalar_conversion import TemplateSystem

from sobolev_drake.systems.control_output import (SCALARS, ControlOutput, template_signature,
                                                  vector_of)

__all__ = ["GalerkinController", "selection_matrix"]


def selection_matrix(indices: Sequence[int], size: int) -> np.ndarray:
    """Rows of the identity: x_design = S x picks ``indices`` of a state of length ``size``.

    Parameters
    ----------
    indices : sequence of int
        The entries of the state to keep, in order.
    size : int
        Length of the state.

    Returns
    -------
    ndarray, shape (len(indices), size)
    """
    idx = list(indices)
    if any((not 0 <= i < size) for i in idx):
        raise ValueError(f"selection indices {idx} out of range for a state of size {size}")
    return np.eye(size)[idx]


def _probe(law, n, nu, T):
    """None if ``law.control`` evaluates on a (1, n) object array of ``T`` to (1, nu) entries of
    ``T``, else why not."""
    X = (vector_of(T, np.linspace(0.1, 0.2, n)) if T is not Expression
         else np.array([Expression(Variable(f"x{i}")) for i in range(n)]))
    try:
        with np.errstate(all="ignore"):   # see ControlOutput._scalar_math
            U = np.asarray(law.control(X[None, :]))
    except Exception as err:  # noqa: BLE001  (any failure means: not convertible)
        return f"{type(law).__name__}.control(X) fails on {T.__name__} ({type(err).__name__}: {err})"
    if U.shape != (1, nu) or not all(isinstance(v, T) for v in U.ravel()):
        return (f"{type(law).__name__}.control(X) on {T.__name__} returns "
                f"{U.dtype} of shape {U.shape}, not (1, {nu}) {T.__name__} entries")
    return None


@TemplateSystem.define("GalerkinController_")
def GalerkinController_(T):  # noqa: N802  (Drake's template naming)
    """GalerkinController for scalar type T (``GalerkinController`` is the float one)."""

    class Impl(ControlOutput, LeafSystem_[T]):
        """Drake LeafSystem: input port ``x`` (plant state), output port ``u`` = u*(S x + o).

        .. pydrake_system::

            name: GalerkinController
            input_ports:
            - x (alias estimated_state)
            output_ports:
            - u (alias control)

        Converts to AutoDiffXd and Expression when the law's ``control(X)`` evaluates on
        object arrays (a ``GalerkinResult`` does when its design's functions accept them: see
        the module docstring).

        Parameters
        ----------
        law : object
            With ``control(X) -> (Q, nu)`` (a ``GalerkinResult``) and, if ``nu`` / ``n`` are
            not given, ``problem.model.nu`` / ``problem.model.n``.
        plant_state_size : int, optional
            Size of the input port (default: the design state size).
        selection : array_like, optional
            (n_design, plant_state_size) matrix, or a list of indices (default identity).
        offset : array_like, optional
            Design-state offset (default 0).
        u_limits : (lo, hi), optional
            Saturation of the output.
        n, nu : int, optional
            Design state and input sizes (default: from ``law.problem.model``).
        period : float, optional
            Sample period (s) of a sampled controller; None (default) for a continuous one.
        computation_delay : bool, default False
            With ``period``: apply each sample's command one period later.

        Attributes
        ----------
        conversion_refusal : str or None
            Why the controller does not convert to AutoDiffXd / Expression (None: it does).
        """

        def _construct(self, law, *, plant_state_size: int | None = None, selection=None,
                       offset=None, u_limits=None, n: int | None = None, nu: int | None = None,
                       period=None, computation_delay=False, converter=None):
            if not callable(getattr(law, "control", None)):
                raise TypeError("law must have a vectorized control(X) method (e.g. "
                                f"GalerkinResult), got {type(law).__name__}")
            model = getattr(getattr(law, "problem", None), "model", None)
            self._n = int(n if n is not None else model.n)
            self._nu = int(nu if nu is not None else model.nu)
            self.conversion_refusal = None
            if T is float:   # convert only if the law evaluates in every scalar type
                reasons = [r for S in SCALARS if (r := _probe(law, self._n, self._nu, S))]
                if reasons:
                    self.conversion_refusal = "; ".join(reasons)
                    converter = SystemScalarConverter()
            LeafSystem_[T].__init__(self, converter)
            self._kw = dict(plant_state_size=plant_state_size, selection=selection,
                            offset=offset, u_limits=u_limits, n=n, nu=nu, period=period,
                            computation_delay=computation_delay)
            size = self._n if plant_state_size is None else int(plant_state_size)
            if selection is None:
                if size != self._n:
                    raise ValueError(f"plant_state_size {size} differs from the design state "
                                     f"size {self._n}: give a selection")
                S = np.eye(size)
            else:
                sel = np.asarray(selection)
                S = selection_matrix(sel, size) if sel.ndim == 1 else sel.astype(float)
            if S.shape != (self._n, size):
                raise ValueError(f"selection must have shape ({self._n}, {size}), got {S.shape}")
            self._S = S
            self._o = (np.zeros(self._n) if offset is None
                       else np.asarray(offset, float).reshape(self._n))
            lim = None
            if u_limits is not None:
                lim = tuple(np.broadcast_to(np.asarray(v, float), (self._nu,)) for v in u_limits)
                if np.any(lim[0] > lim[1]):
                    raise ValueError(f"u_limits: lower bound above upper bound, got {u_limits!r}")
            self._lim = lim
            self._law = law
            self._x = self.DeclareVectorInputPort("x", size)
            self._control_output(T, self._nu, bounds=lim, period=period,
                                 computation_delay=computation_delay,
                                 prerequisites={self.input_port_ticket(self._x.get_index())})

        def _construct_copy(self, other, converter=None):
            Impl._construct(self, other._law, converter=converter, **other._kw)

        def design_state(self, x: ArrayLike) -> np.ndarray:
            """The design state S x + o of a plant state ``x``.

            Parameters
            ----------
            x : array_like, shape (plant_state_size,)
                Plant state (floats, or an object array of this system's scalar type).

            Returns
            -------
            ndarray, shape (n,)
            """
            x = np.asarray(x)
            return self._S @ (x.astype(float) if x.dtype != object else x) + self._o

        def _command(self, context):
            u = self._law.control(self.design_state(self._x.Eval(context))[None, :])
            return np.asarray(u, dtype=float if T is float else object)[0]

    Impl.__signature__ = template_signature(Impl._construct)
    return Impl


GalerkinController = GalerkinController_[None]
