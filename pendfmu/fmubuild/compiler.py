"""Compile a component FMU from its C sources with the system C compiler and zip it.

The C sources are package data (``pendfmu/csrc``, read through importlib.resources), so an
installed wheel builds FMUs as a checkout does. Built FMUs go to :func:`fmu_folder`: the
checkout's ``fmus/`` when pendfmu runs from a source checkout, otherwise a per-version
folder in the user's cache (``PENDFMU_FMU_DIR`` overrides both).

The FMU holds modelDescription.xml, binaries/linux64/<Name>.so (the system C compiler),
binaries/win64/<Name>.dll (cross-compiled with mingw-w64, when it is installed) and
sources/ (framework, model and generated tables in one flat folder, plus
buildDescription.xml), so that an importer on another platform can compile it. The GUID
is a hash of everything that goes into the binaries: an FMU is rebuilt exactly when that
hash changes.

FMI 3.0 versions of the same components (fmus/fmi3/<Name>.fmu) differ only in what
FMI_VERSIONS lists: the facade compiled in, the binaries folders' names (x86_64-linux,
x86_64-windows), the description writer.
"""

from __future__ import annotations

import hashlib
import importlib.resources
import os
import shutil
import subprocess
import sys
import tempfile
import threading
import uuid
import zipfile
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import fmpy
import platformdirs

from pendfmu import __version__
from pendfmu.atomic import write_atomically
from pendfmu.components import Component
from pendfmu.errors import BuildError
from pendfmu.fmubuild import ctables, description, description3



def _source_dir() -> Path:
    """The C sources' folder inside the installed package. Compilers need real files, so a
    package imported from a zip archive cannot build FMUs."""
    folder = Path(str(importlib.resources.files("pendfmu") / "csrc"))
    if not (folder / "framework").is_dir():
        raise BuildError(f"pendfmu's C sources are not at {folder}: reinstall pendfmu from a wheel or a checkout "
                         "(a zipped package cannot build FMUs)")
    return folder


def fmu_folder() -> Path:
    """Where built FMUs (and the native loop's library) are kept.

    ``$PENDFMU_FMU_DIR`` when set; else ``fmus/`` of the source checkout pendfmu runs from
    (a folder holding pendfmu's pyproject.toml beside the package), so that a developer
    finds them where the documentation says; else the user cache, one folder per pendfmu version,
    because an installed package's own folder may be read-only and is shared by users.
    """
    if os.environ.get("PENDFMU_FMU_DIR"):
        return Path(os.environ["PENDFMU_FMU_DIR"]).expanduser().resolve()
    checkout = Path(__file__).resolve().parents[2]
    pyproject = checkout / "pyproject.toml"
    if pyproject.is_file() and 'name = "pendfmu"' in pyproject.read_text(errors="replace"):
        return checkout / "fmus"
    return Path(platformdirs.user_cache_dir("pendfmu")) / __version__ / "fmus"


SOURCE_DIR = _source_dir()
FRAMEWORK_DIR = SOURCE_DIR / "framework"
FMUS_DIR = fmu_folder()  # built FMUs; the sources are in SOURCE_DIR
FMI_HEADERS = Path(fmpy.__file__).parent / "c-code"
CFLAGS = ["-std=c99", "-O3", "-flto", "-fPIC", "-fvisibility=hidden", "-ffp-contract=off",
          "-Wall", "-Wextra", "-Wpedantic", "-Werror"]
PLATFORM = "linux64"
LIBRARY_SUFFIX = ".so"  # a shared library on PLATFORM


@dataclass(frozen=True)
class Platform:
    """How to build a shared library for one platform (PLATFORMS' key: FMI 2.0's folder name)."""

    name: str
    compiler: str  # the default command; linux64's can be overridden with $CC
    suffix: str
    flags: tuple[str, ...]
    install: str  # how to get the compiler, for the warning when it is missing


# Windows: a PE DLL has no ELF visibility (fmi2Functions.h's FMI2_Export and fmi3Functions.h's
# FMI3_Export are dllexport there, and only marked functions are exported), and libgcc is
# linked in statically so that the DLL needs nothing but Windows' own DLLs (KERNEL32,
# msvcrt). mingw-w64 formats with its own C99 printf in -std=c99 (statically linked too).
WIN64_FLAGS = ("-std=c99", "-O3", "-flto", "-ffp-contract=off", "-Wall", "-Wextra", "-Wpedantic", "-Werror",
               "-static-libgcc", "-static")
PLATFORMS = {
    "linux64": Platform("linux64", "gcc", ".so", tuple(CFLAGS), "a C compiler (apt-get install gcc)"),
    "win64": Platform("win64", "x86_64-w64-mingw32-gcc", ".dll", WIN64_FLAGS,
                      "apt-get install gcc-mingw-w64-x86-64 (or: make tools)"),
}


