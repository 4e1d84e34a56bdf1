"""Well-posedness diagnostics of the ``balance-linear`` output-feedback designs (Table 6.2).

Both output-feedback problems measure y = [θ, ϕ̇] without noise (D21 = 0): they are singular
H∞ problems whose LMI optimum γ* is not attained, so the controller returned "at γ*" depends
on where the solver stops.  :func:`gain_growth` shows the least-gain controller growing as
γ → γ*; :func:`backend_spread` compares backends (raw optimum, regularized, fixed γ) on
coordinate-free controller data and on the nonlinear settling time.  They are the evidence
for designing both controllers at γ = (1+δ)γ* (``regularize=True, delta=OF_REG_DELTA``,
docs/design.md §8.2) with γ* from one pinned backend (``OF_BACKEND``).

See docs/experiments/balance-linear.md.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any, Sequence

import numpy as np
from numpy.typing import ArrayLike

from sobolev_drake.experiments._balance_linear_designs import (C_OF, DESIGN_SPECS, GAMMA0_OF, GAMMA1_OF,
                                                               OF_BACKEND, RADIUS, design)
from sobolev_drake.harness import quiet
from sobolev_drake.rigs.balance_linear import BalanceLinearRig, result_gains, theta_settling_time

if TYPE_CHECKING:
    from sobolev_drake.report import ExperimentResult
    from sobolev_drake.synthesis.problem import DynamicController, GeneralizedPlant
    from sobolev_drake.synthesis.regions import LMIRegion

#: frequencies [rad/s] of the controller peak-gain sweep (the disk radius is 150 rad/s)
OMEGA = np.logspace(-2, 4, 400)


def controller_peak_gain(ctrl: DynamicController | Sequence[ArrayLike], omega: ArrayLike = OMEGA) -> float:
    """max over ``omega`` of σ_max(C_K (jωI − A_K)⁻¹ B_K + D_K): invariant under the choice of
    controller state coordinates (unlike ‖B_K‖), defined also for unstable A_K."""
    AK, BK, CK, DK = (np.atleast_2d(np.asarray(m, float)) for m in ctrl)
    n = AK.shape[0]
    if AK.shape != (n, n) or BK.shape[0] != n or CK.shape[1] != n:
        raise ValueError(f"ctrl must be (AK n×n, BK n×ny, CK nu×n, DK nu×ny), got shapes "
                         f"{AK.shape}, {BK.shape}, {CK.shape}, {DK.shape}")
    I = np.eye(n)
    return float(max(np.linalg.norm(CK @ np.linalg.solve(1j * w * I - AK, BK) + DK, 2) for w in omega))


def gain_growth(plant: GeneralizedPlant, region: LMIRegion | None, gamma_opt: float,
                deltas: Sequence[float] = (0.2, 0.1, 0.05, 0.02), *,
                backend: str | None = None) -> list[dict[str, Any]]:
    """Controllers minimizing the LMI gain bound at γ = (1+δ)γ* for each δ.

    Returns a list of dicts (delta, gamma, norm_Y (γ² normalization), DK, peak_gain,
    certified) or (delta, error) when the solver fails (it does close to a non-attained
    infimum: the problem becomes ill-conditioned)."""
    from sobolev_drake.synthesis.hinf import output_feedback
    from sobolev_drake.synthesis.lmi import SynthesisError
    if not gamma_opt > 0:
        raise ValueError(f"gamma_opt must be positive, got {gamma_opt!r}")
    rows = []
    for d in deltas:
        if not d > 0:
            raise ValueError(f"deltas must be positive, got {d!r}")
        try:
            r, _ = quiet(output_feedback, plant, region=region, gamma=(1 + d) * gamma_opt, backend=backend)
        except SynthesisError as e:
            rows.append({"delta": float(d), "error": str(e)[:160]})
            continue
        rows.append({"delta": float(d), "gamma": float(r.gamma), "norm_Y": float(np.linalg.norm(r.Y, 2)),
                     "DK": np.asarray(r.controller.DK).ravel().tolist(),
                     "peak_gain": controller_peak_gain(r.controller), "certified": bool(r.certificate.ok)})
    return rows


def backend_spread(which: str, lin: tuple[np.ndarray, np.ndarray, np.ndarray], rho: float | None,
                   rig: BalanceLinearRig, backends: Sequence[str] = ("clarabel", "ipm", "drake"), *,
                   duration: float = 5.0, gamma: float | None = None,
                   plant: GeneralizedPlant | None = None, region: LMIRegion | None = None
                   ) -> list[dict[str, Any]]:
    """``which`` designed by each backend: LMI optimum (``regularize=False``), regularized at
    (1+δ) times that backend's own γ*, and — with ``gamma``/``plant``/``region`` — the
    least-gain controller at that fixed γ.  Per row: γ, γ*, ‖Y‖, D_K, controller peak gain
    and the θ settling time on the nonlinear rig (or ``error``)."""
    from sobolev_drake.synthesis.hinf import output_feedback
    from sobolev_drake.synthesis.lmi import SynthesisError
    modes = ["LMI optimum", "regularized δ"] + (["fixed γ"] if gamma is not None else [])
    rows = []
    for mode in modes:
        for be in backends:
            row = {"design": which, "rho": rho, "backend": be, "mode": mode}
            try:
                if mode == "fixed γ":
                    r, _ = quiet(output_feedback, plant, region=region, gamma=gamma, backend=be)
                else:
                    r, _, _ = design(which, lin, rho=rho, backend=be, regularize=mode != "LMI optimum")
            except SynthesisError as e:
                rows.append({**row, "error": str(e)[:160]})
                continue
            d = rig.run(result_gains(r), duration)
            rows.append({**row, "gamma": float(r.gamma), "gamma_opt": float(r.gamma_opt),
                         "norm_Y": float(np.linalg.norm(r.Y, 2)), "norm_X": float(np.linalg.norm(r.X, 2)),
                         "DK": np.asarray(r.controller.DK).ravel().tolist(),
                         "peak_gain": controller_peak_gain(r.controller), "certified": bool(r.certificate.ok),
                         "settling_s": theta_settling_time(d),
                         "max_abs_u": float(np.abs(d["u"]).max())})
    return rows


def spread(rows: Sequence[dict[str, Any]], key: str) -> float:
    """Relative spread (max − min)/max|.| of ``key`` over the rows without error."""
    v = np.array([np.linalg.norm(r[key]) if isinstance(r[key], list) else r[key] for r in rows if "error" not in r])
    if v.size < 2:
        return float("nan")
    return float((v.max() - v.min()) / max(np.abs(v).max(), 1e-300))


def posedness_table_rows(spread_rows: Sequence[dict[str, Any]],
                         growth: dict[str, tuple[float | None, list[dict[str, Any]]]]) -> list[list[Any]]:
    """Rows of the diagnostics table: backend comparison, then the gain-growth ladders."""
    rows = []
    for r in spread_rows:
        label = r["mode"]
        if "error" in r:
            rows.append([r["design"], r["rho"] or "—", label, r["backend"], "failed", "", "", "", "", ""])
            continue
        rows.append([r["design"], r["rho"] or "—", label, r["backend"], f"{r['gamma']:.5g}", f"{r['norm_Y']:.3g}",
                     "[" + ", ".join(f"{x:.1f}" for x in r["DK"]) + "]", f"{r['peak_gain']:.3g}",
                     f"{r['settling_s']:.3f}", f"{r['max_abs_u']:.0f}"])
    for name, (rho, g_rows) in growth.items():
        for g in g_rows:
            lab = f"γ = (1+{g['delta']:g})γ*, min gain bound"
            if "error" in g:
                rows.append([name, rho or "—", lab, "", "failed", "", "", "", "", ""])
            else:
                rows.append([name, rho or "—", lab, "", f"{g['gamma']:.5g}", f"{g['norm_Y']:.3g}",
                             "[" + ", ".join(f"{x:.1f}" for x in g["DK"]) + "]", f"{g['peak_gain']:.3g}", "", ""])
    return rows


POSEDNESS_COLUMNS = ["design", "ρ", "synthesis", "backend", "γ", "‖Y‖", "D_K", "peak |K(jω)|",
                     "θ settling [s]", "max |u| [N m]"]


def diagnose(res: ExperimentResult, lin: tuple[np.ndarray, np.ndarray, np.ndarray], rig_of: BalanceLinearRig,
             designs: dict[str, dict[str, Any]], out_dir: str | Path) -> None:
    """O.F. well-posedness table (see :mod:`._balance_linear_posedness`) and its claims."""
    from sobolev_drake.experiments import Claim
    from sobolev_drake.report import write_table
    from sobolev_drake.synthesis import regions
    from sobolev_drake.synthesis import sobolev as sb
    A, B, D = lin
    rho = float(designs["H∞-O.F."]["rho"])
    rows_spread, growth = [], {}
    disk = regions.disk(RADIUS["output_feedback"])
    for name, plant in (("W∞-O.F.", sb.winf_plant(A, B, C_OF, D, Gamma0=GAMMA0_OF, Gamma1=GAMMA1_OF)),
                        ("H∞-O.F.", sb.hinf_plant(A, B, C_OF, D, Q=GAMMA0_OF, R=np.array([[rho]])))):
        g_design = float(designs[name]["res"].gamma)
        winf = DESIGN_SPECS[name].norm == "winf"
        rr = backend_spread(name, lin, None if winf else rho, rig_of, gamma=g_design,
                            plant=plant, region=disk)
        rows_spread += rr
        ref = [r for r in rr if r["mode"] == "LMI optimum" and r["backend"] == OF_BACKEND and "error" not in r]
        g_opt = ref[0]["gamma_opt"] if ref else designs[name]["res"].gamma_opt
        growth[name] = (None if winf else rho,
                        gain_growth(plant, disk, g_opt, (0.2, 0.1, 0.05, 0.02),
                                    backend=OF_BACKEND))  # no slow fallbacks near γ*
        ok = [g for g in growth[name][1] if "error" not in g]
        grows = len(ok) >= 2 and ok[-1]["norm_Y"] >= 5 * ok[0]["norm_Y"]
        res.claims.append(Claim(f"{name} LMI optimum is a non-attained infimum (D21 = 0): ‖Y‖ of the "
                                f"least-gain controller at γ = (1+δ)γ* grows ≥ 5x from δ = 0.2 to the smallest δ solved",
                                grows, ", ".join(f"δ={g['delta']:g}: ‖Y‖={g['norm_Y']:.3g}, peak|K|={g['peak_gain']:.3g}"
                                                 for g in ok)))
        opt = [r for r in rr if r["mode"] == "LMI optimum" and "error" not in r]
        gs = [r["gamma_opt"] for r in opt]
        res.claims.append(Claim(f"{name}: backends agree on the LMI optimum γ* to 1 %",
                                len(gs) >= 2 and max(gs) - min(gs) <= 0.01 * max(gs),
                                ", ".join(f"{r['backend']} {r['gamma_opt']:.5g}" for r in opt)))
        for mode in ("LMI optimum", "regularized δ", "fixed γ"):
            sel = [r for r in rr if r["mode"] == mode and "error" not in r]
            ts = [r["settling_s"] for r in sel]
            agree = len(ts) >= 2 and (max(ts) - min(ts)) <= 0.02 * max(ts)
            what = {"LMI optimum": "LMI-optimum controllers", "regularized δ": "controllers regularized at "
                    "(1+δ) × their own γ*", "fixed γ": f"least-gain controllers at the design γ = {g_design:.5g}"}[mode]
            res.claims.append(Claim(f"{name} {what}: same θ settling time (2 %) with every backend", agree,
                                    ", ".join(f"{r['backend']} {r['settling_s']:.3f} s (D_K "
                                              f"{np.round(r['DK'], 1).tolist()})" for r in sel)
                                    + "".join(f"; {r['backend']} failed" for r in rr
                                              if r["mode"] == mode and "error" in r)))
    res.metrics["of_posedness"] = {"backend_spread": rows_spread, "gain_growth": growth}
    md, js, _ = write_table(out_dir, "balance-linear_of_posedness", POSEDNESS_COLUMNS,
                            posedness_table_rows(rows_spread, growth),
                            title="Output-feedback designs: LMI optimum vs regularized, per backend")
    res.outputs.update({"posedness_md": md, "posedness_json": js})
