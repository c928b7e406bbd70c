"""Check FMI 2.0 and 3.0 FMUs with a battery of tests and print one row per check.

Static: the model description (fmpy's validate_fmu; min <= start <= max; a Co-Simulation or
Model Exchange interface; a modelIdentifier that is a C identifier, else no library of the FMU
is loaded), every function FMI 2.0 or 3.0 requires exported by the binary, the GUID
(instantiation token) checked at instantiation, the declared capabilities working. Dynamic,
for Co-Simulation and Model Exchange (whichever the FMU has): misuse answered with an error
status, the events the stimulus shows, two fresh instances and a reset instance giving
identical outputs, FMU state rollback (around events too) and serialization reproducing a run
bit for bit, step-size convergence (h, h/2, h/4) within --step-rtol or at the --order stated,
and finite outputs over each input's declared range, else by decades up to --input-limit
times its nominal.

Without --input the stimulus is searched for (pendfmu/check/stimulus.py): each input over its
declared range, else around its start value at 1, 10, 100, ... times its nominal up to
--input-limit times it, as a sine, steps and a ramp, until the outputs move and events are seen
from outside (mode changes, event indicators, sign changes and kinks of the outputs); every row
names the stimulus it used. --input REC.csv drives the runs by a recording instead (a whole
recording: columns that are not inputs are ignored and listed; --input-reference compares them
as a reference). Each row is PASS (exercised and right), WARN (FMI leaves it to the FMU: the
reason says what a user should know), FAIL or INCONCLUSIVE (the run exercised nothing the check
could judge: the reason says what was missing). Exit code 0: nothing failed or was
inconclusive; 1: a check failed; 3: none failed, but one was inconclusive; 2: bad input (an FMU
missing or unreadable).

With --reference REF.csv (time first, columns named like the FMU's variables; columns of
inputs are the stimulus) the FMU also runs on the reference's time grid and each other
column is compared inside a tolerance tube: at each time t the result must lie within
[min, max] of the reference over [t - ttol, t + ttol], widened by atol + rtol * max(|ref|,
nominal) (nominal: the variable's nominal attribute, else the column's range). Without
--reference, reference results the FMU carries (FMI-LS-REF, as the FMI standard's Reference
FMUs ship them: extra/org.fmi-standard.fmi-ls-ref/<Model>_out.csv) are used.

Every check that loads the FMU's binary runs in a child process (pendfmu/check/contain.py): a
crash (SIGSEGV, an abort) or a check group that outlives --time-limit is a FAIL row naming the
signal or the limit, and the other checks still run. A child may allocate 2 GiB beyond what it
inherits, and the model description's default experiment plans at most 20000 communication
steps a run (a row "static: planned work" says what was capped).
"""

from __future__ import annotations

import argparse
import math

