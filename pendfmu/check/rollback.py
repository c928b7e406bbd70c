"""State rollback: an FMU state saved during a run, restored after the run went on past
further events, must reproduce the rest of the run bit for bit with the same inputs; so must
a state serialized to bytes and deserialized.

States are saved at a quarter, half and three quarters of the run, at the first instant of
each combination of discrete modes (Integer and Boolean variables) the run visits (a cart
sliding forwards, stuck, sliding backwards), and just before and just after the first events
seen from outside (exercise.py: mode changes, Model Exchange event iterations, sign changes,
kinks and jumps of the outputs), so that an FMU without mode variables is rolled back over
its events too. A state saved at a quarter mark or a first mode instant is rerun to the end,
one around an event for EVENT_WINDOW of the run. A row whose outputs never moved after any
save exercised nothing: INCONCLUSIVE.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pendfmu.check import exercise
from pendfmu.check.fmu import INCONCLUSIVE, CheckResult, Driver, Target, call_error, compare, first_difference
from pendfmu.check.stimulus import excitation, reference_run, unexercised

MAX_MODE_SAVES = 8  # states saved at the first instants of this many mode combinations at most
MAX_EVENT_SAVES = 8  # states saved around events at most (two per event: before and after)
EVENT_WINDOW = 0.05  # a state saved around an event is rerun for this fraction of the run (20 steps at least)


@dataclass
class Plan:
    """Where states are saved: every point, the ones rerun to the end, the first instant of
    the first mode change (or None), how many mode combinations and events are covered."""
    points: list[int]
    to_end: set[int]
    changed: int | None
    combinations: int
    around: list[int]
    events: exercise.Events


def run(target: Target, kind: str) -> list[CheckResult]:
    name = f"rollback: FMU state {kind}"
    interface = target.interface(kind)
    if not interface.canGetAndSetFMUstate:
        return [CheckResult(name, True, "not declared", "canGetAndSetFMUstate is false: nothing to roll back")]
    try:
        plan = _plan(target, kind)
    except Exception as error:
        return [CheckResult(name, False, "call failed", call_error(error))]
    unit = Driver(target, kind)
    try:
        return _rollback(target, kind, unit, plan, interface.canSerializeFMUstate)
    except Exception as error:
        return [CheckResult(name, False, "call failed", call_error(error))]
    finally:
        unit.free()


def _plan(target: Target, kind: str) -> Plan:
    """The save points, from the reference run's modes and events."""
    n = int(round(target.stop / target.step))
    seen = reference_run(target, kind)
    found = exercise.events(target, seen)
    first_in: dict[str, int] = {}
    for k, modes in enumerate(seen.modes):
        if modes != seen.modes[0]:
            first_in.setdefault(repr(modes), k)
    firsts = [k for k in list(first_in.values())[:MAX_MODE_SAVES] if 0 < k < n]
    around = sorted({p for e in found.points[:MAX_EVENT_SAVES // 2] for p in (e - 1, e) if 0 < p < n})
    to_end = {p for p in (n // 4, n // 2, 3 * n // 4, *firsts) if 0 < p < n}
    changed = min(first_in.values(), default=None)
    visited = sum(1 for k in first_in.values() if 0 < k < n)
    return Plan(sorted(to_end | set(around)), to_end, changed, visited, around, found)


def _rollback(target: Target, kind: str, unit: Driver, plan: Plan, serialize: bool) -> list[CheckResult]:
    h, stimulus = target.step, excitation(target).at(target.step)
    n = int(round(target.stop / h))
    unit.initialize(None, stimulus(0.0))
    saved, rows = {}, [unit.outputs()]
    for k in range(n):
        if k in plan.points:
            saved[k] = (unit.get_state(), unit.modes())
        unit.step(h, stimulus(k * h))
        unit.time = (k + 1) * h
        rows.append(unit.outputs())
    reference = np.array(rows)
    window = max(20, int(EVENT_WINDOW * n))
    worst, problems, exercised = 0.0, [], 0
    for k in reversed(plan.points):
        end = n if k in plan.to_end else min(n, k + window)
        state, mode = saved[k]
        said = f" (modes {_modes(target, mode)} at the save)" if mode else ""
        try:
            unit.set_state(state)
            again = unit.run(h, end * h, stimulus)
        except Exception as error:  # the FMU's own error on a rerun is the rollback's failure
            problems.append(f"after restoring the state saved at t = {k * h:.6g} s{said} the rerun fails: "
                            f"{call_error(error)}")
            continue
        difference = compare(again, reference[k:end + 1])
        worst = max(worst, difference)
        exercised += bool(exercise.moved(reference[k:end + 1]).any())
        if difference != 0.0:
            where = first_difference(target, again, reference[k:end + 1], np.arange(k, end + 1) * h)
            problems.append(f"restoring the state saved at t = {k * h:.6g} s{said} does not reproduce the run: "
                            f"{where}")
    results = [_row(target, kind, plan, saved, worst, problems, exercised)]
    if serialize:
        try:
            results.append(_serialized(target, kind, unit, plan, saved, reference))
        except Exception as error:
            results.append(CheckResult(f"rollback: serialized state {kind}", False, "call failed",
                                       f"serializing, restoring or rerunning a saved state: {call_error(error)}"))
    for state, _ in saved.values():
        unit.free_state(state)
    return results


def _row(target: Target, kind: str, plan: Plan, saved: dict, worst: float, problems: list[str],
         exercised: int) -> CheckResult:
    name = f"rollback: FMU state {kind}"
    h = target.step
    figure = f"{len(plan.points)} saves"
    if plan.around:
        figure += f", {len(plan.around)} around {plan.events.describe(h)}"
    figure += (f", in {plan.combinations} mode combinations besides the start's, the first "
               f"{_modes(target, saved[plan.changed][1])}" if plan.changed in saved else ", no mode change seen")
    figure += f"; max difference {worst:.3g} [{excitation(target).label}]"
    if problems:
        return CheckResult(name, False, figure, "; ".join(problems[:2]))
    if not exercised:
        return CheckResult(name, INCONCLUSIVE, figure, unexercised(target, "no output moved after any save (a state "
                                                                       "that restores nothing would pass too)"))
    return CheckResult(name, True, figure)


def _serialized(target: Target, kind: str, unit: Driver, plan: Plan, saved: dict, reference: np.ndarray):
    """A state (at the first mode change, else after the first event, else mid-run)
    serialized, deserialized, restored and rerun to the end."""
    h, n = target.step, len(reference) - 1
    after_event = [p for p in plan.around if p - 1 in plan.around]
    k = plan.changed if plan.changed in saved else after_event[0] if after_event else plan.points[len(plan.points) // 2]
    name = f"rollback: serialized state {kind}"
    data = unit.serialize_state(saved[k][0])
    copy = unit.deserialize_state(data, saved[k][0])
    unit.set_state(copy)
    again = unit.run(h, target.stop, excitation(target).at(h))
    unit.free_state(copy)
    difference = compare(again, reference[k:])
    figure = f"{len(data)} bytes, saved at t = {k * h:.6g} s; max difference {difference:.3g} [{excitation(target).label}]"
    if difference != 0.0:
        return CheckResult(name, False, figure, f"a state serialized at t = {k * h:.6g} s ({len(data)} bytes) and "
                           f"deserialized does not reproduce the run: "
                           + first_difference(target, again, reference[k:], np.arange(k, n + 1) * h))
    if not exercise.moved(reference[k:]).any():
        return CheckResult(name, INCONCLUSIVE, figure, unexercised(target, "no output moved after the save"))
    return CheckResult(name, True, figure)


def _modes(target: Target, values: tuple) -> str:
    return ", ".join(f"{v.name}={int(x)}" for v, x in zip(target.modes, values))
