"""pytest plugin for FMU unit tests: `pendfmu check`'s battery as fixtures and assertions.

Registered as the pytest entry point ``pendfmu.testing`` (pyproject.toml), so a test file in a
project that installed pendfmu uses it without set-up; ``pytest -p pendfmu.testing`` loads it by
hand (the same name: both together are one plugin), ``-p no:pendfmu.testing`` turns it off.

Fixture
    ``fmu_runner``: ``fmu_runner(path, "CS" | "ME", stimulus=..., recording=..., parameters=...,
    stop=..., step=..., outputs=...)`` runs one instance of any FMI 2.0 FMU and returns a
    :class:`Run` (``run.time``, ``run["x"]`` numpy arrays); ``fmu_runner.open(path, kind)``
    gives an instance to step by hand. Every instance is freed when the test ends.

Assertions (each raises AssertionError with the check's message: the variable, the time and
the size of the violation; a check that exercised nothing, such as outputs that never moved,
fails as INCONCLUSIVE with what was missing), on an FMU file, for one interface or every
interface it has:
    ``assert_valid`` (the static checks), ``assert_deterministic``, ``assert_reset_restores``, ``assert_state_rollback``,
    ``assert_converges``, ``assert_finite_over_inputs``, ``assert_calls_rejected`` and
    ``assert_matches(result, reference, atol, rtol, ttol)``.

Each assertion runs its check groups in a child process (pendfmu/check/contain.py): an FMU that
crashes (SIGSEGV, an abort) or hangs fails that test with the signal or the time limit named,
and the session goes on. The time limit of a check group is ``--pendfmu-time-limit SECONDS`` or
the ini option ``pendfmu_time_limit`` (default pendfmu.check.contain.TIME_LIMIT). The
``fmu_runner`` fixture hands out live instances and runs in the test's own process.

Parametrization
    ``@pytest.mark.parametrize("fmu, interface", fmus_and_interfaces(paths))``: one test per
    FMU and interface, with ids like ``Cart-CS``; an interface the FMU does not have is a
    skipped case that says so.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path

import numpy as np
import pytest

__all__ = ["FMURunner", "Run", "assert_calls_rejected", "assert_converges", "assert_deterministic",
           "assert_finite_over_inputs", "assert_matches", "assert_reset_restores", "assert_state_rollback",
           "assert_valid", "fmu_runner", "fmus_and_interfaces"]

KINDS = {"CS": "CS", "CoSimulation": "CS", "ME": "ME", "ModelExchange": "ME"}
LONG = {"CS": "CoSimulation", "ME": "ModelExchange"}
SESSION: dict[str, float] = {}
"""The session's options: "time_limit" when --pendfmu-time-limit or the ini option set it."""


def pytest_addoption(parser) -> None:
    help_text = "seconds each pendfmu check group may take in its child process (default: pendfmu.check.contain's)"
    parser.addoption("--pendfmu-time-limit", type=float, metavar="SECONDS", help=help_text)
    parser.addini("pendfmu_time_limit", help_text)


def pytest_configure(config) -> None:
    given = config.getoption("pendfmu_time_limit", None) or config.getini("pendfmu_time_limit")
    if given:
        limit = float(given)
        if not 0 < limit < float("inf"):
            raise pytest.UsageError(f"--pendfmu-time-limit {given}: needs a finite number of seconds > 0")
        SESSION["time_limit"] = limit


def _contained(jobs) -> list:
    """The rows of check jobs, each group in a child process (contain.run_all)."""
    from pendfmu.check.contain import TIME_LIMIT, run_all

    return run_all(jobs, SESSION.get("time_limit", TIME_LIMIT))


def _kind(interface: str) -> str:
    try:
        return KINDS[interface]
    except KeyError:
        raise ValueError(f"interface {interface!r}: one of 'CS', 'ME', 'CoSimulation', 'ModelExchange'") from None


# -- parametrization

