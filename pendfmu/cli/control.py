"""From a fit to a controller: design balance and swing-up from a fit result, write it as an FMU.

    pendfmu control RESULT.json --out DIR [--task balance|swing-up]
        [--sample-time 1e-3] [--current-limit 5] [--track 0.4]
        [--weights x=0.05 phi=0.01 ...] [--no-compensation]
        [--dx M] [--dphi RAD]

Writes DIR/RigController.fmu (FMI 2.0) and DIR/fmi3/RigController.fmu (FMI 3.0), Co-Simulation
and Model Exchange, whose parameters are the design (retune them without compiling),
DIR/ClosedLoop.ssp (the identified rig's FMUs and the controller, sampled at T_s), and
DIR/design.json and DIR/report.md: the model it was designed on, the gains and the closed
loop's poles. The design: a discrete LQR about upright (on the self-locking screw's cart as
an acceleration-commanded axis, else on the coupled model), a Kalman filter from the
encoders' resolutions, an energy swing-up and the identified friction compensated.
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
    parser.add_argument("--dx", type=float, help="cart encoder resolution [m] (default: the sidecars, else MODEL.md)")
    parser.add_argument("--dphi", type=float, help="pendulum encoder resolution [rad] (default: as --dx)")


def run(args: argparse.Namespace) -> int:
    from pathlib import Path

    from pendfmu.control.report import design_from_result, write_outputs

    the_design, values, notes = design_from_result(args.result, args)
    for path in write_outputs(the_design, values, notes, Path(args.out)):
        print(path)
    return 0
