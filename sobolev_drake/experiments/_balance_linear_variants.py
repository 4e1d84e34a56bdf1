"""Variant W∞/H∞ pairs of ``balance-linear`` (Table 6.2): how robust are the thesis' claims?

The thesis leaves the H∞ baseline's weights unstated ("tuned for a similar settling time") and
does not say which point of the non-attained O.F. infimum its solver returned.  Each variant
below is a W∞ design plus an H∞ family H(ρ); ρ is matched by the same equal-settling-time rule
as the main table (nonlinear plant, 2 % band) and both are flown through the full scenario:

* ``O.F., LMI optimum`` — both O.F. controllers as the raw LMI optimum of the pinned backend
  (``regularize=False``): what a thesis-faithful "minimize γ" run returns.  Its numbers depend
  on where the solver stops (see :mod:`._balance_linear_posedness`), so they are indicative only.
* ``S.F., H∞ Q = I`` — the state-feedback baseline with Q = I instead of Q = Γ0.

See docs/experiments/balance-linear.md.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Mapping, Sequence

import numpy as np

from sobolev_drake.experiments._balance_linear_designs import LOWER, RADIUS, RHO_GRID, design
from sobolev_drake.harness import quiet
from sobolev_drake.rigs.balance_linear import (DISTURBANCE_START, BalanceLinearRig, flight_indices, result_gains,
                                               theta_settling_time)
from sobolev_drake.synthesis.problem import SynthesisResult

if TYPE_CHECKING:
    from sobolev_drake.report import ExperimentResult
from sobolev_drake.tuning import match_parameter

KEYS = ("settling_s", "ise_theta", "ise_phidot", "iadu", "gain", "max_abs_u")


def variant_pair(label: str, w_res: SynthesisResult, h_of_rho: Callable[[float], SynthesisResult],
                 rig: BalanceLinearRig, grid: Sequence[float], duration: float) -> dict[str, Any]:
    """Match ρ of ``h_of_rho`` to the settling time of ``w_res`` on ``rig``; fly both for
    ``duration`` s.  Returns a dict with rho, the search history and both index sets."""
    from sobolev_drake.synthesis.lmi import SynthesisError

    def settle(res):
        return theta_settling_time(rig.run(result_gains(res), DISTURBANCE_START))

    cache = {}

    def f(rho):
        try:
            cache[rho] = h_of_rho(rho)
        except SynthesisError:
            return float("nan")
        return settle(cache[rho])

    target = settle(w_res)
    rho, ts, hist = match_parameter(f, target, grid, refine=3)
    iw = flight_indices(rig.run(result_gains(w_res), duration))
    ih = flight_indices(rig.run(result_gains(cache[rho]), duration))
    return {"label": label, "rho": float(rho), "search": [(float(p), float(v)) for p, v in hist],
            "W": {k: iw[k] for k in KEYS}, "H": {k: ih[k] for k in KEYS}}


def run_variants(lin: tuple[np.ndarray, np.ndarray, np.ndarray], rigs: Mapping[str, BalanceLinearRig],
                 designs: dict[str, dict[str, Any]], duration: float) -> list[dict[str, Any]]:
    """The variants of the module docstring; returns a list of :func:`variant_pair` dicts."""
    from sobolev_drake.synthesis import regions
    from sobolev_drake.synthesis import sobolev as sb
    A, B, D = lin
    w_raw, _, _ = design("W∞-O.F.", lin, regularize=False)
    out = [variant_pair("O.F., LMI optimum (both)", w_raw,
                        lambda rho: design("H∞-O.F.", lin, rho=rho, regularize=False)[0],
                        rigs["output_feedback"], RHO_GRID["output_feedback"], duration)]
    disk = regions.disk(RADIUS["state_feedback"])
    out.append(variant_pair("S.F., H∞ with Q = I", designs["W∞"]["res"],
                            lambda rho: quiet(sb.hinf_state_feedback_qr, A, B, D, np.eye(3),
                                                 np.array([[rho]]), region=disk)[0],
                            rigs["state_feedback"], RHO_GRID["state_feedback"], duration))
    return out


def variant_rows(variants: Sequence[dict[str, Any]]) -> list[list[Any]]:
    """Table rows: one per design of each variant, with the W∞/H∞ ratios on the W∞ row."""
    rows = []
    for v in variants:
        for who in ("H", "W"):
            m = v[who]
            ratio = (lambda k: f" ({m[k] / v['H'][k]:.0%})") if who == "W" else (lambda k: "")
            rows.append([v["label"], "H∞" if who == "H" else "W∞", f"{v['rho']:.4g}" if who == "H" else "—",
                         f"{m['settling_s']:.3f}", f"{m['ise_theta']:.3f}{ratio('ise_theta')}",
                         f"{m['ise_phidot']:.1f}{ratio('ise_phidot')}", f"{m['iadu']:.1f}{ratio('iadu')}",
                         f"{m['gain']:.3f}{ratio('gain')}", f"{m['max_abs_u']:.0f}"])
    return rows


VARIANT_COLUMNS = ["variant", "design", "ρ", "θ settling [s]", "ISE θ", "ISE ϕ̇", "IADU", "‖x‖/‖w‖",
                   "max |u| [N m]"]


def variant_claims(variants: Sequence[dict[str, Any]]) -> list[tuple[str, bool, str]]:
    """(text, held, detail) per variant: does W∞ beat H∞ on ISE ϕ̇, IADU and gain (thesis)?
    "Beat" means below ``LOWER`` times the H∞ value."""
    out = []
    for v in variants:
        w, h = v["W"], v["H"]
        ok = all(w[k] < LOWER * h[k] for k in ("ise_phidot", "iadu", "gain"))
        detail = ", ".join(f"{k} {w[k] / h[k]:.0%}" for k in ("ise_phidot", "iadu", "gain"))
        out.append((f"variant '{v['label']}' (ρ = {v['rho']:.4g}, settling {w['settling_s']:.3f} vs "
                    f"{h['settling_s']:.3f} s): W∞ lower ISE ϕ̇, IADU and ‖x‖/‖w‖ than H∞ (by > {1 - LOWER:.0%})",
                    ok, detail))
    return out


def add_variants(res: ExperimentResult, lin: tuple[np.ndarray, np.ndarray, np.ndarray],
                 rigs: Mapping[str, BalanceLinearRig], designs: dict[str, dict[str, Any]], duration: float,
                 out_dir: str | Path) -> None:
    """Run the variants, write ``balance-linear_variants`` (md + json), add claims/metrics."""
    from sobolev_drake.experiments import Claim
    from sobolev_drake.report import write_table
    variants = run_variants(lin, rigs, designs, duration)
    res.metrics["variants"] = variants
    md, js, _ = write_table(out_dir, "balance-linear_variants", VARIANT_COLUMNS, variant_rows(variants),
                            title=f"Variant pairs, equal θ settling time (nonlinear plant, {duration:g} s); "
                                  "W∞ rows: % of the H∞ value")
    res.outputs.update({"variants_md": md, "variants_json": js})
    res.claims.extend(Claim(t, held, d) for t, held, d in variant_claims(variants))
