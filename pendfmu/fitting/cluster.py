"""The Dask side of a fit, surviving its workers: a worker lost (killed, its machine gone) or
frozen (a swapping machine, a network partition) while the actors are made, in the search
or in the bootstrap costs the work it held, which runs again on the workers left, and the
fit goes on while one is left.

Lost: a call to an actor whose worker has gone fails at once (CommClosedError, "Worker
holding Actor was lost"); the scheduler reruns a lost worker's tasks by itself, except an
actor's creation, which waits for its own worker and so is taken for frozen (below), then
named lost as its worker has left the cluster.

Frozen: Dask waits for a silent worker for its worker-ttl (5 minutes by default), and a call
to it never returns. Calls made together (a generation's chunks, the actors' creation, the
bootstrap's refits) cost about the same, so one still running STRAGGLER_FACTOR times as long
as the first that came back, and at least STRAGGLER_FLOOR seconds, is taken for frozen: its
worker gets no more work from this fit, and its work runs on the others. A worker that is
only slow loses its share and changes no result: a cost is the same wherever it is computed.

Retries: the candidates of a chunk whose worker was lost or frozen run again, one per call,
on the actors left; one whose call fails again (a simulation that kills its worker, as a
segfaulting FMU does) is penalized with the reason. A task that killed every worker it ran on
ends in the scheduler's KilledWorker; as the scheduler blames the tasks queued behind it on
the same workers too, each job given KilledWorker runs once more alone, and one given it
again ends in `failed(job, reason)`.
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable, Sequence

import numpy as np

from pendfmu.errors import WorkersFailed
from pendfmu.fitting.residuals import Residuals
from pendfmu.fitting.workers import CandidateEvaluator, penalized

STRAGGLER_FACTOR = 10.0
STRAGGLER_FLOOR = 5.0  # seconds: the round trips of small calls vary by far more than 10 times
RETURN_WAIT = 30.0  # seconds a search with no worker left waits for one (a nanny restarts a killed worker in 1-2 s)


class WorkersLost(WorkersFailed):
    """Every worker of the Dask cluster was lost or stopped answering."""


FROZEN = ("frozen", None)
LEFT = ("left", None)  # a call that never came back from a worker the cluster no longer lists


async def _outcome(awaitable) -> tuple[str, object]:
    try:
        return "ok", await awaitable
    except Exception as error:  # the worker's connection, never a simulation (those do not raise)
        return "lost", error


async def _settle(awaitables: list) -> list[tuple[str, object]]:
    """Each call's ("ok", value), ("lost", error) or FROZEN: the straggler rule of the module
    docstring, timed from the first call that succeeds."""
    tasks = [asyncio.ensure_future(_outcome(a)) for a in awaitables]
    started, pending = time.monotonic(), set(tasks)
    while pending:
        done, pending = await asyncio.wait(pending, return_when=asyncio.FIRST_COMPLETED)
        if any(task.result()[0] == "ok" for task in done):
            break
    if pending:
        limit = max(STRAGGLER_FLOOR, STRAGGLER_FACTOR * (time.monotonic() - started))
        _, pending = await asyncio.wait(pending, timeout=limit)
    for task in pending:
        task.cancel()
    return [FROZEN if task in pending else task.result() for task in tasks]


def settle(client, awaitables: Sequence) -> list[tuple[str, object]]:
    """_settle on the client's event loop, where its futures and actor calls complete."""
    return client.sync(_settle, list(awaitables)) if awaitables else []


def _failure(outcome: tuple[str, object]) -> str:
    state, error = outcome
    if state == "left":
        return "was lost (it left the cluster)"
    return "stopped answering" if state == "frozen" else f"was lost ({type(error).__name__})"


