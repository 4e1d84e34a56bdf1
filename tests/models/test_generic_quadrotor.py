"""The thesis quadrotor through the generic path (quaternion floating base + Drake
PropellerInfos → from_plant) equals the dedicated QuadrotorModel (issue #32)."""

import numpy as np
import pytest

from sobolev_drake.experiments import quadrotor_figure8 as fig8
from sobolev_drake.models.generic_quadrotor import make_generic_quadrotor_model
from sobolev_drake.models.quadrotor import QuadrotorParams, add_quadrotor, make_quadrotor_model
from sobolev_drake.rigs.mechanical import build_loop, run_loop
from sobolev_drake.systems.rotor_allocation import RotorAllocation


@pytest.fixture(scope="module")
def models():
    return make_generic_quadrotor_model(), make_quadrotor_model(reaction_torque="axial")


def test_generic_terms_equal_the_dedicated_closed_forms(models):
    generic, dedicated = models
    rng = np.random.default_rng(7)
    for _ in range(5):
        q, qdot = rng.uniform(-1, 1, 6), rng.uniform(-2, 2, 6)
        # both are Drake evaluations of the same rigid body through different joints; the
        # products with J (entries ≤ 1) lose a few ulps of the largest term (m g ≈ 22 N)
        tol = 1e3 * np.finfo(float).eps * 22.0
        for a, b in ((generic.M(q), dedicated.M(q)), (generic.Cqdot(q, qdot), dedicated.Cqdot(q, qdot)),
                     (generic.g(q), dedicated.g(q)), (generic.B(q), dedicated.B(q))):
            np.testing.assert_allclose(a, b, rtol=0, atol=tol)
        np.testing.assert_allclose(dedicated.B(q), dedicated.B_closed_form(q), atol=tol)


def test_figure8_gives_the_dedicated_paths_numbers_through_the_generic_model(models):
    """The thesis figure-8 loop (untilted truth, 5° controller model, input-coupling law, B†u*)
    flown with either controller model: the same indices (smoke horizon)."""
    params = QuadrotorParams()
    hover = params.hover_input()
    lo, hi = np.zeros(4), 4 * hover * np.ones(4)
    results = []
    for model in models:
        loop = build_loop(lambda b: add_quadrotor(b, params, tilt=0.0), model, fig8.PARTITION,
                          fig8.sobolev_inner(), fig8.reference(), fig8.disturbance(),
                          allocation=RotorAllocation(model, "pinv", lo, hi))
        run = run_loop(loop, fig8.sobolev_inner(), 0.3, fig8.Q0, np.zeros(6))
        assert not run["failed"]
        results.append(fig8.indices(run, loop.controller.law))
    generic, dedicated = results
    for key in dedicated:
        # the controllers' models agree to ~1e-13 relative; the error-controlled integrator
        # (accuracy 1e-4) amplifies that only through step-size decisions, which it shares
        assert generic[key] == pytest.approx(dedicated[key], rel=1e-6, abs=1e-12), key
