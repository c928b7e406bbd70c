"""Issue 28: a fit survives its workers and its signals, and its checkpoint destroys nothing.

Each case runs a real `pendfmu fit` (a process, where a signal or a kill is part of the case)
of the short cart recording, and compares its result with the same fit undisturbed: a worker
killed with kill -9 in the middle of the search; a hook that segfaults the worker for some
candidates (penalized with the reason); SIGTERM, then `--resume`; kill -9 after a periodic
checkpoint, then `--resume`; a Dask cluster with one worker frozen by SIGSTOP, from the start
and in the middle of a search, one killed while the actors are made, candidates and
bootstrap jobs that kill their Dask workers. The undisturbed fit runs on one process here,
which gives the same result as two workers or a Dask cluster (test_distributed.py).
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest

from processes import WAIT, busy_workers
from conftest import result_without_time
from pendfmu.cli import main

SEARCH = ["--seed", "8", "--generations", "12", "--replicates", "8"]


def fit_command(recording: Path, out: Path, *more: str) -> list[str]:
    return ["fit", "cart", str(recording), *SEARCH, "--out", str(out), *more]


@pytest.fixture(scope="module")
def undisturbed(cart_recording, tmp_path_factory):
    """The fit on one process, how many candidates its global search simulated here, and how
    many seconds it took on this machine at this moment."""

    out = tmp_path_factory.mktemp("undisturbed") / "fit.json"
    started = time.monotonic()
    with counted_candidates() as calls:
        assert main(fit_command(cart_recording, out, "--workers", "1")) == 0
    return result_without_time(out), calls["n"], time.monotonic() - started


@contextmanager
def counted_candidates():
    """Counts the global search's candidates simulated in this process (Residuals.sum_of_squares)."""
    from pendfmu.fitting.residuals import Residuals

    calls = {"n": 0}
    original = Residuals.sum_of_squares

    def counted(self, u):
        calls["n"] += 1
        return original(self, u)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(Residuals, "sum_of_squares", counted)
        yield calls


def without_incidents(path: Path) -> tuple[dict, list[str]]:
    """The result without its timings and the notes on workers lost and survived, and those notes."""
    document = result_without_time(path)
    notes = document["fit"]["notes"]
    incidents = [note for note in notes if "ran again" in note]
    document["fit"]["notes"] = [note for note in notes if note not in incidents]
    return document, incidents


def start_fit(command: list[str], prelude: str = "") -> subprocess.Popen:
    """`pendfmu fit` in a process of its own session (a kill of its group reaches its workers);
    `prelude` is Python run before it (a hook, a shorter period)."""
    code = f"{prelude}\nimport sys\nfrom pendfmu.cli import main\nsys.exit(main(sys.argv[1:]))"
    return subprocess.Popen([sys.executable, "-c", code, *command], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, start_new_session=True, env={**os.environ, "PYTHONUNBUFFERED": "1"})


def finish(process: subprocess.Popen) -> tuple[str, str]:
    try:
        return process.communicate(timeout=WAIT)
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGKILL)
        process.communicate()
        pytest.fail(f"the fit did not end within {WAIT} s")


@contextmanager
def within(seconds: float):
    """Fail a block that takes longer (the code before issue 28 waited for a frozen worker forever)."""
    def expired(number, frame):
        raise TimeoutError(f"still waiting after {seconds} s")

    previous = signal.signal(signal.SIGALRM, expired)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def test_a_worker_killed_with_kill_9_is_replaced_and_the_fit_ends_as_undisturbed(cart_recording, tmp_path,
                                                                                  undisturbed):
    """multiprocessing.Pool never returned a killed worker's job: the fit waited forever."""
    out = tmp_path / "fit.json"
    process = start_fit(fit_command(cart_recording, out, "--workers", "2"))
    os.kill(busy_workers(process)[0], signal.SIGKILL)
    stdout, stderr = finish(process)
    assert process.returncode == 0, stderr
    result, incidents = without_incidents(out)
    assert result == undisturbed[0]
    assert len(incidents) == 1 and "died of SIGKILL" in incidents[0], incidents


