"""Local worker processes that a fit survives: a worker that dies is noticed at once, and
the job it held runs again on a fresh worker.

Why not multiprocessing.Pool: a worker killed while it runs a job (an FMU that segfaults for
some parameter values, the OOM killer, kill -9) is replaced, but its job never returns, and
the fit waited forever. Why not concurrent.futures' ProcessPoolExecutor: it notices the death,
but breaks as a whole, failing every job in flight without telling which one killed its
worker, so an innocent job would be retried, and blamed, with the guilty one.

Here each worker has a pipe of its own and holds one job at a time. The parent waits on the
pipes and on the processes' sentinels together (multiprocessing.connection.wait): a death is
seen the moment it happens, and the job it held is known. That job runs once more on a fresh
worker (a kill -9 or the OOM killer strike once); if that worker dies too, the job is given
up: `failed(job, reason)` gives its result (a penalized cost, a failed refit), the reason
naming the signal, and the other jobs go on.

Signals: the workers ignore Ctrl-C, which a terminal sends to the whole process group and
which is the main process's to handle. SIGTERM and SIGHUP end a worker (the main process's
handler, inherited through fork, is put back to the default): a pool that outlived its owner
is stopped with SIGTERM by multiprocessing at exit, and a worker that ignored it hung the exit.
The pool stops its workers with SIGKILL; a worker whose parent has gone ends at its pipe's end
of file.
"""

from __future__ import annotations

import multiprocessing
import multiprocessing.util
import os
import signal
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from multiprocessing.connection import Connection, wait

from pendfmu.errors import UsageError, WorkersFailed

WORKERS_VARIABLE = "PENDFMU_WORKERS"


def default_workers() -> int:
    """Worker processes when none are asked for (--workers 0): the PENDFMU_WORKERS environment
    variable if set, else one per core. The variable is for a machine whose cores are shared: a
    CI job, a batch of fits run side by side (the test suite runs two at once and sets it to 1,
    so that two fits do not start four processes on two cores)."""
    text = os.environ.get(WORKERS_VARIABLE, "").strip()
    if not text:
        return os.cpu_count() or 1
    try:
        count = int(text)
    except ValueError:
        count = 0
    if count < 1:
        raise UsageError(f"{WORKERS_VARIABLE}={text!r}: must be a whole number of worker processes, 1 or more")
    return count

TRIES = 2  # a job whose worker died is run once more; a second death gives it up
ENDING_SIGNALS = [getattr(signal, name) for name in ("SIGTERM", "SIGHUP") if hasattr(signal, name)]


class WorkerDied(WorkersFailed):
    """A job killed every worker it ran on, and its caller gave no `failed` result for it."""


@dataclass(eq=False)
class _Worker:
    process: multiprocessing.process.BaseProcess
    pipe: Connection
    job: int | None = None  # the index of the job it holds


