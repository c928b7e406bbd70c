"""Recordings: the measured time responses that start pendfmu's one-way flow.

recording -> experiment -> simulator -> residuals -> optimizer -> result -> report

A :class:`Recording` is one run on the rig: a time vector and the signals recorded
against it, plus what the sidecar JSON says about them (``MODEL.md``, "Recordings on
disk"). Everything later in the flow trusts a Recording, so every check happens here,
once, and every failure is a :class:`RecordingError` with a one-line message that names
the file, the column and the line (or the JSON key) -- a user with a 2 GB logger export
must be able to find the bad cell from the message alone.

Files read by :func:`read_recording`
------------------------------------
CSV (``.csv``, any case of the suffix), UTF-8 (a BOM is allowed), comma separated:

* line 1 is the header; the first column is ``time`` [s], the others are named as the
  components' inputs/outputs (:data:`SIGNAL_NAMES`: ``I_c, I, x, v, a, F_A, phi, w,
  alpha, T_A``), case-sensitive;
* every following line holds one number per column; time stamps strictly increase but
  need not be evenly spaced; NaN and Inf are refused (a gap in a measurement is not a
  value a fit can compare with);
* blank lines are allowed only at the end; comment lines are not supported. Error
  messages give file line numbers (the header is line 1).

MATLAB v5 ``.mat`` (what ``save`` writes by default and ``scipy.io.loadmat`` reads;
v7.3/HDF5 files are refused with a hint). Exactly one of these layouts must be present:

1. *Plain variables*: a time vector named ``time``, ``t`` or ``tout`` and one vector
   per signal, named as the signal (``save run1.mat t x phi``). Other numeric vectors of
   the same length count as columns (so they must be signals or be ignored, see below);
   scalars, matrices, strings, cells and structs are skipped and listed in
   :attr:`Recording.ignored`.
2. *A struct with plain fields*: the same as 1, inside one top-level struct
   (``rec.time``, ``rec.x``, ...).
3. *Simulink "Structure with time"* (To Workspace block, scope, root outports):
   a struct with ``time`` (a vector) and ``signals``, a struct array whose elements hold
   ``values`` (one column) and ``label`` (the signal name; name the signal lines in the
   model). ``blockName``/``dimensions`` are allowed and unused. Simulink's "Structure"
   format (``time`` empty) is refused with a hint.
4. *Timeseries-like structs*: one or more top-level structs with fields ``Time`` and
   ``Data`` (and optionally ``Name``, else the variable name is the signal name), e.g.
   ``struct(ts)`` of MATLAB timeseries objects. All must share the same ``Time``.

MATLAB objects (``timeseries``, ``Simulink.SimulationData.Dataset``) and cell arrays
are not readable this way; the error lists every variable found with its MATLAB class
and size. A file in any other layout is brought in by a small adapter that builds a
``Recording(...)`` from arrays: the constructor runs the same checks.

Columns that are not signals
----------------------------
Loggers write more than the fit needs (raw counts, PWM duty, latency). An unknown
column name is an error by default, because the common cause is a typo (``Phi``,
``i_c``) that would otherwise only surface later as "no signal phi". A column is kept
out on purpose by marking it in the sidecar: ``"signals": {"pwm": {"ignore": true}}``;
ignored columns are not parsed, not kept and are listed in ``Recording.ignored``.

The sidecar (``run1.csv`` -> ``run1.json``, ``run1.mat`` -> ``run1.json``), optional,
strict JSON (no comments; a ``"comment"`` key holds free text)::

    {"experiment": "cart-startup",
     "signals": {"x": {"resolution": 9.765625e-06, "quantizer": "round"},
                 "pwm": {"ignore": true}},
     "parameters": {"m_p": 0.0},
     "initial": {"phi": 3.6416}}

Every name in it is checked: ``signals`` keys must be columns of the file, parameters
must be parameters of a component (and inside its allowed range), ``initial`` keys must
be states (:data:`INITIAL_NAMES`).
"""

from __future__ import annotations

import csv
import difflib
import json
import math
import numbers
import os
import tempfile
from array import array
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pendfmu.components import COMPONENTS


def _signal_names() -> tuple[str, ...]:
    """Inputs and outputs of all components, in table order: the only column names."""
    names: dict[str, None] = {}
    for component in COMPONENTS.values():
        for var in component.variables:
            if var.causality in ("input", "output"):
                names[var.name] = None
    return tuple(names)


def _parameter_names() -> tuple[str, ...]:
    """Parameters of all components, each once (m_p and l are shared by two)."""
    names: dict[str, None] = {}
    for component in COMPONENTS.values():
        names.update(dict.fromkeys(component.parameters))
    return tuple(names)