def test_candidates_that_segfault_their_worker_are_penalized_with_the_reason(cart_recording, tmp_path, monkeypatch):
    """A worker's simulation of some candidates segfaults: each such candidate kills its
    worker twice, is penalized, and the note says why (the reason of a failure in a worker
    process was lost before: "(last: )")."""
    import ctypes
    import faulthandler

    from pendfmu.fitting.residuals import Residuals

    here, cost = os.getpid(), Residuals.sum_of_squares

    def crashing(self, u):
        if os.getpid() != here and u[0] > 0.9:
            faulthandler.disable()  # pytest's, inherited: no traceback dump from the dying worker
            ctypes.string_at(0)
        return cost(self, u)

    monkeypatch.setattr(Residuals, "sum_of_squares", crashing)
    out = tmp_path / "fit.json"
    with within(WAIT):
        assert main(["fit", "cart", str(cart_recording), "--seed", "8", "--generations", "2", "--uncertainty",
                     "jacobian", "--workers", "2", "--out", str(out)]) == 0
    notes = json.loads(out.read_text())["fit"]["notes"]
    penalized = [n for n in notes if "simulations failed during the fit and were penalized" in n]
    assert len(penalized) == 1 and ("the simulation did not come back: its worker process died of SIGSEGV, on "
                                    "each of 2 tries") in penalized[0], notes


def killing(job: tuple[int, Path]) -> int:
    """Job 2 kills its worker once (kill -9, the OOM killer), job 4 every time (a segfault)."""
    import faulthandler

    number, flag = job
    faulthandler.disable()  # pytest's, inherited: no traceback dump from the dying worker
    if number == 2 and not flag.exists():
        flag.touch()
        os.kill(os.getpid(), signal.SIGKILL)
    if number == 4:
        os.kill(os.getpid(), signal.SIGSEGV)
    return number * number


def test_a_job_whose_worker_died_runs_again_and_one_that_kills_every_worker_is_given_up(tmp_path):
    from pendfmu.fitting.bootstrap import parallel_map

    jobs = [(n, tmp_path / "killed-once") for n in range(7)]
    incidents: list[str] = []
    with within(30):
        results = parallel_map(killing, jobs, workers=2, failed=lambda job, reason: f"job {job[0]}: {reason}",
                               incidents=incidents)
    assert results == [0, 1, 4, 9, "job 4: its worker process died of SIGSEGV, on each of 2 tries", 25, 36]
    # the last of the 3 deaths is job 4's second, or job 2's on a busy machine (its worker was slower to get there)
    last = ("SIGSEGV", "SIGKILL (kill -9 or the out-of-memory killer)")
    assert incidents in ([f"3 worker process(es) died (last: its worker process died of {signal_name}); their jobs "
                          f"ran again on fresh workers"] for signal_name in last), incidents


def test_the_reason_a_bootstrap_refit_failed_in_a_worker_reaches_the_note(cart_recording, monkeypatch):
    from pendfmu.components import rig_defaults
    from pendfmu.fitting import bootstrap
    from pendfmu.fitting.optimizer import GlobalOptions, optimize
    from pendfmu.fitting.residuals import Residuals
    from pendfmu.fitting.stages import make_experiment, stage_free_parameters
    from pendfmu.fitting.uncertainty import assess_uncertainty
    from pendfmu.recording import read_recording

    values = rig_defaults()
    experiment = make_experiment(read_recording(cart_recording), "cart", values)
    residuals = Residuals([experiment], stage_free_parameters("cart", [experiment], None, [], {}, values), values)
    outcome = optimize(residuals, None, np.full(4, 0.5), 0, GlobalOptions(enabled=False))

    def singular(*args, **kwargs):
        raise np.linalg.LinAlgError("the Jacobian is singular")

    monkeypatch.setattr(bootstrap, "local_search", singular)  # in the forked workers too
    assessed = assess_uncertainty("bootstrap", residuals, outcome, 8, options=GlobalOptions(workers=2))
    assert ("only 0 of 8 bootstrap refits succeeded (last: LinAlgError: the Jacobian is singular)"
            in assessed.notes[0]), assessed.notes


