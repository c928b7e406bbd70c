"""Issue 25 item 5, real-data handling: a recorded rate column, a decay started at a turning
point, and the release angle's box and what its edge means.

The recordings come from the independent reference simulator (tests/reference_rig.py, an
event-driven scipy integration of the paper's model, docs/user-guide/model.md), read through
sensors made here by hand; the truths are what the fits must find, inside their intervals.
Where a real recording is at hand (../shared/realdata, or PENDFMU_REALDATA) the same
handling runs on it too.
"""

from __future__ import annotations

import math
import re
import sys
from pathlib import Path

import numpy as np
import pytest

import pendfmu
from pendfmu.errors import OptionError
from pendfmu.fitting.edges import explain_edges
from pendfmu.fitting.experiment import reading_box, signal_scale
from pendfmu.fitting.optimizer import Outcome
from pendfmu.fitting.plausibility import check_experiment
from pendfmu.fitting.residuals import FreeParameter
from pendfmu.fitting.result import Estimate
from pendfmu.fitting.stages import make_experiment
from pendfmu.fitting.turning import first_reversal, from_turning_point
from pendfmu.components import rig_defaults
from pendfmu.recording import Recording, RecordingError, SignalInfo

sys.path.insert(0, str(Path(__file__).parent))
import reference_rig as rr  # noqa: E402

FRICTION = {"k_fwp": 1e-3, "T_Kp": 2e-3, "T_Sp": 4e-3}
SEARCH = pendfmu.GlobalOptions(workers=1, popsize=4, maxiter=8)
ENCODER = 2 * math.pi / 4096
SAMPLE = 1e-3
# The intervals whose holding the truth is asserted are the calibrated ones: the Jacobian's
# are far too narrow on quantized recordings (bootstrap.py), 8 refits keep the tests short.
CALIBRATED = {"uncertainty": "bootstrap", "replicates": 8}


def quantized(values: np.ndarray, step: float = ENCODER) -> np.ndarray:
    return np.round(values / step) * step


def swing(duration: float, phi0: float, w0: float, **extra) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(time, phi, w) of the reference simulator's free pendulum."""
    time = np.arange(0.0, duration, SAMPLE)
    frame = rr.simulate_pendulum({**FRICTION, **extra}, 0.0, time, phi0=phi0, w0=w0)
    return time, frame["phi"].to_numpy(), frame["w"].to_numpy()


def holds(estimate: Estimate, truth: float) -> bool:
    return estimate.ci95[0] <= truth <= estimate.ci95[1]


# -- the box of a reading


def test_a_readings_box_is_what_its_sensor_could_have_misread():
    time = np.arange(5) * SAMPLE
    values = np.array([1.0, 1.5, 2.0, 2.5, 3.0])

    def box(**info):
        recording = Recording(None, time, {"x": values}, signal_info={"x": SignalInfo(**info)} if info else {})
        return reading_box(recording, "x")

    assert box(resolution=0.1) == pytest.approx((1.0, 0.95, 1.05))  # round: half a step either side
    assert box(resolution=0.1, quantizer="floor") == pytest.approx((1.0, 1.0, 1.1))  # floor: the step above
    assert box(resolution=0.1, noise=0.01) == pytest.approx((1.0, 0.91, 1.09))  # and four noise sigmas
    assert box(noise=0.02) == pytest.approx((1.0, 0.92, 1.08))
    # nothing stated: four times the noise the fit estimates from the data
    scale = signal_scale(Recording(None, time, {"x": values}), "x")
    assert scale > 0 and box() == pytest.approx((1.0, 1.0 - 4 * scale, 1.0 + 4 * scale))


def test_a_noisy_fine_encoder_gives_the_release_angle_room():
    """A 40000-count encoder with 2 mrad of noise: the old box (first reading +-2 counts,
    whatever the noise) left the true release angle out; the box of the reading's error
    holds it, and the fit finds it inside, not at an edge."""
    step, noise = 2 * math.pi / 40000, 2e-3
    time, phi, _ = swing(3.0, math.pi + 0.5, 0.0)
    reading = quantized(phi + np.random.default_rng(4).normal(0, noise, len(phi)), step)
    assert abs(reading[0] - phi[0]) > 2 * step  # the old box missed the truth here
    recording = Recording(None, time, {"phi": reading}, signal_info={"phi": SignalInfo(step, noise=noise)},
                          initial={"w": 0.0})
    result = pendfmu.fit("pendulum", [recording], global_search=SEARCH, progress=False, **CALIBRATED)
    phi0 = result.estimates["phi0[recording]"]
    assert phi0.low < phi[0] < phi0.high and not any(f.startswith("at its") for f in phi0.flags)
    assert holds(phi0, phi[0])
    for name in ("k_fwp", "T_Kp"):
        assert holds(result.estimates[name], FRICTION[name]), name


