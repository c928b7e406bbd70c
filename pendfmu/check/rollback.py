"""State rollback: an FMU state saved during a run (several points, among them the first
instant of each combination of discrete modes, Integer and Boolean variables, that the run
visits, e.g. a cart sliding forwards, stuck, sliding backwards), restored after the run went on past further
events, must reproduce the rest of the run bit for bit with the same inputs; so must a state
serialized to bytes and deserialized."""

from __future__ import annotations

import numpy as np

from pendfmu.check.fmu import CheckResult, Driver, Target, call_error, compare, first_difference

MAX_MODE_SAVES = 8  # states saved at the first instants of this many mode combinations at most


def run(target: Target, kind: str) -> list[CheckResult]:
    name = f"rollback: FMU state {kind}"
    interface = target.interface(kind)
    if not interface.canGetAndSetFMUstate:
        return [CheckResult(name, True, "not declared", "canGetAndSetFMUstate is false: nothing to roll back")]
    h, stimulus = target.step, target.stimulus(target.step)
    n = int(round(target.stop / h))
    unit = Driver(target, kind)
    try:
        unit.initialize(None, stimulus(0.0))
        # a first run to find where the modes change
        modes: list = []
        start = unit.modes()
        unit.run(h, target.stop, stimulus, record_modes=modes)
        unit.reset()
        unit.initialize(None, stimulus(0.0))
        points = {n // 4, n // 2, 3 * n // 4}
        # the first instant of each combination of modes the run visits (sliding either way,
        # stuck, saturated...), so that a state saved in every one of them is restored
        first_in: dict[str, int] = {}
        for k, (_, m) in enumerate(modes):
            if m != start:
                first_in.setdefault(repr(m), k + 1)
        changed = min(first_in.values(), default=None)
        points.update(k for k in list(first_in.values())[:MAX_MODE_SAVES] if k < n)
        points = sorted(p for p in points if 0 < p < n)
        saved, rows = {}, [unit.outputs()]
        for k in range(n):
            if k in points:
                saved[k] = (unit.get_state(), unit.modes())
            unit.step(h, stimulus(k * h))
            unit.time = (k + 1) * h
            rows.append(unit.outputs())
        reference = np.array(rows)
        worst, problems = 0.0, []
        for k in reversed(points):
            state, mode = saved[k]
            unit.set_state(state)
            again = unit.run(h, target.stop, lambda t: stimulus(t))
            difference = compare(again, reference[k:])
            worst = max(worst, difference)
            if difference != 0.0:
                where = first_difference(target, again, reference[k:], np.arange(k, n + 1) * h)
                said = f" (modes {_modes(target, mode)} at the save)" if mode else ""
                problems.append(f"restoring the state saved at t = {k * h:.6g} s{said} does not reproduce the run: "
                                f"{where}")
        visited = sum(1 for k in first_in.values() if k in saved)
        figure = f"{len(points)} saves" + (f", in {visited} mode combinations besides the start's, the first "
                                            f"{_modes(target, saved[changed][1])}"
                                            if changed in saved else ", no mode change seen")
        results = [CheckResult(name, not problems, figure + f"; max difference {worst:.3g}", "; ".join(problems[:2]))]
        if interface.canSerializeFMUstate:
            k = changed if changed in saved else points[len(points) // 2]
            name_s = f"rollback: serialized state {kind}"
            data = unit.serialize_state(saved[k][0])
            copy = unit.deserialize_state(data, saved[k][0])
            unit.set_state(copy)
            again = unit.run(h, target.stop, stimulus)
            difference = compare(again, reference[k:])
            message = "" if difference == 0.0 else (
                f"a state serialized at t = {k * h:.6g} s ({len(data)} bytes) and deserialized does not reproduce "
                f"the run: " + first_difference(target, again, reference[k:], np.arange(k, n + 1) * h))
            results.append(CheckResult(name_s, difference == 0.0, f"{len(data)} bytes; max difference {difference:.3g}",
                                       message))
            unit.free_state(copy)
        for state, _ in saved.values():
            unit.free_state(state)
        return results
    except Exception as error:
        return [CheckResult(name, False, "call failed", call_error(error))]
    finally:
        unit.free()


def _modes(target: Target, values: tuple) -> str:
    return ", ".join(f"{v.name}={int(x)}" for v, x in zip(target.modes, values))
