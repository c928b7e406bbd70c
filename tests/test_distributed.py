"""The global search on a Dask cluster (issue 6): a LocalCluster on loopback gives the same
result file as local processes (deferred updating makes the search independent of who
evaluates the candidates), each Dask worker's actor keeps the residuals and their FMU
instances across generations, and a lost worker loses no candidates."""

from __future__ import annotations

import json

import pytest

distributed = pytest.importorskip("distributed")

from pendfmu.cli import main  # noqa: E402
from conftest import result_without_time  # noqa: E402
from pendfmu.errors import UsageError  # noqa: E402


@pytest.fixture(scope="module")
def cluster():
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, host="127.0.0.1", dashboard_address=":0",
                                  processes=True) as local:
        yield local


@pytest.fixture
def cart_residuals(cart_recording):
    """The cart stage's residuals for the recording, as a fit builds them."""
    from pendfmu.components import rig_defaults
    from pendfmu.fitting.stages import make_experiment, stage_free_parameters
    from pendfmu.recording import read_recording
    from pendfmu.fitting.residuals import Residuals

    values = rig_defaults()
    experiment = make_experiment(read_recording(cart_recording), "cart", values)
    return Residuals([experiment], stage_free_parameters("cart", [experiment], None, [], {}, values), values)


def test_dask_cluster_gives_the_same_result_as_local_processes(cluster, cart_recording, tmp_path):
    command = ["fit", "cart", str(cart_recording), "--seed", "11"]
    assert main(command + ["--out", str(tmp_path / "local.json"), "--workers", "2"]) == 0
    assert main(command + ["--out", str(tmp_path / "dask.json"), "--scheduler", cluster.scheduler_address]) == 0
    assert result_without_time(tmp_path / "dask.json") == result_without_time(tmp_path / "local.json")
    assert result_without_time(tmp_path / "dask.json")["parameters"]["F_Kc"] == pytest.approx(7.0, rel=0.03)
    # --scheduler applied, as the provenance records it (test_fit_options leaves it to this test)
    dask = json.loads((tmp_path / "dask.json").read_text())["provenance"]["stages"]["cart"]["search"]
    assert dask["scheduler"] == cluster.scheduler_address


def test_workers_keep_their_fmu_instances_across_generations(cluster, cart_residuals):
    """One actor per worker holds that worker's residuals: its simulators keep their FMU
    instances from one generation to the next, and the two chunks of a generation go to
    the two workers."""
    import numpy as np
    from distributed import Client

    from pendfmu.fitting.optimizer import _Evaluator
    from pendfmu.fitting.workers import CandidateEvaluator

    def instances(dask_worker):
        copies = [a.residuals for a in dask_worker.state.actors.values() if isinstance(a, CandidateEvaluator)]
        def cart(pool):
            return next(fmu for (name, _), fmu in pool.items() if name == "Cart")

        return [(c.evaluations, len(s._fmus), id(cart(s._fmus).slave.component)) for c in copies for s in c.simulators[:1]]

    evaluator = _Evaluator(cart_residuals, 1, {}, cluster.scheduler_address)
    try:
        generation = [np.array([0.5, 0.5, 0.5, 0.2]) + 0.01 * k for k in range(4)]
        evaluator(None, generation)
        with Client(cluster.scheduler_address, set_as_default=False) as client:
            first = client.run(instances)
            evaluator(None, [u + 0.001 for u in generation])
            second = client.run(instances)
    finally:
        evaluator.close()
    assert sorted(first) == sorted(second) and len(first) == 2
    for worker in first:
        (evaluations_1, fmus_1, instance_1), = first[worker]
        (evaluations_2, fmus_2, instance_2), = second[worker]
        assert (evaluations_1, evaluations_2) == (2, 4)  # two candidates of each generation on each worker
        assert fmus_1 == fmus_2 == 2 and instance_1 == instance_2  # CurrentLoop and Cart, made once


def test_a_fit_pauses_the_workers_profiler_and_restores_it(cluster, cart_residuals):
    """Dask's statistical profiler samples a busy worker every 10 ms and slowed the
    simulations by 10-40 %: the evaluator stops it on every worker and starts it again."""
    from distributed import Client

    from pendfmu.fitting.optimizer import _Evaluator
    from pendfmu.fitting.workers import PROFILER_CALLBACKS

    def running(dask_worker):
        return [dask_worker.periodic_callbacks[name].is_running() for name in PROFILER_CALLBACKS]

    with Client(cluster.scheduler_address, set_as_default=False) as client:
        assert all(all(states) for states in client.run(running).values())
        evaluator = _Evaluator(cart_residuals, 1, {}, cluster.scheduler_address)
        try:
            assert not any(any(states) for states in client.run(running).values())
        finally:
            evaluator.close()
        assert all(all(states) for states in client.run(running).values())


