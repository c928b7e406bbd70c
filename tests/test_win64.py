"""The FMUs' Windows side: binaries/win64/<Name>.dll, cross-compiled with mingw-w64 and run
under wine, must compute what binaries/linux64 computes; the source FMU must compile
warning-free as strict C99 with every compiler at hand; resource URIs must become paths
that Windows' fopen accepts.

One C driver (tests/win64/driver.c) is built twice, natively (dlopen) and with mingw
(LoadLibrary), and runs each component's library through the fmi2 API, printing the
trajectories with %.17g. The comparison is absolute, 1e-12 in SI units: both builds run the
same C with -ffp-contract=off (no fused multiply-adds on one side only) in IEEE doubles on
SSE2; what may differ is the math library (glibc's sin/cos/exp against mingw-w64's), by an
ulp or so per call, and an event, located to a bracket of 1e-12 s, may then move inside its
bracket. The compared signals are states, times and outputs of magnitude below ~10 (x <
0.1 m, phi < 4 rad, w < 10 rad/s): a relative bound would be looser for the large ones and
meaningless near zero crossings, where an absolute one still holds.

Wine's first start creates its prefix (kept in pytest's cache folder: 7-30 s once); a
persistent wineserver for the module makes each later run ~0.3 s instead of ~3 s.
"""

from __future__ import annotations

import math
import re
import shutil
import subprocess
import time
import zipfile
from pathlib import Path

import fmpy
import numpy as np
import pytest

from pendfmu.components import ALL_COMPONENTS as COMPONENTS
from pendfmu.fmubuild import compiler
from pendfmu.fmubuild.compiler import FMI_HEADERS, FRAMEWORK_DIR

from fig3 import BREAKAWAY, OMEGA, PARAMETERS
from conftest import WINE  # the wine fixture lives there, shared by both Windows test files

HERE = Path(__file__).with_name("win64")
MINGW = shutil.which(compiler.PLATFORMS["win64"].compiler)
OBJDUMP = shutil.which("x86_64-w64-mingw32-objdump")
TOLERANCE = 1e-12  # absolute, SI units: see the module docstring
# What a DLL may import: Windows' own libraries, nothing a user would have to ship beside it.
WINDOWS_SYSTEM_DLLS = re.compile(r"(kernel32|msvcrt|ucrtbase|ntdll|user32|advapi32|api-ms-win-crt-[a-z0-9-]+)\.dll",
                                 re.IGNORECASE)

needs_mingw = pytest.mark.skipif(MINGW is None or OBJDUMP is None,
                                 reason="x86_64-w64-mingw32-gcc not found (apt-get install gcc-mingw-w64-x86-64, "
                                        "or make tools)")
needs_wine = pytest.mark.skipif(MINGW is None or WINE is None,
                                reason="wine or x86_64-w64-mingw32-gcc not found (apt-get install wine "
                                       "gcc-mingw-w64-x86-64, or make tools)")


def fmi2_functions() -> set[str]:
    """Every function fmi2Functions.h declares for export (FMI2_Export ... fmi2Xxx;)."""
    text = (FMI_HEADERS / "fmi2Functions.h").read_text()
    return set(re.findall(r"FMI2_Export\s+\w+TYPE\s+(fmi2\w+)\s*;", text))


def unpacked(fmu: Path, folder: Path) -> Path:
    with zipfile.ZipFile(fmu) as archive:
        archive.extractall(folder)
    return folder


def dll_listing(dll: Path) -> str:
    return subprocess.run([OBJDUMP, "-p", str(dll)], capture_output=True, text=True, check=True).stdout


# ---------------------------------------------------------------- the DLLs in the FMUs


@needs_mingw
@pytest.mark.parametrize("name", list(COMPONENTS))
def test_every_fmu_carries_a_win64_dll_next_to_the_linux64_library(built_fmus, name):
    with zipfile.ZipFile(built_fmus[name]) as fmu:
        members = set(fmu.namelist())
    assert {f"binaries/linux64/{name}.so", f"binaries/win64/{name}.dll"} <= members


