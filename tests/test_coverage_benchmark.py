"""The coverage benchmark's recordings (scripts/reference_recordings.py) and truths
(scripts/coverage.py).

The benchmark is only as good as its recordings: they must be the virtual rig's own
(same drives, sensors, noise draws and sidecars) with one thing changed, the simulator.
So at a drawn truth the reference simulator and pendfmu's FMUs must agree, signal by
signal, far below a sensor step. The cart did not (by up to 0.9 encoder steps) until the
current's transients were resolved; the cart test keeps the cause in view.
"""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest

import reference_rig
from coverage_scripts import BENCHMARK
from coverage_scripts import reference_recordings as rr
from pendfmu.virtual_rig import Sensors, reference_truth, simulate_truth, write_experiments

DRAWN, ANGLE = BENCHMARK.draw_truth(0, 3)  # the drawn truth with the largest cart disagreement of 0..5
TRUTH = {**reference_truth(), **DRAWN}
SHORTER = {"pendulum-decay": 6.0, "pendulum-stiction": 8.0}  # s; both still stick and slip


def short_experiments():
    """The six stage experiments; the pendulum ones shortened (the cart ones are needed whole:
    their disagreement builds up over the run)."""
    return [dataclasses.replace(e, duration=SHORTER.get(e.name, e.duration)) for e in rr.stage_experiments(ANGLE)]


def step(name: str) -> float:
    return Sensors(TRUTH["k_D"], np.random.default_rng(0)).info()[name].resolution


@pytest.fixture(scope="module")
def simulated():
    return {e.name: (simulate_truth(e, TRUTH), rr.reference_signals(e, TRUTH)) for e in short_experiments()}


def test_current_loop_and_pendulum_agree_far_below_a_sensor_step(simulated):
    """Measured at this truth: |dI| <= 1e-7 ADC steps, |dphi| <= 3e-7 encoder steps (the
    FMUs' closed-form current loop and RK4 pendulum against DOP853 at rtol 1e-10). The
    bound, 1e-5 steps, is 30x the measured and 1e5 below the quantization: a different
    ripple phase, event rule or input interpolation would exceed it by orders."""
    for experiment in short_experiments():
        fmu, reference = simulated[experiment.name]
        for signal in ("I", "phi"):  # the measured current: ripple included, also in the cart runs
            if signal in experiment.recorded:
                gap = np.max(np.abs(fmu[signal] - reference[signal])) / step(signal)
                assert gap < 1e-5, f"{experiment.name}: max |d{signal}| = {gap:.3g} steps"


def test_cart_agrees_once_the_current_transients_are_resolved(simulated):
    """The cart is driven by the ripple-free current, which after a step relaxes with T_i
    (0.3 ms), barely longer than a 0.2 ms sample. Passed linearly interpolated between
    samples it fell short under the concave rise: the cart lost speed and kept a position
    deficit of 0.19-0.86 encoder steps against the reference (0.5 on the staircase ramp).
    That was the tool's bias, not the data's. The virtual rig's truth now co-simulates at
    20 us and the fit's stage simulator steps every unsettled sample 8 times: measured
    0.003-0.009 steps at the truths 0-2. The bound, 0.03 steps, is 3x that and 30 below
    the old gap; the linearly interpolated drive (the old way) is still shown to be the
    0.1-1 step cause it was."""
    from pendfmu.fitting.stages import make_experiment
    from pendfmu.recording import Recording

    for experiment in (e for e in short_experiments() if e.kind == "cart"):
        fmu, reference = simulated[experiment.name]
        assert np.max(np.abs(fmu["x"] - reference["x"])) / step("x") < 0.03, experiment.name
        recording = Recording(None, reference["time"], {"I_c": reference["I_c"], "x": reference["x"]},
                              parameters=dict(experiment.sidecar_parameters))
        replay = make_experiment(recording, "cart", TRUTH).replay()
        try:
            fitted_model = replay.simulate({**TRUTH, **experiment.sidecar_parameters}, ["x"])["x"]
        finally:
            replay.close()
        assert np.max(np.abs(fitted_model - reference["x"])) / step("x") < 0.03, experiment.name
    experiment = next(e for e in short_experiments() if e.name == "cart-startup-3A")
    fmu, reference = simulated[experiment.name]
    times = reference["time"]
    values = rr.reference_parameters({**TRUTH, **experiment.sidecar_parameters})
    ripple_free = reference_rig.simulate_current_loop({**values, "a_h": 0.0}, rr.held(times, reference["I_c"]),
                                                      times)["I"].to_numpy()
    with np.errstate(invalid="ignore"):  # see reference_recordings.reference_signals
        interpolated = reference_rig.simulate_cart({**values, "J_p": 0.0},
                                                   lambda t: float(np.interp(t, times, ripple_free)), times,
                                                   breakpoints=tuple(times[1:-1]))
    gap = np.max(np.abs(interpolated["x"].to_numpy() - reference["x"])) / step("x")
    assert 0.1 < gap < 1.0


