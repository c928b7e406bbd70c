"""Any FMI 2.0 FMU, driven the same way in Co-Simulation and Model Exchange, for the checks.

`Target(path)` reads the model description and unpacks the FMU once (through the
binding's `unpacked_fmu`); `Driver(target, "CS" | "ME")` instantiates it on the checked
binding (pendfmu.simulator.fmi: a failing call raises FMUError with what the FMU logged),
initializes with parameter values, and steps from one communication point to the next with
inputs held over the step. In Model Exchange the step is integrated here (classical
Runge-Kutta, one stage set per communication step or time-event interval), with state
events located by bisection on the event indicators, so that a discrete change happens at
the same instant whatever the communication step.
"""

from __future__ import annotations

import ctypes
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pendfmu.errors import BadInput, FMUError
from pendfmu.simulator.fmi import instantiate_fmu, unpacked_fmu

DOUBLE_P = ctypes.POINTER(ctypes.c_double)


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
        try:
            self.directory, self.md = unpacked_fmu(self.path.stem, self.path)
        except Exception as error:  # not a zip, no modelDescription.xml, unreadable XML
            raise BadInput(f"{path}: not a readable FMU ({type(error).__name__}: {error})") from None
        if self.md.fmiVersion != "2.0":
            raise BadInput(f"{path}: FMI {self.md.fmiVersion}; pendfmu check reads FMI 2.0 FMUs")
        self.interfaces = [name for name, kind in (("CS", self.md.coSimulation), ("ME", self.md.modelExchange))
                           if kind is not None]
        variables = self.md.modelVariables
        self.variables = {v.name: v for v in variables}
        self.inputs = [v for v in variables if v.causality == "input" and v.type == "Real"]
        self.outputs = [v for v in variables if v.causality == "output" and v.type in ("Real", "Integer", "Boolean")]
        if not self.outputs:  # nothing declared as output: compare every Real that is computed
            self.outputs = [v for v in variables if v.type == "Real" and v.causality in ("local", "output")
                            and v.variability in ("continuous", "discrete")]
        self.parameters = [v for v in variables if v.causality == "parameter" and v.type == "Real"
                           and v.variability in ("fixed", "tunable")]
        self.modes = [v for v in variables if v.type in ("Integer", "Boolean") and v.variability == "discrete"
                      and v.causality in ("local", "output")]
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
        self.stop = stop if stop is not None else (declared_stop or 1.0)
        self.step = step if step is not None else (declared_step or self.stop / 500)
        if not (self.stop > 0 and self.step > 0 and self.step < self.stop):
            raise BadInput(f"--stop {self.stop} and --step {self.step}: need 0 < step < stop")

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


