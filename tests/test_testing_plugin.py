"""The pytest plugin pendfmu.testing: its fixture runs an FMU as CS or ME on a stimulus or a
recording, each assertion helper passes on a correct FMU and fails on the BrokenCart built
with the bug its check is made for, with a message naming the variable, the time and the
size; the parametrization's ids and skips; the plugin loads in a pytest run of its own."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import numpy as np
import pytest

from broken.build import build as build_broken
from pendfmu.fmubuild import ensure_fmu
from pendfmu.testing import (Run, assert_calls_rejected, assert_converges, assert_deterministic,
                             assert_finite_over_inputs, assert_matches, assert_reset_restores, assert_state_rollback,
                             assert_valid, fmus_and_interfaces)


@pytest.fixture(scope="module")
def broken(tmp_path_factory):
    folder = tmp_path_factory.mktemp("broken")
    return {variant: build_broken(variant, folder) for variant in ("ok", "state", "reset", "step", "nan")}


def test_runner_gives_outputs_by_name_in_both_interfaces_and_frees_its_instances(fmu_runner):
    cart = ensure_fmu("Cart")
    runs = [fmu_runner(cart, kind, stimulus={"I": 1.5}, parameters={"v0": 0.3}, stop=0.1, step=1e-3,
                       outputs=["x", "v", "mode"]) for kind in ("CS", "ME")]
    for run in runs:
        assert run.time.shape == run["x"].shape == (101,) and run.time[-1] == pytest.approx(0.1)
        assert run["v"][0] == 0.3 and np.all(np.isfinite(run["x"])) and run["x"][-1] > 0
    assert np.max(np.abs(runs[0]["x"] - runs[1]["x"])) < 1e-6
    assert fmu_runner._open == []  # a run frees its instance; open() ones are freed at teardown
    unit = fmu_runner.open(cart, "ME")
    assert fmu_runner._open == [unit]


def test_runner_holds_a_sampled_stimulus_and_reads_a_recording(fmu_runner, broken, tmp_path):
    times = np.arange(0, 0.201, 0.05)
    u = np.array([0.0, 4.0, 4.0, -4.0, 0.0])
    sampled = fmu_runner(broken["ok"], stimulus={"time": times, "u": u}, step=0.01)
    assert sampled.time[-1] == pytest.approx(0.2) and len(sampled.time) == 21
    by_function = fmu_runner(broken["ok"], stimulus={"u": lambda t: u[min(4, int(t / 0.05 + 1e-9))]}, stop=0.2,
                             step=0.01)
    assert np.array_equal(sampled["x"], by_function["x"])
    with pytest.raises(KeyError, match="'I' is not a Real input of BrokenCart_ok.fmu"):
        fmu_runner(broken["ok"], stimulus={"I": 1.0})

    from pendfmu.recording import Recording

    recording = Recording(None, times, {"I": np.full(5, 1.5)})  # the rig's names: I drives the Cart
    run = fmu_runner(ensure_fmu("Cart"), "CS", recording=recording)
    assert run.time[-1] == pytest.approx(0.2) and run["x"][-1] > 0
    csv = tmp_path / "u.csv"  # not the rig's names: read as a plain CSV, time first; x is not an input
    csv.write_text("time,u,x\n" + "".join(f"{a},{b},0\n" for a, b in zip(times, u)))
    assert np.array_equal(fmu_runner(broken["ok"], recording=csv, step=0.01)["x"], sampled["x"])


def test_each_helper_passes_on_the_correct_cart_and_fails_on_its_bug(broken):
    ok = broken["ok"]
    assert_valid(ok)
    assert_deterministic(ok)
    assert_reset_restores(ok, parameter="m", value=1.25)
    assert_state_rollback(ok)
    assert_converges(ok)
    assert_finite_over_inputs(ok)
    with pytest.raises(AssertionError) as state:
        assert_state_rollback(broken["state"])
    assert "BrokenCart_state.fmu: rollback: FMU state CS: restoring the state saved at t = " in str(state.value)
    assert "max difference" in str(state.value)
    with pytest.raises(AssertionError) as reset:
        assert_reset_restores(broken["reset"], parameter="m", value=1.25)
    assert "m set to 1.25 after fmi2Reset does not act like a fresh instance" in str(reset.value)
    with pytest.raises(AssertionError, match="the result moves with the communication step: a changes by"):
        assert_converges(broken["step"])
    with pytest.raises(AssertionError, match=r"output margin turned nan at t = 0 s"):
        assert_finite_over_inputs(broken["nan"])
    with pytest.raises(AssertionError, match="has no ModelExchange interface"):
        assert_deterministic(ok, "ME")
    with pytest.raises(AssertionError, match="absent.fmu: no such FMU file"):
        assert_valid(ok.parent / "absent.fmu")


def test_calls_rejected_passes_on_the_cart(broken):
    assert_calls_rejected(ensure_fmu("Cart"), "CS")


def test_matches_a_tube_and_names_variable_time_and_size():
    t = np.linspace(0, 1, 101)
    reference = {"time": t, "x": np.where(t < 0.5, 0.0, 1.0)}
    assert_matches(Run(t, {"x": reference["x"].copy()}), reference)
    late = Run(t, {"x": np.where(t < 0.52, 0.0, 1.0)})  # a step 20 ms late: only a time tolerance covers it
    with pytest.raises(AssertionError) as caught:
        assert_matches(late, reference, atol=1e-3)
    assert str(caught.value).startswith("x at t = 0.5 s: 0 is outside the reference's [0.999, 1.001] by 0.999")
    assert_matches(late, reference, atol=1e-3, ttol=0.025)
    assert_matches(Run(t, {"x": reference["x"] * 1.01}), reference, rtol=0.011)
    with pytest.raises(AssertionError, match="no variable in common"):
        assert_matches(Run(t, {"v": t}), reference)


def test_parametrization_ids_and_skips(broken, tmp_path):
    params = fmus_and_interfaces([ensure_fmu("Cart"), broken["ok"], tmp_path / "Later.fmu"])
    assert [p.id for p in params] == ["Cart-CS", "Cart-ME", "BrokenCart_ok-CS", "BrokenCart_ok-ME", "Later-CS",
                                      "Later-ME"]
    skipped = {p.id: p.marks[0].kwargs["reason"] for p in params if p.marks}
    assert skipped == {"BrokenCart_ok-ME": "BrokenCart_ok.fmu has no ModelExchange interface"}
    assert params[0].values == (ensure_fmu("Cart"), "CS")


def test_a_failing_helper_reads_as_a_pytest_failure(broken, tmp_path):
    """Run as a user would: pytest with -p pendfmu.testing on a test file of its own."""
    (tmp_path / "test_user.py").write_text(textwrap.dedent(f"""
        from pendfmu.testing import assert_state_rollback

        def test_rollback():
            assert_state_rollback({str(broken["state"])!r})

        def test_runner(fmu_runner):
            assert fmu_runner({str(broken["ok"])!r}, stop=0.1)["x"].shape == (26,)
        """))
    done = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "pendfmu.testing", "-p", "no:cacheprovider",
                           "test_user.py"], cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert done.returncode == 1, done.stdout + done.stderr
    assert "1 failed, 1 passed" in done.stdout
    assert "AssertionError: BrokenCart_state.fmu: rollback: FMU state CS: restoring the state saved" in done.stdout


def test_deterministic_names_the_first_difference(broken, monkeypatch):
    """No BrokenCart is nondeterministic: the second fresh run is perturbed here instead."""
    from pendfmu.check import determinism

    real, calls = determinism.fresh_run, []

    def drifting(target, kind, parameters=None):
        rows = real(target, kind, parameters)
        calls.append(kind)
        if len(calls) == 2:
            rows[40:, 0] += 1e-9
        return rows

    monkeypatch.setattr(determinism, "fresh_run", drifting)
    with pytest.raises(AssertionError, match=r"two fresh instances with the same inputs differ: x at t = 0.16 s"):
        assert_deterministic(broken["ok"])