def test_sigterm_writes_a_checkpoint_and_resume_ends_as_undisturbed(cart_recording, tmp_path, undisturbed):
    out = tmp_path / "fit.json"
    command = fit_command(cart_recording, out)
    process = start_fit(command + ["--workers", "2"], SAVING)
    first_checkpoint(process, tmp_path / "fit.json.checkpoint")  # some costs are in (a CPU-time mark missed
    process.send_signal(signal.SIGTERM)                          # a short search on a fast run)
    stdout, stderr = finish(process)
    assert process.returncode == 130, stderr
    assert "interrupted" in stdout and "interrupted" in json.loads(out.read_text())
    cached = checkpoint_costs(tmp_path / "fit.json.checkpoint")
    with counted_candidates() as calls:
        assert main(command + ["--workers", "1", "--resume"]) == 0
    assert result_without_time(out) == undisturbed[0]
    assert calls["n"] == undisturbed[1] - cached  # what the checkpoint held was looked up, not simulated
    assert not (tmp_path / "fit.json.checkpoint").exists()


SAVING = "import pendfmu.fitting.checkpoint as c\nc.SAVE_PERIOD = 0.3"
"""A fit's prelude: its checkpoint saved every 0.3 s of the search (30 s in use)."""


def first_checkpoint(process: subprocess.Popen, checkpoint: Path) -> None:
    """Wait for the fit's first periodic checkpoint (SAVING): its search has costs by then."""
    deadline = time.monotonic() + WAIT
    while not checkpoint.exists() and process.poll() is None and time.monotonic() < deadline:
        time.sleep(0.02)
    assert checkpoint.exists(), f"no checkpoint was written while the fit ran: {finish(process)}"


def checkpoint_costs(path: Path) -> int:
    """How many candidates' costs a checkpoint holds (at least one)."""
    document = json.loads(path.read_text())
    count = sum(len(costs) for costs in document["costs"].values())
    assert document["pendfmu_checkpoint"] == 1 and count > 0
    return count


def test_kill_9_after_a_periodic_checkpoint_loses_only_what_came_after(cart_recording, tmp_path, undisturbed):
    """The checkpoint is saved every SAVE_PERIOD seconds of the search (0.3 s here, 30 s in
    use), so a fit killed without warning resumes from it."""
    out = tmp_path / "fit.json"
    checkpoint = tmp_path / "fit.json.checkpoint"
    command = fit_command(cart_recording, out)
    process = start_fit(command + ["--workers", "2"], SAVING)
    first_checkpoint(process, checkpoint)
    os.killpg(process.pid, signal.SIGKILL)
    finish(process)
    assert process.returncode == -signal.SIGKILL and not out.exists()
    cached = checkpoint_costs(checkpoint)
    with counted_candidates() as calls:
        assert main(command + ["--workers", "1", "--resume"]) == 0
    assert result_without_time(out) == undisturbed[0]
    assert calls["n"] == undisturbed[1] - cached


# -- Dask: a worker frozen, killed, or crashed by its work

@pytest.fixture(scope="module")
def cluster():
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, host="127.0.0.1", dashboard_address=":0",
                                  processes=True) as local:
        yield local


@contextmanager
def frozen_worker(cluster):
    """One of the cluster's worker processes stopped (SIGSTOP) for the block, then continued
    (it goes on with what it was given: hooked_workers starts from fresh workers)."""
    from distributed import Client

    with Client(cluster.scheduler_address, set_as_default=False) as client:
        pid = min(client.run(os.getpid).values())
    os.kill(pid, signal.SIGSTOP)
    try:
        yield pid
    finally:
        os.kill(pid, signal.SIGCONT)