# -- a recorded rate column


@pytest.fixture(scope="module")
def mid_swing():
    """A decay recorded from mid-swing (w0 = 1.2 rad/s), phi by a 4096-count encoder and w by
    a tachometer of 5 mrad/s noise."""
    time, phi, w = swing(4.0, math.pi + 0.5, 1.2)
    tachometer = w + np.random.default_rng(1).normal(0.0, 0.005, len(w))
    return Recording(None, time, {"phi": quantized(phi), "w": tachometer},
                     signal_info={"phi": SignalInfo(ENCODER), "w": SignalInfo(noise=0.005)}), phi[0]


def test_a_recorded_rate_is_the_initial_rate(mid_swing):
    recording, phi0 = mid_swing
    result = pendfmu.fit("pendulum", [recording], global_search=SEARCH, progress=False, **CALIBRATED)
    w0 = result.estimates["w0[recording]"]
    tachometer = recording.signal("w")[0]
    assert (w0.low, w0.high) == pytest.approx((tachometer - 0.02, tachometer + 0.02))  # its reading's box
    assert holds(w0, 1.2) and holds(result.estimates["phi0[recording]"], phi0)
    for name in ("k_fwp", "T_Kp"):
        assert holds(result.estimates[name], FRICTION[name]), name
    record = result.provenance["stages"]["pendulum"]["recordings"]["recording"]
    assert record["read_from"] == {"phi0": "phi", "w0": "w"} and record["match"] == {"phi": "phi"}
    # without the w column the run is taken to start at rest, and no parameter can fix that
    only_phi = Recording(None, recording.time, {"phi": recording.signal("phi")},
                         signal_info={"phi": SignalInfo(ENCODER)})
    blind = pendfmu.fit("pendulum", [only_phi], uncertainty="jacobian", global_search=SEARCH, progress=False)
    assert any("times the sensor noise" in w for w in blind.warnings)


def test_a_recorded_rate_is_compared_when_asked(mid_swing):
    recording, _ = mid_swing
    result = pendfmu.fit("pendulum", [recording], match={"w": "w"}, global_search=SEARCH, progress=False,
                         **CALIBRATED)
    assert set(result.nrmse) == {"phi", "w"}
    fit = result.experiments[0]
    # compared at the tachometer's own scale: the w residuals are its noise
    assert np.std(fit.recorded["w"] - fit.simulated["w"]) == pytest.approx(0.005, rel=0.1)
    assert result.provenance["stages"]["pendulum"]["recordings"]["recording"]["match"] == {"phi": "phi", "w": "w"}
    for name in ("k_fwp", "T_Kp"):
        assert holds(result.estimates[name], FRICTION[name]), name


@pytest.mark.parametrize("target, match, message", [
    ("pendulum", {"alpha": "alpha"}, "compares phi and, when asked, its recorded rate (w)"),
    ("pendulum", {"w": "phi"}, "not w=phi"),
    ("current", {"w": "w"}, "recorded rate (none)"),
    ("all", {"w": "w"}, "fit all compares each stage's own signals"),
])
def test_a_match_a_stage_cannot_make_is_refused(mid_swing, tmp_path, target, match, message):
    recording, _ = mid_swing
    recordings = str(tmp_path) if target == "all" else [recording]
    with pytest.raises(OptionError, match=re.escape(message)):
        pendfmu.fit(target, recordings, match=match, global_search=SEARCH)


def test_a_run_without_sidecar_does_not_assume_the_rate_it_records(mid_swing):
    recording, _ = mid_swing
    bare = Recording(None, recording.time, dict(recording.signals))
    experiment = make_experiment(bare, "pendulum", rig_defaults())
    assert experiment.estimated["w0"][0] == bare.signal("w")[0]
    warning = next(w for w in check_experiment(experiment) if "no sidecar" in w)
    assert "w0 = 0" not in warning


