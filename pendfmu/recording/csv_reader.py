"""CSV recordings: a header row, a first column `time`, one column per signal. Every
problem names the file, the column and the line.

Two ways in, one result. A plain file (UTF-8, a header without quotes, then rows of
numbers, the same count in every row, no blank line before the end) is parsed by numpy's
loadtxt in C: 5x faster than cell by cell, and its numbers are Python's own (loadtxt
strips the same whitespace and calls PyOS_string_to_double, the function behind
float()), so the arrays are bit-identical. Anything else, and every file with a
problem, is read cell by cell with the csv module and float(), which says which line
and column are wrong. The fast path never reports an error itself: when it meets one it
steps aside, so the messages are the careful reader's.
"""

from __future__ import annotations

import csv
import io
from array import array
from pathlib import Path

import numpy as np

from pendfmu.recording.schema import RecordingError
from pendfmu.recording.model import Recording, _check_finite, _check_time
from pendfmu.recording.sidecar import _Sidecar, _build, _select_columns


FAST_MAX_BYTES = 256 * 1024**2
"""Larger files are read cell by cell, streaming: the fast path holds the whole text."""


def _read_csv(path: Path, sidecar: _Sidecar) -> Recording:
    """Read a CSV recording: the fast path for a plain file, else cell by cell."""
    parsed = _parse_plain(path, sidecar) or _parse_cells(path, sidecar)
    time, signals, ignored = parsed
    where = _csv_line_locator
    src = str(path)
    _check_time(time, src, "column 'time'", where)
    for name, values in signals.items():
        _check_finite(values, src, f"column {name!r}", where)
    return _build(path, time, signals, sidecar, ignored)


def _parse_plain(path: Path, sidecar: _Sidecar):
    """(time, signals, ignored) of a plain file, parsed by numpy.loadtxt; None for any
    other file, or any problem (see the module docstring)."""
    try:
        if path.stat().st_size > FAST_MAX_BYTES:
            return None
        text = path.read_text(encoding="utf-8-sig")
        first, _, body = text.partition("\n")
        body = body.rstrip("\n")
        if '"' in first or not body.strip():
            return None
        header = _csv_header(csv.reader([first]), str(path))
        keep, ignored = _select_columns(header[1:], sidecar, str(path), "column")
        rows = body.count("\n") + 1
        table = np.loadtxt(io.StringIO(body), delimiter=",", comments=None, dtype=np.float64, ndmin=2)
    except Exception:  # noqa: BLE001 - the careful reader says what is wrong
        return None
    if table.shape != (rows, len(header)):  # loadtxt skips blank lines; the careful reader refuses them
        return None
    signals = {name: table[:, 1 + header[1:].index(name)].copy() for name in keep}
    return table[:, 0].copy(), signals, ignored


def _parse_cells(path: Path, sidecar: _Sidecar):
    """(time, signals, ignored): the CSV parsed cell by cell with Python's float() into
    one flat array of doubles, so memory stays near 8 bytes per cell."""
    src = str(path)
    try:
        with open(path, newline="", encoding="utf-8-sig") as handle:
            reader = csv.reader(handle)
            header = _csv_header(reader, src)
            keep, ignored = _select_columns(header[1:], sidecar, src, "column")
            columns = [0] + [1 + header[1:].index(name) for name in keep]
            data, rows = _csv_rows(reader, header, columns, src)
    except UnicodeDecodeError as exc:
        raise RecordingError(f"{src}: not UTF-8 text (byte {exc.start}); save the CSV as UTF-8") from None
    except csv.Error as exc:
        raise RecordingError(f"{src}: line {reader.line_num}: {exc}") from None
    except OSError as exc:
        raise RecordingError(f"{src}: cannot read: {exc.strerror}") from None
    if rows == 0:
        raise RecordingError(f"{src}: header only, no data rows")
    table = np.frombuffer(data, dtype=np.float64).reshape(rows, len(columns))
    return table[:, 0].copy(), {name: table[:, i + 1].copy() for i, name in enumerate(keep)}, ignored


def _csv_header(reader, src: str) -> list[str]:
    """The header row, stripped; checks the names are usable before any data is read."""
    header = next(reader, None)
    if header is None:
        raise RecordingError(f"{src}: empty file")
    names = [cell.strip() for cell in header]
    if not any(names):
        if all(not any(cell.strip() for cell in row) for row in reader):
            raise RecordingError(f"{src}: empty file")
        raise RecordingError(f"{src}: line 1 is empty; the first line must be the header (time, signal names)")
    if names[0] != "time":
        hint = ""
        if names[0].startswith("#"):
            hint = "; comment lines are not supported, the header must be line 1"
        elif len(names) == 1 and any(sep in names[0] for sep in "; \t"):
            hint = "; the separator must be a comma and line 1 has none"
        elif "time" in names:
            hint = f"; 'time' is column {names.index('time') + 1}, it must be the first"
        listing = f" (header: {', '.join(names)})" if len(names) > 1 else ""
        raise RecordingError(f"{src}: line 1: the first column must be 'time', found {names[0]!r}{hint}{listing}")
    for i, name in enumerate(names):
        if not name:
            raise RecordingError(f"{src}: line 1: column {i + 1} has no name")
        if names.index(name) != i:
            raise RecordingError(f"{src}: line 1: column {name!r} appears twice (columns {names.index(name) + 1} "
                                 f"and {i + 1})")
    if len(names) == 1:
        raise RecordingError(f"{src}: line 1: only a 'time' column, no signals")
    return names


def _csv_rows(reader, header: list[str], columns: list[int], src: str) -> tuple[array, int]:
    """All data rows, the kept columns converted to float, as one flat array."""
    data = array("d")
    width = len(header)
    rows = 0
    blank_line = 0
    everything = columns == list(range(width))
    for row in reader:
        if not any(cell.strip() for cell in row):
            blank_line = blank_line or reader.line_num
            continue
        if blank_line:
            raise RecordingError(f"{src}: line {blank_line} is empty; blank lines are allowed only at the end")
        if len(row) != width:
            raise RecordingError(f"{src}: line {reader.line_num} has {len(row)} cells, the header has {width}")
        cells = row if everything else [row[i] for i in columns]
        try:
            data.extend(map(float, cells))
        except ValueError:
            raise _bad_cell(src, reader.line_num, cells, [header[i] for i in columns]) from None
        rows += 1
    return data, rows


def _bad_cell(src: str, line: int, cells: list[str], names: list[str]) -> RecordingError:
    """The error for the first cell of a row that float() rejects."""
    for cell, name in zip(cells, names):
        try:
            float(cell)
        except ValueError:
            what = "an empty cell" if not cell.strip() else f"{cell.strip()!r}"
            return RecordingError(f"{src}: line {line}, column {name!r}: {what} is not a number")
    return RecordingError(f"{src}: line {line}: not a number")  # unreachable: float() failed above


def _csv_line_locator(index: int) -> str:
    """Data row `index` (0-based) is file line index + 2: header on line 1, no blank lines."""
    return f"line {index + 2}"
