"""The summary of a coverage run (scripts/coverage.py): from its JSON-lines results.

Coverage counts a missing interval (ci95 None) as not covering: a method that gives no
interval has not said where the truth is. Errors and half-widths are relative to the
truth; a phase is compared modulo 2 pi. The ratio median half-width / median |error|
tells calibration apart from luck: for unbiased Gaussian errors and exact 95 % intervals
it is 1.96 / 0.674 = 2.9; far below means overconfident, far above needlessly wide (the
issue's goal allows at most 5).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from statistics import median

from pendfmu.virtual_rig import STAGE_PARAMETERS  # the parameters a truth draws

RIG_PARAMETERS = tuple(n for names in STAGE_PARAMETERS.values() for n in names)
GOAL = {"truths": 30, "overall": 0.90, "each": 0.80, "ratio": 5.0}
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
    _print_goal(table, len(fitted), covered / total)


def _print_goal(table: dict[str, dict], truths: int, overall: float) -> None:
    rows = {k: table[k] for k in RIG_PARAMETERS if k in table}
    low = [k for k, r in rows.items() if r["covered"] / r["n"] < GOAL["each"]]
    wide = [k for k, r in rows.items() if not r["ratio"] <= GOAL["ratio"]]
    problems = []
    if truths < GOAL["truths"]:
        problems.append(f"only {truths} truths (goal: >= {GOAL['truths']})")
    if overall < GOAL["overall"]:
        problems.append(f"overall {100 * overall:.1f} % < 90 %")
    if low:
        problems.append(f"below 80 %: {', '.join(low)}")
    if wide:
        problems.append(f"half-width above 5x the error: {', '.join(wide)}")
    print("goal (>= 30 truths, >= 90 % overall, every parameter >= 80 %, median half-width <= 5x median |error|): "
          + ("met" if not problems else "not met: " + "; ".join(problems)))
