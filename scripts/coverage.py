"""Coverage benchmark of the fit's 95 % intervals (issue 12): do they hold the truth?

For each of N truths drawn around the reference rig (docs/user-guide/model.md), the six stage
recordings (current steps, three cart runs without pendulum, pendulum decay and rocking) are
simulated by the independent reference simulator in tests/ (scripts/reference_recordings.py,
not the FMUs the fit uses), read through the virtual rig's sensors with their own noise
seed, and fitted by ``pendfmu.fit("all", ...)`` from the reference values. Per fitted parameter
the estimate, the truth, its ``ci95`` and flags go to a JSON-lines file as each truth
completes; the summary is printed at the end (or from the file with ``--tally``).

Truths: ``pendfmu.virtual_rig.draw_truth`` (its docstring says how they are drawn);
``--spread wide`` draws each parameter x0.5-2 of the reference instead of x0.6-1.6, and
leaves more carts stuck through their slow ramp (each record says whether it broke away).
Cached recordings, per truth index and seed: DIR/recordings/{GENERATOR}-seed{S}/truth{K}/
(wide: {GENERATOR}-wide-seed{S}). Each record also keeps what a poor fit must be judged by:
the verdict of each stage (fit.assessment), the residual RMS and noise scale of every
recorded signal, and the kinds of every flag.

``--simulator fmu`` makes the same truths' recordings with the virtual rig's FMUs and
the same noise instead: the control run. Where it covers and the reference run does
not, the gap is a disagreement between the FMUs and the physics, not the interval method.

    python scripts/coverage.py [--truths 30] [--seed 0] [--out out/coverage] [--method NAME]
                               [--stages current,cart,pendulum] [--start K] [--spread wide]
    python scripts/coverage.py --tally out/coverage/results-....jsonl [--summary FILE.json]

A truth takes about 4 minutes on a shared 2-core machine (measured with the wide draw):
20-60 s to generate its recordings (cached for later runs) and 3-4 min for the fit, its
restarts, the validation of its halves and its bootstrap.
"""

from __future__ import annotations

import argparse
import json
import math
import shutil
import sys
import tempfile
import time
from pathlib import Path

from pendfmu.fitting.identification import fit
from pendfmu.fitting.spec import UNCERTAINTY_METHODS
from pendfmu.fitting.result import kinds
from pendfmu.virtual_rig import SPREADS, cart_ramp_breaks_away, draw_truth, write_experiments

from coverage_tally import STAGE_OF_RECORDING, STAGE_PARAMETERS, covers, print_summary, read_results, write_summary
from reference_recordings import stage_experiments, write_reference_experiments

GENERATOR = "v1"  # part of the cache path: bump when the recordings change


def noise_seed(seed: int, index: int) -> int:
    return 100_000 * seed + index


def recordings(out: Path, seed: int, index: int, simulator: str = "reference",
               spread: str = "standard") -> tuple[Path, float]:
    """The folder of truth `index`'s recordings, generated once (seconds spent, 0 if cached).
    Written under a temporary name and renamed, so an interrupted run leaves no half folder."""
    kind = (GENERATOR if simulator == "reference" else simulator) + ("" if spread == "standard" else f"-{spread}")
    folder = out / "recordings" / f"{kind}-seed{seed}" / f"truth{index:03d}"
    if folder.is_dir():
        return folder, 0.0
    start = time.perf_counter()
    truth, angle = draw_truth(seed, index, spread)
    partial = folder.with_name(f".{folder.name}.part")
    shutil.rmtree(partial, ignore_errors=True)
    if simulator == "reference":
        write_reference_experiments(partial, truth, noise_seed(seed, index), stage_experiments(angle),
                                    truth_index=index, truth_seed=seed, release_angle=angle)
    else:
        write_experiments(partial, truth, noise_seed(seed, index), stage_experiments(angle))
    partial.rename(folder)
    return folder, time.perf_counter() - start


def stage_view(folder: Path, stages: tuple[str, ...], into: Path) -> Path:
    """A folder with only the recordings of `stages` (symbolic links), for fit all."""
    for csv in folder.glob("*.csv"):
        if STAGE_OF_RECORDING.get(csv.stem) in stages:
            for path in (csv, csv.with_suffix(".json")):
                (into / path.name).symlink_to(path.resolve())
    return into


def fit_truth(folder: Path, seed: int, index: int, stages: tuple[str, ...], method: str | None,
              spread: str = "standard") -> dict:
    """Fit one truth's recordings; the JSON-lines record of every fitted quantity, of each
    stage's verdict and of each recording's residuals."""
    truth, angle = draw_truth(seed, index, spread)
    # Stages not fitted are known exactly; the fitted ones start from the reference values.
    known = {n: truth[n] for stage, names in STAGE_PARAMETERS.items() if stage not in stages for n in names}
    extra = {"uncertainty": method} if method else {}
    start = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        result = fit("all", stage_view(folder, stages, Path(tmp)), params=known or None, seed=index,
                     progress=False, **extra)
    seconds = time.perf_counter() - start
    truths = {**truth, "phi0[pendulum-decay]": math.pi + angle}
    estimates = {label: {"value": e.value, "truth": truths.get(label), "stderr": e.stderr,
                         "ci95": list(e.ci95) if e.ci95 else None, "flags": e.flags,
                         "flag_kinds": kinds(e.flags), "method": e.method}
                 for label, e in result.estimates.items()}
    intervals = sum(u.get("seconds", 0.0) for u in result.uncertainty.values())
    return {"seed": seed, "index": index, "noise_seed": noise_seed(seed, index), "fit_seed": index,
            "method": method or "default", "spread": spread, "stages": list(stages), "seconds": seconds,
            "interval_seconds": intervals, "nfev": result.nfev, "nrmse": result.nrmse, "notes": result.notes,
            "warnings": result.warnings, "ramp_breaks_away": cart_ramp_breaks_away(truth),
            "assessment": stage_verdicts(result.assessment), "residuals": residual_sizes(result),
            "estimates": estimates}


