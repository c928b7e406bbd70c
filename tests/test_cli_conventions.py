"""The command line behaves like mature Python tools' (issue 17): --version, bare `pendfmu`
lists the commands, global options anywhere, options and positionals in any order, "did
you mean" for every name, a word on what a command skipped."""

from __future__ import annotations

import json
import os
import math
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from pendfmu import __version__
from pendfmu.cli import SUBCOMMANDS, build_parser, main
from pendfmu.cli.argv import untangle
from pendfmu.cli.fit import STAGE_NAMES, _truth_lines
from pendfmu.virtual_rig import FACTOR, draw_truth, reference_truth

ROOT = Path(__file__).resolve().parents[1]


def pendfmu(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "pendfmu", *args], capture_output=True, text=True, cwd=cwd,
                          env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"})


def test_version_and_bare_command_list_the_commands():
    version = pendfmu("--version")
    assert (version.returncode, version.stdout.strip()) == (0, f"pendfmu {__version__}")
    bare = pendfmu()
    assert bare.returncode == 0
    for name in SUBCOMMANDS:
        assert f"    {name} " in bare.stdout, name


def test_a_mistyped_command_or_option_gets_the_nearest_name(capsys):
    with pytest.raises(SystemExit) as stop:
        main(["fitt", "cart"])
    assert stop.value.code == 2
    assert "'fitt' is not a command (did you mean 'fit'?)" in capsys.readouterr().err
    with pytest.raises(SystemExit) as stop:
        main(["simulate", "--imput", "rec.csv", "--out", "x.csv"])
    assert stop.value.code == 2
    assert "unrecognized arguments: --imput (did you mean '--input'?)" in capsys.readouterr().err


def test_an_abbreviated_option_is_a_typo_not_a_guess(capsys):
    """argparse would take --fre for --free; a later option --freeze would then change the
    meaning of a script. pendfmu answers it like any other unknown option."""
    with pytest.raises(SystemExit):
        main(["fit", "cart", "rec.csv", "--fre", "k_fwc", "--out", "r.json"])
    assert "(did you mean '--free'?)" in capsys.readouterr().err


def test_global_options_anywhere_before_a_double_dash():
    parser = build_parser()
    assert untangle(["fit", "cart", "--debug", "r.csv", "--out", "o.json"], parser, {}) == \
        (["--debug"], ["fit", "cart", "r.csv", "--out", "o.json"])
    assert untangle(["--debug", "check", "a.fmu"], parser, {})[0] == ["--debug"]
    assert untangle(["check", "--", "--debug"], parser, {}) == ([], ["check", "--", "--debug"])
    assert untangle(["fit", "cart", "--fix", "eta", "--", "-rec.csv"], parser, {"fit": STAGE_NAMES}) == \
        ([], ["fit", "--fix", "eta", "--", "cart", "-rec.csv"])


def test_a_list_option_stops_at_a_positional(tmp_path):
    parser = build_parser()
    words = {"fit": STAGE_NAMES}
    rec = tmp_path / "run.csv"
    rec.write_text("time,I_c\n0,0\n")
    folder = tmp_path / "recordings"
    folder.mkdir()
    cases = {  # typed -> as argparse reads it
        ("fit", "cart", "--fix", "eta", str(rec), "--out", "o.json"):
            ["fit", "cart", str(rec), "--fix", "eta", "--out", "o.json"],
        ("fit", "--fix", "eta", "k_fwc", "cart", "a.csv", "b.mat"):
            ["fit", "cart", "a.csv", "b.mat", "--fix", "eta", "k_fwc"],
        ("fit", "--out", "o.json", "all", str(folder), "--seed", "3"):
            ["fit", "all", str(folder), "--out", "o.json", "--seed", "3"],
        ("check", "--only", "static", "rollback", "Cart.fmu", "x.fmu"):
            ["check", "Cart.fmu", "x.fmu", "--only", "static", "rollback"],
        ("fit", "cart", "--free=v_Sc", str(rec)): ["fit", "cart", str(rec), "--free=v_Sc"],
    }
    for typed, expected in cases.items():
        assert untangle(list(typed), parser, words) == ([], expected), typed
    # NAME=FILE.fmu is an option's value, not a positional
    assert untangle(["system", "--component", "Cart=c.fmu", "Controller=d.fmu", "--out", "s.ssp"], parser, words) \
        == ([], ["system", "--component", "Cart=c.fmu", "Controller=d.fmu", "--out", "s.ssp"])
    # a qualified parameter name is not a file name: Cart.m_c stays with --free
    assert untangle(["fit", "--fmu", "m.fmu", str(rec), "--free", "Cart.m_c", "k"], parser, words)[1] == \
        ["fit", str(rec), "--fmu", "m.fmu", "--free", "Cart.m_c", "k"]


