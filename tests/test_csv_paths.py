"""The CSV reader's ways in (pendfmu/recording/csv_reader.py) give the same arrays bit for
bit: orjson for files of JSON numbers, numpy's loadtxt for other plain files, the csv
module and float() for everything else. The messages for bad files are tested through
read_recording in test_recording.py and test_bad_input.py; here: each fast path is taken
where it should be, steps aside where it must, and never changes a value; and orjson
reads numbers exactly as float() does, which the JSON path relies on."""

from __future__ import annotations

import math
from decimal import Decimal, localcontext

import numpy as np
import orjson
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pendfmu.recording import SIGNAL_NAMES, csv_reader, read_recording
from pendfmu.recording.csv_reader import _parse_cells, _parse_json, _parse_plain
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


# The JSON path (orjson) -------------------------------------------------------------------


def orjson_doubles(texts: list[str]) -> np.ndarray:
    """The doubles orjson reads from number texts, as the JSON path converts them."""
    values = orjson.loads(("[" + ",".join(texts) + "]").encode("ascii"))
    return np.fromiter(values, dtype=np.float64, count=len(values))


def assert_orjson_reads_like_float(texts: list[str]) -> None:
    got = orjson_doubles(texts).view(np.uint64)
    want = np.array([float(t) for t in texts], dtype=np.float64).view(np.uint64)
    wrong = np.flatnonzero(got != want)
    assert wrong.size == 0, [(texts[i], float(texts[i]), orjson_doubles([texts[i]])[0]) for i in wrong[:5]]


def random_doubles(rng, n: int) -> list[float]:
    """Finite doubles from uniformly random bit patterns (every exponent, subnormals)."""
    values = rng.integers(0, 2**64, size=n, dtype=np.uint64).view(np.float64)
    return values[np.isfinite(values)].tolist()


def halfway_texts(values: list[float]) -> list[str]:
    """The exact decimal midpoint between each value and its upper neighbour (a parser that
    is not correctly rounded gets these wrong first), and numbers just below and above it."""
    texts = []
    with localcontext() as context:
        context.prec = 1200  # every midpoint of two doubles is exact in 770 digits
        for x in values:
            upper = float(np.nextafter(abs(x), np.inf))
            if np.isfinite(upper):
                middle = (Decimal(abs(x)) + Decimal(upper)) / 2
                nudge = Decimal(10) ** (middle.adjusted() - 40)
                texts += [format(middle, "e"), format(middle - nudge, "e"), format(middle + nudge, "e")]
    return texts


HARD = ["0.1", "0.2", "0.3", "1e-05", "1E-05", "123.456e7", "123.456E+7", "1e23", "8.98846567431158e307",
        "1.7976931348623157e308", "1.7976931348623158e308", "1.797693134862315807e308",
        "2.2250738585072011e-308", "2.2250738585072012e-308", "2.2250738585072014e-308",
        "2.2250738585072011360574097967091319759348195463516e-308", "4.9406564584124654e-324", "5e-324",
        "2.4703282292062327e-324", "2.4703282292062328e-324", "1e-400", "-1e-400", "0e0", "0E-9999", "-0.0",
        "9007199254740993", "9007199254740992.5", "9007199254740993.0000000000000000000001",
        "1.00000000000000011102230246251565404236316680908203125",
        "1.00000000000000011102230246251565404236316680908203124",
        "1.00000000000000011102230246251565404236316680908203126",
        "18446744073709551615", "18446744073709551616", "-9223372036854775808", "-9223372036854775809",
        "123456789012345678901234567890", "1" + "0" * 300, "0." + "0" * 320 + "1", "1." + "0" * 800 + "1"]


def test_orjson_reads_numbers_bit_for_bit_as_float_does():
    """The JSON path's premise, for the orjson installed: correctly rounded like float().
    (Checked once on 27 million texts of these kinds; here a sample that runs in seconds.)"""
    rng = np.random.default_rng(2024)
    doubles = random_doubles(rng, 300_000)
    data = (rng.standard_normal(100_000) * 10.0 ** rng.integers(-12, 12, 100_000)).tolist()
    subnormals = rng.integers(1, 2**52, 50_000, dtype=np.uint64).view(np.float64).tolist()
    powers = [2.0**e for e in range(-1074, 1024)]
    neighbours = [float(np.nextafter(p, d)) for p in powers for d in (0.0, np.inf)]
    mantissas, exponents = rng.integers(0, 10**9, 100_000).tolist(), rng.integers(-30, 30, 100_000).tolist()
    assert_orjson_reads_like_float(
        [repr(x) for x in doubles] + ["%.17g" % x for x in doubles] + ["%.16g" % x for x in doubles[:100_000]]
        + ["%.30e" % x for x in doubles[:50_000]] + [repr(x) for x in data] + ["%.9g" % x for x in data]
        + [repr(x) for x in subnormals] + ["%.25e" % x for x in subnormals]
        + [repr(x) for x in powers + neighbours if np.isfinite(x)]
        + [f"{m}e{e}" for m, e in zip(mantissas, exponents)]
        + [str(m) + "0" * (e + 30) for m, e in zip(mantissas[:20_000], exponents)]  # integers, some beyond 2**64
        + [str(n) for n in rng.integers(2**53, 2**64, 20_000, dtype=np.uint64).tolist()]  # rounded to a double
        + halfway_texts(random_doubles(rng, 20_000) + subnormals[:5_000]) + HARD)


