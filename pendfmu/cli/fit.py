"""Fit a model's parameters to recordings: a stage of the paper's rig, all stages in
order, or a user's FMU or SSP system.

    pendfmu fit current|cart|pendulum REC.csv ... [--params P.json] --out R.json
    pendfmu fit all DIR [--params P.json] --out R.json
    pendfmu fit --fmu X.fmu REC.csv ... --free NAME ... [--drive INPUT[=COLUMN]]
                [--match OUTPUT[=COLUMN]] [--params P.json] --out R.json
    pendfmu fit --system S.ssp REC.csv ... --free NAME ... (as --fmu)

Recordings are fitted jointly with shared parameters; each recording's sidecar fixes its
own values (e.g. m_p = 0 for the cart without pendulum). `fit all` sorts a folder's
recordings by their signals (I_c and I: current; x: cart; phi: pendulum; x and phi:
predicted with the result, not fitted). A user's model is driven and matched by name
(an input with a recorded column of the same name is driven by it, an output with one is
compared with it) unless --drive and --match say otherwise; names are the FMU's variable
names, `Component.name` in a system.
"""

from __future__ import annotations

import argparse

HELP = "fit parameters to recordings (stages: current, cart, pendulum, all; or --fmu / --system)"
STAGE_NAMES = ("current", "cart", "pendulum", "all")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("items", nargs="+", metavar="STAGE|RECORDING",
                        help="a stage (current, cart, pendulum, all) then its recordings (CSV + sidecar, or .mat; "
                             "for 'all' one folder); with --fmu or --system, recordings only")
    model = parser.add_mutually_exclusive_group()
    model.add_argument("--fmu", metavar="X.fmu", help="fit this FMU (FMI 2.0 Co-Simulation) instead of a stage")
    model.add_argument("--system", metavar="S.ssp", help="fit this SSP system instead of a stage")
    parser.add_argument("--params", help="known parameter values, and the start of the fitted ones")
    parser.add_argument("--out", required=True, help="result: parameters, stderr, ci95, fit statistics (JSON)")
    parser.add_argument("--report", help="write an HTML report with figures into this folder")
    add_parameter_options(parser)
    add_data_options(parser, model=True)
    add_search_options(parser)
    parser.add_argument("--checkpoint", help="checkpoint file, written on Ctrl-C, SIGTERM or SIGHUP and periodically during "
                                             "the search (default: OUT with .checkpoint); deleted when the fit ends")
    parser.add_argument("--resume", action="store_true",
                        help="continue an interrupted fit from its checkpoint (same command otherwise)")
    parser.add_argument("--uncertainty", choices=("bootstrap", "jacobian", "sandwich"), default="bootstrap",
                        help="intervals: parametric bootstrap through the sensor model (calibrated, default; a fit "
                             "whose residuals stand far above the noise gets the sandwich ones instead), the Jacobian "
                             "at the optimum (fast, far too narrow on quantized recordings), or the sandwich (the "
                             "residuals' own size and correlation)")
    parser.add_argument("--replicates", type=int, metavar="N",
                        help="bootstrap replicates (default 24; each is one local refit, run on the workers)")
    parser.add_argument("--harmonic", choices=("auto", "off"), default="auto",
                        help="the current stage (also in 'all'): look for the converter's PWM ripple in the "
                             "residual and fit it (auto, default), or not (off)")
    parser.add_argument("--strict", action="store_true",
                        help="exit with code 3 on any warning (suspicious data: before fitting; suspicious "
                             "result: after writing it)")


def add_parameter_options(parser: argparse.ArgumentParser) -> None:
    """--seed, --free, --fix, --bounds: shared with `pendfmu laws`."""
    parser.add_argument("--seed", type=int, help="seed of the global search (default 0)")
    parser.add_argument("--free", nargs="+", action="extend", default=[], metavar="NAME", help="fit these too")
    parser.add_argument("--fix", nargs="+", action="extend", default=[], metavar="NAME", help="keep these at their given values")
    parser.add_argument("--bounds", nargs="+", action="extend", default=[], metavar="NAME=LOW:HIGH", help="search bounds")


