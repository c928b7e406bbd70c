"""Every check that calls into an FMU's binary runs here: in a child process, with limits.

An FMU is code from elsewhere. A segfault, an abort, an endless loop or a runaway allocation
in its fmi2DoStep would take `pendfmu check` (or a whole pytest session) down with it, and a
model description may ask for more work than any run can do. So the checks run as jobs
(`Job`: a row label and a function returning rows) in a child process forked from this one:
the child inherits the unpacked FMU, the target and the jobs themselves, so nothing goes to
it but a job's index and nothing comes back but that job's rows (pickled CheckResults).

One child runs job after job while it lives (the stimulus the first job found is there for
the next): the cost is a few forks per battery, not one per call. Jobs share a child only
when they say so (`Job.process`): a misuse (sequence.py) can leave an FMU broken beyond its
instance (a pythonfmu binary's embedded interpreter corrupted, to crash a later check), so
the misuses of each interface have a child of their own. Each job gets at most
`time_limit` seconds (`pendfmu check --time-limit`, default TIME_LIMIT), and the child may
allocate at most MEMORY_LIMIT bytes beyond what it inherited (RLIMIT_AS; a runaway
allocation becomes a MemoryError in the child, or a crash of the FMU). A child that dies (a
signal, an exit) or outlives the limit makes its job one FAIL row naming the signal or the
limit; a fresh child goes on with the next job. Ctrl-C in the parent ends the child too, and
on Linux so does the parent's death by any signal (no hung FMU spins on as an orphan).

Where fork is not available (Windows), the jobs run in this process, uncontained.
"""

from __future__ import annotations

import ctypes
import faulthandler
import multiprocessing
import os
import signal
import warnings
from collections.abc import Callable, Iterator, Sequence
from typing import NamedTuple

from pendfmu.check.driver import BUDGET
from pendfmu.check.fmu import FAIL, CheckResult

TIME_LIMIT = 120.0
"""Seconds one check group may take: the longest seen (the rollback check of the Reference
FMUs' Roberts and of pendfmu's Pendulum in Model Exchange, default options) took 27 s on a
2-core machine under a load of 10."""
MEMORY_LIMIT = 2 << 30
"""Bytes a child may allocate beyond what it inherited from the parent."""
PR_SET_PDEATHSIG = 1  # prctl(2): the signal a process gets when its parent dies
KILL_WAIT = 5.0
"""Seconds a child is given to be reaped after it was killed or its pipe closed."""



class Job(NamedTuple):
    """One unit of checking: `label` names the row a crash or a hang becomes, `work` returns
    the check's rows; consecutive jobs of the same `process` share a child, another starts
    a fresh one."""
    label: str
    work: Callable[[], list[CheckResult]]
    process: str = "checks"


def run_contained(jobs: Sequence[Job], time_limit: float = TIME_LIMIT) -> Iterator[list[CheckResult]]:
    """The rows of each job in turn, each job run in a child process (the module's docstring):
    a crash or a hang of the job is its one FAIL row."""
    if "fork" not in multiprocessing.get_all_start_methods():
        for job in jobs:
            yield _rows_of(job.label, job.work)
        return
    child = None
    try:
        for index, job in enumerate(jobs):
            if child is not None and child.process_name != job.process:
                child.close()
                child = None
            child = child or _Child(jobs, job.process)
            rows = child.run(index, time_limit)
            if rows is None:  # it died or hung: the job's row says how, and the next job gets a new child
                rows = [child.failure(job.label, time_limit)]
                child.kill()
                child = None
            yield rows
        if child is not None:
            child.close()
            child = None
    finally:
        if child is not None:  # interrupted (Ctrl-C) or abandoned: no waiting for it
            child.kill()


def run_all(jobs: Sequence[Job], time_limit: float = TIME_LIMIT) -> list[CheckResult]:
    """Every job's rows, in order (run_contained)."""
    return [row for rows in run_contained(jobs, time_limit) for row in rows]


def _rows_of(label: str, work: Callable[[], list[CheckResult]]) -> list[CheckResult]:
    """The job's rows (its own budget of steps, driver.BUDGET); a check that raises is a
    failed row with its reason, not a crash."""
    BUDGET.start()
    try:
        return work()
    except MemoryError:
        return [CheckResult(label, FAIL, "memory limit", f"{label} needed more than the {MEMORY_LIMIT / 2**30:g} GiB "
                                                         f"a check may allocate (the FMU or its planned work)")]
    except Exception as error:
        return [CheckResult(label, FAIL, "check failed", f"{type(error).__name__}: {error}")]
    finally:
        BUDGET.stop()


