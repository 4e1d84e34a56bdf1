"""Scalar-generic Galerkin law (issue #31): u*(x) on AutoDiffXd / Expression, AutoDiffXd gain.

Tolerances.  The float path and the object (AutoDiffXd, Expression) path evaluate the same
expressions except (i) the powers (x/s)ᵖ, pow against repeated products (≤ d roundings),
(ii) ∇V = Σ c_k∇φ_k summed in another order (N terms), (iii) sin/cos of NumPy against
libm (a few ulps), (iv) S⁻¹ by LU against elimination (m ≤ 3).  Componentwise rounding
bounds (Higham, ch. 3 and 9) give |Δv| ≤ k ε T with k = N + d + 3m + 8 and the term scale
T = |S⁻¹|(½|G|ᵀ Σ_k|c_k||∇φ_k| + |s|) + |S⁻¹||S||v| (:func:`term_scale`); both paths round, so
the test allows 2 k ε T.

Central differences with step h of column i of the gain have the truncation error
h²/6 ∂ᵢ³u (the pure third derivative along eᵢ, estimated from second differences of the
AutoDiffXd Jacobian with step δ = 0.05, doubled for the O(δ²) error of that estimate) and the
rounding error k ε (T(heᵢ) + T(−heᵢ)) / (2h); the AutoDiffXd gain rounds its derivative terms,
whose scale is T(heᵢ)/h as h → 0, so the rounding allowance is doubled.  (Measured: the
difference is h²/6 ∂ᵢ³u to three digits, i.e. the AutoDiffXd gain is exact and the central
differences' error is their truncation, 2e-12 here.)
"""

import numpy as np
import pytest
from pydrake.autodiffutils import ExtractGradient, ExtractValue, InitializeAutoDiff
from pydrake.symbolic import Expression, Variable

from sobolev_drake.synthesis.galerkin import (GalerkinProblem, HinfCost, InputAffineModel,
                                              W2Cost, WinfCost, closed_loop_jacobian)
from sobolev_drake.synthesis.galerkin_basis import Box, ObjectEvaluationError, PolynomialBasis
from sobolev_drake.synthesis.galerkin_problem import solve_quasidefinite

EPS = np.finfo(float).eps
H_FD = 1e-6          # the step of closed_loop_jacobian


# --- a nonlinear pendulum-like model written with dtype-preserving NumPy code ---------------
def f_pend(X):
    return np.stack([X[:, 1], np.sin(X[:, 0]) - 0.2 * X[:, 1]], axis=1)


def g_pend(X):
    out = np.zeros((X.shape[0], 2, 1), dtype=X.dtype)
    out[:, 1, 0] = 1.0 / (1.0 + 0.5 * np.cos(X[:, 0]) ** 2)
    return out


def k_pend(X):
    out = np.zeros((X.shape[0], 2, 1), dtype=X.dtype)
    out[:, 0, 0] = 0.3
    out[:, 1, 0] = 0.5 * np.cos(X[:, 0])
    return out


def _identity_h(n):
    return (lambda X: X), (lambda X: np.broadcast_to(np.eye(n), (X.shape[0], n, n)))


SIGMA1_PEND = np.diag([0.5, 0.2])


def pendulum_law(kind):
    """W2 / W∞ / H∞ SGAA law of the pendulum (degree-4 basis, 8² nodes; ~0.1 s)."""
    h, dh = _identity_h(2)
    if kind == "w2":
        model, cost = InputAffineModel(f_pend, g_pend, None, n=2), W2Cost(h, dh, np.eye(2), SIGMA1_PEND)
    elif kind == "winf":
        model = InputAffineModel(f_pend, g_pend, k_pend, n=2)
        cost = WinfCost(h, dh, np.eye(2), SIGMA1_PEND, 2.0)
    else:
        model, cost = InputAffineModel(f_pend, g_pend, k_pend, n=2), HinfCost(h, np.eye(2), [[0.5]], 2.0)
    prob = GalerkinProblem(model, cost, PolynomialBasis(2, 4), Box.symmetric([0.8, 1.5]),
                           quadrature=8)
    return prob.solve(lambda X: -(X @ np.array([6.0, 3.0]))[:, None], tol=1e-10)


@pytest.fixture(scope="module", params=["w2", "winf", "hinf"])
def law(request):
    return pendulum_law(request.param)