def stage_verdicts(assessment: dict) -> dict[str, dict]:
    """Per stage its verdict, the residual spread it judged and its evidence (adequacy.py)."""
    return {stage: {"verdict": a.get("verdict"), "spread": a.get("spread"), "evidence": a.get("evidence", [])}
            for stage, a in assessment.get("stages", {}).items()}


def residual_sizes(result) -> list[dict]:
    """Per fitted recording its stage, samples, and per signal the residual RMS and the
    noise scale the fit divided it by (the result file's own figures)."""
    return [{"name": e["name"], "stage": STAGE_OF_RECORDING.get(e["name"]), "samples": e["samples"],
             "rms": e["rms"], "scale": e["scale"]} for e in result.to_dict()["recordings"]]


def check_method(method: str | None) -> None:
    if method is not None and method not in UNCERTAINTY_METHODS:
        sys.exit(f"--method {method}: one of {', '.join(UNCERTAINTY_METHODS)}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--truths", type=int, default=30, help="number of truths (default 30)")
    parser.add_argument("--seed", type=int, default=0, help="series of truths and noise seeds (default 0)")
    parser.add_argument("--start", type=int, default=0, help="first truth index, to resume or extend (default 0)")
    parser.add_argument("--out", type=Path, default=Path("out/coverage"), help="recordings cache and results")
    parser.add_argument("--method", help="the fit's uncertainty=METHOD (default: the fit's own)")
    parser.add_argument("--stages", default="current,cart,pendulum",
                        help="comma-separated subset of current,cart,pendulum; the others are fixed at the truth")
    parser.add_argument("--simulator", choices=("reference", "fmu"), default="reference",
                        help="who makes the recordings: tests/reference_rig.py (default) or, as a control, "
                             "the FMUs of the virtual rig")
    parser.add_argument("--spread", choices=tuple(SPREADS), default="standard",
                        help="how widely truths are drawn: standard (x0.6-1.6 of the reference) or wide (x0.5-2)")
    parser.add_argument("--tally", type=Path, metavar="FILE", help="print the summary of a results file; no fitting")
    parser.add_argument("--summary", type=Path, metavar="FILE",
                        help="also write the summary and the goal's criteria as JSON (default: beside the results)")
    args = parser.parse_args()
    if args.tally:
        print_summary(read_results(args.tally))
        if args.summary:
            write_summary(read_results(args.tally), args.summary)
        return
    stages = tuple(s for s in ("current", "cart", "pendulum") if s in args.stages.split(","))
    unknown = set(args.stages.split(",")) - set(stages)
    if unknown or not stages:
        parser.error(f"--stages: unknown {', '.join(sorted(unknown)) or 'empty'}; choose from current,cart,pendulum")
    check_method(args.method)
    args.out.mkdir(parents=True, exist_ok=True)
    name = (f"seed{args.seed}-{args.method or 'default'}-{'+'.join(stages)}" + ("-fmu" if args.simulator == "fmu" else "")
            + ("" if args.spread == "standard" else f"-{args.spread}"))
    results = args.out / f"results-{name}.jsonl"
    done = {r["index"] for r in read_results(results)} if results.exists() else set()
    print(f"results: {results}", flush=True)
    for index in range(args.start, args.start + args.truths):
        if index in done:
            print(f"truth {index}: already in the results file, skipped", flush=True)
            continue
        folder, generated = recordings(args.out, args.seed, index, args.simulator, args.spread)
        try:
            record = fit_truth(folder, args.seed, index, stages, args.method, args.spread)
            record["simulator"] = args.simulator
        except Exception as error:  # one truth's failure is a finding, not the end of the run
            record = {"seed": args.seed, "index": index, "method": args.method or "default", "spread": args.spread,
                      "stages": list(stages), "simulator": args.simulator,
                      "error": f"{type(error).__name__}: {error}"}
        record["generate_seconds"] = generated
        with results.open("a") as handle:  # a line per truth: an interrupted run keeps its work
            handle.write(json.dumps(record) + "\n")
        if "error" in record:
            print(f"truth {index}: the fit failed: {record['error']}", flush=True)
            continue
        misses = [k for k, e in record["estimates"].items() if e["truth"] is not None and not covers(e, k)]
        marked = [f"{stage} {a['verdict']}" for stage, a in record["assessment"].items() if a["verdict"] != "adequate"]
        print(f"truth {index}: generated in {generated:.1f} s, fitted in {record['seconds']:.1f} s; "
              f"outside the interval: {', '.join(misses) or 'none'}; marked: {', '.join(marked) or 'none'}",
              flush=True)
    print_summary(read_results(results))
    write_summary(read_results(results), args.summary or results.with_name(results.stem + "-summary.json"))


if __name__ == "__main__":
    main()
