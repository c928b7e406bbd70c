"""A serialized FMU state is bytes a user may keep in a file, damage or edit: restoring any
such bytes must end in fmi2OK or fmi2Error, never in a crash of the host. Every byte of a
real state of the Cart and of the Controller (whose state holds integer parameters that
index its delay line) is overwritten in turn with a few patterns; whatever the FMU accepts
is then stepped. Runs in a child process, so a crash is a failure, not a lost test run."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from pendfmu.fmubuild import ensure_fmu

ROOT = Path(__file__).resolve().parents[1]

CHILD = textwrap.dedent("""
    import sys
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave
    from fmpy.fmi1 import FMICallException

    path, steps = sys.argv[1], int(sys.argv[2])
    md = read_model_description(path)
    slave = FMU2Slave(guid=md.guid, unzipDirectory=extract(path), modelIdentifier=md.coSimulation.modelIdentifier,
                      instanceName="fuzz")
    slave.instantiate()
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    slave.exitInitializationMode()
    t = 0.0
    for _ in range(steps):
        slave.doStep(t, 1e-3)
        t += 1e-3
    blob = bytes(slave.serializeFMUstate(slave.getFMUstate()))
    accepted = refused = 0
    for position in range(len(blob)):
        for pattern in (0xFF, 0x7F, 0x41):
            mutated = bytearray(blob)
            mutated[position] = pattern
            try:
                state = slave.deSerializeFMUstate(bytes(mutated))
                slave.setFMUstate(state)
                slave.freeFMUstate(state)
                for k in range(3):
                    slave.doStep(t + k * 1e-3, 1e-3)
                accepted += 1
            except FMICallException:
                refused += 1
                slave.reset()  # an FMU in its error state: start over, as a master would
                slave.setupExperiment(startTime=0.0)
                slave.enterInitializationMode()
                slave.exitInitializationMode()
    print(f"done {len(blob)} bytes, {accepted} accepted, {refused} refused")
""")


@pytest.mark.parametrize("name", ["Cart", "Controller"])
def test_any_damaged_state_is_refused_or_runs_never_crashes(name, tmp_path):
    script = tmp_path / "child.py"
    script.write_text(CHILD)
    done = subprocess.run([sys.executable, str(script), str(ensure_fmu(name)), "25"], capture_output=True,
                          text=True, timeout=600, cwd=tmp_path)
    assert done.returncode == 0, f"the host crashed (exit {done.returncode}):\n{done.stderr[-2000:]}"
    last = done.stdout.strip().splitlines()[-1]  # before it, the FMU's logged reasons for each refusal
    assert last.startswith("done"), done.stdout[-2000:]
    accepted, refused = (int(w) for w in last.split()[3:6:2])
    assert refused > 0 and accepted > 0  # the check can refuse, and harmless changes still restore
