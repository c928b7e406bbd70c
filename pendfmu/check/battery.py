"""The whole battery on one FMU: `run_battery(path, stop, step) -> list[CheckResult]`.

Static checks once, then every dynamic check for each interface the FMU declares (Co-
Simulation, Model Exchange). A check that raises is a failed row, not a crash of the checker;
the call-sequence checks run their misuse in child processes (a segfault is a FAIL there).
"""

from __future__ import annotations

from pathlib import Path

from pendfmu.check import convergence, determinism, inputs, rollback, sequence, static
from pendfmu.check.fmu import CheckResult, Target

DYNAMIC = (sequence, determinism, rollback, convergence, inputs)


def run_battery(path: str | Path, stop: float | None = None, step: float | None = None,
                only: tuple[str, ...] | None = None, recording: str | Path | None = None) -> list[CheckResult]:
    """Every check on the FMU at `path`; `only` picks checks by module name ("static",
    "sequence", "determinism", "rollback", "convergence", "inputs"); `recording` a CSV of
    inputs (time first) that drives the runs instead of the default sine."""
    target = Target(path, stop, step, recording)
    results: list[CheckResult] = []
    if only is None or "static" in only:
        results += _guarded("static", lambda: static.run(target))
    for module in DYNAMIC:
        label = module.__name__.rsplit(".", 1)[1]
        if only is not None and label not in only:
            continue
        for kind in target.interfaces:
            results += _guarded(f"{label} {kind}", lambda: module.run(target, kind))
    return results


def _guarded(label: str, check) -> list[CheckResult]:
    try:
        return check()
    except Exception as error:  # a check's own failure is a failed row with its reason
        return [CheckResult(label, False, "check failed", f"{type(error).__name__}: {error}")]


def format_table(path: str | Path, results: list[CheckResult]) -> str:
    """One row per check: PASS/FAIL, name, figure; the message under a failure (and under a
    pass that has something to say)."""
    width = max((len(r.name) for r in results), default=10)
    lines = [f"{Path(path).name}"]
    for r in results:
        lines.append(f"  {'PASS' if r.passed else 'FAIL'}  {r.name:<{width}}  {r.figure}")
        if r.message and not r.passed:
            lines.append(f"        {r.message}")
    failed = sum(not r.passed for r in results)
    lines.append(f"  {len(results) - failed} passed, {failed} failed")
    return "\n".join(lines)
