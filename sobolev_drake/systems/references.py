"""Reference trajectories (q_r, q̇_r, q̈_r) with analytic derivatives, as Drake LeafSystems.

A trajectory is a list of *pieces* separated by breakpoints b_0 < b_1 < …; piece k applies on
(b_{k−1}, b_k] (the thesis writes its tables as "t ≤ 8", "8 < t ≤ 30"), the last piece for
every t beyond the last breakpoint.  Each piece gives, for every coordinate, a
:class:`Coordinate`: a callable of *absolute* time t returning (f, ḟ, f̈) — numpy-vectorized,
with a float fast path and a form for any Drake scalar type (float, AutoDiffXd, Expression).

The coordinates (:class:`Coordinate`, :func:`const`, :func:`sine`, :func:`poly`) live in
:mod:`sobolev_drake.systems.reference_coordinates` and are re-exported here.
:class:`PiecewiseTrajectory` is pure numpy (``evaluate(t) -> (q, qd, qdd)``);
:class:`TrajectoryReference` wraps one, or a Drake ``Trajectory`` such as a
``PiecewisePolynomial``, as a scalar-convertible LeafSystem with output ports ``q_r``,
``qdot_r``, ``qddot_r`` and ``reference`` = [q_r; q̇_r; q̈_r] (size 3m), depending on time only.

The thesis catalogue (``table_5_2`` … ``envelope_mission``, with the reconstruction of garbled
tables and the smoothness at the breakpoints) is :mod:`sobolev_drake.systems.reference_catalogue`.
"""

from __future__ import annotations

from bisect import bisect_left
from typing import Sequence

import numpy as np
from numpy.typing import ArrayLike
from pydrake.autodiffutils import AutoDiffXd
from pydrake.systems.framework import BasicVector, LeafSystem_
from pydrake.systems.scalar_conversion import TemplateSystem
from pydrake.trajectories import Trajectory

from sobolev_drake.native import kernel
from sobolev_drake.systems.reference_coordinates import Coordinate, compiled_program, const, poly, sine
from sobolev_drake.systems.scalar_time import (Scalar, is_symbolic, piecewise, probe_scalar_type,
                                               scalar_value, template_signature)
from sobolev_drake.validation import real_vector, sequence

__all__ = [
    "Coordinate", "const", "sine", "poly", "PiecewiseTrajectory", "TrajectoryReference",
    "TrajectoryReference_",
]