class Driver:
    """One instance of the target as CS or ME, stepped from communication point to
    communication point (ME integrated here). `fmu` is its instance on the checked binding:
    every call raises FMUError (instance, function, time, what the FMU logged) on a status
    worse than Warning; `messages` is what the FMU logged."""

    def __init__(self, target: Target, kind: str, name: str | None = None, guid: str | None = None):
        self.target, self.kind = target, kind
        self.fmu = instantiate_fmu(target.directory, target.md, kind, name, guid)
        self.messages = self.fmu.messages
        self.in_vr = [v.valueReference for v in target.inputs]
        self.out = [(v.type, v.valueReference) for v in target.outputs]
        self.time = 0.0
        md = target.md
        self.nx = md.numberOfContinuousStates if kind == "ME" else 0
        self.nz = md.numberOfEventIndicators if kind == "ME" else 0
        self.next_event = math.inf
        self.signs = None  # ME: the event indicators' signs at the end of the last step
        self.events: list[float] = []  # ME: the communication point before each event met (exercise.py)

    # -- set up

    def set_values(self, values: Mapping[str, float]) -> None:
        for name, value in values.items():
            v = self.target.variables[name]
            if v.type == "Real":
                self.fmu.setReal([v.valueReference], [float(value)])
            elif v.type == "Integer":
                self.fmu.setInteger([v.valueReference], [int(value)])
            else:
                self.fmu.setBoolean([v.valueReference], [bool(value)])

    def initialize(self, parameters: Mapping[str, float] | None = None, inputs: np.ndarray | None = None) -> None:
        if parameters:
            self.set_values(parameters)
        self.fmu.setupExperiment(startTime=0.0)
        self.fmu.enterInitializationMode()
        if inputs is not None and len(self.in_vr):
            self.fmu.setReal(self.in_vr, list(inputs))
        self.fmu.exitInitializationMode()
        self.time = 0.0
        if self.kind == "ME":
            self._event_iteration()
            self.fmu.enterContinuousTimeMode()
            self.signs = self._indicators() > 0

    def reset(self) -> None:
        self.fmu.reset()

    def free(self) -> None:
        self.fmu.close()

    # -- values

    def outputs(self) -> np.ndarray:
        row = []
        for kind, vr in self.out:
            getter = {"Real": self.fmu.getReal, "Integer": self.fmu.getInteger, "Boolean": self.fmu.getBoolean}[kind]
            row.append(float(getter([vr])[0]))
        return np.array(row)

    def modes(self) -> tuple:
        values = []
        for v in self.target.modes:
            getter = self.fmu.getInteger if v.type == "Integer" else self.fmu.getBoolean
            values.append(getter([v.valueReference])[0])
        return tuple(values)

    # -- time

    def step(self, h: float, inputs: np.ndarray | None) -> None:
        if inputs is not None and len(self.in_vr):
            self.fmu.setReal(self.in_vr, list(inputs))
        if self.kind == "CS":
            self.fmu.doStep(currentCommunicationPoint=self.time, communicationStepSize=h)
            self.time += h
        else:
            self._integrate(self.time + h)

    def run(self, h: float, stop: float, stimulus: Callable[[float], np.ndarray] | None,
            record_modes: list | None = None) -> np.ndarray:
        """Step from the current time to `stop` with step h (inputs from `stimulus` at each
        communication point); returns the outputs at every point, the first row now."""
        first = int(round(self.time / h))  # times as whole multiples of h: a rerun from a
        n = int(round(stop / h)) - first     # restored state passes the very same numbers
        rows = [self.outputs()]
        for k in range(first, first + n):
            t = k * h
            self.time = t
            self.step(h, stimulus(t) if stimulus is not None else None)
            self.time = (k + 1) * h
            rows.append(self.outputs())
            if record_modes is not None:
                record_modes.append((self.time, self.modes()))
        return np.array(rows)

    # -- Model Exchange

    def _event_iteration(self) -> None:
        while True:
            logged = len(self.messages)
            info = self.fmu.newDiscreteStates()
            # (newDiscreteStatesNeeded, terminateSimulation, nominalsChanged, valuesChanged,
            #  nextEventTimeDefined, nextEventTime)
            if info[1]:
                raise self._terminated("fmi2NewDiscreteStates", logged)
            if not info[0]:
                self.next_event = info[5] if info[4] else math.inf
                return

    def _states(self) -> np.ndarray:
        x = np.empty(self.nx)
        if self.nx:
            self.fmu.getContinuousStates(x.ctypes.data_as(DOUBLE_P), self.nx)
        return x

    def _set(self, t: float, x: np.ndarray) -> None:
        self.fmu.setTime(t)
        if self.nx:
            self.fmu.setContinuousStates(np.ascontiguousarray(x).ctypes.data_as(DOUBLE_P), self.nx)

    def _derivatives(self, t: float, x: np.ndarray) -> np.ndarray:
        self._set(t, x)
        dx = np.empty(self.nx)
        if self.nx:
            self.fmu.getDerivatives(dx.ctypes.data_as(DOUBLE_P), self.nx)
        return dx

    def _indicators(self) -> np.ndarray:
        z = np.empty(self.nz)
        if self.nz:
            self.fmu.getEventIndicators(z.ctypes.data_as(DOUBLE_P), self.nz)
        return z

    def _rk4(self, t: float, x: np.ndarray, h: float) -> np.ndarray:
        if not self.nx:
            return x
        k1 = self._derivatives(t, x)
        k2 = self._derivatives(t + h / 2, x + h / 2 * k1)
        k3 = self._derivatives(t + h / 2, x + h / 2 * k2)
        k4 = self._derivatives(t + h, x + h * k3)
        return x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)

    def _integrate(self, t_end: float) -> None:
        t = self.time
        eps = 1e-12 * max(1.0, abs(t_end))
        while t < t_end - eps:
            # a time event within rounding of the communication point happens at it
            t_next = self.next_event if self.next_event <= t_end + eps else t_end
            x = self._states()
            self._set(t, x)
            z0 = self._indicators() > 0
            if self.signs is not None and np.any(z0 != self.signs):
                # an indicator changed sign with the inputs set at this communication point:
                # the event is here, before integrating on
                self._event_at_point()
                x = self._states()
                z0 = self._indicators() > 0
            dt = t_next - t
            x1 = self._rk4(t, x, dt)
            self._set(t_next, x1)
            crossed = self.nz and np.any((self._indicators() > 0) != z0)
            if crossed:  # bisect for the first instant past the crossing
                low, high = 0.0, dt
                for _ in range(50):
                    if high - low <= 1e-13 * max(1.0, abs(t)):
                        break
                    mid = 0.5 * (low + high)
                    self._set(t + mid, self._rk4(t, x, mid))
                    if np.any((self._indicators() > 0) != z0):
                        high = mid
                    else:
                        low = mid
                t_next = t + high
                self._set(t_next, self._rk4(t, x, high))
            logged = len(self.messages)
            step_event, terminate = self.fmu.completedIntegratorStep()
            if terminate:
                raise self._terminated("fmi2CompletedIntegratorStep", logged)
            if crossed or step_event or t_next >= self.next_event - eps:
                self._event_at_point()
            self.signs = self._indicators() > 0
            t = t_next
        self.time = t_end

    def _terminated(self, function: str, since: int) -> FMUError:
        """The FMU asked to end the simulation (terminateSimulation): it cannot go on."""
        return self.fmu.failure(f"{function} asked to terminate the simulation", function, since)

    def _event_at_point(self) -> None:
        self.events.append(self.time)
        self.fmu.enterEventMode()
        self._event_iteration()
        self.fmu.enterContinuousTimeMode()

    # -- FMU state

    def get_state(self):
        return (self.fmu.getFMUstate(), self.time, self.next_event, self.signs)

    def set_state(self, saved) -> None:
        state, self.time, self.next_event, self.signs = saved
        self.fmu.setFMUstate(state)

    def free_state(self, saved) -> None:
        self.fmu.freeFMUstate(saved[0])


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
