"""Singular H∞ problems (D12 or D21 rank deficient): the default call against the infimum.

Plants: ``random_plants.singular_family`` (seeded; 2-20 states; D21 = 0, D21 of rank 1, D12
with a zero column -- output feedback -- and D12 with a zero column -- state feedback).  For
each plant the library's default call (``state_feedback`` / ``output_feedback``) is judged by
quantities computed here, independently of the path that produced the controller:

* "stabilizing": closed-loop eigenvalues in the open left half plane;
* "certified": ``result.certificate.ok`` and the claimed gamma not below the closed-loop H∞
  norm computed here (Hamiltonian iteration, 1e-6 relative);
* "gap": claimed gamma / reference infimum - 1.  The reference is the smaller of two upper
  estimates of the infimum, computed apart from the default's singular ladder: the LMI optimum
  (``method="lmi", regularize=False, verify=False``: the bounded-real LMI, whose accuracy is the
  solver's -- it is off by percents on badly conditioned plants) and the Riccati bisection's
  optimum of the regular problem made by perturbing the plant by 1e-7 (1e-6, 1e-5 where the
  Riccati tests refuse every level at the smaller one; cost on u, noise on y;
  ``random_plants.reference_infimum``; it bounds the infimum from above and tends to it).  A gap
  below zero means both references were looser than the controller returned (its norm is
  checked independently), not a claim below the infimum;
* "fast": the controller's (output feedback) or closed loop's (state feedback) fastest pole /
  the plant's fastest mode (max |eig A|, at least 1 rad/s).

Usage::

    python benchmarks/synthesis_singular.py [--plants 100] [--seed 0] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import time
import warnings

import numpy as np

from sobolev_drake.synthesis.certificates import hinf_norm
from sobolev_drake.synthesis.hinf import output_feedback, state_feedback
from sobolev_drake.synthesis.random_plants import reference_infimum, singular_family
from sobolev_drake.synthesis.riccati import RiccatiInfeasible


def plant_speed(p):
    """Fastest mode of the plant (rad/s), at least 1 (a plant of integrators has none)."""
    return max(1.0, float(np.abs(np.linalg.eigvals(p.A)).max()))


def judge(case):
    """One row: the default call on ``case`` judged independently, and the LMI reference."""
    p, of = case.plant, case.output_feedback
    synth = output_feedback if of else state_feedback
    row = {"case": str(case), "n": p.n, "kind": "OF" if of else "SF"}
    t = time.perf_counter()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = synth(p)
        row["time"] = time.perf_counter() - t
    except Exception as exc:  # noqa: BLE001 -- a benchmark records every failure
        row.update(time=time.perf_counter() - t, error=f"{type(exc).__name__}: {exc}"[:200])
        return row
    cl = res.closed_loop(p)
    stable = bool(np.linalg.eigvals(cl[0]).real.max() < 0)
    norm = hinf_norm(*cl)[0] if stable else np.inf
    poles = np.linalg.eigvals(res.controller.AK) if of and res.controller.AK.size else \
        np.linalg.eigvals(cl[0])
    row.update(gamma=res.gamma, norm=norm, stabilizing=stable,
               certified=bool(res.certificate.ok and norm <= res.gamma * (1 + 1e-6)),
               fast=float(np.abs(poles).max()) / plant_speed(p) if poles.size else 0.0,
               method=res.method, note=res.warnings[0] if res.warnings else "")
    refs = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            refs["lmi"] = synth(p, method="lmi", regularize=False, verify=False,
                                time_limit=120).gamma_opt
        except Exception as exc:  # noqa: BLE001
            row["lmi_error"] = f"{type(exc).__name__}: {exc}"[:200]
        try:
            refs["riccati"] = reference_infimum(p, of)
        except RiccatiInfeasible as exc:
            row["riccati_error"] = f"{type(exc).__name__}: {exc}"[:200]
    row.update({f"reference_{k}": v for k, v in refs.items()})
    if refs:
        row["reference"] = ref = min(refs.values())
        row["gap"] = res.gamma / ref - 1 if ref > 0 else np.nan
    return row


def summarize(rows):
    ok = [r for r in rows if "error" not in r]
    gaps = np.array([r["gap"] for r in ok if np.isfinite(r.get("gap", np.nan))])
    return {
        "plants": len(rows),
        "returned": len(ok),
        "certified_fraction": sum(r["certified"] for r in ok) / len(rows),
        "stabilizing_fraction": sum(r["stabilizing"] for r in ok) / len(rows),
        "median_gap": float(np.median(gaps)) if gaps.size else None,
        "max_gap": float(gaps.max()) if gaps.size else None,
        "fraction_gap_within_1e-3": float(np.mean(gaps <= 1e-3)) if gaps.size else None,
        "plants_with_a_reference": int(gaps.size),
        "references_looser_than_the_result": int(np.sum(gaps < -1e-4)),
        "max_time_s": max(r["time"] for r in rows),
        "max_fast_ratio": max((r["fast"] for r in ok), default=None),
        "errors": [f'{r["case"]}: {r["error"]}' for r in rows if "error" in r],
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--plants", type=int, default=100)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", default=None)
    args = ap.parse_args()
    rows = []
    for case in singular_family(args.plants, seed=args.seed):
        row = judge(case)
        rows.append(row)
        print(f'{row["case"]:<48} {row.get("method", "-"):>7} gamma {row.get("gamma", np.nan):.6g}'
              f' gap {row.get("gap", np.nan):+.2e} fast {row.get("fast", np.nan):.3g}'
              f' {row["time"]:.2f} s {row.get("error", "")}', flush=True)
    summary = summarize(rows)
    print(json.dumps(summary, indent=1))
    if args.json:
        with open(args.json, "w", encoding="utf-8") as f:
            json.dump({"summary": summary, "rows": rows}, f, indent=1, default=float)


if __name__ == "__main__":
    main()
