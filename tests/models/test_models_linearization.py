"""``models.linearization``: the shared finite-difference linearization of a MechanicalModel."""

import numpy as np
import pytest

from sobolev_drake.models.linearization import central_jacobian, linearize_mechanical


def test_central_jacobian_of_a_quadratic_is_exact():
    M = np.array([[1.0, 2.0], [-3.0, 0.5]])
    J = central_jacobian(lambda x: M @ x + x ** 2, 2, 1e-3)  # x² has zero slope at 0
    np.testing.assert_allclose(J, M, atol=1e-12)


def test_two_wheeled_full_state_matches_closed_form_4_30():
    from sobolev_drake.models.two_wheeled_linear import closed_form_linearization
    from sobolev_drake.models.two_wheeled import make_two_wheeled_model
    model = make_two_wheeled_model()
    A, B, D = linearize_mechanical(model, np.zeros(2), np.zeros(2), [0.0])
    assert A.shape == (4, 4) and B.shape == (4, 1) and D.shape == (4, 2)
    A3, B3, D3 = closed_form_linearization()  # state [θ ϕ̇ θ̇]
    keep = [1, 2, 3]
    np.testing.assert_allclose(A[np.ix_(keep, keep)], A3, atol=1e-8)
    np.testing.assert_allclose(B[keep], B3, atol=1e-8)
    np.testing.assert_allclose(D[keep], D3, atol=1e-8)
    # ϕ is cyclic: no column of A depends on it; q̇ rows are the identity block
    np.testing.assert_allclose(A[:, 0], 0.0, atol=1e-8)
    np.testing.assert_allclose(A[:2, 2:], np.eye(2), atol=1e-12)
    # D = [0; M(q0)⁻¹]
    np.testing.assert_allclose(D[2:], np.linalg.inv(model.M(np.zeros(2))), rtol=1e-7)


def test_bad_input_names_the_argument():
    from sobolev_drake.models.two_wheeled import make_two_wheeled_model
    model = make_two_wheeled_model()
    with pytest.raises(ValueError, match="q0"):
        linearize_mechanical(model, np.zeros(3), np.zeros(2), [0.0])
    with pytest.raises(ValueError, match="w0"):
        linearize_mechanical(model, np.zeros(2), np.zeros(2), [0.0], w0=[np.nan, 0.0])
    with pytest.raises(ValueError, match="step h"):
        linearize_mechanical(model, np.zeros(2), np.zeros(2), [0.0], h=0.0)
