"""The coverage benchmark's scripts (scripts/coverage.py, scripts/reference_recordings.py)
as modules the tests can use: the reference recordings and the benchmark's own truths."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

SCRIPTS = Path(__file__).resolve().parents[1] / "scripts"
sys.path.append(str(SCRIPTS))  # appended: scripts/coverage.py must not shadow a 'coverage' package

import reference_recordings  # noqa: E402 (after the path)


def _benchmark():
    spec = importlib.util.spec_from_file_location("coverage_benchmark", SCRIPTS / "coverage.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


BENCHMARK = _benchmark()
__all__ = ["BENCHMARK", "SCRIPTS", "reference_recordings"]