def _initial_names() -> tuple[str, ...]:
    """Signals whose initial value fixes a state: outputs that are states (x, v, phi, w)
    and outputs computed from one state alone (I, from the current loop's I_mean)."""
    names: dict[str, None] = {}
    for component in COMPONENTS.values():
        states = {v.name for v in component.states}
        for var in component.of(causality="output"):
            if var.state or (var.depends_on is not None and len(var.depends_on) == 1
                             and var.depends_on[0] in states):
                names[var.name] = None
    return tuple(names)


SIGNAL_NAMES: tuple[str, ...] = _signal_names()
"""Valid column names of a recording: the components' inputs and outputs."""

PARAMETER_NAMES: tuple[str, ...] = _parameter_names()
"""Valid keys of the sidecar's ``parameters``."""

INITIAL_NAMES: tuple[str, ...] = _initial_names()
"""Valid keys of the sidecar's ``initial``: signals that are (or follow one) state."""

QUANTIZERS: tuple[str, ...] = ("round", "floor")
"""How a reading is quantized: ``round`` is MODEL.md's default, ``floor`` what a
counter that truncates reports."""

MAT_TIME_NAMES: tuple[str, ...] = ("time", "t", "tout")
"""Names under which a .mat file's time vector is recognised (``tout``: Simulink)."""

MAX_BYTES: int = 2 * 1024**3
"""Default size limit of a recording file; :func:`read_recording` refuses larger files
before reading them, rather than letting the machine swap."""

SIDECAR_KEYS: tuple[str, ...] = ("experiment", "signals", "parameters", "initial", "comment")
SIGNAL_INFO_KEYS: tuple[str, ...] = ("resolution", "quantizer", "noise", "ignore")


class RecordingError(ValueError):
    """A recording (or its sidecar) that cannot be used; the message says where and why."""


# --------------------------------------------------------------------------- the data


@dataclass(frozen=True)
class SignalInfo:
    """How one signal was measured. ``resolution`` is the quantization step Δ in the
    signal's unit (None: not stated, e.g. an unquantized or unknown sensor); ``noise`` the
    standard deviation of the sensor noise before quantization (None: not stated)."""

    resolution: float | None = None
    quantizer: str = "round"
    noise: float | None = None

    def __post_init__(self) -> None:
        problem = (_resolution_problem(self.resolution) or _quantizer_problem(self.quantizer)
                   or _noise_problem(self.noise))
        if problem:
            raise RecordingError(f"SignalInfo: {problem}")


@dataclass(frozen=True, eq=False)
class Recording:
    """One recorded run: ``time`` [s] and the signals sampled at those instants.

    Signals are a ``dict`` of 1-D float64 numpy arrays rather than a pandas DataFrame:
    the simulator and the residuals index them by name and compute with numpy; a dict
    keeps the exact float64 values, has no index that duplicates ``time`` and cannot
    hold a non-numeric column. :meth:`to_frame` gives a DataFrame for plotting.

    The constructor checks everything :func:`read_recording` checks (names, lengths,
    finite values, strictly increasing time, sidecar names), so an adapter for an
    unusual file format just builds a Recording from arrays. The arrays are copied and
    made read-only: a recording is measured data, later stages must not edit it.
    Vector-shaped arrays (N x 1 or 1 x N, as MATLAB stores them) are flattened.
    """

    path: Path | None
    time: np.ndarray
    signals: dict[str, np.ndarray]
    experiment: str = ""
    signal_info: dict[str, SignalInfo] = field(default_factory=dict)
    parameters: dict[str, float] = field(default_factory=dict)
    initial: dict[str, float] = field(default_factory=dict)
    ignored: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        path = None if self.path is None else Path(self.path)
        object.__setattr__(self, "path", path)
        src = self.source
        where = _sample_locator
        time = _as_vector(self.time, src, "time")
        _check_time(time, src, "time", where)
        signals: dict[str, np.ndarray] = {}
        for name, values in dict(self.signals).items():
            if name not in SIGNAL_NAMES:
                raise RecordingError(f"{src}: {name!r} is not a signal name{_suggest(name, SIGNAL_NAMES)}; "
                                     f"valid: {', '.join(SIGNAL_NAMES)}")
            values = _as_vector(values, src, repr(name))
            _check_length(values, time, src, repr(name))
            _check_finite(values, src, repr(name), where)
            signals[name] = values
        if not signals:
            raise RecordingError(f"{src}: no signals, only time")
        for name, info in dict(self.signal_info).items():
            if name not in signals:
                raise RecordingError(f"{src}: signal_info for {name!r}, which is not a signal of this recording "
                                     f"(signals: {', '.join(signals)})")
            if not isinstance(info, SignalInfo):
                raise RecordingError(f"{src}: signal_info[{name!r}] must be a SignalInfo, got {type(info).__name__}")
        if not isinstance(self.experiment, str):
            raise RecordingError(f"{src}: experiment must be a string, got {type(self.experiment).__name__}")
        parameters = _checked_values(self.parameters, _parameter_problem, src, "parameters")
        initial = _checked_values(self.initial, _initial_problem, src, "initial")
        object.__setattr__(self, "time", _frozen(time))
        object.__setattr__(self, "signals", {n: _frozen(v) for n, v in signals.items()})
        object.__setattr__(self, "signal_info", dict(self.signal_info))
        object.__setattr__(self, "parameters", parameters)
        object.__setattr__(self, "initial", initial)
        object.__setattr__(self, "ignored", tuple(self.ignored))

    @property
    def source(self) -> str:
        """The file this recording came from, as error messages name it."""
        return "<recording in memory>" if self.path is None else str(self.path)

    @property
    def names(self) -> tuple[str, ...]:
        """Signal names in file order."""
        return tuple(self.signals)

    def signal(self, name: str) -> np.ndarray:
        """The samples of signal `name`; a missing one is an error naming file and column."""
        if name not in self.signals:
            hint = "" if name in SIGNAL_NAMES else (
                f"; {name!r} is not a signal name either{_suggest(name, SIGNAL_NAMES)} "
                f"(valid: {', '.join(SIGNAL_NAMES)})")
            raise RecordingError(f"{self.source}: no column {name!r} (columns: time, {', '.join(self.signals)}){hint}")
        return self.signals[name]

    def resolution(self, name: str) -> float | None:
        """Quantization step of signal `name` from the sidecar; None when not stated."""
        self.signal(name)
        info = self.signal_info.get(name)
        return None if info is None else info.resolution

    def quantizer(self, name: str) -> str:
        """Quantizer of signal `name` from the sidecar; ``round`` when not stated (MODEL.md)."""
        self.signal(name)
        info = self.signal_info.get(name)
        return "round" if info is None else info.quantizer

    def to_frame(self):
        """The signals as a pandas DataFrame indexed by time (for plotting and inspection)."""
        import pandas as pd

        return pd.DataFrame(dict(self.signals), index=pd.Index(self.time, name="time"))


