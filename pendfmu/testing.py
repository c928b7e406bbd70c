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
    """One pytest case per FMU and interface, for
    ``@pytest.mark.parametrize("fmu, interface", fmus_and_interfaces(paths))``.

    An interface the FMU does not declare is a case marked skip that names it, so a report
    shows what was not tested rather than hiding it. An FMU file that does not exist yet
    (built by a fixture) gets every interface; the test finds out then.

    Parameters
    ----------
    paths : iterable of str or Path
        The FMU files.
    interfaces : iterable of str, optional
        The interfaces to test each with: "CoSimulation"/"CS", "ModelExchange"/"ME".

    Returns
    -------
    list of pytest.param
        ``(path, "CS" | "ME")`` cases with readable ids (``Cart-CS``, ``Cart-ME``).
    """
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
    """The outputs of one run of an FMU (what an `fmu_runner` call returns), indexed by
    name: ``run["time"]``, ``run["x"]``.

    Attributes
    ----------
    time : ndarray
        The communication points [s].
    values : dict of str to ndarray
        Each recorded variable's value at every communication point, by name.
    """
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
        """The recorded variables' names.

        Returns
        -------
        list of str
            In the order they were asked for (``time`` not among them).
        """
        return list(self.values)


Stimulus = Mapping[str, "np.ndarray | float | Callable[[float], float]"]


