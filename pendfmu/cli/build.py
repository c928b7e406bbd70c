"""Compile the component FMUs (CurrentLoop, Cart, Pendulum, Controller): FMI 2.0 as
<Name>.fmu, FMI 3.0 as fmi3/<Name>.fmu.

They go to the FMU folder pendfmu itself loads them from (``fmus/`` in a source checkout,
the user cache for an installed pendfmu; ``PENDFMU_FMU_DIR`` overrides), or to ``--out``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

HELP = "compile the component FMUs, FMI 2.0 and 3.0 (into fmus/ of a checkout, the user cache, or --out)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--force", action="store_true", help="rebuild even if up to date")
    parser.add_argument("--out", type=Path, metavar="DIR",
                        help="write the FMUs into DIR instead of pendfmu's own FMU folder")
    parser.add_argument("--fmi", type=int, choices=(2, 3), action="append", dest="fmi_versions",
                        help="build only this FMI version (repeatable; default: both)")


def run(args: argparse.Namespace) -> int:
    from pendfmu.cli.outputs import check_output_folder
    from pendfmu.fmubuild import build_all

    if args.out is not None:
        check_output_folder(args.out, "--out")
    for version in sorted(set(args.fmi_versions or (2, 3))):
        for name, path in build_all(force=args.force, folder=args.out, fmi_version=version).items():
            print(f"{name}: {path}")
    return 0