HELP = "check FMI 2.0 and 3.0 FMUs: static, call sequence, events, determinism, rollback, step-size convergence, inputs"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("fmus", nargs="+", metavar="FMU", help="FMI 2.0 or 3.0 FMU files")
    parser.add_argument("--stop", type=float, help="length of the runs [s] (default: the default experiment's, "
                                                     "else 1 s)")
    parser.add_argument("--step", type=float, help="communication step h [s] (default: the default experiment's, "
                                                     "else stop/500)")
    parser.add_argument("--input", metavar="REC.csv", help="drive the runs by this recording: time first; columns "
                        "named like the inputs drive them (inputs without one follow a sine of 1 x nominal around their "
                        "start), other columns are ignored and listed; sets --stop to its end")
    parser.add_argument("--input-reference", action="store_true", help="with --input: compare the recording's "
                        "other columns with the FMU's results, as --reference REC.csv does")
    parser.add_argument("--input-limit", type=float, metavar="X", help="drive and probe an input without a declared "
                        "range up to X times its nominal, by decades (default 1000: 1, 10, 100, 1000)")
    parser.add_argument("--order", type=float, metavar="P", help="the FMU is built around a fixed-step solver of "
                        "order P: results that converge at that order with the communication step pass")
    parser.add_argument("--step-rtol", type=float, metavar="R", help="how far a result may move with the "
                        "communication step, of the larger of its nominal and its range over the run (default 1e-4)")
    checks = ("static", "sequence", "events", "determinism", "rollback", "convergence", "inputs", "reference")
    parser.add_argument("--only", nargs="+", choices=checks, metavar="CHECK",
                        help=f"run only these checks: {', '.join(checks)}")
    parser.add_argument("--reference", metavar="REF.csv", help="compare with this reference result in a tolerance "
                        "tube (default: the reference results the FMU carries under extra/, if any)")
    parser.add_argument("--atol", type=float, help="absolute tolerance (default 0: "
                        "the nominal floor of --rtol is the absolute part)")
    parser.add_argument("--rtol", type=float, help="relative tolerance, of max(|reference|, "
                        "nominal) (default 1e-3)")
    parser.add_argument("--ttol", type=float, help="time tolerance [s] at discontinuities (default: a tenth of the "
                        "reference's median sample interval)")
    parser.add_argument("--plot", metavar="DIR", help="write a PNG per variable outside its tube into DIR")
    parser.add_argument("--time-limit", type=float, metavar="SECONDS", help="seconds each check group may take in "
                        "its child process before it is a FAIL row and the other checks go on (default 120: "
                        "pendfmu.check.contain.TIME_LIMIT); a child may also allocate at most 2 GiB")


def _tolerance(value: float | None, option: str, positive: bool = False) -> None:
    from pendfmu.errors import BadInput

    if value is not None and not (math.isfinite(value) and (value > 0 if positive else value >= 0)):
        raise BadInput(f"{option} {value}: needs a finite value {'>' if positive else '>='} 0")


def _options(args: argparse.Namespace) -> dict:
    """The dynamic checks' options, checked (bad input, exit 2, before any check runs)."""
    from pendfmu.check.contain import TIME_LIMIT
    from pendfmu.check.fmu import DEFAULT_INPUT_LIMIT, DEFAULT_STEP_RTOL
    from pendfmu.errors import BadInput

    for value, option in ((args.input_limit, "--input-limit"), (args.order, "--order"), (args.step_rtol, "--step-rtol")):
        _tolerance(value, option, positive=True)
    if args.input_reference and not args.input:
        raise BadInput("--input-reference needs --input REC.csv (the recording whose other columns are compared)")
    _tolerance(args.time_limit, "--time-limit", positive=True)
    return {"input_limit": DEFAULT_INPUT_LIMIT if args.input_limit is None else args.input_limit,
            "order": args.order, "step_rtol": DEFAULT_STEP_RTOL if args.step_rtol is None else args.step_rtol,
            "time_limit": TIME_LIMIT if args.time_limit is None else args.time_limit}


def run(args: argparse.Namespace) -> int:
    from pendfmu.check.battery import exit_code, format_table, run_battery
    from pendfmu.check.fmu import Target
    from pendfmu.check.reference import DEFAULT_ATOL, DEFAULT_RTOL, read_reference_csv

    atol = DEFAULT_ATOL if args.atol is None else args.atol
    rtol = DEFAULT_RTOL if args.rtol is None else args.rtol
    for value, option in ((args.atol, "--atol"), (args.rtol, "--rtol"), (args.ttol, "--ttol")):
        _tolerance(value, option)
    options = _options(args)
    reference = args.input if args.input_reference else args.reference
    for path in args.fmus:  # every file readable before any check runs
        target = Target(path, args.stop, args.step, args.input)
        if reference:
            read_reference_csv(reference, target)
    codes = []
    for path in args.fmus:
        results = run_battery(path, args.stop, args.step, tuple(args.only) if args.only else None, args.input,
                              reference, atol, rtol, args.ttol, args.plot, **options)
        print(format_table(path, results), flush=True)
        codes.append(exit_code(results))
    return 1 if 1 in codes else max(codes, default=0)  # a FAIL anywhere outranks an inconclusive row
