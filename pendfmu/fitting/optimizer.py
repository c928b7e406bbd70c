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

import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from threadpoolctl import threadpool_limits
from scipy.optimize import differential_evolution, least_squares

from pendfmu.errors import PendfmuError, UsageError
from pendfmu.fitting.residuals import Residuals
from pendfmu.fitting.cluster import ActorGroup
from pendfmu.fitting.pool import WorkerPool, default_workers
from pendfmu.fitting.workers import cost_and_failures, penalized, worker_cost, worker_start

@dataclass
class GlobalOptions:
    """The global search's settings, and where a fit's simulations run.

    The global search is scipy's differential evolution over the free parameters' search
    boxes; its best candidate (and the start values) are then refined by least squares. It
    keeps a fit from settling in the nearest local minimum of a stick-slip cost.

    Attributes
    ----------
    enabled : bool
        Whether the global search runs; without it only the start values are refined.
    popsize : int
        Candidates per free parameter in each generation (differential evolution's
        popsize).
    maxiter : int
        The most generations.
    workers : int
        Worker processes for the candidates and the bootstrap refits (and at most as many
        threads for the local refinement's Jacobian); 0: the environment variable
        PENDFMU_WORKERS if set, else one per core.
    scheduler : str or None
        A Dask scheduler's address: candidates are evaluated on its workers instead; None
        for local processes.
    """

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
    last_failure: str = ""  # why the last failed simulation failed ("" when none did)
    # the cost (half the sum of squares) where the refinement of the global search's best
    # ended; the outcome kept may be the refinement of the starting values, which is the same
    # in every search (None: no global search, the outcome is the start's)
    searched_cost: float | None = None


WORKER_WAIT = 60.0  # seconds a fit waits for a Dask scheduler's first worker


class _Evaluator:
    """Evaluates differential evolution's candidates, in worker processes or here, and
    remembers every cost by the candidate's exact coordinates: the memory a checkpoint
    keeps, so that a resumed fit looks up what it had already simulated. A worker that dies
    or stops answering is survived (pool.py, cluster.py); `lost` says what happened."""

    def __init__(self, residuals: Residuals, workers: int, cache: dict[bytes, float], scheduler: str | None = None):
        self.residuals = residuals
        self.cache = cache
        self.failures = 0
        self.pool = None
        self.client = None
        self.actors = None
        if scheduler:
            self.client = _client(scheduler)
            try:
                self.actors = ActorGroup(self.client, residuals)
            except BaseException:
                self.client.close()
                raise
        elif workers > 1:
            self.pool = WorkerPool(workers, worker_cost, worker_start, (residuals,),
                                   failed=lambda u, reason: penalized(residuals, reason))

    @property
    def lost(self) -> str | None:
        """What the user should know of workers lost during the search (None: none was)."""
        if self.actors is not None and self.actors.incidents:
            return f"{'; '.join(self.actors.incidents)}: its work ran again on the workers left"
        if self.pool is not None and self.pool.deaths:
            return (f"{len(self.pool.deaths)} worker process(es) died during the global search (last: "
                    f"{self.pool.deaths[-1]}): their candidates ran again on fresh workers")
        return None

    def __call__(self, function: Callable, candidates) -> list[float]:
        candidates = [np.asarray(c, dtype=float) for c in candidates]
        keys = [c.tobytes() for c in candidates]
        first = {}  # a candidate drawn twice in one batch is simulated once
        for k, key in enumerate(keys):
            if key not in self.cache:
                first.setdefault(key, k)
        missing = list(first.values())
        # Each cost is remembered as soon as it is known, so an interrupt loses none.
        for k, (cost, failed, reason) in zip(missing, self._costs([candidates[k] for k in missing])):
            self.cache[keys[k]] = cost
            self.failures += failed
            if reason:  # from a worker's copy of the residuals: the fit's own did not see it
                self.residuals.last_failure = reason
        return [self.cache[key] for key in keys]

    def _costs(self, candidates):
        if self.actors is not None:
            return self.actors.costs(candidates)
        if self.pool is not None:
            return self.pool.map(candidates)
        return (cost_and_failures(self.residuals, u) for u in candidates)

    def close(self) -> None:
        if self.pool is not None:
            self.pool.close()
        if self.client is not None:
            try:
                self.actors.close()
            finally:
                self.client.close()


