"""The closed loop of the chapter-5 mechanical experiments (thesis 5.3).

A plant, a :class:`~sobolev_drake.systems.mechanical_controller.MechanicalController` on a
separate controller model, a reference, a disturbance and loggers are built into one diagram
(:func:`build_loop`); every run (the W2/W∞ law, each step of an H∞ tuning search, each
allocation variant) swaps only the controller's inner law and re-flies the same diagram
(:func:`run_loop`), because Python LeafSystems are never freed (docs/design.md §8.6).
:func:`sobolev_bound` checks Theorem 3 on a logged W2/W∞ run; :func:`bperp_signal` evaluates the
unmatched disturbance of Assumption 8 along a run (Fig. 5.7).
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike
from pydrake.systems.analysis import ResetIntegratorFromFlags, Simulator
from pydrake.systems.framework import DiagramBuilder, EventStatus, LeafSystem
from scipy.linalg import null_space

from sobolev_drake import viz
from sobolev_drake.harness import add_log_sinks
from sobolev_drake.models.base import MechanicalModel
from sobolev_drake.models.handles import PlantHandles
from sobolev_drake.synthesis.hinf_surface import matched_hinf_surface
from sobolev_drake.synthesis.mechanical import winf_gamma
from sobolev_drake.systems.hinf_baseline import matched_hinf_law, omega_u_guess
from sobolev_drake.systems.inner_laws import HinfLaw, SobolevLaw
from sobolev_drake.systems.mechanical_controller import MechanicalController
from sobolev_drake.systems.mechanical_law import MechanicalLaw
from sobolev_drake.systems.partition import Partition
from sobolev_drake.tuning import match_by_regula_falsi

__all__ = ["MechanicalLoop", "build_loop", "run_loop", "MatchedComparison", "compare_with_matched_hinf",
           "tracked_errors", "sobolev_bound", "left_annihilator", "bperp_signal"]


@dataclass
class MechanicalLoop:
    """A built closed loop: the diagram, its simulator, the plant handles, the controller, the
    log sinks by label ("x", "u", "ref", "w", "ei") and the optional Meshcat recorder.

    Attributes
    ----------
    diagram : Diagram
        The closed-loop diagram built by :func:`build_loop`.
    simulator : Simulator
        Its simulator, reused by every :func:`run_loop`.
    handles : PlantHandles
        Handles of the simulated plant (ports ``x``, ``u``, ``disturbance``, ``set_state``).
    controller : MechanicalController
        The controller, whose inner law :func:`run_loop` swaps.
    sinks : dict of str to VectorLogSink
        Loggers of the plant state "x", control input "u", reference "ref", generalized
        disturbance "w" and error integral "ei".
    meshcat : Meshcat, optional
        The Meshcat instance when recording, else None.
    recorder : MeshcatVisualizer, optional
        The Meshcat recorder when recording, else None.
    info : dict
        Free-form extra data about the loop (empty by default).
    """

    diagram: object
    simulator: object
    handles: object
    controller: MechanicalController
    sinks: dict
    meshcat: object = None
    recorder: object = None
    info: dict = field(default_factory=dict)


def build_loop(add_plant: Callable[[DiagramBuilder], PlantHandles],
               controller_model: MechanicalModel, partition: Partition,
               inner: SobolevLaw | HinfLaw, reference: LeafSystem, disturbance: LeafSystem, *,
               lower: ArrayLike | None = None, upper: ArrayLike | None = None,
               allocation: Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray] | None = None,
               record: bool = False) -> MechanicalLoop:
    """Plant in closed loop with a MechanicalController on ``controller_model``.

    Parameters
    ----------
    add_plant : callable
        ``add_plant(builder) -> PlantHandles`` adds the simulated truth.
    controller_model : MechanicalModel
        The controller's model (separate from the truth).
    partition : Partition
        Controlled / stabilized / uncontrolled DOF.
    inner : SobolevLaw or HinfLaw
        The first inner law (:func:`run_loop` swaps it).
    reference : LeafSystem
        Output port "reference" ([q_r, q̇_r, q̈_r] of the tracked DOF).
    disturbance : LeafSystem
        Output port "generalized_force".
    lower, upper : array_like, optional
        Input limits of the controller.
    allocation : callable, optional
        Allocation hook ``(u*, q, q̇) -> u`` of the controller.
    record : bool
        Add a Meshcat recorder.

    Returns
    -------
    MechanicalLoop
    """
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
    sinks = add_log_sinks(b, (("x", h.x), ("u", ctrl.GetOutputPort("u")),
                              ("ref", ref.GetOutputPort("reference")),
                              ("w", dist.GetOutputPort("generalized_force")),
                              ("ei", ctrl.GetOutputPort("error_integral"))), 0.0)   # per step
    meshcat = recorder = None
    if record:
        meshcat = viz.start_meshcat()
        recorder = viz.add_meshcat_recorder(b, h.scene_graph, meshcat)
    diagram = b.Build()
    sim = Simulator(diagram)
    return MechanicalLoop(diagram, sim, h, ctrl, sinks, meshcat, recorder)


def run_loop(loop: MechanicalLoop, inner: SobolevLaw | HinfLaw, duration: float, q0: ArrayLike,
             qd0: ArrayLike, *, label: str = "", accuracy: float = 1e-4,
             max_step: float = 0.05, evals_per_second: int = 20000) -> dict[str, Any]:
    """Reset the loop, swap the inner law, simulate; return the logged arrays (rows = samples).

    A simulation that fails (divergence, NaN, or more than ``evals_per_second`` derivative
    evaluations per simulated second — a saturated high-gain law chattering) is reported in
    ``run["failed"]`` with the logs up to the failure instead of raising, so an experiment can
    report what happened and a tuning search can treat it as "too aggressive".

    Parameters
    ----------
    loop : MechanicalLoop
        From :func:`build_loop`.
    inner : SobolevLaw or HinfLaw
        The inner law of this run.
    duration : float
        Simulated time (s).
    q0, qd0 : array_like
        Initial configuration and velocity of the plant.
    label : str
        Stored as ``run["label"]``.
    accuracy : float
        Target accuracy of the error-controlled RK3 integrator.
    max_step : float
        Largest integrator step (s).
    evals_per_second : int
        Derivative-evaluation budget per simulated second (deterministic, unlike wall time).

    Returns
    -------
    dict
        "x", "u", "ref", "w", "ei" (samples × size), "t", "failed" (empty or the reason),
        "label".
    """
    ctx = loop.simulator.get_mutable_context()
    loop.controller.set_inner(inner, ctx)
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

    def monitor(context):
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


@dataclass
class MatchedComparison:
    """The W2/W∞ run and the classic H∞ run tuned to it (:func:`compare_with_matched_hinf`).

    Attributes
    ----------
    w_run, hinf_run : dict
        The runs (:func:`run_loop`).
    w_indices, hinf_indices : dict
        Their indices.
    omega_u : float
        The H∞ input weight ωu of ``hinf_run``.
    history : list of (float, float)
        The search's (ωu, index) evaluations.
    target : float
        The index value the search aimed at.
    surface : tuple of float
        The H∞ law's surface (ω1, ω2, ω3) (:func:`~sobolev_drake.synthesis.hinf_surface.matched_hinf_surface`).
    recording : Path or None
        The W2/W∞ run's Meshcat recording (standalone HTML), when asked for.
    """

    w_run: dict
    w_indices: dict
    hinf_run: dict
    hinf_indices: dict
    omega_u: float
    history: list
    target: float
    surface: tuple
    recording: object = None


def compare_with_matched_hinf(loop: MechanicalLoop, w_inner: SobolevLaw, duration: float,
                              q0: ArrayLike, qd0: ArrayLike,
                              indices: Callable[[dict[str, Any]], dict[str, float]], *,
                              match: str = "IADU", omega_u0: float | None = None,
                              target_if_w_failed: float | None = None, iters: int = 6,
                              rtol: float = 0.02, decreasing: bool = True,
                              record_to: str | os.PathLike[str] | None = None
                              ) -> MatchedComparison:
    """Fly the W2/W∞ law, then the classic H∞ law on the same surface with ωu searched so that
    one index equals the W2/W∞ run's (the thesis' comparison rule, e.g. the same IADU).

    The H∞ law is :func:`~sobolev_drake.systems.hinf_baseline.matched_hinf_law` on
    :func:`~sobolev_drake.synthesis.hinf_surface.matched_hinf_surface` of the W law's controlled
    gains; ωu comes from :func:`~sobolev_drake.tuning.match_by_regula_falsi`.

    Parameters
    ----------
    loop : MechanicalLoop
        From :func:`build_loop` (with ``record=True`` for ``record_to``).
    w_inner : SobolevLaw
        The W2/W∞ inner law.
    duration : float
        Simulated time of every run (s).
    q0, qd0 : array_like, shape (n,)
        Initial state of every run, thesis order.
    indices : callable
        ``indices(run) -> dict`` of float.
    match : str, default "IADU"
        The index the H∞ law is tuned to.
    omega_u0 : float, optional
        First ωu of the search; :func:`~sobolev_drake.systems.hinf_baseline.omega_u_guess` by
        default.
    target_if_w_failed : float, optional
        Target of the search when the W2/W∞ run failed (its own index is then not a fair
        target); the failed run's index by default.
    iters, rtol, decreasing
        As for :func:`~sobolev_drake.tuning.match_by_regula_falsi` (``decreasing=False`` when
        the index grows with ωu, e.g. an ISE).
    record_to : str or Path, optional
        Save the W2/W∞ run's recording there (before the H∞ runs replace it).

    Returns
    -------
    MatchedComparison
    """
    if record_to is not None and loop.meshcat is None:
        raise ValueError(f"record_to={str(record_to)!r} needs a loop built with record=True")
    w_run = run_loop(loop, w_inner, duration, q0, qd0, label="W2/W∞")
    recording = None
    if record_to is not None:
        recording = viz.save_recording_html(loop.meshcat, loop.recorder, record_to)
    w_idx = indices(w_run)
    gains = w_inner.controlled
    surface = matched_hinf_surface(gains)
    if omega_u0 is None:
        omega_u0 = omega_u_guess(loop.controller.law, gains, q0, qd0)

    def evaluate(wu):
        r = run_loop(loop, matched_hinf_law(surface, wu), duration, q0, qd0, label="H∞")
        return indices(r)[match], r

    target = (target_if_w_failed if w_run["failed"] and target_if_w_failed is not None
              else w_idx[match])
    wu, h_run, hist = match_by_regula_falsi(evaluate, target, omega_u0, iters=iters, rtol=rtol,
                                            decreasing=decreasing)
    return MatchedComparison(w_run, w_idx, h_run, indices(h_run), wu, hist, target, surface, recording)


def tracked_errors(run: dict[str, Any], law: MechanicalLaw) -> tuple[np.ndarray, np.ndarray]:
    """Tracking errors of a logged run.

    Parameters
    ----------
    run : dict
        From :func:`run_loop`.
    law : MechanicalLaw
        The controller's law (``loop.controller.law``).

    Returns
    -------
    (e, ė) : (ndarray, ndarray)
        Samples × tracked DOF.
    """
    n, m = law.n, law.n_ref
    idx = list(law.partition.tracked)
    q, qd = run["x"][:, :n], run["x"][:, n:]
    return q[:, idx] - run["ref"][:, :m], qd[:, idx] - run["ref"][:, m:2 * m]


def sobolev_bound(run: dict[str, Any], law: MechanicalLaw,
                  truth_model: MechanicalModel) -> dict[str, float | bool]:
    """Theorem 3 on a logged W2/W∞ run of a fully actuated or reduced law.

    ‖z‖²_W (z = ∫q̃c, with ë from the truth's forward dynamics) against γ²‖δ̄‖²_L2 + 2V(x0),
    γ² = max over the run of λmax(M̄⁻¹ Y3 M̄⁻¹) ((5.56)), δ̄ = w_c − Mcu Muu⁻¹ w_u.

    Parameters
    ----------
    run : dict
        From :func:`run_loop` with the W2/W∞ law.
    law : MechanicalLaw
        The controller's law.
    truth_model : MechanicalModel
        The simulated plant's model (for M, C q̇, g, friction, B).

    Returns
    -------
    dict
        "z2", "w2", "gamma", "V0", "rhs", "holds".
    """
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


def left_annihilator(B: ArrayLike) -> np.ndarray:
    """Full-rank left annihilator B⊥ of Assumption 8 (orthonormal rows, B⊥ B = 0).

    Parameters
    ----------
    B : array_like
        Input matrix (n × m).

    Returns
    -------
    ndarray
        (n − rank B) × n.
    """
    B = np.atleast_2d(np.asarray(B, dtype=float))
    return null_space(B.T).T


def bperp_signal(run: dict[str, Any], model: MechanicalModel, law: MechanicalLaw,
                 max_points: int = 1500) -> tuple[np.ndarray, np.ndarray]:
    """(t, ‖B⊥(w − d)‖²) of Fig. 5.7 on at most ``max_points`` logged samples.

    d = g + M[0; q̈cr] + C(q, q̇)[0; q̇cr] ((5.65)), B⊥ of the controller model.

    Parameters
    ----------
    run : dict
        From :func:`run_loop`.
    model : MechanicalModel
        The controller's model.
    law : MechanicalLaw
        The controller's law.
    max_points : int
        Samples evaluated at most (evenly spread).

    Returns
    -------
    (ndarray, ndarray)
    """
    n, m = law.n, law.n_ref
    idx = np.unique(np.linspace(0, len(run["t"]) - 1, min(max_points, len(run["t"]))).astype(int))
    ic = list(law.partition.controlled)
    out = np.empty(len(idx))
    for j, k in enumerate(idx):
        q, qd = run["x"][k, :n], run["x"][k, n:]
        vr, ar = np.zeros(n), np.zeros(n)
        vr[ic] = run["ref"][k, m:2 * m]
        ar[ic] = run["ref"][k, 2 * m:]
        d = model.g(q) + model.M(q) @ ar + model.C_times(q, qd, vr)
        r = left_annihilator(model.B(q)) @ (run["w"][k] - d)
        out[j] = float(r @ r)
    return run["t"][idx], out