@dataclass(frozen=True)
class FmiVersion:
    """What an FMI version changes in a component FMU; everything else is shared."""

    facade: str  # the framework file with this version's API functions
    binaries: dict[str, str]  # PLATFORMS' key -> the folder binaries/<folder>/ of this version
    subfolder: str  # where the FMUs go, inside the FMU folder
    model_description: Callable[[Component, str, list[str]], bytes]


#: The FMI versions the components are built for, each with what it changes in an FMU
#: (FmiVersion: the API facade compiled in, the binaries folders' names, the FMU
#: subfolder, the model description writer): 2 (FMI 2.0) and 3 (FMI 3.0).
FMI_VERSIONS = {
    2: FmiVersion("fmi2_api.c", {"linux64": "linux64", "win64": "win64"}, "", description.model_description),
    3: FmiVersion("fmi3_api.c", {"linux64": "x86_64-linux", "win64": "x86_64-windows"}, "fmi3",
                  description3.model_description),
}


def fmi_version_of(fmi_version: int) -> FmiVersion:
    if fmi_version not in FMI_VERSIONS:
        raise ValueError(f"FMI version {fmi_version!r} is not built; known: {', '.join(map(str, FMI_VERSIONS))}")
    return FMI_VERSIONS[fmi_version]


def _hand_written_sources(component: Component, fmi_version: int = 2) -> dict[str, str]:
    """File name in sources/ -> text, for the framework and the model: the shared framework
    and this version's facade, never another version's."""
    other_facades = {v.facade for n, v in FMI_VERSIONS.items() if n != fmi_version}
    files = {p.name: p.read_text() for p in sorted(FRAMEWORK_DIR.iterdir())
             if p.suffix in (".c", ".h") and p.name not in other_facades}
    files["model.c"] = (SOURCE_DIR / component.name / "model.c").read_text()
    return files


_WARNED_MISSING: set[str] = set()


def built_platforms(warn: bool = True) -> list[Platform]:
    """linux64 and every cross platform whose compiler is installed. A missing cross
    compiler is not an error: the FMUs then carry linux64 only, said once per process
    (when `warn`: a build that will run)."""
    platforms = [PLATFORMS[PLATFORM]]
    for platform in PLATFORMS.values():
        if platform.name == PLATFORM:
            continue
        if shutil.which(platform.compiler):
            platforms.append(platform)
        elif warn and platform.name not in _WARNED_MISSING:
            _WARNED_MISSING.add(platform.name)
            print(f"warning: {platform.compiler} not found, so the FMUs get no binaries/{platform.name}; "
                  f"to build them: {platform.install}", file=sys.stderr)
    return platforms


def compute_guid(component: Component, fmi_version: int = 2) -> str:
    """A GUID that changes whenever the table, the sources, or any platform's compiler and
    flags change (an FMI 3.0 FMU's instantiationToken: its facade is among the sources).

    It does not depend on which compilers this machine has: a shell without mingw-w64 on
    its PATH must not find every FMU stale. Installing mingw-w64 later rebuilds the FMUs
    all the same: build_fmu also wants every buildable platform's binary inside.

    Parameters
    ----------
    component : Component
        The component's variable table (pendfmu.components), hashed with its sources.
    fmi_version : int, optional
        2 or 3: the version whose facade is hashed.

    Returns
    -------
    str
        The GUID in braces, ``{xxxxxxxx-xxxx-...}``.
    """
    digest = hashlib.sha256()
    digest.update(repr(component).encode())
    digest.update(" ".join(CFLAGS).encode())
    for platform in PLATFORMS.values():
        if platform.name != PLATFORM:
            digest.update(f"\0{platform.name} {platform.compiler} {' '.join(platform.flags)}".encode())
    digest.update(__version__.encode())
    for name, text in _hand_written_sources(component, fmi_version).items():
        digest.update(name.encode() + b"\0" + text.encode())
    return "{" + str(uuid.UUID(digest.hexdigest()[:32])) + "}"


def fmu_path(component: Component, fmi_version: int = 2, folder: Path | None = None) -> Path:
    """Where a component's FMU is (or will be) built; nothing is built or checked.

    Parameters
    ----------
    component : Component
        The component's variable table (pendfmu.components).
    fmi_version : int, optional
        2 or 3.
    folder : Path, optional
        The FMU folder; by default the one pendfmu loads from (``compiler.fmu_folder()``).

    Returns
    -------
    Path
        ``<folder>/<Name>.fmu`` for FMI 2.0, ``<folder>/fmi3/<Name>.fmu`` for FMI 3.0.
    """
    return (folder or FMUS_DIR) / fmi_version_of(fmi_version).subfolder / f"{component.name}.fmu"


