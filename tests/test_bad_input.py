"""Bad input through the command line (issue 7): exit code 2, one line naming the file and
the column and row (or key), no traceback, nothing written."""

from __future__ import annotations

import json

import pytest

from pendfmu.cli import main

GOOD = "time,I_c\n0.0,0.0\n0.001,1.0\n0.002,1.0\n"

CASES = {
    "missing file": (None, None, ["nothere.csv"]),
    "empty file": ("", None, ["rec.csv", "empty"]),
    "header only": ("time,I_c\n", None, ["rec.csv", "no data"]),
    "no time column": ("seconds,I_c\n0,0\n0.001,1\n", None, ["rec.csv", "time"]),
    "non-numeric cell": ("time,I_c\n0.0,0.0\n0.001,one\n", None, ["rec.csv", "line 3", "I_c", "'one'"]),
    "NaN in a signal": ("time,I_c\n0.0,0.0\n0.001,nan\n", None, ["rec.csv", "I_c", "line 3"]),
    "Inf in a signal": ("time,I_c\n0.0,0.0\n0.001,inf\n", None, ["rec.csv", "I_c", "line 3"]),
    "time going back": ("time,I_c\n0.0,0.0\n0.002,1.0\n0.001,1.0\n", None, ["rec.csv", "line 4", "time"]),
    "duplicate time stamps": ("time,I_c\n0.0,0.0\n0.001,1.0\n0.001,1.0\n", None, ["rec.csv", "line 4", "duplicate"]),
    "unknown column": ("time,I_c,phii\n0.0,0.0,3.1\n", None, ["rec.csv", "phii", "phi"]),
    "sidecar not JSON": (GOOD, "{not json", ["rec.json", "line 1"]),
    "sidecar unknown parameter": (GOOD, json.dumps({"parameters": {"mass": 1.0}}), ["rec.json", "mass"]),
    "sidecar unknown signal": (GOOD, json.dumps({"signals": {"xx": {"resolution": 1e-3}}}), ["rec.json", "xx"]),
    "sidecar non-physical value": (GOOD, json.dumps({"parameters": {"eta": 2.0}}), ["rec.json", "eta"]),
}


@pytest.mark.parametrize("case", sorted(CASES))
@pytest.mark.parametrize("command", ["simulate", "fit"])
def test_bad_recording_is_exit_2_with_one_line(tmp_path, capsys, case, command):
    csv, sidecar, fragments = CASES[case]
    path = tmp_path / ("nothere.csv" if csv is None else "rec.csv")
    if csv is not None:
        path.write_text(csv)
    if sidecar is not None:
        path.with_suffix(".json").write_text(sidecar)
    out = tmp_path / ("out.csv" if command == "simulate" else "out")  # simulate's suffix picks the format
    argv = (["simulate", "--input", str(path), "--out", str(out)] if command == "simulate"
            else ["fit", "current", str(path), "--out", str(out), "--no-global"])
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert "Traceback" not in err
    for fragment in fragments:
        assert fragment.lower() in err.lower(), (fragment, err)
    assert not out.exists()


def test_mat_file_without_time_vector(tmp_path, capsys):
    import numpy as np
    from scipy.io import savemat

    savemat(tmp_path / "rec.mat", {"I_c": np.ones(5), "x": np.zeros(5)})
    assert main(["simulate", "--input", str(tmp_path / "rec.mat"), "--out", str(tmp_path / "o.csv")]) == 2
    err = capsys.readouterr().err
    assert "rec.mat" in err and "time" in err


def test_recording_larger_than_the_limit_is_refused_before_reading(tmp_path, capsys, monkeypatch):
    from pendfmu import recording

    monkeypatch.setattr(recording, "MAX_BYTES", 64)
    (tmp_path / "rec.csv").write_text(GOOD * 10)
    assert main(["simulate", "--input", str(tmp_path / "rec.csv"), "--out", str(tmp_path / "o.csv")]) == 2
    err = capsys.readouterr().err
    assert "rec.csv" in err and "bytes" in err