# --------------------------------------------------------------------------- quantize


def quantize(values, resolution: float | None, quantizer: str = "round") -> np.ndarray:
    """What a sensor of step `resolution` reads: ``Δ·round(value/Δ)`` (MODEL.md) or
    ``Δ·floor(value/Δ)``. ``round`` rounds halves to even (numpy's rint), which has no
    bias for signals that swing about zero. ``resolution=None`` (not stated) returns the
    values unchanged, so callers can pass ``recording.resolution(name)`` straight in."""
    values = np.asarray(values, dtype=np.float64)
    if resolution is None:
        return values.copy()
    problem = _resolution_problem(resolution) or _quantizer_problem(quantizer)
    if problem:
        raise ValueError(f"quantize: {problem}")
    steps = np.rint(values / resolution) if quantizer == "round" else np.floor(values / resolution)
    return resolution * steps


# --------------------------------------------------------------------------- reading


def read_recording(path: str | os.PathLike, max_bytes: int | None = None) -> Recording:
    """Read a recording (``.csv`` or MATLAB v5 ``.mat``) and its optional sidecar JSON.

    Files above `max_bytes` (default :data:`MAX_BYTES`) are refused before reading:
    parsing needs memory comparable to the file size, and a clear error beats swapping.
    """
    path = Path(path)
    src = str(path)
    if not path.exists():
        raise RecordingError(f"{src}: no such file")
    if not path.is_file():
        raise RecordingError(f"{src}: not a file")
    limit = MAX_BYTES if max_bytes is None else max_bytes
    size = path.stat().st_size
    if size > limit:
        raise RecordingError(f"{src}: file of {_bytes(size)} is above the limit of {_bytes(limit)} for a recording "
                             f"(read_recording(..., max_bytes=...) raises it); split or decimate the recording")
    suffix = path.suffix.lower()
    if suffix not in (".csv", ".mat"):
        raise RecordingError(f"{src}: unsupported file type {path.suffix!r}; "
                             f"a recording is a .csv or a MATLAB .mat file")
    sidecar = _read_sidecar(path.with_suffix(".json"))
    if size == 0:
        raise RecordingError(f"{src}: empty file")
    if suffix == ".csv":
        return _read_csv(path, sidecar)
    return _read_mat(path, sidecar)


@dataclass
class _Sidecar:
    """The parsed, checked sidecar JSON (empty when there is none)."""

    path: Path | None = None
    experiment: str = ""
    signal_info: dict[str, SignalInfo] = field(default_factory=dict)
    ignore: set[str] = field(default_factory=set)
    parameters: dict[str, float] = field(default_factory=dict)
    initial: dict[str, float] = field(default_factory=dict)

    @property
    def described(self) -> list[str]:
        """Column names the sidecar's ``signals`` talks about."""
        return [*self.signal_info, *self.ignore]


