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
