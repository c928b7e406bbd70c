"""Any FMI 2.0 or 3.0 FMU, driven the same way in Co-Simulation and Model Exchange, for the checks.

`Target(path)` reads the model description and unpacks the FMU once (through the
binding's `unpacked_fmu`) and picks what the checks drive and compare: the floating-point
inputs, the numeric outputs (array elements as columns of their own), the floating-point
parameters (pendfmu/check/variables.py). `Driver(target, "CS" | "ME")` (pendfmu/check/driver.py)
is one instance of it, stepped from one communication point to the next.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pendfmu.check.driver import Driver  # noqa: F401 (the checks' one way to run the target)
from pendfmu.check.variables import FLOAT, NUMERIC, elements, is_array
from pendfmu.errors import BadInput, FMUError
from pendfmu.simulator.fmi import UnsafeFMU, unpacked_fmu


MAX_FIXED_STEPS = 10_000
"""A default run covers at most this many of an FMU's declared fixed internal steps."""
MAX_RUN_STEPS = 20_000
"""Communication steps a run may take when the model description sets the step or the stop
(4 times the most any Reference FMU or pendfmu's own asks for): a longer plan is capped and
the row "static: planned work" says how."""

PASS, WARN, FAIL, INCONCLUSIVE = "PASS", "WARN", "FAIL", "INCONCLUSIVE"
VERDICTS = (PASS, WARN, FAIL, INCONCLUSIVE)
"""What a row says: PASS, the check exercised what it checks and the FMU did it right; WARN,
the FMU does something FMI leaves to it in a way a user should know (the reason says why);
FAIL, the FMU breaks what FMI requires or what the check measured; INCONCLUSIVE, the run
exercised nothing the check could judge (the reason says what was missing)."""


@dataclass
class CheckResult:
    """One row of the battery: a check's name, its verdict, what it measured and, when it
    did not pass, why.

    Attributes
    ----------
    name : str
        The check, e.g. "determinism: fresh instances CS".
    verdict : str
        "PASS", "WARN", "FAIL" or "INCONCLUSIVE" (VERDICTS); True and False given to the
        constructor become PASS and FAIL.
    figure : str
        A short text: what was exercised and what was measured.
    message : str
        What a user should know: why it did not pass, or what a WARN means.

    Raises
    ------
    ValueError
        A verdict that is not one of VERDICTS.
    """
    name: str
    verdict: str | bool
    figure: str = ""
    message: str = ""

    def __post_init__(self) -> None:
        if isinstance(self.verdict, bool):
            self.verdict = PASS if self.verdict else FAIL
        if self.verdict not in VERDICTS:
            raise ValueError(f"verdict {self.verdict!r} is not one of {', '.join(VERDICTS)}")

    @property
    def passed(self) -> bool:
        """Whether nothing wrong was found and something was exercised: PASS or WARN."""
        return self.verdict in (PASS, WARN)


DEFAULT_INPUT_LIMIT = 1000.0
"""How far an input without a declared range is driven: up to this many times its nominal
(1, 10, 100, 1000 times; stimulus.py, the inputs check)."""
DEFAULT_STEP_RTOL = 1e-4
"""How far a result may move with the communication step, of its nominal or range (convergence.py)."""


