"""The arm's thesis-printed inertia reading (5.120): closed form, simulated plant, bad input."""

import numpy as np
import pytest
from pydrake.systems.framework import DiagramBuilder
from scipy.integrate import solve_ivp

from sobolev_drake.models.arm import ThesisPrintedArmModel, TwoLinkArmModel, add_arm, make_arm_model
from sobolev_drake.systems.plant_dynamics import PlantDynamics


def test_printed_inertia_matrix_is_the_printed_formula():
    """Table 5.1 (unit masses, lengths, inertias): printed d11 = 4 + cos q2 and d12 = 1.25 +
    0.25 cos q2 against the physical 3.5 + cos q2 and 1.25 + 0.5 cos q2; d22 = 1.25 in both."""
    printed, physical = make_arm_model(inertia="thesis-printed"), make_arm_model()
    assert isinstance(printed, ThesisPrintedArmModel) and type(physical) is TwoLinkArmModel
    for q2 in (-2.0, 0.0, 0.7):
        c = np.cos(q2)
        q = [0.3, q2]
        np.testing.assert_allclose(printed.M(q), [[4 + c, 1.25 + 0.25 * c], [1.25 + 0.25 * c, 1.25]], rtol=1e-14)
        np.testing.assert_allclose(physical.M(q), [[3.5 + c, 1.25 + 0.5 * c], [1.25 + 0.5 * c, 1.25]], rtol=1e-12)
        # C q̇ and g stay the plant's
        np.testing.assert_allclose(printed.Cqdot(q, [1.0, -2.0]), physical.Cqdot(q, [1.0, -2.0]), rtol=1e-12)
    # the controller's dynamics use the model's own M, not the plant's
    assert not PlantDynamics(printed).fast and PlantDynamics(physical).fast


def test_printed_plant_follows_the_printed_equations(fly_constant):
    """The MultibodyPlant driven through the adapter integrates M_printed q̈ + C q̇ + g = τ + w;
    compared with scipy's integration of the closed forms.  Tolerance: both integrators run at
    ~1e-10 relative accuracy over 1 s of motion of ~6 rad (errors ~1e-9 rad), so 1e-6 rad leaves
    a factor of several hundred for error growth; the physical arm ends ~2 rad away (checked too)."""
    tau, w = np.array([30.0, -5.0]), np.array([0.0, 2.0])
    q0, qd0 = np.array([np.pi / 4, 0.3]), np.array([0.0, 0.5])
    finals = {inertia: fly_constant(lambda b, inertia=inertia: add_arm(b, inertia=inertia), q0, qd0, tau, w, 1.0)
              for inertia in ("thesis-printed", "physical")}
    m = make_arm_model(inertia="thesis-printed")

    def rhs(_, x):
        q, qd = x[:2], x[2:]
        return np.r_[qd, np.linalg.solve(m.M_printed(q), tau + w - m.Cqdot_closed_form(q, qd) - m.g_closed_form(q))]

    ref = solve_ivp(rhs, (0.0, 1.0), np.r_[q0, qd0], method="DOP853", rtol=1e-11, atol=1e-12).y[:, -1]
    np.testing.assert_allclose(finals["thesis-printed"][:2], ref[:2], atol=1e-6)
    assert np.abs(finals["physical"][:2] - ref[:2]).max() > 1e-2


def test_unknown_inertia_reading_is_refused():
    with pytest.raises(ValueError, match="inertia must be one of .*'printed'"):
        make_arm_model(inertia="printed")
    with pytest.raises(ValueError, match="inertia must be one of"):
        add_arm(DiagramBuilder(), inertia="Printed")