@pytest.fixture(scope="module")
def folders(tmp_path_factory):
    root = tmp_path_factory.mktemp("coverage")
    experiments = short_experiments()
    write_experiments(root / "fmu", DRAWN, seed=5, experiments=experiments)
    rr.write_reference_experiments(root / "reference", DRAWN, seed=5, experiments=experiments)
    return root / "fmu", root / "reference"


def test_sidecars_and_sensor_readings_are_the_virtual_rigs(folders):
    fmu, reference = folders
    for experiment in short_experiments():
        a, b = (json.loads((f / f"{experiment.name}.json").read_text()) for f in (fmu, reference))
        assert a == b, experiment.name
    for name in ("current-steps", "pendulum-decay", "pendulum-stiction", "cart-startup-2A"):
        a, b = (np.genfromtxt(f / f"{name}.csv", delimiter=",", names=True) for f in (fmu, reference))
        assert a.dtype.names == b.dtype.names
        for column in a.dtype.names:
            if column == "x":  # 0.01 steps apart: a reading near a rounding edge may differ by one step
                assert np.max(np.abs(a[column] - b[column])) <= step("x") * (1 + 1e-9)
            else:  # the same noise draws, and true signals 1e-7 steps apart: the same readings
                assert np.array_equal(a[column], b[column]), f"{name}: {column}"
    truth = [json.loads((f / "truth.json").read_text()) for f in (fmu, reference)]
    assert truth[0]["parameters"] == truth[1]["parameters"] and truth[0]["seed"] == truth[1]["seed"] == 5
    assert truth[1]["simulator"] == "tests/reference_rig.py"


def test_truths_stay_within_the_issues_factors_with_stiction_above_coulomb():
    reference = reference_truth()
    for index in range(200):
        truth, angle = BENCHMARK.draw_truth(1, index)
        for name, value in truth.items():
            assert 0.6 <= value / reference[name] <= 1.6, (index, name)
        assert truth["F_Sc"] >= 1.2 * truth["F_Kc"] and truth["T_Sp"] >= 1.2 * truth["T_Kp"]
        assert 0.36 - 1e-12 <= abs(angle) <= 0.96 + 1e-12
    assert BENCHMARK.draw_truth(1, 7) == BENCHMARK.draw_truth(1, 7) != BENCHMARK.draw_truth(2, 7)
    assert math.isfinite(ANGLE)


def test_the_wide_draw_spans_x05_to_2_and_keeps_the_standard_one():
    """--spread wide (issue 25): every parameter x0.5-2 of the reference, stiction still at least
    1.2 times its Coulomb friction, the release angle 0.6 rad x0.5-2; the default series is the
    one `pendfmu rig --seed` has always recorded (truth (4, 0) pinned as drawn before the option)."""
    reference = reference_truth()
    factors = []
    for index in range(200):
        truth, angle = BENCHMARK.draw_truth(1, index, "wide")
        factors += [value / reference[name] for name, value in truth.items()]
        assert truth["F_Sc"] >= 1.2 * truth["F_Kc"] and truth["T_Sp"] >= 1.2 * truth["T_Kp"]
        assert 0.3 - 1e-12 <= abs(angle) <= 1.2 + 1e-12
    assert 0.5 - 1e-12 <= min(factors) < 0.55 and 1.9 < max(factors) <= 2.0 + 1e-12
    assert BENCHMARK.draw_truth(1, 7) == BENCHMARK.draw_truth(1, 7, "standard") != BENCHMARK.draw_truth(1, 7, "wide")
    assert BENCHMARK.draw_truth(4, 0)[0]["eta"] == 0.3472024289778563
    with pytest.raises(ValueError, match="spread 'wider'"):
        BENCHMARK.draw_truth(1, 7, "wider")


def test_the_cart_stuck_through_its_ramp_is_the_one_the_reference_keeps_still():
    """cart_ramp_breaks_away, against the independent simulator on the benchmark's own ramp: of
    two wide truths with a clear margin, the one it calls stuck does not move by a single
    encoder step, the other runs. Nothing in the draw forces the breakaway: some 30 % stay."""
    from pendfmu.virtual_rig import cart_ramp_breaks_away

    ramp = next(e for e in rr.stage_experiments() if e.name == "cart-ramp")
    reference = reference_truth()

    def margin(truth):
        force = truth["eta"] * reference["k_M"] * reference["k_D"] * ramp.drive(ramp.duration)
        return force / max(truth["F_Sc"], truth["F_Kc"])

    truths = [BENCHMARK.draw_truth(0, index, "wide")[0] for index in range(30)]
    stuck = [t for t in truths if not cart_ramp_breaks_away(t)]
    assert 0.15 * len(truths) <= len(stuck) <= 0.6 * len(truths)
    still = next(t for t in stuck if margin(t) < 0.9)
    runs = next(t for t in truths if margin(t) > 1.1)
    assert cart_ramp_breaks_away(runs)
    for truth, moves in ((still, False), (runs, True)):
        x = rr.reference_signals(ramp, {**reference, **truth})["x"]
        assert (np.max(np.abs(x)) > step("x")) == moves