def test_where_orjson_differs_from_float_the_json_path_checks_itself():
    """Why _json_table checks what it checks: a bare -0 is the integer 0 to orjson, true
    and null are numbers to numpy, and orjson refuses what float() reads as inf. (Were
    orjson to change here, the checks would stay right, only some might be dropped.)"""
    assert orjson_doubles(["-0"]).view(np.uint64)[0] != np.float64(-0.0).view(np.uint64)
    assert orjson_doubles(["true", "null"]).tolist()[0] == 1.0  # a number to numpy, not to float()
    with pytest.raises(orjson.JSONDecodeError):
        orjson.loads(b"[1e400]")  # float() reads inf: the path steps aside, the Inf is reported by line


def both_json(path):
    sidecar = _read_sidecar(path.with_suffix(".json"))
    return _parse_json(path, sidecar), _parse_cells(path, sidecar)


JSON_PLAIN = {
    "written by pendfmu": PLAIN["written by pendfmu"],
    "integers, big ones too": "time,x\n0,5\n1,-7\n2,18446744073709551615\n3,-9223372036854775809\n"
                              "4,123456789012345678901234567890\n5,0\n",
    "spaces and tabs around cells": "time , x\n 0.0 , 1.5\n1.0,\t2.5 \n",
    "windows line ends": PLAIN["windows line ends"],
    "byte order mark": PLAIN["byte order mark"],
    "no final newline": PLAIN["no final newline"],
    "blank lines at the end": "time,x\n0.0,1.0\n1.0,2.0\n\n \r\n\t\n",
    "minus signs and exponents": "time,x\n-1e-5,-0.0\n1E-5,-1.5E+3\n2e5,-1e-400\n",
}


@pytest.mark.parametrize("case", sorted(JSON_PLAIN))
def test_json_plain_files_take_the_json_path_with_the_same_values(tmp_path, case):
    path = tmp_path / "rec.csv"
    path.write_text(JSON_PLAIN[case], newline="")
    fast, careful = both_json(path)
    assert fast is not None
    assert_same(fast, careful)


JSON_ASIDE = {
    "a bare -0": "time,x\n0.0,-0\n1.0,2.0\n",
    "a bare -0 before a windows line end": "time,x\r\n0.0,1.0\r\n1.0,-0\r\n",
    "a plus sign": "time,x\n0.0,+1\n",
    "no digit before the point": "time,x\n0.0,.5\n",
    "no digit after the point": "time,x\n0.0,5.\n",
    "a leading zero": "time,x\n0.0,007\n",
    "nan": "time,x\n0.0,nan\n",
    "inf": "time,x\n0.0,-inf\n",
    "beyond the largest double": "time,x\n0.0,1e400\n",
    "a JSON string (a quoted cell)": 'time,x\n0.0,"1.5"\n',
    "old mac line ends": PLAIN["old mac line ends"],
    "a lone carriage return in a row": "time,x\n0.0,1.0\r1.0,2.0\n2.0,3.0\n",
}


@pytest.mark.parametrize("case", sorted(JSON_ASIDE))
def test_other_plain_files_step_aside_from_the_json_path_and_read_the_same(tmp_path, case):
    path = tmp_path / "rec.csv"
    path.write_text(JSON_ASIDE[case], newline="")
    fast, careful = both_json(path)
    assert fast is None
    plain = _parse_plain(path, _read_sidecar(path.with_suffix(".json")))
    assert_same(plain if plain is not None else careful, careful)


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_files_step_aside_from_the_json_path(tmp_path, case):
    path = tmp_path / "rec.csv"
    path.write_text(BAD[case][0])
    assert _parse_json(path, _read_sidecar(path.with_suffix(".json"))) is None