def test_a_lost_worker_loses_no_candidates(cart_residuals):
    """Each worker evaluates its chunk in an actor, which cannot move: when its worker is
    gone, the chunk runs as a task on a worker that is left, and the costs are the ones a
    local evaluation gives."""
    import time

    import numpy as np

    from pendfmu.fitting.optimizer import _Evaluator
    from pendfmu.fitting.workers import cost_and_failures

    candidates = [np.array([0.5, 0.5, 0.5, 0.2]) + 0.01 * k for k in range(6)]
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, host="127.0.0.1", dashboard_address=":0",
                                  processes=True) as cluster:  # ":0": the module's cluster has the default port
        evaluator = _Evaluator(cart_residuals, 1, {}, cluster.scheduler_address)
        try:
            cluster.scale(1)
            deadline = time.monotonic() + 60
            while len(evaluator.client.scheduler_info()["workers"]) > 1:
                assert time.monotonic() < deadline, "the cluster did not drop a worker"
                time.sleep(0.05)
            costs = evaluator(None, candidates)
        finally:
            evaluator.close()
    assert costs == [cost_and_failures(cart_residuals, u)[0] for u in candidates]
    assert evaluator.lost and "lost" in evaluator.lost


def test_a_scheduler_without_workers_is_a_clear_error(cart_residuals, monkeypatch):
    from pendfmu.fitting import optimizer

    monkeypatch.setattr(optimizer, "WORKER_WAIT", 0.5)
    with distributed.LocalCluster(n_workers=0, host="127.0.0.1", dashboard_address=":0") as cluster:
        with pytest.raises(UsageError, match=f"{cluster.scheduler_address} has no workers"):
            optimizer._Evaluator(cart_residuals, 1, {}, cluster.scheduler_address)


def test_a_foreign_fmu_fit_on_dask_equals_local_processes(cluster, tmp_path):
    """`pendfmu fit --fmu` takes --scheduler as the stages do: the workers load the user's
    FMU from its path and the result is the local processes' one."""
    import json

    from foreign.build import build
    from foreign.recordings import FIT_NAMES, FITTED, TRUTH, write_recordings

    fmu = build("ForeignCart", tmp_path)
    recordings = write_recordings(fmu, tmp_path / "recordings")
    start = {name: TRUTH[name] * (1.3 if k % 2 == 0 else 0.7) for k, name in enumerate(FITTED)}
    (tmp_path / "start.json").write_text(json.dumps({"parameters": {"m": TRUTH["m"], **start}}))
    command = ["fit", "--fmu", str(fmu), *(str(recordings[n]) for n in FIT_NAMES), "--free", *FITTED,
               "--params", str(tmp_path / "start.json"), "--seed", "5", "--uncertainty", "jacobian"]
    assert main(command + ["--out", str(tmp_path / "local.json"), "--workers", "2"]) == 0
    assert main(command + ["--out", str(tmp_path / "dask.json"), "--scheduler", cluster.scheduler_address]) == 0
    assert result_without_time(tmp_path / "dask.json") == result_without_time(tmp_path / "local.json")
    assert result_without_time(tmp_path / "dask.json")["parameters"]["k_u"] == pytest.approx(TRUTH["k_u"], rel=0.01)


def test_a_failure_on_a_dask_worker_comes_back_with_its_reason(cluster, cart_residuals):
    """A candidate outside the unit box (eta = 1.95, which the Cart refuses) fails on a Dask
    worker; its reason reaches the fit's own residuals, which never simulated it."""
    import numpy as np

    from pendfmu.fitting.optimizer import _Evaluator

    evaluator = _Evaluator(cart_residuals, 1, {}, cluster.scheduler_address)
    try:
        evaluator(None, [np.array([2.0, 0.5, 0.5, 0.5]), np.array([0.5, 0.5, 0.5, 0.5])])
    finally:
        evaluator.close()
    assert evaluator.failures == 1 and cart_residuals.failures == 0
    assert "eta = 1.95 is outside its physical range" in cart_residuals.last_failure
