"""From a fit to a controller: design balance and swing-up from a fit result, write it as an FMU.

    pendfmu control RESULT.json --out DIR [--task balance|swing-up]
        [--sample-time 1e-3] [--current-limit 5] [--track 0.4]
        [--weights x=0.05 phi=0.01 ...] [--no-compensation]
        [--dx M] [--dphi RAD] [--duration 20] [--no-verify]
        [--workers N] [--scheduler ADDRESS]
        [--require capture=12 phi=1 x=0.01 I=1 track=0.4] [--tune]

Writes DIR/RigController.fmu (FMI 2.0) and DIR/fmi3/RigController.fmu (FMI 3.0), Co-Simulation
and Model Exchange, whose parameters are the design (retune them without compiling),
DIR/ClosedLoop.ssp (the identified rig's FMUs and the controller, sampled at T_s), and
DIR/design.json and DIR/report.md: the model it was designed on, the gains and the closed
loop's poles. The design: a discrete LQR about upright (on the self-locking screw's cart as
an acceleration-commanded axis, else on the coupled model), a Kalman filter from the
encoders' resolutions, an energy swing-up and the identified friction compensated.

Then the verification before the rig (pendfmu/control/verify.py): the closed loop co-simulated
on the identified model and on every bootstrap replicate the result holds, balance (and
swing-up) for --duration s, compensation as designed and switched, the encoders quantized;
each run judged by the issue's requirements. DIR/verification.json has every run's figures,
DIR/verification.png the runs, and report.md the table with the replicates' success rate.
--require sets the requirements (capture [s], phi [encoder steps], x [m] and I [A] RMS over
the last 10 s, track [m]); --tune first tunes the LQR weights by simulation until every run
(the identified model and each replicate) meets them (control/tuning.py), and designs with those.
"""

from __future__ import annotations

import argparse

HELP = "design a balance and swing-up controller from a fit result and write it as an FMU"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("result", help="a result file of pendfmu fit (all stages, or one with the cart and pendulum)")
    parser.add_argument("--out", required=True, help="output folder")
    parser.add_argument("--task", choices=("balance", "swing-up"), default="balance",
                        help="balance about upright only, or swing up from anywhere and balance (default balance)")
    parser.add_argument("--sample-time", type=float, default=1e-3, help="sample period T_s [s] (default 1e-3)")
    parser.add_argument("--current-limit", type=float, default=5.0, help="current limit [A] (default 5)")
    parser.add_argument("--track", type=float, default=0.4, help="track half-length [m] (default 0.4)")
    parser.add_argument("--weights", nargs="+", default=[], metavar="NAME=SCALE",
                        help="LQR weights as tolerated scales: x [m], phi [rad], v [m/s], w [rad/s], a [m/s^2]")
    parser.add_argument("--no-compensation", action="store_true", help="do not compensate the cart's friction")
    parser.add_argument("--dx", type=float, help="cart encoder resolution [m] (default: the sidecars, else the paper's 1024-count encoder)")
    parser.add_argument("--dphi", type=float, help="pendulum encoder resolution [rad] (default: as --dx)")
    parser.add_argument("--duration", type=float, default=20.0,
                        help="length of each verification run [s] (default 20; the figures are over its last 10 s)")
    parser.add_argument("--no-verify", action="store_true", help="write the design without the closed-loop runs")
    parser.add_argument("--workers", type=int, default=0,
                        help="worker processes for the verification's runs (default: one per core)")
    parser.add_argument("--scheduler", metavar="ADDRESS", help="run the verification on this Dask scheduler's workers")
    parser.add_argument("--require", nargs="+", default=[], metavar="NAME=VALUE",
                        help="requirements: capture [s], phi [encoder steps], x [m] and I [A] RMS over the last "
                             "10 s, track [m] (default: capture=12 phi=1 x=0.01 I=1, the --track)")
    parser.add_argument("--tune", action="store_true",
                        help="tune the LQR weights by simulation until the identified model and every replicate "
                             "meet the requirements (from --weights)")


def run(args: argparse.Namespace) -> int:
    from pathlib import Path

    import dataclasses

    from pendfmu.control.design import design
    from pendfmu.control.fromfit import sidecar_resolutions
    from pendfmu.control.report import (design_from, options_from, requirements_from, write_loop_ssp, write_outputs,
                                        write_verification)
    from pendfmu.control.tuning import tune
    from pendfmu.control.verify import replicate_rigs, verify
    from pendfmu.errors import OptionError
    from pendfmu.fitting.result import read_result

    if not (args.duration > 1e3 * args.sample_time and args.duration <= 3600):
        raise OptionError("duration", f"{args.duration} s: more than a thousand samples and at most an hour")
    if args.workers < 0:
        raise OptionError("workers", f"{args.workers}: 0 (one per core) or more")
    if args.tune and args.no_verify:
        raise OptionError("tune", "tunes by the verification's runs; --no-verify switches them off")
    requirements = requirements_from(args.require)
    result = read_result(args.result)
    the_design, values, notes = design_from(result, args)
    out = Path(args.out)
    replicates = replicate_rigs(result)
    tuning = None
    if args.tune:
        out.mkdir(parents=True, exist_ok=True)
        ssp = write_loop_ssp(the_design, values, out, built=False)  # the designs tried reach it as values
        options = options_from(args, sidecar_resolutions(result))
        tuning = tune(values, options, replicates, ssp, args.duration, requirements, args.workers, args.scheduler,
                      say=lambda line: print(line, flush=True))
        the_design = design(values, dataclasses.replace(options, weights=tuning.weights))
        weights = tuning.weights
        notes.append(f"LQR weights tuned to the requirements by simulation ({len(tuning.tried)} designs tried): "
                     f"{weights.text()} (--weights designs with them again, without tuning)")
    else:
        weights = options_from(args, sidecar_resolutions(result)).weights
        notes.append(f"LQR weights: {weights.text()}")
    paths = write_outputs(the_design, values, notes, out, weights)
    if not args.no_verify:
        which = (f"the identified model and {len(replicates)} bootstrap replicates" if replicates else
                 "the identified model only (the result holds no bootstrap replicates)")
        print(f"verifying in closed loop: {which}, {args.duration:g} s each", flush=True)
        checked = verify(the_design, values, replicates, out / "ClosedLoop.ssp", args.duration, requirements,
                         workers=args.workers, scheduler=args.scheduler)
        paths += write_verification(checked, the_design, notes, out)
        for row in checked.summary():
            print(f"  {row['task']}, compensation {'on' if row['compensation'] else 'off'}: the identified model "
                  f"{'meets' if row['identified']['meets'] else 'MISSES'} the requirements")
            if row["replicates"]:
                print(f"    and {row['replicates_meeting']} of its {row['replicates']} bootstrap replicates")
    for path in dict.fromkeys(paths):  # report.md is written again with the verification
        print(path)
    return 0
