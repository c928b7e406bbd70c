"""Check FMI 2.0 and 3.0 FMUs with a battery of tests and print one row per check.

Static: the model description (fmpy's validate_fmu), every function FMI 2.0 or 3.0 requires
exported by the binary, the GUID (instantiation token) checked at instantiation, the declared
capabilities working. Dynamic, for Co-Simulation and Model Exchange (whichever the FMU has): misuse
answered with an error status (run in child processes: a crash is a FAIL), two fresh
instances and a reset instance giving identical outputs, FMU state rollback and
serialization reproducing a run bit for bit, step-size convergence (h, h/2, h/4) with its
observed order, and finite outputs over each input's declared range.

Inputs are driven by a slow sine over each input's declared range (else around its start
value), held over each communication step h, or by --input REC.csv. Each row is PASS, WARN (FMI
leaves it to the FMU: the reason says what a user should know), FAIL or INCONCLUSIVE (the run
exercised nothing the check could judge). Exit code 0: nothing failed or was inconclusive; 1: a
check failed; 3: none failed, but one was inconclusive; 2: bad input (an FMU missing or unreadable).

With --reference REF.csv (time first, columns named like the FMU's variables; columns of
inputs are the stimulus) the FMU also runs on the reference's time grid and each other
column is compared inside a tolerance tube: at each time t the result must lie within
[min, max] of the reference over [t - ttol, t + ttol], widened by atol + rtol * max(|ref|,
nominal) (nominal: the variable's nominal attribute, else the column's range). Without
--reference, reference results the FMU carries (FMI-LS-REF, as the FMI standard's Reference
FMUs ship them: extra/org.fmi-standard.fmi-ls-ref/<Model>_out.csv) are used.
"""

from __future__ import annotations

import argparse
import math

HELP = "check FMI 2.0 and 3.0 FMUs: static, call sequence, determinism, rollback, step-size convergence, inputs"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("fmus", nargs="+", metavar="FMU", help="FMI 2.0 or 3.0 FMU files")
    parser.add_argument("--stop", type=float, help="length of the runs [s] (default: the default experiment's, "
                                                     "else 1 s)")
    parser.add_argument("--step", type=float, help="communication step h [s] (default: the default experiment's, "
                                                     "else stop/500)")
    parser.add_argument("--input", metavar="REC.csv", help="drive the runs by this recording: time first, then "
                        "columns named like the inputs (others keep the default sine); sets --stop to its end")
    parser.add_argument("--only", nargs="+", choices=("static", "sequence", "determinism", "rollback",
                                                      "convergence", "inputs", "reference"),
                        help="run only these checks")
    parser.add_argument("--reference", metavar="REF.csv", help="compare with this reference result in a tolerance "
                        "tube (default: the reference results the FMU carries under extra/, if any)")
    parser.add_argument("--atol", type=float, help="absolute tolerance (default 0: "
                        "the nominal floor of --rtol is the absolute part)")
    parser.add_argument("--rtol", type=float, help="relative tolerance, of max(|reference|, "
                        "nominal) (default 1e-3)")
    parser.add_argument("--ttol", type=float, help="time tolerance [s] at discontinuities (default: a tenth of the "
                        "reference's median sample interval)")
    parser.add_argument("--plot", metavar="DIR", help="write a PNG per variable outside its tube into DIR")


def _tolerance(value: float | None, option: str) -> None:
    from pendfmu.errors import BadInput

    if value is not None and not (math.isfinite(value) and value >= 0):
        raise BadInput(f"{option} {value}: needs a finite value >= 0")


def run(args: argparse.Namespace) -> int:
    from pendfmu.check.battery import exit_code, format_table, run_battery
    from pendfmu.check.fmu import Target
    from pendfmu.check.reference import DEFAULT_ATOL, DEFAULT_RTOL, read_reference_csv

    atol = DEFAULT_ATOL if args.atol is None else args.atol
    rtol = DEFAULT_RTOL if args.rtol is None else args.rtol
    for value, option in ((args.atol, "--atol"), (args.rtol, "--rtol"), (args.ttol, "--ttol")):
        _tolerance(value, option)
    for path in args.fmus:  # every file readable before any check runs
        target = Target(path, args.stop, args.step, args.input)
        if args.reference:
            read_reference_csv(args.reference, target)
    codes = []
    for path in args.fmus:
        results = run_battery(path, args.stop, args.step, tuple(args.only) if args.only else None, args.input,
                              args.reference, atol, rtol, args.ttol, args.plot)
        print(format_table(path, results), flush=True)
        codes.append(exit_code(results))
    return 1 if 1 in codes else max(codes, default=0)  # a FAIL anywhere outranks an inconclusive row