@needs_mingw
@pytest.mark.parametrize("name", list(COMPONENTS))
def test_dll_needs_only_windows_system_dlls(built_fmus, name, tmp_path):
    """No libgcc_s_seh-1.dll or libwinpthread-1.dll to ship beside it: libgcc and the C99
    printf are linked in statically."""
    listing = dll_listing(unpacked(built_fmus[name], tmp_path) / "binaries" / "win64" / f"{name}.dll")
    imported = re.findall(r"DLL Name: (\S+)", listing)
    assert imported, "objdump listed no imports: not a DLL?"
    assert [dll for dll in imported if not WINDOWS_SYSTEM_DLLS.fullmatch(dll)] == []


@needs_mingw
@pytest.mark.parametrize("name", list(COMPONENTS))
def test_dll_exports_every_fmi2_function(built_fmus, name, tmp_path):
    listing = dll_listing(unpacked(built_fmus[name], tmp_path) / "binaries" / "win64" / f"{name}.dll")
    table = listing.split("[Ordinal/Name Pointer] Table", 1)[1].split("\n\n", 1)[0]  # up to its blank line
    exported = set(re.findall(r"\[\s*\d+\]\s+(\w+)", table))
    expected = fmi2_functions()
    assert len(expected) == 44  # FMI 2.0: 44 functions for Co-Simulation and Model Exchange
    assert expected <= exported
    assert exported - expected == set(), "only the fmi2 functions are the DLL's interface"


def test_guid_hashes_the_win64_platform_and_its_flags(monkeypatch):
    """Changing the Windows flags changes the GUID; whether this machine has mingw-w64 does
    not (a shell without it on PATH must not find every FMU stale): test below for the
    rebuild once it is installed."""
    monkeypatch.setattr(compiler, "_WARNED_MISSING", {"win64"})  # the missing-compiler case stays quiet
    cart = COMPONENTS["Cart"]
    available = dict(compiler.PLATFORMS["win64"].__dict__)

    def guid_with(**changes):
        monkeypatch.setitem(compiler.PLATFORMS, "win64", compiler.Platform(**{**available, **changes}))
        monkeypatch.setattr(shutil, "which", lambda command: "/usr/bin/" + command)
        return compiler.compute_guid(cart)

    with_win64 = guid_with()
    assert guid_with(flags=(*available["flags"], "-O1")) != with_win64
    monkeypatch.setitem(compiler.PLATFORMS, "win64", compiler.Platform(**available))
    monkeypatch.setattr(shutil, "which", lambda command: None if "mingw" in command else "/usr/bin/" + command)
    assert compiler.compute_guid(cart) == with_win64


def test_an_fmu_without_the_dll_is_rebuilt_once_mingw_is_there(monkeypatch, tmp_path, capsys):
    """Built where mingw-w64 was missing, the FMU is current for that machine (no rebuild,
    no warning without a build); once the compiler is there, the FMU is rebuilt with it."""
    monkeypatch.setattr(compiler, "_WARNED_MISSING", set())
    component = COMPONENTS["CurrentLoop"]
    real_which = shutil.which
    monkeypatch.setattr(shutil, "which", lambda command: None if "mingw" in command else real_which(command))
    path = compiler.build_fmu(component, force=True, folder=tmp_path)
    built = path.stat().st_mtime_ns
    assert compiler.build_fmu(component, folder=tmp_path).stat().st_mtime_ns == built  # current: not rebuilt
    monkeypatch.setattr(shutil, "which", real_which)
    compiler.build_fmu(component, folder=tmp_path)
    with zipfile.ZipFile(path) as fmu:
        assert "binaries/win64/CurrentLoop.dll" in fmu.namelist()


def test_missing_cross_compiler_builds_linux64_only_and_warns_once(monkeypatch, capsys):
    monkeypatch.setattr(compiler, "_WARNED_MISSING", set())
    monkeypatch.setattr(shutil, "which", lambda command: None if "mingw" in command else "/usr/bin/" + command)
    assert [p.name for p in compiler.built_platforms()] == ["linux64"]
    assert [p.name for p in compiler.built_platforms()] == ["linux64"]
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 1
    assert lines[0].startswith("warning: x86_64-w64-mingw32-gcc not found")
    assert "binaries/win64" in lines[0] and "apt-get install gcc-mingw-w64-x86-64" in lines[0]