def fmus_and_interfaces(paths: Iterable[str | Path], interfaces: Iterable[str] = ("CoSimulation", "ModelExchange")):
    """pytest params ``(path, interface)`` for every FMU and interface, with readable ids
    (``Cart-CS``, ``Cart-ME``); an interface the FMU does not declare is a param marked skip
    that names it. For ``@pytest.mark.parametrize("fmu, interface", ...)``. An FMU file that
    does not exist yet (built by a fixture) gets every interface; the test finds out then."""
    from fmpy import read_model_description

    params = []
    for path in paths:
        path = Path(path)
        declared = None
        if path.is_file():
            md = read_model_description(str(path))
            declared = {kind for kind, interface in (("CS", md.coSimulation), ("ME", md.modelExchange)) if interface}
        for interface in interfaces:
            kind = _kind(interface)
            marks = ()
            if declared is not None and kind not in declared:
                marks = (pytest.mark.skip(reason=f"{path.name} has no {LONG[kind]} interface"),)
            params.append(pytest.param(path, kind, id=f"{path.stem}-{kind}", marks=marks))
    return params


# -- running an FMU

@dataclass
class Run:
    """The outputs of one run: ``time`` and one numpy array per variable (``run["x"]``)."""
    time: np.ndarray
    values: dict[str, np.ndarray] = field(default_factory=dict)

    def __getitem__(self, name: str) -> np.ndarray:
        if name == "time":
            return self.time
        try:
            return self.values[name]
        except KeyError:
            raise KeyError(f"{name!r} was not recorded; recorded: {', '.join(self.values)}") from None

    def __contains__(self, name: str) -> bool:
        return name == "time" or name in self.values

    def names(self) -> list[str]:
        return list(self.values)


Stimulus = Mapping[str, "np.ndarray | float | Callable[[float], float]"]


class FMURunner:
    """Loads FMUs as CS or ME (pendfmu.check's driver: ME integrated with classical
    Runge-Kutta, state events located by bisection) and runs them; frees what it opened."""

    def __init__(self):
        self._open: list = []
        self._targets: dict = {}

    def target(self, path: str | Path, stop: float | None = None, step: float | None = None):
        """pendfmu.check's Target of the FMU file (read and unpacked once per runner)."""
        key = (str(Path(path).resolve()), stop, step)
        if key not in self._targets:
            self._targets[key] = _target(path, stop, step)
        return self._targets[key]

    def open(self, path: str | Path, interface: str = "CS", outputs: Iterable[str] | None = None):
        """An instantiated (not yet initialized) `pendfmu.check.fmu.Driver`; freed at teardown."""
        from pendfmu.check.fmu import Driver

        target = self.target(path)
        kind = _kind(interface)
        if kind not in target.interfaces:
            raise AssertionError(f"{target.name} has no {LONG[kind]} interface (it has: "
                                 f"{', '.join(LONG[k] for k in target.interfaces)})")
        unit = Driver(target, kind, name=f"test{len(self._open)}")
        self._open.append(unit)
        if outputs is not None:
            unit.out = [(_variable(target, name).type, _variable(target, name).valueReference) for name in outputs]
        return unit

    def __call__(self, path: str | Path, interface: str = "CS", *, stimulus: Stimulus | None = None,
                 recording=None, parameters: Mapping[str, float] | None = None, stop: float | None = None,
                 step: float | None = None, outputs: Iterable[str] | None = None) -> Run:
        """Run the FMU from 0 to `stop` with communication step `step` (defaults: the
        recording's or stimulus' last time and sample period, else the FMU's default
        experiment's stop and step, else 1 s and stop/500). Inputs come from `recording` (a
        pendfmu.recording.Recording, its file, a CSV file with time first, or a mapping with
        "time": the columns named like the FMU's inputs drive them, the others are ignored) or
        `stimulus` ({input: array over stimulus["time"] | constant | function of t}), held
        over each step (the last sample at or before the step's start). Returns the
        `outputs` (default: every output) at every communication point."""
        target = self.target(path)
        times, columns = _inputs(target, stimulus, recording)
        if stop is None:
            stop = float(times[-1]) if times is not None and times[-1] > 0 else target.stop
        if step is None:
            step = float(np.min(np.diff(times))) if times is not None and len(times) > 1 else (
                target.step if target.step < stop else stop / 500)
        names = list(outputs) if outputs is not None else [v.name for v in target.outputs]
        unit = self.open(path, interface, names)
        feed = _feed(target, times, columns)
        unit.initialize(parameters, feed(0.0))
        rows = unit.run(step, stop, feed)
        self.free(unit)
        time = np.arange(len(rows)) * step
        return Run(time, {name: rows[:, j] for j, name in enumerate(names)})

    def free(self, unit) -> None:
        if unit in self._open:
            self._open.remove(unit)
            unit.free()

    def close(self) -> None:
        while self._open:
            self.free(self._open[-1])


