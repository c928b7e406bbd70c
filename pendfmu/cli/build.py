"""Compile the component FMUs (CurrentLoop, Cart, Pendulum, Controller) into fmus/."""

from __future__ import annotations

import argparse

HELP = "compile the component FMUs into fmus/"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--force", action="store_true", help="rebuild even if up to date")


def run(args: argparse.Namespace) -> int:
    from pendfmu.fmubuild import build_all

    for name, path in build_all(force=args.force).items():
        print(f"{name}: {path}")
    return 0