class PiecewiseTrajectory:
    """Pure-numpy piecewise-analytic trajectory of m named coordinates.

    Parameters
    ----------
    names : sequence of str
        The m distinct coordinate names (e.g. ``["x", "y", "z", "psi"]``), in output order.
    pieces : sequence of sequences of Coordinate
        K pieces, each a sequence of m :class:`Coordinate`.
    breakpoints : sequence of float, optional
        K − 1 strictly increasing times separating the pieces; piece k applies on
        (b_{k−1}, b_k].
    description : str, optional
        Free text (source, reconstruction notes).
    """

    def __init__(self, names: Sequence[str], pieces: Sequence[Sequence[Coordinate]],
                 breakpoints: Sequence[float] = (), description: str = "") -> None:
        names = sequence("names", names, "coordinate-name strings")
        if not all(isinstance(n, str) for n in names):
            raise TypeError(f"names must be a sequence of coordinate-name strings, got {names!r}")
        self.names = names
        self.m = len(self.names)
        if self.m == 0:
            raise ValueError("names must list at least one coordinate")
        if len(set(self.names)) != self.m:
            raise ValueError(f"names must be distinct, got {self.names}")
        self.pieces = [sequence(f"pieces[{k}]", p, "Coordinate")
                       for k, p in enumerate(sequence("pieces", pieces, "sequences of Coordinate"))]
        if not self.pieces:
            raise ValueError("pieces must contain at least one piece")
        for k, p in enumerate(self.pieces):
            if len(p) != self.m:
                raise ValueError(f"pieces[{k}] has {len(p)} coordinates, expected {self.m} ({self.names})")
            for j, c in enumerate(p):
                if not isinstance(c, Coordinate):
                    raise TypeError(f"pieces[{k}][{j}] must be a Coordinate, got {type(c).__name__}")
        self.breakpoints = real_vector("breakpoints", breakpoints, allow_empty=True)
        if self.breakpoints.size != len(self.pieces) - 1:
            raise ValueError(f"breakpoints must have {len(self.pieces) - 1} entries (one fewer than pieces), "
                             f"got {self.breakpoints.size}")
        if np.any(np.diff(self.breakpoints) <= 0):
            raise ValueError("breakpoints must be strictly increasing")
        if not isinstance(description, str):
            raise TypeError(f"description must be a string, got {type(description).__name__}")
        self.description = description
        self._bp = self.breakpoints.tolist()

    def evaluate_scalar(self, t: float) -> tuple[list[float], list[float], list[float]]:
        """(q_r, q̇_r, q̈_r) at one finite time t as three lists of floats (fast path of the
        LeafSystem; equal to :meth:`evaluate`).

        Parameters
        ----------
        t : float
            Time (not checked).

        Returns
        -------
        q_r, qdot_r, qddot_r : list of float, length m
        """
        piece = self.pieces[bisect_left(self._bp, t)]   # (b_{k-1}, b_k] → piece k
        vals = [c.scalar(t) for c in piece]
        return [v[0] for v in vals], [v[1] for v in vals], [v[2] for v in vals]

    def evaluate_any(self, t: Scalar) -> tuple[list[Scalar], list[Scalar], list[Scalar]]:
        """(q_r, q̇_r, q̈_r) at one time t of any Drake scalar type: float as
        :meth:`evaluate_scalar`, AutoDiffXd on the piece of t's value (:meth:`Coordinate.at`),
        Expression as an ``if_then_else`` over the pieces (one piece for a constant time).

        Parameters
        ----------
        t : float, AutoDiffXd or Expression
            Time.

        Returns
        -------
        q_r, qdot_r, qddot_r : list, length m
        """
        if isinstance(t, float):
            return self.evaluate_scalar(t)
        if is_symbolic(t):
            vals = piecewise(t, self._bp, [lambda p=p: np.array([c.at(t) for c in p], dtype=object)
                                           for p in self.pieces])
        else:
            vals = [c.at(t) for c in self.pieces[bisect_left(self._bp, scalar_value(t))]]
        return [v[0] for v in vals], [v[1] for v in vals], [v[2] for v in vals]

    def index(self, name: str) -> int:
        """Position of coordinate ``name`` in the output order (``KeyError`` if absent).

        Parameters
        ----------
        name : str
            A coordinate name.

        Returns
        -------
        int
        """
        try:
            return self.names.index(name)
        except ValueError:
            raise KeyError(f"no coordinate {name!r}; coordinates are {self.names}") from None

    def evaluate(self, t: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(q_r, q̇_r, q̈_r) at time(s) t: each shaped (m,) for scalar t, (N, m) for a vector.

        Parameters
        ----------
        t : float or array_like, shape (N,)
            Finite time(s).

        Returns
        -------
        q_r, qdot_r, qddot_r : ndarray, shape (m,) or (N, m)
        """
        t_arr = np.asarray(t, dtype=float)
        scalar = t_arr.ndim == 0
        tt = np.atleast_1d(t_arr)
        if tt.ndim != 1 or not np.all(np.isfinite(tt)):
            raise ValueError(f"t must be a finite scalar or 1-D array, got shape {t_arr.shape}")
        which = np.searchsorted(self.breakpoints, tt, side="left")  # (b_{k-1}, b_k] → piece k
        out = np.zeros((3, tt.size, self.m))
        for k in np.unique(which):
            mask = which == k
            for j, coord in enumerate(self.pieces[k]):
                f, df, ddf = coord(tt[mask])
                out[0, mask, j], out[1, mask, j], out[2, mask, j] = f, df, ddf
        if scalar:
            return out[0, 0], out[1, 0], out[2, 0]
        return out[0], out[1], out[2]

    def __call__(self, t: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return self.evaluate(t)

    def subset(self, names: Sequence[str]) -> "PiecewiseTrajectory":
        """The trajectory restricted to / reordered as ``names``.

        Parameters
        ----------
        names : sequence of str
            Coordinates to keep, in the new output order.

        Returns
        -------
        PiecewiseTrajectory
            Same pieces' coordinates, breakpoints and description.
        """
        idx = [self.index(n) for n in names]
        pieces = [[p[i] for i in idx] for p in self.pieces]
        return PiecewiseTrajectory(list(names), pieces, self.breakpoints, self.description)

    def jumps(self, eps: float = 1e-9) -> list[dict]:
        """Jumps of q, q̇, q̈ at each breakpoint b (value of piece k+1 at b minus piece k at b).

        Parameters
        ----------
        eps : float, default 1e-9
            Not used (every difference is reported as computed).

        Returns
        -------
        list of dict
            One per breakpoint: ``{"t": b, "q": (m,), "qd": (m,), "qdd": (m,)}``.
        """
        out = []
        for k, b in enumerate(self.breakpoints):
            d = [np.array([c(b)[i] for c in self.pieces[k + 1]]) - np.array([c(b)[i] for c in self.pieces[k]])
                 for i in range(3)]
            out.append({"t": float(b), "q": d[0], "qd": d[1], "qdd": d[2]})
        return out

    def smoothness(self, tol: float = 1e-6) -> list[dict]:
        """Per breakpoint and coordinate, the continuity class: "C2+", "C1", "C0" or "jump".

        Parameters
        ----------
        tol : float, default 1e-6
            A jump of absolute size above ``tol`` counts as a discontinuity.

        Returns
        -------
        list of dict
            ``{"t": b, "name": coordinate, "class": ...}`` per breakpoint and coordinate.
        """
        rows = []
        for j in self.jumps():
            for i, name in enumerate(self.names):
                cls = ("jump" if abs(j["q"][i]) > tol else "C0" if abs(j["qd"][i]) > tol
                       else "C1" if abs(j["qdd"][i]) > tol else "C2+")
                rows.append({"t": j["t"], "name": name, "class": cls})
        return rows


@TemplateSystem.define("TrajectoryReference_")
def TrajectoryReference_(T):   # the class for scalar type T (float, AutoDiffXd, Expression)

    class Impl(LeafSystem_[T]):
        """Reference (q_r, q̇_r, q̈_r) of a trajectory as a time-only source (no inputs).

        ``trajectory``: a :class:`PiecewiseTrajectory` or a one-column Drake ``Trajectory`` (e.g.
        ``PiecewisePolynomial``; value and ``MakeDerivative`` derivatives, the end values held
        with zero rates outside its span, as ``TrajectorySource``).  Scalar-convertible: a
        PiecewiseTrajectory is evaluated in the scalar type (symbolic time too), a Drake
        Trajectory<double> at the time's value (chain rule for AutoDiffXd; constant symbolic
        time only).  ``evaluate(t)`` is the numpy equivalent; ``names`` the coordinates.

        .. pydrake_system::

            name: TrajectoryReference
            output_ports:
            - q_r
            - qdot_r
            - qddot_r
            - reference

        Parameters
        ----------
        trajectory : PiecewiseTrajectory or pydrake.trajectories.Trajectory
            The trajectory emitted (a Drake one with ``cols() == 1``).
        names : sequence of str, optional
            Coordinate names of a Drake trajectory (default q0, q1, …); not for a
            PiecewiseTrajectory, which names its own.
        """

        def _construct(self, trajectory, names=None, converter=None):
            LeafSystem_[T].__init__(self, converter)
            self._derivs = None
            if isinstance(trajectory, PiecewiseTrajectory):
                if names is not None:
                    raise ValueError(f"names must be None for a PiecewiseTrajectory (named "
                                     f"{trajectory.names}; see subset()), got {names!r}")
                names, self.description = list(trajectory.names), trajectory.description
            elif isinstance(trajectory, Trajectory):
                if trajectory.cols() != 1 or trajectory.rows() < 1:
                    raise ValueError(f"trajectory must have one column and at least one row, got "
                                     f"{trajectory.rows()}x{trajectory.cols()}")
                names = sequence("names", [f"q{i}" for i in range(trajectory.rows())] if names is None
                                 else names, "coordinate-name strings")
                if len(names) != trajectory.rows() or not all(isinstance(n, str) for n in names):
                    raise ValueError(f"names must be {trajectory.rows()} strings, got {names!r}")
                self._derivs = [trajectory]
                for _ in range(3):   # q̇, q̈ and q⃛ (the AutoDiffXd chain rule of q̈)
                    self._derivs.append(self._derivs[-1].MakeDerivative())
                self.description = f"{type(trajectory).__name__} from {trajectory.start_time()} s"
            else:
                raise TypeError(f"trajectory must be a PiecewiseTrajectory or a pydrake Trajectory "
                                f"(e.g. PiecewisePolynomial), got {type(trajectory).__name__}")
            if T is not float and self._derivs is None:   # refuse float-only Coordinates up front
                bp = trajectory.breakpoints
                for k, (piece, tk) in enumerate(zip(trajectory.pieces, list(bp) + [bp[-1] + 1 if bp.size else 0])):
                    for name, c in zip(trajectory.names, piece):
                        probe_scalar_type(T, "TrajectoryReference", f"coordinate {name!r} of piece {k} ({c!r})",
                                          c.at, tk, "give it a generic= function (pydrake.math), or use const/sine/poly")
            self.trajectory, self.names, m = trajectory, list(names), len(names)
            self.m, time_only = m, {self.time_ticket()}
            for k, name in enumerate(("q_r", "qdot_r", "qddot_r")):   # slices of ``reference``
                self.DeclareVectorOutputPort(name, m, lambda c, out, k=k: out.SetFromVector(
                    self._ref.Eval(c)[k * m:(k + 1) * m]), prerequisites_of_calc=time_only)
            self._ref = self.DeclareVectorOutputPort("reference", 3 * m, self._calc_all,
                                                     prerequisites_of_calc=time_only)
            # the double system's per-sample evaluation in one compiled call where it can be
            # (const/sine/poly pieces; the Python path stays the reference, tested equal)
            self._program = (compiled_program(trajectory.pieces, trajectory.breakpoints)
                             if T is float and self._derivs is None
                             else None)
            self._evaluate_into = None if self._program is None else kernel("reference").evaluate

        def _construct_copy(self, other, converter=None):
            Impl._construct(self, other.trajectory, None if other._derivs is None else other.names,
                            converter=converter)

        __signature__ = template_signature(_construct)

        def evaluate(self, t: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
            """Pure numpy (q_r, q̇_r, q̈_r) at t (see :meth:`PiecewiseTrajectory.evaluate`).

            Parameters
            ----------
            t : float or array_like, shape (N,)
                Finite time(s).

            Returns
            -------
            q_r, qdot_r, qddot_r : ndarray, shape (m,) or (N, m)
            """
            if self._derivs is None:
                return self.trajectory.evaluate(t)
            tt = real_vector("t", np.atleast_1d(t))
            out = np.array([self._eval_drake(float(ti))[:3] for ti in tt])   # (N, 3, m)
            return tuple(out[0, k] if np.ndim(t) == 0 else out[:, k] for k in range(3))

        def _eval_drake(self, t):   # [q, q̇, q̈, q⃛] at float t (zero rates outside the span)
            traj = self.trajectory
            inside = traj.start_time() <= t <= traj.end_time()
            return [d.value(t)[:, 0] if (k == 0 or inside) else np.zeros(self.m)
                    for k, d in enumerate(self._derivs)]

        def _calc_all(self, context, output: BasicVector):
            t = context.get_time()
            # the compiled program where it applies; False (a value not finite: t = ±inf, an
            # overflowing sine argument) leaves the result to the Python path below
            if self._program is not None and self._evaluate_into(self._program, t,
                                                                 output.get_mutable_value()):
                return None
            if self._derivs is None:
                return output.SetFromVector(sum(self.trajectory.evaluate_any(t), []))
            if is_symbolic(t) and not t.GetVariables().empty():
                raise ValueError(f"TrajectoryReference {self.GetSystemPathname()} holds a Drake Trajectory "
                                 f"evaluated in double: the time must be a constant, got {t}; use a "
                                 "PiecewiseTrajectory (const/sine/poly pieces) for a symbolic time")
            vals = self._eval_drake(scalar_value(t))
            if isinstance(t, AutoDiffXd):   # d/dθ f(t(θ)) = ḟ(t) ∂t/∂θ
                dt = t.derivatives()
                vals = [[AutoDiffXd(v, dv * dt) for v, dv in zip(vals[k], vals[k + 1])]
                        for k in range(3)]
            output.SetFromVector(np.concatenate(vals[:3]))

    return Impl


TrajectoryReference = TrajectoryReference_[None]
