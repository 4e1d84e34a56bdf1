"""GalerkinController LeafSystem and the balance-sgaa experiment (smoke run)."""

import numpy as np
import pytest
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource

from sobolev_drake.experiments import balance_sgaa as bal
from sobolev_drake.models.two_wheeled_design import cross_check_design_model, design_model
from sobolev_drake.synthesis.galerkin_balance import K_THESIS, SIGMA1, WINF, sgaa_design
from sobolev_drake.systems.galerkin_controller import GalerkinController, selection_matrix


@pytest.fixture(scope="module")
def winf_law():
    return sgaa_design(WINF, design_model(), nodes=6, check_u0="linearization")


def test_controller_output_equals_law_with_selection_and_limits(winf_law):
    x_plant = np.array([12.0, 0.2, -1.1, 0.4])  # [ϕ θ ϕ̇ θ̇], ϕ must be ignored
    builder = DiagramBuilder()
    src = builder.AddSystem(ConstantVectorSource(x_plant))
    ctrl = builder.AddSystem(GalerkinController(winf_law, plant_state_size=4, selection=[1, 2, 3]))
    sat = builder.AddSystem(GalerkinController(winf_law, plant_state_size=4,
                                               selection=selection_matrix([1, 2, 3], 4),
                                               u_limits=(-0.5, 0.5)))
    builder.Connect(src.get_output_port(), ctrl.GetInputPort("x"))
    builder.Connect(src.get_output_port(), sat.GetInputPort("x"))
    diagram = builder.Build()
    ctx = diagram.CreateDefaultContext()
    u = ctrl.GetOutputPort("u").Eval(ctrl.GetMyContextFromRoot(ctx))
    expected = winf_law.control(x_plant[None, 1:])[0]
    assert np.allclose(u, expected, rtol=1e-12)
    # (4.20) by hand: u = −R⁻¹gᵀ(∇V + Bf + Bk w*), R = gᵀBg, B = σ₁ (h = x)
    f, g, k = design_model()
    X = x_plant[None, 1:]
    Bm = SIGMA1
    G, Kd, F = g(X)[0], k(X)[0], f(X)[0]
    w = winf_law.disturbance(X)[0]
    R = G.T @ Bm @ G
    u_hand = -np.linalg.solve(R, G.T @ (winf_law.gradient(X)[0] + Bm @ F + Bm @ Kd @ w))
    assert np.allclose(u, u_hand, rtol=1e-10)
    u_sat = sat.GetOutputPort("u").Eval(sat.GetMyContextFromRoot(ctx))
    assert np.allclose(u_sat, np.clip(expected, -0.5, 0.5))


def test_controller_rejects_bad_selection(winf_law):
    with pytest.raises(ValueError, match="selection"):
        GalerkinController(winf_law, plant_state_size=4)
    with pytest.raises(ValueError, match="out of range"):
        GalerkinController(winf_law, plant_state_size=4, selection=[1, 2, 4])
    with pytest.raises(TypeError, match="control"):
        GalerkinController(object(), n=3, nu=1)


def test_design_model_matches_drake_model_and_sign_convention():
    assert cross_check_design_model() < 1e-9
    from sobolev_drake.synthesis.galerkin import closed_loop_jacobian
    f, g, _ = design_model()
    for sign, stable in ((+1, True), (-1, False)):
        J = closed_loop_jacobian(lambda X: f(X) + g(X)[:, :, 0] * (sign * X @ K_THESIS)[:, None], 3)
        assert (np.linalg.eigvals(J).real.max() < 0) == stable


def test_balance_sgaa_smoke(tmp_path):
    res = bal.run(tmp_path, smoke=True)
    assert all(c.held for c in res.claims), [c for c in res.claims if not c.held]
    for key in ("table_md", "table_json", "states_png"):
        assert res.outputs[key].exists()
    idx = res.metrics["indices"]
    for name in bal.CONTROLLERS:
        assert np.isfinite(idx[name]["IADU"]) and idx[name]["ISE θ"] > 0
    # the pendulum is being brought back: θ is well below π/4 at the end of the short run
    assert "IADU" in res.table_markdown


def test_sgaa_designs_are_values():
    """The columns of Table 4.2 are SgaaDesign values dispatched on their cost, in table order;
    an unknown cost is rejected."""
    from sobolev_drake.synthesis.galerkin_balance import SgaaDesign

    assert [(d.label, d.cost, d.disturbance) for d in bal.DESIGNS] == [
        ("H∞", "hinf", True), ("W∞", "winf", True), ("W2", "w2", False)]
    assert bal.CONTROLLERS == ("H∞", "W∞", "W2")
    with pytest.raises(ValueError, match="cost must be one of"):
        SgaaDesign("W∞", "W∞")


def test_the_two_wheeled_design_linearizes_by_autodiff_and_converts():
    """The design model evaluates on object arrays, so the gain of its Galerkin law comes from
    AutoDiffXd (exact to rounding) and its controller converts; the former central differences
    agree to their truncation error (measured 3e-13 to 6e-13, ~5e-14 relative)."""
    res = sgaa_design(WINF, design_model(), nodes=6, check_u0="linearization")
    exact = res.feedback_gain(method="autodiff")
    central = res.feedback_gain(method="central")
    np.testing.assert_allclose(exact, res.feedback_gain(), rtol=0, atol=0)   # "auto" is AutoDiff
    # central differences: O(h²)·|u'''| truncation plus ε|u|/h rounding; 1e-9 relative is ≥ 1000×
    # the measured difference
    np.testing.assert_allclose(central, exact, rtol=1e-9, atol=1e-9 * np.abs(exact).max())
    from sobolev_drake.systems.galerkin_controller import GalerkinController
    assert GalerkinController(res).ToAutoDiffXd() is not None