def _read_sidecar(path: Path) -> _Sidecar:
    """Parse and check the sidecar; every problem names the JSON key it is under."""
    if not path.is_file():
        return _Sidecar()
    src = str(path)
    try:
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError as exc:
        raise RecordingError(f"{src}: not UTF-8 text (byte {exc.start})") from None
    try:
        doc = json.loads(text, object_pairs_hook=_no_duplicate_keys)
    except json.JSONDecodeError as exc:
        comment = exc.pos < len(text) and text[exc.pos] == "/"
        hint = "; JSON has no comments, put notes under \"comment\"" if comment else ""
        raise RecordingError(f"{src}: not valid JSON at line {exc.lineno}, column {exc.colno}: "
                             f"{exc.msg}{hint}") from None
    except _DuplicateKey as exc:
        raise RecordingError(f"{src}: key {exc.args[0]!r} appears twice in one object") from None
    if not isinstance(doc, dict):
        raise RecordingError(f"{src}: the top level must be a JSON object, got {_json_type(doc)}")
    for key in doc:
        if key not in SIDECAR_KEYS:
            raise RecordingError(f"{src}: unknown key {key!r}{_suggest(key, SIDECAR_KEYS)}; "
                                 f"valid: {', '.join(SIDECAR_KEYS)}")
    sidecar = _Sidecar(path=path)
    experiment = doc.get("experiment", "")
    if not isinstance(experiment, str):
        raise RecordingError(f"{src}: experiment: must be a string, got {_json_type(experiment)}")
    sidecar.experiment = experiment
    for name, entry in _json_object(doc, "signals", src).items():
        _read_signal_entry(sidecar, name, entry, src)
    sidecar.parameters = _json_numbers(doc, "parameters", _parameter_problem, src)
    sidecar.initial = _json_numbers(doc, "initial", _initial_problem, src)
    return sidecar


def _read_signal_entry(sidecar: _Sidecar, name: str, entry, src: str) -> None:
    """One ``signals.<name>`` entry: either measurement info of a signal, or ``ignore``."""
    key = f"signals.{name}"
    if not isinstance(entry, dict):
        raise RecordingError(f"{src}: {key}: must be an object like {{\"resolution\": 1e-3}}, got {_json_type(entry)}")
    for sub in entry:
        if sub not in SIGNAL_INFO_KEYS:
            raise RecordingError(f"{src}: {key}.{sub}: unknown key{_suggest(sub, SIGNAL_INFO_KEYS)}; "
                                 f"valid: {', '.join(SIGNAL_INFO_KEYS)}")
    ignore = entry.get("ignore", False)
    if not isinstance(ignore, bool):
        raise RecordingError(f"{src}: {key}.ignore: must be true or false, got {_json_type(ignore)}")
    if ignore:
        if set(entry) - {"ignore"}:
            raise RecordingError(f"{src}: {key}: an ignored column takes no resolution or quantizer")
        sidecar.ignore.add(name)
        return
    if name not in SIGNAL_NAMES:
        raise RecordingError(f"{src}: {key}: unknown signal {name!r}{_suggest(name, SIGNAL_NAMES)}; valid: "
                             f"{', '.join(SIGNAL_NAMES)} (or mark an extra column with \"ignore\": true)")
    resolution = entry.get("resolution")
    if isinstance(resolution, bool) or (resolution is not None and not isinstance(resolution, (int, float))):
        raise RecordingError(f"{src}: {key}.resolution: must be a number, got {_json_type(resolution)}")
    problem = _resolution_problem(None if resolution is None else float(resolution))
    if problem:
        raise RecordingError(f"{src}: {key}.resolution: {problem}")
    quantizer = entry.get("quantizer", "round")
    problem = _quantizer_problem(quantizer)
    if problem:
        raise RecordingError(f"{src}: {key}.quantizer: {problem}")
    noise = entry.get("noise")
    if isinstance(noise, bool) or (noise is not None and not isinstance(noise, (int, float))):
        raise RecordingError(f"{src}: {key}.noise: must be a number, got {_json_type(noise)}")
    problem = _noise_problem(None if noise is None else float(noise))
    if problem:
        raise RecordingError(f"{src}: {key}.noise: {problem}")
    sidecar.signal_info[name] = SignalInfo(None if resolution is None else float(resolution), quantizer,
                                           None if noise is None else float(noise))


def _json_object(doc: dict, key: str, src: str) -> dict:
    """``doc[key]`` if it is an object (absent: empty)."""
    value = doc.get(key, {})
    if not isinstance(value, dict):
        raise RecordingError(f"{src}: {key}: must be an object, got {_json_type(value)}")
    return value


def _json_numbers(doc: dict, key: str, problem_of: Callable[[str, float], str | None], src: str) -> dict[str, float]:
    """``doc[key]`` as name -> float, each name and value checked by `problem_of`."""
    out: dict[str, float] = {}
    for name, value in _json_object(doc, key, src).items():
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise RecordingError(f"{src}: {key}.{name}: must be a number, got {_json_type(value)}")
        problem = problem_of(name, float(value))
        if problem:
            raise RecordingError(f"{src}: {key}.{name}: {problem}")
        out[name] = float(value)
    return out