def _serve(pipe: Connection, function: Callable, start: Callable | None, start_args: tuple) -> None:
    """A worker's life: its start, then jobs from the pipe until None or the pipe's end.
    A start that raises is reported as every job's result, so the parent raises it."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    for number in ENDING_SIGNALS:
        signal.signal(number, signal.SIG_DFL)
    started = None
    try:
        if start is not None:
            start(*start_args)
    except Exception as error:
        started = error
    while True:
        try:
            message = pipe.recv()
        except (EOFError, OSError):
            return
        if message is None:
            return
        index, job = message
        pipe.send((index, _outcome(function, job, started)))


def _outcome(function: Callable, job, started: Exception | None) -> tuple[bool, object]:
    """(True, result) or (False, the exception), the exception made safe to pickle."""
    if started is not None:
        return False, _picklable(started)
    try:
        return True, function(job)
    except Exception as error:
        return False, _picklable(error)


def _picklable(error: Exception) -> Exception:
    import pickle

    try:
        pickle.dumps(error)
        return error
    except Exception:
        return RuntimeError(f"{type(error).__name__}: {error}")


def death_reason(exitcode: int | None) -> str:
    """Why a worker process ended, in words."""
    if exitcode is not None and exitcode < 0:
        name = signal.Signals(-exitcode).name
        killed = " (kill -9 or the out-of-memory killer)" if -exitcode == signal.SIGKILL else ""
        return f"its worker process died of {name}{killed}"
    return f"its worker process ended with exit code {exitcode}"


class WorkerPool:
    """`workers` processes, each running `start(*start_args)` once, then `function` on jobs.

    >>> with WorkerPool(2, abs) as pool:
    ...     list(pool.map([-1, 2, -3]))
    [1, 2, 3]
    """

    def __init__(self, workers: int, function: Callable, start: Callable | None = None, start_args: tuple = (),
                 failed: Callable[[object, str], object] | None = None):
        self._context = multiprocessing.get_context("fork" if os.name == "posix" else "spawn")
        self._target = (function, start, start_args)
        self._failed = failed
        self._workers: list[_Worker] = []
        self.deaths: list[str] = []  # why each worker that died while holding a job died
        # stopped when the pool is collected, or at exit before multiprocessing joins its children
        multiprocessing.util.Finalize(self, _stop_all, args=(self._workers,), exitpriority=10)
        for _ in range(max(1, workers)):
            self._workers.append(self._spawn())

    def _spawn(self) -> _Worker:
        mine, theirs = self._context.Pipe()
        process = self._context.Process(target=_serve, args=(theirs, *self._target), daemon=True)
        process.start()
        theirs.close()
        return _Worker(process, mine)

    def map(self, jobs: Iterable) -> Iterator:
        """`function` of each job, in the jobs' order, each as soon as it and those before it
        are done; a job that raised raises here, one given up is `failed(job, reason)`. A map
        left unfinished (an interrupt, a job's error) closes the pool: its workers hold jobs
        nobody waits for."""
        if not self._workers:
            raise ValueError("the worker pool is closed")
        run = _Run(list(jobs))
        try:
            while run.next < len(run.jobs):
                self._hand_out(run)
                self._collect(run)
                yield from run.ready()
        finally:
            if run.next < len(run.jobs):
                self.close()

    def _hand_out(self, run: _Run) -> None:
        idle = deque(w for w in self._workers if w.job is None)
        while idle and run.waiting:
            worker, index = idle.popleft(), run.waiting.popleft()
            try:
                worker.pipe.send((index, run.jobs[index]))
                worker.job = index
            except OSError:  # it died idle: the job goes to its replacement, no try spent
                run.waiting.appendleft(index)
                idle.extend(self._replace([worker]))

    def _collect(self, run: _Run) -> None:
        """Wait until a worker answers or ends; take its answer, or retry its job."""
        pipes = {w.pipe: w for w in self._workers if w.job is not None}
        sentinels = {w.process.sentinel: w for w in self._workers}
        for ready in wait([*pipes, *sentinels]):
            worker = pipes.get(ready) or sentinels[ready]
            if worker not in self._workers:
                continue  # already replaced in this round
            if worker.job is not None and worker.pipe.poll():
                self._answer(worker, run)
            elif not worker.process.is_alive() or ready in pipes:
                self._died(worker, run)

    def _answer(self, worker: _Worker, run: _Run) -> None:
        try:
            index, (ok, value) = worker.pipe.recv()
        except (EOFError, OSError):
            self._died(worker, run)
            return
        worker.job = None
        if not ok:
            raise value
        run.done[index] = value

    def _died(self, worker: _Worker, run: _Run) -> None:
        worker.process.join()
        reason = death_reason(worker.process.exitcode)
        index = worker.job
        self._replace([worker])
        if index is None:
            return  # an idle worker: nothing was lost
        self.deaths.append(reason)
        run.tries[index] += 1
        if run.tries[index] < TRIES:
            run.waiting.appendleft(index)
            return
        reason = f"{reason}, on each of {TRIES} tries"
        if self._failed is None:
            raise WorkerDied(reason)
        run.done[index] = self._failed(run.jobs[index], reason)

    def _replace(self, workers: list[_Worker]) -> list[_Worker]:
        """Stop these workers and start one fresh worker for each; returns the fresh ones."""
        fresh = []
        for worker in workers:
            self._stop(worker)
            fresh.append(self._spawn())
            self._workers[self._workers.index(worker)] = fresh[-1]
        return fresh

    @staticmethod
    def _stop(worker: _Worker) -> None:
        _stop_all([worker])

    def close(self) -> None:
        _stop_all(self._workers)
        self._workers.clear()

    def __enter__(self) -> WorkerPool:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _stop_all(workers: list[_Worker]) -> None:
    for worker in workers:
        if worker.process.is_alive():
            worker.process.kill()
        worker.process.join()
        worker.pipe.close()


class _Run:
    """One map's jobs: those waiting, the tries of each, the results not yet handed back."""

    def __init__(self, jobs: list):
        self.jobs = jobs
        self.waiting = deque(range(len(jobs)))
        self.tries = [0] * len(jobs)
        self.done: dict[int, object] = {}
        self.next = 0

    def ready(self) -> Iterator:
        """The results due, in order (counted before each is handed back: a caller that stops
        after the last has left nothing unfinished)."""
        while self.next in self.done:
            self.next += 1
            yield self.done.pop(self.next - 1)
