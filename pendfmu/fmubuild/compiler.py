"""Compile a component FMU from its C sources and zip it.

The FMU holds modelDescription.xml, binaries/linux64/<Name>.so (the system C compiler),
binaries/win64/<Name>.dll (cross-compiled with mingw-w64, when it is installed) and
sources/ (framework, model and generated tables in one flat folder, plus
buildDescription.xml), so that an importer on another platform can compile it. The GUID
is a hash of everything that goes into the binaries: an FMU is rebuilt exactly when that
hash changes.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import sys
import tempfile
import uuid
import zipfile
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import fmpy

from pendfmu import __version__
from pendfmu.components import Component
from pendfmu.fmubuild import ctables, description

FMUS_DIR = Path(__file__).resolve().parents[2] / "fmus"
FRAMEWORK_DIR = FMUS_DIR / "framework"
FMI_HEADERS = Path(fmpy.__file__).parent / "c-code"
CFLAGS = ["-std=c99", "-O3", "-flto", "-fPIC", "-fvisibility=hidden", "-ffp-contract=off",
          "-Wall", "-Wextra", "-Wpedantic", "-Werror"]
PLATFORM = "linux64"
LIBRARY_SUFFIX = ".so"  # a shared library on PLATFORM


@dataclass(frozen=True)
class Platform:
    """How to build a shared library for one FMI platform folder (binaries/<name>/)."""
    name: str
    compiler: str  # the default command; linux64's can be overridden with $CC
    suffix: str
    flags: tuple[str, ...]
    install: str  # how to get the compiler, for the warning when it is missing


# Windows: a PE DLL has no ELF visibility (fmi2Functions.h's FMI2_Export is dllexport there,
# and only marked functions are exported), and libgcc is linked in statically so that the
# DLL needs nothing but Windows' own DLLs (KERNEL32, msvcrt). mingw-w64 formats with its
# own C99 printf in -std=c99 (statically linked too).
WIN64_FLAGS = ("-std=c99", "-O3", "-flto", "-ffp-contract=off", "-Wall", "-Wextra", "-Wpedantic", "-Werror",
               "-static-libgcc", "-static")
PLATFORMS = {
    "linux64": Platform("linux64", "gcc", ".so", tuple(CFLAGS), "a C compiler (apt-get install gcc)"),
    "win64": Platform("win64", "x86_64-w64-mingw32-gcc", ".dll", WIN64_FLAGS,
                      "apt-get install gcc-mingw-w64-x86-64 (or: make tools)"),
}


class BuildError(RuntimeError):
    """The C compiler rejected a component's sources."""


def _hand_written_sources(component: Component) -> dict[str, str]:
    """File name in sources/ -> text, for the framework and the model."""
    files = {p.name: p.read_text() for p in sorted(FRAMEWORK_DIR.iterdir()) if p.suffix in (".c", ".h")}
    files["model.c"] = (FMUS_DIR / component.name / "model.c").read_text()
    return files


_WARNED_MISSING: set[str] = set()


def built_platforms() -> list[Platform]:
    """linux64 and every cross platform whose compiler is installed. A missing cross
    compiler is not an error: the FMUs then carry linux64 only, said once per process."""
    platforms = [PLATFORMS[PLATFORM]]
    for platform in PLATFORMS.values():
        if platform.name == PLATFORM:
            continue
        if shutil.which(platform.compiler):
            platforms.append(platform)
        elif platform.name not in _WARNED_MISSING:
            _WARNED_MISSING.add(platform.name)
            print(f"warning: {platform.compiler} not found, so the FMUs get no binaries/{platform.name}; "
                  f"to build them: {platform.install}", file=sys.stderr)
    return platforms


def compute_guid(component: Component) -> str:
    """A GUID that changes whenever the table, the sources, the platforms built or their
    compiler flags change (installing mingw-w64 later rebuilds the FMUs with win64)."""
    digest = hashlib.sha256()
    digest.update(repr(component).encode())
    digest.update(" ".join(CFLAGS).encode())
    for platform in built_platforms()[1:]:
        digest.update(f"\0{platform.name} {platform.compiler} {' '.join(platform.flags)}".encode())
    digest.update(__version__.encode())
    for name, text in _hand_written_sources(component).items():
        digest.update(name.encode() + b"\0" + text.encode())
    return "{" + str(uuid.UUID(digest.hexdigest()[:32])) + "}"


