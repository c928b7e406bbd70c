"""`pendfmu check` on an FMU it did not make (issue 24): no PASS without exercise.

The corpus is ForeignCart as a supplier would ship it (tests/foreign/mutants.py: start values
of the identified cart, breakaway at 5 N = 1.25 V of 4 N/V, so the old cautious stimulus of
+-1 V never moved it and every row passed on nothing) and its broken variants, built by
mutation. With default options each variant fails by the check made for it and by that check
only, the correct one passes every row, and a cart that cannot move (k_u = 0) is INCONCLUSIVE
in every dynamic row kind, never PASS.
"""

from __future__ import annotations

import re
from types import SimpleNamespace

import numpy as np
import pytest

from foreign.mutants import VARIANTS, build_variant
from foreign.recordings import TRUTH
from pendfmu.check import exercise, run_battery
from pendfmu.check.fmu import FAIL, INCONCLUSIVE, PASS, Target
from pendfmu.check.stimulus import excitation, probe_values
from pendfmu.cli import main

CAUGHT_BY = {
    "events_at_points": "convergence: h, h/2, h/4 CS",
    "forget_mode": "rollback: FMU state CS",
    "reset_keeps": "determinism: reset CS",
    "nan_above_11V": "inputs: finite outputs CS",
    "step_jump": "convergence: h, h/2, h/4 CS",
}
DYNAMIC = ("events", "determinism", "rollback", "convergence", "inputs")


@pytest.fixture(scope="module")
def corpus(tmp_path_factory):
    folder = tmp_path_factory.mktemp("corpus")
    built = {variant: build_variant(variant, folder) for variant in VARIANTS}
    built["forget_mode_hidden"] = build_variant("forget_mode", folder, hide_mode=True)
    built["still"] = build_variant("ok", folder, starts={**TRUTH, "k_u": 0.0}, name="StillCart")
    return built


def dynamic(results):
    return [r for r in results if r.name.split(":")[0] in DYNAMIC]


def test_the_search_moves_the_shipped_cart_where_a_cautious_stimulus_did_not(corpus):
    used = excitation(Target(corpus["ok"]))
    assert used.label == "sine u 0 ± 10 V"
    assert used.tried[:3] == [("sine u 0 ± 1 V", "no output moved"), ("steps u 0 ± 1 V", "no output moved"),
                              ("ramp u 0 ± 1 V", "no output moved")]
    assert len(used.tried) == 4 and used.tried[3][1].startswith("2 of 2 outputs moved, 3 events (mode changes 3")


def test_the_correct_shipped_cart_passes_every_row_and_each_names_its_stimulus(corpus):
    results = run_battery(corpus["ok"])
    assert {r.verdict for r in results} == {PASS}, [r for r in results if r.verdict != PASS]
    for row in dynamic(results):  # the inputs row names its own stimulus: the values it held
        assert ("[sine u 0 ± 10 V" in row.figure) != row.name.startswith("inputs"), row
    rows = {r.name: r for r in results}
    assert rows["events: seen from outside CS"].figure.startswith("4 events (mode changes 3, sign changes 2, kinks in v")
    assert "moved x 0.586 m, v 4.05 m/s" in rows["determinism: fresh instances CS"].figure
    assert "(m moves the outputs by 0.379)" in rows["determinism: reset CS"].figure
    assert "8 around 4 events" in rows["rollback: FMU state CS"].figure
    assert rows["inputs: finite outputs CS"].figure == \
        "finite, 9 runs: u 0 ± 1, 10, 100, 1000 V by decades (no declared range)"


def _order(figure: str) -> float:
    return float(re.search(r"order (-?[\d.]+)", figure).group(1))


@pytest.mark.parametrize("variant", CAUGHT_BY)
def test_each_broken_variant_fails_by_the_check_made_for_it_only(corpus, variant):
    results = run_battery(corpus[variant])
    failed = {r.name: r for r in results if r.verdict == FAIL}
    assert list(failed) == [CAUGHT_BY[variant]], failed
    assert not [r for r in results if r.verdict == INCONCLUSIVE]
    row = failed[CAUGHT_BY[variant]]
    if variant in ("events_at_points", "step_jump"):  # first order: moves with h instead of shrinking fast
        assert 0.8 < _order(row.figure) < 1.2 and row.figure.startswith("x: d1 ")
        assert row.message.startswith("the result moves with the communication step: x changes by")
        assert "tolerance 0.0001" in row.message and "decided only at communication points" in row.message
    elif variant == "forget_mode":
        assert "restoring the state saved at t = " in row.message and "(modes mode=" in row.message
    elif variant == "reset_keeps":
        assert "fmi2Reset must bring m back to its start value 2" in row.message
    else:
        assert row.figure == "u = 100: x = nan"
        assert row.message == ("with input u held at 100 (probed by decades, no declared range) output x turned nan "
                               "at t = 0.001 s while every call returned OK")


def test_a_state_that_forgets_an_undeclared_mode_is_caught_around_events_seen_from_outside(corpus):
    """The mode is not in the model description: the rollback saves around the kinks and sign
    changes of v instead, and restoring one of those states shows the forgotten mode."""
    target = Target(corpus["forget_mode_hidden"])
    assert target.modes == []
    rows = {r.name: r for r in run_battery(corpus["forget_mode_hidden"], only=("events", "rollback"))}
    assert rows["events: seen from outside CS"].figure.startswith("3 events (sign changes 2, kinks in v")
    rollback = rows["rollback: FMU state CS"]
    assert rollback.verdict == FAIL and "around 3 events" in rollback.figure and "no mode change seen" in rollback.figure
    assert "restoring the state saved at t = " in rollback.message


