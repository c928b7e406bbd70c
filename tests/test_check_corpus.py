"""`pendfmu check` with default options on FMUs pendfmu did not make (tests/corpus/), held to
issue 24's done-when:

- each broken variant fails, in a row named after the check made for its defect;
- each correct FMU has no FAIL, and a row that is INCONCLUSIVE (or WARN) says why;
- no row passes a correct FMU that its check did not exercise. Whether a check exercised a
  model is not read from the row's words: the Python models count in the test process what
  they did (`ACTIVITY`: lag moves, relay switches, breakaways), so each check's own runs are
  observed. BouncingMass needs no observer: gravity makes it bounce whatever the input.

The corpus itself is held to closed forms first (the correct models are correct), with
fmpy as the host, not pendfmu.
"""

from __future__ import annotations

import math
import sys

import numpy as np
import pytest
from fmpy import simulate_fmu

from corpus.build import CORPUS, build_all
from pendfmu.check import run_battery
from pendfmu.check.battery import DYNAMIC
from pendfmu.check.fmu import FAIL, PASS

BROKEN = [(model, variant) for model, variants in CORPUS.items() for variant, check in variants.items() if check]
OBSERVED = {"Lag": "Lag", "Thermostat": "Thermostat", "Slider": "Slider"}
"""The correct models that count their activity: model -> the module pythonfmu imports."""


@pytest.fixture(scope="module")
def corpus(tmp_path_factory):
    saved = list(sys.path)
    yield build_all(tmp_path_factory.mktemp("corpus"))
    sys.path[:] = saved  # pythonfmu's binary puts each instance's resources folder first on sys.path


@pytest.fixture(scope="module")
def checked(corpus):
    """`pendfmu check` on every FMU of the corpus, default options, run once: {key: rows}."""
    return {key: run_battery(path) for key, path in corpus.items()}


def table(rows) -> str:
    return "\n".join(f"{r.verdict:<12} {r.name}: {r.figure} {r.message}".rstrip() for r in rows)


# --- the corpus against closed forms ----------------------------------------------------

def simulate(corpus, model, start, stop, kind="CoSimulation", step=0.01):
    return simulate_fmu(str(corpus[model, "ok"]), fmi_type=kind, start_values=start, stop_time=stop,
                        output_interval=step, relative_tolerance=1e-10)


def test_the_lag_follows_its_exponential(corpus):
    """u held at 5 V: the table gives c = 4.95 V, so y = 2 * 4.95 (1 - exp(-t / 0.5))."""
    result = simulate(corpus, "Lag", {"u": 5.0}, 2.0)
    expected = 9.9 * (1 - np.exp(-result["time"] / 0.5))
    np.testing.assert_allclose(result["y"], expected, rtol=1e-12, atol=1e-12)


def test_the_thermostat_switches_off_at_the_upper_threshold_in_closed_form(corpus):
    """T_out 5 degC: COP 3.4, so the room heats towards 5 + 5 * 2 * 3.4 = 39 degC from 18 and
    the relay opens at 20.5 degC at t1 = 7200 ln(21 / 18.5) s; then it cools towards 5 until
    it reaches 19.5 degC, 7200 ln(15.5 / 14.5) s later."""
    result = simulate(corpus, "Thermostat", {"T_out": 5.0}, 3600.0, step=60.0)
    t, T = result["time"], result["T"]
    t1 = 7200.0 * math.log(21.0 / 18.5)
    t2 = t1 + 7200.0 * math.log(15.5 / 14.5)
    heating, cooling = t <= t1, (t > t1) & (t < t2)
    np.testing.assert_allclose(T[heating], 39.0 - 21.0 * np.exp(-t[heating] / 7200.0), rtol=1e-12)
    np.testing.assert_allclose(T[cooling], 5.0 + 15.5 * np.exp(-(t[cooling] - t1) / 7200.0), rtol=1e-12)


