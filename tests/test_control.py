"""The controller designed from a fit (issue 27): the sampled law in Python, its FMU, and the
closed loop around the independent reference simulator (tests/control_loop.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pendfmu.components import rig_defaults
from pendfmu.control import Controller, Options, Weights, design
from pendfmu.control.export import fmu_parameters
from pendfmu.simulator import ComponentFMU

T_S = 1e-3
DPHI = 2 * math.pi / 1024


def readings(n: int, turns: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """Quantized encoder readings of a pendulum swinging up through upright and over (both of
    the law's modes, phi from hanging to past upright and `turns` full turns added), the cart
    moving: what the law must handle, not a trajectory of any rig."""
    t = T_S * np.arange(n)
    phi = math.pi + 3.6 * np.sin(2 * math.pi * 0.8 * t) * np.minimum(1.0, t) + 2 * math.pi * turns
    x = 0.05 * np.sin(3.0 * t)
    dx = 2 * math.pi / (1024 * 628.3)
    return dx * np.round(x / dx), DPHI * np.round(phi / DPHI)


class FMULaw:
    """The RigController FMU as a sampled law: `law(x, phi)` sets the readings at the sample's
    communication point, reads I_c and steps to the next sample (Co-Simulation, FMI 2.0)."""

    def __init__(self, parameters: dict, x_ref: float = 0.0):
        self.fmu = ComponentFMU("RigController", parameters)
        self.x_ref, self.k = x_ref, 0

    def __call__(self, x: float, phi: float) -> float:
        self.fmu.set(x=x, phi=phi, x_ref=self.x_ref)
        I_c = self.fmu.get("I_c")[0]
        self.fmu.time = self.k * T_S  # communication points by multiplication, as masters do
        self.fmu.step(T_S)
        self.k += 1
        return I_c

    def __enter__(self) -> FMULaw:
        return self

    def __exit__(self, *exc) -> None:
        self.fmu.free()


@pytest.mark.parametrize("eta, compensation", [(0.4, True), (0.75, True), (0.4, False)])
def test_fmu_equals_the_python_law_sample_by_sample(eta, compensation):
    params = {**rig_defaults(), "eta": eta}
    the_design = design(params, Options(task="swing-up", compensation=compensation))
    assert the_design.axis == (eta <= 0.5)
    x, phi = readings(2500)
    law = Controller(the_design)
    python = np.array([law.step(x_k, phi_k, 0.01) for x_k, phi_k in zip(x, phi)])
    with FMULaw(fmu_parameters(the_design), x_ref=0.01) as law_fmu:
        fmu = np.array([law_fmu(x_k, phi_k) for x_k, phi_k in zip(x, phi)])
    assert np.ptp(python) > 1.0  # the law is exercised, not resting at 0
    np.testing.assert_allclose(fmu, python, rtol=0, atol=1e-9)


def test_table_defaults_are_the_reference_rig():
    """The RigController's start values are MODEL.md's reference rig, as its design has them,
    and that design's gains and swing-up law to the table's 6 digits: the FMU as built is a
    controller of that rig (a changed design must be copied into the table)."""
    from pendfmu.components import RIG_CONTROLLER

    designed = fmu_parameters(design(rig_defaults()))
    for name in ("M", "m_p", "l", "J_p", "g", "eta", "A_back", "k_F", "k_fwc", "F_Kc", "F_Sc", "k_fwp", "T_i",
                 "dIdt_max", "T_s", "I_max", "x_max"):
        assert RIG_CONTROLLER.variable(name).start == pytest.approx(designed[name], rel=1e-12), name
    for name, value in designed.items():
        assert RIG_CONTROLLER.variable(name).start == pytest.approx(value, rel=1e-5), name


# ------------------------------------------------ closed loop around the reference simulator
# The criteria are over the last 10 s of 20-25 s runs; the suite cannot afford them
# (the reference simulator takes ~1.5 s of CPU per simulated second), so these runs are
# short and judge the last seconds: the full runs are scripts/control_table.py.

def closed_loop(seed: int, task: str, phi0: float, duration: float, fmu: bool = False) -> dict[str, float]:
    """The controller designed from drawn rig `seed`'s true values (the law in Python, or its
    FMU), in closed loop with the reference simulator of that rig, quantized encoders, 1 ms, +-5 A."""
    from control_loop import close_loop, verdict
    from reference_rig import DEFAULTS

    from pendfmu.virtual_rig import draw_truth

    truth = {**rig_defaults(), **draw_truth(seed)[0]}
    the_design = design(truth, Options(task=task))
    law = FMULaw(fmu_parameters(the_design)) if fmu else Controller(the_design).step
    try:
        run = close_loop({k: v for k, v in truth.items() if k in DEFAULTS}, law, T_s=T_S, duration=duration,
                         phi0=phi0, dx=2 * math.pi / (1024 * truth["k_D"]))
    finally:
        if fmu:
            law.fmu.free()
    assert np.max(np.abs(run["I_c"])) <= 5.0
    return verdict(run, window=duration / 2)


def test_balance_from_a_tenth_of_a_radian_on_a_self_locking_rig():
    figures = closed_loop(1, "balance", 0.1, duration=3.0)  # drawn rig 1: eta 0.36
    assert figures["capture"] <= 1.0, figures
    assert figures["phi_steps"] <= 1.0 and figures["x"] <= 0.010 and figures["I_c"] <= 1.0, figures
    assert figures["x_peak"] <= 0.4, figures


def test_swing_up_from_hanging_on_a_back_drivable_rig():
    """The FMU swings drawn rig 0 (eta 0.59) up and holds it, within the track. The RMS
    figures after capture want seconds of settling this run cannot afford (scripts/control_table.py
    has them over the last 10 s of 20 s); the balance test holds them for a caught pendulum."""
    figures = closed_loop(0, "swing-up", math.pi, duration=6.5, fmu=True)
    assert figures["capture"] <= 6.0, figures
    assert figures["x_peak"] <= 0.4, figures


# ----------------------------------------------------------------------- pendfmu control

def result_file(folder, **parameters) -> str:
    """A result file of `pendfmu fit` as the reader takes it (parameters and the fit's stage)."""
    import json

    path = folder / "fit.json"
    path.write_text(json.dumps({"parameters": parameters, "fit": {"stage": "all"}}))
    return str(path)


@pytest.mark.parametrize("extra, says", [
    (["--weights", "q=1"], "--weights: 'q=1': the name must be one of"),
    (["--weights", "x=abc"], "--weights: 'x=abc': the scale 'abc' is not a number"),
    (["--sample-time", "-1"], "--sample-time: -1.0 must be a positive number"),
    (["--current-limit", "nan"], "--current-limit: nan must be a positive number"),
])
def test_control_refuses_bad_options_in_one_line(tmp_path, capsys, extra, says):
    from pendfmu.cli import main

    code = main(["control", result_file(tmp_path, eta=0.4), "--out", str(tmp_path / "out"), *extra])
    error = capsys.readouterr().err.strip()
    assert code == 2 and says in error and "\n" not in error
    assert not (tmp_path / "out").exists()


def test_control_refuses_a_result_with_a_non_number(tmp_path, capsys):
    from pendfmu.cli import main

    code = main(["control", result_file(tmp_path, eta="fast"), "--out", str(tmp_path / "out")])
    assert code == 2 and "eta = 'fast' is not a finite number" in capsys.readouterr().err


def test_design_reads_the_fit_and_the_sidecars(tmp_path):
    import json
    from types import SimpleNamespace

    from pendfmu.control.report import design_from_result

    (tmp_path / "run.csv").write_text("time,x\n0,0\n")
    (tmp_path / "run.json").write_text(json.dumps({"signals": {"x": {"resolution": 2e-5}}}))
    path = tmp_path / "fit.json"
    path.write_text(json.dumps({"parameters": {"eta": 0.7, "F_Kc": 5.0, "k_fwc": 20.0}, "fit": {"stage": "all"},
                                "provenance": {"inputs": [{"path": str(tmp_path / "run.csv")}]}}))
    args = SimpleNamespace(task="swing-up", sample_time=2e-3, current_limit=4.0, track=0.3, weights=["x=0.1"],
                           no_compensation=True, dx=None, dphi=None)
    the_design, _, notes = design_from_result(str(path), args)
    assert not the_design.axis and the_design.rig.F_Kc == 5.0 and the_design.rig.k_fwc == 20.0
    assert (the_design.T_s, the_design.I_max, the_design.x_max, the_design.compensation) == (2e-3, 4.0, 0.3, False)
    assert "encoder resolution of x: the sidecars" in notes and "encoder resolution of phi: MODEL.md" in notes
    # the sidecar's resolution is the estimator's (not MODEL.md's 9.8e-6 m)
    values = dict(rig_defaults(), eta=0.7, F_Kc=5.0, k_fwc=20.0)
    options = dict(task="swing-up", T_s=2e-3, weights=Weights(x=0.1), compensation=False, I_max=4.0, x_max=0.3)
    assert design(values, Options(dx=2e-5, **options)).L == the_design.L
    assert design(values, Options(**options)).L != the_design.L