def _variable(target, name: str):
    try:
        return target.variables[name]
    except KeyError:
        raise KeyError(f"{target.name} has no variable {name!r}") from None


def _inputs(target, stimulus, recording):
    """(times or None, {input name: values array | constant | function})."""
    if recording is not None and stimulus is not None:
        raise ValueError("give a recording or a stimulus, not both")
    inputs = {v.name for v in target.inputs}
    if recording is not None:
        from pendfmu.recording import Recording, RecordingError, read_recording

        if isinstance(recording, (str, Path)):
            try:
                recording = read_recording(recording)
            except RecordingError:
                if Path(recording).suffix.lower() != ".csv":
                    raise
                recording = _table(recording)  # a CSV whose names are not the rig's: time first
        if isinstance(recording, Recording):
            recording = {"time": recording.time, **recording.signals}
        table = _table(recording)
        return table["time"], {name: values for name, values in table.items() if name in inputs}
    if stimulus is None:
        return None, {}
    stimulus = dict(stimulus)
    times = stimulus.pop("time", None)
    unknown = sorted(set(stimulus) - inputs)
    if unknown:
        raise KeyError(f"stimulus {unknown[0]!r} is not a Real input of {target.name} (inputs: {', '.join(sorted(inputs))})")
    for name, value in stimulus.items():
        if not callable(value) and np.ndim(value) and (times is None or len(value) != len(times)):
            raise ValueError(f"stimulus {name!r}: an array needs stimulus['time'] of the same length")
    return (None if times is None else np.asarray(times, dtype=float)), stimulus


def _feed(target, times, columns) -> Callable[[float], np.ndarray]:
    starts = [float(v.start) if v.start is not None else 0.0 for v in target.inputs]

    def at(t: float) -> np.ndarray:
        row = np.array(starts)
        i = None
        if times is not None:
            i = max(0, int(np.searchsorted(times, t + 1e-12 * max(1.0, abs(t)), side="right")) - 1)
        for k, v in enumerate(target.inputs):
            value = columns.get(v.name)
            if value is None:
                continue
            if callable(value):
                row[k] = float(value(t))
            elif np.ndim(value):
                row[k] = float(value[i])
            else:
                row[k] = float(value)
        return row
    return at


@pytest.fixture
def fmu_runner():
    """Runs FMUs as CS or ME on a recording or a stimulus; frees every instance after the test."""
    runner = FMURunner()
    yield runner
    runner.close()


# -- the battery's checks as assertions

def _target(path, stop=None, step=None, recording=None):
    """pendfmu.check's Target; an FMU it cannot read (no file, no zip, invalid XML, not FMI
    2.0) fails the assertion with the reason."""
    from pendfmu.check.fmu import Target
    from pendfmu.errors import BadInput

    try:
        target = Target(path, stop, step, recording)
    except BadInput as error:
        raise AssertionError(str(error)) from None
    if target.refused:  # nothing of it may be loaded
        raise AssertionError(target.refused)
    return target


def _rows(path, module, interface, stop, step, recording, prepare=None):
    from pendfmu.check.battery import group_jobs

    target = _target(path, stop, step, recording)
    if prepare is not None:
        prepare(target)
    return target, _contained(group_jobs(target, module, _kinds(target, interface)))


def _kinds(target, interface) -> list[str]:
    kinds = target.interfaces if interface is None else [_kind(interface)]
    for kind in kinds:
        if kind not in target.interfaces:
            raise AssertionError(f"{target.name} has no {LONG[kind]} interface")
    return kinds


def _fail_on(target, rows, contains: str = "") -> list:
    """Raises AssertionError for every chosen row that did not pass: a FAIL with its message,
    an INCONCLUSIVE one saying that nothing was exercised and why."""
    from pendfmu.check.fmu import INCONCLUSIVE

    chosen = [r for r in rows if contains in r.name]
    failed = [r for r in chosen if not r.passed]
    if failed:
        raise AssertionError("\n".join(
            f"{target.name}: {r.name}: " + ("INCONCLUSIVE, " if r.verdict == INCONCLUSIVE else "")
            + (f"{r.message} ({r.figure})" if r.message and r.figure else r.message or r.figure) for r in failed))
    return chosen