def test_the_slider_stays_below_breakaway_and_slides_above(corpus):
    assert not np.any(simulate(corpus, "Slider", {"F": 19.9}, 1.0)["x"])
    result = simulate(corpus, "Slider", {"F": 30.0}, 1.0)
    v_end, rate = (30.0 - 15.0) / 4.0, 2.0  # (F - F_c) / c, c / m
    np.testing.assert_allclose(result["v"], v_end * (1 - np.exp(-rate * result["time"])), rtol=1e-12, atol=1e-14)


@pytest.mark.parametrize("kind", ["CoSimulation", "ModelExchange"])
def test_the_bouncing_mass_falls_rebounds_and_rests_as_computed(corpus, kind):
    """Dropped from 0.5 m: the first impact at sqrt(2 h0 / g), the rebound at 0.7 of the
    impact speed; it rests after the first rebound slower than 0.1 m/s (the 10th), then stays."""
    result = simulate(corpus, "BouncingMass", {}, 2.0, kind)
    t, h = result["time"], result["h"]
    g = 9.81
    t1 = math.sqrt(2 * 0.5 / g)
    v1 = 0.7 * g * t1
    falling, rising = t < t1, (t > t1) & (t < t1 + 2 * v1 / g)
    tolerance = 1e-12 if kind == "CoSimulation" else 1e-7  # fmpy's CVode integrates and locates the impact
    np.testing.assert_allclose(h[falling], 0.5 - g * t[falling] ** 2 / 2, atol=tolerance)
    np.testing.assert_allclose(h[rising], v1 * (t[rising] - t1) - g * (t[rising] - t1) ** 2 / 2, atol=tolerance)
    bounces = next(n for n in range(1, 100) if g * t1 * 0.7 ** n < 0.1)
    assert result["bounces"][-1] == bounces == 10 and h[-1] == 0.0


# --- the contract -----------------------------------------------------------------------

@pytest.mark.parametrize("model, variant", BROKEN, ids=[f"{m}_{v}" for m, v in BROKEN])
def test_each_broken_variant_fails_in_the_check_made_for_it(checked, model, variant):
    expected = CORPUS[model][variant]
    rows = checked[model, variant]
    caught = [r for r in rows if r.verdict == FAIL and r.name.startswith(expected)]
    assert caught, f"{model}_{variant}: no FAIL row named '{expected}...':\n{table(rows)}"


@pytest.mark.parametrize("model", sorted(CORPUS))
def test_each_correct_fmu_has_no_failure_and_says_why_it_did_not_pass(checked, model):
    rows = checked[model, "ok"]
    failed = [r for r in rows if r.verdict == FAIL]
    unexplained = [r for r in rows if r.verdict != PASS and not r.message.strip()]
    assert not failed and not unexplained, f"{model}_ok:\n{table(failed + unexplained)}"


@pytest.mark.parametrize("model", sorted(OBSERVED))
def test_no_check_passes_a_correct_fmu_it_did_not_exercise(corpus, model):
    """Each dynamic check alone (its rows are those of the whole battery): a check whose runs
    left the model idle (no lag move, relay switch or breakaway) may not say PASS; it says
    INCONCLUSIVE with the reason. Misuse (sequence) runs in child processes: not observed."""
    path = corpus[model, "ok"]
    wrong = []
    for check in [m.__name__.rsplit(".", 1)[1] for m in DYNAMIC]:
        if check == "sequence":
            continue
        before = activity(OBSERVED[model])
        rows = run_battery(path, only=(check,))
        if activity(OBSERVED[model]) == before:
            wrong += [r for r in rows if r.verdict != "INCONCLUSIVE" or not r.message.strip()]
    assert not wrong, f"{model}_ok: rows of checks that left the model idle:\n{table(wrong)}"


def activity(module: str) -> int:
    """What the model counted so far in this process (0 before its first instance)."""
    loaded = sys.modules.get(module)
    return sum(loaded.ACTIVITY.values()) if loaded is not None else 0
