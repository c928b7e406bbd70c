"""The same inputs and seed give the same result file, bit for bit (issue 7), whatever the
number of worker processes: differential evolution updates its population once per
generation ("deferred"), so the order in which workers finish does not matter. Only the
wall-clock time in fit.seconds differs between runs."""

from __future__ import annotations

import json

import pytest

from pendfmu.cli import main
from pendfmu.virtual_rig import Experiment, steps, write_experiments


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    out = tmp_path_factory.mktemp("determinism")
    experiment = Experiment("cart", "cart", 0.4, 2e-4, ("I_c", "I", "x"), steps((0, 0.0), (0.02, 2.0), (0.25, 0.0)),
                            sidecar_parameters={"m_p": 0.0}, known_initial=("x", "v"))
    write_experiments(out, {"k_fwc": 26.0, "F_Kc": 7.0, "F_Sc": 10.5, "eta": 0.42}, seed=9, experiments=[experiment])
    return out / "cart.csv"


def fitted_text(recording, tmp_path, name, workers):
    out = tmp_path / name
    assert main(["fit", "cart", str(recording), "--out", str(out), "--seed", "42", "--workers", str(workers)]) == 0
    document = json.loads(out.read_text())
    document["fit"].pop("seconds")
    return json.dumps(document, sort_keys=True)


def test_same_seed_same_result_file(recording, tmp_path):
    assert fitted_text(recording, tmp_path, "a.json", 2) == fitted_text(recording, tmp_path, "b.json", 2)


def test_result_does_not_depend_on_the_number_of_workers(recording, tmp_path):
    assert fitted_text(recording, tmp_path, "one.json", 1) == fitted_text(recording, tmp_path, "two.json", 2)
