"""Hostile FMUs are contained (issue 28): `pendfmu check` and the pytest plugin survive an FMU
whose fmi2DoStep segfaults, never returns or allocates without end (each a FAIL row naming
the signal or the limit, the other checks still run and the table is printed); a model
description cannot plan unbounded work (stepSize 1e-300, stopTime 1e12) nor make pendfmu load
a library outside the FMU (a modelIdentifier that is a path: check, simulate, fit and the SSP
master refuse it before loading anything); an FMU without an interface, a parameter whose min
exceeds its max, and broken FMI-LS-REF members are FAIL rows, not passes or internal failures.
The FMUs are built from tests/hostile/ (Hostile.c, evil.c) once per session."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from hostile.build import build_all

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="session")
def hostile(tmp_path_factory):
    return build_all(tmp_path_factory.mktemp("hostile"))


@pytest.fixture
def marker(tmp_path, monkeypatch):
    """The file evil.c's library writes when it is loaded (in this process or a child)."""
    path = tmp_path / "evil-was-loaded"
    monkeypatch.setenv("PENDFMU_EVIL_MARKER", str(path))
    return path


def pendfmu(*args, bound: float, cwd: Path | None = None) -> tuple[subprocess.CompletedProcess, float]:
    """`python -m pendfmu ARGS` as a user runs it, killed after twice `bound`; (result, seconds)."""
    started = time.monotonic()
    done = subprocess.run([sys.executable, "-m", "pendfmu", *map(str, args)], capture_output=True, text=True,
                          timeout=2 * bound, cwd=cwd, env={**os.environ, "PYTHONPATH": str(REPO)})
    return done, time.monotonic() - started


def tables(out: str) -> list[str]:
    """The printed tables, one per FMU (each starts with the FMU's name at the line's start)."""
    return re.split(r"\n(?=\S)", out.strip())


def rows(out: str) -> dict[str, str]:
    """{row name: verdict} of a printed check table."""
    found = re.findall(r"^  (PASS|WARN|FAIL|INCONCLUSIVE) +(\S.*?)(?:  +.*)?$", out, flags=re.M)
    return {name.strip(): verdict for verdict, name in found}


def test_a_segfaulting_dostep_is_a_fail_row_naming_sigsegv_and_the_other_checks_run(hostile):
    done, seconds = pendfmu("check", hostile["segv"], bound=30)
    table = rows(done.stdout)
    assert done.returncode == 1, done.stdout + done.stderr
    assert seconds < 30
    for crashed in ("static CS", "events CS", "determinism CS", "convergence CS", "inputs CS",
                    "sequence: fixed parameter set while stepping CS"):
        assert table[crashed] == "FAIL", done.stdout
    assert done.stdout.count("crashed (SIGSEGV)") == 6
    assert "the FMU crashed the check's process with SIGSEGV during events CS" in done.stdout
    # the checks that never step ran in the fresh children, and the summary closes the table
    assert table["sequence: step before initialization CS"] == table["static: model description"] == "PASS"
    assert done.stdout.rstrip().endswith("6 passed, 6 failed")


def test_a_dostep_that_never_returns_is_a_fail_row_naming_the_time_limit(hostile):
    done, seconds = pendfmu("check", hostile["hang"], "--time-limit", "1", "--only", "static", "events", "rollback",
                            bound=20)
    table = rows(done.stdout)
    assert done.returncode == 1, done.stdout + done.stderr
    assert seconds < 20
    assert table["static CS"] == table["events CS"] == "FAIL" and table["rollback: FMU state CS"] == "PASS"
    assert "events CS did not finish within the time limit of 1 s (--time-limit)" in done.stdout
    assert done.stdout.count("no answer in 1 s") == 2
    refused, _ = pendfmu("check", hostile["hang"], "--time-limit", "0", bound=10)
    assert refused.returncode == 2 and "--time-limit 0.0: needs a finite value > 0" in refused.stderr


def spinning_child(process: subprocess.Popen, cpu: float = 0.5, wait: float = 60.0) -> list[int]:
    """The check's one child process once it has computed for `cpu` s (spinning in the
    FMU's fmi2DoStep that never returns); fails if the check ends or takes `wait` s first."""
    from processes import children, cpu_seconds

    deadline = time.monotonic() + wait
    while time.monotonic() < deadline and process.poll() is None:
        found = children(process.pid)
        if len(found) == 1 and cpu_seconds(found[0]) >= cpu:
            return found
        time.sleep(0.05)
    pytest.fail(f"the check's child never spun in fmi2DoStep (exit {process.poll()})")


