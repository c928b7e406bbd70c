"""Writing signals exactly: CSV text that reads back bit for bit (and is as short as repr),
MATLAB files in Simulink's "Structure with time", and refusals before any work."""

from __future__ import annotations

import math

import numpy as np
import orjson
import pytest
import scipy.io

from pendfmu.recording import RecordingError, read_recording
from pendfmu.recording import csv_text
from pendfmu.recording.csv_text import ROWS_PER_BLOCK, format_rows, header_line
from pendfmu.recording.writer import OUTPUT_SUFFIXES, check_output_path, write_signals

AWKWARD = [5e-324, -5e-324, 1e-300, 2.2250738585072014e-308, 2.225073858507201e-308, 1e-5, 1e-7, 0.1 + 0.2, 0.1, -0.0,
           0.0, 1.0, 3.0, -7.0, 2.0**53, 2.0**53 + 2, 1e15, 1e16, 1e22, 1e23, 123456789012345680.0,
           1.7976931348623157e308, -1.7976931348623157e308, math.pi, 2e-4 * 3, 6.02214076e23, 1 / 3]


def significant(text: str) -> tuple[str, str, int]:
    """(sign, significant digits, decimal exponent of the first digit) of a number's text."""
    sign = "-" if text.startswith("-") else ""
    mantissa, _, exponent = text.lstrip("-").lower().partition("e")
    whole, _, fraction = mantissa.partition(".")
    digits = whole + fraction
    leading = len(digits) - len(digits.lstrip("0"))
    return sign, digits.strip("0") or "0", int(exponent or 0) + len(whole) - leading


def cells_of(values) -> list[str]:
    text = bytes(format_rows(np.asarray(values, dtype=float).reshape(-1, 1))).decode("ascii")
    assert text.endswith("\n")
    return text.splitlines()


def assert_exact_and_shortest(values) -> None:
    values = np.asarray(values, dtype=float)
    cells = cells_of(values)
    assert len(cells) == len(values)
    back = np.array([float(cell) for cell in cells])
    assert back.tobytes() == values.tobytes()  # bit for bit, -0.0 included
    for cell, value in zip(cells, values.tolist()):
        if value != 0.0:
            assert significant(cell) == significant(repr(value)), (cell, repr(value))


def test_awkward_values_read_back_bit_for_bit_with_the_digits_of_repr():
    assert_exact_and_shortest(AWKWARD)
    assert cells_of([-0.0])[0] == "-0.0" and cells_of([0.1 + 0.2])[0] == "0.30000000000000004"


def test_random_bit_patterns_read_back_bit_for_bit_with_the_digits_of_repr():
    rng = np.random.default_rng(13)
    patterns = rng.integers(0, 2**64, size=200_000, dtype=np.uint64).view(np.float64)
    scaled = rng.normal(size=50_000) * 10.0 ** rng.integers(-320, 300, 50_000)
    grid = np.arange(100_001) * 2e-4  # the time stamps of a 20 s recording at 0.2 ms
    values = np.concatenate([patterns[np.isfinite(patterns)], scaled, grid])
    assert_exact_and_shortest(values)


def test_rows_and_columns_keep_their_order():
    table = np.array([[0.0, 1.5, -2.25], [2e-4, 1e-300, 1e22]])
    assert bytes(format_rows(table)) == b"0.0,1.5,-2.25\n0.0002,1e-300,1e+22\n"
    assert bytes(format_rows(np.zeros((0, 3)))) == b""


def rows_one_by_one(table: np.ndarray) -> bytes:
    """The CSV lines built the slow, obvious way: each row's numbers as orjson writes them."""
    return b"".join(orjson.dumps(row, option=orjson.OPT_SERIALIZE_NUMPY)[1:-1] + b"\n" for row in table)


@pytest.mark.parametrize("rows", [1, ROWS_PER_BLOCK - 1, ROWS_PER_BLOCK, ROWS_PER_BLOCK + 1, 3 * ROWS_PER_BLOCK + 5])
@pytest.mark.parametrize("width", [1, 2, 7])
def test_blocks_of_rows_join_into_the_same_lines(rows, width):
    """The table is serialized a block at a time: no row is split, lost or repeated at a
    block's edge, whatever the row count and width."""
    rng = np.random.default_rng(rows * 10 + width)
    table = rng.normal(size=(rows, width)) * 10.0 ** rng.integers(-30, 30, size=(rows, width))
    text = bytes(format_rows(table))
    assert text == rows_one_by_one(table)
    back = np.array([float(cell) for line in text.decode().splitlines() for cell in line.split(",")])
    assert back.tobytes() == table.tobytes()


def test_a_buffer_too_small_for_the_text_grows(monkeypatch):
    """The output is sized for orjson's longest number; were a number ever longer, the
    buffer grows instead of failing or cutting the text."""
    table = np.array(AWKWARD * (3 * ROWS_PER_BLOCK)).reshape(-1, 9)  # several blocks, growing after each
    monkeypatch.setattr(csv_text, "_MOST_BYTES_PER_NUMBER", 1)
    assert bytes(format_rows(table)) == rows_one_by_one(table)


def test_tables_of_any_memory_layout_give_the_same_lines():
    table = np.random.default_rng(3).normal(size=(2000, 6))
    expected = rows_one_by_one(table)
    assert bytes(format_rows(np.asfortranarray(table))) == expected
    assert bytes(format_rows(np.repeat(table, 2, axis=1)[:, ::2])) == expected