def test_without_mingw_the_fmu_holds_linux64_only(monkeypatch, tmp_path, capsys):
    target = tmp_path / "CurrentLoop.fmu"
    monkeypatch.setattr(compiler, "_WARNED_MISSING", set())
    monkeypatch.setattr(shutil, "which", lambda command: None if "mingw" in command else "/usr/bin/" + command)
    assert compiler.build_fmu(COMPONENTS["CurrentLoop"], force=True, folder=tmp_path) == target
    with zipfile.ZipFile(target) as fmu:
        assert [m for m in fmu.namelist() if m.startswith("binaries/")] == ["binaries/linux64/CurrentLoop.so"]
    assert "warning: x86_64-w64-mingw32-gcc not found" in capsys.readouterr().err


@needs_mingw
def test_export_copies_the_win64_dll_byte_for_byte(built_fmus, tmp_path):
    from pendfmu.export.fmu import write_parameterized_fmu

    exported = write_parameterized_fmu("Pendulum", {"l": 0.45}, tmp_path / "Pendulum.fmu")
    member = "binaries/win64/Pendulum.dll"
    with zipfile.ZipFile(built_fmus["Pendulum"]) as original, zipfile.ZipFile(exported) as copy:
        assert copy.read(member) == original.read(member)


# ---------------------------------------------------------------- the source FMU, strict C99

STRICT = ["-std=c99", "-O2", "-Wall", "-Wextra", "-Wpedantic", "-Werror", "-shared"]
SOURCE_COMPILERS = {"gcc": ["-fPIC"], "clang": ["-fPIC"], "x86_64-w64-mingw32-gcc": []}


@pytest.mark.parametrize("cc", list(SOURCE_COMPILERS))
@pytest.mark.parametrize("name", list(COMPONENTS))
def test_source_fmu_compiles_without_a_warning(built_fmus, name, cc, tmp_path):
    """What an importer on another platform does with sources/: strict C99, every warning
    an error, and not even a note on stderr."""
    if shutil.which(cc) is None:
        pytest.skip(f"{cc} not found (make tools installs gcc-mingw-w64-x86-64; clang: apt-get install clang)")
    sources = unpacked(built_fmus[name], tmp_path) / "sources"
    files = sorted(str(p) for p in sources.glob("*.c"))
    assert {"fmi2_api.c", "uri.c", "model.c", "variables.c"} <= {Path(f).name for f in files}
    done = subprocess.run([cc, *STRICT, *SOURCE_COMPILERS[cc], "-I", str(sources), "-I", str(FMI_HEADERS), *files,
                           "-o", str(tmp_path / "library"), "-lm"], capture_output=True, text=True)
    assert done.returncode == 0 and done.stderr == "", done.stderr


def test_framework_has_no_unguarded_compiler_attribute():
    """GCC's __attribute__ only behind a macro that is empty for other compilers."""
    for path in [*FRAMEWORK_DIR.glob("*.[ch]"), *(FRAMEWORK_DIR.parent / "runner").glob("*.[ch]")]:
        for number, line in enumerate(path.read_text().splitlines(), 1):
            if "__attribute__" in line:
                assert line.lstrip().startswith("#define"), f"{path.name}:{number}: {line.strip()}"


# ---------------------------------------------------------------- wine (the fixture: conftest.py)


def build(cc: str, sources: list[Path], output: Path, *extra: str) -> Path:
    subprocess.run([cc, "-std=c99", "-O2", "-Wall", "-Wextra", "-Wpedantic", "-Werror", *extra, *map(str, sources),
                    "-o", str(output), "-lm"], check=True)
    return output


@pytest.fixture(scope="module")
def drivers(tmp_path_factory):
    return build_driver("driver", tmp_path_factory.mktemp("win64-driver"))