def _client(scheduler: str):
    """A client of the Dask scheduler at `scheduler`, once it has a worker."""
    try:
        from distributed import Client
    except ImportError:
        raise UsageError("a Dask scheduler needs Dask: pip install 'pendfmu[distributed]'") from None
    client = Client(scheduler, set_as_default=False, direct_to_workers=True)
    try:  # a cluster started with the fit may still be bringing its workers up
        client.wait_for_workers(1, timeout=WORKER_WAIT)
    except TimeoutError:
        client.close()
        raise UsageError(f"the Dask scheduler at {scheduler} has no workers (waited {WORKER_WAIT:g} s)") from None
    return client


def global_search(coarse: Residuals, n: int, seed: int, options: GlobalOptions,
                  progress: Callable[[str], None] | None = None,
                  cache: dict[bytes, float] | None = None,
                  notes: list[str] | None = None) -> tuple[np.ndarray, float, int, int]:
    """Differential evolution over the unit box; returns (best u, its cost, nfev, failures).
    `cache` maps candidates to costs already known (from a checkpoint) and collects new ones;
    `notes` receives what the user should know about the search (a lost Dask worker)."""
    workers = options.workers or default_workers()
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
    except RuntimeError as error:  # scipy wraps a ValueError of the evaluation, and so pendfmu's BadInput
        if isinstance(error.__cause__, PendfmuError):
            raise error.__cause__ from None
        raise
    finally:
        evaluator.close()
    if evaluator.lost and notes is not None:
        notes.append(evaluator.lost)
    return result.x, float(result.fun), int(result.nfev), evaluator.failures


LOCAL_BUDGET = 30  # least-squares iterations per (free parameter + 1); each also runs n Jacobian columns
LOCAL_ROUNDS = 4  # a refinement that used up its budget while still descending goes on, from where it stopped
STILL_DESCENDING = 1e-6  # a round that lowered the cost by more than this fraction was still descending


def local_search(residuals: Residuals, u0: np.ndarray, threads: int = 1, rounds: int = LOCAL_ROUNDS
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, str | None]:
    """Trust-region least squares; returns (u, Jacobian, residual, a note if it did not
    converge). `threads` > 1 computes the finite-difference Jacobian's columns on that many
    threads (Residuals.jacobian_map): the same numbers, sooner. A refinement that stops at
    its budget while its cost still falls is not an answer: it goes on from where it stopped,
    for up to `rounds` budgets (a converged one is untouched by this, to the bit). A
    bootstrap refit, which starts at the optimum of nearly the same data, takes one round."""
    budget = LOCAL_BUDGET * (len(u0) + 1)

    def refine(u: np.ndarray):
        return least_squares(residuals, u, bounds=(0.0, 1.0), method="trf", diff_step=1e-7, x_scale=1.0,
                             xtol=1e-10, ftol=1e-10, gtol=1e-10, max_nfev=budget,
                             workers=residuals.jacobian_map(threads))

    with threadpool_limits(1, user_api="blas"):
        result, done = refine(u0), 1
        before = 0.5 * float(np.sum(np.square(residuals(u0)))) if result.status == 0 else 0.0
        while result.status == 0 and done < rounds and result.cost < (1.0 - STILL_DESCENDING) * before:
            before = float(result.cost)
            result, done = refine(result.x), done + 1
    note = None
    if result.status == 0:
        note = (f"the local refinement stopped at its budget of {done} x {budget} iterations before converging: "
                f"the estimates may still move")
    return result.x, result.jac, result.fun, note


BOUND_SNAP = 1e-6  # a unit-box coordinate this close to a bound is put on it (result.at_bound agrees)


def optimize(residuals: Residuals, coarse: Residuals | None, u0: np.ndarray, seed: int,
             options: GlobalOptions, progress: Callable[[str], None] | None = None,
             cache: dict[bytes, float] | None = None) -> Outcome:
    """The global search, then the local refinement from its best candidate and from the
    start the user gave; the lower of the two optima is kept.

    Why both: a global search of a few hundred candidates on a rugged cost can settle in a
    poor basin for one seed and not for another (measured on the real servo carriage: the
    cost 57 times the optimum's for one seed of five, with a confident, wrong F_Sc); the
    start the user gave is the other independent guess, and a second local refinement
    costs little against the global search. The same data then give one answer."""
    start = time.perf_counter()
    nfev = failures = 0
    global_best = None
    messages = []
    starts = [u0]
    if options.enabled and coarse is not None and len(u0):
        u_global, global_best, nfev, failures = global_search(coarse, len(u0), seed, options, progress, cache,
                                                                messages)
        starts = [u_global] + ([u0] if not np.allclose(u_global, u0, rtol=0, atol=BOUND_SNAP) else [])
    if progress:
        progress("local refinement (least squares)")
    searched = None
    if len(u0):
        u, jacobian, residual, costs = _best_local(residuals, starts, messages, jacobian_threads(options))
        u, jacobian, residual = snap_to_bounds(residuals, u, jacobian, residual)
        searched = 0.5 * costs[0] if global_best is not None else None
    else:
        u, residual = u0, residuals(u0)
        jacobian = np.zeros((len(residual), 0))
    # least_squares does not count the evaluations of its finite-difference Jacobian.
    return Outcome(u, jacobian, residual, nfev + residuals.evaluations, failures + residuals.failures,
                   time.perf_counter() - start, global_best, messages, last_failure(residuals, coarse), searched)


