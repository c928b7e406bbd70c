"""The sidecar JSON beside a recording: parsed strictly, every problem named by its key;
and how it is combined with the columns read from the file."""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pendfmu.jsontext import parse_json
from pendfmu.recording.schema import RIG, RecordingError, SIDECAR_KEYS, SIGNAL_INFO_KEYS, Vocabulary, _missing_problem, _noise_problem, _quantizer_problem, _resolution_problem
from pendfmu.recording.model import Recording, SignalInfo
from pendfmu.suggest import did_you_mean


@dataclass
class _Sidecar:
    """The parsed, checked sidecar JSON (empty when there is none)."""

    path: Path | None = None
    experiment: str = ""
    signal_info: dict[str, SignalInfo] = field(default_factory=dict)
    ignore: set[str] = field(default_factory=set)
    parameters: dict[str, float] = field(default_factory=dict)
    initial: dict[str, float] = field(default_factory=dict)
    vocabulary: Vocabulary = RIG

    @property
    def described(self) -> list[str]:
        """Column names the sidecar's ``signals`` talks about."""
        return [*self.signal_info, *self.ignore]


def _read_sidecar(path: Path, vocabulary: Vocabulary = RIG) -> _Sidecar:
    """Parse and check the sidecar; every problem names the JSON key it is under."""
    if not path.is_file():
        return _Sidecar(vocabulary=vocabulary)
    src = str(path)
    try:
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError as exc:
        raise RecordingError(f"{src}: not UTF-8 text (byte {exc.start})") from None
    try:
        doc = parse_json(text, object_pairs_hook=_no_duplicate_keys)
    except json.JSONDecodeError as exc:
        comment = exc.pos < len(text) and text[exc.pos] == "/"
        hint = "; JSON has no comments, put notes under \"comment\"" if comment else ""
        raise RecordingError(f"{src}: not valid JSON at line {exc.lineno}, column {exc.colno}: "
                             f"{exc.msg}{hint}") from None
    except _DuplicateKey as exc:
        raise RecordingError(f"{src}: key {exc.args[0]!r} appears twice in one object") from None
    if not isinstance(doc, dict):
        raise RecordingError(f"{src}: the top level must be a JSON object, got {_json_type(doc)}")
    _check_keys(doc, SIDECAR_KEYS, src)
    sidecar = _Sidecar(path=path, vocabulary=vocabulary)
    experiment = doc.get("experiment", "")
    if not isinstance(experiment, str):
        raise RecordingError(f"{src}: experiment: must be a string, got {_json_type(experiment)}")
    sidecar.experiment = experiment
    for name, entry in _json_object(doc, "signals", src).items():
        _read_signal_entry(sidecar, name, entry, src)
    sidecar.parameters = _json_numbers(doc, "parameters", vocabulary.parameter_problem, src)
    sidecar.initial = _json_numbers(doc, "initial", vocabulary.initial_problem, src)
    return sidecar


def _check_keys(document: dict, valid, src: str, under: str = "") -> None:
    """Refuse a key that is not in `valid`, suggesting the nearest valid one."""
    for key in document:
        if key not in valid:
            where = f"{under}.{key}: unknown key" if under else f"unknown key {key!r}"
            raise RecordingError(f"{src}: {where}{did_you_mean(key, valid)}; valid: {', '.join(valid)}")


def _read_signal_entry(sidecar: _Sidecar, name: str, entry, src: str) -> None:
    """One ``signals.<name>`` entry: either measurement info of a signal, or ``ignore``."""
    key = f"signals.{name}"
    if not isinstance(entry, dict):
        raise RecordingError(f"{src}: {key}: must be an object like {{\"resolution\": 1e-3}}, got {_json_type(entry)}")
    _check_keys(entry, SIGNAL_INFO_KEYS, src, key)
    ignore = entry.get("ignore", False)
    if not isinstance(ignore, bool):
        raise RecordingError(f"{src}: {key}.ignore: must be true or false, got {_json_type(ignore)}")
    if ignore:
        if set(entry) - {"ignore"}:
            raise RecordingError(f"{src}: {key}: an ignored column takes no resolution or quantizer")
        sidecar.ignore.add(name)
        return
    known = sidecar.vocabulary.signals
    if name not in known:
        raise RecordingError(f"{src}: {key}: unknown signal {name!r}{did_you_mean(name, known)}; valid: "
                             f"{', '.join(known)} (or mark an extra column with \"ignore\": true)")
    resolution = _optional_number(entry, "resolution", _resolution_problem, f"{src}: {key}")
    quantizer = entry.get("quantizer", "round")
    problem = _quantizer_problem(quantizer)
    if problem:
        raise RecordingError(f"{src}: {key}.quantizer: {problem}")
    noise = _optional_number(entry, "noise", _noise_problem, f"{src}: {key}")
    missing = entry.get("missing")
    problem = _missing_problem(missing)
    if problem:
        raise RecordingError(f"{src}: {key}.missing: {problem}")
    sidecar.signal_info[name] = SignalInfo(resolution, quantizer, noise, missing)


def _missing(sidecar: _Sidecar, name: str) -> bool:
    """Whether the sidecar says signal `name` has missing samples (NaN allowed)."""
    info = sidecar.signal_info.get(name)
    return info is not None and info.missing is not None


def _optional_number(entry: dict, name: str, problem_of: Callable[[float | None], str | None],
                     where: str) -> float | None:
    """entry[name] as a float (None if absent), refused with the key named if it is not a
    number or `problem_of` objects to it."""
    value = entry.get(name)
    if isinstance(value, bool) or (value is not None and not isinstance(value, (int, float))):
        raise RecordingError(f"{where}.{name}: must be a number, got {_json_type(value)}")
    value = None if value is None else float(value)
    problem = problem_of(value)
    if problem:
        raise RecordingError(f"{where}.{name}: {problem}")
    return value


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
        elif name in sidecar.vocabulary.signals:
            keep.append(name)
        else:
            known = sidecar.vocabulary.signals
            sidecar_name = sidecar.path or Path(src).with_suffix(".json")
            raise RecordingError(f"{src}: {noun} {name!r} is not a signal name{did_you_mean(name, known)}; "
                                 f"valid: {', '.join(known)}; to keep it out, mark it in {sidecar_name}: "
                                 f"\"signals\": {{\"{name}\": {{\"ignore\": true}}}}")
    if not keep:
        raise RecordingError(f"{src}: no signals left, all {noun}s are ignored ({', '.join(ignored)})")
    return keep, tuple(ignored)


def _build(path: Path, time: np.ndarray, signals: dict[str, np.ndarray], sidecar: _Sidecar,
           ignored: tuple[str, ...]) -> Recording:
    """The Recording of a checked file and its sidecar."""
    return Recording(path=path, time=time, signals=signals, experiment=sidecar.experiment,
                     signal_info=sidecar.signal_info, parameters=sidecar.parameters, initial=sidecar.initial,
                     ignored=tuple(ignored), sidecar=sidecar.path, vocabulary=sidecar.vocabulary)
