"""Shared harness of the chapter-5 mechanical experiments (thesis 5.3).

One closed loop (plant + MechanicalController + reference + disturbance + loggers, optionally
a Meshcat recorder) is built once per experiment and reused for every run: the W2/W∞ run and
all runs of the H∞ tuning search swap only the controller's inner law
(:meth:`MechanicalController.set_inner`), because Python LeafSystems are not garbage-collected
in drake 1.51.

H∞ baseline rule (the thesis tunes "by trial and error" to the same IADU, or to the same ISE of
a named variable, and prints no weights):

* sliding surface ė + (s/ω1) e + (ω3/ω1) ∫e with ω1 = 1 and the coefficients set to the mean
  over the controlled DOF of the slow factor s² + (k/q) s + t/q of the W closed-loop
  polynomials s³ + (q/y3)s² + (k/y3)s + t/y3 (:func:`hinf_surface`), so both controllers aim at
  the same error dynamics;
* the σ-gain 1/ωu² found by a 1-D search on log ωu (bracketing + regula falsi, :func:`tune`)
  so that the named index matches the W2/W∞ run; γ = 2ωu (the law does not depend on γ).

See docs/experiments/README.md for the experiments that use it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import VectorLogSink

from sobolev_drake import viz
from sobolev_drake.synthesis.mechanical import SobolevGains, hinf_mechanical_gains
from sobolev_drake.systems.mechanical_controller import HinfLaw, MechanicalController

__all__ = ["Loop", "build_loop", "run_loop", "hinf_surface", "hinf_inner", "tune",
           "compare_plot", "pct"]


@dataclass
class Loop:
    diagram: object
    simulator: object
    handles: object
    controller: MechanicalController
    sinks: dict
    meshcat: object = None
    recorder: object = None
    info: dict = field(default_factory=dict)


def build_loop(add_plant: Callable, controller_model, partition, inner, reference, disturbance, *,
               lower=None, upper=None, allocation=None, record=False) -> Loop:
    """Plant (``add_plant(builder) -> PlantHandles``) in closed loop with a MechanicalController
    on ``controller_model`` (separate from the simulated truth)."""
    from pydrake.systems.analysis import Simulator

    b = DiagramBuilder()
    h = add_plant(b)
    ref = b.AddSystem(reference)
    dist = b.AddSystem(disturbance)
    ctrl = b.AddSystem(MechanicalController(controller_model, partition, inner, lower=lower,
                                            upper=upper, allocation=allocation))
    b.Connect(h.x, ctrl.GetInputPort("x"))
    b.Connect(ref.GetOutputPort("reference"), ctrl.GetInputPort("reference"))
    b.Connect(ctrl.GetOutputPort("u"), h.u)
    b.Connect(dist.GetOutputPort("generalized_force"), h.disturbance)
    sinks = {}
    for name, port in (("x", h.x), ("u", ctrl.GetOutputPort("u")),
                       ("ref", ref.GetOutputPort("reference")),
                       ("w", dist.GetOutputPort("generalized_force")),
                       ("ei", ctrl.GetOutputPort("error_integral"))):
        sink = b.AddSystem(VectorLogSink(port.size()))
        b.Connect(port, sink.get_input_port())
        sinks[name] = sink
    meshcat = recorder = None
    if record:
        meshcat = viz.start_meshcat()
        recorder = viz.add_meshcat_recorder(b, h.scene_graph, meshcat)
    diagram = b.Build()
    sim = Simulator(diagram)
    return Loop(diagram, sim, h, ctrl, sinks, meshcat, recorder)


def run_loop(loop: Loop, inner, duration, q0, qd0, *, label="", accuracy=1e-4, max_step=0.05,
             evals_per_second=20000):
    """Reset the loop, swap the inner law, simulate; return logged arrays (rows = samples).

    A simulation that fails (divergence, NaN, or more than ``evals_per_second`` derivative
    evaluations per simulated second — a saturated high-gain law chattering) is reported in
    ``run["failed"]`` with the logs up to the failure instead of raising, so the experiment can
    report what happened and the tuning search treats it as "too aggressive".
    """
    from pydrake.systems.analysis import ResetIntegratorFromFlags
    from pydrake.systems.framework import EventStatus
    loop.controller.set_inner(inner)
    ctx = loop.simulator.get_mutable_context()
    ctx.SetTime(0.0)
    loop.handles.set_state(ctx, loop.diagram, q0, qd0)
    cctx = loop.controller.GetMyMutableContextFromRoot(ctx)
    cctx.SetContinuousState(np.zeros(loop.controller.law.nc))
    for sink in loop.sinks.values():
        sink.FindMutableLog(ctx).Clear()
    failed = ""
    budget = int(evals_per_second * float(duration)) + 2000
    sim = loop.simulator
    ResetIntegratorFromFlags(sim, "runge_kutta3", float(max_step))
    integ = sim.get_mutable_integrator()
    integ.set_target_accuracy(float(accuracy))
    stop = []

    def monitor(context):  # deterministic work budget (derivative evaluations)
        if integ.get_num_derivative_evaluations() > budget:
            stop.append(context.get_time())
            return EventStatus.ReachedTermination(loop.diagram, "evaluation budget exceeded")
        return EventStatus.Succeeded()

    sim.set_monitor(monitor)
    try:
        sim.Initialize()
        integ.ResetStatistics()
        sim.AdvanceTo(float(duration))
        if stop:
            failed = (f"stopped at t = {stop[0]:.3f} s: {budget} derivative evaluations exceeded "
                      "(stiff / chattering closed loop)")
    except (RuntimeError, ValueError, np.linalg.LinAlgError) as exc:
        failed = f"{type(exc).__name__}: {str(exc).splitlines()[0][:200]}"
    sim.clear_monitor()
    out = {name: sink.FindLog(ctx).data().T.copy() for name, sink in loop.sinks.items()}
    out["t"] = loop.sinks["x"].FindLog(ctx).sample_times().copy()
    out["failed"] = failed
    out["label"] = label
    return out


def tracked_errors(run, law):
    """(e, ė) of the tracked DOF (N × m) from the logged state and reference."""
    n, m = law.n, law.n_ref
    idx = list(law.partition.tracked)
    q, qd = run["x"][:, :n], run["x"][:, n:]
    return q[:, idx] - run["ref"][:, :m], qd[:, idx] - run["ref"][:, m:2 * m]


def hinf_surface(gains: SobolevGains) -> tuple[float, float, float]:
    """(ω1, ω2, ω3) of the H∞ sliding surface matched to the W design (module docstring)."""
    q = np.diag(gains.blocks["Q"])
    k = np.diag(gains.blocks["K"])
    t = np.diag(gains.blocks["T"])
    c1, c0 = float(np.mean(k / q)), float(np.mean(t / q))
    w2sq = c1 ** 2 - 2 * c0  # s² = ω2² + 2ω1ω3 with ω1 = 1
    return 1.0, float(np.sqrt(max(w2sq, 0.0))), c0


def hinf_inner(surface, omega_u: float) -> HinfLaw:
    w1, w2, w3 = surface
    return HinfLaw(hinf_mechanical_gains(w1, w2, w3, omega_u, 2.0 * omega_u))


def tune(evaluate: Callable[[float], tuple[float, dict]], target: float, omega0: float, *,
         iters: int = 7, factor: float = 3.0, rtol: float = 0.02, decreasing: bool = True):
    """1-D search of ωu so that ``evaluate(ωu)[0]`` ≈ ``target``; the index is decreasing in ωu
    (IADU: larger ωu, softer law) or, with ``decreasing=False``, increasing (ISE).

    Bracket by multiplying/dividing ωu by ``factor``, then regula falsi on (log ωu, log index).
    Returns (best ωu, best run, history [(ωu, index)]) — the best is the closest in log ratio.
    """
    hist, runs = [], {}

    def ev(w):
        val, run = evaluate(w)
        if run.get("failed") or not np.isfinite(val) or val <= 0:
            val = np.inf  # diverged: treated as "index too large"
        hist.append((float(w), float(val)))
        runs[float(w)] = run
        return val

    lo_w = hi_w = None  # lo_w: a point where ωu must grow, hi_w: where it must shrink
    w = float(omega0)
    for _ in range(iters):
        val = ev(w)
        if abs(np.log(val / target)) < np.log1p(rtol):
            break
        if (val > target) == decreasing:
            lo_w = (w, val)  # ωu must grow
        else:
            hi_w = (w, val)  # ωu must shrink
        if lo_w is None:
            w = w / factor
        elif hi_w is None:
            w = w * factor
        else:
            (a, fa), (b, fb) = lo_w, hi_w
            la, lb = np.log(a), np.log(b)
            if np.isfinite(fa) and np.isfinite(fb):
                ga, gb = np.log(fa / target), np.log(fb / target)
                x = la - ga * (lb - la) / (gb - ga)
                x = min(max(x, la + 0.1 * (lb - la)), lb - 0.1 * (lb - la))  # stay inside
            else:
                x = 0.5 * (la + lb)
            w = float(np.exp(x))
    best = min(hist, key=lambda p: abs(np.log(p[1] / target)) if np.isfinite(p[1]) else np.inf)
    return best[0], runs[best[0]], hist


def pct(value, base):
    return f"{value:.4g} ({100 * value / base:.0f}%)" if base else f"{value:.4g}"


def compare_plot(path, runs: dict, panels, *, title="", vlines=()):
    """Stacked panels; each panel ``(ylabel, fn(run) -> (N, k), labels)`` overlays all runs."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(panels), 1, sharex=True, figsize=(8, 1.9 * len(panels) + 0.8),
                             squeeze=False)
    styles = ["-", "--", ":", "-."]
    for ax, (ylabel, fn, labels) in zip(axes[:, 0], panels):
        for k, (name, run) in enumerate(runs.items()):
            y = np.asarray(fn(run), dtype=float)
            y = y[:, None] if y.ndim == 1 else y
            for j in range(y.shape[1]):
                lab = f"{name} {labels[j]}" if labels else name
                ax.plot(run["t"], y[:, j], styles[k % 4], lw=1.0, color=f"C{j}", label=lab)
        for v in vlines:
            ax.axvline(v, color="0.75", lw=0.6)
        ax.set_ylabel(ylabel)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=6, ncol=4, loc="upper right")
    axes[-1, 0].set_xlabel("t [s]")
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return viz.save_figure(fig, path)