def assert_valid(fmu, interface: str | None = None):
    """The static checks: the model description valid (fmpy's validate_fmu), every function
    FMI 2.0 requires for the interface exported, a wrong GUID refused and the right one
    accepted, the declared capabilities (FMU state, serialization, input derivatives,
    directional derivatives, variable steps) working."""
    from pendfmu.check import static
    from pendfmu.check.battery import group_jobs

    target = _target(fmu)
    binary = _contained(group_jobs(target, static, _kinds(target, interface)))
    _fail_on(target, static.description_rows(target) + binary)


def assert_deterministic(fmu, interface: str | None = None, *, stop=None, step=None, recording=None):
    """Two fresh instances, same inputs: outputs identical bit for bit, and moving (identical
    constants say nothing: that is inconclusive and fails too)."""
    from pendfmu.check.contain import Job

    target = _target(fmu, stop, step, recording)
    jobs = [Job(f"determinism: fresh instances {kind}", partial(_fresh_instances, target, kind))
            for kind in _kinds(target, interface)]
    _fail_on(target, _contained(jobs))


def _fresh_instances(target, kind: str) -> list:
    """The row of two fresh instances' runs (a job of assert_deterministic)."""
    from pendfmu.check import determinism
    from pendfmu.check.fmu import CheckResult, call_error

    try:
        first = determinism.fresh_run(target, kind)
        second = determinism.fresh_run(target, kind)
    except Exception as error:
        return [CheckResult(f"determinism: fresh instances {kind}", False, "run failed", call_error(error))]
    return [determinism.fresh_instances(target, kind, first, second)]


def assert_reset_restores(fmu, interface: str | None = None, *, parameter: str | None = None,
                          value: float | None = None, refusal_ok: bool = True, stop=None, step=None, recording=None):
    """A run after fmi2Reset equals a fresh instance's (the parameter changed before the reset
    back at its start value), and `parameter` = `value` set after the reset acts like a fresh
    instance with that value. The parameter must change the outputs (else the check could not
    see it kept: inconclusive, a failure; without `parameter` the check tries a few). An FMU
    that refuses fmi2Reset passes unless `refusal_ok` is False."""
    from pendfmu.check import determinism

    def prepare(target):
        if parameter is None:
            return
        if parameter not in target.variables:
            raise AssertionError(f"{target.name} has no parameter {parameter!r}")
        variable = target.variables[parameter]
        chosen = value if value is not None else (float(variable.start or 0.0) * 1.25 or 0.5)
        target.varied_parameter = lambda: (variable, float(chosen))
        target.parameters = [variable]  # this one only

    target, rows = _rows(fmu, determinism, interface, stop, step, recording, prepare)
    for row in _fail_on(target, rows, "reset"):
        if row.figure == "fmi2Reset refused" and not refusal_ok:
            raise AssertionError(f"{target.name}: {row.name}: {row.message}")


def assert_state_rollback(fmu, interface: str | None = None, *, stop=None, step=None, recording=None):
    """FMU states saved at several points (one in a new discrete mode), restored after the run
    went on, reproduce the rest of the run bit for bit; serialized states too. An FMU that does
    not declare canGetAndSetFMUstate fails: there is nothing to roll back."""
    from pendfmu.check import rollback

    target, rows = _rows(fmu, rollback, interface, stop, step, recording)
    for row in _fail_on(target, rows):
        if row.figure == "not declared":
            raise AssertionError(f"{target.name}: {row.name}: {row.message}")


def assert_converges(fmu, interface: str | None = None, *, stop=None, step=None, recording=None,
                     order: float | None = None, step_rtol: float | None = None):
    """Communication steps h, h/2, h/4 with the inputs held: the results move by at most
    `step_rtol` (default 1e-4) of each output's nominal or range (a switch decided only at
    communication points fails), or converge at the stated `order` of a fixed-step solver."""
    from pendfmu.check import convergence

    def prepare(target):
        target.stated_order = order
        target.step_rtol = target.step_rtol if step_rtol is None else step_rtol

    target, rows = _rows(fmu, convergence, interface, stop, step, recording, prepare)
    _fail_on(target, rows)


