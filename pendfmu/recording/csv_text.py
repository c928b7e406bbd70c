"""Tables of doubles as CSV text, exact and fast: the text of every number reads back to
the same float64, bit for bit, and is as short as Python's ``repr`` makes it.

Why not the obvious ways:

* ``repr`` per cell (what :func:`write_recording` did) or pandas' ``to_csv``: exact, but
  about 1 µs per number in Python; the 100,001 x 7 table of a 20 s simulation at 0.2 ms
  took 0.6 s, three times the simulation itself.
* ``"%.17g"``: exact but not shortest (0.1 becomes 0.10000000000000001), and no faster.

orjson serializes a float64 array in native code with a shortest round-trip algorithm
(the same significant digits as ``repr``; only the notation of some exponents differs,
e.g. ``0.00001`` for ``1e-05``), about 18 ns per number. A flat array of whole rows gives
``[v0,v1,...]``: dropping the brackets and turning every n-th comma into a newline (the
commas found by one vectorized comparison, none is inside a number) makes it the CSV
lines of an n-column table.

The table is serialized a block of rows at a time (ROWS_PER_BLOCK), each block's text
copied into one output buffer and its commas found while it is still in the cache: for
the 100,001 x 7 table, 18 ms instead of 22 ms for the whole table in one piece (orjson
itself takes 12.5 of them). Measured and not taken: serializing the table as 2-D
(``[[a,b],[c,d]]``) and replacing ``],[`` by a newline, 34 ms (the 2-D dump is 2.5 ms
slower, and bytes.replace searches a 3-byte pattern twice over the 13 MB, 18 ms), or
splitting on ``],[`` and joining, 37 ms; finding the commas in a second thread while
orjson serializes the next block, no faster.

JSON has no NaN or Inf (orjson writes ``null``): a table with a non-finite value is
written with ``repr`` instead (``nan``, ``inf``, ``-inf``: what ``float()`` and pandas read).
"""

from __future__ import annotations

import numpy as np
import orjson

from pendfmu.recording.schema import RecordingError

_COMMA, _NEWLINE = ord(","), ord("\n")

ROWS_PER_BLOCK = 1024
"""Rows serialized at a time: for 7 columns about 150 kB of text, which stays in the cache
while its commas are found (2048 and 4096 rows were as fast, 8192 and more slower)."""

_MOST_BYTES_PER_NUMBER = 25
"""The longest text orjson writes for a double and its comma (``-2.2250738585072014e-308,``
is 25 bytes): the output buffer is sized for it, its unused end never touched."""

_FORBIDDEN_IN_NAMES = (",", '"', "\n", "\r")


def header_line(names) -> bytes:
    """The header row; a name that would need CSV quoting is refused (no reader of ours
    or of the usual tools should have to guess)."""
    for name in names:
        if not name or any(c in name for c in _FORBIDDEN_IN_NAMES) or name != name.strip():
            raise RecordingError(f"column name {name!r} cannot be written as a CSV header: it must be non-empty, "
                             f"without commas, quotes, line breaks or surrounding spaces")
    return ",".join(names).encode("utf-8") + b"\n"


def format_rows(table: np.ndarray) -> bytes | memoryview:
    """The rows of a 2-D float64 table (rows x columns) as CSV lines, each ending in a
    newline; a bytes-like object (a view, so the 10 MB of a long run are not copied)."""
    table = np.ascontiguousarray(table, dtype=np.float64)
    if table.ndim != 2:
        raise RecordingError(f"format_rows needs a 2-D table, got shape {table.shape}")
    rows, width = table.shape
    if rows == 0:
        return b""
    if not np.isfinite(table).all():
        return "".join(",".join(map(repr, row)) + "\n" for row in table.tolist()).encode("ascii")
    out = np.empty(table.size * _MOST_BYTES_PER_NUMBER, dtype=np.uint8)  # pages are touched as filled
    end = 0
    for first in range(0, rows, ROWS_PER_BLOCK):
        text = np.frombuffer(orjson.dumps(table[first:first + ROWS_PER_BLOCK].reshape(-1),
                                          option=orjson.OPT_SERIALIZE_NUMPY), dtype=np.uint8)
        if end + text.size > out.size:  # not with today's orjson (see _MOST_BYTES_PER_NUMBER)
            out = np.concatenate([out[:end], np.empty(max(out.size, text.size), dtype=np.uint8)])
        end = _put_lines(out, end, text[1:], width)
    return memoryview(out)[:end]


def _put_lines(out: np.ndarray, end: int, numbers: np.ndarray, width: int) -> int:
    """Copy the text of a block of whole rows (orjson's ``v0,v1,...]``) into `out` at
    `end` as CSV lines, and return the new end: every `width`-th comma and the closing
    bracket become newlines."""
    start, end = end, end + numbers.size
    out[start:end] = numbers
    commas = np.flatnonzero(numbers == _COMMA)  # none inside a number
    out[start + commas[width - 1::width]] = _NEWLINE
    out[end - 1] = _NEWLINE
    return end
