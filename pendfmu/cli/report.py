"""``pendfmu report A.json [B.json] [--out DIR]``: a result's report, or two compared.

One result file: its report written again (e.g. after an update of pendfmu's report, or
for a result fitted without --report). Two: a comparison page, the values side by side
with their intervals, each difference in units of the combined standard error, and the
recordings both hold overlaid. Both files are read before anything is written: a missing
or foreign file is a one-line error (exit 2) and leaves the output folder as it was.
"""

from __future__ import annotations

import argparse

HELP = "write the report of a result file, or compare two (pendfmu report A.json [B.json] --out DIR)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("results", nargs="+", metavar="RESULT.json", help="one result file, or two to compare")
    parser.add_argument("--out", default="report", help="folder of the report (default: report)")


def run(args: argparse.Namespace) -> int:
    from pathlib import Path

    from pendfmu.cli.outputs import check_output_folder
    from pendfmu.errors import UsageError
    from pendfmu.fitting.result import read_result
    from pendfmu.report import write_comparison, write_report

    if len(args.results) > 2:
        raise UsageError(f"report takes one result file or two to compare, not {len(args.results)}")
    check_output_folder(args.out, "--out")
    results = [read_result(path) for path in args.results]
    if len(results) == 1:
        index = write_report(results[0], args.out)
    else:
        names = tuple(Path(p).stem for p in args.results)
        if names[0] == names[1]:  # run1/fit.json against run2/fit.json
            names = ("A", "B")
        index = write_comparison(results[0], results[1], args.out, names, tuple(args.results))
    print(f"report: {index}")
    return 0
