"""Writing recordings and simulation results, exactly and atomically.

:func:`write_recording` writes a Recording (CSV + sidecar); :func:`write_signals` writes
any time vector with named columns, CSV or MATLAB by the file's suffix, for every command
that writes a model's output (``pendfmu simulate``). Both write exact numbers: a CSV holds
the shortest text that reads back to the same float64 (csv_text.py), a .mat file the
doubles themselves; reading either with :func:`pendfmu.recording.read_recording` gives
bit-identical arrays. Files are written under a temporary name and renamed, so a reader
never sees half a file.
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from pendfmu.atomic import write_atomically
from pendfmu.recording.csv_text import format_rows, header_line
from pendfmu.recording.model import Recording
from pendfmu.recording.schema import RecordingError

OUTPUT_SUFFIXES: tuple[str, ...] = (".csv", ".mat")
"""What :func:`write_signals` writes, chosen by the path's suffix (any case)."""

MAT_VARIABLE = "simout"
"""The one variable of a written .mat file: a Simulink "Structure with time" (see
:func:`write_signals`), named like the To Workspace block's default variable."""


def check_output_path(path: str | os.PathLike) -> str:
    """The format :func:`write_signals` will write to a path, by its suffix; any other
    suffix is refused, naming the allowed ones.

    Commands call this before they simulate, so a typo in the name costs no run.

    Parameters
    ----------
    path : str or os.PathLike
        The output file's name.

    Returns
    -------
    str
        ``".csv"`` or ``".mat"`` (lower case, whatever the name's case).

    Raises
    ------
    RecordingError
        Any other suffix, or none.
    """
    suffix = Path(path).suffix.lower()
    if suffix not in OUTPUT_SUFFIXES:
        found = f"suffix {Path(path).suffix!r}" if suffix else "no suffix"
        raise RecordingError(f"{path}: cannot write a file with {found}; the output must end in "
                             f"{' or '.join(OUTPUT_SUFFIXES)}")
    return suffix


def write_signals(path: str | os.PathLike, time, columns: Mapping[str, object]) -> Path:
    """Write `time` and the named `columns` (1-D, as long as time) to `path`.

    ``.csv``: a header ``time,<names>`` and one row per sample (the text of each number
    is the shortest that reads back to the same double, as ``repr``).

    ``.mat`` (MATLAB v5, scipy.io.savemat): one variable ``simout`` in Simulink's
    "Structure with time" layout: ``simout.time`` (N x 1) and the struct array
    ``simout.signals(k)`` with ``values`` (N x 1), ``dimensions`` (1) and ``label`` (the
    column's name). Chosen over plain variables because it is what Simulink loads as
    is, as the input of a model's root Inports (Data Import/Export > Input: ``simout``),
    and what Simulink logs its outputs as, so a comparison uses the same indexing on both
    sides; and because labels are strings, any model's output names fit (``Cart.x`` is
    not a MATLAB variable name). In MATLAB: ``load out.mat; plot(simout.time,
    simout.signals(2).values)``.

    Parameters
    ----------
    path : str or os.PathLike
        The file, ``.csv`` or ``.mat`` (:func:`check_output_path`); replaced if it exists.
    time : array_like of float
        The time vector [s].
    columns : mapping of str to array_like
        The columns by name, each 1-D and as long as `time`; none named ``time``.

    Returns
    -------
    Path
        `path`.

    Raises
    ------
    RecordingError
        A suffix other than ``.csv``/``.mat``, a column named ``time``, or a column whose
        length differs from `time`'s.
    """
    path = Path(path)
    suffix = check_output_path(path)
    time = _vector(time, "time")
    if "time" in columns:
        raise RecordingError("a column named 'time' would repeat the time vector; give the columns other names")
    table = np.empty((len(time), 1 + len(columns)))
    table[:, 0] = time
    for j, (name, values) in enumerate(columns.items(), start=1):
        values = _vector(values, repr(name))
        if len(values) != len(time):
            raise RecordingError(f"column {name!r} has {len(values)} values, time has {len(time)}")
        table[:, j] = values
    names = ["time", *columns]
    if suffix == ".csv":
        write_atomically(path, [header_line(names), format_rows(table)])
    else:
        _write_mat(path, names, table)
    return path


def write_recording(recording: Recording, path: str | os.PathLike) -> Path:
    """Write a recording as CSV and its sidecar JSON beside it.

    Numbers are written as the shortest text that reads back to the same float64, so
    reading the files gives bit-identical arrays. The sidecar is always written, even
    when empty, so a stale one from an earlier run cannot attach its metadata to the new
    data. Ignored columns of the source are not written.

    Parameters
    ----------
    recording : Recording
        What to write.
    path : str or os.PathLike
        The CSV file (its name must end in ``.csv``); the sidecar is `path` with
        ``.json``. Both are replaced if they exist.

    Returns
    -------
    Path
        The CSV file's path.

    Raises
    ------
    RecordingError
        `path` does not end in ``.csv``.
    """
    path = Path(path)
    if path.suffix.lower() != ".csv":
        raise RecordingError(f"{path}: write_recording writes CSV; the name must end in .csv")
    names = list(recording.signals)
    table = np.column_stack([recording.time, *(recording.signals[n] for n in names)])
    write_atomically(path, [header_line(["time", *names]), format_rows(table)])
    sidecar = json.dumps(_sidecar_document(recording), indent=2) + "\n"
    write_atomically(path.with_suffix(".json"), [sidecar.encode("utf-8")])
    return path


def _sidecar_document(recording: Recording) -> dict:
    """The sidecar JSON of a recording; json writes floats with repr, exact like the CSV."""
    signals = {}
    for name, info in recording.signal_info.items():
        entry: dict = {} if info.resolution is None else {"resolution": info.resolution}
        entry["quantizer"] = info.quantizer
        if info.noise is not None:
            entry["noise"] = info.noise
        if info.missing is not None:
            # a marker value became NaN when the recording was made, and NaN is what the CSV holds
            entry["missing"] = "nan"
        signals[name] = entry
    return {"experiment": recording.experiment, "signals": signals,
            "parameters": dict(recording.parameters), "initial": dict(recording.initial)}


def _write_mat(path: Path, names: list[str], table: np.ndarray) -> None:
    """The table as a Simulink "Structure with time" (see write_signals)."""
    import scipy.io

    signals = np.zeros((1, len(names) - 1), dtype=[("values", object), ("dimensions", object), ("label", object)])
    for k, name in enumerate(names[1:]):
        signals[0, k] = (table[:, k + 1:k + 2].copy(), 1.0, name)
    structure = {"time": table[:, :1].copy(), "signals": signals}
    write_atomically(path, None, lambda out: scipy.io.savemat(out, {MAT_VARIABLE: structure}, format="5"))


def _vector(values, label: str) -> np.ndarray:
    array = np.asarray(values, dtype=np.float64)
    if array.ndim != 1:
        raise RecordingError(f"{label} must be a 1-D array, got shape {array.shape}")
    return array
