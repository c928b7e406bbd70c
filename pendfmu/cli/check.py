"""Check FMI 2.0 FMUs with a battery of tests and print one row per check.

Static: the model description (fmpy's validate_fmu), every fmi2 function FMI 2.0 requires
exported by the binary, the GUID checked by fmi2Instantiate, the declared capabilities
working. Dynamic, for Co-Simulation and Model Exchange (whichever the FMU has): misuse
answered with an error status (run in child processes: a crash is a FAIL), two fresh
instances and a reset instance giving identical outputs, FMU state rollback and
serialization reproducing a run bit for bit, step-size convergence (h, h/2, h/4) with its
observed order, and finite outputs over each input's declared range.

Inputs are driven by a slow sine over each input's declared range (else around its start
value), held over each communication step h, or by --input REC.csv. Exit code 0: every check passed; 1: a check failed; 2: bad input (an FMU missing or
unreadable).
"""

from __future__ import annotations

import argparse

HELP = "check FMI 2.0 FMUs: static, call sequence, determinism, rollback, step-size convergence, inputs"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("fmus", nargs="+", metavar="FMU", help="FMI 2.0 FMU files")
    parser.add_argument("--stop", type=float, help="length of the runs [s] (default: the default experiment's, "
                                                     "else 1 s)")
    parser.add_argument("--step", type=float, help="communication step h [s] (default: the default experiment's, "
                                                     "else stop/500)")
    parser.add_argument("--input", metavar="REC.csv", help="drive the runs by this recording: time first, then "
                        "columns named like the inputs (others keep the default sine); sets --stop to its end")
    parser.add_argument("--only", nargs="+", choices=("static", "sequence", "determinism", "rollback",
                                                      "convergence", "inputs"), help="run only these checks")


def run(args: argparse.Namespace) -> int:
    from pendfmu.check.battery import format_table, run_battery
    from pendfmu.check.fmu import Target

    for path in args.fmus:  # every file readable before any check runs
        Target(path, args.stop, args.step, args.input)
    failed = False
    for path in args.fmus:
        results = run_battery(path, args.stop, args.step, tuple(args.only) if args.only else None, args.input)
        print(format_table(path, results), flush=True)
        failed |= any(not r.passed for r in results)
    return 1 if failed else 0
