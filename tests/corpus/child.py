"""Run the corpus's FMUs in a child Python: `in_child(function, *args)` calls one of this
module's functions there and returns its JSON-able result.

Why a child: pythonfmu 0.7.0's binary releases its interpreter state twice when the process
that loaded it exits (a static shared_ptr destroyed, then assigned by the library's
destructor function: valgrind shows the read of freed memory in finalizePythonInterpreter),
which now and then aborts that process with "corrupted double-linked list". The child writes
its answer and leaves with os._exit, before any library destructor runs; the test process
never loads a pythonfmu binary.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

TESTS = Path(__file__).resolve().parents[1]


def in_child(function: str, *args):
    """`function(*args)` of this module, run in a child Python; its result back from JSON.
    RuntimeError with the child's output if it gave no answer."""
    done = subprocess.run([sys.executable, "-m", "corpus.child", function, json.dumps(args)], cwd=TESTS,
                          capture_output=True, text=True, timeout=600)
    lines = done.stdout.strip().splitlines()
    if done.returncode != 0 or not lines:
        raise RuntimeError(f"corpus child {function} failed ({done.returncode}):\n{done.stdout}\n{done.stderr}")
    return json.loads(lines[-1])


def check(paths: list[str], observed: dict[str, str]) -> list[dict]:
    """`pendfmu check` with default options on each FMU: {"rows": [...]} each; for an FMU
    whose path is a key of `observed` (its value: the model's module), also "checks": each
    dynamic check run alone (but sequence, whose misuse runs in grandchildren), with its rows
    and whether the model's ACTIVITY counter moved during it. An FMU the battery raises on
    (e.g. refused as bad input) gets {"rows": [], "error": what it raised}."""
    from pendfmu.check import run_battery

    answers = []
    for path in paths:
        try:
            answer = {"rows": _rows(run_battery(path))}
            if path in observed:
                answer["checks"] = [_observed(path, observed[path], check) for check in _dynamic_checks()]
        except Exception as error:  # one FMU's trouble must not hide the others' answers
            answer = {"rows": [], "error": f"{type(error).__name__}: {error}"}
        answers.append(answer)
    return answers


def simulate(cases: list[list]) -> list[dict[str, list[float]]]:
    """fmpy's simulate_fmu for each case [path, start values, stop, FMI type, output interval,
    module]: every column of the result as a list, and under "activity" what the model's
    ACTIVITY counter gained in the run (module: the model's module, or None: not counted)."""
    from fmpy import simulate_fmu

    results = []
    for path, start, stop, kind, step, module in cases:
        before = _activity(module) if module else 0
        result = simulate_fmu(path, fmi_type=kind, start_values=start, stop_time=stop, output_interval=step,
                              relative_tolerance=1e-10)
        columns = {name: result[name].tolist() for name in result.dtype.names}
        results.append({**columns, "activity": [(_activity(module) if module else 0) - before]})
    return results


def _dynamic_checks() -> list[str]:
    from pendfmu.check.battery import DYNAMIC

    return [name for name in (m.__name__.rsplit(".", 1)[1] for m in DYNAMIC) if name != "sequence"]


def _observed(path: str, module: str, check: str) -> dict:
    """The check's rows, and whether the model counted activity while it ran: the check runs
    in a process of pendfmu's (pendfmu/check/contain.py), so its group's `run` is wrapped to
    count there and to hand the count back as a row of its own, taken out here."""
    from pendfmu.check import run_battery
    from pendfmu.check.battery import DYNAMIC
    from pendfmu.check.fmu import CheckResult

    group = next(m for m in DYNAMIC if m.__name__.endswith("." + check))
    real = group.run

    def counted(target, kind):
        before = _activity(module)
        rows = real(target, kind)
        return rows + [CheckResult(COUNTED, True, str(_activity(module) - before))]

    group.run = counted
    try:
        results = run_battery(path, only=(check,))
    finally:
        group.run = real
    moved = sum(int(r.figure) for r in results if r.name == COUNTED) > 0
    return {"check": check, "rows": _rows([r for r in results if r.name != COUNTED]), "moved": moved}


COUNTED = "activity counted"


def _activity(module: str) -> int:
    """What the model counted so far in this process (0 before its first instance)."""
    loaded = sys.modules.get(module)
    return sum(loaded.ACTIVITY.values()) if loaded is not None else 0


def _rows(results) -> list[dict]:
    return [{"name": r.name, "verdict": r.verdict, "figure": r.figure, "message": r.message} for r in results]


if __name__ == "__main__":
    answer = globals()[sys.argv[1]](*json.loads(sys.argv[2]))
    print(json.dumps(answer), flush=True)
    sys.stderr.flush()
    os._exit(0)