@pytest.fixture
def cart_recording(tmp_path):
    time = np.round(np.arange(0, 501) * 2e-4, 10)
    frame = pd.DataFrame({"time": time, "I_c": np.where(time > 0.01, 2.0, 0.0), "I": np.where(time > 0.01, 2.0, 0.0),
                          "x": np.zeros_like(time)})
    frame.to_csv(tmp_path / "cart.csv", index=False)
    (tmp_path / "cart.json").write_text(json.dumps({"parameters": {"m_p": 0.0}}))
    return tmp_path / "cart.csv"


def test_fix_of_every_free_parameter_is_an_error_before_any_work(cart_recording, tmp_path, capsys):
    out = tmp_path / "r.json"
    code = main(["fit", "cart", "--fix", "eta", "k_fwc", "F_Kc", "F_Sc", str(cart_recording), "--out", str(out)])
    assert code == 2
    assert "leaves nothing to fit" in capsys.readouterr().err
    assert not out.exists()


def test_a_parameter_file_typo_gets_the_nearest_name(cart_recording, tmp_path, capsys):
    params = tmp_path / "p.json"
    params.write_text(json.dumps({"parameters": {"k_fcw": 25.0}}))
    assert main(["simulate", "--params", str(params), "--input", str(cart_recording), "--out",
                 str(tmp_path / "s.csv")]) == 2
    assert "unknown parameter 'k_fcw' (did you mean 'k_fwc'?)" in capsys.readouterr().err


def test_fit_all_says_which_stages_and_files_it_skipped(tmp_path):
    from pendfmu.fitting.sequence import skipped_in_folder, sort_folder
    from pendfmu.recording import Recording, SignalInfo, write_recording

    time = np.arange(0, 101) * 1e-3
    write_recording(Recording(path=Path("c.csv"), time=time, signals={"I_c": 0 * time, "I": 0 * time, "x": 0 * time},
                              signal_info={"x": SignalInfo(1e-5)}), tmp_path / "c.csv")
    (tmp_path / "notes.txt").write_text("lab notes")
    lines = skipped_in_folder(tmp_path, sort_folder(tmp_path))
    assert lines == ["skipped stage current: no recording with I_c and I without x or phi",
                     "skipped stage pendulum: no recording with phi without x",
                     "not read (not a recording or its sidecar): notes.txt"]


