"""The global search on a Dask cluster (issue 6): a LocalCluster on loopback gives the same
result file as local processes (deferred updating makes the search independent of who
evaluates the candidates), and each Dask worker keeps one copy of the residuals and its
FMU instances across tasks."""

from __future__ import annotations

import pytest

distributed = pytest.importorskip("distributed")

from pendfmu.cli import main  # noqa: E402
from conftest import result_without_time  # noqa: E402


@pytest.fixture(scope="module")
def cluster():
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, host="127.0.0.1", dashboard_address=None,
                                  processes=True) as local:
        yield local


def test_dask_cluster_gives_the_same_result_as_local_processes(cluster, cart_recording, tmp_path):
    command = ["fit", "cart", str(cart_recording), "--seed", "11"]
    assert main(command + ["--out", str(tmp_path / "local.json"), "--workers", "2"]) == 0
    assert main(command + ["--out", str(tmp_path / "dask.json"), "--scheduler", cluster.scheduler_address]) == 0
    assert result_without_time(tmp_path / "dask.json") == result_without_time(tmp_path / "local.json")
    assert result_without_time(tmp_path / "dask.json")["parameters"]["F_Kc"] == pytest.approx(7.0, rel=0.03)


def test_workers_keep_their_fmu_instances_across_tasks(cluster, cart_recording):
    """One scattered copy per worker: its simulators hold FMU instances after the first task."""
    from distributed import Client

    from pendfmu.experiment import make_experiment
    from pendfmu.identification import _free_parameters, rig_defaults
    from pendfmu.workers import dask_costs
    from pendfmu.recording import read_recording
    from pendfmu.residuals import Residuals

    values = rig_defaults()
    experiment = make_experiment(read_recording(cart_recording), "cart", values)
    residuals = Residuals([experiment], _free_parameters("cart", [experiment], None, [], {}, values), values)
    with Client(cluster.scheduler_address, set_as_default=False) as client:
        remote = client.scatter(residuals, broadcast=True, hash=False)
        client.gather(client.map(dask_costs, [[[0.5, 0.5, 0.5, 0.2]] * 2] * 4, residuals=remote, pure=False))

        def instances(dask_worker):
            copies = [v for v in dask_worker.data.values() if isinstance(v, Residuals)]
            return [(c.evaluations, sum(len(s._fmus) for s in c.simulators)) for c in copies]

        per_worker = client.run(instances)
    counts = [pair for pairs in per_worker.values() for pair in pairs]
    assert len(counts) == 2  # one copy on each worker
    assert sum(evaluations for evaluations, _ in counts) == 8
    assert all(fmus == 2 for evaluations, fmus in counts if evaluations)  # CurrentLoop and Cart, made once


def test_a_fit_pauses_the_workers_profiler_and_restores_it(cluster, cart_recording):
    """Dask's statistical profiler samples a busy worker every 10 ms and slowed the
    simulations by 10-40 %: the evaluator stops it on every worker and starts it again."""
    from distributed import Client

    from pendfmu.experiment import make_experiment
    from pendfmu.identification import _free_parameters, rig_defaults
    from pendfmu.optimizer import _Evaluator
    from pendfmu.residuals import Residuals
    from pendfmu.recording import read_recording
    from pendfmu.workers import PROFILER_CALLBACKS

    def running(dask_worker):
        return [dask_worker.periodic_callbacks[name].is_running() for name in PROFILER_CALLBACKS]

    values = rig_defaults()
    experiment = make_experiment(read_recording(cart_recording), "cart", values)
    residuals = Residuals([experiment], _free_parameters("cart", [experiment], None, [], {}, values), values)
    with Client(cluster.scheduler_address, set_as_default=False) as client:
        assert all(all(states) for states in client.run(running).values())
        evaluator = _Evaluator(residuals, 1, {}, cluster.scheduler_address)
        try:
            assert not any(any(states) for states in client.run(running).values())
        finally:
            evaluator.close()
        assert all(all(states) for states in client.run(running).values())
