"""Issue 12, parts 5 and 6: nothing lost, and what looks wrong said on the console.

Mis-scaled recordings (time in ms, x in mm, phi in degrees) and recordings without a
sidecar gave exit 0 and a confident result; the checks must name the file and column
before any fit runs, `--strict` must stop there with exit code 3, and output paths must
be refused (exit 2) before any work.
"""

from __future__ import annotations

import json
import math
import shutil

import numpy as np
import pandas as pd
import pytest

from pendfmu.cli import main
from pendfmu.components import rig_defaults
from pendfmu.fitting.stages import make_experiment
from pendfmu.fitting.plausibility import check_experiment
from pendfmu.recording import read_recording
from pendfmu.fitting.result import Estimate, FitResult
from pendfmu.fitting.statistics import interval
from pendfmu.virtual_rig import Trial, write_experiments


@pytest.fixture(scope="module")
def decay_recording(tmp_path_factory):
    out = tmp_path_factory.mktemp("decay")
    experiment = Trial("decay", "pendulum", 4.0, 2e-4, ("phi",), lambda t: 0.0,
                            truth_overrides={"phi0": math.pi + 0.5, "w0": 0.0}, known_initial=("w",))
    write_experiments(out, {}, seed=3, experiments=[experiment])
    return out / "decay.csv"


def _variant(source, folder, name, change, sidecar=True):
    """A copy of a recording with one column changed (and its sidecar, unless not wanted)."""
    frame = pd.read_csv(source)
    change(frame)
    target = folder / f"{name}.csv"
    frame.to_csv(target, index=False, float_format="%.17g")
    if sidecar:
        shutil.copy(source.with_suffix(".json"), target.with_suffix(".json"))
    return target


def _warnings(path, stage):
    experiment = make_experiment(read_recording(path), stage, rig_defaults())
    return check_experiment(experiment)


def test_good_recordings_have_no_warning(cart_recording, decay_recording):
    assert _warnings(cart_recording, "cart") == []
    assert _warnings(decay_recording, "pendulum") == []


def test_time_in_milliseconds(cart_recording, tmp_path):
    path = _variant(cart_recording, tmp_path, "ms", lambda f: f.__setitem__("time", f["time"] * 1000))
    (warning,) = _warnings(path, "cart")
    assert "ms.csv" in warning and "'time'" in warning and "is it in ms?" in warning


def test_position_in_millimetres(cart_recording, tmp_path):
    path = _variant(cart_recording, tmp_path, "mm", lambda f: f.__setitem__("x", f["x"] * 1000))
    (warning,) = _warnings(path, "cart")
    assert "mm.csv" in warning and "'x'" in warning and "1000 times" in warning


def test_angle_in_degrees(decay_recording, tmp_path):
    path = _variant(decay_recording, tmp_path, "deg", lambda f: f.__setitem__("phi", np.degrees(f["phi"])))
    warnings = _warnings(path, "pendulum")
    assert any("'phi'" in w and "degrees" in w for w in warnings), warnings
    bare = _variant(decay_recording, tmp_path, "deg-bare", lambda f: f.__setitem__("phi", np.degrees(f["phi"])),
                    sidecar=False)
    assert any("'phi'" in w and "degrees" in w for w in _warnings(bare, "pendulum"))


def test_swing_period_against_the_pendulum(decay_recording, tmp_path):
    """Time in ms on a pendulum: the swing lasts 1000 times the pendulum's own period."""
    path = _variant(decay_recording, tmp_path, "slow", lambda f: f.__setitem__("time", f["time"] * 1000))
    warnings = _warnings(path, "pendulum")
    assert any("period" in w and "seconds" in w for w in warnings), warnings


def test_cart_without_sidecar_says_what_it_assumed(cart_recording, tmp_path):
    path = _variant(cart_recording, tmp_path, "bare", lambda f: None, sidecar=False)
    (warning,) = _warnings(path, "cart")
    assert "bare.csv" in warning and "no sidecar" in warning and "m_p = 0.2" in warning and '"m_p": 0' in warning


def test_strict_stops_before_fitting_and_writes_nothing(cart_recording, tmp_path, capsys):
    path = _variant(cart_recording, tmp_path, "mm", lambda f: f.__setitem__("x", f["x"] * 1000))
    out = tmp_path / "result.json"
    assert main(["fit", "cart", str(path), "--out", str(out), "--strict"]) == 3
    err = capsys.readouterr().err
    assert "warning: " in err and "mm.csv" in err and "--strict" in err
    assert not out.exists()


def test_warnings_reach_the_console_and_the_result(cart_recording, tmp_path, capsys):
    """Without --strict the fit runs, the warning is printed at once and kept in the file."""
    path = _variant(cart_recording, tmp_path, "bare", lambda f: None, sidecar=False)
    out = tmp_path / "result.json"
    assert main(["fit", "cart", str(path), "--out", str(out), "--no-global"]) == 0
    err = capsys.readouterr().err
    assert "warning: " in err and "no sidecar" in err
    assert any("no sidecar" in w for w in json.loads(out.read_text())["fit"]["warnings"])


@pytest.mark.parametrize("option", ["--out", "--report"])
def test_output_paths_are_checked_before_any_work(tmp_path, capsys, option):
    """The recording does not even exist: the output path is refused first (exit 2)."""
    (tmp_path / "afile").write_text("")
    target = {"--out": str(tmp_path / "missing" / "r.json"), "--report": str(tmp_path / "afile")}[option]
    argv = ["fit", "cart", str(tmp_path / "nothere.csv"), "--out", str(tmp_path / "r.json")]
    argv += [option, target] if option == "--report" else []
    argv[argv.index("--out") + 1] = target if option == "--out" else argv[argv.index("--out") + 1]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert option in err and "nothere" not in err


def test_interval_never_overflows_and_is_written():
    """A log-scaled parameter whose spread is huge gets an unbounded interval, not an
    OverflowError after the whole fit (5 of about 30 real-data fits ended so)."""
    assert interval(1e-3, 1.0, True, "k_fwp") == (0.0, math.inf)
    assert interval(0.9, 0.2, False, "eta")[1] == 1.0  # clipped to eta's physical range
    estimate = Estimate("k_fwp", 1e-3, 1.0, interval(1e-3, 1.0, True, "k_fwp"), 1e-4, 1e-2)
    result = FitResult("pendulum", {"k_fwp": 1e-3}, {"k_fwp": estimate}, {}, 1.0, {}, 1, 0, 0.1)
    document = result.to_dict()
    assert document["ci95"]["k_fwp"] == [0.0, None]
    json.dumps(document, allow_nan=False)
