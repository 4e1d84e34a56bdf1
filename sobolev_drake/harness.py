"""Closed-loop harness pieces the experiments share: a logged diagram run many times, and a
synthesis call that keeps its warnings."""

from __future__ import annotations

import time
import warnings
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import Context, DiagramBuilder, OutputPort
from pydrake.systems.primitives import VectorLogSink

from sobolev_drake import viz

__all__ = ["LoggedLoop", "add_log_sinks", "collect_logs", "quiet"]


def quiet(fn: Callable[..., Any], *args: Any, **kw: Any) -> tuple[Any, list[str]]:
    """Call a synthesis, returning (result, sorted list of its warning texts).

    The thesis designs are offline computations: no time budget unless the caller sets one
    (``time_limit`` defaults to None here).

    Parameters
    ----------
    fn : callable
        A synthesis function.
    *args, **kw
        Its arguments.

    Returns
    -------
    (result, list of str)
    """
    kw.setdefault("time_limit", None)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = fn(*args, **kw)
    return res, sorted({str(w.message) for w in caught})


def add_log_sinks(b: DiagramBuilder, ports: Sequence[tuple[str, OutputPort]],
                  log_period: float) -> dict[str, VectorLogSink]:
    """Add a ``VectorLogSink`` per port to a builder, in the order given.

    Parameters
    ----------
    b : DiagramBuilder
        The builder.
    ports : sequence of (str, OutputPort)
        The ports to log, with their labels.
    log_period : float
        Sampling period of the logs (s).

    Returns
    -------
    dict
        {label: VectorLogSink}.
    """
    sinks = {}
    for label, port in ports:
        s = b.AddSystem(VectorLogSink(port.size(), log_period))
        b.Connect(port, s.get_input_port())
        sinks[label] = s
    return sinks


def collect_logs(sinks: Mapping[str, VectorLogSink], ctx: Context) -> dict[str, np.ndarray]:
    """{label: samples, "t": times} of log sinks after a run, trimmed to a common length.

    Parameters
    ----------
    sinks : dict
        {label: VectorLogSink} (:func:`add_log_sinks`); the one labelled "x" gives the times.
    ctx : Context
        Root context of the diagram after the run.

    Returns
    -------
    dict
        ``{label: ndarray (size, k)}`` of every sink and ``"t"``: ndarray (k,) of sample times
        (s), all trimmed to the shortest length k.
    """
    data = {k: s.FindLog(ctx).data().copy() for k, s in sinks.items()}
    data["t"] = sinks["x"].FindLog(ctx).sample_times().copy()
    n = min(v.shape[-1] for v in data.values())
    return {k: v[..., :n] for k, v in data.items()}


class LoggedLoop:
    """A closed-loop diagram built once and run many times (a tuning search, several designs).

    A subclass adds its plant handles ``self.h`` (with ``scene_graph``) and its systems to a
    builder, then calls :meth:`build` with the ports to log; each run clears the logs
    (:meth:`clear_logs`), simulates, and collects them trimmed to a common length
    (:meth:`collect`).  Reusing one diagram matters: Python LeafSystems are never freed
    (docs/design.md §8.6).
    """

    def build(self, b: DiagramBuilder, ports: Sequence[tuple[str, OutputPort]], log_period: float,
              record: bool) -> None:
        """Log ``ports`` ((label, port) pairs; one labelled "x" gives the time base), add the
        optional Meshcat recorder, build the diagram and its simulator.

        Parameters
        ----------
        b : DiagramBuilder
        ports : sequence of (str, OutputPort)
        log_period : float
            Sampling period of the logs (s).
        record : bool
            Add a Meshcat recorder (``self.meshcat``, ``self.recorder``).
        """
        self.sinks = add_log_sinks(b, ports, log_period)
        self.meshcat = self.recorder = None
        if record:
            self.meshcat = viz.start_meshcat()
            self.recorder = viz.add_meshcat_recorder(b, self.h.scene_graph, self.meshcat)
        self.diagram = b.Build()
        self.sim = Simulator(self.diagram)
        self.context = self.sim.get_mutable_context()

    def clear_logs(self, ctx: Context) -> None:
        """Empty every log in the root context ``ctx`` before a new run.

        Parameters
        ----------
        ctx : Context
            Root context of ``self.diagram`` (e.g. ``self.context``).
        """
        for s in self.sinks.values():
            s.GetMutableLog(s.GetMyMutableContextFromRoot(ctx)).Clear()

    def collect(self, ctx: Context, t0: float) -> dict[str, Any]:
        """{label: samples, "t": times, "wall_s": wall time since t0}, trimmed to equal length.

        Parameters
        ----------
        ctx : Context
            Root context of ``self.diagram`` after the run.
        t0 : float
            ``time.perf_counter()`` value (s) taken when the run started.

        Returns
        -------
        dict
            ``{label: ndarray (size, k)}`` of every logged port, ``"t"``: ndarray (k,) of
            sample times (s, from the log labelled "x"), all trimmed to the shortest length
            k, and ``"wall_s"``: float, wall-clock seconds since ``t0``.
        """
        data = collect_logs(self.sinks, ctx)
        data["wall_s"] = time.perf_counter() - t0
        return data
