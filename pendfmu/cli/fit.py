"""Fit a model's parameters to recordings: a stage of the paper's rig, all stages in
order, or a user's FMU or SSP system.

    pendfmu fit current|cart|pendulum REC.csv [REC2.csv ...] [--params P.json] --out P2.json
    pendfmu fit all DIR [--params P.json] --out P2.json
    pendfmu fit --fmu X.fmu REC.csv [...] --free NAME ... [--drive INPUT[=COLUMN] ...]
                [--match OUTPUT[=COLUMN] ...] [--params P.json] --out R.json
    pendfmu fit --system S.ssp REC.csv [...] --free NAME ... (as --fmu)

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
    parser.add_argument("--seed", type=int, default=0, help="seed of the global search (default 0)")
    parser.add_argument("--free", nargs="+", action="extend", default=[], metavar="NAME", help="fit these too")
    parser.add_argument("--fix", nargs="+", action="extend", default=[], metavar="NAME", help="keep these at their given values")
    parser.add_argument("--bounds", nargs="+", action="extend", default=[], metavar="NAME=LOW:HIGH", help="search bounds")
    parser.add_argument("--drive", nargs="+", action="extend", metavar="INPUT[=COLUMN]",
                        help="a stage: the recorded signal that drives it (I_c, I, u or a); a model: its inputs driven "
                             "by recorded columns (default: each input with a column of its name)")
    parser.add_argument("--match", nargs="+", action="extend", metavar="OUTPUT[=COLUMN]",
                        help="a model: its outputs compared with recorded columns (default: each output with a "
                             "column of its name)")
    parser.add_argument("--initial", nargs="+", action="extend", default=[], metavar="SIGNAL=PARAMETER",
                        help="a model: the parameter a sidecar's initial value of SIGNAL sets (default: an output "
                             "x sets a parameter x0 where the model has one)")
    parser.add_argument("--interpolation", choices=("hold", "linear"), default="hold",
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
    parser.add_argument("--start", choices=("estimated", "measured"), default="estimated",
                        help="initial states of a window or segment that starts late: estimated (default) or taken "
                             "from its first readings")
    parser.add_argument("--cost", choices=("plain", "quantized"), default="plain",
                        help="residuals: plain least squares, or zero inside each reading's quantization step")
    parser.add_argument("--no-global", action="store_true", help="skip the global search (local refinement only)")
    parser.add_argument("--workers", type=int, default=0, help="processes for the global search (default: cores)")
    parser.add_argument("--scheduler", metavar="ADDRESS",
                        help="evaluate the global search on a Dask cluster (e.g. tcp://10.0.0.5:8786)")
    parser.add_argument("--checkpoint", help="checkpoint file written on Ctrl-C (default: OUT with .checkpoint)")
    parser.add_argument("--resume", action="store_true",
                        help="continue an interrupted fit from its checkpoint (same command otherwise)")
    parser.add_argument("--uncertainty", choices=("bootstrap", "jacobian"), default="bootstrap",
                        help="intervals: parametric bootstrap through the sensor model (calibrated, default) or "
                             "the Jacobian at the optimum (fast, far too narrow on quantized recordings)")
    parser.add_argument("--replicates", type=int, default=24, metavar="N",
                        help="bootstrap replicates (default 24; each is one local refit, run on the workers)")
    parser.add_argument("--strict", action="store_true",
                        help="exit with code 3 on any warning (suspicious data: before fitting; suspicious "
                             "result: after writing it)")


def _bounds(items: list[str]) -> dict[str, tuple[float, float]]:
    from pendfmu.errors import UsageError

    bounds = {}
    for item in items:
        name, _, span = item.partition("=")
        low, _, high = span.partition(":")
        try:
            bounds[name] = (float(low), float(high))
        except ValueError:
            raise UsageError(f"--bounds {item!r}: expected NAME=LOW:HIGH with numbers") from None
        if not bounds[name][0] < bounds[name][1]:
            raise UsageError(f"--bounds {item!r}: LOW must be below HIGH")
    return bounds


def run(args: argparse.Namespace) -> int:
    import sys
    from pathlib import Path

    from pendfmu.fitting.checkpoint import Checkpoint, Interrupted, fingerprint
    from pendfmu.cli.outputs import check_output_file, check_output_folder
    from pendfmu.errors import EXIT_SUSPICIOUS, Suspicious, UsageError
    from pendfmu.fitting.identification import fit
    from pendfmu.fitting.sequence import fit_all
    from pendfmu.fitting.ripple import fit_current
    from pendfmu.fitting.models import checked_values
    from pendfmu.fitting.optimizer import GlobalOptions
    from pendfmu.fitting.provenance import with_command
    from pendfmu.parameters import read_parameters, write_parameters
    from pendfmu.recording.windows import parse_window

    check_output_file(args.out, "--out")
    if args.report:
        check_output_folder(args.report, "--report")
    path = check_output_file(args.checkpoint or f"{args.out}.checkpoint", "--checkpoint")
    model = _model_and_recordings(args)
    if args.stage == "all" and len(args.recordings) != 1:
        raise UsageError("fit all takes one folder of recordings")
    if model is None:
        params = read_parameters(args.params) if args.params else {}
    else:
        params = read_parameters(args.params, lambda values, where: checked_values(model, values, where)) \
            if args.params else {}
    options = GlobalOptions(enabled=not args.no_global, workers=args.workers, scheduler=args.scheduler)
    bounds = _bounds(args.bounds)
    windows = [parse_window(w) for w in args.window]
    if args.stage == "all" and (windows or args.segment or args.per_recording):
        raise UsageError("fit all fits each stage's recordings whole: --window, --segment and --per-recording "
                         "are for one stage or model")
    files = sorted(Path(args.recordings[0]).iterdir()) if args.stage == "all" and Path(args.recordings[0]).is_dir() \
        else [Path(r) for r in args.recordings]
    files = [f for f in files if f.suffix.lower() in (".csv", ".mat") and f.is_file()]
    key = fingerprint(args.stage, sorted(params.items()), args.seed, args.cost, args.free, args.fix,
                      sorted(bounds.items()), args.drive, args.match, args.initial, args.interpolation, args.no_global,
                      args.per_recording, windows, args.segment, args.start,
                      files=files + ([Path(args.fmu or args.system)] if model is not None else []))
    checkpoint = Checkpoint.load(path, key) if args.resume else Checkpoint(path, key)
    printed: list[str] = []

    def warn(message: str) -> None:
        printed.append(message)
        print(f"warning: {message}", file=sys.stderr, flush=True)

    if args.replicates < 8:
        raise UsageError(f"--replicates {args.replicates}: at least 8 (the interval's quantile needs them)")
    common = dict(seed=args.seed, cost=args.cost, global_search=options, checkpoint=checkpoint, warn=warn,
                  strict=args.strict, uncertainty=args.uncertainty, replicates=args.replicates)
    parts = dict(per_recording=args.per_recording, windows=windows, segment=args.segment, start=args.start)
    try:
        if model is not None:
            result = fit(model, args.recordings, params, free=args.free, fix=args.fix, bounds=bounds,
                         drive=args.drive, match=args.match, initial=_pairs(args.initial, "--initial"),
                         interpolation=args.interpolation, **parts, **common)
        elif args.stage == "all":
            result = fit_all(args.recordings[0], params, **common)
        else:
            common.update(fix=args.fix, bounds=bounds, drive=_stage_drive(args))
            if args.stage == "current" and not args.free and not any((windows, args.segment, args.per_recording)):
                result = fit_current(args.recordings, params, **common)
            else:
                result = fit(args.stage, args.recordings, params, free=args.free, **parts, **common)
    except Suspicious:
        print("pendfmu fit: --strict: not fitted, the recordings look wrong (warnings above)", file=sys.stderr)
        return EXIT_SUSPICIOUS
    except Interrupted as stop:
        write_parameters(stop.parameters, args.out, interrupted=f"{stop} (best values so far)")
        checkpoint.save()
        print(f"interrupted: best values so far in {args.out}; resume with the same command and --resume "
              f"(checkpoint {path})")
        return 130
    result.provenance = with_command(result.provenance, getattr(args, "command_line", None))
    if model is not None:  # the file, which the loaded Model does not carry: `pendfmu export` exports for it
        result.model = str(args.fmu or args.system)
    if not result.estimates:  # the library evaluates the cost at fixed values; a command that fits nothing is a slip
        raise UsageError(f"--fix {' '.join(args.fix)} leaves nothing to fit (and no recording estimates its own "
                         f"values); nothing written to {args.out}")
    result.write_json(args.out)
    if path.exists():
        path.unlink()  # the fit is complete: its checkpoint has served
    print(f"{args.out}: {_summary(result)}")
    for line in _details(result):
        print(line)
    if args.stage == "all":
        for line in _truth_lines(Path(args.recordings[0]), result):
            print(line)
    if args.report:
        print(f"report: {result.write_report(args.report)}")
    late = [w for w in result.warnings if not any(w.endswith(p) for p in printed)]
    for message in late:
        print(f"warning: {message}", file=sys.stderr)
    if result.warnings:
        print(f"{len(result.warnings)} warning(s); they are also in {args.out} (fit.warnings)", file=sys.stderr)
    return EXIT_SUSPICIOUS if args.strict and result.warnings else 0  # the result is written either way


def _model_and_recordings(args: argparse.Namespace):
    """Split the positionals: a stage and recordings, or (with --fmu/--system) recordings;
    the user's Model, or None for a stage."""
    from pendfmu.errors import UsageError
    from pendfmu.fitting.models import load_model

    if args.fmu or args.system:
        args.stage, args.recordings = None, list(args.items)
        if args.items[0] in STAGE_NAMES:
            raise UsageError(f"--{'fmu' if args.fmu else 'system'} fits that model: leave out the stage "
                             f"{args.items[0]!r}")
        return load_model(args.fmu or args.system)
    args.stage, args.recordings = args.items[0], list(args.items[1:])
    if args.stage not in STAGE_NAMES:
        from pendfmu.suggest import did_you_mean

        raise UsageError(f"{args.stage!r} is not a stage{did_you_mean(args.stage, STAGE_NAMES)} "
                         f"({', '.join(STAGE_NAMES)}); to fit your own model give "
                         f"--fmu X.fmu or --system S.ssp")
    if not args.recordings:
        raise UsageError(f"fit {args.stage}: give its recordings")
    for option in ("match", "initial"):
        if getattr(args, option):
            raise UsageError(f"--{option} is for a model (--fmu, --system); a stage matches its own signals")
    return None


def _stage_drive(args: argparse.Namespace) -> str | None:
    """A stage's --drive: one recorded column, I_c, I, u or a."""
    from pendfmu.errors import UsageError

    if not args.drive:
        return None
    if len(args.drive) != 1 or args.drive[0] not in ("I_c", "I", "u", "a"):
        raise UsageError(f"--drive {' '.join(args.drive)}: a stage is driven by one recorded signal, I_c, I, u or a")
    return args.drive[0]


def _pairs(items: list[str], option: str) -> dict[str, str]:
    from pendfmu.errors import UsageError

    pairs = {}
    for item in items:
        name, _, value = item.partition("=")
        if not (name and value):
            raise UsageError(f"{option} {item!r}: expected NAME=VALUE")
        pairs[name] = value
    return pairs


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
    return "wrote the result; estimates:\n  " + "\n  ".join(parts)


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
    lines = [f"against {folder / 'truth.json'} (a virtual rig's truth; MODEL.md's reference is where the fit "
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
