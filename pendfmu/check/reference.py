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

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pendfmu.check.driver import StiffModel
from pendfmu.check.fmu import INCONCLUSIVE, WARN, CheckResult, Driver, Target, call_error
from pendfmu.check.reference_files import Reference, carried, read_reference_csv  # noqa: F401 (the API)
from pendfmu.check.variables import Reader, elements, slot

DEFAULT_RTOL = 1e-3
DEFAULT_ATOL = 0.0
TTOL_FRACTION = 0.1


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
    """Whether results already computed lie inside the reference's tolerance tube, one row
    per variable of the reference.

    At each time t the tube spans the reference's values over [t - ttol, t + ttol],
    widened by atol + rtol * max(|reference|, nominal); a failing row names the worst
    point, by how much it is missed and how many samples are outside.

    Parameters
    ----------
    times : array_like of float
        The times [s] of both the reference's and the result's rows.
    reference : mapping of str to ndarray
        The reference values by variable name.
    result : mapping of str to ndarray
        The results by variable name, at the same times; a reference variable missing here
        fails its row.
    atol : float, optional
        The tube's absolute half-width, in each variable's unit.
    rtol : float, optional
        Its relative half-width.
    ttol : float, optional
        The time tolerance [s]; None: a tenth of the median sample interval.
    nominal : mapping of str to float, optional
        Per variable, the floor of the relative tolerance; a name it lacks: the reference
        column's range, max - min.
    plot_dir : str or Path, optional
        Where a PNG per failing variable goes (reference, tube, result and the violations).
    label : str, optional
        Appended to each row's name (" CS", " ME").

    Returns
    -------
    list of CheckResult
        One row per variable of `reference`: PASS inside the tube, else FAIL.
    """
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


# -- running the FMU on the reference's grid

def column(target: Target, name: str):
    """The variable, or array Element, of a reference column's name (y, y[2], A[1,3])."""
    if name in target.variables:
        return target.variables[name]
    array = target.variables[name.split("[", 1)[0]]
    return next(e for e in elements(array) if e.name == name)


def _inputs_on_grid(target: Target, reference: Reference, recording) -> np.ndarray | None:
    """The driven inputs at each row: the reference's column, else --input's, else the start value."""
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
    return np.column_stack(columns) if columns else None


def run_on_grid(target: Target, kind: str, reference: Reference,
                recording: tuple[np.ndarray, dict[str, np.ndarray]] | None = None) -> dict[str, np.ndarray]:
    """The FMU (fresh instance, its floating-point parameters set to their declared start
    values) run through the reference's rows: a step from each row's time to the next
    (none at a repeated time stamp), the inputs of the row held over it; the compared
    variables read after each step."""
    times = reference.times
    inputs = _inputs_on_grid(target, reference, recording)
    reader = Reader([slot(column(target, name)) for name in reference.outputs], target.fmi3)
    unit = Driver(target, kind, name="reference")
    out = np.full((len(times), len(reference.outputs)), np.nan)
    try:
        # every floating-point parameter at the start value the model description declares,
        # as an importer that applies start values does: a copy whose XML says other values
        # than its binary's defaults (pendfmu export --fmu) is checked as it is described
        starts = {v.name: float(v.start) for v in target.parameters if v.start is not None}
        unit.initialize(starts, inputs[0] if inputs is not None else None)
        out[0] = reader.read(unit.fmu)
        for k in range(len(times) - 1):
            h = times[k + 1] - times[k]
            if h > 0:
                unit.time = float(times[k])
                unit.step(float(h), inputs[k] if inputs is not None else None)
                unit.time = float(times[k + 1])
            elif inputs is not None:  # a jump of the inputs: set, no time passes
                unit.set_inputs(inputs[k + 1])
            out[k + 1] = reader.read(unit.fmu)
    except StiffModel:
        raise
    except Exception as error:
        raise RuntimeError(f"the run on the reference's grid failed: {call_error(error)}") from None
    finally:
        unit.free()
    return {name: out[:, j] for j, name in enumerate(reference.outputs)}


