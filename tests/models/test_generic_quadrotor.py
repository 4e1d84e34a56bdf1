"""The thesis quadrotor through the generic path (quaternion floating base + Drake
PropellerInfos → from_plant) equals the dedicated QuadrotorModel (issue #32), in both readings
of the rotor drag torque: the default "thesis" one of (5.123) (body-z component d cos α only,
``from_plant(..., reaction_torque="body_z")``) and "axial" (along the tilted rotor axis, what
Drake's Propeller applies)."""

import numpy as np
import pytest

from sobolev_drake.experiments import quadrotor_figure8 as fig8
from sobolev_drake.models.base import MechanicalModel
from sobolev_drake.models.generic_quadrotor import (make_generic_quadrotor_model,
                                                    quadrotor_propellers)
from sobolev_drake.models.quadrotor import QuadrotorParams, add_quadrotor, make_quadrotor_model
from sobolev_drake.rigs.mechanical import build_loop, run_loop
from sobolev_drake.systems.rotor_allocation import RotorAllocation

READINGS = ("thesis", "axial")
# both are Drake evaluations of the same rigid body through different joints; the products with
# J (entries ≤ 1) lose a few ulps of the largest term (m g ≈ 22 N)
TOL = 1e3 * np.finfo(float).eps * 22.0


@pytest.fixture(scope="module", params=READINGS)
def models(request):
    return (make_generic_quadrotor_model(reaction_torque=request.param),
            make_quadrotor_model(reaction_torque=request.param))


def test_generic_terms_equal_the_dedicated_closed_forms(models):
    generic, dedicated = models
    rng = np.random.default_rng(7)
    for _ in range(5):
        q, qdot = rng.uniform(-1, 1, 6), rng.uniform(-2, 2, 6)
        for a, b in ((generic.M(q), dedicated.M(q)), (generic.Cqdot(q, qdot), dedicated.Cqdot(q, qdot)),
                     (generic.g(q), dedicated.g(q)), (generic.B(q), dedicated.B(q))):
            np.testing.assert_allclose(a, b, rtol=0, atol=TOL)
        # and the dedicated B is (5.123)'s closed form blockdiag(Wᵀ, R) B₀ of its reading
        np.testing.assert_allclose(generic.B(q), dedicated.B_closed_form(q), rtol=0, atol=TOL)


def test_the_two_readings_differ_only_in_the_roll_pitch_drag_torque():
    """The body-z reading drops the in-plane part −s_i d sin α p̂_i of each tilted drag torque
    (rotor i at l p̂_i, spin s = +1, −1, +1, −1): at level attitude the roll/pitch rows differ by
    exactly that, nothing else does, and at α = 0 the readings coincide."""
    p = QuadrotorParams()
    thesis, axial = (make_generic_quadrotor_model(reaction_torque=r) for r in READINGS)
    q0 = np.zeros(6)
    diff = axial.B(q0) - thesis.B(q0)
    d_sin = p.d * np.sin(p.alpha)
    np.testing.assert_allclose(diff[:2], [[-d_sin, 0, d_sin, 0], [0, d_sin, 0, -d_sin]],
                               rtol=0, atol=TOL)
    np.testing.assert_allclose(diff[2:], 0.0, atol=TOL)
    q = np.array([0.3, -0.4, 0.5, 1.0, 2.0, 3.0])
    untilted = [make_generic_quadrotor_model(tilt=0.0, reaction_torque=r).B(q) for r in READINGS]
    np.testing.assert_allclose(untilted[0], untilted[1], rtol=0, atol=TOL)


def test_reaction_torque_is_checked_by_name():
    with pytest.raises(ValueError, match="reaction_torque must be one of"):
        make_generic_quadrotor_model(reaction_torque="body_z")   # the dedicated model's names
    generic = make_generic_quadrotor_model()
    with pytest.raises(ValueError, match="reaction_torque must be one of .*'thesis'"):
        MechanicalModel.from_plant(generic.plant, propellers=quadrotor_propellers(generic.plant),
                                   reaction_torque="thesis")      # the floating base's names


def test_figure8_gives_the_dedicated_paths_numbers_through_the_generic_model(models):
    """The thesis figure-8 loop (untilted truth, 5° controller model, input-coupling law, B†u*)
    flown with either controller model: the same indices (smoke horizon).  The simulated plant
    is the dedicated one (Drake MultibodyPlant + the adapter applying B(q) u as a generalized
    force), as in the experiment."""
    generic_model, dedicated_model = models
    assert generic_model.reaction_torque == {"thesis": "body_z", "axial": "axial"}[
        dedicated_model.reaction_torque]
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
