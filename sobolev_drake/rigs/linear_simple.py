"""Runs of the simple system (6.41) under a Table 6.1 controller (thesis 6.5.1).

Scenario: x(0) = :data:`~sobolev_drake.models.simple_linear.X0`, d(0) = 0, x_K(0) = 0 unless
given; the filter is driven by white Gaussian noise v (unit-variance samples held for the
step, seeded) switched on for :data:`NOISE_WINDOW`.  Two rigs fly it: the exact zero-order-hold
discretization of the linear closed loop (:func:`simulate_exact`, used by the tables) and a
Drake diagram of the same loop (:func:`simulate`, cross-checked in the tests on a short
horizon).  See docs/experiments/linear-simple.md.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike
import scipy.linalg as sla
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import LinearSystem, MatrixGain, Multiplexer, TrajectorySource
from pydrake.trajectories import PiecewisePolynomial

from sobolev_drake.harness import add_log_sinks
from sobolev_drake.models.simple_linear import SIMPLE, X0
from sobolev_drake.synthesis.closed_loop_bounds import (LoopDesign, closed_loop_matrices,
                                                       initial_state)
from sobolev_drake.synthesis.problem import DynamicController
from sobolev_drake.systems.linear_controllers import LinearDynamicOutputFeedback, LinearStateFeedback

__all__ = ["NOISE_WINDOW", "simulate", "simulate_exact"]

#: the noise v is on for t in this closed interval (s)
NOISE_WINDOW = (1.0, 9.0)


def _noise(t, seed):
    rng = np.random.default_rng(seed)
    return np.where((t >= NOISE_WINDOW[0]) & (t <= NOISE_WINDOW[1]), rng.standard_normal(t.size), 0.0)


def simulate(design: LoopDesign, data: np.ndarray | DynamicController | tuple[np.ndarray, ...],
             duration: float, seed: int = 0, dt_noise: float = 1e-3) -> dict[str, np.ndarray]:
    """The closed loop as a Drake diagram (``LinearSystem`` plant and filter, controller
    LeafSystem), integrated with steps of at most ``dt_noise``; x_K(0) = 0.

    Parameters
    ----------
    design : LoopDesign
        Which feedback (static, or dynamic on y = x or y = C x).
    data : ndarray or tuple
        The gain K or the controller (AK, BK, CK, DK).
    duration : float
        Horizon (s).
    seed : int
        Seed of the noise v.
    dt_noise : float
        Hold time of the noise samples, maximum step and log period (s).

    Returns
    -------
    dict
        "t", "x", "u", "w" (samples in rows).
    """
    p = SIMPLE
    b = DiagramBuilder()
    plant = b.AddSystem(LinearSystem(p.A, np.hstack([p.B, p.D]), np.eye(2), np.zeros((2, 2))))
    dist = b.AddSystem(LinearSystem(p.AD, p.BD, p.CD, np.zeros((1, 1))))
    tk = np.arange(0.0, duration + dt_noise, dt_noise)
    v = _noise(tk, seed)
    src = b.AddSystem(TrajectorySource(PiecewisePolynomial.ZeroOrderHold(tk, v[None, :])))
    b.Connect(src.get_output_port(), dist.get_input_port())
    mux = b.AddSystem(Multiplexer([1, 1]))
    b.Connect(mux.get_output_port(), plant.get_input_port())
    b.Connect(dist.get_output_port(), mux.get_input_port(1))
    if design.feedback == "state_feedback":
        ctrl = b.AddSystem(LinearStateFeedback(data))
        b.Connect(plant.get_output_port(), ctrl.GetInputPort("x"))
    else:
        ctrl = b.AddSystem(LinearDynamicOutputFeedback.from_controller(data))
        if design.measured == "state":
            b.Connect(plant.get_output_port(), ctrl.GetInputPort("y"))
        else:
            meas = b.AddSystem(MatrixGain(p.C))
            b.Connect(plant.get_output_port(), meas.get_input_port())
            b.Connect(meas.get_output_port(), ctrl.GetInputPort("y"))
    b.Connect(ctrl.GetOutputPort("u"), mux.get_input_port(0))
    logs = add_log_sinks(b, [("x", plant.get_output_port()), ("u", ctrl.GetOutputPort("u")),
                             ("w", dist.get_output_port())], 1e-3)
    diagram = b.Build()
    ctx = diagram.CreateDefaultContext()
    diagram.GetMutableSubsystemContext(plant, ctx).SetContinuousState(X0)
    sim = Simulator(diagram, ctx)
    sim.get_mutable_integrator().set_maximum_step_size(dt_noise)
    sim.AdvanceTo(duration)
    res = {}
    for name, lg in logs.items():
        log = lg.FindLog(ctx)
        res["t"] = log.sample_times()
        res[name] = log.data().T
    return res


def simulate_exact(design: LoopDesign,
                   data: np.ndarray | DynamicController | tuple[np.ndarray, ...], duration: float,
                   seed: int = 0, dt: float = 1e-3, *, x0: ArrayLike = X0,
                   xk0: ArrayLike | None = None, noise: bool = True) -> dict[str, np.ndarray]:
    """Exact zero-order-hold discretization of the linear closed loop (v is held over dt).

    The regularized output-feedback controllers have fast modes (|eig| ~ 1e5) that make an
    explicit error-controlled integrator crawl; for this linear example the exact
    discretization is both faster and more accurate than the Drake diagram of
    :func:`simulate`.

    Parameters
    ----------
    design : LoopDesign
        Which feedback (static, or dynamic on y = x or y = C x).
    data : ndarray or tuple
        The gain K or the controller (AK, BK, CK, DK).
    duration : float
        Horizon (s).
    seed : int
        Seed of the noise v.
    dt : float
        Step and hold time of the noise samples (s).
    x0 : array_like
        Plant initial state.
    xk0 : array_like, optional
        Controller initial state (default 0).
    noise : bool
        False sets v = 0 (initial-condition response only).

    Returns
    -------
    dict
        "t", "x", "u", "w" (samples in rows).
    """
    Acl, Bcl, Cx, Cu, Cw = closed_loop_matrices(SIMPLE, design, data)
    N = Acl.shape[0]
    E = sla.expm(np.block([[Acl, Bcl], [np.zeros((1, N + 1))]]) * dt)
    Ad_, Bd_ = E[:N, :N], E[:N, N:]
    t = np.arange(0.0, duration + dt / 2, dt)
    v = _noise(t, seed)
    if not noise:
        v[:] = 0.0
    X = np.zeros((t.size, N))
    X[0] = initial_state(SIMPLE, design, data, x0, xk0)
    for k in range(t.size - 1):
        X[k + 1] = Ad_ @ X[k] + Bd_[:, 0] * v[k]
    return {"t": t, "x": X @ Cx.T, "u": X @ Cu.T, "w": X @ Cw.T}