def test_no_row_kind_passes_a_run_that_exercised_nothing(corpus, capsys):
    """k_u = 0: no input moves the cart. Every dynamic row kind is inconclusive with the
    reason; the command exits 3."""
    kinds = {r.name for r in dynamic(run_battery(corpus["ok"]))}
    results = dynamic(run_battery(corpus["still"]))
    assert {r.name for r in results} == kinds  # every kind the correct cart passes
    for row in results:
        assert row.verdict == INCONCLUSIVE and row.message.startswith("nothing was exercised"), row
    events = next(r for r in results if r.name.startswith("events"))
    assert "the search: no output moved with 12 stimuli (sine u 0 ± 1 V ... ramp u 0 ± 1000 V)" in events.message
    assert main(["check", str(corpus["still"]), "--only", "convergence"]) == 3
    assert "INCONCLUSIVE  convergence: h, h/2, h/4 CS" in capsys.readouterr().out


def test_the_plugin_fails_an_assertion_that_exercised_nothing(corpus):
    from pendfmu.testing import (assert_converges, assert_deterministic, assert_finite_over_inputs,
                                 assert_reset_restores, assert_state_rollback)

    still = corpus["still"]
    for check in (assert_deterministic, assert_reset_restores, assert_state_rollback, assert_converges,
                  assert_finite_over_inputs):
        with pytest.raises(AssertionError, match=r"StillCart.fmu: \w+: .* CS: INCONCLUSIVE, nothing was exercised"):
            check(still)


def test_convergence_accepts_a_stated_order_and_fails_a_lower_one(corpus):
    (at_one,) = run_battery(corpus["step_jump"], only=("convergence",), order=1)
    assert at_one.verdict == PASS and "converging at the stated order 1" in at_one.figure
    (at_four,) = run_battery(corpus["step_jump"], only=("convergence",), order=4)
    assert at_four.verdict == FAIL and "below the expected order 4" in at_four.message
    (loose,) = run_battery(corpus["step_jump"], only=("convergence",), step_rtol=0.01)
    assert loose.verdict == PASS and "of its range, tolerance 0.01" in loose.figure


def test_inputs_are_probed_by_decades_up_to_the_limit(corpus):
    target = Target(corpus["nan_above_11V"])
    assert probe_values(target, target.inputs[0]) == ([0.0, 1.0, -1.0, 10.0, -10.0, 100.0, -100.0, 1000.0, -1000.0],
                                                      False)
    (row,) = run_battery(corpus["nan_above_11V"], only=("inputs",), input_limit=10)
    assert row.verdict == PASS and row.figure == "finite, 5 runs: u 0 ± 1, 10 V by decades (no declared range)"


def _recording(path, folder, scale_x=1.0):
    """A whole recording of the cart: u (steps of 10 V), and its outputs x, v as measured."""
    from pendfmu.testing import FMURunner

    runner = FMURunner()
    t = np.arange(0, 0.5001, 1e-3)
    u = np.where((t >= 0.1) & (t < 0.3), 10.0, 0.0)
    run = runner(path, "CS", stimulus={"time": t, "u": u}, step=1e-3)
    runner.close()
    file = folder / f"recording{scale_x:g}.csv"
    np.savetxt(file, np.c_[t, u, run["x"] * scale_x, run["v"]], delimiter=",", header="time,u,x,v", comments="",
               fmt="%.17g")
    return file


def test_input_takes_a_whole_recording_and_can_compare_its_other_columns(corpus, tmp_path, capsys):
    ok = str(corpus["ok"])
    recording = _recording(corpus["ok"], tmp_path)
    assert main(["check", ok, "--input", str(recording), "--only", "events", "determinism"]) == 0
    out = capsys.readouterr().out
    assert "[recording recording1.csv, its columns x, v ignored (not inputs)" in out
    assert main(["check", ok, "--input", str(recording), "--input-reference", "--only", "reference"]) == 0
    assert re.search(r"PASS +reference: x CS", capsys.readouterr().out)
    wrong = _recording(corpus["ok"], tmp_path, scale_x=1.01)
    assert main(["check", ok, "--input", str(wrong), "--input-reference", "--only", "reference"]) == 1
    assert re.search(r"FAIL +reference: x CS", capsys.readouterr().out)
    assert main(["check", ok, "--input-reference"]) == 2
    assert "--input-reference needs --input REC.csv" in capsys.readouterr().err


def test_events_from_outside_find_kinks_and_sign_changes_but_not_what_the_input_causes():
    t = np.arange(0, 1.0001, 0.01)
    target = SimpleNamespace(outputs=[SimpleNamespace(name="v", unit="m/s", nominal=None)])
    stops = np.maximum(0.0, 1 - np.abs(t - 0.5) * 4)  # a triangle: kinks at 0.25, 0.5, 0.75
    seen = exercise.Observed(stops[:, None], [()] * len(t), np.zeros((len(t), 1)))
    assert exercise.events(target, seen).kinds == {"kinks in v": [26, 51, 76]}
    smooth = exercise.Observed(np.sin(2 * np.pi * t)[:, None], [()] * len(t), np.zeros((len(t), 1)))
    assert exercise.events(target, smooth).kinds == {"sign changes": [51]}
    # the same kinks made by the input (a triangle input followed by the output) are no events
    followed = exercise.Observed(stops[:, None], [()] * len(t), stops[:, None])
    assert exercise.events(target, followed).kinds == {}
    moving = exercise.Observed(np.c_[t, np.zeros_like(t)], [()] * len(t), np.zeros((len(t), 0)))
    assert list(exercise.moved(moving.rows)) == [True, False]
