"""A fit that meets failing simulations penalizes, counts and reports them, and still
finds the optimum (issue 7). The failures are forced for a parameter region: every
simulation with F_Kc above 9 N raises the FMU error a real FMU would."""

from __future__ import annotations

import json

import pytest

from pendfmu.cli import main
from pendfmu.simulator import replay
from pendfmu.simulator.component import FMUError


@pytest.fixture
def failing_region(monkeypatch):
    original = replay.Replay.simulate

    def simulate(self, values, outputs):
        if values["F_Kc"] > 9.0:
            raise FMUError("Cart at t = 0.1 s: the solution is no longer finite (forced by the test)")
        return original(self, values, outputs)

    monkeypatch.setattr(replay.Replay, "simulate", simulate)


def test_failures_are_penalized_counted_and_reported(cart_recording, tmp_path, failing_region):
    out = tmp_path / "fit.json"
    # workers 1: the forced failure is patched into this process only
    assert main(["fit", "cart", str(cart_recording), "--out", str(out), "--seed", "2", "--workers", "1"]) == 0
    result = json.loads(out.read_text())
    assert result["fit"]["failures"] > 0
    assert any("simulations failed during the fit" in note and "forced by the test" in note
               for note in result["fit"]["notes"])
    # the optimum lies outside the failing region and is still found
    assert result["parameters"]["F_Kc"] == pytest.approx(7.0, rel=0.03)
    assert result["parameters"]["k_fwc"] == pytest.approx(26.0, rel=0.03)


@pytest.fixture
def failing_in_workers(monkeypatch):
    """Every simulation with F_Kc above 9 N fails, but only in the global search's worker
    processes (forked: they inherit the patch; the fit's own process does not fail). The
    error carries no message, only where it happened, as an FMU that logs nothing gives."""
    import os

    original, parent = replay.Replay.simulate, os.getpid()

    def simulate(self, values, outputs):
        if values["F_Kc"] > 9.0 and os.getpid() != parent:
            raise FMUError("", instance="Cart", function="fmi2DoStep", time=0.1)
        return original(self, values, outputs)

    monkeypatch.setattr(replay.Replay, "simulate", simulate)


def test_failures_in_worker_processes_report_their_reason(cart_recording, tmp_path, failing_in_workers):
    """The reason of a failure in a worker process comes back with its cost: the note names
    where it failed, never "(last: )"."""
    out = tmp_path / "fit.json"
    assert main(["fit", "cart", str(cart_recording), "--out", str(out), "--seed", "2", "--workers", "2"]) == 0
    result = json.loads(out.read_text())
    assert result["fit"]["failures"] > 0
    (note,) = [note for note in result["fit"]["notes"] if "simulations failed during the fit" in note]
    assert "(last: instance Cart, function fmi2DoStep, t = 0.1 s failed: no message logged)" in note


def test_an_fmu_error_without_a_message_still_says_where():
    assert FMUError("", instance="Pendulum", function="fmi2ExitInitializationMode", time=0.0,
                    messages=["J_p too small"]).reason() == (
        "instance Pendulum, function fmi2ExitInitializationMode, t = 0 s failed: J_p too small")
    assert FMUError("").reason() == "an FMU call failed: no message logged"
    assert FMUError("Cart: said so").reason() == "Cart: said so"
