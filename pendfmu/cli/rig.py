"""The virtual rig: write the paper's experiments as recordings, with the truth beside.

By default the rig is not the reference rig (the user guide's model page): every identified
parameter is drawn from the seed around the reference values, so that a fit, which
starts from the reference values, has to find it. ``--reference`` records the
reference rig itself; ``--params`` a rig you describe. truth.json says which.
"""

from __future__ import annotations

import argparse

HELP = "write the paper's experiments as recordings from a simulated rig (truth.json beside)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--out", required=True, help="output folder")
    truth = parser.add_mutually_exclusive_group()
    truth.add_argument("--params", help="the rig's parameters file (absent names: the reference rig's values)")
    truth.add_argument("--reference", action="store_true", help="record the reference rig (the FMUs' defaults)")
    parser.add_argument("--seed", type=int, default=0,
                        help="seed of the drawn rig and of the sensor noise (default 0)")


def run(args: argparse.Namespace) -> int:
    from pendfmu.cli.outputs import check_output_folder
    from pendfmu.parameters import read_parameters
    from pendfmu.virtual_rig import FACTOR, draw_truth, standard_experiments, write_experiments

    check_output_folder(args.out, "--out")
    if args.params:
        truth, about = read_parameters(args.params), {"described": f"the reference rig with {args.params}"}
        experiments = None
    elif args.reference:
        truth, about, experiments = {}, {"described": "the reference rig"}, None
    else:
        truth, angle = draw_truth(args.seed)
        experiments = standard_experiments(abs(angle))
        about = {"described": f"drawn with seed {args.seed}: each identified parameter x{FACTOR[0]}-{FACTOR[1]} of the "
                          f"reference (pendfmu.virtual_rig.draw_truth); free decay released {abs(angle):.3f} rad "
                          f"from hanging"}
    for path in write_experiments(args.out, truth, seed=args.seed, experiments=experiments, **about):
        print(path)
    print(f"truth: {about['described']}")
    return 0