def build_driver(name: str, folder: Path) -> dict[str, Path]:
    """tests/win64/<name>.c natively and for Windows (static: the .exe needs no mingw DLL either)."""
    source = [HERE / f"{name}.c"]
    return {"linux64": build("gcc", source, folder / name, "-I", str(FMI_HEADERS), "-ldl"),
            "win64": build(MINGW, source, folder / f"{name}.exe", "-static", "-I", str(FMI_HEADERS))}


@pytest.fixture(scope="module")
def unpacked_fmus(built_fmus, tmp_path_factory):
    return {name: unpacked(path, tmp_path_factory.mktemp(name)) for name, path in built_fmus.items()}


def resource_uri(folder: Path, platform: str) -> str:
    """The importer's URI of folder/resources: file:///tmp/... natively, and under wine,
    whose drive Z: is the Linux root, file:///Z:/tmp/..."""
    resources = folder / "resources"
    return resources.as_uri() if platform == "linux64" else "file:///Z:" + resources.as_posix()


class Run:
    """One driver run's command line, for both platforms."""

    def __init__(self, name: str, stop: float, step: float, reals: list[str], integers: list[str] = (),
                 parameters: dict[str, float] | None = None, sine: tuple[str, float] | None = None):
        component = COMPONENTS[name]
        self.name = name
        self.args = [repr(stop), repr(step)]
        for variable, value in (parameters or {}).items():
            self.args += ["-p", f"{component.value_reference(variable)}={value!r}"]
        if sine:
            self.args += ["-s", f"{component.value_reference(sine[0])}={sine[1]!r}"]
        self.args += [a for v in reals for a in ("-r", str(component.value_reference(v)))]
        self.args += [a for v in integers for a in ("-i", str(component.value_reference(v)))]
        self.columns = ["time", *reals, *integers]


def trajectory(done: subprocess.CompletedProcess, columns: list[str]) -> dict[str, np.ndarray]:
    assert done.returncode == 0, done.stderr[-2000:]
    table = np.array([[float(value) for value in line.split()] for line in done.stdout.splitlines()])
    assert table.shape[1] == len(columns)
    return {column: table[:, j] for j, column in enumerate(columns)}


def run_on(platform: str, run: Run, folder: Path, guid: str, drivers, wine) -> dict[str, np.ndarray]:
    library = folder / "binaries" / platform / f"{run.name}{compiler.PLATFORMS[platform].suffix}"
    args = [str(library), guid, resource_uri(folder, platform), *run.args]
    if platform == "linux64":
        done = subprocess.run([str(drivers["linux64"]), *args], capture_output=True, text=True, timeout=300)
    else:
        done = wine(drivers["win64"], *args)
    return trajectory(done, run.columns)


def run_both(run: Run, unpacked_fmus, built_fmus, drivers, wine):
    guid = fmpy.read_model_description(str(built_fmus[run.name])).guid
    return tuple(run_on(platform, run, unpacked_fmus[run.name], guid, drivers, wine)
                 for platform in ("linux64", "win64"))


def assert_agree(linux: dict[str, np.ndarray], windows: dict[str, np.ndarray]) -> float:
    """Same points, same shapes; every column within TOLERANCE. Returns the largest difference."""
    largest = 0.0
    for column, values in linux.items():
        assert windows[column].shape == values.shape
        difference = float(np.max(np.abs(windows[column] - values)))
        assert difference <= TOLERANCE, f"{column}: linux64 and win64 differ by {difference:.3g}"
        largest = max(largest, difference)
    return largest


FIG3 = Run("Cart", stop=2.0, step=1e-3, reals=["x", "v", "t_mode"], integers=["mode"], parameters=PARAMETERS,
           sine=("I", OMEGA))


def breakaway(result: dict[str, np.ndarray]) -> float:
    """The FMU's time of the first mode change, stuck (0) to sliding forward (1)."""
    k = int(np.nonzero(np.diff(result["mode"]))[0][0]) + 1
    assert (result["mode"][k - 1], result["mode"][k]) == (0, 1)
    return float(result["t_mode"][k])


