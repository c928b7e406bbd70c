"""The demo of make demo: friction test (paper Fig. 3) and a pendulum free decay, with plots."""

from __future__ import annotations

import argparse

HELP = "run the demo and write CSV and PNG files"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--out", default="out/demo", help="output folder (default: out/demo)")


def run(args: argparse.Namespace) -> int:
    from pendfmu.demo import run_demo

    out = run_demo(args.out)
    print(f"demo results (CSV, PNG, report/index.html, exported FMUs) in {out}")
    return 0