class FMURunner:
    """Loads FMUs as CS or ME (pendfmu.check's driver: ME integrated with classical
    Runge-Kutta, state events located by bisection) and runs them; frees what it opened.

    What the `fmu_runner` fixture gives a test: calling it runs an FMU (``__call__``),
    :meth:`open` gives an instance to step by hand. It takes no arguments and carries no
    public attributes.
    """

    def __init__(self):
        self._open: list = []
        self._targets: dict = {}

    def target(self, path: str | Path, stop: float | None = None, step: float | None = None):
        """pendfmu.check's Target of an FMU file: its description, unpacked binary,
        interfaces and variables (read and unpacked once per runner).

        Parameters
        ----------
        path : str or Path
            The FMU file.
        stop : float, optional
            The end of its runs [s]; by default the default experiment's stop time, else 1 s.
        step : float, optional
            The communication step [s]; by default the default experiment's, else stop/500.

        Returns
        -------
        pendfmu.check.fmu.Target
            The FMU as the checks see it.

        Raises
        ------
        AssertionError
            The file is not an FMU pendfmu can read (no file, not a zip, invalid XML, not
            FMI 2.0 or 3.0, a name FMI does not allow).
        """
        key = (str(Path(path).resolve()), stop, step)
        if key not in self._targets:
            self._targets[key] = _target(path, stop, step)
        return self._targets[key]

    def open(self, path: str | Path, interface: str = "CS", outputs: Iterable[str] | None = None):
        """An FMU instance to step by hand: instantiated, not yet initialized; freed at
        teardown (or by :meth:`free`).

        Parameters
        ----------
        path : str or Path
            The FMU file.
        interface : str, optional
            "CS"/"CoSimulation" or "ME"/"ModelExchange".
        outputs : iterable of str, optional
            The variables its runs record; by default every output.

        Returns
        -------
        pendfmu.check.driver.Driver
            The instance, on the interface asked for.

        Raises
        ------
        AssertionError
            The FMU has no such interface.
        """
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
        """Run an FMU from 0 to `stop`, its inputs held over each step (the last sample at
        or before the step's start), and record its outputs.

        Parameters
        ----------
        path : str or Path
            The FMU file.
        interface : str, optional
            "CS"/"CoSimulation" or "ME"/"ModelExchange".
        stimulus : mapping, optional
            Inputs by name, each an array over ``stimulus["time"]``, a constant, or a
            function of t [s].
        recording : Recording or str or Path or mapping, optional
            Inputs from a recording: a pendfmu.recording.Recording, its file, a CSV file
            with time first, or a mapping with ``"time"``. The columns named like the FMU's
            inputs drive them, the others are ignored. Not with `stimulus`.
        parameters : mapping of str to float, optional
            Parameter values set before initialization.
        stop : float, optional
            The run's end [s]: by default the recording's or stimulus' last time, else the
            FMU's default experiment's stop time, else 1 s.
        step : float, optional
            The communication step [s]: by default the recording's or stimulus' sample
            period, else the default experiment's step, else stop/500.
        outputs : iterable of str, optional
            The variables recorded; by default every output.

        Returns
        -------
        Run
            The recorded variables at every communication point.
        """
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
        """Free an instance :meth:`open` gave, before teardown (a test that opens many).

        Parameters
        ----------
        unit : pendfmu.check.driver.Driver
            The instance; one this runner did not open, or already freed, is left alone.
        """
        if unit in self._open:
            self._open.remove(unit)
            unit.free()

    def close(self) -> None:
        """Free every instance still open, newest first (the fixture's teardown)."""
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
    """Runs FMUs as CS or ME on a recording or a stimulus; frees every instance after the test.

    Yields
    ------
    FMURunner
        The test's runner: ``fmu_runner(path, "CS", stimulus=...)`` returns a :class:`Run`.
    """
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
    directional derivatives, variable steps) working.

    Parameters
    ----------
    fmu : str or Path
        The FMU file.
    interface : str, optional
        "CS"/"CoSimulation" or "ME"/"ModelExchange"; by default every interface it has.

    Raises
    ------
    AssertionError
        A check failed or exercised nothing: each such check's name and message.
    """
    from pendfmu.check import static
    from pendfmu.check.battery import group_jobs

    target = _target(fmu)
    binary = _contained(group_jobs(target, static, _kinds(target, interface)))
    _fail_on(target, static.description_rows(target) + binary)


def assert_deterministic(fmu, interface: str | None = None, *, stop=None, step=None, recording=None):
    """Two fresh instances, same inputs: outputs identical bit for bit, and moving (identical
    constants say nothing: that is inconclusive and fails too).

    Parameters
    ----------
    fmu : str or Path
        The FMU file.
    interface : str, optional
        "CS"/"CoSimulation" or "ME"/"ModelExchange"; by default every interface it has.
    stop : float, optional
        The end of the runs [s]; by default the recording's last time, else the default
        experiment's stop time, else 1 s.
    step : float, optional
        The communication step [s]; by default the default experiment's, else stop/500.
    recording : str or Path, optional
        A CSV file (time first) whose columns named like the FMU's inputs drive them (the
        others are ignored); without it, a stimulus the check searches for to move the
        outputs (pendfmu.check.stimulus).

    Raises
    ------
    AssertionError
        The runs differ, or nothing moved; the first difference is named.
    """
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
    that refuses fmi2Reset passes unless `refusal_ok` is False.

    Parameters
    ----------
    fmu : str or Path
        The FMU file.
    interface : str, optional
        "CS"/"CoSimulation" or "ME"/"ModelExchange"; by default every interface it has.
    parameter : str, optional
        The parameter changed; by default the check tries a few.
    value : float, optional
        Its value after the reset; by default 1.25 times its start value (0.5 for a start
        of 0).
    refusal_ok : bool, optional
        Whether an FMU that refuses fmi2Reset passes.
    stop, step : float, optional
        The end of the runs and the communication step [s], as for
        :func:`assert_deterministic`.
    recording : str or Path, optional
        A recording file driving the inputs, as for :func:`assert_deterministic`.

    Raises
    ------
    AssertionError
        The run after the reset differs from a fresh instance's, the parameter did not
        move the outputs, or (with `refusal_ok` False) fmi2Reset was refused.
    """
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
    not declare canGetAndSetFMUstate fails: there is nothing to roll back.

    Parameters
    ----------
    fmu : str or Path
        The FMU file.
    interface : str, optional
        "CS"/"CoSimulation" or "ME"/"ModelExchange"; by default every interface it has.
    stop, step : float, optional
        The end of the run and the communication step [s], as for
        :func:`assert_deterministic`.
    recording : str or Path, optional
        A recording file driving the inputs, as for :func:`assert_deterministic`.

    Raises
    ------
    AssertionError
        A restored state did not reproduce the run, or the FMU cannot save its state.
    """
    from pendfmu.check import rollback

    target, rows = _rows(fmu, rollback, interface, stop, step, recording)
    for row in _fail_on(target, rows):
        if row.figure == "not declared":
            raise AssertionError(f"{target.name}: {row.name}: {row.message}")


def assert_converges(fmu, interface: str | None = None, *, stop=None, step=None, recording=None,
                     order: float | None = None, step_rtol: float | None = None):
    """Communication steps h, h/2, h/4 with the inputs held: the results move by at most
    `step_rtol` of each output's nominal or range (a switch decided only at communication
    points fails), or converge at the stated `order` of a fixed-step solver.

    Parameters
    ----------
    fmu : str or Path
        The FMU file.
    interface : str, optional
        "CS"/"CoSimulation" or "ME"/"ModelExchange"; by default every interface it has.
    stop : float, optional
        The end of the runs [s], as for :func:`assert_deterministic`.
    step : float, optional
        h, the coarsest communication step [s]; by default the default experiment's step,
        else stop/500.
    recording : str or Path, optional
        A recording file driving the inputs, as for :func:`assert_deterministic`.
    order : float, optional
        The order of the fixed-step solver the FMU is built around; then its results must
        converge at that order.
    step_rtol : float, optional
        How far the results may move, relative to each output's nominal or range; 1e-4
        when not given.

    Raises
    ------
    AssertionError
        An output moved more than allowed (or converged slower than `order`).
    """
    from pendfmu.check import convergence

    def prepare(target):
        target.stated_order = order
        target.step_rtol = target.step_rtol if step_rtol is None else step_rtol

    target, rows = _rows(fmu, convergence, interface, stop, step, recording, prepare)
    _fail_on(target, rows)


def assert_finite_over_inputs(fmu, interface: str | None = None, *, stop=None, step=None,
                              input_limit: float | None = None):
    """Each Real input held at five values over its declared range, else at its start value
    and +- 1, 10, ... times its nominal up to `input_limit` times it: every output stays
    finite and no value inside a declared range is refused.

    Parameters
    ----------
    fmu : str or Path
        The FMU file.
    interface : str, optional
        "CS"/"CoSimulation" or "ME"/"ModelExchange"; by default every interface it has.
    stop, step : float, optional
        The end of each run and the communication step [s], as for
        :func:`assert_deterministic` (the check sets the inputs itself: no recording).
    input_limit : float, optional
        How far an input without a declared range is driven, in multiples of its nominal;
        1000 when not given.

    Raises
    ------
    AssertionError
        An output became NaN or Inf, or a value inside a declared range was refused.
    """
    from pendfmu.check import inputs

    def prepare(target):
        target.input_limit = target.input_limit if input_limit is None else input_limit

    target, rows = _rows(fmu, inputs, interface, stop, step, None, prepare)
    _fail_on(target, rows)


def assert_calls_rejected(fmu, interface: str | None = None, *, step=None):
    """Misuse (a step before initialization, an unknown value reference, NaN and Inf inputs,
    a fixed parameter set while stepping) is answered with an error status and a log message,
    never a crash or an OK with NaN outputs.

    Parameters
    ----------
    fmu : str or Path
        The FMU file.
    interface : str, optional
        "CS"/"CoSimulation" or "ME"/"ModelExchange"; by default every interface it has.
    step : float, optional
        The communication step [s] of the calls; by default the default experiment's, else
        1/500 of its stop time.

    Raises
    ------
    AssertionError
        A misuse was accepted (status OK), or crashed the FMU.
    """
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
    part near zero. A failure names the variable, the time, the value, the tube and by how
    much it is missed.

    Parameters
    ----------
    result, reference : Run or Recording or mapping or str or Path
        What is checked and what it is checked against: a Run, a Recording, a mapping with
        "time" and columns, or a CSV file (time first).
    atol : float, optional
        The tube's absolute half-width, in each variable's unit.
    rtol : float, optional
        Its relative half-width, of max(|y|, nominal).
    ttol : float, optional
        The time tolerance [s]: the tube at t spans the reference's values over
        [t - ttol, t + ttol], so an edge a little early or late passes.
    variables : iterable of str, optional
        The variables compared; by default every one the two have in common.
    nominal : mapping of str to float, optional
        Per variable, the floor of the relative part near zero (default 0).

    Raises
    ------
    AssertionError
        A variable leaves the tube (each is named, with the worst point), a variable is in
        only one of them, or they have none in common.
    """
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