@needs_wine
def test_fig3_breakaway_is_the_same_on_windows(unpacked_fmus, built_fmus, drivers, wine):
    started = time.perf_counter()
    linux, windows = run_both(FIG3, unpacked_fmus, built_fmus, drivers, wine)
    assert_agree(linux, windows)
    assert np.array_equal(linux["mode"], windows["mode"])
    for result in (linux, windows):  # the bound tests/test_friction_fig3.py asserts
        assert abs(breakaway(result) - BREAKAWAY) < 1e-9
    assert time.perf_counter() - started < 60


@needs_wine
def test_pendulum_decay_is_the_same_on_windows(unpacked_fmus, built_fmus, drivers, wine):
    decay = Run("Pendulum", stop=10.0, step=1e-3, reals=["phi", "w", "alpha", "t_mode"], integers=["mode"],
                parameters={"phi0": math.pi + 0.3})
    linux, windows = run_both(decay, unpacked_fmus, built_fmus, drivers, wine)
    assert_agree(linux, windows)
    # a decay indeed: the swing about pi (hanging) loses amplitude
    first, last = (np.max(np.abs(linux["phi"][part] - math.pi)) for part in (slice(0, 2000), slice(-2000, None)))
    assert first > 0.29 and last < 0.9 * first


@needs_wine
@pytest.mark.parametrize("name", list(COMPONENTS))
def test_each_component_runs_the_same_on_windows(name, unpacked_fmus, built_fmus, drivers, wine):
    """Every library loads through LoadLibrary and steps, its first input a sine."""
    component = COMPONENTS[name]
    first_input = component.of(causality="input")[0].name
    outputs = [v.name for v in component.of(causality="output") if v.type == "Real"]
    run = Run(name, stop=1.0, step=1e-3, reals=outputs, sine=(first_input, 2 * math.pi))
    linux, windows = run_both(run, unpacked_fmus, built_fmus, drivers, wine)
    assert_agree(linux, windows)
    assert any(np.ptp(values) > 0 for column, values in linux.items() if column != "time")  # something moved


@needs_wine
def test_exported_fmu_reads_its_start_values_on_windows(unpacked_fmus, built_fmus, drivers, wine, tmp_path):
    """pendfmu export changes l without recompiling: the win64 DLL must find
    resources/pendfmu-start.txt through a file:///Z:/... URI and swing with the new l, as the
    linux64 library does with l set through fmi2SetReal."""
    from pendfmu.export.fmu import write_parameterized_fmu

    changed = {"l": 0.45, "phi0": math.pi + 0.3}
    exported = unpacked(write_parameterized_fmu("Pendulum", changed, tmp_path / "Pendulum.fmu"), tmp_path / "x")
    guid = fmpy.read_model_description(str(exported)).guid
    swing = dict(stop=3.0, step=1e-3, reals=["phi", "w"])
    windows = run_on("win64", Run("Pendulum", **swing), exported, guid, drivers, wine)
    original_guid = fmpy.read_model_description(str(built_fmus["Pendulum"])).guid
    linux = run_on("linux64", Run("Pendulum", **swing, parameters=changed), unpacked_fmus["Pendulum"], original_guid,
                   drivers, wine)
    assert_agree(linux, windows)
    default_l = run_on("linux64", Run("Pendulum", **swing, parameters={"phi0": changed["phi0"]}),
                       unpacked_fmus["Pendulum"], original_guid, drivers, wine)
    assert np.max(np.abs(default_l["phi"] - windows["phi"])) > 0.1  # l matters: the periods differ
    # without its start file the exported GUID is refused: the values did come from the file
    elsewhere = tmp_path / "elsewhere"
    (elsewhere / "resources").mkdir(parents=True)
    library = exported / "binaries" / "win64" / "Pendulum.dll"
    refused = wine(drivers["win64"], str(library), guid, resource_uri(elsewhere, "win64"), *Run("Pendulum", **swing).args)
    assert refused.returncode == 1 and "fmi2Instantiate failed" in refused.stderr


# ---------------------------------------------------------------- file URIs (pendfmu/csrc/framework/uri.c)

