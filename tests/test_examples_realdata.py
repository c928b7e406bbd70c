"""The real-data examples run end to end: ``examples/realdata/<name>/run OUTDIR`` converts
the raw files, fits through pendfmu's command line and leaves ``OUTDIR/result.json``.

Each ``run`` is started as a user starts it (a separate process, this interpreter), so the
shebang script, its path set-up and its exit code are what is tested, not just the
functions behind it. The figures themselves are held to published and independent values
by test_realdata.py and test_realdata_fits.py, on the same conversions; here: the file, the
fitted parameters, and for EMPS the benchmark's terms. About 40 s for the five runs
(``--uncertainty jacobian``, as the examples' READMEs say); skipped without the data.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

import realdata as rd

EXAMPLES = Path(__file__).resolve().parents[1] / "examples" / "realdata"
NAMES = sorted(p.name for p in EXAMPLES.iterdir() if (p / "run").is_file())


def run(name: str, outdir: Path, **env: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(EXAMPLES / name / "run"), str(outdir)], capture_output=True,
                          text=True, env={**os.environ, **env}, timeout=600)


def test_every_example_has_an_executable_run_and_a_readme():
    assert set(NAMES) >= {"kord-stk", "MultiArm-Pendulum", "friction-identification", "rotary-inverted-pendulum",
                          "EMPS"}
    for name in NAMES:
        script = EXAMPLES / name / "run"
        assert os.access(script, os.X_OK), script
        assert script.read_text().startswith("#!/usr/bin/env python3\n"), script
        assert (EXAMPLES / name / "README.md").is_file(), name


@pytest.mark.parametrize("name", NAMES)
def test_run_names_the_missing_file_and_exits_2(tmp_path, name):
    """Without the data: exit 2 and the missing file's path in the message, nothing fitted."""
    absent = tmp_path / "nowhere"
    done = run(name, tmp_path / "out", PENDFMU_REALDATA=str(absent))
    assert done.returncode == 2, done.stderr
    assert str(absent / name) in done.stderr
    assert not (tmp_path / "out" / "result.json").exists()


def test_run_started_by_any_python3_uses_the_projects_interpreter(tmp_path):
    """`run OUTDIR` as a user types it: the first python3 on PATH (here a bare interpreter
    without pendfmu's dependencies, where the machine has one) hands over to the project's
    .venv; the run then gets as far as the missing data (exit 2, the file named)."""
    import shutil

    bare = shutil.which("python3", path=os.defpath) or sys.executable
    absent = tmp_path / "nowhere"
    done = subprocess.run([bare, str(EXAMPLES / "kord-stk" / "run"), str(tmp_path / "out")], capture_output=True,
                          text=True, env={**os.environ, "PENDFMU_REALDATA": str(absent)}, timeout=120)
    assert done.returncode == 2, done.stderr
    assert str(absent / "kord-stk") in done.stderr, done.stderr


def test_run_refuses_an_outdir_git_could_commit(tmp_path):
    """The converted data are derived from files licensed for internal testing only: an
    OUTDIR inside the repository (other than the git-ignored out/) is refused, exit 2."""
    inside = EXAMPLES / "kord-stk" / "converted"
    done = run("kord-stk", inside)
    assert done.returncode == 2 and "inside the repository" in done.stderr, done.stderr
    assert not inside.exists()


@pytest.mark.parametrize("name", NAMES)
def test_run_writes_the_result(tmp_path, name):
    convert = rd.load_example(name)
    if not rd.available(*convert.SOURCES):
        pytest.skip(f"real data absent: {', '.join(map(str, convert.SOURCES))}")
    done = run(name, tmp_path)
    assert done.returncode == 0, done.stderr
    document = json.loads((tmp_path / "result.json").read_text())
    fitted = document["interval_method"]
    assert fitted, "no parameter fitted"
    assert all(math.isfinite(document["parameters"][label]) for label in fitted)
    assert (tmp_path / "command.txt").read_text().startswith(f"pendfmu fit {convert.STAGE} ")
    if name == "EMPS":
        p = document["parameters"]
        assert document["benchmark"] == pytest.approx({"M": p["m_c"] / p["eta"], "Fv": p["k_fwc"] / p["eta"],
                                                       "Fc": p["F_Kc"] / p["eta"],
                                                       "offset": convert.EMPS_PUBLISHED["OF1"]})
