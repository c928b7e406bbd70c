"""The scripted-fitting example in scripts/ runs (it is what users copy)."""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import fmpy
import pendfmu

SCRIPTS = Path(__file__).resolve().parents[1] / "scripts"


def load(name: str):
    spec = importlib.util.spec_from_file_location(name, SCRIPTS / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_fit_example_runs_and_writes_its_files(tmp_path, capsys):
    result = load("fit_example").main(tmp_path)
    assert isinstance(result, pendfmu.FitResult)
    assert math.isclose(result.parameters["T_i"], 0.45e-3, rel_tol=0.03)
    assert (tmp_path / "current.json").exists() and (tmp_path / "report" / "index.html").exists()
    exported = tmp_path / "exported" / "CurrentLoop.fmu"
    start = {v.name: v.start for v in fmpy.read_model_description(str(exported)).modelVariables}
    assert math.isclose(float(start["T_i"]), result.parameters["T_i"], rel_tol=1e-15)
    assert "95 % interval" in capsys.readouterr().out


def test_the_end_to_end_benchmark_runs_on_a_short_recording(capsys):
    """scripts/bench.py's pendfmu simulate vs plain fmpy comparison (issue 13), on 0.2 s."""
    ratio = load("bench").end_to_end(0.2)
    out = capsys.readouterr().out
    assert ratio > 0 and "pendfmu simulate vs plain fmpy" in out and "command line (new process)" in out
