"""Any FMI 2.0 or 3.0 FMU, driven the same way in Co-Simulation and Model Exchange, for the checks.

`Target(path)` reads the model description and unpacks the FMU once (through the
binding's `unpacked_fmu`) and picks what the checks drive and compare: the floating-point
inputs, the numeric outputs (array elements as columns of their own), the floating-point
parameters (pendfmu/check/variables.py). `Driver(target, "CS" | "ME")` (pendfmu/check/driver.py)
is one instance of it, stepped from one communication point to the next.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pendfmu.check.driver import Driver  # noqa: F401 (the checks' one way to run the target)
from pendfmu.check.variables import FLOAT, NUMERIC, elements, is_array
from pendfmu.errors import BadInput, FMUError
from pendfmu.simulator.fmi import unpacked_fmu


MAX_FIXED_STEPS = 10_000
"""A default run covers at most this many of an FMU's declared fixed internal steps."""

PASS, WARN, FAIL, INCONCLUSIVE = "PASS", "WARN", "FAIL", "INCONCLUSIVE"
VERDICTS = (PASS, WARN, FAIL, INCONCLUSIVE)
"""What a row says: PASS, the check exercised what it checks and the FMU did it right; WARN,
the FMU does something FMI leaves to it in a way a user should know (the reason says why);
FAIL, the FMU breaks what FMI requires or what the check measured; INCONCLUSIVE, the run
exercised nothing the check could judge (the reason says what was missing)."""


@dataclass
class CheckResult:
    """One row of the battery: its name, its verdict (VERDICTS; True and False are PASS and
    FAIL), the measured figure (a short text: what was exercised and what was measured) and
    what a user should know (why it did not pass)."""
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
        """Nothing wrong found and something exercised: PASS or WARN."""
        return self.verdict in (PASS, WARN)


@dataclass
class Span:
    """Where an input is exercised: [low, high] and whether the FMU declared it."""
    low: float
    high: float
    declared: bool


class Target:
    """An FMU file: its description, unzipped binary, interfaces, inputs, outputs, parameters."""

    def __init__(self, path: str | Path, stop: float | None = None, step: float | None = None,
                 recording: str | Path | None = None):
        self.path = Path(path)
        if not self.path.is_file():
            raise BadInput(f"{path}: no such FMU file")
        try:
            self.directory, self.md = unpacked_fmu(self.path.stem, self.path)
        except Exception as error:  # not a zip, no modelDescription.xml, unreadable XML
            raise BadInput(f"{path}: not a readable FMU ({type(error).__name__}: {error})") from None
        major = str(self.md.fmiVersion).split(".")[0]
        if major not in ("2", "3"):
            raise BadInput(f"{path}: FMI {self.md.fmiVersion}; pendfmu check reads FMI 2.0 and 3.0 FMUs")
        self.fmi3 = major == "3"
        self.interfaces = [name for name, kind in (("CS", self.md.coSimulation), ("ME", self.md.modelExchange))
                           if kind is not None]
        self._pick_variables(self.md.modelVariables)
        self.shortened = ""
        experiment = self.md.defaultExperiment
        declared_stop = float(experiment.stopTime) if experiment is not None and experiment.stopTime else None
        declared_step = float(experiment.stepSize) if experiment is not None and experiment.stepSize else None
        self.recording = read_inputs(recording, [v.name for v in self.inputs]) if recording else None
        if stop is None and self.recording is not None:
            stop = float(self.recording[0][-1]) or None
        self.stop = stop if stop is not None else self._default_stop(declared_stop or 1.0)
        self.step = step if step is not None else (declared_step or self.stop / 500)
        if not (self.stop > 0 and self.step > 0 and self.step < self.stop):
            raise BadInput(f"--stop {self.stop} and --step {self.step}: need 0 < step < stop")

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

    def span(self, v) -> Span:
        """The declared [min, max] of an input, else its start value +- max(1, |start|/2)."""
        start = float(v.start) if v.start is not None else 0.0
        low = float(v.min) if v.min is not None else None
        high = float(v.max) if v.max is not None else None
        if low is not None and high is not None and math.isfinite(low) and math.isfinite(high) and high - low < 1e12:
            return Span(low, high, True)
        half = max(1.0, abs(start) / 2)
        return Span(start - half if low is None else max(low, start - half),
                    start + half if high is None else min(high, start + half), False)

    def stimulus(self, hold: float) -> Callable[[float], np.ndarray]:
        """Each Real input a slow sine (one and a half periods over the run, its own phase)
        over its span, held constant over intervals of `hold` so that runs with the
        communication step hold, hold/2, ... see the same input."""
        spans = [self.span(v) for v in self.inputs]
        stop = self.stop
        times, columns = self.recording if self.recording is not None else (None, {})
        recorded = [columns.get(v.name) for v in self.inputs]

        def at(t: float) -> np.ndarray:
            t = math.floor(t / hold + 1e-9) * hold
            row = np.array([0.5 * (s.low + s.high) + 0.5 * (s.high - s.low) *
                            math.sin(3 * math.pi * t / stop + 0.7 * k) for k, s in enumerate(spans)])
            if times is not None:  # recorded inputs: the last sample at or before t
                i = max(0, int(np.searchsorted(times, t + 1e-12 * max(1.0, abs(t)), side="right")) - 1)
                for k, column in enumerate(recorded):
                    if column is not None:
                        row[k] = column[i]
            return row
        return at

    def varied_parameter(self):
        """(variable, a non-default value) of a Real parameter, or None: the parameter a
        reset check changes. Prefers one whose value is nonzero (a mass, a gain)."""
        candidates = sorted(self.parameters, key=lambda v: (v.start is None or float(v.start) == 0.0))
        for v in candidates:
            start = float(v.start) if v.start is not None else 0.0
            value = start * 1.25 if start != 0 else 0.5
            low = float(v.min) if v.min is not None else -math.inf
            high = float(v.max) if v.max is not None else math.inf
            if not low <= value <= high:
                value = start * 0.8 if start != 0 else (low + start) / 2 if math.isfinite(low) else start - 0.5
            if low <= value <= high and value != start:
                return v, value
        return None


def read_inputs(path: str | Path, inputs: list[str]) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """(times, {input: values}) from a CSV file whose first column is time and whose other
    columns are named like the FMU's inputs (an input without a column keeps the default
    stimulus). Bad input (exit 2) for a missing file, an unknown column or a bad number."""
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
    unknown = [name for name in header[1:] if name not in inputs]
    if unknown:
        raise BadInput(f"{path}: column {unknown[0]!r} is not an input of the FMU (inputs: {', '.join(inputs)})")
    try:
        data = np.array([[float(x) for x in row] for row in rows[1:] if row], dtype=float)
    except ValueError as error:
        raise BadInput(f"{path}: {error}") from None
    if data.shape[1] != len(header) or not np.all(np.isfinite(data)) or np.any(np.diff(data[:, 0]) < 0):
        raise BadInput(f"{path}: every row needs {len(header)} finite numbers, time not decreasing")
    return data[:, 0], {name: data[:, j] for j, name in enumerate(header) if j}


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