class Target:
    """An FMU file: its description, unzipped binary, interfaces, inputs, outputs, parameters.

    The options of the dynamic checks are attributes (run_battery sets them): `input_limit`,
    how far an input without a declared range is driven (stimulus.py); `stated_order`, the order
    of a fixed-step solver the FMU is built around, and `step_rtol`, the convergence tolerance
    (convergence.py)."""

    input_limit = DEFAULT_INPUT_LIMIT
    stated_order: float | None = None
    step_rtol = DEFAULT_STEP_RTOL

    def __init__(self, path: str | Path, stop: float | None = None, step: float | None = None,
                 recording: str | Path | None = None):
        self.path = Path(path)
        if not self.path.is_file():
            raise BadInput(f"{path}: no such FMU file")
        self.refused = ""  # why no library of it is loaded (a file name FMI does not allow)
        try:
            self.directory, self.md = unpacked_fmu(self.path.stem, self.path)
        except UnsafeFMU as error:  # the static check's row says why; nothing else runs
            self.directory, self.md, self.refused = None, error.description, str(error)
        except Exception as error:  # not a zip, no modelDescription.xml, unreadable XML
            raise BadInput(f"{path}: not a readable FMU ({type(error).__name__}: {error})") from None
        major = str(self.md.fmiVersion).split(".")[0]
        if major not in ("2", "3"):
            raise BadInput(f"{path}: FMI {self.md.fmiVersion}; pendfmu check reads FMI 2.0 and 3.0 FMUs")
        self.fmi3 = major == "3"
        self.interfaces = [name for name, kind in (("CS", self.md.coSimulation), ("ME", self.md.modelExchange))
                           if kind is not None and not self.refused]
        self._pick_variables(self.md.modelVariables)
        self.shortened = ""
        experiment = self.md.defaultExperiment
        declared_stop = float(experiment.stopTime) if experiment is not None and experiment.stopTime else None
        declared_step = float(experiment.stepSize) if experiment is not None and experiment.stepSize else None
        self.recording, self.ignored_columns = None, []
        if recording:
            times, columns, self.ignored_columns = read_inputs(recording, [v.name for v in self.inputs])
            self.recording = (times, columns)
        self.recording_name = Path(recording).name if recording else ""
        if stop is None and self.recording is not None:
            stop = float(self.recording[0][-1]) or None
        self.stop = stop if stop is not None else self._default_stop(declared_stop or 1.0)
        self.step = step if step is not None else (declared_step or self.stop / 500)
        if not (self.stop > 0 and self.step > 0 and self.step < self.stop):
            raise BadInput(f"--stop {self.stop} and --step {self.step}: need 0 < step < stop")
        self.capped = self._cap(stop is not None, step is not None)

    def _cap(self, stop_given: bool, step_given: bool) -> str:
        """At most MAX_RUN_STEPS steps a run unless the user chose both --stop and --step: the
        step lengthened (or, when the user chose it, the stop shortened). What was capped, in
        words, or "" (a model description's stepSize="1e-300" would plan 1e300 steps)."""
        planned = self.stop / self.step
        if planned <= MAX_RUN_STEPS or (stop_given and step_given):
            return ""
        before = f"{self.stop:g} s in steps of {self.step:g} s ({planned:.3g} steps)"
        if step_given:
            self.stop = self.step * MAX_RUN_STEPS
        else:
            self.step = self.stop / MAX_RUN_STEPS
        return (f"runs of {self.stop:g} s in steps of {self.step:g} s, not {before}: at most {MAX_RUN_STEPS} "
                f"communication steps a run (--stop and --step choose others)")

    def _default_stop(self, declared: float) -> float:
        """The default experiment's stop time, or less where the FMU says it computes with a
        fixed internal step (FMI 3.0 fixedInternalStepSize) and the experiment takes more
        than MAX_FIXED_STEPS of them (Roberts: 1e8 s at 1 ms): `shortened` says so."""
        fixed = getattr(self.md.coSimulation, "fixedInternalStepSize", None) if self.md.coSimulation else None
        if fixed and declared > MAX_FIXED_STEPS * float(fixed):
            stop = MAX_FIXED_STEPS * float(fixed)
            self.shortened = (f"runs of {stop:g} s, not the default experiment's {declared:g} s: "
                              f"{MAX_FIXED_STEPS} of the FMU's fixed internal steps of {float(fixed):g} s")
            return stop
        return declared

    def _pick_variables(self, variables) -> None:
        """What the checks drive (floating-point scalar inputs), compare (numeric outputs,
        an array one column per element), vary (floating-point scalar parameters) and follow
        as modes (discrete integers and Booleans); `unchecked` names what they leave alone."""
        self.variables = {v.name: v for v in variables}
        numeric = [v for v in variables if v.type in NUMERIC]
        self.inputs = [v for v in variables if v.causality == "input" and v.type in FLOAT and not is_array(v)]
        outputs = [v for v in numeric if v.causality == "output"]
        if not outputs:  # nothing declared as output: compare every floating-point value that is computed
            outputs = [v for v in numeric if v.type in FLOAT and v.causality == "local"
                       and v.variability in ("continuous", "discrete")]
        self.outputs = [element for v in outputs for element in elements(v)]
        self.parameters = [v for v in variables if v.causality == "parameter" and v.type in FLOAT and not is_array(v)
                           and v.variability in ("fixed", "tunable")]
        self.modes = [v for v in numeric if v.type not in FLOAT and v.variability == "discrete" and not is_array(v)
                      and v.causality in ("local", "output")]
        held = [v.name for v in variables if v.causality == "input" and v not in self.inputs]
        skipped = [v.name for v in variables if v.causality == "output" and v.type not in NUMERIC]
        self.unchecked = ([f"inputs held at their start values: {', '.join(held)}"] if held else []) + (
            [f"outputs not compared (not numbers): {', '.join(skipped)}"] if skipped else [])

    @property
    def name(self) -> str:
        return self.path.name

    def interface(self, kind: str):
        return self.md.coSimulation if kind == "CS" else self.md.modelExchange

    def varied_parameter(self):
        """(variable, a non-default value) of a Real parameter, or None: the parameter a
        reset check changes. Prefers one whose value is nonzero (a mass, a gain)."""
        candidates = sorted(self.parameters, key=lambda v: (v.start is None or float(v.start) == 0.0))
        for v in candidates:
            value = varied_value(v)
            if value is not None:
                return v, value
        return None


