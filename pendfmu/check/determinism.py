"""Determinism: two fresh instances give the same outputs bit for bit, and so does an
instance after fmi2Reset.

FMI 2.0 (fmi2Reset): the FMU goes back to the state it had after fmi2Instantiate, every
variable at its start value. So a run after a reset must equal a fresh instance's run; with
a parameter p changed before the reset that means p is back at its start value, and a
parameter set to a after the reset must act like a fresh instance with p = a (the recurring
bug is an FMU that keeps using the value from before the reset). An FMU that refuses
fmi2Reset with an error status passes: it says it cannot, and a host instantiates anew.
"""

from __future__ import annotations

import numpy as np

from pendfmu.check.fmu import CheckResult, Driver, Target, call_error, compare, first_difference
from pendfmu.errors import FMUError


def fresh_run(target: Target, kind: str, parameters=None) -> np.ndarray:
    unit = Driver(target, kind)
    try:
        return _run(target, unit, parameters)
    finally:
        unit.free()


def _run(target: Target, unit: Driver, parameters=None) -> np.ndarray:
    stimulus = target.stimulus(target.step)
    unit.initialize(parameters, stimulus(0.0))
    return unit.run(target.step, target.stop, stimulus)


def times(target: Target, rows: int) -> np.ndarray:
    return np.arange(rows) * target.step


def run(target: Target, kind: str) -> list[CheckResult]:
    results = []
    name = f"determinism: fresh instances {kind}"
    try:
        first, second = fresh_run(target, kind), fresh_run(target, kind)
    except Exception as error:
        return [CheckResult(name, False, "run failed", call_error(error))]
    difference = compare(first, second)
    if difference == 0.0:
        results.append(CheckResult(name, True, f"identical ({first.shape[0]} points x {first.shape[1]} outputs)"))
    else:
        results.append(CheckResult(name, False, f"max difference {difference:.3g}",
                                   "two fresh instances with the same inputs differ: "
                                   + first_difference(target, first, second, times(target, len(first)))))
    name = f"determinism: reset {kind}"
    varied = target.varied_parameter()
    try:  # before the instance under test exists (an FMU may allow one instance at a time)
        fresh = fresh_run(target, kind, {varied[0].name: varied[1]}) if varied else None
    except Exception as error:
        results.append(CheckResult(name, False, "run failed", call_error(error)))
        return results
    unit = Driver(target, kind)
    try:
        # the instance's first run with p = b (not a: an FMU that derives values from p once
        # would otherwise look right by chance), then reset: back to the start values
        b = _other_value(varied) if varied else None
        _run(target, unit, {varied[0].name: b} if varied else {})
        try:
            unit.reset()
        except FMUError as error:
            results.append(CheckResult(name, True, "fmi2Reset refused",
                                       call_error(error) + "; a host must instantiate anew"))
            return results
        after = _run(target, unit)
        problems = []
        difference = compare(after, first)
        if difference != 0.0:
            what = f" (after running with {varied[0].name} = {b:g})" if varied else ""
            problems.append(f"a run after fmi2Reset{what} differs from a fresh instance's: "
                            + first_difference(target, after, first, times(target, len(first)))
                            + (f"; fmi2Reset must bring {varied[0].name} back to its start value "
                               f"{float(varied[0].start):g}" if varied else ""))
        figure = f"max difference {difference:.3g}"
        if varied:
            p, a = varied
            # reset again, set p = a: must act like a fresh instance with p = a
            unit.reset()
            after_set = _run(target, unit, {p.name: a})
            moved = compare(fresh, first)
            difference = compare(after_set, fresh)
            figure += f"; {p.name} = {a:g} set after reset: {difference:.3g}"
            if difference != 0.0:
                problems.append(f"{p.name} set to {a:g} after fmi2Reset does not act like a fresh instance with "
                                f"{p.name} = {a:g} (the FMU keeps using an old value): "
                                + first_difference(target, after_set, fresh, times(target, len(fresh))))
            elif moved == 0.0:
                figure += f" ({p.name} does not change the outputs)"
        if problems:
            results.append(CheckResult(name, False, figure, "; ".join(problems)))
        else:
            results.append(CheckResult(name, True, figure))
    except Exception as error:
        results.append(CheckResult(name, False, "run failed", call_error(error)))
    finally:
        unit.free()
    return results


def _other_value(varied) -> float:
    """A value of the varied parameter other than its start value and the value a."""
    p, a = varied
    start = float(p.start) if p.start is not None else 0.0
    other = start * 0.9 if start != 0 else a / 2
    if p.min is not None and other < float(p.min) or p.max is not None and other > float(p.max):
        other = (start + a) / 2
    return other