def test_a_dask_worker_frozen_in_the_search_loses_no_candidate(cluster, cart_recording, monkeypatch):
    """Frozen after its actor was made: its chunk runs on the other worker's actor, and the
    costs are the ones a local evaluation gives."""
    from pendfmu.components import rig_defaults
    from pendfmu.fitting import cluster as survival
    from pendfmu.fitting.optimizer import _Evaluator
    from pendfmu.fitting.residuals import Residuals
    from pendfmu.fitting.stages import make_experiment, stage_free_parameters
    from pendfmu.fitting.workers import cost_and_failures
    from pendfmu.recording import read_recording

    monkeypatch.setattr(survival, "STRAGGLER_FLOOR", 1.0)
    values = rig_defaults()
    experiment = make_experiment(read_recording(cart_recording), "cart", values)
    residuals = Residuals([experiment], stage_free_parameters("cart", [experiment], None, [], {}, values), values)
    candidates = [np.array([0.5, 0.5, 0.5, 0.2]) + 0.01 * k for k in range(6)]
    evaluator = _Evaluator(residuals, 1, {}, cluster.scheduler_address)
    try:
        with frozen_worker(cluster), within(60):
            costs = evaluator(None, candidates)
            again = evaluator(None, [u + 0.001 for u in candidates])  # the next generation: the worker left alone
    finally:
        with within(60):
            evaluator.close()
    assert costs == [cost_and_failures(residuals, u)[0] for u in candidates]
    assert again == [cost_and_failures(residuals, u + 0.001)[0] for u in candidates]
    assert "stopped answering in the search" in evaluator.lost


def test_a_dask_worker_frozen_from_the_start_leaves_the_result_undisturbed(cluster, cart_recording, tmp_path,
                                                                           undisturbed, monkeypatch):
    """Frozen before the fit: its actor is never made, and the bootstrap's tasks it holds run
    on the other worker (the straggler floor is 1 s here, 5 s in use)."""
    from pendfmu.fitting import cluster as survival

    monkeypatch.setattr(survival, "STRAGGLER_FLOOR", 1.0)
    out = tmp_path / "fit.json"
    # one worker left does the undisturbed fit's work and the cluster's round trips: on a loaded
    # machine (load 10 once) that alone passed the fixed WAIT, so the limit follows the machine
    hung = max(WAIT, 6 * undisturbed[2])
    with frozen_worker(cluster), within(hung):
        assert main(fit_command(cart_recording, out, "--scheduler", cluster.scheduler_address)) == 0
    result, incidents = without_incidents(out)
    assert result == undisturbed[0]
    assert any("stopped answering while its actor was made" in note for note in incidents), incidents


@contextmanager
def mortal_workers(cluster):
    """A client of the cluster for a block whose workers get killed, their nannies starting
    them again; the block ends when the cluster has its two workers again. A LocalCluster
    closes a nanny for good if its worker's name is missing 15 s after a loss
    (distributed.deploy.lost-worker-timeout), as when it is killed again then, by the same
    test or the next: the cluster lost both its workers that way. Here that delay outlasts
    the module."""
    import dask
    from distributed import Client

    with dask.config.set({"distributed.deploy.lost-worker-timeout": "1h"}):
        with Client(cluster.scheduler_address, set_as_default=False) as client:
            try:
                yield client
            finally:
                with within(60):
                    client.wait_for_workers(2)


@contextmanager
def hooked_workers(cluster, owner: type, name: str, hook):
    """mortal_workers, with `hook(original, *args)` in place of the method `owner.name` in
    the cluster's worker processes, those its nannies start in place of a dead one included
    (a worker plugin: a patch made in this process never reaches them). `hook` travels by
    value: a function defined in a test, not at a module's top level."""
    from distributed.diagnostics.plugin import WorkerPlugin

    class Hooked(WorkerPlugin):
        def setup(self, worker):
            self.original = getattr(owner, name)
            setattr(owner, name, lambda *args: hook(self.original, *args))

        def teardown(self, worker):
            setattr(owner, name, self.original)

    with mortal_workers(cluster) as client:
        with within(60):  # fresh workers: a worker continued after frozen_worker goes on with an
            client.restart()  # earlier fit's actor, which once ran under the hook and killed its worker
        client.register_plugin(Hooked(), name="hooked")
        try:
            yield client
        finally:
            with within(60):
                client.wait_for_workers(2)  # the plugin's teardown reaches the workers started again
                client.unregister_worker_plugin("hooked")