def sobolev_bound(run, law, truth_model):
    """Theorem 3 check on a logged W2/W∞ run of a fully actuated or reduced law:
    ‖z‖²_W (z = ∫q̃c, ë from the truth's forward dynamics) against γ²‖δ̄‖²_L2 + 2V(x0),
    γ² = max over the run of λmax(M̄⁻¹ Y3 M̄⁻¹) ((5.56)), δ̄ = w_c − Mcu Muu⁻¹ w_u.
    """
    from sobolev_drake.synthesis.mechanical import winf_gamma

    g = law.law.controlled
    n, nc = law.n, law.nc
    ic, iu = law.ic, law.iu
    Y = g.weights
    t = run["t"]
    e, ed = tracked_errors(run, law)
    qddr = run["ref"][:, 2 * law.n_ref:]
    cost, w2, gam2 = [], [], []
    for k in range(len(t)):
        q, qd = run["x"][k, :n], run["x"][k, n:]
        M = truth_model.M(q)
        h = truth_model.Cqdot(q, qd) + truth_model.g(q) + truth_model.friction(qd)
        qdd = np.linalg.solve(M, truth_model.B(q) @ run["u"][k] + run["w"][k] - h)
        edd = qdd[ic] - qddr[k, :nc]
        ei = run["ei"][k]
        cost.append(ei @ Y["Y0"] @ ei + e[k] @ Y["Y1"] @ e[k] + ed[k] @ Y["Y2"] @ ed[k]
                    + edd @ Y["Y3"] @ edd)
        w = run["w"][k]
        if len(iu):
            X = M[np.ix_(ic, iu)] @ np.linalg.inv(M[np.ix_(iu, iu)])
            Mbar = M[np.ix_(ic, ic)] - X @ M[np.ix_(iu, ic)]
            dbar = w[ic] - X @ w[iu]
        else:
            Mbar, dbar = M, w
        w2.append(dbar @ dbar)
        gam2.append(winf_gamma(Mbar, Y["Y3"]) ** 2)
    z2 = float(np.trapezoid(cost, t))
    wl2 = float(np.trapezoid(w2, t))
    V0 = g.value(np.concatenate([ed[0], e[0], run["ei"][0]]))
    gamma2 = float(max(gam2))
    return {"z2": z2, "w2": wl2, "gamma": float(np.sqrt(gamma2)), "V0": V0,
            "rhs": gamma2 * wl2 + 2 * V0, "holds": bool(z2 <= gamma2 * wl2 + 2 * V0)}


def omega_u_guess(law, gains: SobolevGains, q0, qd0) -> float:
    """Initial ωu for the search: 1/ωu² ≈ mean over the controlled DOF of the W law's ė gain
    in force units, diag(M̄)·diag(Y3⁻¹Q) (M̄ = reduced inertia (5.5) or the tracked block of M)."""
    if law.partition.mode == "reduced":
        Mbar = law.reduced_model(np.asarray(q0, float), np.asarray(qd0, float))[0]
    else:
        M = law.model.M(np.asarray(q0, float))
        Mbar = M[np.ix_(law.ic, law.ic)]
    kd = np.diag(gains.blocks["Q"]) / np.diag(gains.weights["Y3"])
    return float(1.0 / np.sqrt(np.mean(np.diag(Mbar) * kd)))
