"""Reference results as `pendfmu check` reads them: a CSV file (--reference) or what the FMU
carries (FMI-LS-REF, pendfmu/export/lsref.py).

A CSV has time first, then a column per variable, named as in the model description. Cells
are numbers, `true`/`false` for a Boolean, and for an FMI 3.0 array the values of all its
elements separated by spaces (`1 2 3`, as the Reference FMUs write StateSpace's y): it
becomes one column per element (`y[1]`, `y[2]`, ...). An empty cell is a missing sample.
Columns of the inputs the check drives are the stimulus; the others are compared.

A user's file (strict) must name only variables of the FMU. A carried file is the FMU's own
and read leniently: a column that names no variable (upstream's Roberts carries
BouncingBall's h and v; its Feedthrough for FMI 2.0 the FMI 3.0 types), a text or binary
column, an input the check does not drive: each is left out with a note, and the notes are
a WARN row.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pendfmu.check.variables import NUMERIC, elements, is_array, size
from pendfmu.errors import BadInput


@dataclass
class Reference:
    """A reference result: times (non-decreasing; repeated = a jump), the stimulus columns
    (named like the FMU's inputs) and the columns to compare; `origin` says where it came
    from, `notes` what was left out of it and why, `carried` whether the FMU carries it."""
    times: np.ndarray
    inputs: dict[str, np.ndarray]
    outputs: dict[str, np.ndarray]
    origin: str
    notes: list[str] = field(default_factory=list)
    carried: bool = False
    judged: dict | None = field(default=None, repr=False)  # reference.judge_carried's rows per interface


def _cells(path: Path, text: str | None) -> list[list[str]]:
    if text is None:
        try:
            text = path.read_text()
        except OSError as error:
            raise BadInput(f"{path}: cannot read the reference ({error.strerror})") from None
    rows = [row for row in csv.reader(text.splitlines()) if row]
    if len(rows) < 2:
        raise BadInput(f"{path}: needs a header (time first, then variable names) and at least one row")
    if any(len(row) != len(rows[0]) for row in rows[1:]):
        raise BadInput(f"{path}: every row needs {len(rows[0])} values")
    return rows


def _number(path: Path, name: str, cell: str, kind: str) -> float:
    cell = cell.strip()
    if not cell:
        return math.nan
    if kind == "Boolean" and cell.lower() in ("true", "false"):
        return float(cell.lower() == "true")
    try:
        return float(cell)
    except ValueError:
        raise BadInput(f"{path}: column {name!r}: {cell!r} is not a number") from None


def _column(path: Path, variable, cells: list[str]) -> dict[str, np.ndarray]:
    """{name: values} of one column; an array's column as one per element."""
    kind = variable.type
    if not is_array(variable):
        return {variable.name: np.array([_number(path, variable.name, c, kind) for c in cells])}
    n = size(variable)
    split = [c.split() for c in cells]
    bad = next((c for c, parts in zip(cells, split) if parts and len(parts) != n), None)
    if bad is not None:
        raise BadInput(f"{path}: column {variable.name!r}: {bad!r} is not {n} values (the array's size)")
    values = np.array([[_number(path, variable.name, p, kind) for p in parts] if parts else [math.nan] * n
                       for parts in split]).reshape(len(cells), n)
    return {element.name: values[:, k] for k, element in enumerate(elements(variable))}


def _note(names: list[str], why: str) -> list[str]:
    return [f"column{'s' if len(names) > 1 else ''} {', '.join(names)}: {why}"] if names else []


def read_reference_csv(path: str | Path, target, origin: str | None = None, text: str | None = None,
                       inputs_only: bool = False, strict: bool = True) -> Reference:
    """A reference CSV (module docstring): time first, then columns named like the FMU's
    variables. Bad input for what cannot be read; with `strict` also for a column that names
    no variable of the FMU (else it is left out with a note)."""
    path = Path(path)
    rows = _cells(path, text)
    header = [name.strip() for name in rows[0]]
    unknown = [name for name in header[1:] if name not in target.variables]
    if unknown and strict:
        raise BadInput(f"{path}: column {unknown[0]!r} is not a variable of {target.name}")
    driven = {v.name for v in target.inputs}
    stimulus, compared, undriven, texts = {}, {}, [], []
    for j, name in enumerate(header[1:], 1):
        v = target.variables.get(name)
        if v is None:
            continue
        if v.causality == "input" and name not in driven:
            undriven.append(name)
        elif v.type not in NUMERIC:
            texts.append(name)
        else:
            (stimulus if name in driven else compared).update(_column(path, v, [row[j] for row in rows[1:]]))
    times = np.array([_number(path, header[0], row[0], "Real") for row in rows[1:]])
    if not np.all(np.isfinite(times)) or np.any(np.diff(times) < 0):
        raise BadInput(f"{path}: time must be finite and not decreasing")
    if times[0] != 0.0:
        raise BadInput(f"{path}: the reference starts at t = {times[0]:g} s; pendfmu check starts its runs at 0")
    if inputs_only and compared:
        raise BadInput(f"{path}: column {next(iter(compared))!r} is not an input of {target.name}")
    notes = (_note(unknown, f"not variables of {target.name}, not compared")
             + _note(texts, "not numbers, not compared")
             + _note(undriven, "inputs pendfmu check does not drive (not floating-point), held at their start values"))
    if not compared and not inputs_only and strict:
        raise BadInput(f"{path}: no column to compare (every column is an input of {target.name})")
    if any(np.isnan(c).any() for c in stimulus.values()):
        raise BadInput(f"{path}: an input column has a missing value")
    return Reference(times, stimulus, compared, origin or str(path), notes)


def carried(target) -> list[Reference]:
    """The reference results the FMU carries (FMI-LS-REF), each with its stimulus: the
    stimulus's columns held from each of its rows to the next (on the reference's very rows
    when both files share the time column). What could not be used is in the first one's
    notes (an empty reference carries them when nothing else is there)."""
    from pendfmu.export import lsref

    shipped = lsref.carried(target.path)
    references = []
    for found in shipped.results:
        reference = read_reference_csv(f"{target.name}:{found.member}", target, text=found.text, strict=False,
                                       origin=f"reference from the FMU: {found.member}")
        reference.carried = True
        reference.notes = [f"{found.member}: {note}" for note in reference.notes]
        if found.stimulus_text is not None:
            stimulus = read_reference_csv(f"{target.name}:{found.stimulus_member}", target, text=found.stimulus_text,
                                          inputs_only=True, strict=False)
            _hold(stimulus, reference)
            reference.notes += [f"{found.stimulus_member}: {note}" for note in stimulus.notes]
        references.append(reference)
    if shipped.notes:
        if not references:
            references.append(Reference(np.zeros(1), {}, {}, "FMI-LS-REF", carried=True))
        references[0].notes = shipped.notes + references[0].notes
    return references


def _hold(stimulus: Reference, reference: Reference) -> None:
    """The stimulus's inputs on the reference's rows, each held from its row to the next."""
    same_grid = len(stimulus.times) == len(reference.times) and np.array_equal(stimulus.times, reference.times)
    index = (np.arange(len(reference.times)) if same_grid else
             np.maximum(np.searchsorted(stimulus.times, reference.times, side="right") - 1, 0))
    for name, column in stimulus.inputs.items():
        reference.inputs.setdefault(name, column[index])
