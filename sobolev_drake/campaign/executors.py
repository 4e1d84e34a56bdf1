"""Where a campaign's tasks run: in this process, in a pool of worker processes, or on a Dask
cluster.  Each executor calls ``fn(*args)`` for every tuple of ``calls`` and yields the results
as they finish; none is a scheduler of our own.

* :func:`inline` — in this process (debugging, tests);
* :func:`processes` — a ``concurrent.futures.ProcessPoolExecutor`` (spawn) of ``workers``
  processes, renewed every ``workers × tasks_per_worker`` calls because Python LeafSystems are
  never freed (docs/design.md §8.6); the workers die with the campaign process;
* :func:`dask` — a ``distributed.LocalCluster`` (``scheduler="dask-local"``) or the Dask
  scheduler at an address, with bounded waits for a scheduler and for workers.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import sys
import threading
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor, as_completed
from typing import Any

from sobolev_drake.campaign.errors import ClusterLostError, ClusterUnavailableError, first_line

__all__ = ["inline", "processes", "dask", "pick", "worker_count", "DASK_CONNECT_TIMEOUT",
           "DASK_WORKERLESS_TIMEOUT"]

#: seconds to wait for a Dask scheduler to answer, and for a cluster to have a worker
DASK_CONNECT_TIMEOUT = 20.0
#: seconds a Dask cluster may go without any worker mid-run before the campaign stops
DASK_WORKERLESS_TIMEOUT = 60.0


def pick(workers: int, scheduler: str | None) -> Callable[..., Any]:
    """The executor for ``workers`` (0: this process) and ``scheduler`` (None: processes).

    Parameters
    ----------
    workers : int
    scheduler : str or None

    Returns
    -------
    callable
        ``executor(fn, calls, workers, scheduler, tasks_per_worker)`` yielding results.
    """
    return inline if workers == 0 else (processes if scheduler is None else dask)


_ARGUMENTS = """
    Parameters
    ----------
    fn : callable
        Picklable (top-level) function, except for :func:`inline`.
    calls : list of tuple
        Arguments of each call.
    workers : int
        Processes (ignored by :func:`inline`; a remote Dask cluster has its own).
    scheduler : str or None
        "dask-local" or a Dask scheduler address (:func:`dask` only).
    tasks_per_worker : int
        Calls per worker process before the pool is renewed (:func:`processes` only).

    Yields
    ------
    object
        ``fn(*args)`` of each call, in the order they finish.
"""



def inline(fn: Callable[..., Any], calls: list[tuple], workers: int, scheduler: str | None,
           tasks_per_worker: int) -> Any:
    for args in calls:
        yield fn(*args)


def _die_with_parent(parent_pid):
    """Pool-worker initializer: end this worker when the campaign process dies, however it
    dies (SIGKILL, the OOM killer), instead of sleeping forever as an orphan.  Linux: the
    kernel's parent-death signal; elsewhere (and as a backstop) a thread watching the parent."""
    if sys.platform.startswith("linux"):
        try:
            import ctypes

            pr_set_pdeathsig = 1
            ctypes.CDLL(None, use_errno=True).prctl(pr_set_pdeathsig, int(signal.SIGKILL), 0, 0, 0)
        except (OSError, AttributeError):
            pass
    if os.getppid() != parent_pid:            # the parent died before the signal was armed
        os._exit(1)

    def watch():
        while os.getppid() == parent_pid:
            time.sleep(1.0)
        os._exit(1)

    threading.Thread(target=watch, name="die-with-parent", daemon=True).start()


def processes(fn: Callable[..., Any], calls: list[tuple], workers: int, scheduler: str | None,
              tasks_per_worker: int) -> Any:
    # A fresh pool every `workers × tasks_per_worker` calls bounds what a worker accumulates
    # (Python LeafSystems are never freed).  ProcessPoolExecutor's own max_tasks_per_child is
    # not used: on Python 3.11 the pool stops scheduling once a worker retires (seen here, a
    # campaign hung after exactly tasks_per_worker cases).
    ctx = multiprocessing.get_context("spawn")
    per_round = workers * tasks_per_worker
    for start in range(0, len(calls), per_round):
        chunk = calls[start:start + per_round]
        with ProcessPoolExecutor(max_workers=min(workers, len(chunk)), mp_context=ctx,
                                 initializer=_die_with_parent, initargs=(os.getpid(),)) as pool:
            futures = [pool.submit(fn, *args) for args in chunk]
            for f in as_completed(futures):
                yield f.result()