_DESCRIPTIONS: dict[tuple, object] = {}
# One description parsed at a time in a process. fmpy validates each against the FMI XML
# schema, and libxml2 sets up its schema types on the first schema parse of a process: two
# threads doing that at once (build_all's stale checks, one per component) left, about once
# in 60 processes, every later schema parse of the process failing with "xmlSchemaPValAttrNodeValue,
# the given type is not a built-in type" (measured with 10 threads, one FMU each). built_guid
# took that for a missing FMU, so a pytest worker rebuilt FMUs and failed a dozen tests.
_PARSING = threading.Lock()


def model_description(path: Path):
    """fmpy's parsed modelDescription.xml of an FMU file, kept while the file is unchanged
    (same inode, size and modification time). Parsing takes 1.5 ms, and checking, building
    and loading one system asks for each FMU's description four or five times (16 ms of a
    0.1 s `pendfmu simulate`). One thread parses at a time (_PARSING)."""
    path = Path(path)
    stat = path.stat()
    key = (str(path.resolve()), stat.st_ino, stat.st_size, stat.st_mtime_ns)
    with _PARSING:
        if key not in _DESCRIPTIONS:
            _DESCRIPTIONS[key] = fmpy.read_model_description(str(path))
    return _DESCRIPTIONS[key]


def built_guid(path: Path) -> str | None:
    """The GUID inside an existing FMU, or None if there is none readable."""
    try:
        return model_description(path).guid
    except Exception:  # a missing or broken file just means "build it"
        return None


def source_files(component: Component, guid: str, fmi_version: int = 2) -> dict[str, str]:
    files = _hand_written_sources(component, fmi_version)
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
    try:
        result = subprocess.run(command, capture_output=True, text=True)
    except FileNotFoundError:
        raise BuildError(f"no C compiler {cc!r} on this machine: install one (Debian: apt-get install gcc) or name "
                         f"it in the environment variable CC") from None
    if result.returncode != 0:
        raise BuildError(f"{cc} failed for {', '.join(str(s) for s in sources)}:\n{result.stderr}")


def compile_sources(source_dir: Path, output: Path, compiler: str | None = None, platform: str = PLATFORM) -> None:
    """Compile every .c file of a flat sources folder into the shared library `output`."""
    compile_library(sorted(str(p) for p in source_dir.glob("*.c")), output, [source_dir], compiler, platform)


def _holds_binaries(path: Path, version: FmiVersion) -> bool:
    """Whether the FMU at `path` has a binary for every platform this machine can build."""
    try:
        with zipfile.ZipFile(path) as fmu:
            folders = {name.split("/")[1] for name in fmu.namelist() if name.startswith("binaries/") and name.count("/") > 1}
    except (OSError, zipfile.BadZipFile):
        return False
    return all(version.binaries[p.name] in folders for p in built_platforms(warn=False))


def build_fmu(component: Component, force: bool = False, fmi_version: int = 2, folder: Path | None = None) -> Path:
    """Build a component's FMU unless an FMU of the same sources is already there.

    An FMU is stale when its GUID (:func:`compute_guid`) differs, or when it lacks the
    binary of a platform this machine can now build for. It is written whole or not at
    all: a reader never sees half an FMU.

    Parameters
    ----------
    component : Component
        What to build: a component's variable table (pendfmu.components).
    force : bool, optional
        Build even when an FMU of the same sources is there.
    fmi_version : int, optional
        2 (FMI 2.0) or 3 (FMI 3.0).
    folder : Path, optional
        The FMU folder, as for :func:`fmu_path`.

    Returns
    -------
    Path
        The FMU: ``<folder>/<Name>.fmu``, or ``<folder>/fmi3/<Name>.fmu`` for FMI 3.0.

    Raises
    ------
    BuildError
        No C compiler, or the compiler refused the sources (its output in the message).
    """
    version = fmi_version_of(fmi_version)
    target = fmu_path(component, fmi_version, folder)
    guid = compute_guid(component, fmi_version)
    if not force and target.exists() and built_guid(target) == guid and _holds_binaries(target, version):
        return target
    target.parent.mkdir(parents=True, exist_ok=True)
    files = source_files(component, guid, fmi_version)
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

        def write(out) -> None:
            with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as fmu:
                fmu.writestr("modelDescription.xml", version.model_description(component, guid, names))
                for name, library in libraries.items():
                    fmu.write(library, f"binaries/{version.binaries[name]}/{library.name}")
                for name in names:
                    fmu.write(sources / name, f"sources/{name}")
                fmu.writestr("sources/buildDescription.xml", description.build_description(component, names))

        write_atomically(target, writer=write)  # a reader never sees half an FMU
    return target