def nominals(target: Target, names) -> dict[str, float]:
    """The model description's nominal of each name that declares one (an array's: its
    element's, or the one for all)."""
    found = {}
    for name in names:
        v = column(target, name)
        nominal = getattr(v, "nominal", None)
        if nominal in (None, ""):
            continue
        values = str(nominal).split()
        index = getattr(v, "index", 0)
        found[name] = float(values[index] if index < len(values) else values[0])
    return found


def run(target: Target, kind: str, reference: Reference, atol: float = DEFAULT_ATOL, rtol: float = DEFAULT_RTOL,
        ttol: float | None = None, plot_dir: str | Path | None = None) -> list[CheckResult]:
    """The reference rows for one interface; what was left out of the reference (its notes)
    a WARN row, once (with the first interface). A reference the FMU carries is judged for
    every interface at the first call (judge_carried) and each later call gets its rows."""
    if reference.carried:
        if reference.judged is None:
            reference.judged = judge_carried(target, reference, atol, rtol, ttol, plot_dir)
        return reference.judged.get(kind, [])
    return _notes(target, kind, reference) + _compared(target, kind, reference, atol, rtol, ttol, plot_dir)


def judge_carried(target: Target, reference: Reference, atol: float, rtol: float, ttol: float | None,
                  plot_dir) -> dict[str, list[CheckResult]]:
    """{interface: rows} for a reference the FMU carries. Where one interface reproduces it
    and another does not, the other's tube failures are WARNs: a carried result is one
    solver's (the Reference FMUs': Co-Simulation with the FMU's own fixed-step Euler), FMI-LS-REF
    does not record which interface or solver made it, and FMI lets the interfaces differ by
    their solvers' accuracy (Model Exchange is integrated here by pendfmu's driver)."""
    rows = {kind: _compared(target, kind, reference, atol, rtol, ttol, plot_dir) for kind in target.interfaces}
    reproduced = [kind for kind, compared in rows.items() if compared and all(r.passed for r in compared)]
    if reproduced:
        for kind, compared in rows.items():
            for row in compared:
                if not row.passed and not row.name.startswith("reference: run "):
                    row.verdict = WARN
                    row.message += (f"; the FMU's {reproduced[0]} reproduces this carried reference: it is one "
                                    f"solver's result, and which interface or solver made it FMI-LS-REF does not "
                                    f"record (the interfaces may differ by their solvers' accuracy)")
    if target.interfaces:
        first = target.interfaces[0]
        rows[first] = _notes(target, first, reference) + rows[first]
    return rows


def _notes(target: Target, kind: str, reference: Reference) -> list[CheckResult]:
    if not reference.notes or kind != target.interfaces[0]:
        return []
    label = "FMI-LS-REF" if reference.carried else Path(reference.origin).name
    count = len(reference.notes)
    return [CheckResult(f"reference: {label}", WARN, f"{count} note{'s' if count > 1 else ''}: not all of it compared",
                        "; ".join(reference.notes))]


def _compared(target: Target, kind: str, reference: Reference, atol: float, rtol: float, ttol: float | None,
              plot_dir) -> list[CheckResult]:
    """The FMU on the reference's grid in one interface, a row per compared variable."""
    if not reference.outputs:
        return []
    try:
        result = run_on_grid(target, kind, reference, target.recording)
    except StiffModel as error:
        return [CheckResult(f"reference: run {kind}", INCONCLUSIVE, "not run to the end", str(error))]
    except Exception as error:
        return [CheckResult(f"reference: run {kind}", False, "run failed", str(error))]
    compared = compare(reference.times, reference.outputs, result, atol, rtol, ttol,
                       nominals(target, reference.outputs), plot_dir, f" {kind}")
    for row in compared:
        row.figure += f" [{reference.origin}]"
    return compared
