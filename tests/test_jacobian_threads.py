"""The local refinement's Jacobian on threads, and FMU instances shared by a fit's
recordings: the same numbers as one thread, each FMU loaded once per thread, and an FMU
that declares canBeInstantiatedOnlyOncePerProcess kept to one instance in the process
(every fit and replay shares it) and one thread."""

from __future__ import annotations

import pickle
import zipfile

import numpy as np
import pytest

from foreign.build import build
from foreign.recordings import FIT_NAMES, FITTED, TRUTH, write_recordings
from pendfmu.fitting.models import initial_map, model_experiments, model_free_parameters, read_for
from pendfmu.simulator.model import Model
from pendfmu.fitting.optimizer import local_search
from pendfmu.fitting.residuals import Residuals, unit_of


@pytest.fixture(scope="module")
def cart(tmp_path_factory):
    folder = tmp_path_factory.mktemp("threads")
    fmu = build("ForeignCart", folder)
    recordings = write_recordings(fmu, folder / "recordings")
    return folder, fmu, [recordings[name] for name in FIT_NAMES]


def _residuals(fmu, paths, fitted=FITTED) -> tuple[Residuals, np.ndarray]:
    model = Model.load(fmu)
    start = {name: TRUTH[name] * (1.3 if k % 2 == 0 else 0.7) for k, name in enumerate(FITTED)}
    values = {**model.defaults(), "m": TRUTH["m"], **start}
    initial = initial_map(model, None)
    recordings = read_for(model, paths, None, None, initial)
    experiments = model_experiments(model, recordings, values, None, None, initial)
    free = model_free_parameters(model, list(fitted), [], {}, values)
    return Residuals(experiments, free, values), unit_of(free, [values[p.name] for p in free])


def test_the_jacobian_on_two_threads_gives_the_same_fit_to_the_bit(cart):
    _, fmu, paths = cart
    serial, u0 = _residuals(fmu, paths)
    threaded, _ = _residuals(fmu, paths)
    try:
        one = local_search(serial, u0, threads=1)
        two = local_search(threaded, u0, threads=2)
        assert threaded._threads, "no column ran in a second thread"
        for a, b in zip(one[:3], two[:3]):
            assert np.array_equal(a, b)
        assert threaded.evaluations == serial.evaluations
    finally:
        serial.close()
        threaded.close()


def test_a_fits_recordings_share_one_instance_per_thread(cart):
    _, fmu, paths = cart
    residuals, u0 = _residuals(fmu, paths)
    try:
        residuals(u0)
        pools = {id(s._fmus) for s in residuals.simulators}
        assert len(pools) == 1 and len(residuals.simulators[0]._fmus) == 1
    finally:
        residuals.close()


def _declaring_once_per_process(fmu, target):
    """A copy of the FMU whose model description says canBeInstantiatedOnlyOncePerProcess."""
    with zipfile.ZipFile(fmu) as src, zipfile.ZipFile(target, "w") as dst:
        for info in src.infolist():
            data = src.read(info)
            if info.filename == "modelDescription.xml":
                data = data.replace(b"<CoSimulation", b'<CoSimulation canBeInstantiatedOnlyOncePerProcess="true"', 1)
                assert b"canBeInstantiatedOnlyOncePerProcess" in data
            dst.writestr(info, data)
    return target


def test_an_fmu_instantiated_once_per_process_gets_one_instance_and_one_thread(cart):
    folder, fmu, paths = cart
    once = _declaring_once_per_process(fmu, folder / "Once.fmu")
    residuals, u0 = _residuals(once, paths)
    try:
        assert residuals.experiments[0].model.instantiated_once_per_process()
        assert residuals.jacobian_map(2) is None
        local_search(residuals, u0, threads=2)
        assert not residuals._threads and len(residuals.simulators[0]._fmus) == 1
        other, _ = _residuals(once, paths)  # another fit in the same process: the same instance
        other(u0)
        assert other.simulators[0]._fmus is residuals.simulators[0]._fmus
        [instance] = other.simulators[0]._fmus.values()
        copy = pickle.loads(pickle.dumps(other.simulators[0]))  # as sent to a worker process
        assert copy._fmus is other.simulators[0]._fmus
        other.close()
        assert instance.slave is not None  # kept for the process's next fit
    finally:
        residuals.close()


def test_a_jacobian_of_two_columns_stays_on_one_thread(cart):
    _, fmu, paths = cart
    residuals, u0 = _residuals(fmu, paths, FITTED[:2])
    try:
        local_search(residuals, u0, threads=2)
        assert not residuals._threads
    finally:
        residuals.close()


def test_co_simulation_masters_share_the_one_instance_too(cart):
    """The master (coupled systems) takes an FMU declaring canBeInstantiatedOnlyOncePerProcess
    from the same process pool: two masters, one instance, both runs equal."""
    from pendfmu.simulator.component import PROCESS_POOL
    from pendfmu.simulator.master import ExternalInput, Master

    folder, fmu, _ = cart
    once = _declaring_once_per_process(fmu, folder / "OnceMaster.fmu")
    times = np.arange(0, 0.201, 1e-3)
    drive = {"ForeignCart.u": ExternalInput(times, np.where(times > 0.05, 2.0, 0.0))}
    masters = [Master({"ForeignCart": "ForeignCart"}, [], {"ForeignCart": {"m": 2.0}}, step=1e-3,
                      fmus={"ForeignCart": once}) for _ in range(2)]
    try:
        runs = [m.run(times, ["ForeignCart.x"], drive)["ForeignCart.x"].to_numpy() for m in masters]
        assert masters[0]._fmus["ForeignCart"] is masters[1]._fmus["ForeignCart"]
        assert any(instance is masters[0]._fmus["ForeignCart"] for instance in PROCESS_POOL.values())
        assert np.array_equal(runs[0], runs[1]) and runs[0][-1] > 0
    finally:
        for m in masters:
            m.close()