def term_scale(res, X):
    """T(X) of the module docstring, shape (Q, m): the size of the terms summed for v*(X)."""
    prob = res.problem
    F, G = prob.model.evaluate(X)
    s, S = prob.cost.decision_terms(X, F, G, prob.model.nu)
    if hasattr(prob.cost, "sigma1"):   # s = ½GᵀBF with B = σ₁ (h = x)
        s = 0.5 * np.einsum("qij,ik,qk->qj", np.abs(G), np.abs(prob.cost.sigma1), np.abs(F))
    dV = np.abs(res.coefficients) @ np.abs(prob.basis.gradient(X))
    Sinv = np.abs(np.linalg.inv(S))
    rhs = 0.5 * np.einsum("qij,qi->qj", np.abs(G), dV) + np.abs(s)
    v = np.abs(res.decision(X))
    return np.einsum("qij,qj->qi", Sinv, rhs) + np.einsum("qij,qjk,qk->qi", Sinv, np.abs(S), v)


def rounding_factor(res):
    """k = N + d + 3m + 8 of the module docstring."""
    return len(res.basis) + res.basis.degree + 3 * res.problem.model.m + 8


def autodiff_jacobian(res, x):
    """∂u*/∂x at x by AutoDiffXd through the public ``control``."""
    u = res.control(InitializeAutoDiff(np.asarray(x, float)).ravel()[None, :])[0]
    return ExtractGradient(u)


POINTS = np.array([[0.3, -1.0], [-0.7, 1.4], [0.05, 0.1], [0.0, 0.0], [0.8, 1.5]])


# ---------------------------------------------------------------- generic path = float path
def test_autodiff_and_symbolic_law_equal_the_float_law(law):
    U = law.decision(POINTS)
    tol = 2 * rounding_factor(law) * EPS * term_scale(law, POINTS)
    Xad = np.array([InitializeAutoDiff(x).ravel() for x in POINTS])
    Uad = law.decision(Xad)
    assert Uad.dtype == object and Uad.shape == U.shape
    assert np.all(np.abs(ExtractValue(Uad.ravel()).reshape(U.shape) - U) <= tol)
    # the derivatives are those of the same expression: the gradient of V by AutoDiffXd is ∇V
    dV = law.gradient(POINTS)
    Vad = law.value(Xad)
    dV_ad = np.array([v.derivatives() for v in Vad])
    np.testing.assert_allclose(dV_ad, dV, rtol=0, atol=2 * rounding_factor(law) * EPS *
                               (np.abs(law.coefficients) @ np.abs(law.basis.gradient(POINTS))).max())

    xv = [Variable(f"x{i}") for i in range(2)]
    Usym = law.control(np.array([[Expression(v) for v in xv]]))[0]
    for x, u, t in zip(POINTS, U[:, :1], tol[:, :1]):
        env = dict(zip(xv, x))
        got = np.array([e.Evaluate(env) for e in Usym])
        assert np.all(np.abs(got - u) <= t), (x, got - u, t)


def test_quasidefinite_elimination_equals_lu():
    rng = np.random.default_rng(0)
    M = rng.normal(size=(5, 2, 2))
    Suu = np.einsum("qij,qkj->qik", M, M) + np.eye(2)           # ≻ 0
    Sww = -np.eye(1) - rng.random((5, 1, 1))                       # ≺ 0
    Suw = rng.normal(size=(5, 2, 1))
    S = np.block([[Suu, Suw], [Suw.transpose(0, 2, 1), Sww]])
    r = rng.normal(size=(5, 3))
    x = solve_quasidefinite(S, r).astype(float)
    ref = np.linalg.solve(S, r[:, :, None])[:, :, 0]
    # both backward stable: |Δx| ≤ 2·3m ε |S⁻¹||S||x| (m = 3)
    bound = 18 * EPS * np.einsum("qij,qjk,qk->qi", np.abs(np.linalg.inv(S)), np.abs(S), np.abs(ref))
    assert np.all(np.abs(x - ref) <= bound)


# ------------------------------------------------------------------- AutoDiffXd gain vs FD
def test_autodiff_gain_equals_central_differences_at_their_accuracy(law):
    n = 2
    K_ad = law.feedback_gain()
    assert K_ad.shape == (1, n)
    np.testing.assert_array_equal(K_ad, law.feedback_gain("autodiff"))
    K_fd = law.feedback_gain("central")
    np.testing.assert_array_equal(K_fd, closed_loop_jacobian(law.control, n))
    k, delta, J0 = rounding_factor(law), 0.05, autodiff_jacobian(law, np.zeros(n))
    for i in range(n):
        e = np.eye(n)[i]
        d3 = (autodiff_jacobian(law, delta * e) - 2 * J0 + autodiff_jacobian(law, -delta * e))[:, i] / delta ** 2
        T = term_scale(law, np.array([H_FD * e, -H_FD * e]))[:, :1]
        tol = 2 * H_FD ** 2 / 6 * np.abs(d3) + 2 * k * EPS * T.sum(axis=0) / (2 * H_FD)
        assert np.all(np.abs(K_ad[:, i] - K_fd[:, i]) <= tol), (i, K_ad[:, i] - K_fd[:, i], tol)