@pytest.mark.parametrize("text, message", [
    ("time,x\n0.0,1.0\n1.0,1 2\n", "line 3, column 'x': '1 2' is not a number"),
    ("time,x\n0.0,1.0\n1.0,,\n", "line 3 has 3 cells"),
    ("time,x\n0.0,1.0\n1.0,true\n", "line 3, column 'x': 'true' is not a number"),
    ("time,x\n0.0,1.0\n1.0,null\n", "line 3, column 'x': 'null' is not a number"),
    ("time,x\n0.0,1.0\n1.0,[1]\n", "line 3, column 'x': '\\[1\\]' is not a number"),
    ("time,x\n0.0,1.0\n1.0,1e400\n", "Inf in column 'x' at line 3"),
    ("time,x\r\r\n0.0,1.0\r\n", "line 2 is empty"),
    ("time,x\n5\n", "line 2 has 1 cells"),
    ("time,x\n0.0,1.0\n5\n", "line 3 has 1 cells"),
    ("time,x\r\n0.0,1.0\r\r\n1.0,2.0\r\n", "line 3 is empty"),
])
def test_files_of_json_values_that_are_not_numbers_get_the_careful_readers_message(tmp_path, text, message):
    """JSON takes these for numbers, blanks or line ends; the careful reader does not."""
    path = tmp_path / "rec.csv"
    path.write_text(text, newline="")
    assert _parse_json(path, _read_sidecar(path.with_suffix(".json"))) is None
    with pytest.raises(ValueError, match=message):
        read_recording(path)


def test_the_json_path_parses_in_chunks_of_whole_lines(tmp_path, monkeypatch):
    """Chunk edges must not split or lose a row: tiny chunks, every edge position."""
    rng = np.random.default_rng(8)
    time = np.arange(500) * 2e-4
    path = write_signals(tmp_path / "rec.csv", time, {"x": rng.normal(size=500), "phi": -rng.random(500)})
    for chunk in (1, 7, 64, 1000):
        monkeypatch.setattr(csv_reader, "JSON_CHUNK_BYTES", chunk)
        fast, careful = both_json(path)
        assert fast is not None
        assert_same(fast, careful)


def test_a_long_random_recording_reads_back_bit_for_bit_by_the_json_path(tmp_path):
    rng = np.random.default_rng(6)
    n = 50_000
    columns = {"x": np.array(random_doubles(rng, 2 * n)[:n]), "phi": rng.normal(size=n) * 1e-3}
    columns["phi"][::7] = -0.0
    path = write_signals(tmp_path / "rec.csv", np.arange(n) * 2e-4, columns)
    fast, careful = both_json(path)
    assert fast is not None
    assert_same(fast, careful)
    assert fast[1]["x"].tobytes() == columns["x"].tobytes()


CELL_FORMS = [repr, lambda x: "%.17g" % x, lambda x: "%.3g" % x, lambda x: "%.5E" % x,
              lambda x: str(int(x)) if abs(x) < 1e30 else repr(x)]
finite = st.floats(allow_nan=False, allow_infinity=False)
cells = st.tuples(finite, st.sampled_from(range(len(CELL_FORMS))), st.sampled_from(["", " ", "\t", "  "]),
                  st.sampled_from(["", " ", "\t"]))


@settings(max_examples=150, derandomize=True, deadline=None)
@given(st.integers(1, 4).flatmap(lambda width: st.lists(st.lists(cells, min_size=width, max_size=width),
                                                         min_size=1, max_size=12)),
       st.sampled_from(["\n", "\r\n"]), st.sampled_from(["", "\n", "\n\n", "\r\n \n"]),
       st.sampled_from(["0.0", "-0", "-0.0"]))
def test_any_json_plain_file_reads_like_the_careful_reader(tmp_path_factory, rows, end, trailer, zero):
    """Random cells in every form float() and JSON share, blanks around them, both line
    ends: what the reader takes (the JSON path, or where it steps aside loadtxt or the
    careful reader) gives the careful reader's arrays bit for bit; and the JSON path
    takes every file without a bare -0 ("%.3g" writes one for -0.0) or a number beyond
    the largest double ("%.3g" rounds 1.795e308 up to 1.8e+308, which float() reads as inf)."""
    width = len(rows[0])
    texts = [[zero if k == 0 else f"{k}"] + [f"{a}{CELL_FORMS[form](x)}{b}" for x, form, a, b in row]
             for k, row in enumerate(rows)]
    lines = ["time," + ",".join(SIGNAL_NAMES[:width])] + [",".join(row) for row in texts]
    path = tmp_path_factory.mktemp("json") / "rec.csv"
    path.write_text(end.join(lines) + trailer, newline="")
    sidecar = _read_sidecar(path.with_suffix(".json"))
    careful = _parse_cells(path, sidecar)
    assert_same(_parse_plain(path, sidecar) or careful, careful)
    if all(cell.strip() != "-0" and math.isfinite(float(cell)) for row in texts for cell in row):
        assert_same(_parse_json(path, sidecar), careful)