def fmu_path(component: Component) -> Path:
    return FMUS_DIR / f"{component.name}.fmu"


_DESCRIPTIONS: dict[tuple, object] = {}


def model_description(path: Path):
    """fmpy's parsed modelDescription.xml of an FMU file, kept while the file is unchanged
    (same inode, size and modification time). Parsing takes 1.5 ms, and checking, building
    and loading one system asks for each FMU's description four or five times (16 ms of a
    0.1 s `pendfmu simulate`)."""
    path = Path(path)
    stat = path.stat()
    key = (str(path.resolve()), stat.st_ino, stat.st_size, stat.st_mtime_ns)
    if key not in _DESCRIPTIONS:
        _DESCRIPTIONS[key] = fmpy.read_model_description(str(path))
    return _DESCRIPTIONS[key]


def built_guid(path: Path) -> str | None:
    """The GUID inside an existing FMU, or None if there is none readable."""
    try:
        return model_description(path).guid
    except Exception:  # a missing or broken file just means "build it"
        return None


def source_files(component: Component, guid: str) -> dict[str, str]:
    files = _hand_written_sources(component)
    files["variables.h"] = ctables.variables_header(component, guid)
    files["variables.c"] = ctables.variables_source(component)
    return files


def compile_library(sources: Sequence[str | Path], output: Path, include: Sequence[Path] = (),
                    compiler: str | None = None, platform: str = PLATFORM) -> None:
    """Compile C sources into the shared library `output` for `platform` (a key of
    PLATFORMS), headers searched in `include` and then the FMI headers. pendfmu's one
    compiler command: the FMUs, the native loop and the benchmark's limit are built with
    the same flags (those the GUIDs and the loop's library name hash) for the same platform."""
    target = PLATFORMS[platform]
    cc = compiler or (os.environ.get("CC", target.compiler) if platform == PLATFORM else target.compiler)
    folders = [*(f for folder in include for f in ("-I", str(folder))), "-I", str(FMI_HEADERS)]
    command = [cc, *target.flags, "-shared", *folders, *(str(s) for s in sources), "-o", str(output), "-lm"]
    result = subprocess.run(command, capture_output=True, text=True)
    if result.returncode != 0:
        raise BuildError(f"{cc} failed for {', '.join(str(s) for s in sources)}:\n{result.stderr}")


def compile_sources(source_dir: Path, output: Path, compiler: str | None = None, platform: str = PLATFORM) -> None:
    """Compile every .c file of a flat sources folder into the shared library `output`."""
    compile_library(sorted(str(p) for p in source_dir.glob("*.c")), output, [source_dir], compiler, platform)


def build_fmu(component: Component, force: bool = False) -> Path:
    """Build fmus/<Name>.fmu unless an FMU of the same sources is already there."""
    target = fmu_path(component)
    guid = compute_guid(component)
    if not force and target.exists() and built_guid(target) == guid:
        return target
    files = source_files(component, guid)
    names = sorted(files)
    with tempfile.TemporaryDirectory(prefix=f"pendfmu-{component.name}-") as tmp:
        tmp_dir = Path(tmp)
        sources = tmp_dir / "sources"
        sources.mkdir()
        for name, text in files.items():
            (sources / name).write_text(text)
        libraries = {p.name: tmp_dir / p.name / f"{component.name}{p.suffix}" for p in built_platforms()}
        for library in libraries.values():
            library.parent.mkdir()
        # One compiler process per platform, side by side: with a free core, win64 adds little wall time.
        with ThreadPoolExecutor(len(libraries)) as pool:
            for done in [pool.submit(compile_sources, sources, library, platform=name)
                         for name, library in libraries.items()]:
                done.result()  # a BuildError is raised here
        partial = target.with_name(f".{target.name}.{os.getpid()}.part")
        with zipfile.ZipFile(partial, "w", zipfile.ZIP_DEFLATED) as fmu:
            fmu.writestr("modelDescription.xml", description.model_description(component, guid, names))
            for name, library in libraries.items():
                fmu.write(library, f"binaries/{name}/{library.name}")
            for name in names:
                fmu.write(sources / name, f"sources/{name}")
            fmu.writestr("sources/buildDescription.xml", description.build_description(component, names))
        shutil.move(partial, target)  # atomic: a reader never sees half an FMU
    return target
