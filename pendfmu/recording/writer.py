"""Writing recordings: CSV with repr-exact numbers and the sidecar, atomically."""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path

from pendfmu.recording.schema import RecordingError
from pendfmu.recording.model import Recording


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
