"""Agreement with a reference result inside a tolerance tube.

The FMU runs on the reference's time grid (inputs from the reference file's input columns,
or from --input, held over each step), and each compared variable y is checked against the
reference r at every row i of the grid:

    window_i = [t_i - ttol, t_i + ttol]
    lo_i, hi_i = min and max of r over window_i
    tol_i = atol + rtol * max(max(|lo_i|, |hi_i|), nominal)
    y_i passes when lo_i - tol_i <= y_i <= hi_i + tol_i

r is read as a function of time: linear between rows, and a repeated time stamp (two rows at
the same t, the FMI convention) is a jump, so both of its values belong to any window that
contains t. min/max over the window are taken over the rows inside it and r interpolated at
its two ends. The time tolerance is what lets an event a few microseconds away from the
reference's pass (csv-compare fails there and near zero: its issues #66 and #76); the
nominal floor (the variable's `nominal` attribute, else the reference column's range) keeps
a relative tolerance from shrinking to nothing where the signal crosses zero.

Defaults: rtol 1e-3, atol 0 (the nominal floor is the absolute part: 1e-3 of the variable's
nominal or range), ttol a tenth of the reference's median sample interval. Two correct
solvers at their usual tolerances agree far inside 1e-3 of a variable's range, a result
written with 6 significant digits rounds at 5e-7, and a wrong parameter of 1 % moves the
result by about 1e-2 of its range; a tenth of a sample covers event times that differ by the
event location accuracy of two simulators without letting a result a whole sample late pass.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pendfmu.check.fmu import CheckResult, Driver, Target, call_error
from pendfmu.errors import BadInput

DEFAULT_RTOL = 1e-3
DEFAULT_ATOL = 0.0
TTOL_FRACTION = 0.1


@dataclass
class Reference:
    """A reference result: times (non-decreasing; repeated = a jump), the stimulus columns
    (named like the FMU's inputs) and the columns to compare; `origin` says where it came from."""
    times: np.ndarray
    inputs: dict[str, np.ndarray]
    outputs: dict[str, np.ndarray]
    origin: str


def default_ttol(times: np.ndarray) -> float:
    """A tenth of the median positive sample interval (0 for a single row)."""
    steps = np.diff(np.asarray(times, dtype=float))
    steps = steps[steps > 0]
    return float(TTOL_FRACTION * np.median(steps)) if steps.size else 0.0


def _range_table(values: np.ndarray, op) -> list[np.ndarray]:
    """Sparse table: level k holds op over values[i : i + 2**k]."""
    table = [values]
    width = 1
    while 2 * width <= len(values):
        previous = table[-1]
        table.append(op(previous[:-width], previous[width:]))
        width *= 2
    return table


def _range_query(table: list[np.ndarray], first: np.ndarray, last: np.ndarray, op) -> np.ndarray:
    """op over values[first[i] .. last[i]] (inclusive) for every i."""
    length = last - first + 1
    level = np.floor(np.log2(np.maximum(length, 1))).astype(int)
    out = np.empty(len(first))
    for k in np.unique(level):
        rows = level == k
        width = 1 << int(k)
        out[rows] = op(table[k][first[rows]], table[k][last[rows] - width + 1])
    return out


def _interpolate(times: np.ndarray, values: np.ndarray, at: np.ndarray, side: str) -> np.ndarray:
    """r at `at` (linear between rows); at a repeated time stamp the value on `side`
    ("left": before the jump, "right": after); NaN outside the grid."""
    out = np.full(len(at), np.nan)
    inside = (at >= times[0]) & (at <= times[-1])
    if side == "left":  # the last row strictly before, the first at or after
        k = np.searchsorted(times, at[inside], side="left")
        before, after = np.maximum(k - 1, 0), np.minimum(k, len(times) - 1)
    else:  # the last row at or before, the first strictly after
        k = np.searchsorted(times, at[inside], side="right")
        before, after = np.maximum(k - 1, 0), np.minimum(k, len(times) - 1)
    t0, t1 = times[before], times[after]
    span = np.where(t1 > t0, t1 - t0, 1.0)
    w = np.where(t1 > t0, (at[inside] - t0) / span, 0.0)
    v0, v1 = values[before], values[after]
    out[inside] = np.where(w == 0.0, v0, v0 + w * (v1 - v0))
    return out


def tube(times: np.ndarray, reference: np.ndarray, ttol: float) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi): min and max of the reference over [t_i - ttol, t_i + ttol] for every row i
    (NaN reference samples are left out; a row whose window holds none gives NaN)."""
    times = np.asarray(times, dtype=float)
    reference = np.asarray(reference, dtype=float)
    first = np.searchsorted(times, times - ttol, side="left")
    last = np.searchsorted(times, times + ttol, side="right") - 1
    lo = _range_query(_range_table(reference, np.fmin), first, last, np.fmin)
    hi = _range_query(_range_table(reference, np.fmax), first, last, np.fmax)
    if ttol > 0:
        valid = ~np.isnan(reference)
        t, r = times[valid], reference[valid]
        if len(t):
            for at, side in ((times - ttol, "right"), (times + ttol, "left")):
                edge = _interpolate(t, r, at, side)
                lo, hi = np.fmin(lo, edge), np.fmax(hi, edge)
    return lo, hi


@dataclass
class Violation:
    """Where one variable is furthest outside its tube."""
    index: int
    time: float
    size: float          # distance outside the tube
    value: float
    lo: float
    hi: float
    tol: float           # the tube's half-width beyond [lo, hi] there
    count: int           # rows outside the tube
    rows: int            # rows compared


def tube_check(times, reference, result, atol: float, rtol: float, ttol: float, nominal: float):
    """(lo, hi, tol, excess) per row: excess = distance of the result outside [lo, hi]
    (0 inside, inf for a non-finite result where the reference is finite)."""
    lo, hi = tube(times, reference, ttol)
    tol = atol + rtol * np.maximum(np.maximum(np.abs(lo), np.abs(hi)), nominal)
    result = np.asarray(result, dtype=float)
    excess = np.maximum(np.maximum(lo - result, result - hi), 0.0)
    excess = np.where(np.isfinite(result), excess, np.inf)
    excess = np.where(np.isnan(lo) | np.isnan(np.asarray(reference, dtype=float)), 0.0, excess)
    return lo, hi, tol, excess


def _nominal_of(name: str, reference: np.ndarray, nominal: Mapping[str, float] | None) -> tuple[float, str]:
    if nominal is not None and name in nominal and nominal[name] is not None:
        return abs(float(nominal[name])), "nominal"
    finite = reference[np.isfinite(reference)]
    if not finite.size:
        return 1.0, "range"
    spread = float(finite.max() - finite.min())
    return (spread if spread > 0 else float(np.max(np.abs(finite))) or 1.0), "range"


def compare(times, reference: Mapping[str, np.ndarray], result: Mapping[str, np.ndarray],
            atol: float = DEFAULT_ATOL, rtol: float = DEFAULT_RTOL, ttol: float | None = None,
            nominal: Mapping[str, float] | None = None, plot_dir: str | Path | None = None,
            label: str = "") -> list[CheckResult]:
    """One row per variable of `reference`: the result (same times) inside the tube?

    `nominal` maps names to the floor of the relative tolerance (a name it lacks: the
    reference column's range, max - min). `ttol` None: a tenth of the median sample
    interval. With `plot_dir` a PNG per failing variable (reference, tube, result and the
    violations). `label` is appended to each row's name (" CS", " ME")."""
    times = np.asarray(times, dtype=float)
    if ttol is None:
        ttol = default_ttol(times)
    rows = []
    for name, ref in reference.items():
        ref = np.asarray(ref, dtype=float)
        row_name = f"reference: {name}{label}"
        if name not in result:
            rows.append(CheckResult(row_name, False, "not in the result", f"the result has no variable {name}"))
            continue
        floor, floor_kind = _nominal_of(name, ref, nominal)
        lo, hi, tol, excess = tube_check(times, ref, result[name], atol, rtol, ttol, floor)
        ratio = np.where(tol > 0, excess / np.where(tol > 0, tol, 1.0), np.where(excess > 0, np.inf, 0.0))
        outside = excess > tol
        value = np.asarray(result[name], dtype=float)
        if not outside.any():
            k = int(np.argmax(ratio)) if len(ratio) else 0
            used = float(ratio[k]) if len(ratio) else 0.0
            rows.append(CheckResult(row_name, True, f"inside the tube: worst {used:.2g} of the tolerance "
                                                    f"(t = {times[k]:.9g} s), {floor_kind} {floor:.3g}"))
            continue
        beyond = np.where(outside, excess - tol, -np.inf)
        k = int(np.argmax(beyond))
        v = Violation(k, float(times[k]), float(excess[k] - tol[k]), float(value[k]), float(lo[k]), float(hi[k]),
                      float(tol[k]), int(outside.sum()), int(np.sum(~np.isnan(ref))))
        figure = f"{name}: {v.size:.3g} outside at t = {v.time:.9g} s (tube ±{v.tol:.3g})"
        message = (f"{name} leaves the tolerance tube at t = {v.time:.9g} s by {v.size:.3g}: result {v.value:.8g}, "
                   f"reference within ±{ttol:.3g} s in [{v.lo:.8g}, {v.hi:.8g}], tube ±{v.tol:.3g} "
                   f"(= {atol:g} + {rtol:g} x max(|reference|, {floor_kind} {floor:.3g})); "
                   f"{v.count} of {v.rows} samples outside")
        if plot_dir is not None:
            path = plot_violation(Path(plot_dir) / f"{_safe(name)}{_safe(label)}.png", name, times, ref, value,
                                  lo - tol, hi + tol, outside, v)
            message += f"; plot {path}"
        rows.append(CheckResult(row_name, False, figure, message))
    return rows


def _safe(text: str) -> str:
    return "".join(c if c.isalnum() or c in "-_." else "_" for c in text.strip())


def plot_violation(path: Path, name: str, times, reference, result, low, high, outside, worst: Violation) -> Path:
    """A PNG: the reference, its tube, the result and the rows outside, the worst one marked."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path.parent.mkdir(parents=True, exist_ok=True)
    figure, (axis, below) = plt.subplots(2, 1, figsize=(9, 6.5), sharex=True, height_ratios=(3, 2))
    axis.fill_between(times, low, high, color="tab:blue", alpha=0.2, label="tolerance tube")
    axis.plot(times, reference, color="tab:blue", lw=1, label="reference")
    axis.plot(times, result, color="tab:orange", lw=1, ls="--", label="result")
    axis.plot(times[outside], result[outside], "x", color="tab:red", ms=4, label="outside the tube")
    axis.annotate(f"worst: {worst.size:.3g} at t = {worst.time:.6g} s", (worst.time, worst.value),
                  textcoords="offset points", xytext=(10, 10), color="tab:red",
                  arrowprops=dict(arrowstyle="->", color="tab:red"))
    axis.set_ylabel(name)
    axis.set_title(f"{name}: {worst.count} of {worst.rows} samples outside the tube")
    axis.legend(loc="best", fontsize="small")
    # the same, minus the reference: the tube's width and the deviation become visible
    below.fill_between(times, low - reference, high - reference, color="tab:blue", alpha=0.2, label="tube - reference")
    below.plot(times, result - reference, color="tab:orange", lw=1, label="result - reference")
    below.plot(times[outside], (result - reference)[outside], "x", color="tab:red", ms=4)
    below.axhline(0.0, color="tab:blue", lw=0.5)
    below.set_xlabel("time [s]")
    below.set_ylabel(f"{name} - reference")
    below.legend(loc="best", fontsize="small")
    figure.tight_layout()
    figure.savefig(path, dpi=100)
    plt.close(figure)
    return path


# -- reading a reference and running the FMU on its grid

def read_reference_csv(path: str | Path, target: Target, origin: str | None = None, text: str | None = None,
                       inputs_only: bool = False) -> Reference:
    """A reference CSV: time first, then columns named like the FMU's variables; columns of
    inputs are the stimulus, the others are compared. Empty cells are missing samples."""
    path = Path(path)
    if text is None:
        try:
            text = path.read_text()
        except OSError as error:
            raise BadInput(f"{path}: cannot read the reference ({error.strerror})") from None
    rows = [row for row in csv.reader(text.splitlines()) if row]
    if len(rows) < 2:
        raise BadInput(f"{path}: needs a header (time first, then variable names) and at least one row")
    header = [name.strip() for name in rows[0]]
    inputs = {v.name for v in target.inputs}
    unknown = [name for name in header[1:] if name not in target.variables]
    if unknown:
        raise BadInput(f"{path}: column {unknown[0]!r} is not a variable of {target.name}")
    try:
        data = np.array([[float(x) if x.strip() else math.nan for x in row] for row in rows[1:]], dtype=float)
    except ValueError as error:
        raise BadInput(f"{path}: {error}") from None
    if data.ndim != 2 or data.shape[1] != len(header):
        raise BadInput(f"{path}: every row needs {len(header)} values")
    times = data[:, 0]
    if not np.all(np.isfinite(times)) or np.any(np.diff(times) < 0):
        raise BadInput(f"{path}: time must be finite and not decreasing")
    if times[0] != 0.0:
        raise BadInput(f"{path}: the reference starts at t = {times[0]:g} s; pendfmu check starts its runs at 0")
    columns = {name: data[:, j] for j, name in enumerate(header) if j}
    stimulus = {n: c for n, c in columns.items() if n in inputs}
    compared = {n: c for n, c in columns.items() if n not in inputs}
    if inputs_only and compared:
        raise BadInput(f"{path}: column {next(iter(compared))!r} is not an input of {target.name}")
    if not compared and not inputs_only:
        raise BadInput(f"{path}: no column to compare (every column is an input of {target.name})")
    if any(np.isnan(c).any() for c in stimulus.values()):
        raise BadInput(f"{path}: an input column has a missing value")
    return Reference(times, stimulus, compared, origin or str(path))


def run_on_grid(target: Target, kind: str, reference: Reference,
                recording: tuple[np.ndarray, dict[str, np.ndarray]] | None = None) -> dict[str, np.ndarray]:
    """The FMU (fresh instance, its Real parameters set to their declared start values) run
    through the reference's rows: a step from
    each row's time to the next (none at a repeated time stamp), the inputs of the row held
    over it; the compared variables read after each step."""
    times = reference.times
    columns = []
    for v in target.inputs:
        if v.name in reference.inputs:
            columns.append(reference.inputs[v.name])
        elif recording is not None and v.name in recording[1]:
            rec_t, rec = recording
            index = np.maximum(np.searchsorted(rec_t, times + 1e-12 * np.maximum(1.0, np.abs(times)), side="right") - 1, 0)
            columns.append(rec[v.name][index])
        else:
            columns.append(np.full(len(times), float(v.start) if v.start is not None else 0.0))
    inputs = np.column_stack(columns) if columns else None
    variables = [target.variables[name] for name in reference.outputs]
    unit = Driver(target, kind, name="reference")
    out = np.full((len(times), len(variables)), np.nan)

    def read(k: int) -> None:
        for j, v in enumerate(variables):
            getter = {"Real": unit.fmu.getReal, "Integer": unit.fmu.getInteger,
                      "Boolean": unit.fmu.getBoolean}.get(v.type)
            if getter is not None:
                out[k, j] = float(getter([v.valueReference])[0])
    try:
        # every Real parameter at the start value the model description declares, as an
        # importer that applies start values does: a copy whose XML says other values than
        # its binary's defaults (pendfmu export --fmu) is checked as it is described
        starts = {v.name: float(v.start) for v in target.parameters if v.start is not None}
        unit.initialize(starts, inputs[0] if inputs is not None else None)
        read(0)
        for k in range(len(times) - 1):
            h = times[k + 1] - times[k]
            if h > 0:
                unit.time = float(times[k])
                unit.step(float(h), inputs[k] if inputs is not None else None)
                unit.time = float(times[k + 1])
            elif inputs is not None and len(unit.in_vr):  # a jump of the inputs: set, no time passes
                unit.fmu.setReal(unit.in_vr, list(inputs[k + 1]))
            read(k + 1)
    except Exception as error:
        raise RuntimeError(f"the run on the reference's grid failed: {call_error(error)}") from None
    finally:
        unit.free()
    return {name: out[:, j] for j, name in enumerate(reference.outputs)}


def nominals(target: Target, names) -> dict[str, float]:
    """The model description's nominal of each name that declares one."""
    found = {}
    for name in names:
        nominal = getattr(target.variables[name], "nominal", None)
        if nominal not in (None, ""):
            found[name] = float(nominal)
    return found


def run(target: Target, kind: str, reference: Reference, atol: float = DEFAULT_ATOL, rtol: float = DEFAULT_RTOL,
        ttol: float | None = None, plot_dir: str | Path | None = None) -> list[CheckResult]:
    """The reference rows for one interface."""
    try:
        result = run_on_grid(target, kind, reference, target.recording)
    except Exception as error:
        return [CheckResult(f"reference: run {kind}", False, "run failed", str(error))]
    rows = compare(reference.times, reference.outputs, result, atol, rtol, ttol,
                   nominals(target, reference.outputs), plot_dir, f" {kind}")
    for row in rows:
        row.figure += f" [{reference.origin}]"
    return rows



def carried(target: Target) -> list[Reference]:
    """The reference results the FMU carries (FMI-LS-REF, pendfmu/export/lsref.py), each
    with its stimulus: the stimulus's columns held from each of its rows to the next (on
    the reference's very rows when both files share the time column)."""
    from pendfmu.export import lsref

    references = []
    for found in lsref.carried(target.path):
        where = f"{target.name}:{found.member}"
        reference = read_reference_csv(where, target, origin=f"reference from the FMU: {found.member}",
                                       text=found.text)
        if found.stimulus_text is not None:
            stimulus = read_reference_csv(f"{target.name}:{found.stimulus_member}", target, text=found.stimulus_text,
                                          inputs_only=True)
            same_grid = len(stimulus.times) == len(reference.times) and np.array_equal(stimulus.times, reference.times)
            index = (np.arange(len(reference.times)) if same_grid else
                     np.maximum(np.searchsorted(stimulus.times, reference.times, side="right") - 1, 0))
            for name, column in stimulus.inputs.items():
                reference.inputs.setdefault(name, column[index])
        references.append(reference)
    return references
