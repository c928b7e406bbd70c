"""The ``pendfmu`` command line: ``main(argv)`` so tests can call it in-process.

Exit codes: 0 success, 2 bad input (a one-line message, no traceback), 1 internal failure.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence


class UsageError(Exception):
    """Bad input from the user: reported in one line, exit code 2."""


def _cmd_build(args: argparse.Namespace) -> int:
    from pendfmu.fmubuild import build_all

    for name, path in build_all(force=args.force).items():
        print(f"{name}: {path}")
    return 0


def _cmd_demo(args: argparse.Namespace) -> int:
    from pendfmu.demo import run_demo

    out = run_demo(args.out)
    print(f"demo results (CSV and PNG) in {out}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="pendfmu", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)

    build = sub.add_parser("build", help="compile the component FMUs into fmus/")
    build.add_argument("--force", action="store_true", help="rebuild even if up to date")
    build.set_defaults(func=_cmd_build)

    demo = sub.add_parser("demo", help="friction test (paper Fig. 3) and pendulum decay, with plots")
    demo.add_argument("--out", default="out/demo", help="output folder (default: out/demo)")
    demo.set_defaults(func=_cmd_demo)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except UsageError as error:
        print(f"pendfmu: error: {error}", file=sys.stderr)
        return 2
