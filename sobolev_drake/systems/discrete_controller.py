"""A discrete-time synthesis result as a Drake system that runs the loop it was certified for.

:func:`discrete_controller_system` turns a discrete-time
:class:`~sobolev_drake.synthesis.problem.SynthesisResult` (``dt > 0``) into Drake's own
``AffineSystem`` with ``time_period = result.dt`` (scalar-convertible, ``Linearize``-able):
at t_k = k·dt it reads the connected signal y(t_k), computes u_k = C_K x_K + D_K (S y − y_op)
and holds u_op + u_k until t_k+1 (the zero-order hold of :func:`~sobolev_drake.synthesis.
discrete.sampled_data_plant`); with ``result.discrete.computation_delay`` the command computed at t_k is
held on [t_k+1, t_k+2) instead.  The held command and the pending one are states of the
system, so its output has no direct feedthrough and closes an algebraic-loop-free diagram.
Before the first update (at t = 0) the command is u_op.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike
from pydrake.systems.primitives import AffineSystem

from sobolev_drake.synthesis.problem import SynthesisResult
from sobolev_drake.validation import real_matrix, real_vector

__all__ = ["discrete_controller_system"]


def discrete_controller_system(result: SynthesisResult, *, y_op: ArrayLike | None = None,
                               u_op: ArrayLike | None = None,
                               S: ArrayLike | None = None) -> AffineSystem:
    """Drake ``AffineSystem`` (period ``result.dt``) running a discrete-time controller.

    Parameters
    ----------
    result : SynthesisResult
        A discrete-time result (``dt > 0``), from
        :func:`~sobolev_drake.synthesis.discrete.hinf_discrete`.
    y_op, u_op : array_like, optional
        Operating point: the controller sees S y − y_op and outputs u_op + u (zero default).
    S : array_like, optional
        Selection y_model = S y of the connected signal (e.g. a plant's full state).

    Returns
    -------
    pydrake.systems.primitives.AffineSystem
        Input: the measurement (S's columns, or ny); output: the held command u.

    Raises
    ------
    TypeError
        When ``result`` is not a discrete-time synthesis result (a continuous one runs as
        :func:`~sobolev_drake.systems.linear_controllers.controller_system`).

    Examples
    --------
    >>> import control
    >>> import sobolev_drake as sd
    >>> Pc = control.ss([[0, 1], [-4, -0.2]], [[0, 0], [1, 1]],
    ...                 [[1, 0], [0, 0], [1, 0]], [[0, 0], [0, 1], [0.1, 0]])
    >>> res = sd.hinf_discrete(control.c2d(Pc, 0.01), nmeas=1, ncon=1)
    >>> K = sd.discrete_controller_system(res)
    >>> K.time_period(), K.num_inputs(), K.num_outputs(), K.HasAnyDirectFeedthrough()
    (0.01, 1, 1, False)
    """
    if not isinstance(result, SynthesisResult) or not result.dt:
        what = (f"a continuous-time {result.kind} result (use sd.controller_system)"
                if isinstance(result, SynthesisResult) else type(result).__name__)
        raise TypeError(f"result must be a discrete-time SynthesisResult (dt > 0, from "
                        f"sd.hinf_discrete), got {what}")
    AK, BK, CK, DK = (np.asarray(M, float) for M in result.controller)
    nk, ny, nu = AK.shape[0], BK.shape[1], CK.shape[0]
    Sm = np.eye(ny) if S is None else real_matrix("S", S, (ny, None))
    y0 = np.zeros(ny) if y_op is None else real_vector("y_op", y_op, ny)
    u0 = np.zeros(nu) if u_op is None else real_vector("u_op", u_op, nu)
    lag = 2 if result.discrete.computation_delay else 1        # command states: [pending;] held
    A = np.zeros((nk + lag * nu, nk + lag * nu))
    A[:nk, :nk] = AK
    A[nk:nk + nu, :nk] = CK                            # next command from x_K[k] and y_k
    if lag == 2:
        A[nk + nu:, nk:nk + nu] = np.eye(nu)           # the pending command becomes the held one
    Bm = np.vstack([BK, DK, np.zeros(((lag - 1) * nu, ny))])
    C = np.hstack([np.zeros((nu, nk + (lag - 1) * nu)), np.eye(nu)])
    return AffineSystem(A, Bm @ Sm, -Bm @ y0, C, np.zeros((nu, Sm.shape[1])), u0,
                        time_period=result.dt)
