"""Fit every real data set through the command line for several seeds, and judge issue 12.

    python scripts/realdata_fits.py [--seeds 0 1 2 3 4] [--cases NAME ...] [--replicates N]
                                    [--cli='--uncertainty jacobian'] [--work out/realdata-fits]
                                    [--json out/realdata-fits.json]

For each data set of ``tests/realdata_cases.py`` (conversions in ``examples/realdata/*/convert.py``) the
recordings are written into a temporary work folder (default ``out/realdata-fits``, which
git ignores: the recordings are derived from data licensed for internal testing only and
must never be committed), then ``pendfmu fit STAGE ... --seed S`` runs in-process through
``pendfmu.cli.main`` for every seed. Printed per data set and seed: the exit code, whether
the result file exists, the seconds, every estimate with its interval, method and flags,
the warnings and notes. Then a one-line verdict per criterion:

1. every fit ends with a result file (issue 12), and none with an internal failure (exit 1);
2. every parameter reported as a set (method "bounded", or flagged at a search bound)
   reports the same set for every seed (issue 12), by realdata_cases.same_set: the same
   method, value and ends within 1 % relative (its docstring says why); sets that differ
   beyond the four digits the console prints (1e-3) are listed as information;
3. every interval lies inside its parameter's physical range and contains its value;
4. (information) point estimates whose spread over the seeds exceeds their narrowest
   interval's width: a seed dependence the intervals do not cover.

The exit status is 0 when criteria 1-3 hold, 1 otherwise. ``--json`` keeps the figures.
"""

from __future__ import annotations

import argparse
import json
import math
import shlex
import shutil
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

import realdata_cases as cases  # noqa: E402
import realdata_rigs as rigs  # noqa: E402


def interval_text(ci95) -> str:
    if ci95 is None:
        return "no interval"
    low, high = (-math.inf if ci95[0] is None else ci95[0]), (math.inf if ci95[1] is None else ci95[1])
    return f"[{low:.4g}, {high:.4g}]"


def print_run(run: cases.Run) -> None:
    print(f"  seed {run.seed}: exit {run.exit_code}, result file {'written' if run.written else 'MISSING'}, "
          f"{run.seconds:.1f} s")
    if not run.written:
        for line in run.stderr.strip().splitlines()[-3:]:
            print(f"    stderr: {line}")
        return
    document = run.document
    for label, (value, ci95, method) in cases.estimates(document).items():
        print(f"    {label:6s} = {value:<12.6g} 95 % {interval_text(ci95):28s} {method or '(initial state)'}")
    for label, flags in document["flags"].items():
        for flag in flags:
            print(f"    flag {label}: {flag}")
    for warning in document["fit"]["warnings"]:
        print(f"    warning: {warning}")
    for note in document["fit"]["notes"]:
        print(f"    note: {note}")
    print(f"    cost {document['fit']['cost']:.6g}, nrmse {document['fit']['nrmse']}, "
          f"{document['fit']['nfev']} simulations")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3, 4])
    parser.add_argument("--cases", nargs="+", default=list(cases.CASES), choices=list(cases.CASES))
    parser.add_argument("--replicates", type=int, help="bootstrap replicates (default: the CLI's)")
    parser.add_argument("--cli", default="", metavar="OPTIONS",
                        help="more options for every fit, in one string (e.g. --cli='--uncertainty jacobian')")
    parser.add_argument("--work", type=Path, default=ROOT / "out" / "realdata-fits")
    parser.add_argument("--json", type=Path, help="write the figures here (keep it out of git)")
    parser.add_argument("--keep", action="store_true", help="keep the work folder (derived data: never commit it)")
    parser.add_argument("--verdicts-from", type=Path, metavar="JSON",
                        help="judge the runs a --json file kept, without fitting again")
    args = parser.parse_args(argv)
    if args.verdicts_from:
        return verdicts(load_runs(args.verdicts_from), None)
    extra = (["--replicates", str(args.replicates)] if args.replicates else []) + shlex.split(args.cli)

    runs: dict[str, list[cases.Run]] = {}
    try:
        for name in args.cases:
            case = cases.CASES[name]
            print(f"\n== {name} ({case.stage} stage)")
            if not case.available:
                print(f"  skipped: real data absent ({', '.join(map(str, case.sources))})")
                continue
            arguments = case.prepare(args.work / name)
            print(f"  pendfmu {' '.join(a if '/' not in a else Path(a).name for a in arguments)} "
                  f"--seed S {' '.join(extra)}")
            runs[name] = []
            for seed in args.seeds:
                run = cases.run_fit(arguments, args.work / name / f"result-{seed}.json", seed, name, extra)
                runs[name].append(run)
                print_run(run)
        for name, reason in rigs.SKIPPED.items():
            print(f"\n== {name}: {reason}")
    finally:
        if not args.keep:
            shutil.rmtree(args.work, ignore_errors=True)
    return verdicts(runs, args.json)


