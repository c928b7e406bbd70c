"""CSV recordings: a header row, a first column `time`, one column per signal. Every
problem names the file, the column and the line.

Three ways in, one result. Cell by cell with the csv module and float() is the careful
reader: it reads anything a CSV may hold and says which line and column are wrong, but
costs about 1 µs a number. Two fast paths take the plain files (UTF-8, a header without
quotes, then rows of numbers, the same count in every row, no blank line before the end)
and never report an error themselves: when they meet one they step aside, so every
message is the careful reader's.

* The usual file, numbers as JSON writes them (what pendfmu and most tools write): the
  body becomes a JSON array, which orjson parses in native code (40 to 80 ns a number,
  checks included: a half to a third of loadtxt's time). orjson's numbers are float()'s
  bit for bit, correctly rounded: checked on 27 million texts (random doubles in several
  formats, exact halfway cases, subnormals, long and integer texts) with orjson 3.13,
  and on a sample of them by tests/test_csv_paths.py, which is what tells for another
  version. Its two differences are checked for here: a bare ``-0`` is the integer 0 to
  orjson, -0.0 to float() (so the count of values with the sign bit set must equal the
  count of leading minus signs), and JSON has values that are not numbers (``true``,
  ``null``, strings: only number characters may be in a cell). The rows are checked in
  one pass before any number is read: with the number characters deleted, the body must
  be exactly width - 1 commas and a newline per row.
* Any other plain file (``+1``, ``.5``, ``1.``, ``nan``, line ends other than ``\n`` and
  ``\r\n``) is parsed by numpy's loadtxt in C, 5x faster than cell by cell; its numbers
  are Python's own (loadtxt strips the same whitespace and calls PyOS_string_to_double,
  the function behind float()).

Files from spreadsheets in many European locales separate cells with ``;`` (or a tab)
and write decimal commas (``0,5``): when line 1 has a semicolon or a tab and no comma,
that is the separator, and a comma in a cell is its decimal mark; such files take the
careful reader. The time column may be spelled as tools write it: ``time``, ``t``,
``Time``, ``time [s]``, ``t (s)``, ``time/s``, ``time_s`` (TIME_NAMES); another unit is
refused with a message rather than read as seconds.
"""

from __future__ import annotations

import codecs
import csv
import io
import re
from array import array
from pathlib import Path

import numpy as np
import orjson

from pendfmu.recording.schema import RecordingError
from pendfmu.recording.model import Recording, _check_finite, _check_time
from pendfmu.recording.sidecar import _Sidecar, _build, _missing, _select_columns


FAST_MAX_BYTES = 256 * 1024**2
"""Larger files are read cell by cell, streaming: the fast paths hold the whole text."""

JSON_CHUNK_BYTES = 256 * 1024
"""orjson parses this much of the body at a time (whole lines): its Python floats cost
32 bytes a number, a chunk bounds them; and a small chunk is parsed in the cache (a
13 MB body in one piece took 1.7 times as long)."""

_SIGNS = b"-eE"
_NUMBER_BYTES = b"0123456789.+ \t"
"""With _SIGNS, what a cell of a JSON-plain file may hold: JSON's number characters, and
the blanks that JSON, loadtxt and float() all skip. Kept apart because the minus signs
are counted (see _json_table)."""


TIME_NAMES = re.compile(r"^(t|time)\s*(\[\s*s\s*\]|\(\s*s\s*\)|/\s*s|_s)?$", re.IGNORECASE)
"""The first column's spellings read as time in seconds."""
TIME_OTHER_UNIT = re.compile(r"^(t|time)\s*(\[\s*(\w+)\s*\]|\(\s*(\w+)\s*\)|/\s*(\w+))$", re.IGNORECASE)


def _separator(path: Path) -> str:
    """The cell separator, from line 1: a comma unless the line has none and has a
    semicolon (or else a tab). Unreadable files get the comma: the readers say why."""
    try:
        with open(path, encoding="utf-8-sig", errors="replace", newline="") as handle:
            first = handle.readline()
    except OSError:
        return ","
    if "," in first:
        return ","
    return ";" if ";" in first else "\t" if "\t" in first else ","


def signal_columns(path: Path) -> list[str]:
    """The signal columns line 1 of a CSV recording names (after time), split by the same
    separator rule the reader uses; nothing for a file that cannot be read (the reader
    then says why)."""
    try:
        with open(path, encoding="utf-8-sig", newline="") as handle:
            header = next(csv.reader(handle, delimiter=_separator(path)), [])
    except (OSError, UnicodeDecodeError, csv.Error):
        return []
    return [name.strip() for name in header[1:] if name.strip()]


