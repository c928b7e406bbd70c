"""Build the foreign test FMUs: `build(name, out_dir) -> Path` of `<out_dir>/<name>.fmu`.

The foreign FMUs (ForeignCart, NoStateCart, MEOnly, Colliding) stand for FMUs that pendfmu
did not make, so nothing here uses pendfmu: each one is its model file plus the small shared
layer `src/foreign_fmi2.c`, compiled by one gcc call against the FMI 2.0 headers that fmpy
ships (`fmpy/c-code/`), and zipped with its hand-written `src/<name>.xml` as
`modelDescription.xml` and the library as `binaries/linux64/<name>.so`. They are built at
test time into a temporary folder; no built FMU is kept in git.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

import fmpy

SOURCES = Path(__file__).resolve().parent / "src"

INTERFACE = {"ForeignCart": "CS", "NoStateCart": "CS", "MEOnly": "ME", "Colliding": "CS"}
"""Every foreign FMU and the one FMI interface it implements."""

CFLAGS = ("-std=c99", "-O2", "-fPIC", "-shared", "-fvisibility=hidden", "-Wall", "-Wextra", "-Werror")


def build(name: str, out_dir: str | Path, defines: tuple[str, ...] = (), sources: Path = SOURCES,
          fmu_name: str | None = None) -> Path:
    """Compile the foreign FMU `name` and write `<out_dir>/<fmu_name or name>.fmu`; returns
    its path. `defines` are extra -D macros (a planted bug, tests/foreign/mutants.py), `sources`
    a folder with (rewritten) copies of src/.

    Raises ValueError for an unknown name and RuntimeError with gcc's output when the
    compilation fails (a warning is an error: -Wall -Wextra -Werror)."""
    if name not in INTERFACE:
        raise ValueError(f"unknown foreign FMU {name!r}; known: {', '.join(INTERFACE)}")
    if not sys.platform.startswith("linux"):
        raise RuntimeError("the foreign FMUs are built for linux64 only")
    compiler = shutil.which("gcc")
    if compiler is None:
        raise RuntimeError("gcc is needed to build the foreign test FMUs")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    headers = Path(fmpy.__file__).resolve().parent / "c-code"
    with tempfile.TemporaryDirectory(prefix=f"{name}-") as work:
        library = Path(work) / f"{name}.so"
        command = [compiler, *CFLAGS, f"-DFOREIGN_{INTERFACE[name]}", *(f"-D{d}" for d in defines), f"-I{headers}",
                   f"-I{sources}", str(sources / "foreign_fmi2.c"), str(sources / f"{name}.c"), "-o", str(library), "-lm"]
        done = subprocess.run(command, capture_output=True, text=True)
        if done.returncode != 0:
            raise RuntimeError(f"building {name} failed:\n{' '.join(command)}\n{done.stderr}")
        fmu = out_dir / f"{fmu_name or name}.fmu"
        with zipfile.ZipFile(fmu, "w", zipfile.ZIP_DEFLATED) as archive:
            archive.write(sources / f"{name}.xml", "modelDescription.xml")
            archive.write(library, f"binaries/linux64/{name}.so")
    return fmu


def build_all(out_dir: str | Path) -> dict[str, Path]:
    """Every foreign FMU, built into `out_dir`: {name: path}."""
    return {name: build(name, out_dir) for name in INTERFACE}


if __name__ == "__main__":
    target = Path(sys.argv[1]) if len(sys.argv) > 1 else Path("foreign-fmus")
    for built in build_all(target).values():
        print(built)
