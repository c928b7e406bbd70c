"""Benchmark: `fit all` on the standard virtual-rig set, wall time and evaluations, and
what its calibrated intervals (the bootstrap) cost against the fit itself.

    python scripts/bench_fit.py [--seed N] [--workers N] [--uncertainty bootstrap|jacobian]

Prints one line per stage and the total, measured in this run (not a test: these
machines are shared and noisy, so the figures are printed, never asserted).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from pendfmu.fitting.identification import fit
from pendfmu.fitting.optimizer import GlobalOptions
from pendfmu.virtual_rig import write_experiments


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--workers", type=int, default=0, help="global-search processes (default: cores)")
    parser.add_argument("--uncertainty", default="bootstrap", choices=("bootstrap", "jacobian"))
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        start = time.perf_counter()
        write_experiments(folder, seed=args.seed)
        print(f"virtual rig: {time.perf_counter() - start:.1f} s")
        start = time.perf_counter()
        result = fit("all", folder, seed=args.seed, global_search=GlobalOptions(workers=args.workers), progress=False,
                     uncertainty=args.uncertainty)
        wall = time.perf_counter() - start
    intervals = sum(u.get("seconds", 0.0) for u in result.uncertainty.values())
    print(f"fit all: {wall:.1f} s wall, {result.nfev} simulations, {result.failures} failed, "
          f"{result.seconds:.1f} s in the optimizers")
    print(f"intervals ({args.uncertainty}): {intervals:.1f} s, {intervals / (wall - intervals):.2f}x the fit itself "
          f"({wall - intervals:.1f} s); per stage: "
          + ", ".join(f"{stage} {u.get('seconds', 0.0):.1f} s" for stage, u in result.uncertainty.items()))
    for name, errors in sorted(result.validation.items()):
        print(f"  predicted {name}: phi RMS {errors.get('phi_rms_steps', float('nan')):.2f} encoder steps")


if __name__ == "__main__":
    main()
