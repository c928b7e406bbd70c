"""The summary of a coverage run (scripts/coverage.py): from its JSON-lines results.

Coverage counts a missing interval (ci95 None) as not covering: a method that gives no
interval has not said where the truth is. Errors and half-widths are relative to the
truth; a phase is compared modulo 2 pi. The ratio median half-width / median |error|
tells calibration apart from luck: for unbiased Gaussian errors and exact 95 % intervals
it is 1.96 / 0.674 = 2.9; far below means overconfident, far above needlessly wide (the
issue's goal allows at most 5).

A stage fit is poor when its residuals, over every sample of its recordings, have an RMS
above NOISE_LIMIT times the noise scale the fit divided them by (the result's own figures,
recomputed here, not taken from the verdict they are to check). A poor fit must be marked:
its stage's verdict (fit.assessment) is not 'adequate', or one of its estimates carries a
MARKS flag. The goal's criteria (issue 25) are printed with PASS/FAIL each and written as
JSON by write_summary.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from statistics import median

from pendfmu.virtual_rig import STAGE_PARAMETERS  # the parameters a truth draws

RIG_PARAMETERS = tuple(n for names in STAGE_PARAMETERS.values() for n in names)
STAGE_OF_RECORDING = {"current-steps": "current", "cart-startup-2A": "cart", "cart-startup-3A": "cart",
                      "cart-ramp": "cart", "pendulum-decay": "pendulum", "pendulum-stiction": "pendulum"}
GOAL = {"truths": 30, "overall": 0.90, "each": 0.80, "ratio": 5.0, "unmarked": 0}
NOISE_LIMIT = 3.0  # residual RMS / noise above which a fit must be marked
MARKS = ("model-inadequate", "fit-failed")  # flag kinds that mark an estimate's fit as poor
CALIBRATED_RATIO = 1.959963984540054 / 0.6744897501960817


def read_results(path: Path) -> list[dict]:
    """The records of a results file; a last line cut short by an interruption is skipped."""
    records = []
    for line in Path(path).read_text().splitlines():
        try:
            records.append(json.loads(line))
        except json.JSONDecodeError:
            continue
    return records


def _truth_near(label: str, value: float, truth: float) -> float:
    """The truth, for a phase shifted by whole turns to the estimate's side."""
    if label.startswith("phase"):
        return truth + 2 * math.pi * round((value - truth) / (2 * math.pi))
    return truth


def covers(entry: dict, label: str = "") -> bool:
    if entry["ci95"] is None or entry["truth"] is None:
        return False
    low, high = entry["ci95"]
    return low <= _truth_near(label, entry["value"], entry["truth"]) <= high


def summarize(records: list[dict]) -> dict[str, dict]:
    """Per label: n, covered, missing, flagged and the relative errors and half-widths."""
    table: dict[str, dict] = {}
    for record in records:
        for label, entry in record.get("estimates", {}).items():
            if entry["truth"] is None:
                continue
            row = table.setdefault(label, {"n": 0, "covered": 0, "missing": 0, "flagged": 0,
                                           "errors": [], "half_widths": []})
            truth = _truth_near(label, entry["value"], entry["truth"])
            row["n"] += 1
            row["covered"] += covers(entry, label)
            row["missing"] += entry["ci95"] is None
            row["flagged"] += bool(entry["flags"])
            row["errors"].append((entry["value"] - truth) / abs(truth))
            if entry["ci95"] is not None:
                row["half_widths"].append((entry["ci95"][1] - entry["ci95"][0]) / 2 / abs(truth))
    for row in table.values():
        row["median_abs_error"] = median(abs(e) for e in row["errors"])
        row["median_error"] = median(row["errors"])
        row["median_half_width"] = median(row["half_widths"]) if row["half_widths"] else math.nan
        row["ratio"] = (row["median_half_width"] / row["median_abs_error"]
                        if row["median_abs_error"] > 0 else math.inf)
    return table


