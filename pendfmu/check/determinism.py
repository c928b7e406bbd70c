"""Determinism: two fresh instances give the same outputs bit for bit, and so does an
instance after fmi2Reset.

FMI 2.0 (fmi2Reset): the FMU goes back to the state it had after fmi2Instantiate, every
variable at its start value. So a run after a reset must equal a fresh instance's run; with
a parameter p changed before the reset that means p is back at its start value, and a
parameter set to a after the reset must act like a fresh instance with p = a (the recurring
bug is an FMU that keeps using the value from before the reset). An FMU that refuses
fmi2Reset with an error status passes: it says it cannot, and a host instantiates anew.

Exercise (exercise.py): identical runs of outputs that never moved say nothing, and a kept
parameter shows only if the parameter changes the outputs; the reset check tries up to
MAX_PARAMETERS parameters for one that does. Either missing makes the row INCONCLUSIVE.
"""

from __future__ import annotations

import numpy as np

from pendfmu.check import exercise
from pendfmu.check.fmu import (INCONCLUSIVE, CheckResult, Driver, Target, call_error, compare, first_difference,
                               varied_value)
from pendfmu.check.stimulus import excitation, reference_run, unexercised
from pendfmu.errors import FMUError

MAX_PARAMETERS = 4
"""Parameters the reset check tries for one that changes the outputs (a fresh run each)."""


def fresh_run(target: Target, kind: str, parameters=None) -> np.ndarray:
    unit = Driver(target, kind)
    try:
        return _run(target, unit, parameters)
    finally:
        unit.free()


def _run(target: Target, unit: Driver, parameters=None) -> np.ndarray:
    stimulus = excitation(target).at(target.step)
    unit.initialize(parameters, stimulus(0.0))
    return unit.run(target.step, target.stop, stimulus)


def times(target: Target, rows: int) -> np.ndarray:
    return np.arange(rows) * target.step


def run(target: Target, kind: str) -> list[CheckResult]:
    name = f"determinism: fresh instances {kind}"
    try:  # the first fresh instance's run is the one every check starts from (exercise.py)
        first = reference_run(target, kind).rows
        second = fresh_run(target, kind)
    except Exception as error:
        return [CheckResult(name, False, "run failed", call_error(error))]
    return [fresh_instances(target, kind, first, second), reset(target, kind, first)]


def fresh_instances(target: Target, kind: str, first: np.ndarray, second: np.ndarray) -> CheckResult:
    """The row for two fresh instances' runs."""
    name = f"determinism: fresh instances {kind}"
    difference = compare(first, second)
    stimulus = f" [{excitation(target).label}]"
    if difference != 0.0:
        return CheckResult(name, False, f"max difference {difference:.3g}" + stimulus,
                           "two fresh instances with the same inputs differ: "
                           + first_difference(target, first, second, times(target, len(first))))
    figure = f"identical ({first.shape[0]} points x {first.shape[1]} outputs); " + exercise.movement(target, first)
    if not exercise.moved(first).any():
        return CheckResult(name, INCONCLUSIVE, figure + stimulus, unexercised(target, "no output moved"))
    return CheckResult(name, True, figure + stimulus)


def reset(target: Target, kind: str, first: np.ndarray) -> CheckResult:
    """The row for fmi2Reset (fmi3Reset): back to the start values, and a parameter set after it used."""
    name = f"determinism: reset {kind}"
    try:  # before the instance under test exists (an FMU may allow one instance at a time)
        varied, fresh, effect, tried = _influential(target, kind, first)
    except Exception as error:
        return CheckResult(name, False, "run failed", call_error(error))
    unit = Driver(target, kind)
    try:
        return _reset_row(target, unit, name, first, varied, fresh, effect, tried)
    except Exception as error:
        return CheckResult(name, False, "run failed", call_error(error))
    finally:
        unit.free()


def _influential(target: Target, kind: str, first: np.ndarray):
    """(parameter and value, its fresh run, how far it moved the outputs, names tried): the
    first of up to MAX_PARAMETERS parameters whose value changes the outputs, else the first."""
    chosen = target.varied_parameter()
    if chosen is None:
        return None, None, 0.0, []
    others = [(v, varied_value(v)) for v in target.parameters if v is not chosen[0]]
    candidates = [chosen] + [(v, value) for v, value in others if value is not None][:MAX_PARAMETERS - 1]
    found, tried = None, []
    for v, value in candidates:
        fresh = fresh_run(target, kind, {v.name: value})
        effect = compare(fresh, first)
        tried.append(f"{v.name} = {value:g}")
        if found is None:
            found = ((v, value), fresh, effect)
        if effect > 0:
            return (v, value), fresh, effect, tried
    return (*found, tried)


def _reset_row(target, unit, name, first, varied, fresh, effect, tried) -> CheckResult:
    # the instance's first run with p = b (not a: an FMU that derives values from p once
    # would otherwise look right by chance), then reset: back to the start values
    stimulus = f" [{excitation(target).label}]"
    call = f"{'fmi3' if target.fmi3 else 'fmi2'}Reset"  # the FMU's own function, named in the rows
    b = _other_value(varied) if varied else None
    _run(target, unit, {varied[0].name: b} if varied else {})
    try:
        unit.reset()
    except FMUError as error:
        return CheckResult(name, True, f"{call} refused", call_error(error) + "; a host must instantiate anew")
    after = _run(target, unit)
    problems = []
    difference = compare(after, first)
    if difference != 0.0:
        what = f" (after running with {varied[0].name} = {b:g})" if varied else ""
        problems.append(f"a run after {call}{what} differs from a fresh instance's: "
                        + first_difference(target, after, first, times(target, len(first)))
                        + (f"; {call} must bring {varied[0].name} back to its start value "
                           f"{float(varied[0].start):g}" if varied else ""))
    figure = f"max difference {difference:.3g}"
    if varied:
        p, a = varied
        unit.reset()  # reset again, set p = a: must act like a fresh instance with p = a
        after_set = _run(target, unit, {p.name: a})
        difference = compare(after_set, fresh)
        figure += f"; {p.name} = {a:g} set after reset: {difference:.3g}"
        if difference != 0.0:
            problems.append(f"{p.name} set to {a:g} after {call} does not act like a fresh instance with "
                            f"{p.name} = {a:g} (the FMU keeps using an old value): "
                            + first_difference(target, after_set, fresh, times(target, len(fresh))))
        else:
            figure += f" ({p.name} moves the outputs by {effect:.3g})" if effect > 0 else ""
    if problems:
        return CheckResult(name, False, figure + stimulus, "; ".join(problems))
    if not exercise.moved(first).any():
        return CheckResult(name, INCONCLUSIVE, figure + stimulus, unexercised(target, "no output moved"))
    if varied and effect == 0:
        return CheckResult(name, INCONCLUSIVE, figure + " (no parameter tried changes the outputs)" + stimulus,
                           unexercised(target, f"none of {', '.join(tried)} changes the outputs (a value kept "
                                               f"across {call} would not show)") + ", or choose another parameter")
    return CheckResult(name, True, figure + stimulus)


def _other_value(varied) -> float:
    """A value of the varied parameter other than its start value and the value a."""
    p, a = varied
    start = float(p.start) if p.start is not None else 0.0
    other = start * 0.9 if start != 0 else a / 2
    if p.min is not None and other < float(p.min) or p.max is not None and other > float(p.max):
        other = (start + a) / 2
    return other