# -- a decay started at its first turning point


@pytest.fixture(scope="module")
def released_by_hand():
    """A decay held at pi + 0.6 until an unmarked instant (0.3137 s), then released: the
    recording starts before the release, as a hand-released run does."""
    time = np.arange(0.0, 5.0, SAMPLE)
    release = 0.3137
    moving = time >= release
    frame = rr.simulate_pendulum(FRICTION, 0.0, np.concatenate([[release], time[moving]]), phi0=math.pi + 0.6)
    phi = np.where(moving, np.interp(time, frame["time"], frame["phi"]), math.pi + 0.6)
    w = np.where(moving, np.interp(time, frame["time"], frame["w"]), 0.0)
    return Recording(Path("decay.csv"), time, {"phi": quantized(phi)}, signal_info={"phi": SignalInfo(ENCODER)}), phi, w


def test_a_decay_starts_at_its_first_turning_point(released_by_hand):
    recording, phi, w = released_by_hand
    result = pendfmu.fit("pendulum", [recording], start="turning", global_search=SEARCH, progress=False,
                         **CALIBRATED)
    (label, record), = result.provenance["stages"]["pendulum"]["recordings"].items()
    start = int(round(record["span"][0] / SAMPLE))
    assert 0.9 < record["span"][0] < 1.0  # half a period (1.27 s) after the release
    assert abs(w[start]) < 0.03 and record["read_from"]["w0"] == "phi' at its turning point"
    assert holds(result.estimates[f"w0[{label}]"], w[start]) and holds(result.estimates[f"phi0[{label}]"], phi[start])
    for name in ("k_fwp", "T_Kp"):
        assert holds(result.estimates[name], FRICTION[name]), name
        assert result.estimates[name].value == pytest.approx(FRICTION[name], rel=0.02), name


def test_the_release_is_not_a_turning_point_and_noise_makes_none():
    held = np.concatenate([np.full(100, 2.0), 2.0 - 0.01 * np.arange(1, 200)])
    assert first_reversal(held, 0.05) is None  # the hand's release: the readings never approached it
    noise = np.random.default_rng(3).normal(0, 0.004, 1000)
    assert first_reversal(noise + np.linspace(0, 1, 1000), 0.05) is None  # ten sigmas: noise cannot turn
    turn = np.concatenate([np.linspace(0, 1, 50), np.linspace(1, 0, 50)])
    assert first_reversal(turn, 0.05) == (49, 1)


def test_a_recording_that_never_turns_is_refused_by_name():
    time = np.arange(0.0, 0.5, SAMPLE)
    recording = Recording(Path("ramp.csv"), time, {"phi": quantized(math.pi + 0.3 * time)},
                          signal_info={"phi": SignalInfo(ENCODER)})
    with pytest.raises(RecordingError, match=r"ramp.csv: start 'turning': the recorded phi never turns"):
        from_turning_point(recording)
    with pytest.raises(OptionError, match="'turning' starts a swing at its first turning point"):
        pendfmu.fit("cart", [recording], start="turning")


# -- a start at the edge of its box


def test_at_the_edge_the_flag_names_the_model_and_the_interval_is_no_point():
    """Air drag (k_dp) that the stage does not fit: the residuals stand at 13 times the
    noise, the release angle ends at the edge of its reading's box, and every bootstrap
    refit stays there. The flag names the model, not the box; the interval reaches into the
    box instead of being a point (before: [x, x], and the advice to widen the box)."""
    time, phi, _ = swing(3.0, math.pi + 0.8, 0.0, k_dp=0.003)
    recording = Recording(None, time, {"phi": quantized(phi)}, signal_info={"phi": SignalInfo(ENCODER)},
                          initial={"w": 0.0})
    result = pendfmu.fit("pendulum", [recording], global_search=SEARCH, progress=False, **CALIBRATED)
    phi0 = result.estimates["phi0[recording]"]
    assert phi0.value in (phi0.low, phi0.high), "the premise: the start ends at its edge"
    flag = next(f for f in phi0.flags if f.startswith("at its"))
    assert "times the sensor noise, so the model cannot follow this recording" in flag
    assert "The box is not the cause" in flag and "widen" not in flag
    low, high = phi0.ci95
    assert phi0.low <= low < high <= phi0.high and high - low > 0.25 * (phi0.high - phi0.low)
    assert not any(f.startswith("correlated") for f in phi0.flags)


