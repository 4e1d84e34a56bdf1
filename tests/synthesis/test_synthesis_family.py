"""Generated plant families (``random_plants.py``): the default syntheses return a certified,
stabilizing controller for every plant, near the optimum where a Riccati solution exists,
checked against quantities computed independently of the Riccati path (the closed-loop norm
by Hamiltonian iteration, the LMI path's controller).  The benchmark runs 200+ plants of
10-40 states; this is its fast subset (4-12 states)."""

import warnings

import numpy as np
import pytest

from sobolev_drake.synthesis.certificates import hinf_norm
from sobolev_drake.synthesis.hinf import output_feedback, state_feedback
from sobolev_drake.synthesis.lmi import SynthesisError
from sobolev_drake.synthesis.random_plants import FAMILIES, plant_family, random_plant

CASES = plant_family(24, (4, 12), seed=7)


@pytest.mark.parametrize("case", CASES, ids=str)
@pytest.mark.parametrize("synthesis", [state_feedback, output_feedback],
                         ids=["SF", "OF"])
def test_family_certified_and_near_optimal(case, synthesis):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = synthesis(case.plant)
        try:  # independent reference: the LMI optimum's controller, when the LMI solves
            lmi = synthesis(case.plant, method="lmi", regularize=False, verify=False)
        except SynthesisError:
            lmi = None
    cl = res.closed_loop(case.plant)
    assert np.linalg.eigvals(cl[0]).real.max() < 0
    achieved = hinf_norm(*cl)[0]
    assert achieved <= res.gamma * (1 + 2e-7)  # the certified bound (Hamiltonian lower bound)
    regular = case.regular or synthesis is state_feedback  # SF never needs D21
    if not (regular and lmi is not None and lmi.certificate.ok):
        return
    lmi_achieved = lmi.certificate.achieved
    # No controller beats the optimum, and the Riccati gamma_opt is the upper end of a
    # bisection bracket of relative width 1e-6: it may not exceed what the LMI's
    # controller achieves by more than that width (plus the Hamiltonian norm's 2e-7).
    assert res.gamma_opt <= lmi_achieved * (1 + 2e-6)
    if not res.regularized:  # on the feedthrough bound both are relaxed by design
        # within 1e-4 of the optimum: the controller is built at (1 + 2e-5) gamma_opt and
        # backed off at most to (1 + 1e-4) when a certificate fails
        assert achieved <= lmi_achieved * (1 + 1e-4)


def test_family_generator_is_reproducible_and_checks_its_family():
    a = plant_family(3, (5, 6), seed=3)
    b = plant_family(3, (5, 6), seed=3)
    assert all(np.array_equal(x.plant.A, y.plant.A) for x, y in zip(a, b))
    assert [c.family for c in plant_family(len(FAMILIES), (5, 5))] == list(FAMILIES)
    with pytest.raises(ValueError, match="family must be one of"):
        random_plant(np.random.default_rng(0), 4, "unstabl")


# stable, unstable and feedthrough plants only: SB10AD's own gamma iteration takes 4-18 s on
# 5-state lightly damped and ill-conditioned plants (the benchmark runs those, time-boxed)
@pytest.mark.parametrize("case", plant_family(9, (3, 8), seed=11,
                                              families=("stable", "unstable", "feedthrough")),
                         ids=str)
def test_output_feedback_against_python_control(case):
    """python-control's hinfsyn (slycot SB10AD) on the same plant: where its controller is
    stabilizing and its claimed gamma holds (its closed-loop norm, computed here, is not above
    it), our certified gamma is within 1e-4 of that norm or below -- both approximate the
    same optimum from above.  Where it is not (measured on lightly damped and unstable plants:
    claimed gamma below the achieved norm, or an unstable closed loop), ours still certifies."""
    control = pytest.importorskip("control")
    from sobolev_drake.synthesis.problem import DynamicController
    p = case.plant
    res = output_feedback(p)
    assert res.certificate.ok and res.method == "riccati"
    P = control.ss(p.A, np.hstack([p.B1, p.B2]), np.vstack([p.C1, p.C2]),
                   np.block([[p.D11, p.D12], [p.D21, np.zeros((p.ny, p.nu))]]))
    K, _, gam, _ = control.hinfsyn(P, p.ny, p.nu)
    cl = p.closed_loop(controller=DynamicController(K.A, K.B, K.C, K.D))
    if np.linalg.eigvals(cl[0]).real.max() >= 0:
        return
    theirs = hinf_norm(*cl)[0]
    if theirs <= gam * (1 + 1e-6):  # an honest python-control result
        # an optimum on the feedthrough bound is relaxed by design to (1 + delta) x it
        factor = (1 + 1e-2) * (1 + 1e-6) if res.regularized else 1.0
        assert res.gamma <= theirs * factor * (1 + 1e-4)