def test_a_dask_worker_killed_while_the_actors_are_made_leaves_the_result_undisturbed(cluster, cart_recording,
                                                                                      tmp_path, undisturbed,
                                                                                      monkeypatch):
    """The first actor to start being made kills its worker (kill -9) in its __init__: which
    of the two is whichever creates the flag file first, and exactly one does. The other
    worker's actor is made; the killed one's never comes (it waits for its worker), and its
    nanny starts the worker again at a new address, where the search makes an actor at a
    later generation (the straggler floor is 1 s here, 5 s in use). Before issue 28 the fit
    waited for the lost actor for ever."""
    from pendfmu.fitting import cluster as survival
    from pendfmu.fitting.workers import CandidateEvaluator

    monkeypatch.setattr(survival, "STRAGGLER_FLOOR", 1.0)

    flag = tmp_path / "killed"

    def dies_once(original, evaluator, residuals):
        try:
            os.close(os.open(flag, os.O_CREAT | os.O_EXCL | os.O_WRONLY))
        except FileExistsError:
            return original(evaluator, residuals)
        os.kill(os.getpid(), signal.SIGKILL)

    out = tmp_path / "fit.json"
    with hooked_workers(cluster, CandidateEvaluator, "__init__", dies_once), within(WAIT):
        assert main(fit_command(cart_recording, out, "--scheduler", cluster.scheduler_address)) == 0
    assert flag.exists()
    result, incidents = without_incidents(out)
    assert result == undisturbed[0]
    # (with a 1 s floor, a bootstrap refit slower than the others on a busy machine may be copied: a note more)
    assert any("was lost (it left the cluster) while its actor was made" in note for note in incidents), incidents


def test_a_candidate_that_segfaults_its_dask_worker_is_penalized_with_the_reason(cluster, cart_recording, tmp_path):
    """The Dask twin of the local workers' case: one candidate of the first generation (the
    only one with u[0] > 0.98 in this search) segfaults the worker that simulates it, then
    the worker that runs it again, and is penalized; the nannies start both workers again and
    the fit goes on. Before issue 28 its chunk ran again as a task, which killed worker
    after worker until the scheduler gave up: "internal failure: KilledWorker"."""
    from pendfmu.fitting.residuals import Residuals

    def crashing(original, residuals, u):
        if u[0] > 0.98:
            import ctypes
            import faulthandler

            faulthandler.disable()  # no traceback dump from the dying worker
            ctypes.string_at(0)
        return original(residuals, u)

    out = tmp_path / "fit.json"
    with hooked_workers(cluster, Residuals, "sum_of_squares", crashing), within(WAIT):
        assert main(["fit", "cart", str(cart_recording), "--seed", "8", "--generations", "2", "--uncertainty",
                     "jacobian", "--scheduler", cluster.scheduler_address, "--out", str(out)]) == 0
    notes = json.loads(out.read_text())["fit"]["notes"]
    penalized = [n for n in notes if "simulations failed during the fit and were penalized" in n]
    assert len(penalized) == 1 and penalized[0].startswith("1 simulations failed"), notes
    assert ("the simulation did not come back: the Dask workers that ran it were lost or stopped answering, on each "
            "of 2 tries") in penalized[0], notes