def test_a_point_interval_at_an_edge_becomes_one_sided():
    free = [FreeParameter("k", 1.0, 3.0, False), FreeParameter("phi0", 2.0, 2.5, False, "run")]
    jacobian = np.array([[1.0, 0.0], [0.0, 2.0], [1.0, 1.0]])
    outcome = Outcome(np.array([0.5, 0.0]), jacobian, np.array([0.1, -0.1, 0.05]), 0, 0, 0.0)
    estimates = {"k": Estimate("k", 2.0, 0.1, (1.8, 2.2), 1.0, 3.0, method="bootstrap"),
                 "phi0[run]": Estimate("phi0[run]", 2.0, 0.0, (2.0, 2.0), 2.0, 2.5,
                                       ["at its lower bound 2: the optimum may lie beyond; widen its bounds",
                                        "correlated +1.000 with k: only a combination of the two is determined"],
                                       method="bootstrap")}
    estimates["k"].flags.append("correlated +1.000 with phi0[run]: only a combination of the two is determined")
    correlation = {"k": {"k": 1.0, "phi0[run]": 1.0}, "phi0[run]": {"k": 1.0, "phi0[run]": 1.0}}
    explain_edges(free, outcome, estimates, correlation, [], spread=20.0, limit=3.0)
    low, high = estimates["phi0[run]"].ci95
    assert low == 2.0 and 2.0 < high <= 2.5
    assert correlation["k"]["phi0[run]"] is None and not estimates["k"].flags
    assert estimates["phi0[run]"].flags[0].endswith("so a wider box may not help")


# -- real recordings, where present


REALDATA = Path(__file__).resolve().parents[1] / "examples" / "realdata"
sys.path.insert(0, str(REALDATA))


def _multiarm():
    from _common import available, load_example

    example = load_example("MultiArm-Pendulum")
    if not available(example.MULTIARM_MAT):
        pytest.skip(f"real data absent: {example.MULTIARM_MAT}")
    return example


def test_the_multiarm_rate_column_starts_the_fit():
    """The MultiArm file's second row is the authors' (denoised) rate: as a w column it is the
    initial rate (1.85 rad/s at the first sample; the slope of phi there is 1.9), where before
    w0 = 0 was assumed."""
    from scipy.io import loadmat

    example = _multiarm()
    data = loadmat(example.MULTIARM_MAT)
    first = np.asarray(data["Y_id"].flat[0])
    time = np.ravel(data["Time_id"].flat[0])
    recording = Recording(None, time, {"phi": first[0], "w": first[1]},
                          signal_info={"phi": SignalInfo(example.ENCODER_RESOLUTION)})
    experiment = make_experiment(recording, "pendulum", {**rig_defaults(), **example.PUBLISHED_PENDULUM})
    value, low, high = experiment.estimated["w0"]
    assert value == first[1][0] and abs(value) > 0.1 and low < value < high


def test_the_multiarm_decay_from_turning_points_keeps_its_starts_inside():
    """Two of MultiArm's windows, each from its first turning point with its rate estimated:
    the residuals stay far above the noise (the model misses the rig's air drag), every start
    at an edge says so, and no interval is a point."""
    example = _multiarm()
    recordings, known = example.build(2)
    time, phi = example.read_multiarm_decay()
    whole = Recording(Path("multiarm.mat"), time, {"phi": phi}, signal_info={"phi": SignalInfo(example.ENCODER_RESOLUTION)})
    windows = [(float(r.time[0]) - 0.1, float(r.time[-1])) for r in recordings]
    result = pendfmu.fit("pendulum", [whole], known, windows=windows, start="turning", uncertainty="jacobian",
                         bounds=example.PENDULUM_BOUNDS, seed=0, progress=False)
    assert any("times the sensor noise" in w for w in result.warnings)
    for label, estimate in result.estimates.items():
        low, high = estimate.ci95
        assert high > low, label
        for flag in estimate.flags:
            if "[" in label and flag.startswith("at its"):
                assert "so the model cannot follow this recording" in flag, label

