"""The simple second-order system (6.41) with its disturbance filter, and the W∞ designs of
Table 6.1 (thesis 6.5.1).

ẋ = A x + B u + D w with a matched disturbance (D = B) w = C_d d, ḋ = A_d d + B_d v; the
output-feedback designs measure y = C x; weights Γ0 = diag(10, 10), Γ1 = I.  The four designs
are solved as LMIs as in the thesis ((6.7), (6.22), (6.31)/(6.36)); the disturbance-model rows in
the well-posed augmented form, since (6.31) is degenerate (docs/design.md §8.3).
See docs/experiments/linear-simple.md.
"""

from __future__ import annotations

import warnings
from dataclasses import replace
from typing import Any, NamedTuple

import numpy as np

from sobolev_drake.synthesis import regions
from sobolev_drake.synthesis.closed_loop_bounds import FilteredDisturbancePlant, LoopDesign
from sobolev_drake.synthesis.lmi import InfeasibleLMIError
from sobolev_drake.synthesis.problem import SynthesisResult
from sobolev_drake.synthesis.sobolev import (disturbance_model_degeneracy, winf_disturbance_augmented,
                                             winf_disturbance_thesis, winf_output_feedback,
                                             winf_state_feedback)

__all__ = ["A", "B", "D", "AD", "BD", "CD", "C", "GAMMA0", "GAMMA1", "SIMPLE", "X0",
           "WELL_POSED_DISK", "THESIS_SYNTHESIS", "WINF", "WINF_D", "WINF_OF", "WINF_OFD",
           "DESIGNS", "DesignedController", "synthesize", "design", "design_well_posed"]

A = np.array([[0, 50], [-50, -50.0]])
B = np.array([[0.0], [1]])
D = np.array([[0.0], [1]])
AD = np.array([[0, 100], [-100, -100.0]])
BD = np.array([[0.0], [100]])
CD = np.array([[10.0, 10]])
C = np.array([[1.0, 1]])
GAMMA0, GAMMA1 = np.diag([10.0, 10]), np.eye(2)
#: system (6.41) as one value
SIMPLE = FilteredDisturbancePlant(A, B, D, AD, BD, CD, C, GAMMA0, GAMMA1)
X0 = np.array([3.0, 1.0])  # initial plant state of the runs (6.5.1)
#: disk radius of the well-posed (bandwidth-limited) disturbance-model variants (extra rows)
WELL_POSED_DISK = 1000.0
#: the thesis solves these designs as LMIs ((6.7), (6.22), (6.31)/(6.36)); so does the table
#: compared with its numbers (the library's default would take the Riccati path); offline
#: designs, so no time budget
THESIS_SYNTHESIS = {"method": "lmi", "time_limit": None}

WINF = LoopDesign("W∞", "state_feedback")
WINF_D = LoopDesign("W∞-D", "output_feedback", disturbance_model=True, measured="state")
WINF_OF = LoopDesign("W∞-O.F.", "output_feedback")
WINF_OFD = LoopDesign("W∞-O.F.D", "output_feedback", disturbance_model=True)
#: the rows of Table 6.1, in its order
DESIGNS = (WINF, WINF_D, WINF_OF, WINF_OFD)


class DesignedController(NamedTuple):
    """A design, its controller and the synthesis result it came from.

    Parameters
    ----------
    design : LoopDesign
    data : ndarray or DynamicController
        The gain K (static state feedback) or the controller (AK, BK, CK, DK).
    result : SynthesisResult
    """

    design: LoopDesign
    data: Any
    result: Any


def synthesize(design: LoopDesign, **options: Any) -> SynthesisResult:
    """Solve one design of Table 6.1 on (6.41), chosen by its fields.

    Parameters
    ----------
    design : LoopDesign
        Static state feedback (6.7), output feedback (6.22) or, with ``disturbance_model``,
        the well-posed disturbance-model design measuring y = x or y = C x.
    **options
        Passed to the synthesis (method, region, backend, time_limit, ...).

    Returns
    -------
    SynthesisResult
    """
    Cm = C if design.measured == "output" else None
    if design.disturbance_model:
        return winf_disturbance_augmented(A, B, D, AD, BD, CD, GAMMA0, GAMMA1, C=Cm, **options)
    if design.feedback == "state_feedback":
        return winf_state_feedback(A, B, D, GAMMA0, GAMMA1, **options)
    return winf_output_feedback(A, B, C, D, GAMMA0, GAMMA1, **options)


def _controller(design, r):
    return DesignedController(design, r.K if design.feedback == "state_feedback" else r.controller, r)


def design() -> tuple[dict[str, DesignedController], list[str]]:
    """Synthesize the four controllers of Table 6.1 and diagnose (6.31) as written.

    Returns
    -------
    (dict, list of str)
        {label: DesignedController} in the table's order, and the notes on (6.31).
    """
    notes = []
    out = {}
    kw = THESIS_SYNTHESIS
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        out[WINF.label] = _controller(WINF, synthesize(WINF, **kw))
        rep = disturbance_model_degeneracy(AD, BD, CD, 1.0, 1000.0)
        try:
            winf_disturbance_thesis(A, B, D, AD, BD, CD, GAMMA0, GAMMA1, 1.0, 1000.0)
            notes.append("(6.31) strict LMI unexpectedly feasible")
        except InfeasibleLMIError as e:
            notes.append(f"(6.31) as written: {e}")
        notes.append(rep.message)
        for d in (WINF_D, WINF_OF, WINF_OFD):
            out[d.label] = _controller(d, synthesize(d, **kw))
    return out, notes


def design_well_posed(radius: float = WELL_POSED_DISK,
                      backend: str | None = None) -> dict[str, DesignedController]:
    """The disturbance-model designs with a disk pole region (6.39) of ``radius``.

    A bounded controller bandwidth: the delivered controllers are certified tightly.  The disk
    does not make the LMI optimum solver independent, so the experiment re-solves with the own
    interior-point backend (``backend="ipm"``) and reports both
    (docs/experiments/linear-simple.md).

    Parameters
    ----------
    radius : float
        Disk radius.
    backend : str, optional
        LMI backend (the library's default chain when None).

    Returns
    -------
    dict
        {"<label>, disk r = <radius>": DesignedController}.
    """
    out = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for d in (WINF_D, WINF_OFD):
            r = synthesize(d, region=regions.disk(radius), backend=backend, time_limit=None)
            label = f"{d.label}, disk r = {radius:g}"
            out[label] = _controller(replace(d, label=label), r)
    return out