def add_data_options(parser: argparse.ArgumentParser, model: bool) -> None:
    """What a stage (or, with `model`, a user's model) is driven by and compared with, and
    which parts of the recordings: shared with `pendfmu laws` (stages only)."""
    parser.add_argument("--drive", nargs="+", action="extend", metavar="INPUT[=COLUMN]",
                        help="a stage: the recorded signal that drives it (I_c, I, u or a); a model: its inputs driven "
                             "by recorded columns (default: each input with a column of its name)")
    parser.add_argument("--match", nargs="+", action="extend", metavar="OUTPUT[=COLUMN]",
                        help="a model: its outputs compared with recorded columns (default: each output with a "
                             "column of its name); a stage: its recorded rate compared as well (pendulum: w, "
                             "cart: v)")
    if model:
        parser.add_argument("--initial", nargs="+", action="extend", metavar="SIGNAL=PARAMETER",
                            help="a model: the parameter a sidecar's initial value of SIGNAL sets (default: an output "
                                 "x sets a parameter x0 where the model has one)")
        parser.add_argument("--interpolation", choices=("hold", "linear"),
                            help="a model: its drives between samples, held (default) or linear (where the FMU can "
                                 "interpolate inputs)")
    parser.add_argument("--per-recording", nargs="+", action="extend", default=[], metavar="NAME",
                        help="estimate these for each recording (or window, segment) on its own: initial states "
                             "(x0 v0 phi0 w0), a sensor's offset (phi_offset), any parameter")
    parser.add_argument("--window", nargs="+", action="extend", default=[], metavar="T0:T1",
                        help="fit only these time windows of each recording (seconds); each starts from its own "
                             "initial states")
    parser.add_argument("--segment", type=float, metavar="SECONDS",
                        help="split each recording (or window) into segments this long, each fitted from its own "
                             "initial states (multiple shooting, for long, closed-loop or unstable runs)")
    parser.add_argument("--start", choices=("estimated", "measured", "turning"),
                        help="initial states of a window or segment that starts late: estimated (default) or taken "
                             "from its first readings; the pendulum stage: 'turning' starts each recording (window, "
                             "segment) at the first turning point of its swing, where the rate is known")
    parser.add_argument("--cost", choices=("plain", "quantized"), default="plain",
                        help="residuals: plain least squares, or zero inside each reading's quantization step")


def add_search_options(parser: argparse.ArgumentParser, runs: str = "the global search") -> None:
    """The global search and where it runs (`runs`: what the workers run): shared with `pendfmu laws`."""
    parser.add_argument("--no-global", action="store_true", help="skip the global search (local refinement only)")
    parser.add_argument("--generations", type=int, metavar="N", help="generations of the global search (default 25)")
    parser.add_argument("--population", type=int, metavar="N",
                        help="the global search's candidates per free parameter (default 8)")
    parser.add_argument("--workers", type=int, default=0, help=f"processes for {runs} (default: cores)")
    parser.add_argument("--scheduler", metavar="ADDRESS",
                        help=f"evaluate {runs} on a Dask cluster (e.g. tcp://10.0.0.5:8786)")


def fit_spec(args: argparse.Namespace):
    """The command line's words as a FitSpec (fitting/spec.py): parsed, nothing decided."""
    from pendfmu.fitting.spec import FitSpec

    target, recordings = _target_and_recordings(args)
    return FitSpec(target, recordings, initial=args.initial, interpolation=args.interpolation, harmonic=args.harmonic,
                   uncertainty=args.uncertainty, replicates=args.replicates, **spec_options(args))


def spec_options(args: argparse.Namespace) -> dict:
    """The FitSpec fields that `pendfmu fit` and `pendfmu laws` share, from their words."""
    from pendfmu.fitting.optimizer import GlobalOptions

    sizes = {name: value for name, value in (("popsize", args.population), ("maxiter", args.generations))
             if value is not None}
    search = GlobalOptions(enabled=not args.no_global, workers=args.workers, scheduler=args.scheduler, **sizes)
    return dict(params=args.params or {}, free=args.free, fix=args.fix, bounds=args.bounds, drive=args.drive,
                match=args.match, per_recording=args.per_recording, windows=args.window, segment=args.segment,
                start=args.start, cost=args.cost, seed=args.seed, global_search=search)


def run(args: argparse.Namespace) -> int:
    import sys

    from pendfmu.cli.outputs import check_output_file, check_output_folder
    from pendfmu.errors import EXIT_SUSPICIOUS, Suspicious
    from pendfmu.fitting.checkpoint import (Checkpoint, Interrupted, refuse_unsafe_path, spec_fingerprint,
                                            stop_signals_interrupt)
    from pendfmu.fitting.identification import fit
    from pendfmu.fitting.provenance import with_command
    from pendfmu.fitting.spec import check_applicable
    from pendfmu.parameters import write_parameters

    check_output_file(args.out, "--out")
    if args.report:
        check_output_folder(args.report, "--report")
    path = check_output_file(args.checkpoint or f"{args.out}.checkpoint", "--checkpoint")
    spec = fit_spec(args)
    check_applicable(spec)
    refuse_unsafe_path(path, args.out, spec)
    key = spec_fingerprint(spec)
    checkpoint = Checkpoint.load(path, key) if args.resume else Checkpoint(path, key)
    printed: list[str] = []

    def warn(message: str) -> None:
        printed.append(message)
        print(f"warning: {message}", file=sys.stderr, flush=True)

    try:
        with stop_signals_interrupt():
            result = fit(spec, checkpoint=checkpoint, warn=warn, strict=args.strict)
    except Suspicious:
        print("pendfmu fit: --strict: not fitted, the recordings look wrong (warnings above)", file=sys.stderr)
        return EXIT_SUSPICIOUS
    except Interrupted as stop:
        write_parameters(stop.parameters, args.out, interrupted=f"{stop} (best values so far)")
        checkpoint.save()
        print(f"interrupted: best values so far in {args.out}; resume with the same command and --resume "
              f"(checkpoint {path})")
        return 130
    except KeyboardInterrupt:  # after a search: its costs are kept all the same
        checkpoint.save()
        print(f"pendfmu fit: interrupted; resume with the same command and --resume (checkpoint {path})",
              file=sys.stderr)
        return 130
    result.provenance = with_command(result.provenance, getattr(args, "command_line", None))
    result.write_json(args.out)
    checkpoint.discard()  # the fit is complete: its checkpoint has served (if the file is still its own)
    _print_result(args, spec, result, printed)
    return EXIT_SUSPICIOUS if args.strict and result.warnings else 0  # the result is written either way


