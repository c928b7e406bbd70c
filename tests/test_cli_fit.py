"""The `pendfmu fit` command-line contract on small recordings."""

from __future__ import annotations

import json

import pytest

from pendfmu.cli import main
from pendfmu.virtual_rig import Trial, steps, write_experiments


@pytest.fixture(scope="module")
def current_recording(tmp_path_factory):
    out = tmp_path_factory.mktemp("cli-fit")
    experiment = Trial("steps", "current", 0.012, 20e-6, ("I_c", "I"),
                            steps((0, 0.0), (1e-3, 2.0), (6e-3, -1.0)))
    write_experiments(out, {"T_i": 0.5e-3, "dIdt_max": 2000.0, "a_h": 0.0}, seed=4, experiments=[experiment])
    return out / "steps.csv"


def test_fit_writes_the_result_file(current_recording, tmp_path, capsys):
    out = tmp_path / "fitted.json"
    assert main(["fit", "current", str(current_recording), "--out", str(out), "--seed", "1"]) == 0
    result = json.loads(out.read_text())
    assert result["parameters"]["T_i"] == pytest.approx(0.5e-3, rel=0.03)
    assert result["parameters"]["dIdt_max"] == pytest.approx(2000.0, rel=0.03)
    assert "T_i = " in capsys.readouterr().out
    assert "no PWM ripple found" in " ".join(result["fit"]["notes"])


def test_recording_without_the_fitted_signal_is_exit_2(current_recording, tmp_path, capsys):
    code = main(["fit", "cart", str(current_recording), "--out", str(tmp_path / "o.json")])
    err = capsys.readouterr().err
    assert code == 2 and "needs the recorded signal 'x'" in err and "Traceback" not in err


def test_unknown_free_parameter_is_exit_2(current_recording, tmp_path, capsys):
    code = main(["fit", "current", str(current_recording), "--free", "k_fwc", "--out", str(tmp_path / "o.json")])
    assert code == 2 and "'k_fwc' is not one" in capsys.readouterr().err


def test_bad_bounds_are_exit_2(current_recording, tmp_path, capsys):
    code = main(["fit", "current", str(current_recording), "--bounds", "T_i=1e-3:1e-4", "--out",
                 str(tmp_path / "o.json")])
    assert code == 2 and "LOW must be below HIGH" in capsys.readouterr().err


def test_fit_all_on_an_empty_folder_is_exit_2(tmp_path, capsys):
    assert main(["fit", "all", str(tmp_path), "--out", str(tmp_path / "o.json")]) == 2
    assert "no recordings" in capsys.readouterr().err


def test_a_model_that_misses_part_of_the_recording_is_reported(tmp_path):
    """Fitting the current loop without its ripple harmonic to a recording that has one: the
    residuals stand far above the ADC noise, and the result says so."""
    from pendfmu.fitting.identification import fit
    from pendfmu.virtual_rig import Trial, steps, write_experiments

    experiment = Trial("rippled", "current", 0.012, 20e-6, ("I_c", "I"), steps((0, 0.0), (1e-3, 2.0)))
    write_experiments(tmp_path, {"a_h": 0.05, "f_h": 3000.0}, seed=4, experiments=[experiment])
    without = fit("current", [tmp_path / "rippled.csv"], harmonic="off", seed=1, progress=False)
    assert any("times the sensor noise" in warning for warning in without.warnings)
    with_ripple = fit("current", [tmp_path / "rippled.csv"], seed=1, progress=False)
    assert not any("times the sensor noise" in warning for warning in with_ripple.warnings)


def test_bounds_for_a_parameter_not_fitted_is_exit_2(current_recording, tmp_path, capsys):
    """A typo or a fixed name in --bounds was silently ignored."""
    code = main(["fit", "current", str(current_recording), "--bounds", "T_I=1e-4:1e-3", "--out",
                 str(tmp_path / "o.json")])
    err = capsys.readouterr().err
    assert code == 2 and "'T_I'" in err and "T_i" in err


def test_repeated_options_accumulate(current_recording, tmp_path):
    """A second --bounds replaced the first; now both apply (and --fix likewise)."""
    out = tmp_path / "o.json"
    assert main(["fit", "current", str(current_recording), "--bounds", "T_i=4e-4:6e-4", "--bounds",
                 "dIdt_max=1900:2100", "--no-global", "--uncertainty", "jacobian", "--out", str(out)]) == 0
    fitted = json.loads(out.read_text())["parameters"]
    assert 4e-4 <= fitted["T_i"] <= 6e-4 and 1900 <= fitted["dIdt_max"] <= 2100


def test_an_initial_states_box_follows_bounds(tmp_path):
    """--bounds phi0=LOW:HIGH sets the release angle's box (it was fixed at +-2 encoder steps
    around the first reading, while the at-bound flag told the user to use --bounds)."""
    import math

    from pendfmu.fitting.identification import fit

    experiment = Trial("swing", "pendulum", 2.0, 2e-4, ("phi",), lambda t: 0.0,
                            truth_overrides={"phi0": math.pi + 0.5, "w0": 0.0}, known_initial=("w",))
    write_experiments(tmp_path, {}, seed=2, experiments=[experiment])
    from pendfmu.fitting.optimizer import GlobalOptions

    result = fit("pendulum", [tmp_path / "swing.csv"], {}, bounds={"phi0": (3.5, 3.7)}, fix=["T_Sp"],
                 global_search=GlobalOptions(enabled=False), progress=False, uncertainty="jacobian")
    estimate = result.estimates["phi0[swing]"]
    assert (estimate.low, estimate.high) == (3.5, 3.7)
    assert abs(estimate.value - (math.pi + 0.5)) < 2 * math.pi / 1024  # within an encoder step of the truth