class _DuplicateKey(Exception):
    pass


def _no_duplicate_keys(pairs):
    """json's default silently keeps the last of two equal keys; a sidecar that says
    two things about one name is a mistake worth reporting."""
    out = {}
    for key, value in pairs:
        if key in out:
            raise _DuplicateKey(key)
        out[key] = value
    return out


def _json_type(value) -> str:
    return {dict: "an object", list: "an array", str: "a string", bool: "a boolean", type(None): "null",
            int: "a number", float: "a number"}.get(type(value), type(value).__name__)


# --------------------------------------------------------------------------- CSV


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


# --------------------------------------------------------------------------- MATLAB


def _read_mat(path: Path, sidecar: _Sidecar) -> Recording:
    """Find the one accepted layout in a .mat file (see the module docstring)."""
    src = str(path)
    contents, data = _load_mat(path, src)
    candidates = _mat_candidates(data, src)
    if not candidates:
        raise RecordingError(f"{src}: no time vector with signals found; accepted: variables {_time_names()} "
                             f"with signal vectors, a struct holding them, a Simulink 'Structure with time' "
                             f"(time, signals.values/label) or structs with Time/Data; found: {_listing(contents)}"
                             f"{_mat_hint(contents)}")
    if len(candidates) > 1:
        raise RecordingError(f"{src}: more than one recording in the file: {'; '.join(c.layout for c in candidates)}; "
                             f"keep one per file")
    found = candidates[0]
    keep, ignored = _select_columns([s.name for s in found.series], sidecar, src, "signal")
    by_name = {s.name: s for s in found.series}
    where = _sample_locator
    _check_time(found.time, src, found.time_label, where)
    signals: dict[str, np.ndarray] = {}
    for name in keep:
        series = by_name[name]
        _check_length(series.values, found.time, src, series.label)
        _check_finite(series.values, src, series.label, where)
        signals[name] = series.values
    return _build(path, found.time, signals, sidecar, tuple(found.skipped) + ignored)


@dataclass
class _Series:
    name: str  # the signal name it claims
    label: str  # where it is in the file, for messages
    values: np.ndarray


@dataclass
class _Candidate:
    layout: str
    time: np.ndarray
    time_label: str
    series: list[_Series]
    skipped: list[str]


def _load_mat(path: Path, src: str) -> tuple[list[tuple[str, tuple, str]], dict]:
    """(whosmat listing, loadmat contents). The listing gives MATLAB classes and sizes,
    which loadmat's converted values no longer show, for the error messages."""
    import scipy.io

    try:
        contents = scipy.io.whosmat(str(path))
        data = scipy.io.loadmat(str(path), simplify_cells=True)
    except NotImplementedError:
        raise RecordingError(f"{src}: a MATLAB v7.3 (HDF5) file; save it with save(..., '-v7') "
                             f"or export a CSV") from None
    except Exception as exc:  # scipy raises ValueError, TypeError, OSError... on damaged files
        raise RecordingError(f"{src}: not a readable MATLAB .mat file ({type(exc).__name__}: {exc})") from None
    return contents, {k: v for k, v in data.items() if not k.startswith("__")}


def _mat_candidates(data: dict, src: str) -> list[_Candidate]:
    """Every place in the file that holds a time vector with signals."""
    candidates = []
    plain = _plain_layout(data, "", src)
    if plain is not None:
        candidates.append(plain)
    timeseries: list[tuple[str, dict]] = []
    for name, value in data.items():
        if not isinstance(value, dict):
            continue
        if "signals" in value and "time" in value:
            candidates.append(_simulink_layout(name, value, src))
        elif "Time" in value and "Data" in value:
            timeseries.append((name, value))
        else:
            inner = _plain_layout(value, f"{name}.", src)
            if inner is not None:
                candidates.append(inner)
    if timeseries:
        candidates.append(_timeseries_layout(timeseries, src))
    return candidates


def _plain_layout(variables: dict, prefix: str, src: str) -> _Candidate | None:
    """Layouts 1 and 2: a time vector and signal vectors side by side (top level or in
    a struct). None when there is no time vector or no vector beside it."""
    time_keys = [k for k in MAT_TIME_NAMES if k in variables]
    if not time_keys:
        return None
    if len(time_keys) > 1:
        raise RecordingError(f"{src}: two time vectors, {' and '.join(prefix + k for k in time_keys)}; keep one")
    time_key = time_keys[0]
    time = _mat_vector(variables[time_key])
    if time is None:
        raise RecordingError(f"{src}: {prefix}{time_key} is not a numeric vector ({_describe(variables[time_key])})")
    series, skipped = [], []
    for name, value in variables.items():
        if name == time_key:
            continue
        vector = _mat_vector(value)
        if name in SIGNAL_NAMES and vector is None:
            raise RecordingError(f"{src}: {prefix}{name} is not a numeric vector ({_describe(value)})")
        if vector is not None and (name in SIGNAL_NAMES or (len(vector) == len(time) and len(time) > 1)):
            series.append(_Series(name, f"{prefix}{name}", vector))
        else:
            skipped.append(prefix + name)
    if not series:
        return None
    where = f"variables {prefix}{time_key}, ..." if not prefix else f"struct {prefix[:-1]}"
    return _Candidate(where, time, prefix + time_key, series, skipped)


