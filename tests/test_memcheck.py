"""Every FMU binary under valgrind memcheck (issue 7): no invalid access, no leak, across a
Co-Simulation run with state save/restore/serialize, a Model Exchange sequence, the misuse
cases and instantiate/free cycles (tests/memcheck/driver.c, C only, so Python's own
allocations do not blur the picture); the FMI 3.0 binaries the same way (driver3.c, with
Co-Simulation's event mode). Marked slow; `make test` runs it."""

from __future__ import annotations

import shutil
import subprocess
import zipfile
from pathlib import Path

import fmpy
import pytest

from pendfmu.components import ALL_COMPONENTS as COMPONENTS
from pendfmu.fmubuild import ensure_fmu
from pendfmu.fmubuild.compiler import FMI_HEADERS

DRIVER = Path(__file__).with_name("memcheck") / "driver.c"
DRIVER3 = Path(__file__).with_name("memcheck") / "driver3.c"
# a parameter whose negative value is non-physical, per component
NEGATIVE = {"CurrentLoop": "T_i", "Cart": "m_c", "Pendulum": "m_p", "Controller": "T_s", "RigController": "T_s"}

pytestmark = [pytest.mark.slow,
              pytest.mark.skipif(shutil.which("valgrind") is None, reason="valgrind not installed")]


def compile_driver(source, folder):
    path = folder / source.stem
    subprocess.run(["gcc", "-std=c99", "-O1", "-g", "-Wall", "-Wextra", "-Werror", "-I", str(FMI_HEADERS),
                    str(source), "-o", str(path), "-ldl", "-lm"], check=True)
    return path


@pytest.fixture(scope="module")
def driver(tmp_path_factory):
    return compile_driver(DRIVER, tmp_path_factory.mktemp("memcheck"))


@pytest.fixture(scope="module")
def driver3(tmp_path_factory):
    return compile_driver(DRIVER3, tmp_path_factory.mktemp("memcheck3"))


@pytest.mark.parametrize("name", list(COMPONENTS))
def test_no_invalid_access_and_no_leak(built_fmus, driver, name, tmp_path):
    with zipfile.ZipFile(built_fmus[name]) as fmu:
        fmu.extractall(tmp_path)
    md = fmpy.read_model_description(str(built_fmus[name]))
    component = COMPONENTS[name]
    (input_name,) = [v.name for v in component.of(causality="input")][:1]
    command = ["valgrind", "--error-exitcode=99", "--leak-check=full", "--errors-for-leak-kinds=definite,indirect",
               "--show-leak-kinds=definite,indirect", str(driver),
               str(tmp_path / "binaries" / "linux64" / f"{name}.so"), md.guid, (tmp_path / "resources").as_uri(),
               str(component.value_reference(input_name)), str(component.value_reference(NEGATIVE[name])),
               str(len(component.states)), str(component.event_indicators)]
    done = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-3000:]
    assert "ERROR SUMMARY: 0 errors" in done.stderr


def memcheck(command):
    done = subprocess.run(["valgrind", "--error-exitcode=99", "--leak-check=full",
                           "--errors-for-leak-kinds=definite,indirect", "--show-leak-kinds=definite,indirect",
                           *command], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-3000:]
    assert "ERROR SUMMARY: 0 errors" in done.stderr


@pytest.mark.parametrize("name", list(COMPONENTS))
def test_fmi3_no_invalid_access_and_no_leak(driver3, name, tmp_path):
    path = ensure_fmu(name, 3)
    with zipfile.ZipFile(path) as fmu:
        fmu.extractall(tmp_path)
    component = COMPONENTS[name]
    (input_name,) = [v.name for v in component.of(causality="input")][:1]
    memcheck([str(driver3), str(tmp_path / "binaries" / "x86_64-linux" / f"{name}.so"),
              fmpy.read_model_description(str(path)).guid, str(tmp_path / "resources") + "/",
              str(component.value_reference(input_name)), str(component.value_reference(NEGATIVE[name])),
              str(len(component.states)), str(component.event_indicators)])
