"""What the intervals cost on real recordings, against the fit itself (issue 25, item 6).

    python scripts/interval_cost.py [--cases NAME ...] [--seed 0] [--json out/interval-cost.json]

Each data set of ``tests/realdata_cases.py`` that is present (../shared/realdata; the
recordings go to a temporary folder and are removed: they are licensed for internal
testing only) is fitted once through ``pendfmu fit`` with the default intervals: the
bootstrap on a fit as good as its sensors; the sandwich, widened by the validation's
halves, on one the model cannot follow (adequacy.py). Printed per data set, all measured
in this one run: the search's seconds (``fit.seconds``: the global search, its restarts
and the local refinement), the intervals' seconds (``fit.uncertainty.seconds``), the
validation's (``fit.assessment.windows.seconds``: the halves refitted), and the ratio of
the last two to the first. The goal is a ratio of at most 3: intervals fast enough to
leave on.
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

import realdata_cases as cases  # noqa: E402

GOAL = 3.0  # the intervals may take at most this many times the search


def cost(document: dict) -> dict:
    """The seconds of the search, the intervals and the validation, from a result file."""
    fit = document["fit"]
    uncertainty = fit.get("uncertainty") or {}
    windows = (fit.get("assessment") or {}).get("windows") or {}
    search, intervals, validation = fit["seconds"], uncertainty.get("seconds", 0.0), windows.get("seconds", 0.0)
    return {"search": search, "intervals": intervals, "validation": validation,
            "method": uncertainty.get("method", "?"), "verdict": (fit.get("assessment") or {}).get("verdict", "?"),
            "ratio": (intervals + validation) / search if search > 0 else float("nan")}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", nargs="+", default=list(cases.CASES), choices=list(cases.CASES))
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", type=Path, help="write the figures here (keep it out of git)")
    args = parser.parse_args(argv)
    work = Path(tempfile.mkdtemp(prefix="interval-cost-"))
    rows: dict[str, dict] = {}
    try:
        for name in args.cases:
            case = cases.CASES[name]
            if not case.available:
                print(f"{name}: skipped, real data absent")
                continue
            run = cases.run_fit(case.prepare(work / name), work / name / "result.json", args.seed, name)
            if not run.written:
                print(f"{name}: no result (exit {run.exit_code}): {run.stderr.strip().splitlines()[-1:]}")
                continue
            rows[name] = cost(run.document)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    print(f"\n{'data set':28s} {'verdict':18s} {'intervals by':22s} {'search s':>9s} {'intervals s':>12s} "
          f"{'validation s':>13s} {'ratio':>6s}")
    for name, row in rows.items():
        print(f"{name:28s} {row['verdict']:18s} {row['method']:22s} {row['search']:9.1f} {row['intervals']:12.1f} "
              f"{row['validation']:13.1f} {row['ratio']:6.2f}")
    worst = max((row["ratio"] for row in rows.values()), default=float("nan"))
    print(f"\nintervals and validation at most {GOAL:g} times the search: {'PASS' if worst <= GOAL else 'FAIL'} "
          f"(worst {worst:.2f})")
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1))
    return 0 if worst <= GOAL else 1


if __name__ == "__main__":
    sys.exit(main())
