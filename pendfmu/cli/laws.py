"""Which friction law do the recordings support: the candidate laws of the cart's or the
pendulum's friction fitted, ranked by their error on held-out data, and one recommended.

    pendfmu laws pendulum decay.csv --params P.json --out laws.json
    pendfmu laws cart run1.csv run2.csv --drive I --out laws.json --report out/
    pendfmu laws cart run.csv --laws viscous stiction offset --out laws.json

The laws are a ladder, each the one before plus a term: viscous only; + Coulomb; + stiction
(the paper's law); + Stribeck; + direction asymmetry; + offset; + air drag (the pendulum).
Each is fitted to the whole recordings and to their early halves; the early fit predicts
the late halves (the held-out data). The table ranks the laws by that held-out error, with
BIC beside it, and the simplest law within 5 % of the best held-out error is recommended.
The fits run in parallel on --workers processes or a Dask --scheduler. The options of
pendfmu fit that apply pass through to every law's fit; --free and --fix may not name the
friction terms, which each law sets itself.
"""

from __future__ import annotations

import argparse

from pendfmu.cli.fit import add_data_options, add_parameter_options, add_search_options

HELP = "compare the cart's or the pendulum's friction laws on held-out data and recommend one"
STAGE_NAMES = ("cart", "pendulum")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("stage", metavar="STAGE", help="cart or pendulum: the joint whose friction is compared")
    parser.add_argument("recordings", nargs="+", metavar="RECORDING",
                        help="the stage's recordings (CSV + sidecar, or .mat), as for pendfmu fit")
    parser.add_argument("--params", help="known parameter values, and the start of the fitted ones")
    parser.add_argument("--out", required=True, help="the comparison: each law's fits, the ranking, the "
                                                     "recommendation and why (JSON)")
    parser.add_argument("--report", help="write an HTML page of the comparison into this folder")
    parser.add_argument("--laws", nargs="+", metavar="LAW",
                        help="compare only these (default: all): viscous coulomb stiction stribeck asymmetry offset "
                             "drag; each adds its terms to the one before among them")
    add_parameter_options(parser)
    add_data_options(parser, model=False)
    add_search_options(parser, runs="the laws' fits")


def run(args: argparse.Namespace) -> int:
    import sys

    from pendfmu.cli.fit import spec_options
    from pendfmu.cli.outputs import check_output_file, check_output_folder
    from pendfmu.errors import EXIT_MODEL_FAILED
    from pendfmu.fitting.laws import compare_laws

    check_output_file(args.out, "--out")
    if args.report:
        check_output_folder(args.report, "--report")
    comparison = compare_laws(args.stage, args.recordings, laws=args.laws,
                              say=lambda line: print(f"laws: {line}", flush=True),
                              warn=lambda message: print(f"warning: {message}", file=sys.stderr, flush=True),
                              **spec_options(args))
    comparison.request["command"] = getattr(args, "command_line", None)
    comparison.write_json(args.out)
    for line in summary(comparison, args.out):
        print(line)
    if args.report:
        from pendfmu.report import write_laws_report

        print(f"report: {write_laws_report(comparison, args.report)}")
    return 0 if comparison.recommended else EXIT_MODEL_FAILED


def summary(comparison, out: str) -> list[str]:
    """The console's account: what was compared, the table, the recommendation and why."""
    lines = [f"{out}: {len(comparison.rows)} friction laws of the {comparison.stage} stage in "
             f"{comparison.seconds:.0f} s; held out: {comparison.held_out}",
             comparison.table(),
             "free: the parameters each law estimates; RMS: of the residuals in units of the sensor noise (1: as "
             f"good as the sensors allow); dBIC: BIC minus the lowest, on {comparison.effective_samples:.4g} "
             "effective samples"]
    if comparison.recommended is None:
        return [*lines, f"no law recommended: {comparison.reason}"]
    chosen = comparison.row(comparison.recommended)
    values = ", ".join(f"{name} = {value:.4g}" for name, value in chosen.whole.values.items())
    lines += [f"recommended: {chosen.label} ({', '.join(chosen.terms)}): {comparison.reason}",
              f"  its fit to the whole recordings: {values}"]
    return lines + [f"note: {note}" for note in comparison.notes]
