"""Configuration and designs of ``balance-linear`` (thesis 6.5.2, Table 6.2).

The four designs are values (:class:`~sobolev_drake.synthesis.designs.LinearDesign`: label, norm, feedback) with the thesis' weights
and a disk pole region each (the thesis' region matrix read as a disk, docs/design.md §4.4;
both output-feedback designs regularized at γ = (1+δ)γ*, docs/design.md §8.2), plus the
settings of the equal-settling-time search of the H∞ input weight ρ.

See docs/experiments/balance-linear.md.
"""

from __future__ import annotations

import time
import numpy as np

from sobolev_drake.harness import quiet
from sobolev_drake.synthesis.designs import FeedbackTable, LinearDesign
from sobolev_drake.synthesis.problem import SynthesisResult

GAMMA0_SF = np.diag([0.2, 2.0, 0.3])
GAMMA1_SF = np.diag([2.6, 0.25, 0.625])
GAMMA0_OF = np.diag([10.0, 1.0, 10.0])
GAMMA1_OF = np.diag([0.66, 0.35, 0.3355])
C_OF = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])  # θ̇ not measured (6.5.2)
RADIUS = FeedbackTable(state_feedback=40.0, output_feedback=150.0)


DESIGN_SPECS = {d.label: d for d in (
    LinearDesign("H∞", "hinf", "state_feedback"), LinearDesign("W∞", "winf", "state_feedback"),
    LinearDesign("H∞-O.F.", "hinf", "output_feedback"),
    LinearDesign("W∞-O.F.", "winf", "output_feedback"))}
DESIGNS = tuple(DESIGN_SPECS)
#: Table 6.2: ISE θ, ISE ϕ̇, IADU, empirical H∞ index
THESIS_TABLE_6_2 = {"H∞": (1.7, 82.9, 48.2, 1.47), "W∞": (1.8, 65.8, 33.5, 1.32),
                    "H∞-O.F.": (1.6, 96.1, 4544.0, 13.5), "W∞-O.F.": (1.8, 71.6, 682.0, 9.2)}
#: "W∞ has a lower index than H∞" claims need W∞ < LOWER × H∞ (differences of ~1 % are within
#: the spread of the tuning rule itself, e.g. 2.040 vs 2.046 s settling)
LOWER = 0.98
#: ρ grids of the equal-settling-time search (R = ρ; Q = Γ0 of the matching W∞ design); two
#: points per decade: the O.F. settling time is V-shaped in ρ and a decade grid straddles its
#: dip, finding no match although one exists
RHO_GRID = FeedbackTable(np.logspace(-3, 3, 13), np.logspace(-3, 3, 13))
#: relative γ relaxation of the regularized O.F. designs (see _balance_linear_posedness): at
#: δ = 0.05 Clarabel, cvxpy/Clarabel and Drake/Clarabel return the same settling time to
#: 1e-3 s; at δ ≤ 0.02 the gain-bound LMI is so ill-conditioned that solvers fail or disagree
OF_REG_DELTA = 0.05
#: backend of the O.F. designs when none is given.  Their anchor γ* is the non-attained
#: infimum and solvers stop at different depths, so (1+δ)γ* and with it the controller would
#: follow the default backend chain; given γ, all backends return the same least-gain controller
OF_BACKEND = "clarabel"
#: ρ found by a full run (used by smoke mode, which skips the search; settling 2.046 s vs
#: W∞ 2.040 s and 0.781 s vs W∞-O.F. 0.777 s)
RHO_TUNED = {"H∞": 6.978, "H∞-O.F.": 8.058}


def design(which: LinearDesign | str, lin: tuple[np.ndarray, np.ndarray, np.ndarray], *,
           rho: float | None = None, backend: str | None = None, regularize: bool | str | None = None
           ) -> tuple[SynthesisResult, list[str], float]:
    """Synthesize one design of Table 6.2 on the linearization, with its disk region.

    Parameters
    ----------
    which : LinearDesign or str
        The design or its label (one of :data:`DESIGNS`); dispatched on its fields.
    lin : (A, B, D)
        The linear model.
    rho : float, optional
        H∞ designs only: the input weight R = ρ (> 0).
    backend : str, optional
        LMI backend; O.F. designs default to :data:`OF_BACKEND`.
    regularize : None, bool or "auto"
        None = the experiment's choice — O.F. designs regularized at
        γ = (1 + :data:`OF_REG_DELTA`)γ* (their LMI optimum is a non-attained infimum, see
        :mod:`._balance_linear_posedness`), state feedback with the synthesis default ("auto":
        W∞ sits on its feedthrough bound and is regularized at δ = 0.01 by the library).
        False gives the raw LMI optimum; True/"auto" are passed to the synthesis.

    Returns
    -------
    (SynthesisResult, list of str, float)
        The result, its warning texts and the synthesis time (s).
    """
    from sobolev_drake.synthesis import regions
    from sobolev_drake.synthesis import sobolev as sb
    spec = which if isinstance(which, LinearDesign) else DESIGN_SPECS.get(which)
    if spec is None:
        raise ValueError(f"which must be one of {DESIGNS} or a LinearDesign, got {which!r}")
    A, B, D = lin
    of = spec.feedback == "output_feedback"
    disk = regions.disk(RADIUS[spec.feedback])
    G0, G1 = (GAMMA0_OF, GAMMA1_OF) if of else (GAMMA0_SF, GAMMA1_SF)
    if spec.norm == "winf":
        fn = sb.winf_output_feedback if of else sb.winf_state_feedback
        args = (A, B, C_OF, D, G0, G1) if of else (A, B, D, G0, G1)
    else:
        if rho is None or not rho > 0:
            raise ValueError(f"H∞ designs need a positive input weight rho, got {rho!r}")
        fn = sb.hinf_output_feedback_qr if of else sb.hinf_state_feedback_qr
        R = np.array([[float(rho)]])
        args = (A, B, C_OF, D, G0, R) if of else (A, B, D, G0, R)
    if of and backend is None:
        backend = OF_BACKEND
    if regularize is None:
        kw = {"regularize": True, "delta": OF_REG_DELTA} if of else {}
    elif regularize is True and of:
        kw = {"regularize": True, "delta": OF_REG_DELTA}
    elif regularize in (True, False, "auto"):
        kw = {"regularize": regularize}
    else:
        raise ValueError(f"regularize must be None, True, False or 'auto', got {regularize!r}")
    t0 = time.perf_counter()
    res, notes = quiet(fn, *args, region=disk, backend=backend, **kw)
    return res, notes, time.perf_counter() - t0
