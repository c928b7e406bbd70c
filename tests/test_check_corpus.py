"""`pendfmu check` with default options on FMUs pendfmu did not make (tests/corpus/), held to
issue 24's done-when:

- each broken variant fails, in a row named after the check made for its defect;
- each correct FMU has no FAIL, and a row that is INCONCLUSIVE (or WARN) says why;
- no row passes a correct FMU that its check did not exercise. Whether a check exercised a
  model is not read from the row's words: the Python models count in the process that runs
  them what they did (`ACTIVITY`: lag moves, relay switches, breakaways), so each check's own
  runs are observed. BouncingMass needs no observer: gravity makes it bounce whatever the input.

The corpus itself is held to closed forms first (the correct models are correct), with
fmpy as the host, not pendfmu. Every FMU runs in a child Python (tests/corpus/child.py says
why: pythonfmu's binary can abort the process that loaded it when that process exits).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from corpus.build import CORPUS, HERE, MUTATIONS, build_all, mutated_source
from corpus.child import in_child
from pendfmu.check.fmu import FAIL, INCONCLUSIVE, PASS, CheckResult

BROKEN = [(model, variant) for model, variants in CORPUS.items() for variant, check in variants.items() if check]
OBSERVED = ("Lag", "Thermostat", "Slider")
"""The correct models that count their activity (the module pythonfmu imports is the model's name)."""
SIMULATIONS = {  # name: (model, start values, stop time, FMI type, output interval)
    "lag": ("Lag", {"u": 5.0}, 2.0, "CoSimulation", 0.01),
    "thermostat": ("Thermostat", {"T_out": 5.0}, 3600.0, "CoSimulation", 60.0),
    "slider stuck": ("Slider", {"F": 19.9}, 1.0, "CoSimulation", 0.01),
    "slider sliding": ("Slider", {"F": 30.0}, 1.0, "CoSimulation", 0.01),
    "bouncing CS": ("BouncingMass", {}, 2.0, "CoSimulation", 0.01),
    "bouncing ME": ("BouncingMass", {}, 2.0, "ModelExchange", 0.01),
}


@pytest.fixture(scope="module")
def corpus(tmp_path_factory):
    return build_all(tmp_path_factory.mktemp("corpus"))


@pytest.fixture(scope="module")
def checked(corpus):
    """`pendfmu check` with default options on every FMU of the corpus, in one child:
    {key: {"rows": [CheckResult...], "checks": [...] for the observed models}}."""
    keys = list(corpus)
    observed = {str(corpus[model, "ok"]): model for model in OBSERVED}
    answers = in_child("check", [str(corpus[key]) for key in keys], observed)
    for answer in answers:
        answer["rows"] = [CheckResult(**row) for row in answer["rows"]]
        for check in answer.get("checks", []):
            check["rows"] = [CheckResult(**row) for row in check["rows"]]
    return dict(zip(keys, answers))


@pytest.fixture(scope="module")
def simulated(corpus):
    """fmpy's simulate_fmu on the correct models (SIMULATIONS), in one child: {name: columns}."""
    cases = [[str(corpus[model, "ok"]), start, stop, kind, step, model if model in OBSERVED else None]
             for model, start, stop, kind, step in SIMULATIONS.values()]
    results = in_child("simulate", cases)
    return {name: {column: np.array(values) for column, values in result.items()}
            for name, result in zip(SIMULATIONS, results)}


def table(rows, error: str | None = None) -> str:
    lines = [f"{r.verdict:<12} {r.name}: {r.figure} {r.message}".rstrip() for r in rows]
    return "\n".join(lines + ([f"pendfmu check raised {error}"] if error else []))


# --- the corpus against closed forms ----------------------------------------------------

def test_the_lag_follows_its_exponential(simulated):
    """u held at 5 V: the table gives c = 4.95 V, so y = 2 * 4.95 (1 - exp(-t / 0.5))."""
    result = simulated["lag"]
    expected = 9.9 * (1 - np.exp(-result["time"] / 0.5))
    np.testing.assert_allclose(result["y"], expected, rtol=1e-12, atol=1e-12)
    assert result["activity"][0] == len(result["time"]) - 1  # every step moved it: the observer sees it


def test_the_thermostat_switches_off_at_the_upper_threshold_in_closed_form(simulated):
    """T_out 5 degC: COP 3.4, so the room heats towards 5 + 5 * 2 * 3.4 = 39 degC from 18 and
    the relay opens at 20.5 degC at t1 = 7200 ln(21 / 18.5) s; then it cools towards 5 until
    it reaches 19.5 degC, 7200 ln(15.5 / 14.5) s later, and heats again for 7200 ln(19.5 / 18.5) s."""
    result = simulated["thermostat"]
    t, T = result["time"], result["T"]
    t1 = 7200.0 * math.log(21.0 / 18.5)
    t2 = t1 + 7200.0 * math.log(15.5 / 14.5)
    heating, cooling = t <= t1, (t > t1) & (t < t2)
    np.testing.assert_allclose(T[heating], 39.0 - 21.0 * np.exp(-t[heating] / 7200.0), rtol=1e-12)
    np.testing.assert_allclose(T[cooling], 5.0 + 15.5 * np.exp(-(t[cooling] - t1) / 7200.0), rtol=1e-12)
    cool, heat = t2 - t1, 7200.0 * math.log(19.5 / 18.5)
    switches = [t1 + k // 2 * (cool + heat) + k % 2 * cool for k in range(20)]
    assert result["activity"][0] == sum(s <= t[-1] for s in switches) == 7  # the observer counts each switch


def test_the_slider_stays_below_breakaway_and_slides_above(simulated):
    assert not np.any(simulated["slider stuck"]["x"]) and simulated["slider stuck"]["activity"][0] == 0
    result = simulated["slider sliding"]
    assert result["activity"][0] == 1  # one breakaway, seen by the observer
    v_end, rate = (30.0 - 15.0) / 4.0, 2.0  # (F - F_c) / c, c / m
    np.testing.assert_allclose(result["v"], v_end * (1 - np.exp(-rate * result["time"])), rtol=1e-12, atol=1e-14)


@pytest.mark.parametrize("kind", ["CoSimulation", "ModelExchange"])
def test_the_bouncing_mass_falls_rebounds_and_rests_as_computed(simulated, kind):
    """Dropped from 0.5 m: the first impact at sqrt(2 h0 / g), the rebound at 0.7 of the
    impact speed; it rests after the first rebound slower than 0.1 m/s (the 10th), then stays."""
    result = simulated[f"bouncing {'CS' if kind == 'CoSimulation' else 'ME'}"]
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


@pytest.mark.parametrize("model, variant", list(MUTATIONS), ids=[f"{m}_{v}" for m, v in MUTATIONS])
def test_a_python_variant_is_its_model_with_the_planted_line_and_its_own_name(model, variant):
    correct = (HERE / f"{model}.py").read_text().splitlines()
    name, broken = mutated_source(model, variant)
    changed = [(a, b) for a, b in zip(correct, broken.splitlines()) if a != b]
    assert name == f"{model}_{variant}" and len(broken.splitlines()) == len(correct) and len(changed) == 2
    assert changed[0] == (f"class {model}(Fmi2Slave):", f"class {name}(Fmi2Slave):")
    planted = changed[1]
    assert planted[0].endswith(f"# MUTATION {variant}") and planted[1].strip() == MUTATIONS[model, variant]


# --- the contract -----------------------------------------------------------------------

@pytest.mark.parametrize("model, variant", BROKEN, ids=[f"{m}_{v}" for m, v in BROKEN])
def test_each_broken_variant_fails_in_the_check_made_for_it(checked, model, variant):
    expected = CORPUS[model][variant]
    answer = checked[model, variant]
    caught = [r for r in answer["rows"] if r.verdict == FAIL and r.name.startswith(expected)]
    assert caught, f"{model}_{variant}: no FAIL row named '{expected}...':\n{table(answer['rows'], answer.get('error'))}"


@pytest.mark.parametrize("model", sorted(CORPUS))
def test_each_correct_fmu_has_no_failure_and_says_why_it_did_not_pass(checked, model):
    answer = checked[model, "ok"]
    failed = [r for r in answer["rows"] if r.verdict == FAIL]
    unexplained = [r for r in answer["rows"] if r.verdict != PASS and not r.message.strip()]
    assert answer["rows"] and not failed and not unexplained, \
        f"{model}_ok:\n{table(failed + unexplained, answer.get('error'))}"


@pytest.mark.parametrize("model", OBSERVED)
def test_no_check_passes_a_correct_fmu_it_did_not_exercise(checked, model):
    """Each dynamic check alone (its rows are those of the whole battery): a check whose runs
    left the model idle (no lag move, relay switch or breakaway) may not say PASS; it says
    INCONCLUSIVE with the reason. Misuse (sequence) runs in grandchildren: not observed."""
    answer = checked[model, "ok"]
    assert "checks" in answer, table([], answer.get("error"))
    wrong = [row for check in answer["checks"] if not check["moved"] for row in check["rows"]
             if row.verdict != INCONCLUSIVE or not row.message.strip()]
    assert not wrong, f"{model}_ok: rows of checks that left the model idle:\n{table(wrong)}"