def test_a_dask_job_that_kills_every_worker_is_given_up_and_the_others_end(cluster, tmp_path, monkeypatch):
    """The bootstrap's map on Dask, with the local pool's jobs (`killing`): the scheduler runs
    job 2 again after its worker's death; job 4 kills every worker it runs on and is given
    up, and every other job ends with its result, also one queued behind job 4 on a worker
    it killed (the scheduler blames those too: it runs again alone). The scheduler gives a
    task up after 2 deaths here (allowed-failures 1; 3 by default). `killing` travels by
    reference: the workers import this module, on the sys.path multiprocessing gives them.
    Before issue 28 the map raised KilledWorker: the whole bootstrap failed."""
    from pendfmu.fitting.bootstrap import parallel_map

    monkeypatch.setattr(cluster.scheduler, "allowed_failures", 1)
    jobs = [(n, tmp_path / "killed-once") for n in range(7)]
    with mortal_workers(cluster), within(60):
        results = parallel_map(killing, jobs, scheduler=cluster.scheduler_address,
                               failed=lambda job, reason: f"job {job[0]}: {reason}")
    assert results == [0, 1, 4, 9, "job 4: it killed every Dask worker that ran it, with other jobs and alone "
                                   "(KilledWorker)", 25, 36]


def test_a_dask_map_whose_workers_are_all_gone_ends_with_a_reason_not_a_wait(monkeypatch):
    """With no worker left (here: none from the start), the bootstrap's map waits RETURN_WAIT
    for one to join, then gives up with WorkersLost (exit 6 on the command line). Before, it
    waited for ever: the first task's end, which nothing would compute."""
    distributed = pytest.importorskip("distributed")
    from pendfmu.fitting import cluster as survival
    from pendfmu.fitting.bootstrap import parallel_map

    monkeypatch.setattr(survival, "RETURN_WAIT", 1.0)
    monkeypatch.setattr(survival, "POLL", 0.2)
    with distributed.LocalCluster(n_workers=0, host="127.0.0.1", dashboard_address=":0") as empty, within(30):
        with pytest.raises(survival.WorkersLost, match="every worker of the Dask cluster was lost, and none joined "
                                                        "within 1 s"):
            parallel_map(abs, [-1, -2], scheduler=empty.scheduler_address)


# -- the checkpoint's path

@pytest.mark.parametrize("name", ["out", "recording", "sidecar", "params", "other"])
def test_a_checkpoint_path_that_would_destroy_a_file_is_refused_before_the_fit(cart_recording, tmp_path, capsys,
                                                                               name):
    """`--checkpoint r.json --out r.json` deleted the result after the fit (and so any file
    the checkpoint path named)."""
    recording = tmp_path / "cart.csv"
    for source in (cart_recording, cart_recording.with_suffix(".json")):
        (tmp_path / source.name).write_bytes(source.read_bytes())
    params = tmp_path / "params.json"
    params.write_text(json.dumps({"parameters": {"m_p": 0.0}}))
    (tmp_path / "notes.txt").write_text("mine")
    out = tmp_path / "r.json"
    path = {"out": out, "recording": recording, "sidecar": recording.with_suffix(".json"), "params": params,
            "other": tmp_path / "notes.txt"}[name]
    before = path.read_bytes() if path.exists() else None
    started = time.perf_counter()
    code = main(["fit", "cart", str(recording), "--params", str(params), "--out", str(out), "--checkpoint", str(path),
                 "--no-global", "--uncertainty", "jacobian"])
    error = capsys.readouterr().err
    assert code == 2 and f"--checkpoint {path}" in error and len(error.strip().splitlines()) == 1, error
    assert time.perf_counter() - started < 5  # before the fit
    assert (path.read_bytes() if path.exists() else None) == before


def test_another_fits_checkpoint_at_the_path_is_not_deleted_by_a_completed_fit(cart_recording, tmp_path):
    """A completed fit deletes its checkpoint only if the file is its own: another fit's
    stays (this short fit wrote none: it never reached the save period)."""
    other = json.dumps({"pendfmu_checkpoint": 1, "fingerprint": "f" * 64, "costs": {}})
    path = tmp_path / "fit.checkpoint"
    path.write_text(other)
    assert main(["fit", "cart", str(cart_recording), "--no-global", "--uncertainty", "jacobian", "--out",
                 str(tmp_path / "r.json"), "--checkpoint", str(path)]) == 0
    assert path.read_text() == other
