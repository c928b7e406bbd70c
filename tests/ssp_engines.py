"""Other tools' SSP engines driving pendfmu's rig SSP, for tests/test_ssp_tools.py.

Each runner steps an SSP at a fixed communication step h, sets the command current at the
start of every step (held over it, as `pendfmu simulate --interpolation hold` does) and
returns time and the rig's outputs at the communication points k*h, k = 1..n.

How each one couples (read from their sources, and measured by the tests):
- fmpy 0.3.32 ``simulate_ssp``: Jacobi. All components step with the connector values of
  the previous communication point; connections (those from the system's input connectors
  included) are passed on after every step. So a component input lags its source by one
  step, and the system input by one more step before it reaches CurrentLoop.
- ecos 0.7.2 (``fixed_step_algorithm``): Jacobi; values set through the API before a step
  reach the FMU before it steps, connections are passed on after all stepped.
- libcosim 0.0.6 (``fixed_step_algorithm``): Jacobi the same way; the override manipulator
  sets the drive before the step.
pendfmu's master steps Gauss-Seidel and interpolates connected inputs linearly over the
step, so each connection in a Jacobi master adds a lag of h/2 against it (a value held
from t over [t, t+h] against the line from t to t+h).
"""

from __future__ import annotations

import os
import shutil
import stat
import tempfile
import zipfile
from collections.abc import Callable
from pathlib import Path

import numpy as np

# The rig system's output connectors (pendfmu.ssp.rig.RIG_OUTPUTS) and their components.
OUTPUTS = {"I": ("CurrentLoop", "I"), "x": ("Cart", "x"), "v": ("Cart", "v"), "a": ("Cart", "a"),
           "phi": ("Pendulum", "phi"), "w": ("Pendulum", "w")}
DRIVE = ("CurrentLoop", "I_c")

Drive = Callable[[float], float]


def steps(stop: float, h: float) -> int:
    """The number of communication steps of length h up to stop (stop a multiple of h)."""
    n = round(stop / h)
    assert abs(n * h - stop) < 1e-12 * stop, f"stop {stop} is not a multiple of the step {h}"
    return n


def run_fmpy(ssp: Path, drive: Drive, stop: float, h: float) -> dict[str, np.ndarray]:
    """fmpy's simulate_ssp, driven through the system input I_c and read at the system outputs.

    Its row stamped t holds the connector values after the step from t, i.e. at t + h (and
    the drive it read at t reaches CurrentLoop only in the step after)."""
    from fmpy.ssp.simulation import simulate_ssp

    n = steps(stop, h)
    rows = simulate_ssp(str(ssp), stop_time=stop + h / 2, step_size=h, input={"I_c": drive})
    result = {"time": (np.arange(n) + 1) * h}
    for name in OUTPUTS:
        result[name] = np.asarray(rows[name][:n], dtype=float)
    return result


def run_ecos(ssp: Path, drive: Drive, stop: float, h: float) -> dict[str, np.ndarray]:
    """ecos through its Python API (the wheel's command-line binary lacks the executable bit;
    the library is what it runs). No parameter set is named: the values must take effect
    by default."""
    from ecospy.EcosSimulation import EcosSimulation

    n = steps(stop, h)
    result = {name: np.empty(n) for name in ("time", *OUTPUTS)}
    with EcosSimulation(h, ssp_path=str(ssp)) as simulation:
        simulation.init(0.0)
        for k in range(n):
            simulation.set_real("::".join(DRIVE), drive(k * h))
            simulation.step()
            result["time"][k] = (k + 1) * h
            for name, (instance, variable) in OUTPUTS.items():
                result[name][k] = simulation.get_real(f"{instance}::{variable}")
    return result


def run_libcosim(ssp: Path, drive: Drive, stop: float, h: float) -> dict[str, np.ndarray]:
    """libcosim through libcosimpy (times in integer nanoseconds), on the unpacked archive."""
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimManipulator import CosimManipulator
    from libcosimpy.CosimObserver import CosimObserver

    n = steps(stop, h)
    step_ns = round(h * 1e9)
    assert abs(step_ns * 1e-9 - h) < 1e-15, f"step {h} is not a whole number of nanoseconds"
    with tempfile.TemporaryDirectory(prefix="pendfmu-libcosim-") as tmp:
        with zipfile.ZipFile(ssp) as archive:
            archive.extractall(tmp)
        execution = CosimExecution.from_ssp_file(tmp, step_ns)
        manipulator = CosimManipulator.create_override()
        observer = CosimObserver.create_last_value()
        execution.add_manipulator(manipulator)
        execution.add_observer(observer)
        index = {info.name.decode(): info.index for info in execution.slave_infos()}
        refs = {i: {v.name.decode(): v.reference for v in execution.slave_variables(i)} for i in index.values()}
        drive_slave = index[DRIVE[0]]
        drive_ref = refs[drive_slave][DRIVE[1]]
        result = {name: np.empty(n) for name in ("time", *OUTPUTS)}
        for k in range(n):
            manipulator.slave_real_values(drive_slave, [drive_ref], [drive(k * h)])
            assert execution.step(), f"libcosim failed at step {k}"
            result["time"][k] = (k + 1) * h
            for name, (instance, variable) in OUTPUTS.items():
                slave = index[instance]
                result[name][k] = observer.last_real_values(slave, [refs[slave][variable]])[0]
        execution.stop()
        del execution
    return result


def ecos_command(directory: Path) -> Path:
    """A copy of the ecos wheel's command-line binary with the executable bit (the wheel
    installs it without; TOOL-NOTES.md), in `directory`."""
    import ecospy

    binary = Path(ecospy.__file__).parent / "binaries" / "ecos"
    copy = Path(directory) / "ecos"
    shutil.copyfile(binary, copy)
    copy.chmod(copy.stat().st_mode | stat.S_IXUSR)
    return copy


def available(module: str) -> str | None:
    """Why `module` cannot be used here (not installed, or a library it needs is missing), or None."""
    try:
        __import__(module)
    except ImportError as error:
        return f"{module} not installed ({error})"
    except OSError as error:  # ecospy loads libecosc.so, which needs libtbb12
        return f"{module} cannot load its library ({error}); `make tools` installs libtbb12"
    return None


def with_environment(**values: str):
    """os.environ with `values` added, for a subprocess."""
    return {**os.environ, **values}