def _pooled(table: dict[str, dict], labels) -> tuple[int, int, int]:
    rows = [table[k] for k in labels if k in table]
    return sum(r["covered"] for r in rows), sum(r["n"] for r in rows), sum(r["missing"] for r in rows)


def print_summary(records: list[dict]) -> None:
    failed = [r for r in records if "error" in r]
    fitted = [r for r in records if "error" not in r]
    methods = sorted({r["method"] for r in records})
    print(f"\n{len(fitted)} truths fitted ({len(failed)} failed), method {', '.join(methods) or '-'}, "
          f"seeds {sorted({r['seed'] for r in records})}")
    for record in failed:
        print(f"  truth {record['index']} failed: {record['error']}")
    if not fitted:
        return
    table = summarize(fitted)
    print(f"{'parameter':22s} {'covered':>9s} {'%':>6s} {'missing':>7s} {'flagged':>7s} {'med |err|':>10s} "
          f"{'med err':>10s} {'med half-w':>10s} {'ratio':>6s}")
    labels = [k for k in RIG_PARAMETERS if k in table] + sorted(k for k in table if k not in RIG_PARAMETERS)
    for label in labels:
        row = table[label]
        note = "  (initial state; not in the overall figures)" if label not in RIG_PARAMETERS else ""
        print(f"{label:22s} {row['covered']:>4d}/{row['n']:<4d} {100 * row['covered'] / row['n']:5.1f}% "
              f"{row['missing']:>7d} {row['flagged']:>7d} {row['median_abs_error']:10.3g} {row['median_error']:+10.2g} "
              f"{row['median_half_width']:10.3g} {row['ratio']:6.2f}{note}")
    covered, total, missing = _pooled(table, RIG_PARAMETERS)
    print(f"overall (rig parameters): {covered}/{total} = {100 * covered / total:.1f} % covered; "
          f"{missing} intervals missing (counted as not covering)")
    later = [n for s in ("cart", "pendulum") for n in STAGE_PARAMETERS[s]]
    covered_cp, total_cp, _ = _pooled(table, later)
    if total_cp:
        print(f"cart and pendulum stages: {covered_cp}/{total_cp} = {100 * covered_cp / total_cp:.1f} % covered")
    print(f"errors and half-widths relative to the truth; ratio = median half-width / median |error| "
          f"({CALIBRATED_RATIO:.1f} for calibrated Gaussian intervals)")
    seconds = [r["seconds"] for r in fitted]
    generated = [r["generate_seconds"] for r in fitted if r.get("generate_seconds")]
    print(f"fit time per truth: median {median(seconds):.1f} s, max {max(seconds):.1f} s, total {sum(seconds):.0f} s"
          + (f"; generating the recordings: median {median(generated):.1f} s per truth" if generated else ""))
    timed = [r for r in fitted if "interval_seconds" in r]
    if timed:
        ratios = [r["interval_seconds"] / (r["seconds"] - r["interval_seconds"]) for r in timed]
        print(f"intervals against the fit itself: median {median(ratios):.2f}x, max {max(ratios):.2f}x "
              f"(interval seconds / the rest of fit_all's seconds)")
    _print_stuck(fitted)
    _print_goal(table, fitted)


def _print_stuck(records: list[dict]) -> None:
    """Coverage of the cart's parameters apart for carts that broke away in their slow ramp and
    carts that stayed stuck there (only the steps tell their friction)."""
    for broke, words in ((True, "broke away in the ramp"), (False, "stayed stuck through the ramp")):
        group = [r for r in records if r.get("ramp_breaks_away") is broke]
        covered, total, _ = _pooled(summarize(group), STAGE_PARAMETERS["cart"]) if group else (0, 0, 0)
        if total:
            print(f"cart parameters of the {len(group)} carts that {words}: {covered}/{total} = "
                  f"{100 * covered / total:.1f} % covered")


