"""``balance-coupled``: two-wheeled vehicle with the input-coupling law, W2/W∞ vs classic
nonlinear H∞ (thesis 5.3.2, Table 5.7).

θ is controlled and ϕ stabilized; τ = B†u* is clipped to ±``torque_limit`` (for one input the
exact bounded least-squares allocation).  The H∞ law (docs/design.md §4.3) is tuned to the
same ISE θ on the same loop, by default with the W law's ϕ̇ damping
(``hinf_phidot="matched"``; ``"equal"`` keeps the classic structure, which cannot meet that
rule).

See docs/experiments/balance-coupled.md.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Callable

import numpy as np
from numpy.typing import ArrayLike

from sobolev_drake import norms, plots, report
from sobolev_drake.experiments import Claim, ExperimentResult, register
from sobolev_drake.models.base import MechanicalModel
from sobolev_drake.models.two_wheeled import add_two_wheeled, make_two_wheeled_model
from sobolev_drake.report import percent_rows, reading_claim
from sobolev_drake.rigs.mechanical import (MechanicalLoop, build_loop, compare_with_matched_hinf, run_loop,
                                           tracked_errors)
from sobolev_drake.synthesis.hinf_surface import matched_hinf_surface, scaled_surface
from sobolev_drake.synthesis.mechanical import controlled_gains, stabilized_gains
from sobolev_drake.systems.hinf_baseline import matched_hinf_law
from sobolev_drake.systems.disturbances import TimeProfiledForce
from sobolev_drake.systems.mechanical_controller import HinfLaw, Partition, SobolevLaw
from sobolev_drake.systems.references import PiecewiseTrajectory, TrajectoryReference, const

PARTITION = Partition(controlled=[1], stabilized=[0])          # q = [ϕ θ]: qc = θ, qs = ϕ
GAMMAS = (1000.0, 300.0, 2.0, 0.001)                            # Γ0..Γ3
UPSILONS = (0.1, 1.1)                                           # Υ0, Υ1
Q0, QD0 = np.array([0.0, np.pi / 4]), np.zeros(2)
THESIS = {"W2/W∞": {"IADU": 79.5, "ISE θ": 0.047, "ISE ϕ̇": 4.975e4},
          "H∞": {"IADU": 108.3, "ISE θ": 0.0468, "ISE ϕ̇": 5.032e4}}
COLS = ["IADU", "ISE θ", "ISE ϕ̇"]
B_PERP = np.array([1.0, 1.0]) / np.sqrt(2.0)                    # left annihilator of B = [1, −1]ᵀ
#: an H∞ tuning fitted to the thesis' H∞ row (the thesis prints none): the W-matched surface's
#: error polynomial s² + c1 s + c0 with c1 × 3.75 and c0 × 16, ωu from an equal-ISE θ search on
#: it, no torque limit (docs/experiments/balance-coupled.md); fitted, so it shows only that
#: some tuning gives the row
HINF_READING_FACTORS, HINF_READING_OMEGA_U = (3.75, 16.0), 0.6915
HINF_READING = "surface c1 × 3.75, c0 × 16, ωu 0.6915, no torque limit (fitted)"


def sobolev_inner() -> SobolevLaw:
    """W2/W∞ gains of the thesis tuning (Theorem 4, (5.76)–(5.82))."""
    return SobolevLaw(controlled_gains(*GAMMAS), stabilized=stabilized_gains(*UPSILONS))


def reference() -> TrajectoryReference:
    return TrajectoryReference(PiecewiseTrajectory(["theta"], [[const(0.0)]],
                                                   description="upright: theta_r = 0"))


def disturbance() -> TimeProfiledForce:
    return TimeProfiledForce(2, [
        {"index": 0, "value": lambda t: 4.0 * np.sin(2 * np.pi * t / 5), "from": 7.0, "to": 14.0},
        {"index": 1, "value": 4.0, "from": 22.0, "to": 32.0},
    ])


def indices(run: dict[str, Any]) -> dict[str, float]:
    t = run["t"]
    return {"IADU": float(norms.iadu(t, run["u"]).sum()),
            "ISE θ": float(norms.ise(t, run["x"][:, 1])),      # θ_r ≡ 0
            "ISE ϕ̇": float(norms.ise(t, run["x"][:, 2]))}


def annihilator_residual(run: dict[str, Any], model: MechanicalModel) -> np.ndarray:
    """‖B⊥(w − d)‖² along a run (Assumption 8) with d = g + K(q̇) (θ_r ≡ 0: no reference terms)."""
    out = np.empty(len(run["t"]))
    for k in range(len(out)):
        q, qd = run["x"][k, :2], run["x"][k, 2:]
        out[k] = float(B_PERP @ (run["w"][k] - model.g(q) - model.friction(qd))) ** 2
    return out


def coupled_loop(model: MechanicalModel, w_inner: SobolevLaw, limit: float | None, hinf_phidot: str,
                 record: bool = False) -> MechanicalLoop:
    """The closed loop of this experiment: τ = B†u* clipped to ±``limit`` (None: no limit) and,
    with ``hinf_phidot="matched"``, an H∞ law's ϕ̇ damping replaced by the W law's."""
    base, holder = make_allocation(limit), {}
    # ϕ̇ damping of the W law in force units: M_ϕϕ Υ1⁻¹U (M_ϕϕ = (M + m)r² + Ir is constant)
    w_damping = float(model.M(Q0)[0, 0] * w_inner.stabilized.K[0, 0])

    def alloc(u, q, qd):
        inner = holder["controller"].law.law
        if hinf_phidot == "matched" and isinstance(inner, HinfLaw):
            # the classic law damps q̇s with the σ gain R⁻¹ (u*_ϕ ∋ −R⁻¹ϕ̇), which fights the
            # balance under a constant wθ; give it the W law's ϕ̇ damping instead
            # (docs/experiments/balance-coupled.md)
            u = np.array(u, dtype=float)
            u[0] += (inner.gains.R_inv - w_damping) * qd[0]
        return base(u, q, qd)

    loop = build_loop(add_two_wheeled, model, PARTITION, w_inner, reference(), disturbance(),
                      allocation=alloc, record=record)
    holder["controller"] = loop.controller
    return loop


def hinf_reading(duration: float) -> dict[str, float]:
    """Indices of the classic H∞ of :data:`HINF_READING` (fitted to the thesis' H∞ row)."""
    w_inner = sobolev_inner()
    loop = coupled_loop(make_two_wheeled_model(), w_inner, None, "matched")
    surface = scaled_surface(matched_hinf_surface(w_inner.controlled), *HINF_READING_FACTORS)
    return indices(run_loop(loop, matched_hinf_law(surface, HINF_READING_OMEGA_U), duration, Q0, QD0,
                            label="H∞ reading"))


def make_allocation(limit: float | None) -> Callable[[ArrayLike, ArrayLike, ArrayLike], np.ndarray]:
    """τ = B†u* = (u*_ϕ − u*_θ)/2 (5.118), saturated to ±``limit``: with a single input this is
    exactly the bounded least-squares allocation min ‖u* − Bτ‖ s.t. |τ| ≤ limit (a convex 1-D
    quadratic's constrained minimizer is its clipped unconstrained one), without a QP solve."""
    hi = np.inf if limit is None else float(limit)
    return lambda u, q, qd: np.array([min(max(0.5 * (u[0] - u[1]), -hi), hi)])


@register("balance-coupled", "Two-wheeled vehicle, input-coupling law: W2/W∞ vs H∞ (Table 5.7)",
          default_duration=40.0, thesis_ref="5.3.2, Table 5.7, Fig. 5.5")
def run(out_dir: str | Path, *, duration: float | None = None, record: bool = False, smoke: bool = False,
        torque_limit: float | None = 50.0, hinf_phidot: str = "matched") -> ExperimentResult:
    out_dir = Path(out_dir)
    duration = float(duration or (1.0 if smoke else 40.0))
    lim = None if torque_limit is None else float(torque_limit)
    if lim is not None and not lim > 0:
        raise ValueError(f"torque_limit must be positive or None, got {torque_limit!r}")
    if hinf_phidot not in ("matched", "equal"):
        raise ValueError(f"hinf_phidot must be 'matched' or 'equal', got {hinf_phidot!r}")
    w_inner = sobolev_inner()
    model = make_two_wheeled_model()
    loop = coupled_loop(model, w_inner, lim, hinf_phidot, record=record)
    law = loop.controller.law
    outputs, claims = {}, []
    cmp = compare_with_matched_hinf(loop, w_inner, duration, Q0, QD0, indices, match="ISE θ",
                                    iters=1 if smoke else 9, rtol=0.01, decreasing=False,
                                    record_to=out_dir / "balance_coupled_w.html" if record else None)
    if record:
        outputs["meshcat W2/W∞"] = cmp.recording
    w_run, w_idx, h_run, h_idx, wu, hist, surface = (
        cmp.w_run, cmp.w_indices, cmp.hinf_run, cmp.hinf_indices, cmp.omega_u, cmp.history, cmp.surface)
    reading = hinf_reading(duration)
    rows = percent_rows({"W2/W∞": w_idx, "H∞": h_idx}, "H∞", COLS)
    rows += percent_rows({f"H∞ — {HINF_READING} (% of the thesis' H∞)": reading}, THESIS["H∞"], COLS)
    th = percent_rows(THESIS, "H∞", COLS) + [None]
    md, js, table = report.write_table(
        out_dir, "balance_coupled", ["controller", *COLS], rows, thesis_rows=th,
        title=f"Table 5.7 (two-wheeled vehicle, input coupling, {duration:g} s, torque limit "
              f"{'none' if lim is None else f'±{lim:g} N m'}, H∞ ϕ̇ damping {hinf_phidot})")
    outputs.update({"table (md)": md, "table (json)": js})
    runs = {"W2/W∞": w_run, "H∞": h_run}
    for r in runs.values():
        r["bperp"] = annihilator_residual(r, model)
    outputs["states and input"] = plots.compare_plot(
        out_dir / "balance_coupled.png", runs,
        [("θ [rad]", lambda r: r["x"][:, 1], None),
         ("ϕ̇ [rad/s]", lambda r: r["x"][:, 2], None),
         ("u [N m]", lambda r: r["u"][:, 0], None),
         ("‖B⊥(w−d)‖²", lambda r: r["bperp"], None),
         ("w [N m]", lambda r: r["w"], ["wϕ", "wθ"])],
        title="Two-wheeled vehicle, input coupling (thesis Fig. 5.5)", vlines=(7, 14, 22, 32))
    sat = {k: 0.0 if lim is None else norms.fraction_at_bounds(r["u"], -lim, lim)
           for k, r in runs.items()}
    for name, r in runs.items():
        if r["failed"]:
            claims.append(Claim(f"{name} simulation completed", False, r["failed"]))
        claims.append(Claim(f"{name} keeps the vehicle upright (|θ| < π/2) and |θ| < 0.01 rad at "
                            "the end", bool(np.max(np.abs(r["x"][:, 1])) < np.pi / 2
                                            and abs(r["x"][-1, 1]) < 0.01),
                            f"max |θ| {np.max(np.abs(r['x'][:, 1])):.3g}, final θ {r['x'][-1, 1]:.3g}"))
        claims.append(Claim(f"{name}: motor torque saturated less than 5 % of the time",
                            sat[name] < 0.05, f"saturated samples {100 * sat[name]:.1f} %, "
                                              f"|u| max {np.abs(r['u']).max():.3g} N m"))
    claims.append(Claim("H∞ tuned to the same ISE θ as W2/W∞ (within 2 %)",
                        abs(h_idx["ISE θ"] / w_idx["ISE θ"] - 1) < 0.02,
                        f"W {w_idx['ISE θ']:.4g}, H∞ {h_idx['ISE θ']:.4g}, ωu = {wu:.4g}; search "
                        f"(ωu, ISE θ) {[(round(a, 5), float(f'{b:.4g}')) for a, b in hist]}"))
    claims.append(Claim("W2/W∞ needs less control variation (IADU) than H∞ at equal ISE θ "
                        "(thesis 73 %)", w_idx["IADU"] < h_idx["IADU"],
                        f"{100 * w_idx['IADU'] / h_idx['IADU']:.0f} %"))
    claims.append(Claim("ISE ϕ̇ similar for both controllers (thesis 98 %; within ±10 %)",
                        abs(w_idx["ISE ϕ̇"] / h_idx["ISE ϕ̇"] - 1) < 0.1,
                        f"{100 * w_idx['ISE ϕ̇'] / h_idx['ISE ϕ̇']:.0f} %"))
    claims.append(reading_claim(f"an H∞ tuning ({HINF_READING}) reproduces the thesis' H∞ row within 2 %",
                                reading, THESIS["H∞"], COLS, 0.02))
    claims.append(reading_claim("our W2/W∞ run reproduces the thesis' W2/W∞ row within 2 %",
                                w_idx, THESIS["W2/W∞"], COLS, 0.02))
    e, _ = tracked_errors(w_run, law)
    metrics = {"W2/W∞": w_idx, "H∞": h_idx, "hinf_omega_u": wu, "hinf_surface": surface,
               "hinf_search": hist, "duration": duration, "final_theta_W": float(e[-1, 0]),
               "torque_limit": lim, "saturated_fraction": sat, "hinf_phidot": hinf_phidot,
               "bperp_max": {k: float(r["bperp"].max()) for k, r in runs.items()}, "hinf_reading": reading}
    return ExperimentResult("balance-coupled", outputs, metrics, claims, table)