URI_CASES = [
    # (style, uri, expected path or None for "refused")
    ("P", "file:///tmp/pendfmu/resources", "/tmp/pendfmu/resources"),
    ("P", "file:/tmp/pendfmu/resources/", "/tmp/pendfmu/resources/"),
    ("P", "file://localhost/tmp/res", "/tmp/res"),
    ("P", "FILE://LocalHost/tmp/res", "/tmp/res"),
    ("P", "file:///tmp/my%20dir/r%C3%A9s", "/tmp/my dir/r\u00e9s"),
    ("P", "file:///C:/dir/res", "/C:/dir/res"),  # POSIX keeps the leading slash, as before
    ("P", "file://server/share/dir", None),  # another machine's file
    ("W", "file:///C:/dir/res", "C:\\dir\\res"),
    ("W", "file:/C:/dir", "C:\\dir"),
    ("W", "file://localhost/C:/dir", "C:\\dir"),
    ("W", "file:///C:/my%20dir/res", "C:\\my dir\\res"),
    ("W", "file:///C%3A/dir", "C:\\dir"),
    ("W", "file:///C%3a/dir", "C:\\dir"),
    ("W", "file:///C|/dir", "C:\\dir"),
    ("W", "file:///d:/", "d:\\"),
    ("W", "file:///Z:/tmp/x/resources/", "Z:\\tmp\\x\\resources\\"),
    ("W", "file://server/share/dir", "\\\\server\\share\\dir"),
    ("W", "file://server/share%20x/dir", "\\\\server\\share x\\dir"),
    ("W", "file:///dir/res", "\\dir\\res"),  # no drive: the current drive's root
    ("W", "file:///C:dir", "\\C:dir"),  # not a drive path ("C:" without a separator after it)
    *[(style, uri, None) for style in "PW" for uri in (
        "file:///tmp/a%2",  # escape cut short at the end
        "file:///tmp/a%",
        "file:///tmp/%zz/b",  # not hexadecimal
        "file:///tmp/%2g",
        "file:///tmp/a%00b",  # an escaped NUL would cut the path short
        "http://host/tmp/res",  # not a file URI
        "file:relative/res",  # not absolute
        "file://",
        "",
    )],
]


def uri_input(cases, size: int = 512) -> str:
    return "".join(f"{style} {size} {uri}\n" for style, uri, _ in cases)


def expected_output(local: str, cases) -> str:
    return f"local {local}\n" + "".join(f"{'false' if path is None else path}\n" for _, _, path in cases)


@pytest.fixture(scope="module")
def uri_programs(tmp_path_factory):
    folder = tmp_path_factory.mktemp("uri")
    sources = [HERE / "uri_test.c", FRAMEWORK_DIR / "uri.c"]
    programs = {"linux64": build("gcc", sources, folder / "uri_test", "-I", str(FRAMEWORK_DIR))}
    if MINGW:
        programs["win64"] = build(MINGW, sources, folder / "uri_test.exe", "-static", "-I", str(FRAMEWORK_DIR))
    return programs


def test_file_uris_become_local_paths(uri_programs):
    done = subprocess.run([str(uri_programs["linux64"])], input=uri_input(URI_CASES), capture_output=True,
                          text=True, check=True)
    assert done.stdout == expected_output("P", URI_CASES)


@needs_wine
def test_file_uris_become_windows_paths_under_wine(uri_programs, wine):
    """The same cases through the Windows build: the same answers (the style is an argument),
    and the platform's own style is Windows'."""
    done = wine(uri_programs["win64"], stdin=uri_input(URI_CASES))
    assert done.returncode == 0, done.stderr
    assert done.stdout == expected_output("W", URI_CASES)


def test_a_path_longer_than_the_buffer_is_refused(uri_programs):
    cases = [("P", "file:///tmp/abcdef", None), ("W", "file://server/share", None), ("P", "file:///tmp/ab", "/tmp/ab")]
    done = subprocess.run([str(uri_programs["linux64"])], input=uri_input(cases, size=8), capture_output=True,
                          text=True, check=True)
    assert done.stdout == expected_output("P", cases)