def _simulink_layout(name: str, value: dict, src: str) -> _Candidate:
    """Layout 3: Simulink's "Structure with time"."""
    time = _mat_vector(value["time"])
    if time is None or time.size == 0:
        raise RecordingError(f"{src}: {name}.time is empty or not a vector ({_describe(value['time'])}): Simulink "
                             f"saved 'Structure' without time; choose 'Structure with time'")
    elements = value["signals"]
    if isinstance(elements, np.ndarray):
        elements = list(elements.ravel())
    elif not isinstance(elements, list):
        elements = [elements]  # one signal: loadmat gives the struct itself
    series = []
    for i, element in enumerate(elements, start=1):
        where = f"{name}.signals({i})"
        if not isinstance(element, dict) or "values" not in element:
            raise RecordingError(f"{src}: {where} has no field 'values' ({_describe(element)})")
        label = element.get("label")
        if not isinstance(label, str) or not label.strip():
            raise RecordingError(f"{src}: {where}.label is empty: name the signal line in the model after the "
                                 f"signal ({', '.join(SIGNAL_NAMES)})")
        vector = _mat_vector(element["values"])
        if vector is None:
            raise RecordingError(f"{src}: {where}.values ({label!r}) is not one numeric column "
                                 f"({_describe(element['values'])}); log each signal on its own line")
        series.append(_Series(label.strip(), f"{label.strip()!r} ({where}.values)", vector))
    return _Candidate(f"Simulink structure {name}", time, f"{name}.time", series, [])


def _timeseries_layout(structs: list[tuple[str, dict]], src: str) -> _Candidate:
    """Layout 4: structs with Time/Data, one per signal, sharing one time base."""
    first_name, first = structs[0]
    time = _mat_vector(first["Time"])
    if time is None:
        raise RecordingError(f"{src}: {first_name}.Time is not a numeric vector ({_describe(first['Time'])})")
    series = []
    for name, value in structs:
        other = _mat_vector(value["Time"])
        if other is None or not np.array_equal(other, time):
            raise RecordingError(f"{src}: {name}.Time differs from {first_name}.Time; a recording has one time "
                                 f"base: resample in MATLAB or save the signals in separate files")
        signal = value.get("Name")
        signal = signal.strip() if isinstance(signal, str) and signal.strip() else name
        vector = _mat_vector(value["Data"])
        if vector is None:
            raise RecordingError(f"{src}: {name}.Data is not one numeric column ({_describe(value['Data'])})")
        series.append(_Series(signal, f"{signal!r} ({name}.Data)", vector))
    names = ", ".join(n for n, _ in structs)
    return _Candidate(f"timeseries-like structs {names}", time, f"{first_name}.Time", series, [])


def _mat_vector(value) -> np.ndarray | None:
    """A real numeric vector (N, N x 1, 1 x N; squeezed by loadmat) as float64, or None."""
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return np.array([value], dtype=np.float64)
    if not isinstance(value, np.ndarray) or value.dtype.kind not in "iuf":
        return None
    if value.ndim > 1 and sum(d > 1 for d in value.shape) > 1:
        return None
    return np.asarray(value, dtype=np.float64).reshape(-1)


def _describe(value) -> str:
    """A short description of a loaded MATLAB value for error messages."""
    if isinstance(value, dict):
        return f"struct with fields {', '.join(value)}"
    if isinstance(value, np.ndarray):
        return f"{value.dtype} array of shape {value.shape}"
    return type(value).__name__


def _listing(contents: list[tuple[str, tuple, str]]) -> str:
    """The variables of a .mat file as MATLAB would show them: name (class RxC)."""
    if not contents:
        return "no variables"
    return ", ".join(f"{name} ({cls} {'x'.join(map(str, shape))})" for name, shape, cls in contents)


def _mat_hint(contents: list[tuple[str, tuple, str]]) -> str:
    """Advice for the two layouts users bring most that scipy cannot take as they are."""
    classes = {cls for _, _, cls in contents}
    if "cell" in classes:
        return ("; cell arrays (several runs or pieces?) are not read: save one run per file, or build a "
                "Recording(path, time, signals) from the arrays in an adapter")
    if classes & {"object", "opaque"}:
        return ("; MATLAB objects (timeseries, Simulink Dataset) cannot be read: log as "
                "'Structure with time' or save plain vectors")
    return ""


