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


def readings(n: int, turns: int = 2, quantized: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Quantized encoder readings of a pendulum swinging up through upright and over (both of
    the law's modes, phi from hanging to past upright and `turns` full turns added), the cart
    moving: what the law must handle, not a trajectory of any rig."""
    t = T_S * np.arange(n)
    phi = math.pi + 3.6 * np.sin(2 * math.pi * 0.8 * t) * np.minimum(1.0, t) + 2 * math.pi * turns
    x = 0.05 * np.sin(3.0 * t)
    dx = 2 * math.pi / (1024 * 628.3)
    return (dx * np.round(x / dx), DPHI * np.round(phi / DPHI)) if quantized else (x, phi)


class FMULaw:
    """The RigController FMU as a sampled law: `law(x, phi)` sets the readings at the sample's
    communication point, reads I_c and steps to the next sample (Co-Simulation, FMI 2.0)."""

    def __init__(self, parameters: dict, x_ref: float = 0.0, fmu=None):
        self.fmu = ComponentFMU("RigController", parameters, fmu=fmu)
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


@pytest.mark.parametrize("eta, compensation, quantum, track", [
    (0.4, True, False, 0.4), (0.75, True, False, 0.4), (0.4, False, False, 0.4), (0.75, True, True, 0.4),
    (0.4, True, False, 0.03)])
def test_fmu_equals_the_python_law_sample_by_sample(eta, compensation, quantum, track):
    """The same commands to 1e-9 A; with `quantum` the readings are continuous and both round
    them to the encoders' steps themselves (x_quantum, phi_quantum: the verification's encoders);
    on a 3 cm track the readings' 5 cm swings reach the track limit's braking."""
    import dataclasses

    params = {**rig_defaults(), "eta": eta}
    the_design = design(params, Options(task="swing-up", compensation=compensation, x_max=track))
    assert the_design.axis == (eta <= 0.5)
    x, phi = readings(2500, quantized=not quantum)
    if quantum:
        the_design = dataclasses.replace(the_design, x_quantum=2 * math.pi / (1024 * 628.3), phi_quantum=DPHI)
    law = Controller(the_design)
    python = np.array([law.step(x_k, phi_k, 0.01) for x_k, phi_k in zip(x, phi)])
    with FMULaw(fmu_parameters(the_design), x_ref=0.01) as law_fmu:
        fmu = np.array([law_fmu(x_k, phi_k) for x_k, phi_k in zip(x, phi)])
    assert np.ptp(python) > 1.0  # the law is exercised, not resting at 0
    np.testing.assert_allclose(fmu, python, rtol=0, atol=1e-9)
    if quantum:  # the rounding happened: unrounded readings command otherwise
        unrounded = Controller(dataclasses.replace(the_design, x_quantum=0.0, phi_quantum=0.0))
        assert np.max(np.abs(python - [unrounded.step(x_k, phi_k, 0.01) for x_k, phi_k in zip(x, phi)])) > 1e-3
    if track < 0.4:  # the braking happened: on the long track the law commands otherwise
        long = Controller(dataclasses.replace(the_design, x_max=0.4))
        assert np.max(np.abs(python - [long.step(x_k, phi_k, 0.01) for x_k, phi_k in zip(x, phi)])) > 1e-3


def test_a_stuck_self_locking_cart_wanted_to_push_little_holds_itself_in_both_twins():
    """Balancing on a self-locking screw, a still cart (x constant) under a pendulum that
    leans a few encoder steps to and fro: while the wanted force is below F_ramp the command
    is exactly 0 A (law.Controller.holds), beyond it the breakaway's current flows; the FMU
    commands the same to 1e-9 A. On a back-drivable screw nothing holds."""
    for eta, holds in ((0.4, True), (0.75, False)):
        the_design = design({**rig_defaults(), "eta": eta}, Options(task="balance"))
        t = T_S * np.arange(3000)
        phi = DPHI * np.round(0.02 * np.sin(2 * math.pi * 0.5 * t) * np.exp(-t) / DPHI)
        x = np.zeros_like(t)
        law = Controller(the_design)
        python = np.array([law.step(x_k, phi_k) for x_k, phi_k in zip(x, phi)])
        with FMULaw(fmu_parameters(the_design)) as law_fmu:
            fmu = np.array([law_fmu(x_k, phi_k) for x_k, phi_k in zip(x, phi)])
        np.testing.assert_allclose(fmu, python, rtol=0, atol=1e-9)
        held = python[500:] == 0.0
        assert held.any() == holds and (not holds or (~held).any()), (eta, held.mean())


def test_table_defaults_are_the_reference_rig():
    """The RigController's start values are the reference rig (docs/user-guide/model.md), as
    its design has them, and that design's gains and swing-up law to the table's 6 digits:
    the FMU as built is a controller of that rig (a changed design must be copied into the
    table)."""
    from pendfmu.components import RIG_CONTROLLER

    designed = fmu_parameters(design(rig_defaults()))
    for name in ("M", "m_p", "l", "J_p", "g", "eta", "A_back", "k_F", "k_fwc", "F_Kc", "F_Sc", "k_fwp", "T_i",
                 "dIdt_max", "T_s", "I_max", "x_max"):
        assert RIG_CONTROLLER.variable(name).start == pytest.approx(designed[name], rel=1e-12), name
    for name, value in designed.items():
        assert RIG_CONTROLLER.variable(name).start == pytest.approx(value, rel=1e-5), name


# ------------------------------------------------ closed loop around the reference simulator
# The issue's criteria are over the last 10 s of 20-25 s runs; the suite cannot afford them
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


# Each closed-loop test also runs pendfmu's own verification of the same design and rig
# (verify.py: its FMUs and master) and compares. Not sample by sample: a reading one count
# apart (x's count is 10 um) changes the command, and the two simulators' stick-slip events
# differ by far less than a count but not by nothing, so the runs part after a few samples.
# What survives is the large motion: the cart's excursion (measured 0.2 % apart in balance,
# 1.1 % in swing-up) and the swing that is caught (capture 0.04 s apart; a swing more or
# less would be half a period, 0.5 s, apart).

def test_balance_from_a_tenth_of_a_radian_on_a_self_locking_rig(tmp_path):
    figures = closed_loop(1, "balance", 0.1, duration=3.0)  # drawn rig 1: eta 0.36
    assert figures["capture"] <= 1.0, figures
    assert figures["phi_steps"] <= 1.0 and figures["x"] <= 0.010 and figures["I_c"] <= 1.0, figures
    assert figures["x_peak"] <= 0.4, figures
    own = verified(1, "balance", 3.0, tmp_path)
    assert own["capture"] <= 1.0 and own["x_peak"] == pytest.approx(figures["x_peak"], rel=0.02), (own, figures)


def test_swing_up_from_hanging_on_a_back_drivable_rig(tmp_path):
    """The FMU swings drawn rig 0 (eta 0.59) up and holds it, within the track. The RMS
    figures after capture want seconds of settling this run cannot afford (scripts/control_table.py
    has them over the last 10 s of 20 s); the balance test holds them for a caught pendulum."""
    figures = closed_loop(0, "swing-up", math.pi, duration=6.5, fmu=True)
    assert figures["capture"] <= 6.0, figures
    assert figures["x_peak"] <= 0.4, figures
    own = verified(0, "swing-up", 6.5, tmp_path)
    assert own["capture"] == pytest.approx(figures["capture"], abs=0.25), (own, figures)
    assert own["x_peak"] == pytest.approx(figures["x_peak"], rel=0.03), (own, figures)


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
    (["--require", "q=1"], "--require: 'q=1': the name must be one of capture, phi, x, I, track"),
    (["--require", "x=-1"], "--require: 'x=-1': must be a positive number"),
    (["--tune", "--no-verify"], "--tune: tunes by the verification's runs; --no-verify switches them off"),
    (["--duration", "0.5"], "--duration: 0.5 s: more than a thousand samples"),
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
    assert "encoder resolution of x: the sidecars" in notes and "encoder resolution of phi: the reference rig's encoders" in notes
    # the sidecar's resolution is the estimator's (not the reference rig's 9.8e-6 m)
    values = dict(rig_defaults(), eta=0.7, F_Kc=5.0, k_fwc=20.0)
    options = dict(task="swing-up", T_s=2e-3, weights=Weights(x=0.1), compensation=False, I_max=4.0, x_max=0.3)
    assert design(values, Options(dx=2e-5, **options)).L == the_design.L
    assert design(values, Options(**options)).L != the_design.L


# ------------------------------------------------------ verification before the rig (verify.py)

def test_the_figures_of_a_run_are_the_issues():
    """judge() on signals whose figures are known: a pendulum away from upright until 4 s, then
    0.5 encoder steps off; the cart 3 mm off with a 50 mm excursion; a 0.2 A current."""
    from pendfmu.control.verify import judge

    time = np.arange(0, 20.0005, 1e-3)
    phi = np.where(time < 4.0, 0.5, 0.5 * DPHI) + 4 * math.pi  # whole turns do not count
    x = np.where(time < 1.0, 0.05, 0.003)
    figures = judge(time, x, phi, np.full_like(time, -0.2), DPHI)
    assert figures["capture"] == pytest.approx(4.0, abs=1e-9)
    assert figures["phi_steps"] == pytest.approx(0.5, rel=1e-9)
    assert figures["x_rms"] == pytest.approx(0.003, rel=1e-12) and figures["I_rms"] == pytest.approx(0.2, rel=1e-12)
    assert figures["x_peak"] == 0.05
    assert judge(time, x, np.full_like(time, math.pi), 0 * time, DPHI)["capture"] is None  # never caught


def verified(seed: int, task: str, duration: float, folder) -> dict:
    """pendfmu's own verification run (its rig FMUs, master and RigController FMU) of the
    design from drawn rig `seed`'s true values: what closed_loop runs on the reference."""
    from pendfmu.control.report import write_loop_ssp
    from pendfmu.control.verify import plan, simulate
    from pendfmu.virtual_rig import draw_truth

    truth = {**rig_defaults(), **draw_truth(seed)[0]}
    the_design = design(truth, Options(task=task))
    ssp = write_loop_ssp(the_design, truth, folder, built=False)  # the design as parameter values (plan)
    runs = plan(the_design, truth, [], ssp, duration, both_compensations=False)
    outcome = simulate(next(r for r in runs if r.task == task))
    assert not outcome.failure, outcome.failure
    return outcome.figures()


@pytest.fixture(scope="module")
def bootstrapped(tmp_path_factory):
    """`pendfmu fit all` with 8 bootstrap replicates on a short current and cart recording
    of a rig away from the reference rig (the pendulum left out: its refits take seconds each)."""
    import json

    from pendfmu.cli import main
    from pendfmu.virtual_rig import Trial, steps, write_experiments

    root = tmp_path_factory.mktemp("bootstrapped")
    truth = {"F_Kc": 6.5, "k_fwc": 36.0, "T_i": 4e-4}
    write_experiments(root / "rec", truth, seed=2, experiments=[
        Trial("current-steps", "current", 0.008, 20e-6, ("I_c", "I"), steps((0, 0.0), (1e-3, 2.0), (5e-3, -1.0))),
        Trial("cart-startup", "cart", 0.4, 2e-4, ("I_c", "I", "x", "v"), steps((0, 0.0), (0.02, 3.0), (0.2, 0.0)),
              sidecar_parameters={"m_p": 0.0}, known_initial=("x", "v"))])
    out = root / "fit.json"
    assert main(["fit", "all", str(root / "rec"), "--out", str(out), "--replicates", "8", "--generations", "3",
                 "--workers", "1"]) == 0
    return out, json.loads(out.read_text())


def test_the_result_keeps_each_replicates_rig(bootstrapped):
    """Per replicate, the values its refits found: the current loop's and the cart's of the
    same replicate (the chained bootstrap), around the estimate, and read back as written."""
    from pendfmu.fitting.result import read_result

    path, document = bootstrapped
    rows = document["replicates"]
    assert len(rows) == 8
    fitted = {"T_i", "dIdt_max", "eta", "k_fwc", "F_Kc", "F_Sc"}
    assert all(fitted <= set(row) for row in rows)
    for name in ("T_i", "k_fwc", "F_Kc"):
        values = np.array([row[name] for row in rows])
        assert np.ptp(values) > 0 and np.all(np.abs(values / document["parameters"][name] - 1) < 0.2), name
    assert read_result(path).replicates == rows


def test_control_verifies_the_design_on_every_replicate(bootstrapped, tmp_path, capsys):
    """`pendfmu control` runs balance on the identified model and on each of the 8 replicates,
    compensation on and off; verification.json has each run, report.md the table."""
    import json

    from pendfmu.cli import main

    path, document = bootstrapped
    out = tmp_path / "ctl"
    assert main(["control", str(path), "--out", str(out), "--duration", "3", "--workers", "1"]) == 0
    printed = capsys.readouterr().out
    assert "the identified model and 8 bootstrap replicates" in printed
    checked = json.loads((out / "verification.json").read_text())
    assert len(checked["runs"]) == 2 * 9
    assert {(row["task"], row["compensation"], row["replicates"]) for row in checked["summary"]} == \
        {("balance", True, 8), ("balance", False, 8)}
    on = next(row for row in checked["summary"] if row["compensation"])
    assert on["identified"]["meets"] and on["identified"]["capture"] <= 1.0
    assert 0 <= on["replicates_meeting"] <= 8 and on["success_rate"] == on["replicates_meeting"] / 8
    runs = [run for run in checked["runs"] if run["compensation"]]
    assert len({run["x_peak"] for run in runs}) > 1  # the replicates' rigs differ, and so do their runs
    report = (out / "report.md").read_text()
    assert "## Verification in closed loop" in report and "worst of 8 replicates" in report
    assert (out / "verification.png").stat().st_size > 10_000
    # the weights it was designed with, to design with again (a tuning's are what --tune chose)
    assert json.loads((out / "design.json").read_text())["weights"] == {"x": 0.02, "phi": 0.01, "v": 0.5, "w": 1.0,
                                                                        "a": 1.0}
    assert "LQR weights: x=0.02 phi=0.01 v=0.5 w=1 a=1" in report


def test_the_replicates_rigs_reach_the_runs(bootstrapped, tmp_path):
    """plan(): each replicate's run carries that replicate's values (not the estimate's)."""
    from pendfmu.control.report import write_loop_ssp
    from pendfmu.control.verify import plan

    _, document = bootstrapped
    values = {**rig_defaults(), **document["parameters"]}
    ssp = write_loop_ssp(design(values), values, tmp_path, built=False)
    runs = plan(design(values), values, document["replicates"], ssp, 3.0)
    by_rig = {run.rig: run.values for run in runs if run.compensation}
    assert by_rig["identified"]["Cart.F_Kc"] == values["F_Kc"]
    for b, row in enumerate(document["replicates"]):
        assert by_rig[str(b)]["Cart.F_Kc"] == row["F_Kc"] and by_rig[str(b)]["CurrentLoop.T_i"] == row["T_i"]


def test_tuning_meets_a_requirement_the_default_weights_miss(bootstrapped, tmp_path):
    """The cart's RMS position at 0.7 times what the default design reaches on its worst rig
    (identified model and 8 replicates, balance from 0.1 rad, 3 s runs): the default misses
    it; the tuned weights meet it on every rig, and they are other weights."""
    import dataclasses

    from pendfmu.control.report import write_loop_ssp
    from pendfmu.control.tuning import score, tune
    from pendfmu.control.verify import Requirements, verify

    _, document = bootstrapped
    values = {**rig_defaults(), **document["parameters"]}
    options = Options()
    default = design(values, options)
    ssp = write_loop_ssp(default, values, tmp_path, built=False)
    before = verify(default, values, document["replicates"], ssp, 3.0, workers=1)
    worst_x = max(o.x_rms for o in before.outcomes if o.run.compensation)
    required = Requirements(x_rms=0.7 * worst_x)
    own = [o for o in before.outcomes if o.run.compensation]
    assert score(own, required, default.x_max)[0] > 0  # the default misses it
    tuned = tune(values, options, document["replicates"], ssp, 3.0, required, workers=1)
    assert score(tuned.verification.outcomes, required, default.x_max) [0] == 0, tuned.tried[-3:]
    assert len(tuned.verification.outcomes) == 9 and tuned.weights != options.weights
    assert dataclasses.asdict(tuned.weights) == tuned.tried[[s for _, s in tuned.tried].index(
        min(s for _, s in tuned.tried))][0]  # the best design tried is the one kept


def test_the_swing_up_stays_within_a_short_track(tmp_path):
    """Drawn rig 0's swing-up uses 270 mm of its 400 mm half-track (verification run); on a
    200 mm half-track the law brakes before the end (within_track) and the cart stays inside,
    in pendfmu's closed loop and in the independent reference simulator's."""
    from control_loop import close_loop
    from reference_rig import DEFAULTS

    from pendfmu.control.report import write_loop_ssp
    from pendfmu.control.verify import plan, simulate
    from pendfmu.virtual_rig import draw_truth

    truth = {**rig_defaults(), **draw_truth(0)[0]}
    peaks = {}
    for track in (0.4, 0.2):
        the_design = design(truth, Options(task="swing-up", x_max=track))
        ssp = write_loop_ssp(the_design, truth, tmp_path, built=False)
        run = next(r for r in plan(the_design, truth, [], ssp, 8.0, both_compensations=False) if r.task == "swing-up")
        peaks[track] = simulate(run).x_peak
    assert peaks[0.4] > 0.2 >= peaks[0.2], peaks
    reference = close_loop({k: v for k, v in truth.items() if k in DEFAULTS},
                           Controller(design(truth, Options(task="swing-up", x_max=0.2))).step, T_s=T_S,
                           duration=4.0, phi0=math.pi, dx=2 * math.pi / (1024 * truth["k_D"]))
    assert np.max(np.abs(reference["x"])) <= 0.2


# ------------------------------------------- the issue's done-when on two rigs (make acceptance)
# Per rig: the paper's recordings, `pendfmu fit all` (bootstrap), `pendfmu control --task swing-up`,
# and the exported RigController.fmu (no parameter set from outside: its start values are the
# design) in closed loop with the reference simulator of the true rig, 20 s from 0.1 rad and from
# hanging. About 8 minutes a rig: the fit, and 40 simulated seconds at 1.5 s of CPU each.
# scripts/control_table.py does the same for the ten rigs of the table in docs/user-guide/fit-to-controller.md.
ISSUE = {"capture": 12.0, "phi_steps": 1.0, "x": 0.010, "I_c": 1.0, "x_peak": 0.4}


@pytest.mark.acceptance
@pytest.mark.parametrize("seed", [1, 0, 3], ids=["self-locking", "back-drivable", "self-locking-hunting"])
def test_the_exported_controller_meets_the_issues_criteria_on_a_fitted_rig(seed, tmp_path):
    """The issue's done-when on drawn rigs, as a user gets there: `pendfmu rig`, `pendfmu fit
    all`, `pendfmu control --tune` (the weights tuned until its own verification over the
    fit's replicates meets the requirements), then the exported FMU around the independent
    reference simulator of the true rig for 20 s, from 0.1 rad and from hanging. Rig 3's
    cart, with the default weights, slipped to and fro after the swing-up's catch at 1.08 A
    RMS (6 of its 24 replicates missed too); tuned (x 0.02 -> 0.04 m) it meets at 0.94 A."""
    from control_loop import close_loop, verdict
    from reference_rig import DEFAULTS

    from pendfmu.cli import main
    from pendfmu.virtual_rig import draw_truth

    truth = {**rig_defaults(), **draw_truth(seed)[0]}
    assert (truth["eta"] > 0.5) == (seed == 0)
    assert main(["rig", "--seed", str(seed), "--out", str(tmp_path / "rec")]) == 0
    assert main(["fit", "all", str(tmp_path / "rec"), "--out", str(tmp_path / "fit.json")]) == 0
    assert main(["control", str(tmp_path / "fit.json"), "--out", str(tmp_path / "ctl"), "--task", "swing-up",
                 "--tune"]) == 0
    failures = {}
    for start in (0.1, math.pi):
        with FMULaw({}, fmu=tmp_path / "ctl" / "RigController.fmu") as law:
            run = close_loop({k: v for k, v in truth.items() if k in DEFAULTS}, law, T_s=T_S, duration=20.0,
                             phi0=start, dx=2 * math.pi / (1024 * truth["k_D"]))
        figures = verdict(run, window=10.0)
        missed = {k: figures[k] for k, limit in ISSUE.items() if not figures[k] <= limit}
        if missed:
            failures[start] = figures
    assert not failures, failures


def test_a_closed_loop_written_again_in_place_is_run_as_written(tmp_path):
    """verify's per-process replay: ClosedLoop.ssp of a back-drivable rig (its back-drive wiring),
    then the same path written for a self-locking rig; the second run must be the second
    system's, as a fresh process runs it (it once ran with the first system's wiring)."""
    from pendfmu.control import verify as verification
    from pendfmu.control.report import write_loop_ssp
    from pendfmu.virtual_rig import draw_truth

    def run_of(seed: int):
        truth = {**rig_defaults(), **draw_truth(seed)[0]}
        the_design = design(truth, Options())
        ssp = write_loop_ssp(the_design, truth, tmp_path, built=False)
        return next(r for r in verification.plan(the_design, truth, [], ssp, 2.0, both_compensations=False))

    verification.simulate(run_of(0))  # eta 0.59
    after = verification.simulate(run_of(1)).signals  # eta 0.36, the same path
    verification._REPLAYS.clear()
    assert verification.simulate(run_of(1)).signals == after


def test_a_runner_keeps_its_worker_processes_and_gives_what_one_process_gives(tmp_path):
    """verify.runner over two batches (a tuning's designs) on two worker processes: the same
    outcomes, in order, as the runs made here."""
    from pendfmu.control.report import write_loop_ssp
    from pendfmu.control.verify import plan, runner, simulate
    from pendfmu.virtual_rig import draw_truth

    truth = {**rig_defaults(), **draw_truth(1)[0]}
    the_design = design(truth, Options(task="swing-up"))
    runs = plan(the_design, truth, [], write_loop_ssp(the_design, truth, tmp_path, built=False), 1.0)
    here = [simulate(run).signals for run in runs]
    with runner(workers=2) as run:
        batches = [[outcome.signals for outcome in run(runs)] for _ in range(2)]
    assert len(runs) == 4 and batches == [here, here]


def test_the_verification_reads_the_encoders_the_design_was_made_for(tmp_path):
    """A rig whose sidecars give a 4096-count pendulum encoder and a 20 um cart encoder: the
    runs round the controller's inputs to those steps and count phi in them (verification once
    assumed the paper's 1024 counts whatever the recordings said)."""
    from pendfmu.control.report import write_loop_ssp
    from pendfmu.control.verify import plan

    values = rig_defaults()
    the_design = design(values, Options(dx=2e-5, dphi=2 * math.pi / 4096))
    runs = plan(the_design, values, [], write_loop_ssp(the_design, values, tmp_path, built=False), 2.0)
    assert {run.values["RigController.x_quantum"] for run in runs} == {2e-5}
    assert {run.values["RigController.phi_quantum"] for run in runs} == {run.dphi for run in runs} == {2 * math.pi / 4096}