@pytest.mark.parametrize("how", [signal.SIGINT, signal.SIGKILL], ids=["Ctrl-C", "kill -9"])
def test_a_check_whose_fmu_hangs_ends_on_ctrl_c_or_kill_and_its_child_with_it(hostile, how):
    with subprocess.Popen([sys.executable, "-m", "pendfmu", "check", hostile["hang"], "--only", "events"],
                          stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                          env={**os.environ, "PYTHONPATH": str(REPO)}) as process:
        try:
            children = spinning_child(process)  # inside the hanging fmi2DoStep (a fixed 3 s sleep missed it under load)
            process.send_signal(how)
            process.wait(timeout=10)
        finally:
            process.kill()
    assert process.returncode == (130 if how == signal.SIGINT else -signal.SIGKILL)
    assert len(children) == 1
    deadline = time.monotonic() + 5  # the child, spinning in fmi2DoStep, is gone too
    while Path(f"/proc/{children[0]}").exists() and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not Path(f"/proc/{children[0]}").exists() or "Z" in Path(f"/proc/{children[0]}/stat").read_text().split()[2]


def test_the_help_states_the_default_time_limit():
    import argparse

    from pendfmu.check.contain import TIME_LIMIT
    from pendfmu.cli import check

    parser = argparse.ArgumentParser()
    check.add_arguments(parser)
    assert f"(default {TIME_LIMIT:g}: pendfmu.check.contain.TIME_LIMIT)" in " ".join(parser.format_help().split())


def test_the_pytest_plugin_fails_the_crashing_and_the_hanging_test_and_the_session_goes_on(hostile, tmp_path):
    (tmp_path / "test_user.py").write_text(textwrap.dedent(f"""
        from pendfmu.testing import assert_converges, assert_deterministic, assert_valid

        def test_crashes():
            assert_deterministic({str(hostile["segv"])!r})

        def test_hangs():
            assert_converges({str(hostile["hang"])!r})

        def test_passes():
            assert_valid({str(hostile["ok"])!r})
        """))
    (tmp_path / "pytest.ini").write_text("[pytest]\npendfmu_time_limit = 1\n")
    started = time.monotonic()
    done = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "pendfmu.testing", "-p", "no:cacheprovider",
                           "test_user.py"], cwd=tmp_path, capture_output=True, text=True, timeout=60,
                          env={**os.environ, "PYTHONPATH": str(REPO)})
    assert time.monotonic() - started < 30
    assert done.returncode == 1, done.stdout + done.stderr
    assert "2 failed, 1 passed" in done.stdout
    assert "determinism: fresh instances CS: the FMU crashed the check's process with SIGSEGV" in done.stdout
    assert "convergence CS did not finish within the time limit of 1 s" in done.stdout


def test_a_default_experiment_cannot_plan_unbounded_steps_and_the_row_says_what_was_capped(hostile):
    done, seconds = pendfmu("check", hostile["tiny_step"], hostile["long_stop"], "--only", "events", bound=30)
    assert done.returncode == 0, done.stdout + done.stderr
    assert seconds < 30
    assert ("runs of 1 s in steps of 5e-05 s, not 1 s in steps of 1e-300 s (1e+300 steps): at most 20000 "
            "communication steps a run") in done.stdout
    assert "runs of 1e+12 s in steps of 5e+07 s, not 1e+12 s in steps of 0.001 s (1e+15 steps)" in done.stdout
    assert done.stdout.count("WARN  static: planned work") == 2
    assert done.stdout.count("PASS  events: seen from outside CS") == 2


def test_a_runaway_allocation_stops_at_the_memory_limit(hostile):
    """The FMU takes 64 MiB blocks until malloc refuses (itself it stops at 16 GiB) and says
    how much it got: no more than the child's limit, 2 GiB beyond what it inherited."""
    done, seconds = pendfmu("check", hostile["hog"], "--only", "events", bound=30)
    assert done.returncode == 1, done.stdout + done.stderr
    got = re.search(r"out of memory after (\d+) MiB \(fmi2DoStep returned Error\)", done.stdout)
    assert got and int(got.group(1)) <= 2048 and rows(done.stdout)["events: seen from outside CS"] == "FAIL"