def test_the_virtual_rig_draws_a_truth_the_fit_does_not_start_from(tmp_path):
    """`pendfmu rig --seed N` records a rig unlike the reference rig (docs/user-guide/model.md;
    which the fit starts from), within the drawn factors, and says so in truth.json;
    --reference keeps the reference rig."""
    drawn, angle = draw_truth(4)
    reference = reference_truth()
    for name, value in drawn.items():
        assert FACTOR[0] <= value / reference[name] <= FACTOR[1]
        assert not math.isclose(value, reference[name], rel_tol=1e-3), name
    assert drawn == draw_truth(4)[0] != draw_truth(5)[0]
    result = pendfmu("rig", "--out", str(tmp_path / "rec"), "--seed", "4", cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    written = json.loads((tmp_path / "rec" / "truth.json").read_text())
    assert {k: written["parameters"][k] for k in drawn} == drawn
    assert written["seed"] == 4 and "drawn with seed 4" in written["described"]
    decay = json.loads((tmp_path / "rec" / "pendulum-decay.json").read_text())
    assert "phi" not in decay.get("initial", {})  # the release angle is the fit's to find ...
    assert written["recordings"]["pendulum-decay"]["phi0"] == math.pi + abs(angle)  # ... and truth.json says it
    assert math.isclose(abs(angle), 0.549, abs_tol=5e-4)


def test_fit_all_on_a_virtual_rig_folder_prints_the_truth_beside_each_estimate(tmp_path):
    (tmp_path / "truth.json").write_text(json.dumps({"parameters": {"k_fwc": 30.0, "F_Kc": 6.0}, "seed": 1}))
    estimate = SimpleNamespace
    result = SimpleNamespace(estimates={
        "k_fwc": estimate(value=30.3, ci95=(29.9, 30.6), method="bootstrap"),
        "F_Kc": estimate(value=6.5, ci95=(6.2, 6.8), method="bootstrap"),
        "phi0[pendulum-decay]": estimate(value=3.7, ci95=(3.6, 3.8), method="bootstrap")})
    lines = _truth_lines(tmp_path, result)
    assert lines[1].split()[:7] == ["k_fwc", "reference", "30", "truth", "30", "found", "30.3"] and "inside" in lines[1]
    assert "OUTSIDE" in lines[2]
    assert lines[-1] == "  1 of 2 intervals hold the truth"
    assert _truth_lines(tmp_path / "nothing-here", result) == []


@pytest.mark.parametrize("header", ["time", "t", "Time", "TIME", "time [s]", "t (s)", "time/s", "time_s", "Time [ s ]"])
def test_common_time_column_spellings_are_time_in_seconds(tmp_path, header):
    from pendfmu.recording import read_recording

    (tmp_path / "r.csv").write_text(f"{header},I_c\n0,1.5\n0.001,2\n")
    recording = read_recording(tmp_path / "r.csv")
    assert recording.time.tolist() == [0.0, 0.001] and recording.signal("I_c").tolist() == [1.5, 2.0]


def test_a_time_column_in_another_unit_is_refused_by_name(tmp_path):
    from pendfmu.recording import RecordingError, read_recording

    (tmp_path / "r.csv").write_text("time [ms],I_c\n0,1.5\n1,2\n")
    with pytest.raises(RecordingError, match=r"r.csv: line 1: the time column 'time \[ms\]' is in 'ms'"):
        read_recording(tmp_path / "r.csv")


@pytest.mark.parametrize("separator", [";", "\t"])
def test_european_csv_with_decimal_commas_reads_like_the_plain_one(tmp_path, separator):
    """A spreadsheet in a German or French locale writes `time;I_c` and `0,0002;1,5`: the
    same numbers as the comma file, bit for bit."""
    from pendfmu.recording import read_recording

    time = [float(t) for t in np.arange(0, 50) * 2e-4]
    current = [float(np.sin(t * 37.0)) for t in time]
    plain = "time,I_c\n" + "".join(f"{t!r},{c!r}\n" for t, c in zip(time, current))
    european = f"time{separator}I_c\n" + "".join(f"{t!r}{separator}{c!r}\n".replace(".", ",")
                                                 for t, c in zip(time, current))
    (tmp_path / "plain.csv").write_text(plain)
    (tmp_path / "european.csv").write_text(european)
    a, b = read_recording(tmp_path / "plain.csv"), read_recording(tmp_path / "european.csv")
    assert np.array_equal(a.time, b.time) and np.array_equal(a.signal("I_c"), b.signal("I_c"))
    assert np.array_equal(b.signal("I_c"), current)


def test_a_bad_cell_in_a_european_csv_names_its_line_and_column(tmp_path):
    from pendfmu.recording import RecordingError, read_recording

    (tmp_path / "r.csv").write_text("time;I_c\n0;1,5\n0,1;zwei\n")
    with pytest.raises(RecordingError, match=r"r.csv: line 3, column 'I_c': 'zwei' is not a number"):
        read_recording(tmp_path / "r.csv")


def test_progress_shows_a_bar_on_a_terminal_and_nothing_in_a_pipe(monkeypatch, capsys):
    from pendfmu import console

    assert list(console.progress(iter(range(3)), "steps")) == [0, 1, 2]
    assert capsys.readouterr().err == ""  # pytest's stderr is no terminal
    monkeypatch.setattr(console, "on_terminal", lambda: True)
    assert list(console.progress(["a", "b"], "building FMUs", label=str.upper)) == ["a", "b"]
    shown = capsys.readouterr().err
    assert "building FMUs" in shown and "B" in shown


def test_a_mistyped_choice_or_stage_gets_the_nearest_name(capsys):
    with pytest.raises(SystemExit) as stop:
        main(["check", "--only", "statc", "fmus/Cart.fmu"])
    assert stop.value.code == 2
    assert "'statc' is not one of static, sequence" in capsys.readouterr().err
    assert main(["fit", "cartt", "rec.csv", "--out", "x.json"]) == 2
    assert "'cartt' is not a stage (did you mean 'cart'?)" in capsys.readouterr().err


def test_system_components_given_as_name_equals_file(tmp_path, capsys):
    """The user guide's `pendfmu system --component NAME=FILE.fmu ...` form, through main()."""
    from pendfmu.fmubuild import ensure_fmu

    out = tmp_path / "s.ssp"
    assert main(["system", "--component", f"Cart={ensure_fmu('Cart')}", f"Controller={ensure_fmu('Controller')}",
                 "--connect", "Controller.u=Cart.u", "Cart.x=Controller.y", "--out", str(out)]) == 0
    assert out.is_file()


def test_a_positional_after_a_double_dash_may_start_with_a_dash(tmp_path, capsys):
    """`--` ends the options: a recording named -rec.csv is a recording (here: not found)."""
    assert main(["fit", "cart", "--out", str(tmp_path / "r.json"), "--", "-rec.csv"]) == 2
    assert "-rec.csv: no such file" in capsys.readouterr().err


def test_the_truth_table_survives_a_zero_truth_and_a_missing_interval(tmp_path):
    (tmp_path / "truth.json").write_text(json.dumps({"parameters": {"a_h": 0.0, "k_fwc": 30.0}}))
    estimate = SimpleNamespace
    result = SimpleNamespace(estimates={"a_h": estimate(value=0.001, ci95=(-0.002, 0.003), method="bootstrap"),
                                        "k_fwc": estimate(value=30.1, ci95=None, method="jacobian")})
    lines = _truth_lines(tmp_path, result)
    assert "(+0.001) inside its 95 % interval" in lines[1] and lines[2].endswith("no interval")
    assert lines[-1] == "  1 of 1 intervals hold the truth (1 estimates without an interval)"


def test_a_bad_decimal_comma_cell_is_shown_as_written(tmp_path):
    from pendfmu.recording import RecordingError, read_recording

    (tmp_path / "r.csv").write_text("time;I_c\n0;1,5\n0,1;1.234,5\n")
    with pytest.raises(RecordingError, match=r"line 3, column 'I_c': '1.234,5' is not a number"):
        read_recording(tmp_path / "r.csv")


def test_a_semicolon_header_with_a_comma_in_it_says_so(tmp_path):
    from pendfmu.recording import RecordingError, read_recording

    (tmp_path / "r.csv").write_text("time;I_c,raw\n0;1,5\n")
    with pytest.raises(RecordingError, match="line 1 has both ';' and ','"):
        read_recording(tmp_path / "r.csv")


def test_simulate_reads_a_european_recording_like_the_plain_one(tmp_path, capsys):
    """The columns a simulation may leave alone (a laser's x beside the drive I) are found
    in a ';' header as in a ',' one: the same rule as the reader's."""
    from pendfmu.fmubuild import ensure_fmu

    (tmp_path / "plain.csv").write_text("time,I,x_laser\n0,0,0\n0.001,2,0\n0.002,2,0\n")
    (tmp_path / "european.csv").write_text("time;I;x_laser\n0;0;0\n0,001;2;0\n0,002;2;0\n")
    outputs = {}
    for name in ("plain", "european"):
        assert main(["simulate", "--fmu", str(ensure_fmu("Cart")), "--input", str(tmp_path / f"{name}.csv"),
                     "--out", str(tmp_path / f"{name}-out.csv")]) == 0
        assert "note: driven by I; not used: x_laser" in capsys.readouterr().out
        outputs[name] = (tmp_path / f"{name}-out.csv").read_text()
    assert outputs["plain"] == outputs["european"]


@pytest.mark.parametrize("value", ["two", "0", "-3"])
def test_a_worker_count_from_the_environment_that_is_no_count_is_exit_2(cart_recording, tmp_path, capsys,
                                                                         monkeypatch, value):
    """PENDFMU_WORKERS, the default for --workers on a shared machine, is checked like an option:
    one line naming the variable and the value, exit 2, nothing written."""
    from pendfmu.cli import main

    monkeypatch.setenv("PENDFMU_WORKERS", value)
    out = tmp_path / "fit.json"
    code = main(["fit", "cart", str(cart_recording), "--out", str(out), "--uncertainty", "jacobian"])
    error = capsys.readouterr().err.strip()
    assert code == 2 and f"PENDFMU_WORKERS={value!r}" in error and "\n" not in error, error
    assert not out.exists()


def test_the_environments_worker_count_is_the_default_and_an_option_overrides_it(monkeypatch):
    from pendfmu.fitting.optimizer import GlobalOptions, jacobian_threads
    from pendfmu.fitting.pool import default_workers

    monkeypatch.setenv("PENDFMU_WORKERS", "3")
    assert default_workers() == 3
    assert jacobian_threads(GlobalOptions(workers=1)) == 1
    monkeypatch.delenv("PENDFMU_WORKERS")
    assert default_workers() == (os.cpu_count() or 1)
