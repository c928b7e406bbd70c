"""The FMI 3.0 FMUs' Windows side: binaries/x86_64-windows/<Name>.dll, cross-compiled with
mingw-w64 and run under wine, must compute what binaries/x86_64-linux computes, as
tests/test_win64.py checks for the FMI 2.0 DLLs (its helpers, fixtures and the reasoning
behind its 1e-12 bound are reused here).

One C driver (tests/win64/driver3.c) is built natively (dlopen) and with mingw (LoadLibrary)
and runs a library through the fmi3 Co-Simulation API, resourcePath a plain path (FMI 3.0
has no URIs): /tmp/.../resources/ natively, Z:\\tmp\\...\\resources\\ under wine. The FMI 3.0
façade wraps the same instance code as FMI 2.0's, so beyond linux-vs-windows agreement the
runs are tied to the FMI 2.0 DLL's: the same pendulum decay to the bit, and the Fig. 3
breakaway at the first communication point after the FMI 2.0 DLL's (FMI 3.0 holds the force
over a step, having no input derivatives; FMI 2.0 gets them and finds t_b itself).
"""

from __future__ import annotations

import math
import re
import subprocess
import zipfile
from pathlib import Path

import fmpy
import numpy as np
import pytest

from pendfmu.components import ALL_COMPONENTS as COMPONENTS
from pendfmu.fmubuild import build_all
from pendfmu.fmubuild.compiler import FMI_HEADERS, FMI_VERSIONS, PLATFORMS

from fig3 import BREAKAWAY, edges
from test_win64 import (FIG3, Run, assert_agree, breakaway, build_driver, dll_listing, drivers, needs_mingw, needs_wine,
                        run_on, trajectory, unpacked, unpacked_fmus)

SHARED_FIXTURES = (drivers, unpacked_fmus)  # test_win64.py's, found by pytest through these names (wine: conftest)
FOLDERS = FMI_VERSIONS[3].binaries  # PLATFORMS' key -> x86_64-linux / x86_64-windows
ONLY_IMPORTS = {"kernel32.dll", "msvcrt.dll"}  # Windows' own: nothing to ship beside the DLL


def fmi3_functions() -> set[str]:
    """Every function fmi3Functions.h declares for export (FMI3_Export fmi3XxxTYPE fmi3Xxx;)."""
    text = (FMI_HEADERS / "fmi3Functions.h").read_text()
    return set(re.findall(r"FMI3_Export\s+\w+TYPE\s+(fmi3\w+)\s*;", text))


@pytest.fixture(scope="module")
def fmi3_fmus():
    return build_all(fmi_version=3)


@pytest.fixture(scope="module")
def unpacked_fmi3(fmi3_fmus, tmp_path_factory):
    return {name: unpacked(path, tmp_path_factory.mktemp(f"{name}-fmi3")) for name, path in fmi3_fmus.items()}


@pytest.fixture(scope="module")
def drivers3(tmp_path_factory):
    return build_driver("driver3", tmp_path_factory.mktemp("win64-driver3"))


def resource_path(folder: Path, platform: str) -> str:
    """FMI 3.0's resourcePath of folder/resources, a plain path ending in a separator; under
    wine, whose drive Z: is the Linux root, Z:\\tmp\\...\\resources\\."""
    resources = folder / "resources"
    if platform == "linux64":
        return f"{resources}/"
    return "Z:" + str(resources).replace("/", "\\") + "\\"


def token_of(fmu: Path) -> str:
    return fmpy.read_model_description(str(fmu)).guid  # fmpy's name for instantiationToken


def run3_on(platform: str, run: Run, folder: Path, token: str, drivers3, wine, event_mode: bool = False,
            resources: Path | None = None) -> dict[str, np.ndarray] | subprocess.CompletedProcess:
    """The driver's trajectory (with event mode, an `event` column too); with `resources`,
    another folder than the FMU's, the finished process instead, to see a refusal."""
    library = folder / "binaries" / FOLDERS[platform] / f"{run.name}{PLATFORMS[platform].suffix}"
    args = [str(library), token, resource_path(resources or folder, platform), *run.args, *(["-e"] if event_mode else [])]
    if platform == "linux64":
        done = subprocess.run([str(drivers3["linux64"]), *args], capture_output=True, text=True, timeout=300)
    else:
        done = wine(drivers3["win64"], *args)
    if resources is not None:
        return done
    return trajectory(done, [*run.columns, *(["event"] if event_mode else [])])


