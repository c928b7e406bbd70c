"""CSV recordings: a header row, a first column `time`, one column per signal. Every
problem names the file, the column and the line."""

from __future__ import annotations

import csv
from array import array
from pathlib import Path

import numpy as np

from pendfmu.recording.schema import RecordingError
from pendfmu.recording.model import Recording, _check_finite, _check_time
from pendfmu.recording.sidecar import _Sidecar, _build, _select_columns


def _read_csv(path: Path, sidecar: _Sidecar) -> Recording:
    """Parse the CSV cell by cell with Python's float() (exact, shortest-repr round
    trip) into one flat array of doubles, so memory stays near 8 bytes per cell."""
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
    time = table[:, 0].copy()
    signals = {name: table[:, i + 1].copy() for i, name in enumerate(keep)}
    where = _csv_line_locator
    _check_time(time, src, "column 'time'", where)
    for name, values in signals.items():
        _check_finite(values, src, f"column {name!r}", where)
    return _build(path, time, signals, sidecar, ignored)


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
