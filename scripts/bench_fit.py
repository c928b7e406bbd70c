"""Benchmark: `fit all` on the standard virtual-rig set, wall time and evaluations.

    python scripts/bench_fit.py [--seed N] [--workers N]

Prints one line per stage and the total, measured in this run (not a test: these
machines are shared and noisy, so the figures are printed, never asserted).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from pendfmu.identification import fit_all
from pendfmu.optimizer import GlobalOptions
from pendfmu.virtual_rig import write_experiments


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--workers", type=int, default=0, help="global-search processes (default: cores)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        start = time.perf_counter()
        write_experiments(folder, seed=args.seed)
        print(f"virtual rig: {time.perf_counter() - start:.1f} s")
        start = time.perf_counter()
        result = fit_all(folder, seed=args.seed, global_search=GlobalOptions(workers=args.workers), progress=False)
        wall = time.perf_counter() - start
    print(f"fit all: {wall:.1f} s wall, {result.nfev} simulations, {result.failures} failed, "
          f"{result.seconds:.1f} s in the optimizers")
    for name, errors in sorted(result.validation.items()):
        print(f"  predicted {name}: phi RMS {errors.get('phi_rms_steps', float('nan')):.2f} encoder steps")


if __name__ == "__main__":
    main()