def run3_both(run: Run, unpacked_fmi3, fmi3_fmus, drivers3, wine, event_mode: bool = False):
    token = token_of(fmi3_fmus[run.name])
    return tuple(run3_on(platform, run, unpacked_fmi3[run.name], token, drivers3, wine, event_mode)
                 for platform in ("linux64", "win64"))


# ---------------------------------------------------------------- the DLLs in the FMUs


@needs_mingw
@pytest.mark.parametrize("name", list(COMPONENTS))
def test_dll_imports_only_kernel32_and_msvcrt(fmi3_fmus, unpacked_fmi3, name):
    with zipfile.ZipFile(fmi3_fmus[name]) as fmu:
        members = set(fmu.namelist())
    assert {f"binaries/x86_64-linux/{name}.so", f"binaries/x86_64-windows/{name}.dll"} <= members
    listing = dll_listing(unpacked_fmi3[name] / "binaries" / "x86_64-windows" / f"{name}.dll")
    imported = {dll.lower() for dll in re.findall(r"DLL Name: (\S+)", listing)}
    assert imported == ONLY_IMPORTS


@needs_mingw
@pytest.mark.parametrize("name", list(COMPONENTS))
def test_dll_exports_every_fmi3_function_and_what_the_linux_library_exports(unpacked_fmi3, name):
    listing = dll_listing(unpacked_fmi3[name] / "binaries" / "x86_64-windows" / f"{name}.dll")
    table = listing.split("[Ordinal/Name Pointer] Table", 1)[1].split("\n\n", 1)[0]  # up to its blank line
    exported = set(re.findall(r"\[\s*\d+\]\s+(\w+)", table))
    expected = fmi3_functions()
    assert len(expected) == 75  # FMI 3.0: the 75 functions of all three interfaces
    assert exported == expected, "exactly the fmi3 functions are the DLL's interface"
    so = unpacked_fmi3[name] / "binaries" / "x86_64-linux" / f"{name}.so"
    linux = subprocess.run(["nm", "-D", "--defined-only", "--format=just-symbols", str(so)], capture_output=True,
                           text=True, check=True).stdout.split()
    assert set(linux) == exported


# ---------------------------------------------------------------- wine


@needs_wine
def test_fig3_breakaway_on_windows_follows_the_fmi2_dll(unpacked_fmi3, fmi3_fmus, unpacked_fmus, built_fmus, drivers3,
                                                         drivers, wine):
    """The same command line as test_win64.py's FIG3: driver3 holds the sine over each step.
    The FMI 2.0 DLL, given the force's derivatives, breaks away at t_b (within 1e-9 s of
    the analytic time); the FMI 3.0 DLL, its force held over each 1 ms step, at the first
    communication point past t_b, where the held force first exceeds F_S. The mode sequence
    is the same."""
    linux, windows = run3_both(FIG3, unpacked_fmi3, fmi3_fmus, drivers3, wine)
    assert_agree(linux, windows)
    assert np.array_equal(linux["mode"], windows["mode"])
    fmi2_dll = run_on("win64", FIG3, unpacked_fmus["Cart"], token_of(built_fmus["Cart"]), drivers, wine)
    assert abs(breakaway(fmi2_dll) - BREAKAWAY) < 1e-9
    step = 1e-3
    for result in (linux, windows):
        assert abs(breakaway(result) - math.ceil(breakaway(fmi2_dll) / step) * step) < 1e-12
        assert [change[1:] for change in edges(result)] == [change[1:] for change in edges(fmi2_dll)]


