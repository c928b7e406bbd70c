"""The `pendfmu simulate` contract, end to end and in-process (main(argv))."""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest

from pendfmu.cli import main


@pytest.fixture
def recording(tmp_path):
    time = np.round(np.arange(0, 1501) * 2e-4, 10)
    pd.DataFrame({"time": time, "I_c": np.where(time >= 0.02, 1.5, 0.0)}).to_csv(tmp_path / "rec.csv", index=False)
    return tmp_path / "rec.csv"


def write(path, document):
    path.write_text(json.dumps(document))
    return path


def test_writes_the_contract_columns_at_the_recording_time_stamps(recording, tmp_path, capsys):
    params = write(tmp_path / "p.json", {"parameters": {"k_fwc": 25.0, "phi0": math.pi + 0.2}})
    out = tmp_path / "out.csv"
    assert main(["simulate", "--params", str(params), "--input", str(recording), "--out", str(out)]) == 0
    result = pd.read_csv(out)
    assert list(result.columns) == ["time", "I", "x", "v", "a", "phi", "w"]
    np.testing.assert_array_equal(result["time"], pd.read_csv(recording)["time"])
    assert result["phi"][0] == pytest.approx(math.pi + 0.2)
    assert result["x"].iloc[-1] > 0.01  # 1.5 A drives 22.6 N > F_Sc: the cart moves
    assert "wrote 1501 samples" in capsys.readouterr().out


def test_sidecar_initial_overrides_the_parameters_file(recording, tmp_path):
    params = write(tmp_path / "p.json", {"parameters": {"phi0": 3.0, "x0": 0.1}})
    write(recording.with_suffix(".json"), {"initial": {"phi": 3.5}})
    out = tmp_path / "out.csv"
    assert main(["simulate", "--params", str(params), "--input", str(recording), "--out", str(out)]) == 0
    first = pd.read_csv(out).iloc[0]
    assert (first["phi"], first["x"]) == (3.5, 0.1)


def test_absent_names_keep_the_defaults(recording, tmp_path):
    out = tmp_path / "out.csv"
    assert main(["simulate", "--input", str(recording), "--out", str(out)]) == 0
    assert pd.read_csv(out)["phi"][0] == pytest.approx(math.pi)


def test_unknown_parameter_is_exit_2_listing_valid_names(recording, tmp_path, capsys):
    params = write(tmp_path / "p.json", {"parameters": {"k_fwcc": 25.0}})
    code = main(["simulate", "--params", str(params), "--input", str(recording), "--out", str(tmp_path / "o.csv")])
    err = capsys.readouterr().err
    assert code == 2
    assert "unknown parameter 'k_fwcc'" in err and "k_fwc" in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1


@pytest.mark.parametrize("parameters, fragment", [({"m_c": -1}, "m_c = -1 is outside its physical range (0.0, inf)"),
                                                  ({"eta": 1.5}, "eta = 1.5 is outside its physical range (0.0, 1.0]"),
                                                  ({"eta": 0.0}, "eta = 0 is outside its physical range (0.0, 1.0]"),
                                                  ({"l": 0.0}, "l = 0 is outside its physical range (0.0, inf)"),
                                                  ({"l": "long"}, "l = 'long' is not a number")])
def test_bad_parameter_values_are_exit_2(recording, tmp_path, capsys, parameters, fragment):
    params = write(tmp_path / "p.json", {"parameters": parameters})
    code = main(["simulate", "--params", str(params), "--input", str(recording), "--out", str(tmp_path / "o.csv")])
    assert code == 2 and fragment in capsys.readouterr().err


def test_missing_command_current_is_exit_2(tmp_path, capsys):
    pd.DataFrame({"time": [0.0, 1e-3], "x": [0.0, 0.0]}).to_csv(tmp_path / "r.csv", index=False)
    assert main(["simulate", "--input", str(tmp_path / "r.csv"), "--out", str(tmp_path / "o.csv")]) == 2
    assert "no column 'I_c'" in capsys.readouterr().err


def test_missing_input_file_is_exit_2(tmp_path, capsys):
    assert main(["simulate", "--input", str(tmp_path / "none.csv"), "--out", str(tmp_path / "o.csv")]) == 2
    assert "none.csv" in capsys.readouterr().err


def test_usage_error_is_exit_2(capsys):
    with pytest.raises(SystemExit) as exited:
        main(["simulate", "--out", "x.csv"])
    assert exited.value.code == 2


def test_command_line_entry_point_runs(recording, tmp_path):
    """The installed console script, as other tools call it."""
    import subprocess
    import sys

    out = tmp_path / "o.csv"
    done = subprocess.run([sys.executable, "-m", "pendfmu", "simulate", "--input", str(recording), "--out", str(out)],
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert out.exists()


def test_mat_output_holds_the_same_doubles_as_the_csv(recording, tmp_path, capsys):
    """.mat (Simulink 'Structure with time') and .csv outputs read back through read_recording
    with bit-identical arrays: the CSV text is exact."""
    from pendfmu.recording import read_recording

    params = write(tmp_path / "p.json", {"parameters": {"k_fwc": 25.0, "phi0": math.pi + 0.2}})
    for name in ("out.csv", "out.mat"):
        assert main(["simulate", "--params", str(params), "--input", str(recording), "--out", str(tmp_path / name)]) == 0
    assert "out.mat" in capsys.readouterr().out
    from_csv, from_mat = read_recording(tmp_path / "out.csv"), read_recording(tmp_path / "out.mat")
    assert from_mat.names == from_csv.names == ("I", "x", "v", "a", "phi", "w")
    assert from_mat.time.tobytes() == from_csv.time.tobytes()
    for name in from_csv.names:
        assert from_mat.signal(name).tobytes() == from_csv.signal(name).tobytes(), name
    assert from_mat.signal("x")[-1] > 0.01


@pytest.mark.parametrize("name", ["out.txt", "out.xlsx", "out"])
def test_unknown_output_suffix_is_exit_2_before_any_simulation(recording, tmp_path, capsys, monkeypatch, name):
    import pendfmu.simulator.rig

    def no_simulation(*args, **kwargs):
        raise AssertionError("simulated despite a bad --out")

    monkeypatch.setattr(pendfmu.simulator.rig, "simulate_recording", no_simulation)
    code = main(["simulate", "--input", str(recording), "--out", str(tmp_path / name)])
    err = capsys.readouterr().err
    assert code == 2 and ".csv or .mat" in err and name in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / name).exists()


def test_output_into_a_missing_folder_is_exit_2_before_any_simulation(recording, tmp_path, capsys):
    code = main(["simulate", "--input", str(recording), "--out", str(tmp_path / "nowhere" / "out.csv")])
    assert code == 2 and "does not exist" in capsys.readouterr().err
