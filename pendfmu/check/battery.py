"""The whole battery on one FMU: `run_battery(path, stop, step) -> list[CheckResult]`.

Static checks once, then every dynamic check for each interface the FMU declares (Co-
Simulation, Model Exchange). A check that raises is a failed row, not a crash of the checker;
the call-sequence checks run their misuse in child processes (a segfault is a FAIL there).
"""

from __future__ import annotations

from pathlib import Path

from pendfmu.check import convergence, determinism, events, inputs, rollback, sequence, static
from pendfmu.check import reference as reference_mod
from pendfmu.check.fmu import (DEFAULT_INPUT_LIMIT, DEFAULT_STEP_RTOL, FAIL, INCONCLUSIVE, PASS, VERDICTS, WARN,
                               CheckResult, Target)
from pendfmu.check.reference import DEFAULT_ATOL, DEFAULT_RTOL
from pendfmu.console import progress
from pendfmu.errors import EXIT_SUSPICIOUS as EXIT_INCONCLUSIVE
from pendfmu.errors import BadInput

DYNAMIC = (sequence, events, determinism, rollback, convergence, inputs)


def run_battery(path: str | Path, stop: float | None = None, step: float | None = None,
                only: tuple[str, ...] | None = None, recording: str | Path | None = None,
                reference: str | Path | None = None, atol: float = DEFAULT_ATOL, rtol: float = DEFAULT_RTOL,
                ttol: float | None = None, plot_dir: str | Path | None = None,
                input_limit: float = DEFAULT_INPUT_LIMIT, order: float | None = None,
                step_rtol: float = DEFAULT_STEP_RTOL) -> list[CheckResult]:
    """Every check on the FMU at `path`; `only` picks checks by module name ("static",
    "sequence", "events", "determinism", "rollback", "convergence", "inputs", "reference");
    `recording` a CSV (time first; a whole recording: columns that are not inputs are
    ignored) that drives the runs instead of the stimulus the search finds (stimulus.py:
    inputs without a declared range up to `input_limit` times their nominal). `order`: the
    order of the fixed-step solver the FMU is built around, `step_rtol`: how far a result may
    move with the communication step (convergence.py). `reference` a CSV of reference results
    compared inside a tolerance tube (atol, rtol, ttol; pendfmu/check/reference.py), else the
    reference results the FMU carries (FMI-LS-REF), if any; `plot_dir` gets a PNG per failing
    variable."""
    target = Target(path, stop, step, recording)
    target.input_limit, target.stated_order, target.step_rtol = input_limit, order, step_rtol
    known = reference_mod.read_reference_csv(reference, target) if reference is not None else None
    results: list[CheckResult] = []
    if only is None or "static" in only:
        results += _guarded("static", lambda: static.run(target))
    runs = [(module, kind) for module in DYNAMIC for kind in target.interfaces
            if only is None or module.__name__.rsplit(".", 1)[1] in only]
    for module, kind in progress(runs, f"checking {Path(path).name}",
                                 label=lambda run: f"{run[0].__name__.rsplit('.', 1)[1]} {run[1]}"):
        label = module.__name__.rsplit(".", 1)[1]
        results += _guarded(f"{label} {kind}", lambda: module.run(target, kind))
    if only is None or "reference" in only:
        references = [known] if known is not None else []
        if known is None:
            try:
                references = reference_mod.carried(target)
            except BadInput as error:  # the FMU's own references are broken: its failure
                results.append(CheckResult("reference: FMI-LS-REF", False, "unreadable", str(error)))
        for ref in references:
            for kind in target.interfaces:
                results += _guarded(f"reference {kind}",
                                    lambda: reference_mod.run(target, kind, ref, atol, rtol, ttol, plot_dir))
    return results


def _guarded(label: str, check) -> list[CheckResult]:
    try:
        return check()
    except Exception as error:  # a check's own failure is a failed row with its reason
        return [CheckResult(label, False, "check failed", f"{type(error).__name__}: {error}")]


def format_table(path: str | Path, results: list[CheckResult]) -> str:
    """One row per check: its verdict, name and figure; the reason under any row that did
    not pass (and under a WARN)."""
    width = max((len(r.name) for r in results), default=10)
    column = max((len(r.verdict) for r in results), default=4)  # "PASS  name" unless a longer verdict is shown
    lines = [f"{Path(path).name}"]
    for r in results:
        lines.append(f"  {r.verdict:<{column}}  {r.name:<{width}}  {r.figure}")
        if r.message and r.verdict != PASS:
            lines.append(f"  {'':<{column}}  {r.message}")
    count = {verdict: sum(r.verdict == verdict for r in results) for verdict in VERDICTS}
    summary = [f"{count[PASS]} passed", f"{count[WARN]} with a warning" if count[WARN] else "",
               f"{count[FAIL]} failed", f"{count[INCONCLUSIVE]} inconclusive" if count[INCONCLUSIVE] else ""]
    lines.append("  " + ", ".join(part for part in summary if part))
    return "\n".join(lines)


def exit_code(results: list[CheckResult]) -> int:
    """1 if a check failed, else 3 if one was inconclusive (nothing exercised), else 0."""
    verdicts = {r.verdict for r in results}
    return 1 if FAIL in verdicts else (EXIT_INCONCLUSIVE if INCONCLUSIVE in verdicts else 0)