def test_non_finite_values_are_written_as_python_reads_them():
    text = bytes(format_rows(np.array([[0.0, np.nan], [1.0, np.inf], [2.0, -np.inf]])))
    assert text == b"0.0,nan\n1.0,inf\n2.0,-inf\n"


@pytest.mark.parametrize("name", ["a,b", 'say "x"', "two\nlines", " padded", ""])
def test_header_names_that_need_quoting_are_refused(name):
    with pytest.raises(ValueError, match="cannot be written as a CSV header"):
        header_line(["time", name])


@pytest.fixture
def signals():
    time = np.array([-0.0, 5e-324, 1e-300, 1e-5, 0.1 + 0.2, 1.0, 3.0, 2.0**53, 1e22, 1.7976931348623157e308])
    x = np.array(AWKWARD[:len(time)])
    phi = np.array(AWKWARD[-len(time):]) * -1.0
    return time, {"x": x, "phi": phi}


@pytest.mark.parametrize("suffix", [".csv", ".mat", ".CSV", ".Mat"])
def test_written_signals_read_back_identical(tmp_path, signals, suffix):
    time, columns = signals
    path = write_signals(tmp_path / f"out{suffix}", time, columns)
    rec = read_recording(path)
    assert rec.time.tobytes() == time.tobytes()
    assert rec.names == ("x", "phi")
    for name, values in columns.items():
        assert rec.signal(name).tobytes() == values.tobytes()


def test_csv_is_a_header_and_one_row_per_sample(tmp_path):
    path = write_signals(tmp_path / "out.csv", [0.0, 2e-4], {"x": [1.0, -0.0], "phi": [math.pi, 1e-300]})
    assert path.read_text() == "time,x,phi\n0.0,1.0,3.141592653589793\n0.0002,-0.0,1e-300\n"
    assert not list(tmp_path.glob(".*"))  # no temporary file left behind


def test_mat_is_a_simulink_structure_with_time(tmp_path, signals):
    time, columns = signals
    path = write_signals(tmp_path / "out.mat", time, columns)
    data = scipy.io.loadmat(path)
    assert [k for k in data if not k.startswith("__")] == ["simout"]
    simout = data["simout"][0, 0]
    assert simout["time"].shape == (len(time), 1)  # columns, as Simulink loads them
    signals_ = simout["signals"]
    assert signals_.shape == (1, 2)
    assert [str(s["label"][0]) for s in signals_[0]] == ["x", "phi"]
    for s, values in zip(signals_[0], columns.values()):
        assert s["values"].shape == (len(time), 1) and s["dimensions"][0, 0] == 1.0
        assert s["values"][:, 0].tobytes() == values.tobytes()


def test_mat_labels_may_be_any_model_output_name(tmp_path):
    path = write_signals(tmp_path / "out.mat", [0.0, 1.0], {"Cart.x": [0.0, 1.0]})
    simout = scipy.io.loadmat(path, simplify_cells=True)["simout"]
    assert simout["signals"]["label"] == "Cart.x"


@pytest.mark.parametrize("name", ["out.txt", "out.json", "out", "out.csv.gz"])
def test_unknown_suffixes_are_refused_naming_the_allowed_ones(tmp_path, name):
    with pytest.raises(RecordingError) as raised:
        write_signals(tmp_path / name, [0.0], {"x": [1.0]})
    assert ".csv or .mat" in str(raised.value) and name in str(raised.value)
    assert not list(tmp_path.iterdir())
    assert OUTPUT_SUFFIXES == (".csv", ".mat")
    with pytest.raises(RecordingError):
        check_output_path(name)


def test_columns_of_another_length_or_named_time_are_refused(tmp_path):
    with pytest.raises(ValueError, match="column 'x' has 1 values, time has 2"):
        write_signals(tmp_path / "out.csv", [0.0, 1.0], {"x": [1.0]})
    with pytest.raises(ValueError, match="named 'time'"):
        write_signals(tmp_path / "out.csv", [0.0, 1.0], {"time": [0.0, 1.0]})
    assert not list(tmp_path.iterdir())


def test_an_existing_file_is_replaced_whole(tmp_path):
    path = tmp_path / "out.csv"
    path.write_text("old content that is longer than the new one\n" * 100)
    write_signals(path, [0.0], {"x": [1.0]})
    assert path.read_text() == "time,x\n0.0,1.0\n"


@pytest.mark.parametrize("marker", ["nan", -9999.0])
def test_missing_samples_survive_the_round_trip(tmp_path, marker):
    """A recording with missing readings (NaN, or a marker that became NaN) writes a sidecar
    that says so: read back, the same samples are missing, not an error on the NaN."""
    from pendfmu.recording import Recording, SignalInfo
    from pendfmu.recording.writer import write_recording

    phi = np.array([3.0, 2.9, marker if marker != "nan" else np.nan, 2.7])
    recording = Recording(tmp_path / "made", np.arange(4) * 0.1, {"a": np.zeros(4), "phi": phi},
                          signal_info={"phi": SignalInfo(1e-3, missing=marker)})
    back = read_recording(write_recording(recording, tmp_path / "rec.csv"))
    assert np.array_equal(np.isnan(back.signal("phi")), [False, False, True, False])
    assert np.array_equal(back.signal("phi")[[0, 1, 3]], [3.0, 2.9, 2.7])
    assert back.signal_info["phi"].missing == "nan"
