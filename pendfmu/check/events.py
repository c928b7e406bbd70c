"""Events seen from outside: what the stimulus made the FMU do, one row per interface.

The row names the stimulus the dynamic checks use (the recording, or what the search of
stimulus.py found and what it tried first), how far each output moved, and the events seen
from outside in that run (exercise.py: mode changes, Model Exchange event iterations, sign
changes, kinks and jumps of the outputs). It is what the rollback saves around and what makes
the convergence check meaningful for event location. PASS when outputs moved and events were
seen; INCONCLUSIVE otherwise, with the reason: an FMU without events is not at fault, but the
event-related checks then exercised none. A run that fails is a FAIL.
"""

from __future__ import annotations

from pendfmu.check import exercise
from pendfmu.check.fmu import INCONCLUSIVE, CheckResult, Target, call_error
from pendfmu.check.stimulus import excitation, reference_run, unexercised


def run(target: Target, kind: str) -> list[CheckResult]:
    return [_row(target, kind)]


def _row(target: Target, kind: str) -> CheckResult:
    name = f"events: seen from outside {kind}"
    used = excitation(target)
    try:
        seen = reference_run(target, kind)
    except Exception as error:
        return CheckResult(name, False, "run failed", f"with {used.label}: {call_error(error)}")
    found = exercise.events(target, seen)
    searched = f"; stimulus {len(used.tried)} of the search" if len(used.tried) > 1 else ""
    figure = f"{found.describe(target.step)}; {exercise.movement(target, seen.rows)} [{used.label}{searched}]"
    if not exercise.moved(seen.rows).any():
        return CheckResult(name, INCONCLUSIVE, figure, unexercised(target, "no output moved, so no event could show"))
    if not len(found):
        return CheckResult(name, INCONCLUSIVE, figure, unexercised(
            target, "no event seen (no mode change, event iteration, sign change, kink or jump of an output): an FMU "
                    "without events is not at fault, but rollback around events and event location in the convergence "
                    "check exercised none"))
    return CheckResult(name, True, figure)