def dask(fn: Callable[..., Any], calls: list[tuple], workers: int, scheduler: str | None,
         tasks_per_worker: int) -> Any:
    try:
        from distributed import Client, LocalCluster, wait
    except ImportError:
        raise ImportError("a Dask scheduler needs Dask: pip install 'sobolev_drake[campaign]'") from None

    cluster = None
    if scheduler == "dask-local":
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                               dashboard_address=None)
        client = Client(cluster)
    else:
        try:
            client = Client(scheduler, timeout=DASK_CONNECT_TIMEOUT)
        except (OSError, TimeoutError, ValueError) as exc:
            raise ClusterUnavailableError(
                f"scheduler: cannot reach a Dask scheduler at {scheduler!r} within "
                f"{DASK_CONNECT_TIMEOUT:g} s ({type(exc).__name__}: {first_line(exc)}); start one "
                "(`dask scheduler`, then `dask worker ADDRESS`), or use --scheduler dask-local") from None
    try:
        try:
            client.wait_for_workers(1, timeout=DASK_CONNECT_TIMEOUT)
        except TimeoutError:
            raise ClusterUnavailableError(
                f"scheduler: the Dask scheduler at {scheduler!r} has no worker after "
                f"{DASK_CONNECT_TIMEOUT:g} s; start workers (`dask worker ADDRESS`)") from None
        pending = {client.submit(fn, *args, pure=False) for args in calls}
        workerless_since = None
        while pending:
            try:
                done, pending = wait(pending, timeout=2.0, return_when="FIRST_COMPLETED")
            except TimeoutError:
                done = set()
            for f in done:
                yield f.result()
            if done:
                workerless_since = None
                continue
            try:
                alive = len(client.scheduler_info().get("workers", {}))
            except (OSError, TimeoutError) as exc:
                raise ClusterLostError(f"the Dask scheduler at {scheduler!r} stopped answering "
                                       f"({type(exc).__name__})") from None
            if alive:
                workerless_since = None
            elif workerless_since is None:
                workerless_since = time.monotonic()
            elif time.monotonic() - workerless_since > DASK_WORKERLESS_TIMEOUT:
                raise ClusterLostError(
                    f"the Dask cluster at {scheduler!r} has had no worker for "
                    f"{DASK_WORKERLESS_TIMEOUT:g} s with {len(pending)} case(s) pending")
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def worker_count(workers: int, scheduler: str | None, pending: int) -> int:
    """Processes to start: at most one per CPU and one per pending task (said on stderr when
    the CPU count caps ``workers``).

    Parameters
    ----------
    workers : int
        Asked for (0: this process).
    scheduler : str or None
        A remote scheduler's workers are its own: ``workers`` is returned as is.
    pending : int
        Tasks to run.

    Returns
    -------
    int
    """
    if workers == 0:
        return 1
    if scheduler is not None and scheduler != "dask-local":
        return workers                     # a remote cluster has the workers it has
    cpus = os.cpu_count() or 1
    n = max(1, min(workers, cpus, pending))
    if n < workers and workers > cpus:
        print(f"sobolev-drake: --workers {workers} capped at {n} (this machine has {cpus} CPUs; "
              "cases are CPU-bound)", file=sys.stderr)
    return n


inline.__doc__ = "Every call in this process, in order.\n" + _ARGUMENTS
processes.__doc__ = ("The calls on a pool of spawned worker processes that die with this one.\n"
                     + _ARGUMENTS)
dask.__doc__ = ("""The calls on a Dask cluster: a ``LocalCluster`` of ``workers`` processes, or the
    scheduler at address ``scheduler``.
""" + _ARGUMENTS + """
    Raises
    ------
    ClusterUnavailableError
        No answer within :data:`DASK_CONNECT_TIMEOUT` s, or no worker by then.
    ClusterLostError
        No worker for :data:`DASK_WORKERLESS_TIMEOUT` s mid-run, or the scheduler stopped
        answering.
""")
