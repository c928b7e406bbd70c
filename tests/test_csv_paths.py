"""The CSV reader's two ways in (pendfmu/recording/csv_reader.py) give the same arrays bit
for bit: numpy's loadtxt for plain files, the csv module and float() for everything else.
The messages for bad files are tested through read_recording in test_recording.py and
test_bad_input.py; here: the fast path is taken where it should be, steps aside where it
must, and never changes a value."""

from __future__ import annotations

import numpy as np
import pytest

from pendfmu.recording import read_recording
from pendfmu.recording.csv_reader import _parse_cells, _parse_plain
from pendfmu.recording.sidecar import _read_sidecar
from pendfmu.recording.writer import write_signals


def both(path):
    sidecar = _read_sidecar(path.with_suffix(".json"))
    return _parse_plain(path, sidecar), _parse_cells(path, sidecar)


def assert_same(fast, careful):
    assert fast[0].tobytes() == careful[0].tobytes()
    assert list(fast[1]) == list(careful[1])
    for name in careful[1]:
        assert fast[1][name].tobytes() == careful[1][name].tobytes(), name
    assert fast[2] == careful[2]


PLAIN = {
    "written by pendfmu": "time,I_c,x\n0.0,1.5,-0.0\n0.0002,1e-300,5e-324\n0.0004,0.30000000000000004,1e+22\n",
    "other number forms": "time,x\n0,+1\n1,.5\n2,5.\n3,1E5\n4,-0\n5,12345678901234567890123\n6,1.e-3\n",
    "spaces around cells": "time , x\n 0.0 , 1.5\n1.0,\t2.5 \n",
    "windows line ends": "time,x\r\n0.0,1.0\r\n1.0,2.0\r\n",
    "old mac line ends": "time,x\r0.0,1.0\r1.0,2.0\r",
    "byte order mark": "\ufefftime,x\n0.0,1.0\n",
    "no final newline": "time,x\n0.0,1.0\n1.0,2.0",
    "blank lines at the end": "time,x\n0.0,1.0\n1.0,2.0\n\n\n",
    "non-finite (refused later, by line)": "time,x\n0.0,1.0\n1.0,nan\n2.0,-inf\n",
}


@pytest.mark.parametrize("case", sorted(PLAIN))
def test_plain_files_take_the_fast_path_with_the_same_values(tmp_path, case):
    path = tmp_path / "rec.csv"
    path.write_text(PLAIN[case], newline="")
    fast, careful = both(path)
    assert fast is not None
    assert_same(fast, careful)


def test_ignored_columns_are_dropped_the_same_way(tmp_path):
    path = tmp_path / "rec.csv"
    path.write_text("time,pwm,x\n0.0,7,1.0\n1.0,8,2.0\n")
    path.with_suffix(".json").write_text('{"signals": {"pwm": {"ignore": true}}}')
    fast, careful = both(path)
    assert fast is not None and fast[2] == ("pwm",)
    assert_same(fast, careful)


OTHER = {
    "underscores in a number": "time,x\n0.0,1_000.5\n1.0,2.0\n",
    "quoted cells": 'time,x\n0.0,"1.5"\n1.0,2.0\n',
    "quoted header": '"time","x"\n0.0,1.5\n',
    "text in an ignored column": "time,note,x\n0.0,start,1.0\n1.0,,2.0\n",
    "non-ASCII digits": "time,x\n0.0,\u0661\n",
}


@pytest.mark.parametrize("case", sorted(OTHER))
def test_other_valid_files_are_read_cell_by_cell(tmp_path, case):
    path = tmp_path / "rec.csv"
    path.write_text(OTHER[case], encoding="utf-8")
    if case == "text in an ignored column":
        path.with_suffix(".json").write_text('{"signals": {"note": {"ignore": true}}}')
    fast, careful = both(path)
    assert fast is None
    assert read_recording(path).time.tolist() == careful[0].tolist()


BAD = {
    "blank line inside": ("time,x\n0.0,1.0\n\n1.0,2.0\n", "line 3 is empty"),
    "blank line of spaces inside": ("time,x\n0.0,1.0\n   \n1.0,2.0\n", "line 3 is empty"),
    "ragged row": ("time,x\n0.0,1.0\n1.0,2.0,3.0\n", "line 3 has 3 cells"),
    "empty cell": ("time,x\n0.0,1.0\n1.0,\n", "an empty cell is not a number"),
    "header only": ("time,x\n", "header only"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_files_get_the_careful_readers_message(tmp_path, case):
    text, message = BAD[case]
    path = tmp_path / "rec.csv"
    path.write_text(text)
    sidecar = _read_sidecar(path.with_suffix(".json"))
    assert _parse_plain(path, sidecar) is None
    with pytest.raises(ValueError, match=message):
        read_recording(path)


def test_a_long_random_recording_reads_back_bit_for_bit_by_both_paths(tmp_path):
    rng = np.random.default_rng(5)
    n = 20_000
    time = np.cumsum(rng.uniform(1e-6, 1e-3, n))
    columns = {"x": rng.normal(size=n) * 10.0 ** rng.integers(-300, 300, n),
               "phi": rng.integers(0, 2**64, size=n, dtype=np.uint64).view(np.float64)}
    columns["phi"][~np.isfinite(columns["phi"])] = 0.0
    path = write_signals(tmp_path / "rec.csv", time, columns)
    fast, careful = both(path)
    assert fast is not None
    assert_same(fast, careful)
    assert fast[1]["phi"].tobytes() == columns["phi"].tobytes()