def _read_csv(path: Path, sidecar: _Sidecar) -> Recording:
    """Read a CSV recording: the fast path for a plain file, else cell by cell."""
    separator = _separator(path)
    parsed = (_parse_plain(path, sidecar) if separator == "," else None) or _parse_cells(path, sidecar, separator)
    time, signals, ignored = parsed
    where = _csv_line_locator
    src = str(path)
    _check_time(time, src, "column 'time'", where)
    for name, values in signals.items():
        _check_finite(values, src, f"column {name!r}", where, _missing(sidecar, name), name)
    return _build(path, time, signals, sidecar, ignored)


def _parse_plain(path: Path, sidecar: _Sidecar):
    """(time, signals, ignored) of a plain file; None for any other file, or any problem
    (see the module docstring)."""
    return _parse_json(path, sidecar) or _parse_loadtxt(path, sidecar)


def _parse_json(path: Path, sidecar: _Sidecar):
    """(time, signals, ignored) of a file whose cells are all JSON numbers, parsed by
    orjson; None for any other file."""
    try:
        if path.stat().st_size > FAST_MAX_BYTES:
            return None
        lines = _json_lines(path.read_bytes())
        if lines is None:
            return None
        first, body = lines
        header, keep, ignored = _plain_header(first, bool(body), path, sidecar)  # body: stripped already
        table = _json_table(body, len(header))
    except Exception:  # noqa: BLE001 - the other readers say what is wrong
        return None
    return None if table is None else _plain_columns(table, header, keep, ignored)


def _json_lines(raw: bytes) -> tuple[str, bytes] | None:
    """The header (text) and the body of a file (bytes, rows split by ``\n``, no line
    break or blank at the end); None if the header line ends otherwise than in ``\n`` or
    ``\r\n``. A lone ``\r`` is a line break to universal newlines (loadtxt's path) and to
    the csv module, a blank to JSON: in the body the row check refuses it."""
    start = len(codecs.BOM_UTF8) if raw.startswith(codecs.BOM_UTF8) else 0
    newline = raw.find(b"\n", start)
    if newline < 0:
        return None
    end = len(raw)
    while end > newline and raw[end - 1] in b" \t\r\n":  # one slice below, not two copies of the body
        end -= 1
    first, body = raw[start:newline].removesuffix(b"\r"), raw[newline + 1:end]
    if b"\r" in first:
        return None
    return first.decode("utf-8"), body.replace(b"\r\n", b"\n") if b"\r" in body else body


def _json_table(body: bytes, width: int) -> np.ndarray | None:
    """The rows x width numbers of the body; None unless every row has `width` cells, all
    of them JSON numbers that float() reads the same (the module docstring)."""
    marks = body.translate(None, _NUMBER_BYTES)  # the separators, _SIGNS, and anything else
    separators = marks.translate(None, _SIGNS)
    rows = separators.count(b"\n") + 1
    if separators != ((b"," * (width - 1) + b"\n") * rows)[:-1]:
        return None  # a ragged row, a blank line, or a character that is not in a number
    table = _json_numbers(body, rows * width).reshape(rows, width)
    minus_signs = marks.count(b"-") - marks.count(b"e-") - marks.count(b"E-")  # not an exponent's
    if np.count_nonzero(np.signbit(table)) != minus_signs:
        return None  # a bare -0: orjson reads the integer 0, float() -0.0
    return table


def _json_numbers(body: bytes, count: int) -> np.ndarray:
    """The `count` numbers of a checked body, parsed by orjson a chunk of whole lines at a
    time (JSON_CHUNK_BYTES); orjson's integers (cells without a point or an exponent)
    become doubles as float() makes them, correctly rounded."""
    numbers = np.empty(count)
    filled = start = 0
    while start < len(body):
        end = body.find(b"\n", start + JSON_CHUNK_BYTES)
        end = len(body) if end < 0 else end
        values = orjson.loads(b"".join((b"[", body[start:end].replace(b"\n", b","), b"]")))
        values = np.fromiter(values, dtype=np.float64, count=len(values))
        numbers[filled:filled + values.size] = values
        filled += values.size
        start = end + 1
    if filled != count:
        raise ValueError(f"{filled} numbers, expected {count}")  # unreachable after the row check
    return numbers