class ActorGroup:
    """One CandidateEvaluator actor on each worker that answers: a global search's candidates
    go to them in chunks, and nothing a lost or frozen worker held is lost."""

    def __init__(self, client, residuals: Residuals):
        self.client, self.residuals = client, residuals
        self.actors: dict[str, object] = {}  # worker address -> its actor
        self.futures: dict[str, object] = {}  # what keeps each actor alive on its worker
        self.gone: set[str] = set()  # workers lost or frozen: no more work from this fit
        self.incidents: list[str] = []
        self.add_actors()

    def add_actors(self) -> None:
        """An actor on each worker that has none and has not failed this fit (one that a
        nanny restarted comes back at a new address)."""
        workers = self._fresh_workers()
        with self.client.as_current():  # the actors' proxies bind to this client, not a default one
            futures = [self.client.submit(CandidateEvaluator, self.residuals, actor=True, workers=[w],
                                          allow_other_workers=False, pure=False) for w in workers]
            for worker, future, outcome in zip(workers, futures, settle(self.client, futures)):
                if outcome[0] == "ok":  # made: its proxy, taken here (the event loop's lacks the client)
                    self.actors[worker], self.futures[worker] = future.result(), future
                else:
                    self._drop(worker, outcome, "while its actor was made")
        if not self.actors:
            raise WorkersLost(f"no worker of the Dask cluster answered ({'; '.join(self.incidents[-3:])})")

    def _fresh_workers(self) -> list[str]:
        """The workers without an actor that have not failed this fit; with no actor left,
        the first to (re)join within RETURN_WAIT."""
        deadline = time.monotonic() + RETURN_WAIT
        while True:
            listed = self.client.scheduler_info()["workers"]
            fresh = [w for w in sorted(listed) if w not in self.actors and w not in self.gone]
            if fresh or self.actors or time.monotonic() > deadline:
                return fresh
            try:
                self.client.wait_for_workers(len(listed) + 1, timeout=deadline - time.monotonic())
            except TimeoutError:
                pass

    def _drop(self, worker: str, outcome: tuple[str, object], when: str) -> None:
        if outcome == FROZEN and worker not in self.client.scheduler_info()["workers"]:
            outcome = LEFT  # killed while its actor was made: that task waits for its worker, never failing
        self.actors.pop(worker, None)
        self.futures.pop(worker, None)
        self.gone.add(worker)
        self.incidents.append(f"the Dask worker {worker} {_failure(outcome)} {when}")

    def costs(self, candidates: list[np.ndarray]) -> list[tuple[float, int, str]]:
        """(cost, failures, reason) of each candidate: one chunk per actor (a generation's
        candidates cost about the same), then a failed chunk's candidates one by one."""
        results: list = [None] * len(candidates)
        if self.gone:  # a lost worker that its nanny restarted is back at a new address
            self.add_actors()
        chunks = [list(c) for c in np.array_split(np.arange(len(candidates)), len(self.actors)) if len(c)]
        again = [k for chunk in self._calls(chunks, candidates, results, "in the search") for k in chunk]
        while again:
            if not self.actors:
                self.add_actors()
            wave, again = again[:len(self.actors)], again[len(self.actors):]
            for (k,) in self._calls([[k] for k in wave], candidates, results, "running a candidate again"):
                results[k] = penalized(self.residuals, f"the Dask workers that ran it were lost or stopped answering, "
                                                       f"on each of 2 tries ({self.incidents[-1]})")
        return results

    def _calls(self, chunks: list[list[int]], candidates, results: list, when: str) -> list[list[int]]:
        """Each chunk to its own actor; fills `results`; returns the chunks that failed."""
        workers = list(self.actors)[:len(chunks)]
        calls = [self._call(self.actors[w], [candidates[k] for k in chunk]) for w, chunk in zip(workers, chunks)]
        failed = []
        for worker, chunk, outcome in zip(workers, chunks, settle(self.client, calls)):
            if outcome[0] == "ok":
                for k, value in zip(chunk, outcome[1]):
                    results[k] = value
            else:
                self._drop(worker, outcome, when)
                failed.append(chunk)
        return failed

    @staticmethod
    def _call(actor, chunk):
        return _awaitable(lambda: actor.costs(chunk))

    def close(self) -> None:
        """Restart the profilers the actors paused (on the workers that still answer)."""
        settle(self.client, [_awaitable(actor.resume) for actor in self.actors.values()])


def _awaitable(call: Callable):
    """An actor's pending call, or an awaitable of the error its worker's loss raised at once."""
    try:
        return call()
    except Exception as error:
        lost = error

    async def raise_it():
        raise lost
    return raise_it()


