"""LMI building blocks shared by every linear synthesis in this package.

An LMI is stored once, as data: a symmetric matrix function F(x) = F0 + sum_i x_i F_i of the
decision vector x (kept as ``vec(F) = f0 + M x`` with a sparse M, row-major vec). Every
backend receives exactly this data, so "the same LMIs" are solved by

* ``"clarabel"`` (default): the PyPI Clarabel called directly with the conic data
  (``_svec_data``), no modelling layer: the same solver and problem as ``"cvxpy"`` (identical
  gamma on the benchmark plants) without cvxpy's import (1.5-5 s per process) and
  canonicalization;
* ``"cvxpy"`` (Clarabel through cvxpy; ``"cvxpy:scs"``, ``"cvxpy:mosek"``);
* ``"drake"`` (``MathematicalProgram`` + ``AddLinearMatrixInequalityConstraint``, Clarabel by
  default; ``"drake:scs"``, ``"drake:csdp"``, ``"drake:mosek"``);
* ``"ipm"``: own dense primal-dual interior-point method (``sdp_ipm.py``) with the m x m
  Schur complement; 4-8x faster than Clarabel on the 12-20-state benchmark plants, but it
  stops with "Stalled" on problems whose infimum needs unbounded Lyapunov variables (e.g. the
  3-state output-feedback benchmark plant), and on degenerate problems (uncontrollable
  disturbance-model states) its optimum can differ from Clarabel's;
* ``"auto"``: "ipm", and "clarabel" when the IPM does not converge.  The syntheses
  (``hinf_common._solve``) additionally reject an IPM result whose certificate fails or whose
  P does not satisfy the bounded-real inequality, and record the fallback.

Clarabel is the default because it is the robust choice (the PyPI build uses a faster
linear-algebra backend than the Clarabel bundled with Drake, docs/design.md §8.5,
``benchmarks/synthesis.py``); "auto" is the fast opt-in.

Matrix expressions (:class:`Affine`) support ``+ - @ .T``, scalar products, :func:`bmat` and
:func:`kron`, which is all the bounded-real-lemma and LMI-region constraints need.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np
from numpy.typing import ArrayLike
import scipy.sparse as sp

from sobolev_drake.errors import SynthesisError

__all__ = [
    "BACKENDS", "SynthesisError", "InfeasibleLMIError", "Affine", "bmat", "kron", "SolveOutcome",
    "LMIProgram",
]

DEFAULT_BACKEND = "clarabel"
BACKENDS = ("clarabel", "ipm", "auto", "cvxpy", "cvxpy:clarabel", "cvxpy:scs", "cvxpy:mosek",
            "drake", "drake:clarabel", "drake:scs", "drake:csdp", "drake:mosek")


class InfeasibleLMIError(SynthesisError):
    """The solver reported the LMI problem infeasible / not solved (status attached).

    Parameters
    ----------
    message : str
        The error message.
    status : str, optional
        The solver's status text (kept as ``.status``).
    """

    def __init__(self, message: str, status: str = "") -> None:
        super().__init__(message)
        self.status = status


# --------------------------------------------------------------------------- expressions
class Affine:
    """Matrix-valued affine function const + reshape(coef @ x) of the decision vector."""

    __array_ufunc__ = None  # so ndarray @ Affine / ndarray * Affine defer to Affine

    def __init__(self, const: np.ndarray, coef: sp.spmatrix) -> None:
        self.const = np.atleast_2d(np.asarray(const, dtype=float))
        self.coef = sp.csr_matrix(coef)
        assert self.coef.shape[0] == self.const.size

    @property
    def shape(self):
        return self.const.shape

    def _ncols(self, n):
        if self.coef.shape[1] == n:
            return self.coef
        c = self.coef.tocoo()
        return sp.csr_matrix((c.data, (c.row, c.col)), shape=(c.shape[0], n))

    @staticmethod
    def lift(x: Affine | ArrayLike, ncols: int = 0) -> Affine:
        if isinstance(x, Affine):
            return x
        x = np.atleast_2d(np.asarray(x, dtype=float))
        return Affine(x, sp.csr_matrix((x.size, ncols)))

    def __add__(self, other):
        other = Affine.lift(other)
        if other.shape != self.shape:
            raise ValueError(f"shape mismatch {self.shape} + {other.shape}")
        n = max(self.coef.shape[1], other.coef.shape[1])
        return Affine(self.const + other.const, self._ncols(n) + other._ncols(n))

    __radd__ = __add__

    def __neg__(self):
        return Affine(-self.const, -self.coef)

    def __sub__(self, other):
        return self + (-Affine.lift(other))

    def __rsub__(self, other):
        return Affine.lift(other) + (-self)

    def __mul__(self, s):
        if np.isscalar(s):
            return Affine(self.const * s, self.coef * s)
        if self.shape == (1, 1):  # scalar variable times a constant matrix
            M = np.atleast_2d(np.asarray(s, dtype=float))
            coef = sp.csr_matrix(M.reshape(-1, 1)) @ self.coef
            return Affine(self.const[0, 0] * M, coef)
        raise TypeError("Affine * supports scalars (or 1x1 Affine * matrix); use @ for matrices")

    __rmul__ = __mul__

    def __matmul__(self, B):  # X @ B, vec_r(X B) = (I kron B^T) vec_r(X)
        B = np.atleast_2d(np.asarray(B, dtype=float))
        m, _ = self.shape
        op = sp.kron(sp.identity(m), sp.csr_matrix(B.T), format="csr")
        return Affine(self.const @ B, op @ self.coef)

    def __rmatmul__(self, A):  # A @ X, vec_r(A X) = (A kron I) vec_r(X)
        A = np.atleast_2d(np.asarray(A, dtype=float))
        _, n = self.shape
        op = sp.kron(sp.csr_matrix(A), sp.identity(n), format="csr")
        return Affine(A @ self.const, op @ self.coef)

    @property
    def T(self):
        m, n = self.shape
        perm = (np.arange(m)[None, :] * n + np.arange(n)[:, None]).ravel()
        return Affine(self.const.T, self.coef[perm])

    def sym(self) -> Affine:
        """X + X^T (the 'He' operator)."""
        return self + self.T

    def value(self, x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        return self.const + (self._ncols(x.size) @ x).reshape(self.shape)


def bmat(blocks: Sequence[Sequence[Affine | ArrayLike | None]]) -> Affine:
    """Block matrix of Affine / ndarray / None (zero) entries; like ``numpy.block``."""
    nr, nc = len(blocks), len(blocks[0])
    rows = [None] * nr
    cols = [None] * nc
    for i, row in enumerate(blocks):
        if len(row) != nc:
            raise ValueError("bmat: ragged block rows")
        for j, b in enumerate(row):
            if b is None or (np.isscalar(b) and b == 0):
                continue
            shp = Affine.lift(b).shape
            if rows[i] is not None and rows[i] != shp[0] or cols[j] is not None and cols[j] != shp[1]:
                raise ValueError(f"bmat: block ({i},{j}) has shape {shp}, inconsistent")
            rows[i], cols[j] = shp[0], shp[1]
    if any(r is None for r in rows) or any(c is None for c in cols):
        raise ValueError("bmat: a block row/column is all zeros; give its size with np.zeros")
    R, C = sum(rows), sum(cols)
    ncol = max([b.coef.shape[1] for row in blocks for b in row if isinstance(b, Affine)] + [0])
    const = np.zeros((R, C))
    data, ri, ci = [], [], []
    r0 = 0
    for i, row in enumerate(blocks):
        c0 = 0
        for j, b in enumerate(row):
            if b is not None and not (np.isscalar(b) and b == 0):
                b = Affine.lift(b)
                m, n = b.shape
                const[r0:r0 + m, c0:c0 + n] = b.const
                coo = b.coef.tocoo()
                rr, cc = np.divmod(coo.row, n)
                data.append(coo.data)
                ri.append((r0 + rr) * C + c0 + cc)
                ci.append(coo.col)
            c0 += cols[j]
        r0 += rows[i]
    cat = (lambda L: np.concatenate(L) if L else np.zeros(0))
    coef = sp.csr_matrix((cat(data), (cat(ri).astype(int), cat(ci).astype(int))), shape=(R * C, ncol))
    return Affine(const, coef)


def kron(a: ArrayLike, X: Affine) -> Affine:
    """Kronecker product of a constant matrix with an Affine expression (LMI regions)."""
    a = np.atleast_2d(np.asarray(a, dtype=float))
    X = Affine.lift(X)
    zero = np.zeros(X.shape)
    return bmat([[X * float(a[i, j]) if a[i, j] != 0 else zero for j in range(a.shape[1])]
                 for i in range(a.shape[0])])


# --------------------------------------------------------------------------- program
@dataclass
class SolveOutcome:
    x: np.ndarray
    success: bool
    status: str
    solver: str
    backend: str
    build_time: float
    solve_time: float
    inaccurate: bool = False
    extra: dict = field(default_factory=dict)


class LMIProgram:
    """Decision variables, LMIs ``F(x) <= -margin I`` and a linear objective."""

    def __init__(self) -> None:
        self.nvar = 0
        self.lmis: list[tuple[str, Affine, float]] = []
        self.objective: Affine | None = None
        self.names: dict[str, tuple[int, tuple]] = {}

    def _new(self, k):
        start = self.nvar
        self.nvar += k
        return start

    def sym(self, n: int, name: str = "") -> Affine:
        """Symmetric n x n matrix variable."""
        iu = np.triu_indices(n)
        start = self._new(len(iu[0]))
        idx = np.zeros((n, n), dtype=int)
        idx[iu] = np.arange(len(iu[0])) + start
        idx = np.triu(idx) + np.triu(idx, 1).T
        coef = sp.csr_matrix((np.ones(n * n), (np.arange(n * n), idx.ravel())), shape=(n * n, self.nvar))
        return Affine(np.zeros((n, n)), coef)

    def full(self, m: int, n: int, name: str = "") -> Affine:
        start = self._new(m * n)
        coef = sp.csr_matrix((np.ones(m * n), (np.arange(m * n), start + np.arange(m * n))),
                             shape=(m * n, self.nvar))
        return Affine(np.zeros((m, n)), coef)

    def scalar(self, name: str = "") -> Affine:
        return self.full(1, 1, name)

    def add_lmi(self, F: Affine | ArrayLike, margin: float = 0.0, name: str = "") -> None:
        """Constrain the symmetric part of F to be <= -margin I (negative semidefinite)."""
        F = Affine.lift(F)
        if F.shape[0] != F.shape[1]:
            raise ValueError(f"LMI {name!r} is not square: {F.shape}")
        self.lmis.append((name, (F + F.T) * 0.5, float(margin)))

    def add_pos(self, F: Affine | ArrayLike, margin: float = 0.0, name: str = "") -> None:
        """Constrain F >= margin I."""
        self.add_lmi(-Affine.lift(F), margin, name)

    def minimize(self, f: Affine | ArrayLike) -> None:
        f = Affine.lift(f)
        if f.shape != (1, 1):
            raise ValueError("objective must be a scalar expression")
        self.objective = f

    # ---------------------------------------------------------------- backends
    def solve(self, backend: str | None = None, options: dict[str, Any] | None = None) -> SolveOutcome:
        backend = (backend or DEFAULT_BACKEND).lower()
        if backend not in BACKENDS:
            raise ValueError(f"backend must be one of {BACKENDS}, got {backend!r}")
        front, _, solver = backend.partition(":")
        solver = solver or "clarabel"
        if front == "clarabel":
            return self._solve_clarabel(options or {})
        if front == "ipm":
            return self._solve_ipm(options or {})
        if front == "auto":  # own IPM, Clarabel when it does not converge (no certificate here)
            out = self._solve_ipm({})
            if out.success:
                return out
            first = f"ipm/IPM: status {out.status}"
            out = self._solve_clarabel({})
            out.extra["fallback"] = first
            out.status += f" (after fallback: {first})"
            return out
        if front == "cvxpy":
            return self._solve_cvxpy(solver, options or {})
        return self._solve_drake(solver, options or {})

    def _svec_data(self):
        """Conic data of the LMIs for a PSD-triangle cone solver: (A, b, sizes) with
        A x + s = b, s in the cones (s = svec(-F(x) - margin I)).

        svec: upper triangle, column by column, off-diagonal entries times sqrt(2) (Clarabel's
        PSDTriangleConeT convention). F is stored row-major, so entry (i, j) is row i n + j.
        """
        blocks_A, blocks_b, sizes = [], [], []
        for _, F, margin in self.lmis:
            n = F.shape[0]
            j, i = np.tril_indices(n)  # (i <= j) ordered by column j, then row i
            rows = i * n + j
            scale = np.where(i == j, 1.0, np.sqrt(2.0))
            blocks_A.append(sp.diags(scale) @ F._ncols(self.nvar)[rows])
            blocks_b.append(scale * (-F.const - margin * np.eye(n))[i, j])
            sizes.append(n)
        return sp.vstack(blocks_A, format="csc"), np.concatenate(blocks_b), sizes

    def _solve_clarabel(self, options):
        """PyPI Clarabel called directly with the stored LMI data (no modelling layer)."""
        import clarabel
        t0 = time.perf_counter()
        A, b, sizes = self._svec_data()
        c = self.objective._ncols(self.nvar).toarray().ravel()
        P = sp.csc_matrix((self.nvar, self.nvar))
        settings = clarabel.DefaultSettings()
        settings.verbose = False
        for k, v in options.items():
            if not hasattr(settings, k):
                raise ValueError(f"unknown Clarabel setting {k!r}")
            setattr(settings, k, v)
        solver = clarabel.DefaultSolver(P, c, A, b, [clarabel.PSDTriangleConeT(n) for n in sizes],
                                        settings)
        t1 = time.perf_counter()
        sol = solver.solve()
        t2 = time.perf_counter()
        status = str(sol.status).split(".")[-1]
        ok = status in ("Solved", "AlmostSolved")
        xv = np.asarray(sol.x, dtype=float) if ok else np.full(self.nvar, np.nan)
        return SolveOutcome(xv, ok, status, "CLARABEL", "clarabel", t1 - t0, t2 - t1,
                            inaccurate=status.startswith("Almost"),
                            extra={"iterations": sol.iterations})

    def _solve_ipm(self, options):
        """Own dense HKM interior-point method (``sdp_ipm.py``) on the stored LMI data."""
        from .sdp_ipm import solve_sdp
        t0 = time.perf_counter()
        C, A = [], []
        for _, F, margin in self.lmis:
            n = F.shape[0]
            C.append(-F.const - margin * np.eye(n))
            # A_i = F_i (S = -F(x) - margin I = C - sum x_i F_i)
            A.append(F._ncols(self.nvar).T.toarray().reshape(self.nvar, n, n))
        c = self.objective._ncols(self.nvar).toarray().ravel()
        t1 = time.perf_counter()
        x, status, info = solve_sdp(c, C, A, **options)
        t2 = time.perf_counter()
        ok = status in ("Solved", "AlmostSolved")
        return SolveOutcome(x if ok else np.full(self.nvar, np.nan), ok, status, "IPM", "ipm",
                            t1 - t0, t2 - t1, inaccurate=status.startswith("Almost"), extra=info)

    def _solve_cvxpy(self, solver, options):
        import cvxpy as cp
        t0 = time.perf_counter()
        x = cp.Variable(self.nvar)
        cons = []
        for name, F, margin in self.lmis:
            n = F.shape[0]
            vec = F._ncols(self.nvar) @ x + F.const.ravel()
            expr = cp.reshape(vec, (n, n), order="C")
            cons.append(expr << -margin * np.eye(n))
        obj = self.objective._ncols(self.nvar) @ x + self.objective.const.ravel()
        prob = cp.Problem(cp.Minimize(cp.sum(obj)), cons)
        t1 = time.perf_counter()
        name = {"clarabel": cp.CLARABEL, "scs": cp.SCS, "mosek": cp.MOSEK}[solver]
        try:
            prob.solve(solver=name, **options)
        except cp.error.SolverError as e:
            raise InfeasibleLMIError(f"cvxpy/{solver} failed: {e}", "solver_error") from e
        except Exception as e:  # e.g. MOSEK without a license raises its own error type
            raise SynthesisError(f"cvxpy/{solver} not usable: {type(e).__name__}: {e}") from e
        t2 = time.perf_counter()
        status = str(prob.status)
        ok = status in ("optimal", "optimal_inaccurate")
        xv = np.asarray(x.value, dtype=float) if x.value is not None else np.full(self.nvar, np.nan)
        return SolveOutcome(xv, ok, status, solver.upper(), "cvxpy", t1 - t0, t2 - t1,
                            inaccurate=status.endswith("inaccurate"))

    def _solve_drake(self, solver, options):
        from pydrake.solvers import (ClarabelSolver, CsdpSolver, MathematicalProgram,
                                     MosekSolver, ScsSolver, SolverOptions)
        t0 = time.perf_counter()
        prog = MathematicalProgram()
        x = prog.NewContinuousVariables(self.nvar, "x")
        for name, F, margin in self.lmis:
            n = F.shape[0]
            coef = F._ncols(self.nvar).tocsc()
            used = np.flatnonzero(np.diff(coef.indptr))
            # AddLinearMatrixInequalityConstraint: F0 + sum x_i F_i >= 0, so pass -F - margin I.
            mats = [-F.const - margin * np.eye(n)]
            for j in used:
                Fi = -coef[:, j].toarray().reshape(n, n)
                mats.append(0.5 * (Fi + Fi.T))
            prog.AddLinearMatrixInequalityConstraint(mats, x[used])
        c = self.objective._ncols(self.nvar).toarray().ravel()
        used = np.flatnonzero(c)
        prog.AddLinearCost(c[used], float(self.objective.const[0, 0]), x[used])
        cls = {"clarabel": ClarabelSolver, "scs": ScsSolver, "csdp": CsdpSolver,
               "mosek": MosekSolver}[solver]
        s = cls()
        if not (s.available() and s.enabled()):
            raise SynthesisError(f"Drake solver {solver} is not available/enabled (license?)")
        opts = SolverOptions()
        for k, v in options.items():
            opts.SetOption(s.solver_id(), k, v)
        t1 = time.perf_counter()
        res = s.Solve(prog, None, opts)
        t2 = time.perf_counter()
        status = res.get_solution_result().name
        detail = ""
        try:
            det = res.get_solver_details()
            detail = str(getattr(det, "status", getattr(det, "solution_status", "")))
            if hasattr(det, "scs_status"):  # SCS exit flags: 1 solved, 2 solved/inaccurate
                detail = {1: "solved", 2: "solved inaccurate"}.get(det.scs_status, f"scs_status {det.scs_status}")
        except Exception:  # details type differs per solver; purely informative
            pass
        xv = np.asarray(res.GetSolution(x), dtype=float)
        inacc = "inaccurate" in detail.lower() or "almost" in detail.lower()
        return SolveOutcome(xv, res.is_success(), status + (f" ({detail})" if detail else ""),
                            solver.upper(), "drake", t1 - t0, t2 - t1, inaccurate=inacc)
