"""The virtual rig: write the paper's experiments as recordings, with the truth beside."""

from __future__ import annotations

import argparse

HELP = "write the paper's experiments as recordings from a simulated rig"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--out", required=True, help="output folder")
    parser.add_argument("--params", help="truth parameters file (default: MODEL.md's reference rig)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the sensor noise (default 0)")


def run(args: argparse.Namespace) -> int:
    from pendfmu.parameters import read_parameters
    from pendfmu.virtual_rig import write_experiments

    truth = read_parameters(args.params) if args.params else {}
    for path in write_experiments(args.out, truth, seed=args.seed):
        print(path)
    return 0