def last_failure(residuals: Residuals, coarse: Residuals | None) -> str:
    """Why the fit's last failed simulation failed: the local refinement's (it runs last),
    else the global search's, whose workers sent their reasons back (_Evaluator)."""
    return residuals.last_failure or (coarse.last_failure if coarse is not None else "")


def jacobian_threads(options: GlobalOptions) -> int:
    """Threads for the local refinement's Jacobian: one per core, or --workers (or
    PENDFMU_WORKERS) if fewer (with --workers 1, one); one on a Dask cluster, whose cores are
    elsewhere."""
    cores = os.cpu_count() or 1
    if options.scheduler:
        return 1
    return max(1, min(options.workers or default_workers(), cores))


def _best_local(residuals: Residuals, starts: list[np.ndarray], messages: list[str], threads: int = 1):
    """The local refinement from each start; the lowest optimum, a note when they differ, and
    every start's sum of squares at its end."""
    found = []
    for u0 in starts:
        u, jacobian, residual, note = local_search(residuals, u0, threads)
        found.append((float(residual @ residual), u, jacobian, residual, note))
    best = min(range(len(found)), key=lambda k: found[k][0])
    cost, u, jacobian, residual, note = found[best]
    if note:
        messages.append(note)
    if len(found) > 1:
        other = found[1 - best][0]
        if other <= cost * (1 + 1e-3) or np.allclose(found[1 - best][1], u, atol=1e-3):
            pass  # the same optimum, reached twice
        elif best == 1:
            messages.append(f"the local refinement from the starting values ended lower than from the global "
                            f"search's best (cost {cost:.6g} against {other:.6g}): the cost has several minima; "
                            f"the lower is kept")
        else:
            messages.append(f"the local refinement from the starting values ended in another minimum (cost "
                            f"{other:.6g} against {cost:.6g}): the cost has several minima; the lower is kept")
    return u, jacobian, residual, [f[0] for f in found]


BOUND_ZONE = 1e-4  # ... and one this close, if the bound fits at least as well


def snap_to_bounds(residuals: Residuals, u: np.ndarray, jacobian: np.ndarray, residual: np.ndarray):
    """Put coordinates that end next to a bound on it, with the residual and the Jacobian
    there: those within BOUND_SNAP always, those within BOUND_ZONE if the cost at the
    bound is no higher. A parameter whose optimum is the bound is then reported at the
    same point whatever path the search took: on the real carriage, stiction ended at
    0, 1e-10, 1e-8 or 4e-6 from its bound depending on the seed, and the bootstrap's
    refits from those points gave intervals twice as wide for one of them."""
    cost = float(residual @ residual)
    for zone in (BOUND_ZONE, BOUND_SNAP):
        snapped = np.where(u < zone, 0.0, np.where(u > 1.0 - zone, 1.0, u))
        if np.array_equal(snapped, u):
            continue
        moved = residuals(snapped)
        if zone == BOUND_SNAP or float(moved @ moved) <= cost * (1 + 1e-12):
            return snapped, forward_jacobian(residuals, snapped, moved), moved
    return u, jacobian, residual


def forward_jacobian(residuals: Residuals, u: np.ndarray, residual: np.ndarray, step: float = 1e-7) -> np.ndarray:
    """d residual / d u by forward differences, stepping into the box at a bound."""
    jacobian = np.empty((len(residual), len(u)))
    for k in range(len(u)):
        h = -step if u[k] + step > 1.0 else step
        moved = np.array(u, dtype=float)
        moved[k] += h
        jacobian[:, k] = (residuals(moved) - residual) / h
    return jacobian