def _print_result(args: argparse.Namespace, spec, result, printed: list[str]) -> None:
    """The summary, notes, flags, a virtual rig's truth, the report and the late warnings."""
    import sys
    from pathlib import Path

    print(f"{args.out}: {_summary(result)}")
    for line in _details(result):
        print(line)
    if spec.kind == "sequence":
        for line in _truth_lines(Path(spec.recordings[0]), result):
            print(line)
    if args.report:
        from pendfmu.report import write_report

        print(f"report: {write_report(result, args.report)}")
    late = [w for w in result.warnings if not any(w.endswith(p) for p in printed)]
    for message in late:
        print(f"warning: {message}", file=sys.stderr)
    if result.warnings:
        print(f"{len(result.warnings)} warning(s); they are also in {args.out} (fit.warnings)", file=sys.stderr)


def _target_and_recordings(args: argparse.Namespace) -> tuple[str, list[str]]:
    """Split the positionals: a stage and its recordings, or (with --fmu/--system) recordings."""
    from pendfmu.errors import UsageError

    if args.fmu or args.system:
        if args.items[0] in STAGE_NAMES:
            raise UsageError(f"--{'fmu' if args.fmu else 'system'} fits that model: leave out the stage "
                             f"{args.items[0]!r}")
        return args.fmu or args.system, list(args.items)
    stage = args.items[0]
    if stage not in STAGE_NAMES:
        from pendfmu.suggest import did_you_mean

        raise UsageError(f"{stage!r} is not a stage{did_you_mean(stage, STAGE_NAMES)} "
                         f"({', '.join(STAGE_NAMES)}); to fit your own model give "
                         f"--fmu X.fmu or --system S.ssp")
    return stage, list(args.items[1:])


def _summary(result) -> str:
    from pendfmu.report.content import interval_text

    parts = []
    for label, estimate in result.estimates.items():
        if estimate.ci95 is None:
            parts.append(f"{label} = {estimate.value:.6g} (no interval)")
        elif estimate.method == "bounded":
            parts.append(f"{label} in {interval_text(*estimate.ci95)} (bounded only)")
        else:
            parts.append(f"{label} = {estimate.value:.6g}, 95 % {interval_text(*estimate.ci95)} ({estimate.method})")
    verdict = result.assessment.get("verdict", "adequate")
    return f"wrote the result ({verdict}); estimates:\n  " + "\n  ".join(parts)


def _truth_lines(folder, result=None) -> list[str]:
    """A virtual rig's folder holds truth.json: show what the fit found against it."""
    import math

    from pendfmu.virtual_rig import against_truth, read_truth

    truth = read_truth(folder)
    if truth is None or result is None:
        return []
    from pendfmu.components import rig_defaults

    rows = against_truth(result.estimates, truth)
    reference = rig_defaults()  # where a fit starts when no value is given
    lines = [f"against {folder / 'truth.json'} (a virtual rig's truth; the reference rig is where the fit "
             f"started):"]
    def line(r) -> str:
        error = f"{r.value / r.truth - 1:+.2%}" if r.truth != 0 else f"{r.value - r.truth:+.3g}"
        verdict = "no interval" if math.isnan(r.low) else \
            f"{'inside' if r.holds else 'OUTSIDE'} its 95 % interval"
        return (f"  {r.name:<10} reference {reference.get(r.name, float('nan')):<10.4g} truth {r.truth:<12.6g} "
                f"found {r.value:<12.6g} ({error}) {verdict}")

    lines += [line(r) for r in rows]
    judged = [r for r in rows if not math.isnan(r.low)]
    lines.append(f"  {sum(r.holds for r in judged)} of {len(judged)} intervals hold the truth"
                 + (f" ({len(rows) - len(judged)} estimates without an interval)" if len(judged) < len(rows) else ""))
    return lines


def _details(result) -> list[str]:
    """The notes and flags, printed with the summary: a file alone is not read."""
    lines = [f"note: {note}" for note in result.notes]
    lines += [f"flag {label}: {flag}" for label, estimate in result.estimates.items() for flag in estimate.flags
              if not any(w.endswith(f"{label}: {flag}") for w in result.warnings)]  # those print as warnings
    return lines
