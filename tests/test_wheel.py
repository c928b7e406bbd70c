"""pendfmu as a real package: a wheel built from the checkout's tracked files installs into a
fresh virtual environment, and that installation builds the FMUs from the C sources it
carries (package data read through importlib.resources) into the user's cache and
simulates with them.

The installed copy must compute what the checkout computes: the same sources and compiler
flags give the same GUIDs, and `pendfmu simulate` gives the same file, byte for byte. One
version number: the wheel's metadata and ``pendfmu.__version__`` agree.

It needs git (to list the tracked files, as a clean clone would have them). The fresh venv
sees the test environment's packages through a path file, not its own copies of them (pip
installing numpy, scipy, pandas, matplotlib... took 100 s of the suite's time): the wheel is
installed without them; `pip check` then says whether the wheel's declared dependencies are
met by those packages (one named wrongly fails), and every package the installed pendfmu
imports must be among them or theirs (one the wheel forgot fails).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from pendfmu.fmubuild import ALL_COMPONENTS, compute_guid
from pendfmu.fmubuild.compiler import model_description

ROOT = Path(__file__).resolve().parents[1]


def _tracked_files() -> list[str]:
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("needs a git checkout to build the wheel from its tracked files")
    listing = subprocess.run(["git", "-C", str(ROOT), "ls-files", "-z"], capture_output=True, check=True)
    return [name for name in listing.stdout.decode().split("\0") if name]


def _run(command: list[str], **kwargs) -> subprocess.CompletedProcess:
    result = subprocess.run(command, capture_output=True, text=True, **kwargs)
    assert result.returncode == 0, f"{' '.join(command)} failed:\n{result.stdout}\n{result.stderr}"
    return result


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """A fresh venv with the wheel of the tracked files installed; its bin folder."""
    tmp = tmp_path_factory.mktemp("wheel")
    clone = tmp / "clone"
    for name in _tracked_files():
        if (ROOT / name).is_file():  # a deletion not yet committed is not in a clone either
            (clone / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(ROOT / name, clone / name)
    _run([sys.executable, "-m", "pip", "wheel", "--quiet", "--no-deps", "--wheel-dir", str(tmp / "dist"),
          str(clone)])
    wheels = list((tmp / "dist").glob("pendfmu-*.whl"))
    assert len(wheels) == 1, wheels
    _run([sys.executable, "-m", "venv", str(tmp / "venv")])
    bin_dir = tmp / "venv" / "bin"
    _see_the_test_environments_packages(bin_dir)
    _run([str(bin_dir / "python"), "-m", "pip", "install", "--quiet", "--disable-pip-version-check", "--no-deps",
          str(wheels[0])])
    _run([str(bin_dir / "python"), "-m", "pip", "check", "--disable-pip-version-check"])
    return bin_dir


def _see_the_test_environments_packages(bin_dir: Path) -> None:
    """A path file in the fresh venv naming the test environment's site-packages: its
    packages importable after the venv's own (so the installed pendfmu comes first), and its
    path files unread (so the checkout's editable pendfmu stays out)."""
    import site

    own = subprocess.run([str(bin_dir / "python"), "-c", "import site; print(site.getsitepackages()[0])"],
                         capture_output=True, text=True, check=True).stdout.strip()
    (Path(own) / "test-environment.pth").write_text("\n".join(site.getsitepackages()) + "\n")


def _clean_env(cache: Path) -> dict[str, str]:
    """The installed copy alone: no checkout on the path, no FMU folder override."""
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PENDFMU_FMU_DIR")}
    env["XDG_CACHE_HOME"] = str(cache)
    return env


@pytest.mark.skipif(sys.platform != "linux", reason="the cache folder asserted is the XDG one")
def test_wheel_installs_builds_and_simulates_like_the_checkout(installed, tmp_path):
    from pendfmu import __version__

    env, work = _clean_env(tmp_path / "cache"), tmp_path / "work"
    work.mkdir()
    python = str(installed / "python")
    where = _run([python, "-c", "import importlib.metadata as m, pendfmu; "
                  "print(pendfmu.__file__); print(pendfmu.__version__); print(m.version('pendfmu'))"],
                 cwd=work, env=env).stdout.split()
    assert Path(where[0]).is_relative_to(installed.parent), f"imported {where[0]}, not the installed copy"
    assert where[1] == where[2] == __version__

    # FMI 2.0 only: the GUIDs and the simulation asserted are its FMUs', and the FMI 3.0 build from
    # the same package data is the same code path with the other version (half the compiling)
    built = _run([str(installed / "pendfmu"), "build", "--fmi", "2"], cwd=work, env=env).stdout
    cache = tmp_path / "cache" / "pendfmu" / __version__ / "fmus"
    for name, component in ALL_COMPONENTS.items():
        assert f"{name}: {cache / (name + '.fmu')}" in built
        assert model_description(cache / f"{name}.fmu").guid == compute_guid(component)

    time = np.round(np.arange(0, 1001) * 2e-4, 10)
    recording = work / "step.csv"
    pd.DataFrame({"time": time, "I_c": np.where(time >= 0.02, 1.5, 0.0)}).to_csv(recording, index=False)
    _run([str(installed / "pendfmu"), "simulate", "--input", str(recording), "--out", "installed.csv"],
         cwd=work, env=env)
    _run([sys.executable, "-m", "pendfmu", "simulate", "--input", str(recording), "--out", "checkout.csv"],
         cwd=work, env={**os.environ, "PYTHONPATH": str(ROOT)})
    installed_run = (work / "installed.csv").read_bytes()
    assert installed_run == (work / "checkout.csv").read_bytes()
    assert pd.read_csv(work / "installed.csv")["x"].iloc[-1] > 0.01  # the drive moved the cart


CLOSURE = """
import ast, importlib.metadata as m, re, sys
from pathlib import Path
import pendfmu
imported = set()
for source in Path(pendfmu.__file__).parent.rglob("*.py"):
    for node in ast.walk(ast.parse(source.read_bytes())):
        if isinstance(node, ast.Import):
            imported |= {alias.name.split(".")[0] for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0:
            imported.add(node.module.split(".")[0])
owners = m.packages_distributions()
declared, todo = set(), [("pendfmu", None)]
while todo:
    name, extras = todo.pop()  # extras None: pendfmu's own, all of them (Dask, the test tools)
    try:
        requirements = m.requires(name) or []
    except m.PackageNotFoundError:  # a requirement for another platform (pip check holds the rest)
        continue
    for requirement in requirements:
        extra = re.search(r"extra\\s*==\\s*['\\"]([^'\\"]+)", requirement)
        if extra and extras is not None and extra.group(1) not in extras:
            continue
        wanted, asked = re.match(r"([A-Za-z0-9_.-]+)(?:\\[([^]]*)\\])?", requirement).groups()
        wanted = wanted.lower().replace("_", "-")
        if wanted not in declared:
            declared.add(wanted)
            todo.append((wanted, {e.strip() for e in (asked or "").split(",")}))
for name in sorted(imported - set(sys.stdlib_module_names) - {"pendfmu", "__future__"}):
    dists = {d.lower().replace("_", "-") for d in owners.get(name, [])}
    if not dists & declared:
        print(name, sorted(dists))
"""


def test_every_package_the_installed_copy_imports_is_a_declared_dependency(installed, tmp_path):
    """A dependency the wheel forgot would import here from the test environment's packages:
    each top-level package that an import statement anywhere in the installed pendfmu names
    (lazy ones inside functions too) must belong to a distribution the wheel requires (its
    extras included: Dask, pytest for the plugin), or one those require."""
    undeclared = _run([str(installed / "python"), "-c", CLOSURE], cwd=tmp_path,
                      env=_clean_env(tmp_path / "cache")).stdout
    assert undeclared == "", f"imported, not declared: {undeclared}"


def test_build_out_writes_the_fmus_where_asked(installed, tmp_path):
    env = _clean_env(tmp_path / "cache")
    out = tmp_path / "mine"
    _run([str(installed / "pendfmu"), "build", "--out", str(out), "--fmi", "2"], cwd=tmp_path, env=env)
    assert sorted(p.name for p in out.glob("*.fmu")) == sorted(f"{n}.fmu" for n in ALL_COMPONENTS)
    assert not (tmp_path / "cache" / "pendfmu").exists()


def test_the_recording_format_ships_with_the_package(installed, tmp_path):
    """A user who pip-installed pendfmu has the recording format: `pendfmu format` prints the
    installed copy of FORMAT.md, the checkout's text."""
    env = _clean_env(tmp_path / "cache")
    where = Path(_run([str(installed / "pendfmu"), "format", "--path"], cwd=tmp_path, env=env).stdout.strip())
    assert where.is_relative_to(installed.parent) and where.is_file()
    printed = _run([str(installed / "pendfmu"), "format"], cwd=tmp_path, env=env).stdout
    assert printed == (ROOT / "pendfmu" / "recording" / "FORMAT.md").read_text(encoding="utf-8")