# a linear plant: with h = x the gain at the origin has a closed form in the coefficients
A = np.array([[0.0, 1.0, 0.0], [2.0, -0.5, 1.0], [0.0, 0.0, -1.0]])
Bu = np.array([[0.0], [1.0], [0.5]])
Kw = np.array([[0.0], [0.0], [1.0]])
S0, S1, GAMMA = np.diag([1.0, 2.0, 3.0]), np.diag([0.5, 0.2, 0.3]), 3.0


def _linear_law(kind, f=None):
    h, dh = _identity_h(3)
    g = lambda X: np.broadcast_to(Bu, (X.shape[0], 3, 1))
    k = lambda X: np.broadcast_to(Kw, (X.shape[0], 3, 1))
    f = f or (lambda X: X @ A.T)
    cost = {"w2": W2Cost(h, dh, S0, S1), "winf": WinfCost(h, dh, S0, S1, GAMMA),
            "hinf": HinfCost(h, np.eye(3), [[0.5]], GAMMA)}[kind]
    model = InputAffineModel(f, g, None if kind == "w2" else k, n=3)
    prob = GalerkinProblem(model, cost, PolynomialBasis(3, 3), Box.symmetric([1.0, 1.0, 1.0]),
                           quadrature=4)
    return prob.solve(lambda X: X @ np.array([[-8.0, -6.0, -2.0]]).T, tol=1e-12)


def _quadratic_part(basis, c):
    """P with the quadratic terms of cᵀΦ = xᵀPx."""
    P = np.zeros((basis.n, basis.n))
    for e, ci in zip(basis.exponents, c):
        if e.sum() == 2:
            i, j = np.repeat(np.arange(basis.n), e)    # x_i x_j (i = j for a square)
            P[i, j] += ci / 2
            P[j, i] += ci / 2
    return P


@pytest.mark.parametrize("kind", ["w2", "winf", "hinf"])
def test_autodiff_gain_equals_the_closed_form_of_a_linear_design(kind):
    res = _linear_law(kind)
    P = _quadratic_part(res.basis, res.coefficients)   # ∇V = 2Px + (linear terms) + O(|x|²)
    G = Bu if kind == "w2" else np.hstack([Bu, Kw])
    m = G.shape[1]
    if kind == "hinf":            # S = diag(R, −γ²), s = 0
        S, Ns = np.diag([0.5, -GAMMA ** 2]), np.zeros((m, 3))
    else:                         # S = ½GᵀσG − ½γ² diag(0, I), s = ½Gᵀσ₁A x
        S = 0.5 * G.T @ S1 @ G - 0.5 * GAMMA ** 2 * np.diag([0.0] + [1.0] * (m - 1))
        Ns = 0.5 * G.T @ S1 @ A
    K_closed = -np.linalg.solve(S, G.T @ P + Ns)[:1]   # v = −S⁻¹(½Gᵀ∇V + s)
    K_ad = res.feedback_gain("autodiff")
    # rounding of both: (N + 3m) ε κ(S) relative, N ≤ 19, κ(S) < 50 here: < 1e-12
    assert np.linalg.cond(S) < 50
    np.testing.assert_allclose(K_ad, K_closed, rtol=1e-12, atol=1e-12 * np.abs(K_closed).max())


# ------------------------------------------------------------------- double-only functions
def test_double_only_model_falls_back_to_central_differences_and_names_the_function():
    def f_float(X):                       # fills a float array: double only
        out = np.empty((X.shape[0], 3))
        out[:] = X @ A.T
        return out

    res = _linear_law("w2", f=f_float)
    np.testing.assert_array_equal(res.feedback_gain(), res.feedback_gain("central"))
    with pytest.raises(ObjectEvaluationError, match=r"model function f\(X\) does not evaluate "
                                                    r"on an object array of AutoDiffXd"):
        res.feedback_gain("autodiff")
    with pytest.raises(TypeError, match="Expression"):
        res.control(np.array([[Expression(Variable(f"x{i}")) for i in range(3)]]))
    with pytest.raises(ValueError, match="method must be"):
        res.feedback_gain("forward")
    # the float path is unchanged: the same design with a dtype-preserving f is identical
    np.testing.assert_array_equal(_linear_law("w2").coefficients, res.coefficients)
