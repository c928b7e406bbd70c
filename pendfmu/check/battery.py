"""The whole battery on one FMU: `run_battery(path, stop, step) -> list[CheckResult]`.

Static checks of the model description once, then, for each interface the FMU declares (Co-
Simulation, Model Exchange), the static checks of its binary and every dynamic check. Each
check that loads the binary runs as a job in a child process with a time limit
(pendfmu/check/contain.py): a check that raises, crashes (SIGSEGV, an abort) or hangs is a
failed row, not a crash or a hang of the checker, and the other checks still run.
"""

from __future__ import annotations

from functools import partial
from pathlib import Path

from pendfmu.check import convergence, determinism, events, inputs, rollback, sequence, static
from pendfmu.check import reference as reference_mod
from pendfmu.check.contain import TIME_LIMIT, Job, run_contained
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
                step_rtol: float = DEFAULT_STEP_RTOL, time_limit: float = TIME_LIMIT) -> list[CheckResult]:
    """Run every check (or the chosen ones) on an FMU, for each interface it has: what
    `pendfmu check` runs. Each check group runs in a child process, so an FMU that crashes
    or hangs fails its rows, and the battery goes on.

    Parameters
    ----------
    path : str or Path
        The FMU file (FMI 2.0 or 3.0).
    stop : float, optional
        The end of the runs [s]; by default the recording's last time, else the default
        experiment's stop time, else 1 s.
    step : float, optional
        The communication step [s]; by default the default experiment's, else stop/500.
    only : tuple of str, optional
        The checks to run, by module name: "static", "sequence", "events", "determinism",
        "rollback", "convergence", "inputs", "reference"; all by default.
    recording : str or Path, optional
        A CSV (time first; a whole recording: columns that are not inputs are ignored) that
        drives the runs instead of the stimulus the search finds (stimulus.py).
    reference : str or Path, optional
        A CSV of reference results compared inside a tolerance tube; by default the
        reference results the FMU carries (FMI-LS-REF), if any.
    atol, rtol : float, optional
        The tube's absolute half-width (in each variable's unit) and relative one (of
        max(|reference|, the variable's nominal, else the reference column's range)).
    ttol : float, optional
        The tube's time tolerance [s]; by default a tenth of the median sample interval.
    plot_dir : str or Path, optional
        Where a PNG per failing variable of the reference check goes.
    input_limit : float, optional
        How far the stimulus drives an input without a declared range, in multiples of its
        nominal.
    order : float, optional
        The order of the fixed-step solver the FMU is built around (convergence.py).
    step_rtol : float, optional
        How far a result may move with the communication step, of its nominal or range
        (convergence.py).
    time_limit : float, optional
        The seconds each check group may take in its child process.

    Returns
    -------
    list of CheckResult
        One row per check and interface (several for some checks).

    Raises
    ------
    BadInput
        The file is not an FMU pendfmu can read, `stop` and `step` do not fit
        (0 < step < stop), or the reference CSV cannot be read.
    """
    target = Target(path, stop, step, recording)
    target.input_limit, target.stated_order, target.step_rtol = input_limit, order, step_rtol
    known = reference_mod.read_reference_csv(reference, target) if reference is not None else None
    chosen = [module for module in (static, *DYNAMIC) if only is None or _label(module) in only]
    results = static.description_rows(target) if static in chosen else []
    if target.capped:
        results.append(CheckResult("static: planned work", WARN, "steps capped", target.capped))
    jobs = [job for module in chosen for job in group_jobs(target, module, target.interfaces)]
    unreadable = []
    if only is None or "reference" in only:
        references = [known] if known is not None else []
        if known is None:
            try:
                references = reference_mod.carried(target)
            except BadInput as error:  # the FMU's own references are broken: its failure
                unreadable.append(CheckResult("reference: FMI-LS-REF", False, "unreadable", str(error)))
        jobs += [Job(f"reference: {Path(ref.origin).name}",
                     partial(_reference_rows, target, ref, atol, rtol, ttol, plot_dir))
                 for ref in references if target.interfaces]
    for rows in progress(run_contained(jobs, time_limit), f"checking {Path(path).name}", total=len(jobs),
                         label=lambda rows: rows[0].name if rows else ""):
        results += rows
    return results + unreadable


def _label(module) -> str:
    return module.__name__.rsplit(".", 1)[1]


def group_jobs(target: Target, module, kinds) -> list[Job]:
    """The jobs of one check group for each interface: the module's own split (`jobs`, one per
    misuse in sequence.py) where it has one, else one job running module.run(target, kind)."""
    if hasattr(module, "jobs"):
        return [job for kind in kinds for job in module.jobs(target, kind)]
    return [Job(f"{_label(module)} {kind}", partial(module.run, target, kind)) for kind in kinds]


def _reference_rows(target: Target, ref, atol, rtol, ttol, plot_dir) -> list[CheckResult]:
    """One reference compared in every interface (one job: a carried one is judged across them)."""
    return [row for kind in target.interfaces for row in reference_mod.run(target, kind, ref, atol, rtol, ttol,
                                                                            plot_dir)]


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