@needs_wine
def test_pendulum_decay_on_windows_is_the_fmi2_dlls_to_the_bit(unpacked_fmi3, fmi3_fmus, unpacked_fmus, built_fmus,
                                                               drivers3, drivers, wine):
    """No input, so nothing for the two façades to treat differently: the FMI 3.0 DLL swings
    exactly as the FMI 2.0 DLL does."""
    decay = Run("Pendulum", stop=10.0, step=1e-3, reals=["phi", "w", "alpha", "t_mode"], integers=["mode"],
                parameters={"phi0": math.pi + 0.3})
    linux, windows = run3_both(decay, unpacked_fmi3, fmi3_fmus, drivers3, wine)
    assert_agree(linux, windows)
    fmi2_dll = run_on("win64", decay, unpacked_fmus["Pendulum"], token_of(built_fmus["Pendulum"]), drivers, wine)
    for column, values in fmi2_dll.items():
        np.testing.assert_array_equal(windows[column], values, err_msg=column)
    first, last = (np.max(np.abs(linux["phi"][part] - math.pi)) for part in (slice(0, 2000), slice(-2000, None)))
    assert first > 0.29 and last < 0.9 * first  # a decay indeed


@needs_wine
def test_controller_samples_in_event_mode_on_windows(unpacked_fmi3, fmi3_fmus, drivers3, wine):
    """Steps of T_s / 2 with eventModeUsed: every second step ends on a sample and asks for
    Event Mode, where the driver sets y at the sample and fmi3UpdateDiscreteStates takes it,
    so u = K_p (r - y) shows the sample's own input at the sample's communication point."""
    T_s, K_p, r, omega = 2e-3, 2.0, 1.0, 2 * math.pi * 5
    samples = Run("Controller", stop=0.2, step=T_s / 2, reals=["u", "t_sample"],
                  parameters={"T_s": T_s, "K_p": K_p, "r": r}, sine=("y", omega))
    linux, windows = run3_both(samples, unpacked_fmi3, fmi3_fmus, drivers3, wine, event_mode=True)
    assert_agree(linux, windows)
    k = np.arange(len(linux["time"]))
    for result in (linux, windows):
        assert np.array_equal(result["event"], (k > 0) & (k % 2 == 0))
        at_sample = k % 2 == 0
        np.testing.assert_allclose(result["t_sample"][at_sample], result["time"][at_sample], rtol=0, atol=1e-15)
        np.testing.assert_allclose(result["u"][at_sample], K_p * (r - np.sin(omega * result["time"][at_sample])),
                                   rtol=0, atol=1e-12)
        assert np.array_equal(result["u"][1::2], result["u"][0:-1:2])  # held between samples
    assert np.ptp(linux["u"]) > 3.9  # the sine went through: u from 0 to 4


@needs_wine
def test_exported_fmu_reads_its_start_values_through_a_windows_path(unpacked_fmi3, fmi3_fmus, drivers3, wine,
                                                                     tmp_path):
    """An FMI 3.0 `pendfmu export` changes l without recompiling: the DLL must find
    resources\\pendfmu-start.txt through the Z:\\...\\resources\\ path and swing as the
    linux library does with l set through fmi3SetFloat64."""
    from pendfmu.export.fmu import write_parameterized_fmu

    changed = {"l": 0.45, "phi0": math.pi + 0.3}
    fmu = write_parameterized_fmu("Pendulum", changed, tmp_path / "Pendulum.fmu", fmi_version=3)
    exported, token = unpacked(fmu, tmp_path / "x"), token_of(fmu)
    swing = dict(stop=3.0, step=1e-3, reals=["phi", "w"])
    windows = run3_on("win64", Run("Pendulum", **swing), exported, token, drivers3, wine)
    original = token_of(fmi3_fmus["Pendulum"])
    linux = run3_on("linux64", Run("Pendulum", **swing, parameters=changed), unpacked_fmi3["Pendulum"], original,
                    drivers3, wine)
    assert_agree(linux, windows)
    default_l = run3_on("linux64", Run("Pendulum", **swing, parameters={"phi0": changed["phi0"]}),
                        unpacked_fmi3["Pendulum"], original, drivers3, wine)
    assert np.max(np.abs(default_l["phi"] - windows["phi"])) > 0.1  # l matters: the periods differ
    elsewhere = tmp_path / "elsewhere"  # without its start file the exported token is refused
    (elsewhere / "resources").mkdir(parents=True)
    refused = run3_on("win64", Run("Pendulum", **swing), exported, token, drivers3, wine, resources=elsewhere)
    assert refused.returncode == 1 and "fmi3InstantiateCoSimulation failed" in refused.stderr