class _Child:
    """A forked process that runs the jobs it was forked with, one index at a time (those of
    `process_name`)."""

    def __init__(self, jobs: Sequence[Job], process_name: str):
        self.process_name = process_name
        context = multiprocessing.get_context("fork")
        self.connection, theirs = context.Pipe()
        self.process = context.Process(target=_serve, args=(jobs, theirs, self.connection, os.getpid()),
                                       daemon=True, name="pendfmu-check")
        with warnings.catch_warnings():
            # Python 3.12 warns of fork beside threads: the child runs only its jobs, and one
            # that waits on a lock a lost thread held ends at the time limit
            warnings.simplefilter("ignore", DeprecationWarning)
            self.process.start()
        theirs.close()
        self.timed_out = False

    def run(self, index: int, time_limit: float) -> list[CheckResult] | None:
        """The rows of job `index`, or None when the child died or did not answer in time."""
        try:
            self.connection.send(index)
            if self.connection.poll(time_limit):
                return self.connection.recv()
            self.timed_out = True
        except (EOFError, OSError):  # the child is gone (its pipe closed with it)
            pass
        return None

    def failure(self, label: str, time_limit: float) -> CheckResult:
        """The FAIL row of a job whose child died or hung."""
        if self.timed_out:
            return CheckResult(label, FAIL, f"no answer in {time_limit:g} s",
                               f"{label} did not finish within the time limit of {time_limit:g} s (--time-limit): "
                               f"the FMU hung in a call or works too long; its process was killed, the other checks "
                               f"went on in a new one")
        self.process.join(KILL_WAIT)
        code = self.process.exitcode
        how = _signal_name(-code) if code is not None and code < 0 else f"exit code {code}"
        return CheckResult(label, FAIL, f"crashed ({how})",
                           f"the FMU crashed the check's process with {how} during {label}; the other checks went "
                           f"on in a new one")

    def close(self) -> None:
        """End a child that answered: it leaves at the closed pipe."""
        self.connection.close()
        self.process.join(KILL_WAIT)
        self.kill()

    def kill(self) -> None:
        self.connection.close()
        if self.process.is_alive():
            self.process.kill()
        self.process.join(KILL_WAIT)


def _signal_name(number: int) -> str:
    try:
        return signal.Signals(number).name
    except ValueError:
        return f"signal {number}"


def _serve(jobs: Sequence[Job], connection, parents, parent: int) -> None:
    """The child: bound to its parent's life, limit its memory, then run each job whose index
    arrives until the pipe closes (`parents`, the parent's end it inherited, closed first:
    else the pipe never closes)."""
    _die_with(parent)
    parents.close()
    faulthandler.disable()  # a crash is the job's row; a Python traceback would read as the checker's own
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's to handle: it ends this child
    _limit_memory()
    while True:
        try:
            index = connection.recv()
        except (EOFError, OSError):
            return
        connection.send(_rows_of(jobs[index].label, jobs[index].work))


def _die_with(parent: int) -> None:
    """Linux: SIGKILL this child when its parent dies (kill -9, a SIGTERM not handled), so that
    no FMU hung in a call spins on as an orphan."""
    try:
        ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGKILL)
    except (OSError, AttributeError):  # not Linux: daemon children still end with a parent that exits
        return
    if os.getppid() != parent:  # the parent died before prctl took effect
        os._exit(1)


def _limit_memory() -> None:
    """RLIMIT_AS: what this process has mapped (inherited) plus MEMORY_LIMIT."""
    import resource  # POSIX only, as fork is

    try:
        with open("/proc/self/statm") as handle:
            mapped = int(handle.read().split()[0]) * resource.getpagesize()
    except (OSError, ValueError, IndexError):
        return  # not Linux: the time limit still holds
    soft, hard = resource.getrlimit(resource.RLIMIT_AS)
    wanted = mapped + MEMORY_LIMIT
    if hard != resource.RLIM_INFINITY:
        wanted = min(wanted, hard)
    if soft == resource.RLIM_INFINITY or wanted < soft:
        resource.setrlimit(resource.RLIMIT_AS, (wanted, hard))
