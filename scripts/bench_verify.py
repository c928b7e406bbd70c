"""Benchmark: the verification over a fit's bootstrap replicates (issue 27's done-when: for
100 replicates of a 20 s run, at most 2 minutes on the 2-core machine).

The fit is Getting started's (docs): `pendfmu rig --seed 4`, then `pendfmu fit all` with --replicates
100 (made once, kept in WORK; about 6 minutes on two cores). Then, timed: the design's
balance run of DURATION s on the identified model and on each replicate, compensation as
designed (verify.verify on all cores), as `pendfmu control` runs it. Prints the runs, the
seconds, the ratio to the 120 s budget and the replicates' success rate.

    python scripts/bench_verify.py [--work out/bench-verify] [--replicates 100] [--duration 20] [--workers 0]

Measured (2026-11-27, this 2-core machine): 101 balance runs of 20 s in 6.0 s, 0.05 of the
budget; the identified model and 97 of the 100 replicates met the requirements.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from pathlib import Path

BUDGET = 120.0  # s for 100 replicates


def fitted(work: Path, replicates: int) -> Path:
    """WORK/fit.json: the Getting-started rig's fit with `replicates` bootstrap replicates (made once)."""
    fit = work / f"fit-{replicates}.json"
    if not fit.exists():
        rig = work / "rec"
        if not rig.exists():
            subprocess.run([sys.executable, "-m", "pendfmu", "rig", "--seed", "4", "--out", str(rig)], check=True)
        subprocess.run([sys.executable, "-m", "pendfmu", "fit", "all", str(rig), "--out", str(fit),
                        "--replicates", str(replicates)], check=True)
    return fit


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--work", default="out/bench-verify")
    parser.add_argument("--replicates", type=int, default=100)
    parser.add_argument("--duration", type=float, default=20.0)
    parser.add_argument("--workers", type=int, default=0)
    args = parser.parse_args()

    from pendfmu.control.export import write_fmus
    from pendfmu.control.report import design_from, write_loop_ssp
    from pendfmu.control.verify import Verification, Requirements, parallel_runs, plan, replicate_rigs
    from pendfmu.fitting.result import read_result

    work = Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    result = read_result(fitted(work, args.replicates))
    options = argparse.Namespace(task="balance", sample_time=1e-3, current_limit=5.0, track=0.4, weights=[],
                                 no_compensation=False, dx=None, dphi=None)
    the_design, values, _ = design_from(result, options)
    write_fmus(the_design, work)
    ssp = write_loop_ssp(the_design, values, work)
    runs = plan(the_design, values, replicate_rigs(result), ssp, args.duration, both_compensations=False)
    start = time.perf_counter()
    outcomes = parallel_runs(runs, args.workers)
    seconds = time.perf_counter() - start
    checked = Verification(Requirements(), the_design.x_max, outcomes, seconds)
    (row,) = checked.summary()
    per_hundred = seconds * 100 / row["replicates"]
    print(f"{len(runs)} balance runs of {args.duration:g} s (the identified model and {row['replicates']} "
          f"replicates) in {seconds:.1f} s: {per_hundred:.1f} s per 100 replicates, {per_hundred / BUDGET:.2f} of "
          f"the {BUDGET:g} s budget")
    print(f"identified model meets the requirements: {row['identified']['meets']}; replicates meeting them: "
          f"{row['replicates_meeting']} of {row['replicates']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