def _time_names() -> str:
    return "/".join(MAT_TIME_NAMES)


def _sample_locator(index: int) -> str:
    """Sample `index` (0-based) named as MATLAB would index it."""
    return f"sample {index + 1}"


# --------------------------------------------------------------------------- shared checks


def _select_columns(names: list[str], sidecar: _Sidecar, src: str, noun: str) -> tuple[list[str], tuple[str, ...]]:
    """Split the file's column names into signals to keep and columns the sidecar marks
    ignored; anything else is an error that lists the valid names."""
    for name in sidecar.described:
        if name not in names:
            raise RecordingError(f"{sidecar.path}: signals.{name}: the recording {src} has no {noun} {name!r} "
                                 f"({noun}s: {', '.join(names)})")
    keep, ignored, seen = [], [], set()
    for name in names:
        if name in seen:
            raise RecordingError(f"{src}: {noun} {name!r} appears twice")
        seen.add(name)
        if name in sidecar.ignore:
            ignored.append(name)
        elif name in SIGNAL_NAMES:
            keep.append(name)
        else:
            sidecar_name = sidecar.path or Path(src).with_suffix(".json")
            raise RecordingError(f"{src}: {noun} {name!r} is not a signal name{_suggest(name, SIGNAL_NAMES)}; "
                                 f"valid: {', '.join(SIGNAL_NAMES)}; to keep it out, mark it in {sidecar_name}: "
                                 f"\"signals\": {{\"{name}\": {{\"ignore\": true}}}}")
    if not keep:
        raise RecordingError(f"{src}: no signals left, all {noun}s are ignored ({', '.join(ignored)})")
    return keep, tuple(ignored)


def _build(path: Path, time: np.ndarray, signals: dict[str, np.ndarray], sidecar: _Sidecar,
           ignored: tuple[str, ...]) -> Recording:
    """The Recording of a checked file and its sidecar."""
    return Recording(path=path, time=time, signals=signals, experiment=sidecar.experiment,
                     signal_info=sidecar.signal_info, parameters=sidecar.parameters, initial=sidecar.initial,
                     ignored=tuple(ignored))


def _check_time(time: np.ndarray, src: str, label: str, where: Callable[[int], str]) -> None:
    """Time must be finite and strictly increasing; duplicates and steps back are told apart
    because they have different causes (a logger's rounding vs. concatenated runs)."""
    if time.size == 0:
        raise RecordingError(f"{src}: {label} is empty")
    _check_finite(time, src, label, where)
    steps = np.diff(time)
    bad = np.flatnonzero(steps <= 0)
    if bad.size:
        i = int(bad[0])
        before, after = float(time[i]), float(time[i + 1])
        if before == after:
            raise RecordingError(f"{src}: duplicate time stamp {before!r} in {label} at {where(i)} and "
                                 f"{where(i + 1)}; time must strictly increase")
        raise RecordingError(f"{src}: {label} is not strictly increasing at {where(i + 1)}: {after!r} "
                             f"after {before!r} at {where(i)}")


def _check_finite(values: np.ndarray, src: str, label: str, where: Callable[[int], str]) -> None:
    """No NaN or Inf: the fit compares every sample, and a gap is not a value."""
    bad = np.flatnonzero(~np.isfinite(values))
    if bad.size:
        i = int(bad[0])
        what = "NaN" if np.isnan(values[i]) else "Inf"
        more = f" (and {bad.size - 1} more)" if bad.size > 1 else ""
        raise RecordingError(f"{src}: {what} in {label} at {where(i)}{more}")


def _check_length(values: np.ndarray, time: np.ndarray, src: str, label: str) -> None:
    if len(values) != len(time):
        raise RecordingError(f"{src}: {label} has {len(values)} samples, time has {len(time)}")


