"""MATLAB v5 recordings (scipy.io.loadmat): the layouts listed in pendfmu.recording, and a
message listing what a file holds when none fits."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pendfmu.recording.schema import MAT_TIME_NAMES, RecordingError, SIGNAL_NAMES
from pendfmu.recording.model import Recording, _check_finite, _check_length, _check_time, _sample_locator
from pendfmu.recording.sidecar import _Sidecar, _build, _missing, _select_columns


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
        _check_finite(series.values, src, series.label, where, _missing(sidecar, name), name)
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
