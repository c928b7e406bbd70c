"""The same inputs and seed give the same result file, bit for bit (issue 7), whatever the
number of worker processes: differential evolution updates its population once per
generation ("deferred"), so the order in which workers finish does not matter. Only the
wall-clock times (fit.seconds, fit.uncertainty.seconds) differ between runs."""

from __future__ import annotations

import json

from pendfmu.cli import main
from conftest import result_without_time


def fitted_text(recording, tmp_path, name, workers):
    out = tmp_path / name
    assert main(["fit", "cart", str(recording), "--out", str(out), "--seed", "42", "--workers", str(workers)]) == 0
    return json.dumps(result_without_time(out), sort_keys=True)


def test_same_seed_same_result_file(cart_recording, tmp_path):
    assert fitted_text(cart_recording, tmp_path, "a.json", 2) == fitted_text(cart_recording, tmp_path, "b.json", 2)


def test_result_does_not_depend_on_the_number_of_workers(cart_recording, tmp_path):
    assert fitted_text(cart_recording, tmp_path, "one.json", 1) == fitted_text(cart_recording, tmp_path, "two.json", 2)
