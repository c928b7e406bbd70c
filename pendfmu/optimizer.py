"""The optimizer: a seeded global search, then a local least-squares refinement.

Global: scipy's differential evolution over the unit box, on a cheaper copy of the model
(every k-th sample and a longer internal step, where the stage allows), its candidates
evaluated in parallel by local worker processes or by the workers of a Dask cluster. Each
worker builds its own FMU instances once and reuses them (reset per evaluation). With
deferred updating the result depends on the seed only, not on the number or kind of workers.

Every process of a fit keeps BLAS to one thread. Its arrays are tiny, and OpenBLAS's idle
threads spin after each call: with a worker per core they took the workers' cores, and two
local workers ran slower than one (measured: 10.3 s against 8.3 s; 4.4 s once limited).

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
from threadpoolctl import threadpool_limits
from scipy.optimize import differential_evolution, least_squares

from pendfmu.residuals import Residuals
from pendfmu.workers import (CandidateEvaluator, cost_and_failures, dask_costs, pause_profiler, resume_profiler,
                             worker_cost, worker_start)

@dataclass
class GlobalOptions:
    enabled: bool = True
    popsize: int = 8  # candidates per free parameter
    maxiter: int = 25
    workers: int = 0  # 0: one per core
    scheduler: str | None = None  # a Dask scheduler address: evaluate candidates on its workers


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


WORKER_WAIT = 60.0  # seconds a fit waits for a Dask scheduler's first worker


class _Evaluator:
    """Evaluates differential evolution's candidates, in worker processes or here, and
    remembers every cost by the candidate's exact coordinates: the memory a checkpoint
    keeps, so that a resumed fit looks up what it had already simulated."""

    def __init__(self, residuals: Residuals, workers: int, cache: dict[bytes, float], scheduler: str | None = None):
        self.residuals = residuals
        self.cache = cache
        self.failures = 0
        self.pool = None
        self.client = None
        self.lost = None  # why a Dask actor's chunk ran as a task instead
        if scheduler:
            try:
                from distributed import Client
            except ImportError:
                raise RuntimeError("--scheduler needs Dask: pip install 'pendfmu[distributed]'") from None
            self.client = Client(scheduler, set_as_default=False, direct_to_workers=True)
            try:  # a cluster started with the fit may still be bringing its workers up
                self.client.wait_for_workers(1, timeout=WORKER_WAIT)
            except TimeoutError:
                self.client.close()
                raise RuntimeError(f"the Dask scheduler at {scheduler} has no workers "
                                   f"(waited {WORKER_WAIT:g} s)") from None
            self.paused = self.client.run(pause_profiler)  # worker address -> callbacks stopped
            with self.client.as_current():  # the actors' proxies bind to this client, not a default one
                self.actors = [self.client.submit(CandidateEvaluator, residuals, actor=True, workers=[worker],
                                                  allow_other_workers=False, pure=False).result()
                               for worker in sorted(self.client.scheduler_info()["workers"])]
        elif workers > 1:
            context = multiprocessing.get_context("fork" if os.name == "posix" else "spawn")
            self.pool = context.Pool(workers, initializer=worker_start, initargs=(residuals,))

    def __call__(self, function: Callable, candidates) -> list[float]:
        candidates = [np.asarray(c, dtype=float) for c in candidates]
        keys = [c.tobytes() for c in candidates]
        missing = [k for k, key in enumerate(keys) if key not in self.cache]
        # Each cost is remembered as soon as it is known, so an interrupt loses none.
        for k, (cost, failed) in zip(missing, self._costs([candidates[k] for k in missing])):
            self.cache[keys[k]] = cost
            self.failures += failed
        return [self.cache[key] for key in keys]

    def _costs(self, candidates):
        if self.client is not None:
            # One chunk per worker's actor: a generation's candidates cost about the same,
            # and every call costs a round trip the workers could use.
            chunks = [[candidates[k] for k in c] for c in np.array_split(np.arange(len(candidates)), len(self.actors))
                      if len(c)]
            calls = [(chunk, self._actor_call(actor, chunk)) for chunk, actor in zip(chunks, self.actors)]
            for chunk, call in calls:
                yield from self._actor_result(chunk, call)
            return
        if self.pool is not None:
            yield from self.pool.imap(worker_cost, candidates)
            return
        for u in candidates:
            yield cost_and_failures(self.residuals, u)

    @staticmethod
    def _actor_call(actor, chunk):
        """The actor's pending call, or the error its worker's loss raised at once."""
        try:
            return actor.costs(chunk)
        except Exception as lost:
            return lost

    def _actor_result(self, chunk, call) -> list[tuple[float, int]]:
        """An actor's costs; if its worker has gone (an actor does not move), the chunk runs
        as an ordinary task on any worker the cluster still has, and nothing is lost."""
        try:
            if isinstance(call, Exception):
                raise call
            return call.result()
        except Exception as lost:  # the worker's connection, not the simulations (they do not raise)
            if self.lost is None:
                self.lost = f"a Dask worker was lost ({type(lost).__name__}); its candidates ran as tasks"
            return self.client.submit(dask_costs, chunk, self.residuals, pure=False).result()

    def close(self) -> None:
        if self.pool is not None:
            self.pool.terminate()
            self.pool.join()
        if self.client is not None:
            alive = set(self.client.scheduler_info()["workers"])  # a lost worker has nothing to restore
            for worker, names in self.paused.items():
                if names and worker in alive:
                    self.client.run(resume_profiler, names, workers=[worker], on_error="ignore")
            self.client.close()


def global_search(coarse: Residuals, n: int, seed: int, options: GlobalOptions,
                  progress: Callable[[str], None] | None = None,
                  cache: dict[bytes, float] | None = None,
                  notes: list[str] | None = None) -> tuple[np.ndarray, float, int, int]:
    """Differential evolution over the unit box; returns (best u, its cost, nfev, failures).
    `cache` maps candidates to costs already known (from a checkpoint) and collects new ones;
    `notes` receives what the user should know about the search (a lost Dask worker)."""
    workers = options.workers or os.cpu_count() or 1
    evaluator = _Evaluator(coarse, workers, {} if cache is None else cache, options.scheduler)
    generation = [0]

    def report(intermediate_result):
        generation[0] += 1
        if progress:
            progress(f"global search: generation {generation[0]}/{options.maxiter}")

    try:
        with threadpool_limits(1, user_api="blas"):
            result = differential_evolution(
                coarse.sum_of_squares, [(0.0, 1.0)] * n, rng=np.random.default_rng(seed), popsize=options.popsize,
                maxiter=options.maxiter, tol=1e-3, init="sobol", polish=False, updating="deferred",
                workers=evaluator, callback=report)
    finally:
        evaluator.close()
    if evaluator.lost and notes is not None:
        notes.append(evaluator.lost)
    return result.x, float(result.fun), int(result.nfev), evaluator.failures


LOCAL_BUDGET = 30  # least-squares iterations per (free parameter + 1); each also runs n Jacobian columns


def local_search(residuals: Residuals, u0: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, str | None]:
    """Trust-region least squares; returns (u, Jacobian, residual, a note if it did not converge)."""
    with threadpool_limits(1, user_api="blas"):
        result = least_squares(residuals, u0, bounds=(0.0, 1.0), method="trf", diff_step=1e-7, x_scale=1.0,
                               xtol=1e-10, ftol=1e-10, gtol=1e-10, max_nfev=LOCAL_BUDGET * (len(u0) + 1))
    note = None
    if result.status == 0:
        note = (f"the local refinement stopped at its budget of {LOCAL_BUDGET * (len(u0) + 1)} iterations "
                f"before converging: the estimates may still move")
    return result.x, result.jac, result.fun, note


def optimize(residuals: Residuals, coarse: Residuals | None, u0: np.ndarray, seed: int,
             options: GlobalOptions, progress: Callable[[str], None] | None = None,
             cache: dict[bytes, float] | None = None) -> Outcome:
    start = time.perf_counter()
    nfev = failures = 0
    global_best = None
    messages = []
    if options.enabled and coarse is not None and len(u0):
        u_global, global_best, nfev, failures = global_search(coarse, len(u0), seed, options, progress, cache,
                                                                messages)
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
