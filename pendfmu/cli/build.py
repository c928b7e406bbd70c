"""Compile the component FMUs (CurrentLoop, Cart, Pendulum, Controller): FMI 2.0 into fmus/,
FMI 3.0 into fmus/fmi3/."""

from __future__ import annotations

import argparse

HELP = "compile the component FMUs (FMI 2.0 into fmus/, FMI 3.0 into fmus/fmi3/)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--force", action="store_true", help="rebuild even if up to date")
    parser.add_argument("--fmi", type=int, choices=(2, 3), action="append", dest="fmi_versions",
                        help="build only this FMI version (repeatable; default: both)")


def run(args: argparse.Namespace) -> int:
    from pendfmu.fmubuild import build_all

    for version in sorted(set(args.fmi_versions or (2, 3))):
        for name, path in build_all(force=args.force, fmi_version=version).items():
            print(f"{name}: {path}")
    return 0