def load_runs(path: Path) -> dict[str, list[cases.Run]]:
    kept = json.loads(path.read_text())
    return {name: [cases.Run(name, r["seed"], r["exit"], path, r["seconds"], "", r["stderr"], r["result"])
                   for r in rs] for name, rs in kept.items()}


def verdicts(runs: dict[str, list[cases.Run]], json_path: Path | None) -> int:
    every = [r for rs in runs.values() for r in rs]
    missing = [f"{r.case} seed {r.seed} (exit {r.exit_code})" for r in every if not r.written]
    internal = [f"{r.case} seed {r.seed}" for r in every if r.exit_code == 1]
    print(f"\n== sets across seeds (method, value, ends; the same within {cases.SET_TOLERANCE:g} relative, "
          f"identical as printed within {cases.PRINTED_PRECISION:g})")
    differing, printed = [], []
    for name, rs in runs.items():
        exact = cases.set_agreement(rs, cases.PRINTED_PRECISION)
        for label, (same, sets) in cases.set_agreement(rs).items():
            shown = "; ".join(f"s{r.seed}: {s[0] or 'initial state'} {s[1]:.5g} [{s[2]:.5g}, {s[3]:.5g}]"
                              for r, s in zip([r for r in rs if r.written], sets))
            verdict = ("identical" if exact[label][0] else "same within 1 %") if same else "DIFFERENT"
            print(f"  {name} {label}: {verdict} -- {shown}")
            if not same:
                differing.append(f"{name} {label}")
            elif not exact[label][0]:
                printed.append(f"{name} {label}")
    outside = [f"{r.case} seed {r.seed}: {p}" for r in every if r.written for p in cases.interval_problems(r.document)]
    spread = []
    print("\n== point estimates across seeds (spread of the values against the narrowest 95 % interval)")
    for name, rs in runs.items():
        for label, (values, width) in cases.point_spread(rs).items():
            print(f"  {name} {label}: spread {values:.4g}, narrowest interval width {width:.4g}")
            if values > width:
                spread.append(f"{name} {label}")

    print("\n== verdicts")
    total = len(every)
    print(f"result file after every fit: {'PASS' if not missing else 'FAIL'} ({total - len(missing)} of {total}"
          f"{'; missing: ' + ', '.join(missing) if missing else ''})")
    print(f"no internal failure (exit 1): {'PASS' if not internal else 'FAIL'}"
          f"{' (' + ', '.join(internal) + ')' if internal else ''}")
    print(f"same set for every seed (within {cases.SET_TOLERANCE:g}): {'PASS' if not differing else 'FAIL'}"
          f"{' (different: ' + ', '.join(differing) + ')' if differing else ''}")
    print(f"sets identical as printed (within {cases.PRINTED_PRECISION:g}, information): "
          f"{'yes' if not (printed or differing) else 'no: ' + ', '.join(differing + printed)}")
    print(f"intervals inside physical ranges: {'PASS' if not outside else 'FAIL'}"
          f"{' (' + '; '.join(outside) + ')' if outside else ''}")
    print(f"point estimates within their intervals across seeds (information): "
          f"{'yes' if not spread else 'no: ' + ', '.join(spread)}")
    if json_path:
        json_path.write_text(json.dumps({name: [{"seed": r.seed, "exit": r.exit_code, "seconds": r.seconds,
                                                 "stderr": r.stderr, "result": r.document} for r in rs]
                                         for name, rs in runs.items()}, indent=1))
    return 0 if not (missing or internal or differing or outside) else 1


if __name__ == "__main__":
    sys.exit(main())
