"""What runs in the processes that evaluate a global search's candidates.

Local worker processes (forked by the optimizer) and Dask workers import this module, not
the optimizer: a Dask worker imports the module of every function it runs, and the
optimizer's scipy.optimize alone took 0.45 s of each worker's first task.
"""

from __future__ import annotations

import signal
import threading

import numpy as np
from threadpoolctl import threadpool_limits

from pendfmu.fitting.residuals import PENALTY, Residuals

_WORKER_RESIDUALS: Residuals | None = None


def worker_start(residuals: Residuals) -> None:
    """Initializer of a local worker process: its copy of the residuals, BLAS on one thread
    (OpenBLAS's idle threads spin and take the other workers' cores)."""
    global _WORKER_RESIDUALS
    _WORKER_RESIDUALS = residuals
    threadpool_limits(1, user_api="blas")  # for the life of the worker process
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the main process's to handle


def cost_and_failures(residuals: Residuals, u: np.ndarray) -> tuple[float, int, str]:
    """(cost, simulations that failed, why the last of them failed: "" if none) of one
    candidate. The reason travels back with the cost: in a worker process or on a Dask
    worker, `residuals` is that worker's copy, and the fit's own never hears of it."""
    before = residuals.failures
    cost = residuals.sum_of_squares(u)
    failed = residuals.failures - before
    return cost, failed, residuals.last_failure if failed else ""


def penalized(residuals: Residuals, reason: str) -> tuple[float, int, str]:
    """cost_and_failures of a candidate that never came back (its worker died on every try):
    the cost of a failed simulation, and why."""
    residual = np.full(residuals.size, PENALTY)
    return float(residual @ residual), 1, f"the simulation did not come back: {reason}"


def worker_cost(u: np.ndarray) -> tuple[float, int, str]:
    """cost_and_failures of one candidate, in a local worker process."""
    return cost_and_failures(_WORKER_RESIDUALS, u)


_DASK_LOCK = threading.Lock()


def dask_costs(candidates: list[np.ndarray], residuals: Residuals) -> list[tuple[float, int, str]]:
    """On a Dask worker, a chunk of candidates, for the worker's CandidateEvaluator (which
    keeps `residuals` and so its FMU instances, reset per run, for the whole search) or as a
    task when that actor's worker was lost. The lock keeps a multi-threaded worker from
    stepping the same instances from two threads at once."""
    with _DASK_LOCK, threadpool_limits(1, user_api="blas"):
        return [cost_and_failures(residuals, u) for u in candidates]


class CandidateEvaluator:
    """A Dask actor: one per worker for the length of a global search, holding that worker's
    residuals (and so its FMU instances, reset per run). Why an actor: the client calls it
    directly, without the scheduler; a generation's round trip is then about 3 ms here
    instead of 13-18 ms for a task, which two workers otherwise lost at every generation."""

    def __init__(self, residuals: Residuals):
        from distributed import get_worker

        self.residuals = residuals
        self.paused = pause_profiler(get_worker())  # here, not by Client.run: a frozen worker would hang that

    def costs(self, candidates: list[np.ndarray]) -> list[tuple[float, int, str]]:
        return dask_costs(candidates, self.residuals)

    def resume(self) -> None:
        """The search is over: the worker's profiler runs again."""
        from distributed import get_worker

        resume_profiler(self.paused, get_worker())


PROFILER_CALLBACKS = ("profile", "profile-cycle")


def pause_profiler(dask_worker) -> list[str]:
    """Stop a Dask worker's statistical profiler for the duration of a fit (by its actor). It samples the running task's stack every 10 ms on the worker's event
    loop, which took 10-40 % of a busy worker's core from the simulations (2 workers: 1.50x
    one instead of 1.75x). Returns the callbacks it stopped, for resume_profiler."""
    stopped = []
    for name in PROFILER_CALLBACKS:
        callback = dask_worker.periodic_callbacks.get(name)
        if callback is not None and callback.is_running():
            callback.stop()
            stopped.append(name)
    return stopped


def resume_profiler(names: list[str], dask_worker=None) -> None:
    """Restart what pause_profiler stopped."""
    for name in names:
        if name in dask_worker.periodic_callbacks:
            dask_worker.periodic_callbacks[name].start()
