"""The W2/W∞ vs matched classic H∞ comparison shared by the chapter-5 experiments."""

import numpy as np
import pytest

from sobolev_drake.experiments import manipulator as arm
from sobolev_drake.models.arm import add_arm, make_arm_model
from sobolev_drake.rigs.mechanical import build_loop, compare_with_matched_hinf
from sobolev_drake.synthesis.mechanical import controlled_gains
from sobolev_drake.systems.disturbances import TimeProfiledForce
from sobolev_drake.systems.mechanical_controller import Partition, SobolevLaw
from sobolev_drake.systems.mechanical_law import HinfLaw
from sobolev_drake.systems.reference_catalogue import table_5_2


def _loop(record=False):
    inner = SobolevLaw(controlled_gains(*arm.WEIGHTS))
    loop = build_loop(add_arm, make_arm_model(), Partition(controlled=[0, 1]), inner, table_5_2(),
                      TimeProfiledForce(2, []), record=record)
    return loop, inner


def test_hinf_law_matches_the_w_law_index():
    """The returned H∞ run is the closest search point to the W run's IADU, and the search met
    the 2 % rule (IADU is monotone in ωu on this loop, so six evaluations bracket and close it)."""
    loop, inner = _loop()
    law = loop.controller.law
    cmp = compare_with_matched_hinf(loop, inner, 1.0, arm.Q0, arm.QD0, lambda r: arm.indices(r, law),
                                    iters=6)
    assert not cmp.w_run["failed"] and not cmp.hinf_run["failed"]
    assert cmp.target == cmp.w_indices["IADU"]
    assert len(cmp.history) <= 6
    ratios = [abs(np.log(v / cmp.target)) for _, v in cmp.history]
    best = cmp.history[int(np.argmin(ratios))]
    assert cmp.omega_u == best[0] and cmp.hinf_indices["IADU"] == pytest.approx(best[1], rel=1e-12)
    assert abs(cmp.hinf_indices["IADU"] / cmp.target - 1) < 0.02
    # the loop was left flying the last H∞ law of the search
    assert isinstance(loop.controller.law_of(loop.simulator.get_context()).law, HinfLaw)
    assert len(cmp.surface) == 3 and cmp.surface[0] == 1.0


def test_recording_needs_a_recording_loop(tmp_path):
    loop, inner = _loop(record=False)
    with pytest.raises(ValueError, match="record=True"):
        compare_with_matched_hinf(loop, inner, 0.05, arm.Q0, arm.QD0, lambda r: {"IADU": 1.0},
                                  iters=1, record_to=tmp_path / "w.html")