def stage_of(label: str) -> str | None:
    """The stage that fits an estimate: a rig parameter's, or its recording's (phi0[pendulum-decay])."""
    name, _, recording = label.partition("[")
    if recording:
        return STAGE_OF_RECORDING.get(recording.rstrip("]"))
    return next((stage for stage, names in STAGE_PARAMETERS.items() if name in names), None)


def residual_spreads(record: dict) -> dict[str, float]:
    """Per stage, the RMS of residual / noise scale over every sample of its recordings' fitted
    signals (1 for a fit as good as the sensors allow)."""
    sums: dict[str, list[float]] = {}
    for entry in record.get("residuals", []):
        for signal, rms in entry["rms"].items():
            scale = entry["scale"].get(signal)
            if rms is None or not scale:
                continue
            total = sums.setdefault(entry["stage"], [0.0, 0])
            total[0] += entry["samples"] * (rms / scale) ** 2
            total[1] += entry["samples"]
    return {stage: math.sqrt(total / samples) for stage, (total, samples) in sums.items() if samples}


def is_marked(record: dict, stage: str) -> bool:
    """Whether a stage's fit says it is poor: its verdict, or a MARKS flag on one of its estimates."""
    verdict = record.get("assessment", {}).get(stage, {}).get("verdict") or "adequate"
    flagged = any(set(entry.get("flag_kinds", [])) & set(MARKS)
                  for label, entry in record["estimates"].items() if stage_of(label) == stage)
    return verdict != "adequate" or flagged


def poor_fits(records: list[dict]) -> list[dict]:
    """Every stage fit whose residuals exceed NOISE_LIMIT times the noise, and whether it is marked."""
    poor = []
    for record in records:
        for stage, spread in residual_spreads(record).items():
            if spread > NOISE_LIMIT:
                verdict = record.get("assessment", {}).get(stage, {}).get("verdict")
                poor.append({"index": record["index"], "stage": stage, "spread": spread, "verdict": verdict,
                             "marked": is_marked(record, stage)})
    return poor


def verdict_counts(records: list[dict]) -> dict[str, dict[str, int]]:
    """Per stage, how many fits got each verdict (fit.assessment). The benchmark's recordings
    come from the model the fit uses, so a mark on a fit within NOISE_LIMIT is a false alarm."""
    counts: dict[str, dict[str, int]] = {}
    for record in records:
        spreads = residual_spreads(record)
        for stage, assessment in record.get("assessment", {}).items():
            row = counts.setdefault(stage, {})
            row[assessment["verdict"]] = row.get(assessment["verdict"], 0) + 1
            if assessment["verdict"] != "adequate" and spreads.get(stage, math.inf) <= NOISE_LIMIT:
                row["marked within the noise limit"] = row.get("marked within the noise limit", 0) + 1
    return counts


def criteria(table: dict[str, dict], records: list[dict]) -> dict[str, dict]:
    """The goal's criteria: each with its figure, the goal, PASS or FAIL, and its details."""
    rows = {k: table[k] for k in RIG_PARAMETERS if k in table}
    covered, total, _ = _pooled(table, RIG_PARAMETERS)
    each = {k: r["covered"] / r["n"] for k, r in rows.items()}
    ratios = {k: r["ratio"] for k, r in rows.items()}
    lowest = min(each, key=each.get)
    widest = max(ratios, key=lambda k: ratios[k] if not math.isnan(ratios[k]) else math.inf)
    poor = poor_fits(records)
    unmarked = [p for p in poor if not p["marked"]]
    judged = sum(bool(r.get("residuals")) for r in records)
    return {
        "rigs": _criterion(len(records), f">= {GOAL['truths']}", len(records) >= GOAL["truths"]),
        "overall_coverage": _criterion(covered / total, f">= {GOAL['overall']:.0%}", covered / total >= GOAL["overall"],
                                       covered=covered, intervals=total),
        "min_parameter_coverage": _criterion(each[lowest], f">= {GOAL['each']:.0%}", each[lowest] >= GOAL["each"],
                                             parameter=lowest, per_parameter=each),
        "half_width_ratio": _criterion(ratios[widest], f"<= {GOAL['ratio']:g} for every parameter",
                                       all(r <= GOAL["ratio"] for r in ratios.values()),
                                       parameter=widest, per_parameter=ratios),
        "unmarked_poor_fits": _criterion(len(unmarked), f"{GOAL['unmarked']} (residual RMS > {NOISE_LIMIT:g}x noise)",
                                         judged == len(records) and len(unmarked) <= GOAL["unmarked"],
                                         poor=poor, truths_with_residuals=judged),
    }