def dask_map(client, function: Callable, jobs: Sequence, done: Callable[[], None],
             failed: Callable[[object, str], object] | None, incidents: list[str] | None = None) -> list:
    """`function` over `jobs` as tasks, in order; `done` as each finishes. A task stuck on a
    frozen worker is copied to the others (module docstring), which `incidents` is told. A
    job given KilledWorker runs once more, alone: the scheduler counts a worker's death
    against every task the worker held, queued ones too, and a job queued behind one that
    kills its workers was given KilledWorker with it. Given it alone too, it gives
    `failed(job, reason)`."""
    results = _tasks(client, function, jobs, done, incidents)
    for k in [k for k, result in enumerate(results) if result is KILLED]:
        (results[k],) = _tasks(client, function, [jobs[k]], done, incidents)
        if results[k] is KILLED:
            results[k] = _given_up(jobs[k], failed)
            done()
    return results


KILLED = object()  # a task's result when the scheduler gave it up: it killed every worker it ran on


def _tasks(client, function: Callable, jobs: Sequence, done: Callable[[], None], incidents: list[str] | None) -> list:
    """dask_map's tasks, KILLED for those given KilledWorker. A result is released from the
    cluster once taken: one kept there is computed again when its worker is lost."""
    index = {future: k for k, future in enumerate(client.map(function, jobs, pure=False))}
    results: dict[int, object] = {}
    pending, copied, gaps, last, waiters = set(index), set(), [], time.monotonic(), {}
    while pending:
        finished = client.sync(_first_done, pending, _task_limit(gaps), waiters)
        if not finished:
            copies = _copies(client, function, jobs, pending - copied, index, copied)
            if copies and incidents is not None:
                incidents.append(f"{len(copies)} task(s) stuck on a Dask worker that stopped answering ran again on "
                                 f"the others")
            pending |= copies
            continue
        gaps.append(time.monotonic() - last)
        last = time.monotonic()
        for future, outcome in finished.items():
            k = index.pop(future)
            if k not in results:
                results[k] = _task_result(outcome)
                if results[k] is not KILLED:
                    done()
        pending = {f for f in pending if f in index and index[f] not in results}
    client.cancel([f for f in index if not f.done()])
    return [results[k] for k in range(len(jobs))]


def _task_limit(gaps: list[float]) -> float | None:
    """How long a map waits for its next task before it takes the tasks left for stuck: the
    straggler rule on the typical time between two tasks' ends (the first, which includes
    the workers' start-up, only while it is the one known); no limit before any has ended."""
    if not gaps:
        return None
    typical = float(np.median(gaps[1:] if len(gaps) > 1 else gaps))
    return max(STRAGGLER_FLOOR, STRAGGLER_FACTOR * typical)


async def _first_done(futures: set, timeout: float | None, waiters: dict) -> dict:
    """The futures that finish first (waiting at most `timeout` s) and their outcomes. A
    future's waiter (in `waiters`) lasts from one call to the next until the future ends, never
    cancelled: the client's gathers of results are one request that waiters join, and a
    waiter cancelled at the limit cancelled it for the others too (asyncio's CancelledError,
    once a lost worker's results were being computed again)."""
    for future in futures - waiters.keys():
        waiters[future] = asyncio.ensure_future(_outcome(future))
    finished, _ = await asyncio.wait([waiters[f] for f in futures], timeout=timeout,
                                     return_when=asyncio.FIRST_COMPLETED)
    return {f: waiters.pop(f).result() for f in [f for f in futures if waiters[f] in finished]}


def _task_result(outcome: tuple[str, object]):
    from distributed import KilledWorker

    state, value = outcome
    if state == "ok":
        return value
    if not isinstance(value, KilledWorker):
        raise value  # the function's own error, as a local worker's
    return KILLED


def _given_up(job, failed):
    reason = "it killed every Dask worker that ran it, with other jobs and alone (KilledWorker)"
    if failed is None:
        raise WorkersLost(reason)
    return failed(job, reason)


def _copies(client, function: Callable, jobs: Sequence, candidates: set, index: dict, copied: set) -> set:
    """Copies, on the other workers, of the tasks among `candidates` held by workers that
    finished nothing within the straggler limit (frozen); the originals stay pending too."""
    keys = {f.key: f for f in candidates}
    processing = client.processing()
    stuck = {w: [keys[key] for key in running if key in keys] for w, running in processing.items()}
    stuck = {w: held for w, held in stuck.items() if held}
    healthy = [w for w in client.scheduler_info()["workers"] if w not in stuck]
    if not healthy:
        return set()
    copies = set()
    for original in (f for held in stuck.values() for f in held):
        copy = client.submit(function, jobs[index[original]], pure=False, workers=healthy, allow_other_workers=False)
        index[copy] = index[original]
        copied.add(original)
        copies.add(copy)
    return copies