def varied_value(v) -> float | None:
    """A value of parameter v other than its start value, inside its declared range: 1.25 or
    0.8 times the start, else 0.5 or halfway to its minimum; None when none fits."""
    start = float(v.start) if v.start is not None else 0.0
    value = start * 1.25 if start != 0 else 0.5
    low = float(v.min) if v.min is not None else -math.inf
    high = float(v.max) if v.max is not None else math.inf
    if not low <= value <= high:
        value = start * 0.8 if start != 0 else (low + start) / 2 if math.isfinite(low) else start - 0.5
    return value if low <= value <= high and value != start else None


def read_inputs(path: str | Path, inputs: list[str]) -> tuple[np.ndarray, dict[str, np.ndarray], list[str]]:
    """(times, {input: values}, ignored columns) from a CSV file whose first column is time: a
    whole recording, its columns named like the FMU's inputs drive them (an input without a
    column keeps the default stimulus) and the others (measured outputs...) are ignored. Bad
    input (exit 2) for a missing file, no column that is an input, or a bad number."""
    import csv

    path = Path(path)
    try:
        with open(path, newline="") as handle:
            rows = list(csv.reader(handle))
    except OSError as error:
        raise BadInput(f"{path}: cannot read the input recording ({error.strerror})") from None
    if len(rows) < 2:
        raise BadInput(f"{path}: needs a header (time first, then input names) and at least one row")
    header = [name.strip() for name in rows[0]]
    ignored = [name for name in header[1:] if name not in inputs]
    if len(ignored) == len(header) - 1:
        raise BadInput(f"{path}: column {ignored[0]!r} is not an input of the FMU (inputs: {', '.join(inputs)}); "
                       f"no column drives an input" if ignored else f"{path}: no column besides time")
    used = [0] + [j for j, name in enumerate(header) if j and name in inputs]
    body = [row for row in rows[1:] if row]
    if any(len(row) != len(header) for row in body):
        raise BadInput(f"{path}: every row needs {len(header)} columns, like the header")
    try:
        data = np.array([[float(row[j]) for j in used] for row in body], dtype=float)
    except ValueError as error:
        raise BadInput(f"{path}: {error}") from None
    if not np.all(np.isfinite(data)) or np.any(np.diff(data[:, 0]) < 0):
        raise BadInput(f"{path}: time and the inputs' columns need finite numbers, time not decreasing")
    return data[:, 0], {header[j]: data[:, i] for i, j in enumerate(used) if i}, ignored


def call_error(error: Exception) -> str:
    """What went wrong in a run: an FMUError says it all (instance, function, time, what the
    FMU logged); anything else is the checker's own trouble, named by its type."""
    return str(error) if isinstance(error, FMUError) else f"{type(error).__name__}: {error}"


def compare(a: np.ndarray, b: np.ndarray) -> float:
    """The largest difference between two runs (inf where one is not finite and the other is)."""
    if a.shape != b.shape:
        return math.inf
    same_nan = np.isnan(a) & np.isnan(b)
    diff = np.where(same_nan, 0.0, np.abs(a - b))
    return float(np.nanmax(np.where(np.isnan(diff), np.inf, diff))) if diff.size else 0.0


def first_difference(target: Target, a: np.ndarray, b: np.ndarray, times: np.ndarray) -> str:
    """'output v at t = 0.12 s: 0.31 vs 0.29' for the first row where two runs differ."""
    bad = np.argwhere(~((a == b) | (np.isnan(a) & np.isnan(b))))
    if not len(bad):
        return ""
    k, j = bad[0]
    return f"{target.outputs[j].name} at t = {times[k]:.6g} s: {a[k, j]:.10g} vs {b[k, j]:.10g}"