def _criterion(value, goal: str, passed: bool, **details) -> dict:
    return {"value": value, "goal": goal, "verdict": "PASS" if passed else "FAIL", **details}


def _print_goal(table: dict[str, dict], records: list[dict]) -> None:
    found = criteria(table, records)
    print("goal (issue 25):")
    lines = {
        "rigs": f"rigs fitted: {found['rigs']['value']}",
        "overall_coverage": f"overall coverage: {100 * found['overall_coverage']['value']:.1f} %",
        "min_parameter_coverage": f"lowest parameter coverage: {100 * found['min_parameter_coverage']['value']:.1f} % "
                                  f"({found['min_parameter_coverage']['parameter']})",
        "half_width_ratio": f"largest median half-width / median |error|: {found['half_width_ratio']['value']:.2f} "
                            f"({found['half_width_ratio']['parameter']})",
        "unmarked_poor_fits": f"poor fits left unmarked: {found['unmarked_poor_fits']['value']} of "
                              f"{len(found['unmarked_poor_fits']['poor'])} poor stage fits",
    }
    for key, line in lines.items():
        print(f"  {found[key]['verdict']}  {line} (goal {found[key]['goal']})")
    for stage, counts in verdict_counts(records).items():
        print(f"        {stage} verdicts: " + ", ".join(f"{k} {v}" for k, v in counts.items()))
    for poor in found["unmarked_poor_fits"]["poor"]:
        print(f"        truth {poor['index']} {poor['stage']}: residuals {poor['spread']:.3g}x the noise, verdict "
              f"{poor['verdict']}, {'marked' if poor['marked'] else 'NOT marked'}")
    missing = len(records) - found["unmarked_poor_fits"]["truths_with_residuals"]
    if missing:
        print(f"        {missing} records without residual figures (an older results file): criterion not judged")


def summary(records: list[dict]) -> dict:
    """The machine-readable summary: the table per estimate, the criteria, times, failures."""
    fitted = [r for r in records if "error" not in r]
    table = summarize(fitted)
    rows = {k: {key: v for key, v in row.items() if key not in ("errors", "half_widths")} for k, row in table.items()}
    return {"truths": len(records), "fitted": len(fitted), "failed": {r["index"]: r["error"] for r in records if "error" in r},
            "methods": sorted({r["method"] for r in records}), "spreads": sorted({r.get("spread", "standard") for r in records}),
            "stages": sorted({s for r in records for s in r["stages"]}),
            "carts_stuck_through_the_ramp": [r["index"] for r in fitted if r.get("ramp_breaks_away") is False],
            "fit_seconds": [r["seconds"] for r in fitted], "verdicts": verdict_counts(fitted), "parameters": rows,
            "criteria": criteria(table, fitted) if fitted else {}}


def write_summary(records: list[dict], path: Path) -> Path:
    """The summary as JSON (a non-finite figure, such as an unbounded half-width's ratio, as null)."""
    Path(path).write_text(json.dumps(_finite(summary(records)), indent=2) + "\n")
    print(f"summary: {path}")
    return Path(path)


def _finite(value):
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {str(k): _finite(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_finite(v) for v in value]
    return value