def test_a_model_identifier_that_is_a_path_loads_nothing_anywhere(hostile, marker, tmp_path):
    done, _ = pendfmu("check", hostile["evil"], hostile["evil_outside"], hostile["evil3"], bound=30)
    assert not marker.exists(), "check loaded the library"
    assert done.returncode == 1, done.stdout + done.stderr
    assert done.stdout.count("FAIL  static: model description") == 3 and "static CS" not in done.stdout
    assert done.stdout.count("<CoSimulation modelIdentifier> '../../x/evil' is not a C identifier") == 2
    assert "pendfmu loads no library from it" in done.stdout
    (tmp_path / "u.csv").write_text("time,u\n0,0\n0.1,0.5\n0.2,0\n")
    for command in (["simulate", "--fmu", hostile["evil"], "--input", "u.csv", "--out", "y.csv"],
                    ["fit", "--fmu", hostile["evil"], "u.csv", "--free", "k", "--out", "r.json"]):
        refused, _ = pendfmu(*command, bound=30, cwd=tmp_path)
        assert not marker.exists(), f"{command[0]} loaded the library"
        assert refused.returncode == 2, refused.stdout + refused.stderr
        assert "Hostile_evil.fmu" in refused.stderr and "modelIdentifier> '../../x/evil'" in refused.stderr


def test_the_ssp_master_refuses_a_component_whose_model_identifier_is_a_path(hostile, marker, tmp_path):
    from pendfmu.errors import BadInput
    from pendfmu.simulator.model import Model
    from pendfmu.ssp.archive import write_ssp
    from pendfmu.ssp.compose import compose

    ssp = write_ssp(compose({"H": hostile["evil"]}, []), tmp_path / "evil.ssp")
    with pytest.raises(BadInput, match=r"resources/Hostile_evil.fmu: <CoSimulation modelIdentifier> '\.\./\.\./x/"):
        Model.load(ssp)
    assert not marker.exists()


def test_no_interface_and_a_range_fmi_forbids_are_failures(hostile):
    done, _ = pendfmu("check", hostile["no_interface"], hostile["min_over_max"], hostile["start_outside"],
                      "--only", "static", bound=30)
    assert done.returncode == 1, done.stdout + done.stderr
    interface, over, outside = tables(done.stdout)
    assert rows(interface)["static: interfaces"] == "FAIL"
    assert "declares no interface (FMI requires a <CoSimulation> or <ModelExchange> element" in interface
    for table, problem in ((over, "variable k: min 10 exceeds max 0"),
                           (outside, "variable k: start 20 outside [2, 10]")):
        assert rows(table)["static: model description"] == "FAIL" and problem in table


def test_broken_fmi_ls_ref_members_are_fail_rows_naming_the_file(hostile):
    broken = ("ref_not_utf8", "ref_not_xml", "ref_bomb", "ref_experiments_bomb")
    done, _ = pendfmu("check", *(hostile[name] for name in broken), "--only", "reference", bound=30)
    assert done.returncode == 1 and "internal failure" not in done.stderr, done.stdout + done.stderr
    printed = tables(done.stdout)
    assert [rows(table) for table in printed] == [{"reference: FMI-LS-REF": "FAIL"}] * 4
    folder = "extra/org.fmi-standard.fmi-ls-ref"
    for table, said in zip(printed, (f"{folder}/Hostile_out.csv: not UTF-8 text (byte 17: b'\\xff')",
                                    f"{folder}/fmi-ls-manifest.xml: not XML",
                                    f"{folder}/fmi-ls-manifest.xml: not XML: Maximum entity amplification",
                                    f"{folder}/experiments.xml: not XML: Maximum entity amplification")):
        assert said in table, table


def test_a_check_group_stops_at_its_cap_of_steps_and_says_so(hostile, monkeypatch):
    from pendfmu.check import driver, run_battery

    monkeypatch.setattr(driver, "MAX_GROUP_STEPS", 150)  # two runs of 100 steps: the second stops
    (fresh,) = run_battery(hostile["ok"], only=("determinism",))
    assert fresh.verdict == "FAIL" and fresh.figure == "run failed"
    assert "WorkLimit: the check group took more than 150 communication steps" in fresh.message
    # per group: events takes 200 steps (a probe and its run), determinism's fresh instances 100
    # more (300 in all), and only its reset (four more runs) meets the cap
    monkeypatch.setattr(driver, "MAX_GROUP_STEPS", 250)
    events, fresh, reset = run_battery(hostile["ok"], only=("events", "determinism"))
    assert events.verdict == fresh.verdict == "PASS" and "WorkLimit" in reset.message
