"""Successive Galerkin approximation (SGAA) of the W2, W∞ and classic H∞ HJ equations.

Thesis chapter 4: Algorithm 4.1 (W2, HJB (4.9)), Algorithm 4.2 (W∞, HJBI (4.23), inner
disturbance loop) and the H∞ SGAA of Beard & McLain (1998) used as the baseline.  Each iteration
solves the *generalized* HJ equation of the current policy, which is linear in the coefficients
c of V = cᵀΦ, by the Galerkin projection (4.24)–(4.29) on a box Ω, then updates the policy
((4.8), (4.19)/(4.20)).  Integrals use a tensor Gauss–Legendre rule (default) or the thesis'
composite midpoint rule.  The maths of the costs and of the precomputed tensors is in
:mod:`sobolev_drake.synthesis.galerkin_problem`; bases and quadrature in
:mod:`sobolev_drake.synthesis.galerkin_basis`.

Public API
----------
``GalerkinProblem(model, cost, basis, box, quadrature=...)`` and ``problem.solve(u0, ...)``,
or the functional forms :func:`sgaa_w2`, :func:`sgaa_winf`, :func:`sgaa_hinf`.  The result
(:class:`GalerkinResult`) evaluates V, ∇V, u*(x), w*(x) and the HJ residual anywhere
(vectorized), and records the iteration history.  V, ∇V, u* and w* also evaluate on object
arrays of AutoDiffXd or symbolic Expression (the same expressions; the small saddle solve by
elimination), when the model's and the cost's functions accept them; ``feedback_gain()`` is
then the exact AutoDiffXd derivative of u* at the origin.

Safety: the initial control is checked to stabilize the model on Ω (linearization + sampled
trajectories, :func:`check_admissible`), the saddle-point condition (4.22) is checked at every
node (:class:`SaddlePointError`), and a diverging run raises :class:`GalerkinDivergenceError`
(never returning its coefficients).

W∞ disturbance update: ``disturbance_update="best_response"`` (default) uses
w = argmax_w H(V, u⁽ⁱ⁾, w), so that the inner loop is the maximizing player's policy iteration
of Beard & McLain (monotone); ``"saddle"`` uses the thesis' (4.19) literally (the joint saddle
for the current V).  Both have the same fixed point (the HJBI solution).  When the disturbance
enters through the range of g (k = gE) the W∞ worst-case disturbance is zero and W∞ = W2
(Remarks 30/36).

Notes on the thesis text (checked against the linear Riccati limits in the tests):
(4.15) has inconsistent factors (the cross terms fᵀBgu etc. carry no ½, the disturbance term is
−½γ²wᵀw as in (4.13)); (4.21)/(4.22) drop σ₁ (the Hessians are gᵀ∇hᵀσ₁∇hg and
kᵀ∇hᵀσ₁∇hk − γ²I); (4.22) is the condition for the maximization at fixed u, which implies the
invertibility of the matrix in (4.19); Algorithm 4.2 leaves w⁽ⁱ'⁰⁾ undefined for i > 0 (we warm
start from w⁽ⁱ⁻¹'∞⁾); the separable approximation (4.33) of the midpoint rule is not an identity
for coupled integrands, so :func:`midpoint` integrates on the full tensor grid.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np
from numpy.typing import ArrayLike

from sobolev_drake.validation import real_scalar
from sobolev_drake.synthesis.galerkin_basis import (Box, FunctionBasis, ObjectEvaluationError, PolynomialBasis,
                                                    QuadratureRule, check_points, gauss_legendre)
from sobolev_drake.synthesis.galerkin_problem import (
    AdmissibilityError, AffineGalerkinSystem, GalerkinConvergenceError, GalerkinDivergenceError,
    HinfCost, InputAffineModel, NodeData, SaddlePointError, W2Cost, WinfCost, autodiff_jacobian,
    bmm, bmv, quiet as _quiet, solve_galerkin, solve_quasidefinite)

__all__ = ["GalerkinProblem", "GalerkinResult", "sgaa_w2", "sgaa_winf", "sgaa_hinf",
           "check_admissible", "closed_loop_jacobian", "W2Cost", "WinfCost", "HinfCost",
           "InputAffineModel", "GalerkinDivergenceError", "GalerkinConvergenceError",
           "AdmissibilityError", "SaddlePointError"]


def closed_loop_jacobian(fun: Callable, n: int, h: float = 1e-6) -> np.ndarray:
    """Central-difference Jacobian at the origin of a vectorized vector field ``fun(X)``."""
    E = h * np.eye(n)
    Y = np.asarray(fun(np.vstack([E, -E])), dtype=float)
    return ((Y[:n] - Y[n:]) / (2 * h)).T


def _rk4_batch(fun, X0, dt, steps):
    X = X0.copy()
    for _ in range(steps):
        k1 = fun(X)
        k2 = fun(X + 0.5 * dt * k1)
        k3 = fun(X + 0.5 * dt * k2)
        k4 = fun(X + dt * k3)
        X = X + dt / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
        if not np.all(np.isfinite(X)) or np.abs(X).max() > 1e8:
            return X, False
    return X, True


def check_admissible(model: InputAffineModel, u0: Callable, box: Box, *, samples: int = 64,
                     simulate: bool = True, tol: float = 0.05, seed: int = 0) -> dict:
    """Check that ``u0`` stabilizes ẋ = f + g u0 (w = 0) on Ω, raise :class:`AdmissibilityError`.

    1. The linearization at the origin must be Hurwitz.
    2. (``simulate``) trajectories from the vertices of Ω and ``samples`` random points are
       integrated (vectorized RK4) for 15 slowest linear time constants; every one must end
       with ‖x(T)/half-width‖∞ ≤ ``tol``.

    Returns diagnostics (eigenvalues, horizon, worst final state).
    """
    n = model.n

    def closed(X):
        F, G = model.evaluate(X)
        U = np.asarray(u0(X), dtype=float)
        if U.shape != (X.shape[0], model.nu):
            raise ValueError(f"u0(X) must return shape (Q, {model.nu}), got {U.shape}")
        return F + bmv(G[:, :, :model.nu], U)

    J = closed_loop_jacobian(closed, n)
    eig = np.linalg.eigvals(J)
    info = {"u0_linearization_eigenvalues": eig}
    if eig.real.max() >= 0:
        raise AdmissibilityError(
            "u0 is not admissible: the closed-loop linearization at the origin is not Hurwitz "
            f"(eigenvalues {np.round(eig, 4).tolist()}); check the sign convention u = +Kx "
            "vs u = −Kx")
    if not simulate:
        return info
    alpha = -eig.real.max()
    rho = np.abs(eig).max()
    T = 15.0 / alpha
    dt = min(0.25 / rho, T / 100)
    steps = int(min(6000, np.ceil(T / dt)))
    dt = T / steps
    X0 = np.vstack([box.vertices(), box.sample(samples, seed=seed)])
    XT, finite = _rk4_batch(closed, X0, dt, steps)
    half = 0.5 * (box.upper - box.lower)
    final = np.abs(XT / half).max(axis=1) if finite else np.full(X0.shape[0], np.inf)
    info.update(horizon=T, worst_final=float(np.nanmax(final)))
    bad = ~(final <= tol)
    if bad.any():
        raise AdmissibilityError(
            f"u0 is not admissible on Ω: {int(bad.sum())} of {X0.shape[0]} sampled initial "
            f"states do not converge within {T:.3g} s (e.g. x0 = "
            f"{np.round(X0[np.argmax(bad)], 4).tolist()}); shrink the box or choose another u0")
    return info


@dataclass
class GalerkinResult:
    """Outcome of an SGAA run (only ever built from a converged, non-diverged run).

    ``coefficients`` c of V = cᵀΦ; ``history`` one dict per (outer) iteration with
    ``coef_change`` ‖c⁽ⁱ⁾ − c⁽ⁱ⁻¹⁾‖₂, ``residual_rms`` / ``residual_rel`` (HJ residual of V⁽ⁱ⁾
    with its own saddle policy, on the test points; rel = rms / rms of ℓ), ``cost_integral``
    ∫Ω V⁽ⁱ⁾ dΩ and ``inner_iterations``; ``diagnostics`` admissibility, saddle margin, timing.
    """

    kind: str
    coefficients: np.ndarray
    basis: object
    problem: "GalerkinProblem"
    history: list = field(default_factory=list)
    iterations: int = 0
    diagnostics: dict = field(default_factory=dict)

    def value(self, X: ArrayLike) -> np.ndarray:
        """V(X) = Φ(X) c, shape (Q,) (X float, or an object array as in :meth:`decision`)."""
        with _quiet(X):
            return self.basis.evaluate(X) @ self.coefficients

    def gradient(self, X: ArrayLike) -> np.ndarray:
        """∇V(X), shape (Q, n) (X float, or an object array as in :meth:`decision`)."""
        with _quiet(X):
            return np.tensordot(self.basis.gradient(X), self.coefficients, axes=(1, 0))

    def decision(self, X: ArrayLike) -> np.ndarray:
        """Saddle decision v* = [u*; w*] = −S⁻¹(½Gᵀ∇V + s) at X (shape (Q, nu + nw)).

        Float X: vectorized, S⁻¹ by batched LU (the fast path).  Object X (AutoDiffXd or
        Expression): the same expressions, S⁻¹ by elimination (:func:`solve_quasidefinite`),
        equal up to rounding; the basis, f, g, k and ∇h must accept object arrays, else an
        ``ObjectEvaluationError`` (a ``TypeError``) names the function.

        Parameters
        ----------
        X : array_like, shape (Q, n) or (n,)
            Design states: floats, or an object array of AutoDiffXd or Expression.

        Returns
        -------
        ndarray, shape (Q, nu + nw)
            Float, or object entries of the scalar type of X.
        """
        prob = self.problem
        X = check_points("X", X, prob.model.n, keep_object=True)
        with _quiet(X):
            dV = self.coefficients @ self.basis.gradient(X)  # (Q, n)
            F, G = prob.model.evaluate(X)
            s, S = prob.cost.decision_terms(X, F, G, prob.model.nu)
            rhs = 0.5 * bmv(G.transpose(0, 2, 1), dV) + s
            if X.dtype == object:
                return -solve_quasidefinite(S, rhs)
        return -np.linalg.solve(S, rhs[:, :, None])[:, :, 0]

    def control(self, X: ArrayLike) -> np.ndarray:
        """u*(X) of (4.8) / (4.20) / H∞, shape (Q, nu)."""
        return self.decision(X)[:, :self.problem.model.nu]

    def disturbance(self, X: ArrayLike) -> np.ndarray:
        """Worst-case w*(X) of (4.19) (shape (Q, nw))."""
        return self.decision(X)[:, self.problem.model.nu:]

    def residual(self, X: ArrayLike) -> np.ndarray:
        """HJ residual ∇Vᵀ(f + g u* + k w*) + ℓ(x, u*, w*) at X."""
        nodes = self.problem.nodes_at(check_points("X", X, self.problem.model.n))
        return nodes.hamiltonian(self.coefficients, nodes.saddle(self.coefficients))

    def feedback_gain(self, method: str = "auto") -> np.ndarray:
        """Linearization u ≈ K x at the origin, shape (nu, n).

        ``"autodiff"``: K = ∂u*/∂x(0) to rounding, u* evaluated on AutoDiffXd (see
        :meth:`decision`); ``"central"``: central differences, step h = 1e-6 (error
        h²/6·|u‴| + ε|u|/h); ``"auto"``: AutoDiffXd, or central differences when a function of
        the design is double only (e.g. it fills ``np.empty`` float arrays).

        Parameters
        ----------
        method : {"auto", "autodiff", "central"}, default "auto"
            How to differentiate u* at the origin.

        Returns
        -------
        ndarray, shape (nu, n)
            K with u*(x) = K x + O(|x|²) (u = +K x).
        """
        if method not in ("auto", "autodiff", "central"):
            raise ValueError(f"method must be 'auto', 'autodiff' or 'central', got {method!r}")
        n = self.problem.model.n
        if method != "central":
            try:
                return autodiff_jacobian(self.control, np.zeros(n))
            except ObjectEvaluationError:
                if method == "autodiff":
                    raise
        return closed_loop_jacobian(self.control, n)


class GalerkinProblem:
    """An SGAA design: model, cost, basis, box Ω and quadrature rule.

    Parameters
    ----------
    model : :class:`InputAffineModel` (f, g, k).
    cost : :class:`W2Cost`, :class:`WinfCost` or :class:`HinfCost`.
    basis : :class:`~sobolev_drake.synthesis.galerkin_basis.PolynomialBasis` or
        :class:`~sobolev_drake.synthesis.galerkin_basis.FunctionBasis`.
    box : :class:`Box` Ω.
    quadrature : :class:`QuadratureRule` on Ω, or an int (Gauss–Legendre nodes per axis);
        default ``degree + 2`` nodes per axis for polynomial bases.
    test_points : points for the residual diagnostics (default 2000 seeded random points of Ω).
    """

    def __init__(self, model: InputAffineModel, cost: W2Cost | WinfCost | HinfCost,
                 basis: PolynomialBasis | FunctionBasis, box: Box, quadrature: QuadratureRule | int | None = None,
                 test_points: ArrayLike | None = None) -> None:
        if not isinstance(box, Box):
            raise TypeError(f"box must be a Box, got {type(box).__name__}")
        if box.n != model.n or basis.n != model.n:
            raise ValueError(f"dimensions disagree: model n = {model.n}, box n = {box.n}, "
                             f"basis n = {basis.n}")
        if cost.kind == "w2" and model.nw:
            raise ValueError("W2Cost has no disturbance term: build the model with k=None "
                             "(or use WinfCost)")
        if cost.kind == "winf" and not model.nw:
            raise ValueError("WinfCost needs a disturbance channel k(x)")
        gam = cost.gamma_value()
        if gam is not None and not (np.isfinite(gam) and gam > 0):
            raise ValueError(f"gamma must be a positive finite number, got {gam}")
        self.model, self.cost, self.basis, self.box = model, cost, basis, box
        if quadrature is None:
            quadrature = getattr(basis, "degree", 4) + 2
        if isinstance(quadrature, (int, np.integer)):
            quadrature = gauss_legendre(box, int(quadrature))
        if not isinstance(quadrature, QuadratureRule):
            raise TypeError("quadrature must be a QuadratureRule or an int")
        self.quadrature = quadrature
        self.test_points = box.sample(2000, seed=12345) if test_points is None else \
            check_points("test_points", test_points, model.n)
        self.nodes = NodeData(model, cost, basis, quadrature.points, quadrature.weights)
        self._check_basis()
        self.saddle_margin = self._check_saddle(self.nodes)
        self._test = self.nodes_at(self.test_points)
        self._check_saddle(self._test)

    def nodes_at(self, X: np.ndarray) -> NodeData:
        return NodeData(self.model, self.cost, self.basis, X, np.zeros(X.shape[0]))

    def _check_basis(self):
        Wphi = self.nodes.Phi * self.nodes.w[:, None]
        gram = Wphi.T @ self.nodes.Phi
        ev = np.linalg.eigvalsh(gram)
        if ev.min() <= 1e-12 * ev.max():
            raise ValueError(
                f"degenerate basis: the Gram matrix ∫Ω ΦΦᵀ dΩ is singular on the quadrature "
                f"nodes (eigenvalues {ev.min():.2e} .. {ev.max():.2e}); remove linearly "
                "dependent basis functions or use more quadrature nodes")
        self.gram_condition = float(ev.max() / ev.min())

    def _check_saddle(self, nodes):
        """(4.22), corrected: ∂²H/∂w² = kᵀ∇hᵀσ₁∇hk − γ²I < 0 (for H∞: −γ²I)."""
        nu, nw = self.model.nu, self.model.nw
        if not nw:
            return None
        Sww = 2.0 * nodes.S[:, nu:, nu:]  # = ∂²H/∂w²
        lam = np.linalg.eigvalsh(Sww).max(axis=1)
        worst = int(np.argmax(lam))
        if lam[worst] >= 0:
            gam = self.cost.gamma_value()
            need = np.sqrt(gam ** 2 + lam.max())
            raise SaddlePointError(
                f"gamma = {gam:g} violates the saddle-point condition (4.22) "
                f"kᵀ∇hᵀσ₁∇hk − γ²I < 0 at x = {np.round(nodes.X[worst], 4).tolist()} "
                f"(max eigenvalue {lam[worst]:.3g}); need gamma > {need:.4g} on Ω")
        return float(-lam.max())

    # ------------------------------------------------------------------------------------
    def _record(self, history, it, c, c_prev, inner=0, t0=None):
        ham = self._test.hamiltonian(c, self._test.saddle(c))
        ell = self._test.running_cost(self._test.saddle(c))
        rec = {"iteration": it, "inner_iterations": inner,
               "coef_change": float(np.linalg.norm(c - c_prev)) if c_prev is not None else np.nan,
               "coef_norm": float(np.linalg.norm(c)),
               "residual_rms": float(np.sqrt(np.mean(ham ** 2))),
               "residual_rel": float(np.sqrt(np.mean(ham ** 2)) / max(1e-300, np.sqrt(np.mean(ell ** 2)))),
               "cost_integral": float(self.quadrature.integrate(self.nodes.Phi @ c)),
               "time": time.perf_counter() - t0 if t0 is not None else np.nan}
        history.append(rec)
        return rec

    def _check_step(self, history, c, c_ref_norm, label):
        if not np.all(np.isfinite(c)):
            raise GalerkinDivergenceError(f"{label}: non-finite coefficients", history)
        if np.linalg.norm(c) > self.divergence_factor * max(c_ref_norm, 1e-12):
            raise GalerkinDivergenceError(
                f"{label}: coefficients grew by more than {self.divergence_factor:g}× "
                f"(‖c‖ = {np.linalg.norm(c):.3e}); the iteration diverges", history)

    def _check_policy(self, history, c, label):
        """Each u⁽ⁱ⁾ must stay admissible (Beard): its linearization must be Hurwitz."""
        nu = self.model.nu

        def closed(X):
            nodes = self.nodes_at(X)
            v = nodes.saddle(c)
            return nodes.F + bmv(nodes.G[:, :, :nu], v[:, :nu])

        eig = np.linalg.eigvals(closed_loop_jacobian(closed, self.model.n))
        if eig.real.max() >= 0:
            raise GalerkinDivergenceError(
                f"{label}: the updated control is not stabilizing at the origin (eigenvalues "
                f"{np.round(eig, 4).tolist()}); the approximation diverged (basis too poor, "
                "Ω too large, or gamma too small)", history)
        return eig

    def solve(self, u0: Callable, *, tol: float = 1e-9, max_iter: int = 60, inner_tol: float | None = None,
              max_inner: int = 60, method: str = "direct", disturbance_update: str = "best_response",
              check_u0: str = "simulate", divergence_factor: float = 1e6,
              atol: float = 0.0) -> GalerkinResult:
        """Run the SGAA from the admissible control ``u0(X) -> (Q, nu)``.

        Stops when ‖c⁽ⁱ⁾ − c⁽ⁱ⁻¹⁾‖₂ ≤ max(atol, tol·max(1, ‖c⁽ⁱ⁾‖₂)) (the thesis uses the
        absolute criterion ‖Δc‖₂ < 0.1, i.e. ``atol=0.1``; Remark 18).
        ``check_u0``: "simulate" (linearization + sampled trajectories), "linearization" or
        "none".  Raises :class:`GalerkinConvergenceError` when the budget runs out.

        ``method``: both methods use the per-node policy maps v = v₀ + L c precomputed once.
        ``"tensor"`` also precomputes A₁ (N³·Q work once, then N³ per solve); ``"direct"``
        (default) assembles A from the nodes at every solve (N²·Q per solve).  The tensor pays
        off only beyond ~N Galerkin solves; the balance W∞ design needs ~25 and is ~1.5× faster
        with ``"direct"`` (``benchmarks/galerkin.py``).  Results agree to round-off.
        """
        if disturbance_update not in ("best_response", "saddle"):
            raise ValueError("disturbance_update must be 'best_response' or 'saddle'")
        if check_u0 not in ("simulate", "linearization", "none"):
            raise ValueError("check_u0 must be 'simulate', 'linearization' or 'none'")
        real_scalar("tol", tol, low=0.0)
        real_scalar("atol", atol, low=0.0)
        if inner_tol is not None:
            real_scalar("inner_tol", inner_tol, low=0.0)
        if isinstance(max_iter, (bool, np.bool_)) or not isinstance(max_iter, (int, np.integer)) or max_iter < 1:
            raise ValueError(f"max_iter must be an integer >= 1, got {max_iter!r}")
        self.divergence_factor = real_scalar("divergence_factor", divergence_factor, low=1.0, low_open=True)
        inner_tol = tol if inner_tol is None else inner_tol
        t0 = time.perf_counter()
        diag = {"quadrature": self.quadrature.name, "nodes": self.quadrature.size,
                "basis_terms": len(self.basis), "gram_condition": self.gram_condition,
                "saddle_margin": self.saddle_margin, "method": method}
        if check_u0 != "none":
            diag.update(check_admissible(self.model, u0, self.box,
                                         simulate=(check_u0 == "simulate")))
        nodes, nu, nw = self.nodes, self.model.nu, self.model.nw
        U0 = np.asarray(u0(nodes.X), dtype=float)
        if U0.shape != (nodes.X.shape[0], nu):
            raise ValueError(f"u0(X) must return shape (Q, {nu}), got {U0.shape}")
        history: list = []
        atol = float(atol)
        converged = lambda c, cp, t: np.linalg.norm(c - cp) <= max(
            atol, t * max(1.0, np.linalg.norm(c)))

        def outer_loop(step, c, what):
            """Policy iterations i = 1..max_iter: step(c, i) -> (c_next, inner iterations)."""
            for it in range(1, max_iter + 1):
                self._check_policy(history, c, f"iteration {it}")
                c_new, nin = step(c, it)
                self._record(history, it, c_new, c, inner=nin, t0=t0)
                done = converged(c_new, c, tol)
                c = c_new
                if done:
                    return c
            raise GalerkinConvergenceError(
                f"SGAA did not converge in {max_iter} {what} (last change "
                f"{history[-1]['coef_change']:.3e})", history)

        if not nw:  # ---------------- Algorithm 4.1 (W2) / H2 ------------------------------
            c = solve_galerkin(*nodes.system(U0))
            c_ref = np.linalg.norm(c)
            self._record(history, 0, c, None, t0=t0)
            self._check_step(history, c, c_ref, "iteration 0")
            t_pre = time.perf_counter()
            sysA = AffineGalerkinSystem(nodes, nodes.v0_saddle, nodes.L_saddle, method=method)
            diag["tensor_time"] = time.perf_counter() - t_pre
            def sgaa_step(c_in, it):
                c_next = sysA.solve(c_in)
                self._check_step(history, c_next, c_ref, f"iteration {it}")
                return c_next, 0

            c = outer_loop(sgaa_step, c, "iterations")
        else:  # ---------------------- Algorithm 4.2 (W∞) / Beard's H∞ ---------------------
            def inner_loop(solve_for, c_start, c_ref, it):
                c_in, changes = c_start, []
                for j in range(1, max_inner + 1):
                    c_next = solve_for(c_in)
                    self._check_step(history, c_next, c_ref, f"iteration {it}, inner {j}")
                    changes.append(float(np.linalg.norm(c_next - c_in)))
                    if converged(c_next, c_in, inner_tol):
                        return c_next, j
                    c_in = c_next
                raise GalerkinDivergenceError(
                    f"iteration {it}: the disturbance loop did not converge in {max_inner} "
                    f"steps (last coefficient changes {np.round(changes[-4:], 4).tolist()}; "
                    "Remark 20: gamma too small for this control, or the closed loop leaves Ω)",
                    history)

            # i = 0: u = u0 fixed, w(0,0) = 0
            c = solve_galerkin(*nodes.system(np.hstack([U0, np.zeros((U0.shape[0], nw))])))
            c_ref = max(np.linalg.norm(c), 1e-12)

            def solve_i0(c_in):
                if disturbance_update == "saddle":
                    W = nodes.saddle(c_in)[:, nu:]
                else:
                    W = nodes.best_response_w(c_in, U0)
                return solve_galerkin(*nodes.system(np.hstack([U0, W])))

            c, nin = inner_loop(solve_i0, c, c_ref, 0)
            self._record(history, 0, c, None, inner=nin, t0=t0)
            # i ≥ 1: p = [c_outer; c_inner]; u = u*(c_outer), w from c_inner (and u)
            Qn, N = nodes.Phi.shape
            m = nu + nw
            v0 = nodes.v0_saddle.copy()
            L = np.zeros((Qn, m, 2 * N))
            L[:, :nu, :N] = nodes.L_saddle[:, :nu, :]
            if disturbance_update == "saddle":
                L[:, nu:, N:] = nodes.L_saddle[:, nu:, :]
            else:
                Sww_inv, Swu = nodes.Sww_inv, nodes.S[:, nu:, :nu]
                v0[:, nu:] = -bmv(Sww_inv, nodes.s[:, nu:] + bmv(Swu, nodes.v0_saddle[:, :nu]))
                L[:, nu:, N:] = -0.5 * bmm(Sww_inv, nodes.GtdPhi[:, nu:, :])
                L[:, nu:, :N] = -bmm(bmm(Sww_inv, Swu), nodes.L_saddle[:, :nu, :])
            t_pre = time.perf_counter()
            sysA = AffineGalerkinSystem(nodes, v0, L, method=method, slow=N)
            diag["tensor_time"] = time.perf_counter() - t_pre
            def outer_step(c_outer, it):
                return inner_loop(lambda ci: sysA.solve(np.concatenate([c_outer, ci])),
                                  c_outer, c_ref, it)

            c = outer_loop(outer_step, c, "outer iterations")

        diag["closed_loop_eigenvalues"] = self._check_policy(history, c, "final")
        Vt = self._test.Phi @ c
        r2 = np.sum(self.test_points ** 2, axis=1)
        diag["min_V_over_norm2"] = float(np.min(Vt[r2 > 0] / r2[r2 > 0]))
        diag["total_time"] = time.perf_counter() - t0
        return GalerkinResult(self.cost.kind, c, self.basis, self, history, len(history) - 1, diag)


# --- functional API (python-control style) ------------------------------------------------
def _problem(f, g, k, cost, basis, box, quadrature, n):
    if not isinstance(box, Box):
        box = Box(*box)
    n = box.n if n is None else n
    model = InputAffineModel(f, g, k, n=n)
    return GalerkinProblem(model, cost, basis, box, quadrature)


def sgaa_w2(f: Callable, g: Callable, h: Callable, dh: Callable, sigma0: ArrayLike, sigma1: ArrayLike,
            u0: Callable, basis: PolynomialBasis | FunctionBasis, box: Box | tuple[ArrayLike, ArrayLike],
            *, quadrature: QuadratureRule | int | None = None, n: int | None = None, **kw: Any) -> GalerkinResult:
    """W2 controller by Algorithm 4.1; returns :class:`GalerkinResult`.  ``box`` is a
    :class:`Box` or a (lower, upper) pair; ``kw`` go to :meth:`GalerkinProblem.solve`."""
    prob = _problem(f, g, None, W2Cost(h, dh, sigma0, sigma1), basis, box, quadrature, n)
    return prob.solve(u0, **kw)


def sgaa_winf(f: Callable, g: Callable, k: Callable, h: Callable, dh: Callable, sigma0: ArrayLike,
              sigma1: ArrayLike, gamma: float, u0: Callable, basis: PolynomialBasis | FunctionBasis,
              box: Box | tuple[ArrayLike, ArrayLike], *, quadrature: QuadratureRule | int | None = None,
              n: int | None = None, **kw: Any) -> GalerkinResult:
    """W∞ controller by Algorithm 4.2 (inner disturbance loop)."""
    prob = _problem(f, g, k, WinfCost(h, dh, sigma0, sigma1, gamma), basis, box, quadrature, n)
    return prob.solve(u0, **kw)


def sgaa_hinf(f: Callable, g: Callable, k: Callable | None, h: Callable, Q: ArrayLike, R: ArrayLike,
              gamma: float, u0: Callable, basis: PolynomialBasis | FunctionBasis,
              box: Box | tuple[ArrayLike, ArrayLike], *, quadrature: QuadratureRule | int | None = None,
              n: int | None = None, **kw: Any) -> GalerkinResult:
    """Classic nonlinear H∞ by the SGAA of Beard & McLain (1998): cost hᵀQh + uᵀRu − γ²wᵀw.
    ``k=None`` gives the nonlinear H2 (GHJB) iteration."""
    prob = _problem(f, g, k, HinfCost(h, Q, R, gamma if k is not None else 1.0), basis, box,
                    quadrature, n)
    return prob.solve(u0, **kw)