def assert_finite_over_inputs(fmu, interface: str | None = None, *, stop=None, step=None,
                              input_limit: float | None = None):
    """Each Real input held at five values over its declared range, else at its start value
    and +- 1, 10, ... times its nominal up to `input_limit` (default 1000) times it: every
    output stays finite and no value inside a declared range is refused."""
    from pendfmu.check import inputs

    def prepare(target):
        target.input_limit = target.input_limit if input_limit is None else input_limit

    target, rows = _rows(fmu, inputs, interface, stop, step, None, prepare)
    _fail_on(target, rows)


def assert_calls_rejected(fmu, interface: str | None = None, *, step=None):
    """Misuse (a step before initialization, an unknown value reference, NaN and Inf inputs,
    a fixed parameter set while stepping) is answered with an error status and a log message,
    never a crash or an OK with NaN outputs."""
    from pendfmu.check import sequence

    target, rows = _rows(fmu, sequence, interface, None, step, None)
    _fail_on(target, rows)


# -- agreement with a reference

def assert_matches(result, reference, atol: float = 0.0, rtol: float = 0.0, ttol: float = 0.0,
                   variables: Iterable[str] | None = None, nominal: Mapping[str, float] | None = None):
    """Every variable of `result` named in `reference` lies inside the reference's tube, the
    one `pendfmu check --reference` uses (pendfmu.check.reference.tube_check): at each of the
    reference's times t, within atol + rtol * max(|y|, nominal) of the reference's values over
    [t - ttol, t + ttol]. The result is taken at the reference's times (linear between its
    own samples where the grids differ); `nominal` (per name, default 0) floors the relative
    part near zero. `result`, `reference`: a Run, a Recording, a mapping with "time" and
    columns, or a CSV file (time first). A failure names the variable, the time, the value,
    the tube and by how much it is missed."""
    from pendfmu.check.reference import tube_check

    result, reference = _table(result), _table(reference)
    names = list(variables) if variables is not None else [n for n in reference if n != "time" and n in result]
    if not names:
        raise AssertionError(f"no variable in common between the result ({', '.join(n for n in result if n != 'time')})"
                             f" and the reference ({', '.join(n for n in reference if n != 'time')})")
    t_ref, t = reference["time"], result["time"]
    inside = (t_ref >= t[0] - 1e-12) & (t_ref <= t[-1] + 1e-12)
    same_grid = len(t) == len(t_ref) and np.array_equal(t, t_ref)
    problems = []
    for name in names:
        for table, which in ((result, "result"), (reference, "reference")):
            if name not in table:
                raise AssertionError(f"{name!r} is not in the {which}")
        y = result[name] if same_grid else np.interp(t_ref, t, result[name])
        floor = float((nominal or {}).get(name, 0.0))
        low, high, width, miss = tube_check(t_ref, reference[name], y, atol, rtol, ttol, floor)
        miss = np.where(inside & (miss > width), miss - width, 0.0)
        k = int(np.argmax(miss))
        if miss[k] > 0:
            count = int(np.sum(miss > 0))
            problems.append(f"{name} at t = {t_ref[k]:.6g} s: {y[k]:.10g} is outside the reference's "
                            f"[{low[k] - width[k]:.10g}, {high[k] + width[k]:.10g}] by {miss[k]:.3g} "
                            f"(atol {atol:g}, rtol {rtol:g}, ttol {ttol:g} s; {count} of {int(inside.sum())} points "
                            f"outside)")
    if problems:
        raise AssertionError("\n".join(problems))


def _table(data) -> dict[str, np.ndarray]:
    if isinstance(data, Run):
        return {"time": data.time, **data.values}
    if isinstance(data, (str, Path)):
        path = Path(data)
        with open(path) as handle:
            header = [name.strip() for name in handle.readline().split(",")]
        numbers = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
        return {("time" if j == 0 else name): numbers[:, j] for j, name in enumerate(header)}
    if hasattr(data, "signals") and hasattr(data, "time"):  # a Recording
        return {"time": np.asarray(data.time, dtype=float), **{k: np.asarray(v, float) for k, v in data.signals.items()}}
    table = {name: np.asarray(values, dtype=float) for name, values in dict(data).items()}
    if "time" not in table:
        raise KeyError("a result or reference needs a 'time' column")
    return table


