"""A fit that meets failing simulations penalizes, counts and reports them, and still
finds the optimum (issue 7). The failures are forced for a parameter region: every
simulation with F_Kc above 9 N raises the FMU error a real FMU would."""

from __future__ import annotations

import json

import pytest

from pendfmu.cli import main
from pendfmu.simulator import stage
from pendfmu.simulator.component import FMUError
from pendfmu.virtual_rig import Experiment, steps, write_experiments


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    out = tmp_path_factory.mktemp("failures")
    experiment = Experiment("cart", "cart", 0.4, 2e-4, ("I_c", "I", "x"), steps((0, 0.0), (0.02, 2.0), (0.25, 0.0)),
                            sidecar_parameters={"m_p": 0.0}, known_initial=("x", "v"))
    write_experiments(out, {"k_fwc": 26.0, "F_Kc": 7.0, "F_Sc": 10.5, "eta": 0.42}, seed=9, experiments=[experiment])
    return out / "cart.csv"


@pytest.fixture
def failing_region(monkeypatch):
    original = stage.StageSimulator.simulate

    def simulate(self, values, extra=()):
        if values["F_Kc"] > 9.0:
            raise FMUError("Cart at t = 0.1 s: the solution is no longer finite (forced by the test)")
        return original(self, values, extra)

    monkeypatch.setattr(stage.StageSimulator, "simulate", simulate)


def test_failures_are_penalized_counted_and_reported(recording, tmp_path, failing_region):
    out = tmp_path / "fit.json"
    # workers 1: the forced failure is patched into this process only
    assert main(["fit", "cart", str(recording), "--out", str(out), "--seed", "2", "--workers", "1"]) == 0
    result = json.loads(out.read_text())
    assert result["fit"]["failures"] > 0
    assert any("simulations failed during the fit" in note and "forced by the test" in note
               for note in result["fit"]["notes"])
    # the optimum lies outside the failing region and is still found
    assert result["parameters"]["F_Kc"] == pytest.approx(7.0, rel=0.03)
    assert result["parameters"]["k_fwc"] == pytest.approx(26.0, rel=0.03)