def _parse_loadtxt(path: Path, sidecar: _Sidecar):
    """(time, signals, ignored) of a plain file, parsed by numpy.loadtxt; None for any
    other file, or any problem."""
    try:
        if path.stat().st_size > FAST_MAX_BYTES:
            return None
        text = path.read_text(encoding="utf-8-sig")
        first, _, body = text.partition("\n")
        body = body.rstrip("\n")
        header, keep, ignored = _plain_header(first, bool(body.strip()), path, sidecar)
        rows = body.count("\n") + 1
        table = np.loadtxt(io.StringIO(body), delimiter=",", comments=None, dtype=np.float64, ndmin=2)
    except Exception:  # noqa: BLE001 - the careful reader says what is wrong
        return None
    if table.shape != (rows, len(header)):  # loadtxt skips blank lines; the careful reader refuses them
        return None
    return _plain_columns(table, header, keep, ignored)


def _plain_header(first: str, has_rows: bool, path: Path, sidecar: _Sidecar):
    """(header, kept names, ignored names) of a plain file's first line; raises for any
    other file: a quoted header, no rows, a bad name."""
    if '"' in first or not has_rows:
        raise ValueError("not a plain file")
    header = _csv_header(csv.reader([first]), str(path))
    keep, ignored = _select_columns(header[1:], sidecar, str(path), "column")
    return header, keep, ignored


def _plain_columns(table: np.ndarray, header: list[str], keep: list[str], ignored):
    """(time, signals, ignored) from the rows x columns table of a plain file."""
    signals = {name: table[:, 1 + header[1:].index(name)].copy() for name in keep}
    return table[:, 0].copy(), signals, ignored


def _parse_cells(path: Path, sidecar: _Sidecar, separator: str = ","):
    """(time, signals, ignored): the CSV parsed cell by cell with Python's float() into
    one flat array of doubles, so memory stays near 8 bytes per cell. With a separator
    other than the comma, a comma in a cell is a decimal mark."""
    src = str(path)
    try:
        with open(path, newline="", encoding="utf-8-sig") as handle:
            reader = csv.reader(handle, delimiter=separator)
            header = _csv_header(reader, src)
            keep, ignored = _select_columns(header[1:], sidecar, src, "column")
            columns = [0] + [1 + header[1:].index(name) for name in keep]
            data, rows = _csv_rows(reader, header, columns, src, decimal_comma=separator != ",")
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
    other_unit = TIME_OTHER_UNIT.match(names[0])
    if TIME_NAMES.match(names[0]):
        names[0] = "time"
    elif other_unit:
        unit = next(u for u in other_unit.groups()[2:] if u)
        raise RecordingError(f"{src}: line 1: the time column {names[0]!r} is in {unit!r}; pendfmu reads time in "
                             f"seconds: convert it, or name the column 'time' if it is in seconds")
    if names[0] != "time":
        hint = ""
        if names[0].startswith("#"):
            hint = "; comment lines are not supported, the header must be line 1"
        elif ";" in names[0]:
            hint = "; line 1 has both ';' and ',': in a ';'-separated file the header must hold no comma"
        elif len(names) == 1 and " " in names[0]:
            hint = "; cells must be separated by commas, semicolons or tabs and line 1 has none"
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


def _csv_rows(reader, header: list[str], columns: list[int], src: str,
              decimal_comma: bool = False) -> tuple[array, int]:
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
            data.extend(map(float, [cell.replace(",", ".") for cell in cells] if decimal_comma else cells))
        except ValueError:
            raise _bad_cell(src, reader.line_num, cells, [header[i] for i in columns], decimal_comma) from None
        rows += 1
    return data, rows


def _bad_cell(src: str, line: int, cells: list[str], names: list[str], decimal_comma: bool = False) -> RecordingError:
    """The error for the first cell of a row that float() rejects, shown as written."""
    for cell, name in zip(cells, names):
        try:
            float(cell.replace(",", ".") if decimal_comma else cell)
        except ValueError:
            what = "an empty cell" if not cell.strip() else f"{cell.strip()!r}"
            return RecordingError(f"{src}: line {line}, column {name!r}: {what} is not a number")
    return RecordingError(f"{src}: line {line}: not a number")  # unreachable: float() failed above


def _csv_line_locator(index: int) -> str:
    """Data row `index` (0-based) is file line index + 2: header on line 1, no blank lines."""
    return f"line {index + 2}"