def _as_vector(values, src: str, label: str) -> np.ndarray:
    """A float64 copy of a vector-shaped array (N, N x 1, 1 x N)."""
    try:
        array_ = np.array(values, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise RecordingError(f"{src}: {label} is not numeric ({exc})") from None
    if array_.ndim != 1:
        if array_.ndim == 0 or sum(d > 1 for d in array_.shape) > 1:
            raise RecordingError(f"{src}: {label} must be a vector, got shape {array_.shape}")
        array_ = array_.reshape(-1)
    return array_


def _frozen(values: np.ndarray) -> np.ndarray:
    values.setflags(write=False)
    return values


def _checked_values(values: Mapping[str, float], problem_of, src: str, what: str) -> dict[str, float]:
    """Constructor-side check of parameters/initial (the sidecar reader has its own, with JSON keys)."""
    out = {}
    for name, value in dict(values).items():
        try:
            number = float(value)
        except (TypeError, ValueError):
            raise RecordingError(f"{src}: {what}[{name!r}] must be a number, got {value!r}") from None
        problem = problem_of(name, number)
        if problem:
            raise RecordingError(f"{src}: {what}[{name!r}]: {problem}")
        out[name] = number
    return out


def _parameter_problem(name: str, value: float) -> str | None:
    """Why `value` cannot be parameter `name` (unknown, not finite, out of range), or None.
    m_p and l belong to two components with different ranges (the Cart takes m_p = 0,
    pendulum removed); a value is fine if one of them accepts it."""
    if name not in PARAMETER_NAMES:
        return f"unknown parameter{_suggest(name, PARAMETER_NAMES)}; valid: {', '.join(PARAMETER_NAMES)}"
    if not math.isfinite(value):
        return f"must be finite, got {value!r}"
    ranges = []
    for component in COMPONENTS.values():
        var = component.parameters.get(name)
        if var is None:
            continue
        below = var.low is not None and (value < var.low or (var.low_open and value == var.low))
        above = var.high is not None and value > var.high
        if not (below or above):
            return None
        ranges.append(f"{var.allowed_range()} in {component.name}")
    return f"{value!r} is outside the allowed range ({'; '.join(ranges)})"


def _initial_problem(name: str, value: float) -> str | None:
    """Why `value` cannot be the known initial value of `name`, or None."""
    if name not in INITIAL_NAMES:
        return f"not a state{_suggest(name, INITIAL_NAMES)}; valid: {', '.join(INITIAL_NAMES)}"
    if not math.isfinite(value):
        return f"must be finite, got {value!r}"
    return None


def _noise_problem(noise: float | None) -> str | None:
    if noise is None:
        return None
    if not math.isfinite(noise) or noise < 0:
        return f"noise {noise!r} must be a finite standard deviation >= 0"
    return None


def _resolution_problem(resolution) -> str | None:
    if resolution is None:
        return None
    if isinstance(resolution, bool) or not isinstance(resolution, numbers.Real):
        return f"resolution must be a number, got {resolution!r}"
    if not (math.isfinite(resolution) and resolution > 0):
        return f"resolution must be a positive finite number, got {resolution!r}"
    return None


def _quantizer_problem(quantizer) -> str | None:
    if quantizer not in QUANTIZERS:
        return f"quantizer must be one of {', '.join(QUANTIZERS)}, got {quantizer!r}"
    return None


def _suggest(name: str, valid) -> str:
    """' (did you mean 'phi'?)' for a near miss, case first: typos are the usual cause."""
    for candidate in valid:
        if candidate.lower() == str(name).lower():
            return f" (did you mean {candidate!r}?)"
    close = difflib.get_close_matches(str(name), list(valid), n=1, cutoff=0.75)
    return f" (did you mean {close[0]!r}?)" if close else ""


def _bytes(size: int) -> str:
    """A file size for messages: bytes below 1 MB, else MB or GB."""
    if size < 1024**2:
        return f"{size} bytes"
    if size < 1024**3:
        return f"{size / 1024**2:.1f} MB"
    return f"{size / 1024**3:.2f} GB"


# --------------------------------------------------------------------------- writing


def write_recording(recording: Recording, path: str | os.PathLike) -> Path:
    """Write `recording` as ``path`` (CSV) and its sidecar ``path`` with ``.json``.

    Numbers are written with ``repr`` (the shortest text that reads back to the same
    float64), so reading the files gives bit-identical arrays. The sidecar is always
    written, even when empty, so a stale one from an earlier run cannot attach its
    metadata to the new data. Both files are written to temporary names and renamed,
    so a reader never sees half a file. Ignored columns of the source are not written.
    Returns the CSV path.
    """
    path = Path(path)
    if path.suffix.lower() != ".csv":
        raise RecordingError(f"{path}: write_recording writes CSV; the name must end in .csv")
    names = list(recording.signals)
    columns = [recording.time.tolist()] + [recording.signals[n].tolist() for n in names]
    lines = [",".join(["time", *names])]
    lines.extend(",".join(map(repr, row)) for row in zip(*columns))
    _write_atomic(path, "\n".join(lines) + "\n")
    _write_atomic(path.with_suffix(".json"), json.dumps(_sidecar_document(recording), indent=2) + "\n")
    return path


def _sidecar_document(recording: Recording) -> dict:
    """The sidecar JSON of a recording; json writes floats with repr, exact like the CSV."""
    signals = {}
    for name, info in recording.signal_info.items():
        entry: dict = {} if info.resolution is None else {"resolution": info.resolution}
        entry["quantizer"] = info.quantizer
        if info.noise is not None:
            entry["noise"] = info.noise
        signals[name] = entry
    return {"experiment": recording.experiment, "signals": signals,
            "parameters": dict(recording.parameters), "initial": dict(recording.initial)}


def _write_atomic(path: Path, text: str) -> None:
    """Write via a temporary file in the same directory and rename over `path`."""
    handle, temporary = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    try:
        with os.fdopen(handle, "w", encoding="utf-8", newline="") as out:
            out.write(text)
        os.replace(temporary, path)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise
