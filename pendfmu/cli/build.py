"""Compile the component FMUs (CurrentLoop, Cart, Pendulum, Controller).

They go to the FMU folder pendfmu itself loads them from (``fmus/`` in a source checkout,
the user cache for an installed pendfmu; ``PENDFMU_FMU_DIR`` overrides), or to ``--out``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

HELP = "compile the component FMUs (into fmus/ of a checkout, the user cache, or --out)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--force", action="store_true", help="rebuild even if up to date")
    parser.add_argument("--out", type=Path, metavar="DIR",
                        help="write the FMUs into DIR instead of pendfmu's own FMU folder")


def run(args: argparse.Namespace) -> int:
    from pendfmu.errors import UsageError
    from pendfmu.fmubuild import build_all

    if args.out is not None and args.out.exists() and not args.out.is_dir():
        raise UsageError(f"--out {args.out}: exists and is not a directory")
    for name, path in build_all(force=args.force, folder=args.out).items():
        print(f"{name}: {path}")
    return 0
