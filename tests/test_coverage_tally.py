"""The coverage benchmark's criteria (scripts/coverage_tally.py, issue 25), on records made
here with known figures: a poor fit is found from the residuals themselves, not from the
verdict it is to check, and only a verdict or a marking flag counts as its mark."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import pytest

sys.path.append(str(Path(__file__).resolve().parents[1] / "scripts"))

import coverage_tally as tally  # noqa: E402


def entry(value: float, truth: float, half_width: float, kinds=()) -> dict:
    return {"value": value, "truth": truth, "ci95": [value - half_width, value + half_width],
            "flags": [f"a {k} flag" for k in kinds], "flag_kinds": list(kinds)}


def record(index: int, cart_spread: float = 1.0, verdict: str = "adequate", eta_kinds=(), miss: bool = False) -> dict:
    """A truth whose every rig parameter has error 1 % and half-width 2 % (eta 5 % off if
    `miss`), and whose cart residuals are `cart_spread` times the noise: two recordings of 1000
    and 3000 samples at sqrt(13) and 1 times, pooled to 2 (scaled by cart_spread / 2)."""
    estimates = {name: entry(1.01, 1.0, 0.02) for name in tally.RIG_PARAMETERS}
    estimates["eta"] = entry(1.05 if miss else 1.01, 1.0, 0.02, eta_kinds)
    factor = cart_spread / 2.0
    residuals = [{"name": "cart-ramp", "stage": "cart", "samples": 1000, "rms": {"x": math.sqrt(13) * factor * 1e-6},
                  "scale": {"x": 1e-6}},
                 {"name": "cart-startup-2A", "stage": "cart", "samples": 3000, "rms": {"x": factor * 2e-6},
                  "scale": {"x": 2e-6}},
                 {"name": "pendulum-decay", "stage": "pendulum", "samples": 10, "rms": {"phi": 1e-3},
                  "scale": {"phi": 1e-3}}]
    return {"index": index, "seed": 0, "method": "default", "stages": ["cart", "pendulum"], "seconds": 1.0,
            "estimates": estimates, "residuals": residuals,
            "assessment": {"cart": {"verdict": verdict}, "pendulum": {"verdict": "adequate"}}}


def test_residual_spread_pools_every_sample_of_a_stage():
    spreads = tally.residual_spreads(record(0, cart_spread=2.0))
    assert spreads["cart"] == pytest.approx(2.0, rel=1e-12)  # sqrt((1000 * 13 + 3000 * 1) / 4000)
    assert spreads["pendulum"] == pytest.approx(1.0)


@pytest.mark.parametrize("verdict, eta_kinds, marked", [
    ("adequate", (), False), ("adequate", ("correlated",), False), ("adequate", ("fit-failed",), True),
    ("model-inadequate", (), True), ("fit-failed", (), True)])
def test_a_poor_fit_is_marked_by_its_verdict_or_a_marking_flag(verdict, eta_kinds, marked):
    poor = tally.poor_fits([record(3, cart_spread=3.5, verdict=verdict, eta_kinds=eta_kinds), record(4, 2.9)])
    assert [(p["index"], p["stage"], p["marked"]) for p in poor] == [(3, "cart", marked)]


def test_the_criteria_pass_and_fail_on_their_own_figures(tmp_path):
    good = [record(k) for k in range(30)]
    found = tally.criteria(tally.summarize(good), good)
    assert {k: c["verdict"] for k, c in found.items()} == dict.fromkeys(found, "PASS")
    assert found["half_width_ratio"]["value"] == pytest.approx(2.0)
    # 7 of 30 eta intervals miss (76.7 %), and one cart fit at 4x the noise is left unmarked
    bad = [record(k, miss=k < 7) for k in range(29)] + [record(29, cart_spread=4.0)]
    found = tally.criteria(tally.summarize(bad), bad)
    assert found["min_parameter_coverage"]["verdict"] == "FAIL" and found["min_parameter_coverage"]["parameter"] == "eta"
    assert found["overall_coverage"]["verdict"] == "PASS"  # 353 of 360
    assert found["unmarked_poor_fits"]["value"] == 1 and found["unmarked_poor_fits"]["verdict"] == "FAIL"
    assert tally.criteria(tally.summarize(good[:29]), good[:29])["rigs"]["verdict"] == "FAIL"
    written = json.loads(tally.write_summary(bad, tmp_path / "summary.json").read_text())
    assert written["criteria"]["min_parameter_coverage"]["value"] == pytest.approx(23 / 30)


def test_records_without_residual_figures_leave_the_criterion_unjudged():
    old = [{k: v for k, v in record(k).items() if k != "residuals"} for k in range(30)]
    assert tally.criteria(tally.summarize(old), old)["unmarked_poor_fits"]["verdict"] == "FAIL"


def test_marks_on_fits_within_the_noise_are_counted_as_false_alarms():
    records = [record(0, verdict="model-inadequate"), record(1, cart_spread=3.5, verdict="fit-failed"), record(2)]
    assert tally.verdict_counts(records)["cart"] == {"model-inadequate": 1, "marked within the noise limit": 1,
                                                     "fit-failed": 1, "adequate": 1}
