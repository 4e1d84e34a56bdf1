"""A Galerkin (SGAA) law flown on the nonlinear Drake two-wheeled vehicle, and the Table 4.2
indices of a flight (thesis 4.4).

Scenario: x(0) = :data:`X0` (θ = π/4, at rest); the disturbance torques :data:`PULSES`
(wϕ = 1 N m on 7 ≤ t < 14 s, wθ = 1 N m on 22 ≤ t < 32 s); the law runs in a
``GalerkinController`` on [θ ϕ̇ θ̇]; logs every 0.01 s.  See docs/experiments/balance-sgaa.md.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import LogVectorOutput

from sobolev_drake import viz
from sobolev_drake.models.two_wheeled import add_two_wheeled
from sobolev_drake.norms import iadu, ise, settling_time
from sobolev_drake.simulation import simulate
from sobolev_drake.synthesis.galerkin import GalerkinResult
from sobolev_drake.systems.disturbances import TimeProfiledForce
from sobolev_drake.systems.galerkin_controller import GalerkinController

__all__ = ["X0", "PULSES", "SETTLING", "SETTLE_BEFORE", "fly", "flight_indices"]

#: initial design state [θ ϕ̇ θ̇]
X0 = np.array([np.pi / 4, 0.0, 0.0])
PULSES = [{"index": 0, "value": 1.0, "from": 7.0, "to": 14.0},
          {"index": 1, "value": 1.0, "from": 22.0, "to": 32.0}]
#: the 5 % settling criterion of Table 4.2: first sample after the last one with |θ| > 5 % |θ(0)|
SETTLING = {"fraction": 0.05, "crossing": "next_sample"}
SETTLE_BEFORE = 7.0  # the settling time of a flight is read before the first pulse


def fly(law: GalerkinResult, duration: float, record: bool = False,
        out_dir: str | os.PathLike[str] | None = None, label: str = "") -> dict[str, Any]:
    """Fly ``law`` from :data:`X0` through :data:`PULSES` on the nonlinear vehicle.

    Parameters
    ----------
    law : GalerkinResult
        The state-feedback law on [θ ϕ̇ θ̇].
    duration : float
        Horizon (s).
    record : bool
        Record a Meshcat replay, saved as ``balance_<label>.html`` in ``out_dir``.
    out_dir : path-like, optional
        Where the replay goes (needed with ``record``).
    label : str
        Progress label and replay file name.

    Returns
    -------
    dict
        "t", "x" (plant state [ϕ θ ϕ̇ θ̇]), "u", "w" (samples in rows), and "html" with ``record``.
    """
    builder = DiagramBuilder()
    plant = add_two_wheeled(builder)
    ctrl = builder.AddSystem(GalerkinController(law, plant_state_size=4, selection=[1, 2, 3]))
    dist = builder.AddSystem(TimeProfiledForce(2, PULSES))
    builder.Connect(plant.x, ctrl.get_input_port())
    builder.Connect(ctrl.get_output_port(), plant.u)
    builder.Connect(dist.get_output_port(), plant.disturbance)
    period = 0.01
    xlog = LogVectorOutput(plant.x, builder, period)
    ulog = LogVectorOutput(ctrl.get_output_port(), builder, period)
    wlog = LogVectorOutput(dist.get_output_port(), builder, period)
    meshcat = recorder = None
    if record:
        meshcat = viz.start_meshcat()
        recorder = viz.add_meshcat_recorder(builder, plant.scene_graph, meshcat)
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    plant.set_state(context, diagram, [0.0, X0[0]], [X0[1], X0[2]])
    simulate(diagram, context, duration, progress=False, label=label, max_step=0.01)
    out = {}
    for name, lg in (("x", xlog), ("u", ulog), ("w", wlog)):
        log = lg.FindLog(context)
        out["t"], out[name] = log.sample_times(), log.data().T
    if record:
        out["html"] = viz.save_recording_html(meshcat, recorder, Path(out_dir) / f"balance_{label}.html")
    return out


def flight_indices(sim: dict[str, Any]) -> dict[str, float]:
    """The Table 4.2 indices of a flight and what explains them.

    Parameters
    ----------
    sim : dict
        A flight of :func:`fly`.

    Returns
    -------
    dict
        IADU, ISE of θ, ϕ̇, θ̇, the 5 % settling time of θ (before :data:`SETTLE_BEFORE`),
        max |ϕ̇| and the mean ϕ̇ over the last 0.5 s of each pulse.
    """
    t, x, u = sim["t"], sim["x"], sim["u"]
    th, phid, thd = x[:, 1], x[:, 2], x[:, 3]
    early = t < SETTLE_BEFORE
    out = {"IADU": float(np.sum(iadu(t, u))), "ISE θ": float(ise(t, th)),
           "ISE ϕ̇": float(ise(t, phid)), "ISE θ̇": float(ise(t, thd)),
           "settling θ (5 %)": settling_time(t[early], th[early], **SETTLING),
           "max |ϕ̇|": float(np.abs(phid).max())}
    # wheel speed at the end of each disturbance window: under a constant torque the vehicle
    # settles where u ≈ K_θ θ + K_ϕ̇ ϕ̇ balances it, so the ISE of ϕ̇ is mostly set by the
    # ratio of the θ and ϕ̇ gains of the (nonlinear) law
    for p in PULSES:
        sel = (t > p["to"] - 0.5) & (t < p["to"])
        if sel.any():
            out[f"ϕ̇ before t = {p['to']:g} s"] = float(phid[sel].mean())
    return out
