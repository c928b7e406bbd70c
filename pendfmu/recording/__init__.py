"""Recordings: the measured time responses that start pendfmu's one-way flow.

recording -> experiment -> simulator -> residuals -> optimizer -> result -> report

A :class:`Recording` is one run on the rig: a time vector and the signals recorded
against it, plus what the sidecar JSON says about them (the recording format,
``pendfmu/recording/FORMAT.md``). Everything later in the flow trusts a Recording, so every
check happens here, once, and every failure is a :class:`RecordingError` with a one-line
message that names the file, the column and the line (or the JSON key) -- a user with a 2 GB
logger export must be able to find the bad cell from the message alone.

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

Files written
-------------
:func:`write_recording` writes a Recording as CSV + sidecar; :func:`write_signals` writes
any time vector with named columns as CSV or as MATLAB v5 in Simulink's "Structure with
time", chosen by the suffix (:func:`check_output_path` checks it before any work). Both
are exact: read back, they give bit-identical arrays (pendfmu/recording/writer.py).

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

import os
from pathlib import Path

from pendfmu.recording.csv_reader import _read_csv
from pendfmu.recording.mat_reader import _read_mat
from pendfmu.recording.model import Recording, SignalInfo, quantize
from pendfmu.recording.schema import (INITIAL_NAMES, MAT_TIME_NAMES, PARAMETER_NAMES, QUANTIZERS, RIG, SIGNAL_NAMES,
                                      RecordingError, Vocabulary, _bytes)
from pendfmu.recording.sidecar import _read_sidecar
from pendfmu.recording.writer import check_output_path, write_recording, write_signals

__all__ = ["INITIAL_NAMES", "MAT_TIME_NAMES", "MAX_BYTES", "PARAMETER_NAMES", "QUANTIZERS", "RIG", "SIGNAL_NAMES",
           "Recording", "RecordingError", "SignalInfo", "Vocabulary", "check_output_path", "format_document", "quantize",
           "read_recording", "write_recording", "write_signals"]


def format_document() -> Path:
    """Where the recording format's reference is: columns, units, the sidecar's keys, the
    angle and inertia conventions. `pendfmu format` prints it.

    Returns
    -------
    Path
        FORMAT.md, shipped with the package.
    """
    from importlib.resources import files

    return Path(str(files(__name__) / "FORMAT.md"))


MAX_BYTES: int = 2 * 1024**3
"""Default size limit of a recording file; :func:`read_recording` refuses larger files
before reading them, rather than letting the machine swap."""


def read_recording(path: str | os.PathLike, max_bytes: int | None = None, vocabulary: Vocabulary = RIG) -> Recording:
    """Read a recording (``.csv`` or MATLAB v5 ``.mat``) and its optional sidecar JSON.

    Everything is checked here, once (the module docstring lists the layouts and the
    rules); later stages trust a Recording.

    Parameters
    ----------
    path : str or os.PathLike
        The ``.csv`` or ``.mat`` file; its sidecar is the same name with ``.json``.
    max_bytes : int, optional
        Files above this size [bytes] are refused before reading: parsing needs memory
        comparable to the file size, and a clear error beats swapping. Default
        :data:`MAX_BYTES`.
    vocabulary : Vocabulary, optional
        The names it may use: the rig's (docs/user-guide/model.md; :data:`RIG`, the default),
        or those of a user's model (``Model.vocabulary()``).

    Returns
    -------
    Recording
        The checked recording, its arrays read-only.

    Raises
    ------
    RecordingError
        The file or its sidecar cannot be used; the message names the file, the column
        and the line (or the JSON key).
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
    sidecar = _read_sidecar(path.with_suffix(".json"), vocabulary)
    if size == 0:
        raise RecordingError(f"{src}: empty file")
    if suffix == ".csv":
        return _read_csv(path, sidecar)
    return _read_mat(path, sidecar)
