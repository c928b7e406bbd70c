"""The optimizer: a seeded global search, then a local least-squares refinement.

Global: scipy's differential evolution over the unit box, on a decimated copy of the
recordings (every k-th sample: the landscape's shape at a fraction of the cost), its
candidates evaluated in parallel by local worker processes. Each worker builds its own
FMU instances once and reuses them (reset per evaluation). With deferred updating the
result depends on the seed only, not on the number of workers.

Local: scipy's least_squares (trust-region reflective) from the best candidate, on all
samples, with a finite-difference Jacobian. A simulation that fails returns a penalty
residual and is counted; it never stops the fit.
"""

from __future__ import annotations

import multiprocessing
import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import differential_evolution, least_squares

from pendfmu.residuals import Residuals

_WORKER_RESIDUALS: Residuals | None = None


def _worker_start(residuals: Residuals) -> None:
    global _WORKER_RESIDUALS
    _WORKER_RESIDUALS = residuals


def _worker_cost(u: np.ndarray) -> tuple[float, int]:
    before = _WORKER_RESIDUALS.failures
    cost = _WORKER_RESIDUALS.sum_of_squares(u)
    return cost, _WORKER_RESIDUALS.failures - before


@dataclass
class GlobalOptions:
    enabled: bool = True
    popsize: int = 8  # candidates per free parameter
    maxiter: int = 25
    workers: int = 0  # 0: one per core


@dataclass
class Outcome:
    u: np.ndarray
    jacobian: np.ndarray
    residual: np.ndarray
    nfev: int
    failures: int
    seconds: float
    global_best: float | None = None
    messages: list[str] = field(default_factory=list)


class _Pool:
    """Parallel map over worker processes that hold the (decimated) residuals."""

    def __init__(self, residuals: Residuals, workers: int):
        context = multiprocessing.get_context("fork" if os.name == "posix" else "spawn")
        self.pool = context.Pool(workers, initializer=_worker_start, initargs=(residuals,))
        self.failures = 0

    def __call__(self, function: Callable, candidates) -> list[float]:
        results = self.pool.map(_worker_cost, list(candidates))
        self.failures += sum(f for _, f in results)
        return [cost for cost, _ in results]

    def close(self) -> None:
        self.pool.terminate()
        self.pool.join()


def global_search(coarse: Residuals, n: int, seed: int, options: GlobalOptions,
                  progress: Callable[[str], None] | None = None) -> tuple[np.ndarray, float, int, int]:
    """Differential evolution over the unit box; returns (best u, its cost, nfev, failures)."""
    workers = options.workers or os.cpu_count() or 1
    pool = _Pool(coarse, workers) if workers > 1 else None
    generation = [0]

    def report(xk, convergence=None):
        generation[0] += 1
        if progress:
            progress(f"global search: generation {generation[0]}/{options.maxiter}")

    try:
        result = differential_evolution(
            coarse.sum_of_squares, [(0.0, 1.0)] * n, seed=seed, popsize=options.popsize,
            maxiter=options.maxiter, tol=1e-3, init="sobol", polish=False, updating="deferred",
            workers=pool if pool else 1, callback=report)
    finally:
        if pool:
            pool.close()
    failures = (pool.failures if pool else 0) + coarse.failures
    return result.x, float(result.fun), int(result.nfev), failures


LOCAL_BUDGET = 30  # least-squares iterations per (free parameter + 1); each also runs n Jacobian columns


def local_search(residuals: Residuals, u0: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, str | None]:
    """Trust-region least squares; returns (u, Jacobian, residual, a note if it did not converge)."""
    result = least_squares(residuals, u0, bounds=(0.0, 1.0), method="trf", diff_step=1e-7,
                           x_scale=1.0, xtol=1e-10, ftol=1e-10, gtol=1e-10, max_nfev=LOCAL_BUDGET * (len(u0) + 1))
    note = None
    if result.status == 0:
        note = (f"the local refinement stopped at its budget of {LOCAL_BUDGET * (len(u0) + 1)} iterations "
                f"before converging: the estimates may still move")
    return result.x, result.jac, result.fun, note


def optimize(residuals: Residuals, coarse: Residuals | None, u0: np.ndarray, seed: int,
             options: GlobalOptions, progress: Callable[[str], None] | None = None) -> Outcome:
    start = time.perf_counter()
    nfev = failures = 0
    global_best = None
    messages = []
    if options.enabled and coarse is not None and len(u0):
        u_global, global_best, nfev, failures = global_search(coarse, len(u0), seed, options, progress)
        # Keep the start the user gave if the global search found nothing better.
        if coarse.sum_of_squares(u_global) <= coarse.sum_of_squares(u0):
            u0 = u_global
        else:
            messages.append("the global search found nothing better than the starting values")
    if progress:
        progress("local refinement (least squares)")
    if len(u0):
        u, jacobian, residual, note = local_search(residuals, u0)
        if note:
            messages.append(note)
    else:
        u, residual = u0, residuals(u0)
        jacobian = np.zeros((len(residual), 0))
    # least_squares does not count the evaluations of its finite-difference Jacobian.
    return Outcome(u, jacobian, residual, nfev + residuals.evaluations, failures + residuals.failures,
                   time.perf_counter() - start, global_best, messages)
