"""Tests of pendfmu.recording: reading, writing and checking recordings.

Every error case has its own test that asserts the message names the file and the
column and line (or JSON key), because the message is all a user gets. Real recordings
from ../shared/realdata are read in place (their licences allow internal testing only,
so they are never copied into the repository); those tests skip when it is absent.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import scipy.io

from pendfmu.recording import (
    PARAMETER_NAMES,
    SIGNAL_NAMES,
    Recording,
    RecordingError,
    SignalInfo,
    quantize,
    read_recording,
    write_recording,
)

REALDATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "realdata"


def write_csv(tmp_path: Path, text: str, name: str = "run1.csv", sidecar: dict | str | None = None) -> Path:
    """A CSV (and optionally its sidecar) in tmp_path; `text` is written verbatim."""
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    if sidecar is not None:
        side = sidecar if isinstance(sidecar, str) else json.dumps(sidecar)
        path.with_suffix(".json").write_text(side, encoding="utf-8")
    return path


def error_of(path: Path, **kwargs) -> str:
    with pytest.raises(RecordingError) as info:
        read_recording(path, **kwargs)
    message = str(info.value)
    assert "\n" not in message, "messages are one line"
    return message


GOOD = "time,I_c,x\n0.0,0.0,0.0\n0.001,1.0,0.5\n0.002,1.0,0.75\n"


# --------------------------------------------------------------------------- good files


def test_round_trip_csv_and_sidecar_is_bit_exact(tmp_path):
    rng = np.random.default_rng(1)
    n = 500
    time = np.cumsum(rng.uniform(1e-5, 1e-3, n))  # irregular, arbitrary digits
    x = rng.normal(0, 1, n) * 10.0 ** rng.integers(-300, 300, n)  # huge and tiny magnitudes
    x[:4] = [-0.0, 5e-324, -1.7976931348623157e308, 0.1 + 0.2]  # signed zero, subnormal, max, classic
    phi = math.pi + rng.normal(0, 1, n)
    original = Recording(
        path=None, time=time, signals={"x": x, "phi": phi}, experiment="coupled step, run 3",
        signal_info={"x": SignalInfo(9.765625e-06, "round"), "phi": SignalInfo(2 * math.pi / 1024, "floor")},
        parameters={"m_p": 0.0, "k_D": 628.3185307179586}, initial={"phi": 3.6416, "x": -0.1},
    )
    path = write_recording(original, tmp_path / "run1.csv")
    assert path == tmp_path / "run1.csv" and (tmp_path / "run1.json").is_file()
    again = read_recording(path)
    assert again.time.tobytes() == original.time.tobytes()
    for name in ("x", "phi"):
        assert again.signal(name).tobytes() == original.signal(name).tobytes()
    assert math.copysign(1.0, again.signal("x")[0]) == -1.0
    assert again.names == ("x", "phi")
    assert again.experiment == original.experiment
    assert again.signal_info == original.signal_info
    assert again.parameters == original.parameters and again.initial == original.initial
    assert again.path == path and again.ignored == ()


def test_irregular_time_stamps_are_kept_as_recorded(tmp_path):
    path = write_csv(tmp_path, "time,I\n0,0\n0.1,1\n0.15,2\n0.4,3\n1e0,4\n")
    rec = read_recording(path)
    assert rec.time.tolist() == [0.0, 0.1, 0.15, 0.4, 1.0]
    assert rec.signal("I").tolist() == [0.0, 1.0, 2.0, 3.0, 4.0]


def test_without_sidecar_metadata_is_empty_and_quantizer_defaults_to_round(tmp_path):
    rec = read_recording(write_csv(tmp_path, GOOD))
    assert rec.experiment == "" and rec.parameters == {} and rec.initial == {}
    assert rec.resolution("x") is None and rec.quantizer("x") == "round"


def test_sidecar_is_read(tmp_path):
    side = {"experiment": "cart-startup", "signals": {"x": {"resolution": 9.765625e-06}},
            "parameters": {"m_p": 0}, "initial": {"x": 0.25}, "comment": "free text"}
    rec = read_recording(write_csv(tmp_path, GOOD, sidecar=side))
    assert rec.experiment == "cart-startup"
    assert rec.resolution("x") == 9.765625e-06 and rec.quantizer("x") == "round"
    assert rec.resolution("I_c") is None
    assert rec.parameters == {"m_p": 0.0} and isinstance(rec.parameters["m_p"], float)
    assert rec.initial == {"x": 0.25}


def test_whitespace_bom_crlf_and_trailing_blank_lines_are_accepted(tmp_path):
    path = tmp_path / "run1.csv"
    path.write_bytes("\ufefftime , x\r\n0, 1.5 \r\n1,2\r\n\r\n\r\n".encode())
    rec = read_recording(path)
    assert rec.time.tolist() == [0.0, 1.0] and rec.signal("x").tolist() == [1.5, 2.0]


def test_column_marked_ignore_in_the_sidecar_is_left_out(tmp_path):
    text = "time,x,pwm_raw,phi\n0,0,abc,3.1\n1,1,,3.2\n"  # ignored cells are not even parsed
    rec = read_recording(write_csv(tmp_path, text, sidecar={"signals": {"pwm_raw": {"ignore": True}}}))
    assert rec.names == ("x", "phi") and rec.ignored == ("pwm_raw",)
    assert rec.signal("phi").tolist() == [3.1, 3.2]


def test_recording_arrays_are_read_only_copies():
    time = np.array([0.0, 1.0])
    rec = Recording(path=None, time=time, signals={"x": np.array([[1.0], [2.0]])})  # N x 1, as MATLAB has it
    time[0] = -5.0
    assert rec.time[0] == 0.0 and rec.signal("x").shape == (2,)
    with pytest.raises(ValueError):
        rec.signal("x")[0] = 3.0


def test_to_frame_is_indexed_by_time(tmp_path):
    frame = read_recording(write_csv(tmp_path, GOOD)).to_frame()
    assert list(frame.columns) == ["I_c", "x"] and frame.index.name == "time"
    assert frame["x"].tolist() == [0.0, 0.5, 0.75]


# --------------------------------------------------------------------------- CSV errors


def test_missing_file(tmp_path):
    path = tmp_path / "nothere.csv"
    assert error_of(path) == f"{path}: no such file"


def test_empty_file(tmp_path):
    path = write_csv(tmp_path, "")
    assert error_of(path) == f"{path}: empty file"
    assert error_of(write_csv(tmp_path, "\n  \n", name="blank.csv")).endswith("blank.csv: empty file")


def test_header_only(tmp_path):
    path = write_csv(tmp_path, "time,x\n")
    assert error_of(path) == f"{path}: header only, no data rows"


def test_no_time_column(tmp_path):
    path = write_csv(tmp_path, "x,phi\n0,1\n")
    message = error_of(path)
    assert message.startswith(f"{path}: line 1: the first column must be 'time', found 'x'")


def test_time_column_not_first_is_named(tmp_path):
    message = error_of(write_csv(tmp_path, "x,time\n0,1\n"))
    assert "'time' is column 2, it must be the first" in message


def test_space_separated_header_gets_a_hint(tmp_path):
    """Semicolons and tabs are read (tests/test_cli_conventions.py); spaces are not a separator."""
    assert "cells must be separated by commas, semicolons or tabs and line 1 has none" in \
        error_of(write_csv(tmp_path, "time x\n0 1\n"))


def test_non_numeric_cell_names_line_and_column(tmp_path):
    path = write_csv(tmp_path, "time,I_c,x\n0,0,0\n0.001,1.0,0.5\n0.002,1.0,abc\n")
    assert error_of(path) == f"{path}: line 4, column 'x': 'abc' is not a number"


def test_empty_cell_names_line_and_column(tmp_path):
    path = write_csv(tmp_path, "time,I_c,x\n0,0,0\n0.001,,0.5\n")
    assert error_of(path) == f"{path}: line 3, column 'I_c': an empty cell is not a number"


def test_nan_in_a_signal(tmp_path):
    path = write_csv(tmp_path, "time,x\n0,0\n1,nan\n2,NaN\n")
    assert error_of(path) == (f"{path}: NaN in column 'x' at line 3 (and 1 more); if it marks a missing sample, "
                              f'say so in the sidecar: "signals": {{"x": {{"missing": "nan"}}}}')


def test_inf_in_a_signal(tmp_path):
    path = write_csv(tmp_path, "time,I_c,phi\n0,0,0\n1,0,0\n2,1,-inf\n")
    assert error_of(path) == f"{path}: Inf in column 'phi' at line 4"


def test_nan_in_time(tmp_path):
    path = write_csv(tmp_path, "time,x\n0,0\nnan,1\n")
    assert error_of(path) == f"{path}: NaN in column 'time' at line 3"


def test_time_not_strictly_increasing(tmp_path):
    path = write_csv(tmp_path, "time,x\n0,0\n0.5,1\n0.3,2\n")
    assert error_of(path) == (f"{path}: column 'time' is not strictly increasing at line 4: "
                              f"0.3 after 0.5 at line 3")


def test_duplicate_time_stamps(tmp_path):
    path = write_csv(tmp_path, "time,x\n0,0\n0.5,1\n0.5,2\n1,3\n")
    assert error_of(path) == (f"{path}: duplicate time stamp 0.5 in column 'time' at line 3 and line 4; "
                              f"time must strictly increase")


def test_row_with_wrong_number_of_cells(tmp_path):
    path = write_csv(tmp_path, "time,x\n0,0\n1,1,7\n")
    assert error_of(path) == f"{path}: line 3 has 3 cells, the header has 2"


def test_blank_line_in_the_middle(tmp_path):
    path = write_csv(tmp_path, "time,x\n0,0\n\n1,1\n")
    assert error_of(path) == f"{path}: line 3 is empty; blank lines are allowed only at the end"


def test_duplicate_column(tmp_path):
    path = write_csv(tmp_path, "time,x,x\n0,0,0\n")
    assert error_of(path) == f"{path}: line 1: column 'x' appears twice (columns 2 and 3)"


def test_only_time_column(tmp_path):
    path = write_csv(tmp_path, "time\n0\n")
    assert error_of(path) == f"{path}: line 1: only a 'time' column, no signals"


def test_unknown_column_lists_valid_signals_and_how_to_ignore(tmp_path):
    path = write_csv(tmp_path, "time,Phi,latency\n0,0,1\n")
    message = error_of(path)
    assert message.startswith(f"{path}: column 'Phi' is not a signal name (did you mean 'phi'?); valid: ")
    assert ", ".join(SIGNAL_NAMES) in message
    assert f"mark it in {tmp_path / 'run1.json'}" in message and '"ignore": true' in message


def test_unsupported_suffix(tmp_path):
    path = write_csv(tmp_path, "time,x\n0,0\n", name="run1.txt")
    assert "unsupported file type '.txt'" in error_of(path)


def test_file_above_the_size_limit_is_refused_before_reading(tmp_path):
    path = write_csv(tmp_path, GOOD)
    message = error_of(path, max_bytes=10)
    assert message.startswith(f"{path}: file of {path.stat().st_size} bytes is above the limit of 10 bytes")
    assert "max_bytes" in message


def test_size_limit_default_is_module_setting(tmp_path, monkeypatch):
    import pendfmu.recording as recording

    monkeypatch.setattr(recording, "MAX_BYTES", 5)
    assert "above the limit" in error_of(write_csv(tmp_path, GOOD))


# --------------------------------------------------------------------------- sidecar errors


def test_sidecar_not_valid_json_names_line_and_column(tmp_path):
    path = write_csv(tmp_path, GOOD, sidecar='{\n  "experiment": "a",\n  "signals": {,}\n}\n')
    message = error_of(path)
    assert message.startswith(f"{tmp_path / 'run1.json'}: not valid JSON at line 3, column 15:")


def test_sidecar_with_comments_gets_a_hint(tmp_path):
    path = write_csv(tmp_path, GOOD, sidecar='{"experiment": "a" // free text\n}')
    assert "JSON has no comments" in error_of(path)


def test_sidecar_unknown_parameter_lists_valid_ones(tmp_path):
    path = write_csv(tmp_path, GOOD, sidecar={"parameters": {"m_pp": 0.1}})
    message = error_of(path)
    assert message.startswith(f"{tmp_path / 'run1.json'}: parameters.m_pp: unknown parameter (did you mean 'm_p'?)")
    assert ", ".join(PARAMETER_NAMES) in message


def test_sidecar_parameter_out_of_range(tmp_path):
    path = write_csv(tmp_path, GOOD, sidecar={"parameters": {"eta": 1.5}})
    assert "parameters.eta: eta = 1.5 is outside its physical range (0.0, 1.0] [1]" in error_of(path)


def test_sidecar_m_p_zero_is_accepted_for_the_cart(tmp_path):
    rec = read_recording(write_csv(tmp_path, GOOD, sidecar={"parameters": {"m_p": 0.0}}))
    assert rec.parameters == {"m_p": 0.0}


def test_sidecar_unknown_signal_lists_valid_ones(tmp_path):
    path = write_csv(tmp_path, GOOD, sidecar={"signals": {"theta": {"resolution": 0.001}}})
    message = error_of(path)
    assert message.startswith(f"{tmp_path / 'run1.json'}: signals.theta: unknown signal 'theta'; valid: ")
    assert ", ".join(SIGNAL_NAMES) in message


def test_sidecar_signal_not_in_the_file(tmp_path):
    path = write_csv(tmp_path, GOOD, sidecar={"signals": {"phi": {"resolution": 0.001}}})
    assert error_of(path) == (f"{tmp_path / 'run1.json'}: signals.phi: the recording {path} has no column 'phi' "
                              f"(columns: I_c, x)")


def test_sidecar_unknown_initial_state(tmp_path):
    path = write_csv(tmp_path, GOOD, sidecar={"initial": {"alpha": 0.0}})
    message = error_of(path)
    assert message.startswith(f"{tmp_path / 'run1.json'}: initial.alpha: not a state; valid: ")
    assert "phi" in message and "x" in message


def test_sidecar_bad_resolution_and_quantizer(tmp_path):
    path = write_csv(tmp_path, GOOD, sidecar={"signals": {"x": {"resolution": -1}}})
    assert "signals.x.resolution: resolution must be a positive finite number, got -1.0" in error_of(path)
    path = write_csv(tmp_path, GOOD, sidecar={"signals": {"x": {"quantizer": "ceil"}}})
    assert "signals.x.quantizer: quantizer must be one of round, floor, got 'ceil'" in error_of(path)


def test_sidecar_unknown_top_level_key(tmp_path):
    path = write_csv(tmp_path, GOOD, sidecar={"paramters": {}})
    message = error_of(path)
    assert "run1.json: unknown key 'paramters' (did you mean 'parameters'?)" in message


def test_sidecar_duplicate_key(tmp_path):
    path = write_csv(tmp_path, GOOD, sidecar='{"parameters": {"eta": 0.4, "eta": 0.5}}')
    assert error_of(path) == f"{tmp_path / 'run1.json'}: key 'eta' appears twice in one object"


# --------------------------------------------------------------------------- Recording API


def test_signal_missing_names_file_and_column(tmp_path):
    path = write_csv(tmp_path, GOOD)
    rec = read_recording(path)
    with pytest.raises(RecordingError) as info:
        rec.signal("phi")
    assert str(info.value) == f"{path}: no column 'phi' (columns: time, I_c, x)"
    with pytest.raises(RecordingError, match="'theta' is not a signal name either"):
        rec.resolution("theta")


def test_constructor_checks_like_the_reader():
    with pytest.raises(RecordingError, match=r"<recording in memory>: 'theta' is not a signal name"):
        Recording(path=None, time=[0.0, 1.0], signals={"theta": [0.0, 1.0]})
    with pytest.raises(RecordingError, match=r"'x' has 3 samples, time has 2"):
        Recording(path=None, time=[0.0, 1.0], signals={"x": [0.0, 1.0, 2.0]})
    with pytest.raises(RecordingError, match=r"time is not strictly increasing at sample 3"):
        Recording(path="a.mat", time=[0.0, 1.0, 0.5], signals={"x": [0.0, 1.0, 2.0]})
    with pytest.raises(RecordingError, match=r"parameters\['T_i'\]: T_i = -1 is outside its physical range \(0\.0, inf\) \[s\]"):
        Recording(path=None, time=[0.0], signals={"x": [0.0]}, parameters={"T_i": -1})


def test_write_needs_csv_suffix(tmp_path):
    rec = Recording(path=None, time=[0.0], signals={"x": [1.0]})
    with pytest.raises(RecordingError, match=r"must end in \.csv"):
        write_recording(rec, tmp_path / "run1.mat")


def test_write_replaces_a_stale_sidecar(tmp_path):
    (tmp_path / "run1.json").write_text(json.dumps({"parameters": {"m_p": 0.0}}))
    write_recording(Recording(path=None, time=[0.0], signals={"x": [1.0]}), tmp_path / "run1.csv")
    assert read_recording(tmp_path / "run1.csv").parameters == {}


# --------------------------------------------------------------------------- quantize


def test_quantize_round_and_floor():
    step = 0.25
    values = np.array([0.1, 0.2, -0.2, 0.9, -0.9])
    assert quantize(values, step).tolist() == [0.0, 0.25, -0.25, 1.0, -1.0]
    assert quantize(values, step, "floor").tolist() == [0.0, 0.0, -0.25, 0.75, -1.0]
    assert quantize(values, None).tolist() == values.tolist()
    dphi = 2 * math.pi / 1024
    reading = quantize(np.linspace(0, 7, 1001), dphi)
    assert np.allclose(reading / dphi, np.rint(reading / dphi), rtol=0, atol=1e-9)
    with pytest.raises(ValueError, match="positive"):
        quantize(values, 0.0)
    with pytest.raises(ValueError, match="quantizer"):
        quantize(values, step, "ceil")


# --------------------------------------------------------------------------- MATLAB


def save_mat(tmp_path: Path, variables: dict, name: str = "sim.mat") -> Path:
    path = tmp_path / name
    scipy.io.savemat(path, variables)
    return path


T = np.linspace(0.0, 1.0, 11)


def test_mat_plain_variables(tmp_path):
    path = save_mat(tmp_path, {"t": T[:, None], "x": 2 * T[:, None], "phi": np.pi + T, "dt": 0.1})
    rec = read_recording(path)
    assert rec.time.tolist() == T.tolist()
    assert rec.names == ("x", "phi") and rec.signal("x").tolist() == (2 * T).tolist()
    assert rec.ignored == ("dt",)


def test_mat_plain_variables_with_sidecar(tmp_path):
    path = save_mat(tmp_path, {"tout": T, "phi": T, "counts": T})
    path.with_suffix(".json").write_text(json.dumps({"signals": {"counts": {"ignore": True},
                                                                 "phi": {"resolution": 0.5}}}))
    rec = read_recording(path)
    assert rec.names == ("phi",) and rec.ignored == ("counts",) and rec.resolution("phi") == 0.5


def test_mat_struct_with_plain_fields(tmp_path):
    path = save_mat(tmp_path, {"rec": {"time": T, "I_c": T, "I": T / 2}})
    rec = read_recording(path)
    assert rec.names == ("I_c", "I") and rec.signal("I").tolist() == (T / 2).tolist()


def simulink_structure(time, labels_values, blocks="model/To Workspace"):
    signals = np.zeros((1, len(labels_values)), dtype=[("values", object), ("dimensions", object),
                                                       ("label", object), ("blockName", object)])
    for i, (label, values) in enumerate(labels_values):
        signals[0, i] = (np.asarray(values, dtype=float)[:, None], 1.0, label, blocks)
    return {"time": time, "signals": signals, "blockName": "model"}


def test_mat_simulink_structure_with_time(tmp_path):
    yout = simulink_structure(T[:, None], [("I_c", np.ones_like(T)), ("x", T ** 2)])
    path = save_mat(tmp_path, {"tout": T[:, None], "yout": yout})
    rec = read_recording(path)
    assert rec.time.tolist() == T.tolist() and rec.names == ("I_c", "x")
    assert rec.signal("x").tolist() == (T ** 2).tolist()


def test_mat_simulink_structure_with_one_signal(tmp_path):
    path = save_mat(tmp_path, {"ScopeData": simulink_structure(T, [("phi", T)])})
    assert read_recording(path).names == ("phi",)


def test_mat_simulink_structure_without_time(tmp_path):
    yout = simulink_structure(np.zeros((0, 0)), [("x", T)])
    message = error_of(save_mat(tmp_path, {"yout": yout}))
    assert "yout.time is empty" in message and "'Structure with time'" in message


def test_mat_simulink_signal_with_unknown_label(tmp_path):
    path = save_mat(tmp_path, {"yout": simulink_structure(T, [("x", T), ("theta", T)])})
    message = error_of(path)
    assert message.startswith(f"{path}: signal 'theta' is not a signal name; valid: {', '.join(SIGNAL_NAMES)}")


def test_mat_simulink_nan_names_signal_and_sample(tmp_path):
    bad = T.copy()
    bad[4] = np.nan
    path = save_mat(tmp_path, {"yout": simulink_structure(T, [("x", T), ("phi", bad)])})
    assert error_of(path) == (f"{path}: NaN in 'phi' (yout.signals(2).values) at sample 5; if it marks a missing "
                              f'sample, say so in the sidecar: "signals": {{"phi": {{"missing": "nan"}}}}')


def test_mat_timeseries_like_structs(tmp_path):
    path = save_mat(tmp_path, {"ts_x": {"Time": T, "Data": T * 3, "Name": "x"},
                               "phi": {"Time": T, "Data": T + 1}})
    rec = read_recording(path)
    assert set(rec.names) == {"x", "phi"} and rec.signal("phi").tolist() == (T + 1).tolist()


def test_mat_timeseries_with_different_time_bases(tmp_path):
    path = save_mat(tmp_path, {"x": {"Time": T, "Data": T}, "phi": {"Time": T * 2, "Data": T}})
    assert "Time differs from" in error_of(path)


def test_mat_time_not_increasing_names_variable_and_sample(tmp_path):
    time = T.copy()
    time[3] = time[2]
    path = save_mat(tmp_path, {"time": time, "x": T})
    assert error_of(path) == (f"{path}: duplicate time stamp {float(T[2])!r} in time at sample 3 and sample 4; "
                              f"time must strictly increase")


def test_mat_signal_length_mismatch(tmp_path):
    path = save_mat(tmp_path, {"t": T, "x": T[:5]})
    assert error_of(path) == f"{path}: x has 5 samples, time has 11"


def test_mat_without_time_vector_lists_what_it_found(tmp_path):
    path = save_mat(tmp_path, {"x": T, "phi": T, "Ts": 0.1})
    message = error_of(path)
    assert message.startswith(f"{path}: no time vector with signals found; accepted: variables time/t/tout")
    assert "found: x (double 1x11), phi (double 1x11), Ts (double 1x1)" in message


def test_mat_two_recordings_in_one_file_is_ambiguous(tmp_path):
    path = save_mat(tmp_path, {"t": T, "x": T, "yout": simulink_structure(T, [("phi", T)])})
    message = error_of(path)
    assert "more than one recording in the file" in message and "yout" in message


def test_not_a_mat_file(tmp_path):
    path = tmp_path / "junk.mat"
    path.write_bytes(b"this is not a MATLAB file at all" * 10)
    assert error_of(path).startswith(f"{path}: not a readable MATLAB .mat file")


# --------------------------------------------------------------------------- real recordings


MULTIARM = REALDATA / "MultiArm-Pendulum" / "SinglePendulumDataForParameterEstimation.mat"
KORD = REALDATA / "kord-stk" / "LaTest.CSV"


@pytest.mark.skipif(not MULTIARM.is_file(), reason="real recordings (../shared/realdata) not present")
def test_real_multiarm_mat_cells_are_refused_with_a_listing():
    """Its pieces of one free swing are cell arrays (Y_id{k} = [theta; dtheta]): no layout fits."""
    message = error_of(MULTIARM)
    assert message.startswith(f"{MULTIARM}: no time vector with signals found")
    for found in ("Time_id (cell 4x1)", "Y_id (cell 4x1)", "Y_vad (cell 2x1)", "dt (double 1x1)"):
        assert found in message
    assert "cell arrays" in message and "Recording(path, time, signals)" in message


@pytest.mark.skipif(not MULTIARM.is_file(), reason="real recordings (../shared/realdata) not present")
def test_real_multiarm_through_an_adapter():
    """The adapter the error message suggests: piece k of Y_id as a recording of phi.
    Its theta is 0 upright and pi hanging, pendfmu's phi convention; row 2 (dtheta) is
    the authors' denoised derivative, not a measurement, so it is left out."""
    mat = scipy.io.loadmat(MULTIARM, simplify_cells=True)
    rec = Recording(path=MULTIARM, time=mat["Time_id"][0], signals={"phi": mat["Y_id"][0][0]},
                    experiment="free swing, piece 1 of Y_id")
    assert len(rec.time) == 9167
    assert np.allclose(np.diff(rec.time), 1e-3)
    assert abs(np.mean(rec.signal("phi")) - math.pi) < 0.1  # swings about the hanging position


@pytest.mark.skipif(not KORD.is_file(), reason="real recordings (../shared/realdata) not present")
def test_real_scope_csv_is_refused_with_its_header():
    """An oscilloscope export: space separated, two header lines ('x-axis 1', units), no 'time'."""
    message = error_of(KORD)
    assert message.startswith(f"{KORD}: line 1: the first column must be 'time', found 'x-axis 1'; "
                              f"cells must be separated by commas, semicolons or tabs and line 1 has none")
