"""`pendfmu check` (pendfmu/check/): pendfmu's four FMUs and the foreign test FMUs pass every
check, and each deliberately broken BrokenCart (tests/broken/) is caught by the check made
for it, with a message that says what is wrong; the command's table and exit codes."""

from __future__ import annotations

import re

import pytest

from broken.build import build as build_broken
from foreign.build import build_all as build_foreign
from pendfmu.check import run_battery
from pendfmu.cli import main
from pendfmu.fmubuild import ensure_fmu

STOP = 0.2  # seconds per run: every check, both interfaces, well under a second or two per FMU


@pytest.fixture(scope="module")
def foreign(tmp_path_factory):
    return build_foreign(tmp_path_factory.mktemp("foreign"))


@pytest.fixture(scope="module")
def broken(tmp_path_factory):
    folder = tmp_path_factory.mktemp("broken")
    return {variant: build_broken(variant, folder) for variant in ("ok", "state", "reset", "step", "nan")}


def failures(results):
    return {r.name: r for r in results if not r.passed}


def checked_names(results):
    return {r.name.split(":")[0] for r in results}


@pytest.mark.parametrize("name", ["CurrentLoop", "Cart", "Pendulum", "Controller"])
def test_pendfmus_fmus_pass_every_check_in_both_interfaces(name):
    results = run_battery(ensure_fmu(name), stop=STOP)
    assert not failures(results), failures(results)
    assert checked_names(results) == {"static", "sequence", "events", "determinism", "rollback", "convergence", "inputs"}
    assert any(r.name.endswith(" ME") for r in results) and any(r.name.endswith(" CS") for r in results)


def test_the_foreign_fmus_pass_every_check(foreign):
    for name, path in foreign.items():
        results = run_battery(path, stop=STOP)
        assert not failures(results), (name, failures(results))
    # what they cannot do is reported, not failed
    rows = {r.name: r for r in run_battery(foreign["NoStateCart"], stop=STOP, only=("determinism", "rollback"))}
    assert rows["determinism: reset CS"].figure == "fmi2Reset refused"
    # the refusal in the FMU's own words (its C code), through the binding's FMUError
    assert rows["determinism: reset CS"].message.startswith(
        "NoStateCart at t = 0.2 s: fmi2Reset is not supported by NoStateCart: free this instance and instantiate a "
        "new one (fmi2Reset returned Error)")
    assert rows["rollback: FMU state CS"].figure == "not declared"


def test_the_cart_rollback_saves_a_state_while_sliding():
    (row, _) = run_battery(ensure_fmu("Cart"), stop=STOP, only=("rollback",))[:2]
    assert "mode combinations besides the start's, the first mode=1, stuck=0" in row.figure  # stuck, then sliding


def test_the_correct_broken_cart_passes_and_each_bug_is_caught_by_its_check(broken):
    assert not failures(run_battery(broken["ok"]))
    caught = {variant: failures(run_battery(broken[variant])) for variant in ("state", "reset", "step", "nan")}
    assert {v: sorted(f) for v, f in caught.items()} == {
        "state": ["rollback: FMU state CS"],
        "reset": ["determinism: reset CS"],
        "step": ["convergence: h, h/2, h/4 CS"],
        "nan": ["inputs: finite outputs CS"],
    }
    state = caught["state"]["rollback: FMU state CS"].message
    assert "restoring the state saved at t = " in state and "modes mode=" in state and "does not reproduce" in state
    reset = caught["reset"]["determinism: reset CS"].message
    assert "fmi2Reset must bring m back to its start value 1" in reset
    assert "m set to 1.25 after fmi2Reset does not act like a fresh instance" in reset
    step = caught["step"]["convergence: h, h/2, h/4 CS"]
    assert "the result moves with the communication step: a changes by" in step.message
    assert "order" in step.figure
    nan = caught["nan"]["inputs: finite outputs CS"].message
    assert nan.startswith("with input u held at 5 (in its declared range [-5, 5]) output margin turned nan")
    assert "every call returned OK" in nan


def test_command_prints_a_row_per_check_and_exits_by_the_result(broken, capsys):
    assert main(["check", str(broken["ok"]), "--only", "static", "determinism"]) == 0
    out = capsys.readouterr().out
    assert re.search(r"PASS +static: GUID CS", out) and re.search(r"PASS +determinism: reset CS", out)
    assert "0 failed" in out
    assert main(["check", str(broken["ok"]), str(broken["nan"]), "--only", "inputs"]) == 1
    out = capsys.readouterr().out
    assert "FAIL  inputs: finite outputs CS" in out and "u = 5: margin = nan" in out


def test_command_names_a_missing_or_unreadable_fmu_and_exits_2(broken, tmp_path, capsys):
    assert main(["check", str(broken["ok"]), str(tmp_path / "absent.fmu")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "absent.fmu: no such FMU file" in err[0]
    junk = tmp_path / "junk.fmu"
    junk.write_text("not a zip")
    assert main(["check", str(junk)]) == 2
    assert "junk.fmu: not a readable FMU" in capsys.readouterr().err


def test_a_crash_on_misuse_is_a_failed_row_and_the_other_misuses_still_run(broken, monkeypatch):
    import os
    import signal

    from pendfmu.check import sequence
    from pendfmu.check.battery import group_jobs
    from pendfmu.check.contain import run_all
    from pendfmu.check.fmu import Target

    real = sequence._misuse

    def misuse(target, kind, step, case):  # segfaults on one misuse, as a broken FMU would (in the child)
        if case == "unknown value reference":
            os.kill(os.getpid(), signal.SIGSEGV)
        return real(target, kind, step, case)

    monkeypatch.setattr(sequence, "_misuse", misuse)
    target = Target(broken["ok"])
    rows = {r.name: r for r in run_all(group_jobs(target, sequence, ["CS"]))}
    crashed = rows.pop("sequence: unknown value reference CS")
    assert not crashed.passed and crashed.figure == "crashed (SIGSEGV)"
    assert "crashed the check's process with SIGSEGV during sequence: unknown value reference CS" in crashed.message
    assert len(rows) == 4 and all(r.passed for r in rows.values())


def test_input_recording_drives_the_runs_and_a_wrong_column_is_bad_input(broken, tmp_path, capsys):
    recording = tmp_path / "u.csv"
    recording.write_text("time,u\n0,0\n0.5,4\n1.0,-4\n1.5,1\n")
    results = run_battery(broken["state"], only=("determinism", "rollback"), recording=recording)
    rows = {r.name: r for r in results}
    assert rows["determinism: fresh instances CS"].figure.startswith("identical (376 points")  # 1.5 s at 4 ms
    assert not rows["rollback: FMU state CS"].passed
    wrong = tmp_path / "wrong.csv"
    wrong.write_text("time,I\n0,1\n")
    assert main(["check", str(broken["ok"]), "--input", str(wrong)]) == 2
    assert "wrong.csv: column 'I' is not an input of the FMU (inputs: u)" in capsys.readouterr().err
