"""Build the corpus of FMUs pendfmu did not make, correct and broken (issue 24, item 8):
`build(model, variant, out_dir) -> Path` of `<out_dir>/<model>_<variant>.fmu`.

Three models are Python sources built by pythonfmu from PyPI, as a user of that generator
builds them (`pythonfmu build -f Model.py corpus_helpers.py`, in a child process); one is a C file compiled
against the FMI 2.0 headers fmpy ships and zipped with its hand-written description. A
broken variant is made from the same source: a Python line marked `# MUTATION <variant>` is
replaced by the line in MUTATIONS (and the class and module renamed, so that the variants
live side by side in one process); the C file is compiled with -DBREAK_<VARIANT>. Nothing
built is kept in git.
"""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

import fmpy

HERE = Path(__file__).resolve().parent

CORPUS: dict[str, dict[str, str | None]] = {
    "Lag": {"ok": None, "reset": "determinism", "nan": "inputs", "euler": "convergence"},
    "Thermostat": {"ok": None, "state": "rollback", "reset": "determinism", "nan": "inputs", "step": "convergence"},
    "Slider": {"ok": None, "step": "convergence"},
    "BouncingMass": {"ok": None, "events": "convergence", "state": "rollback", "reset": "determinism",
                     "nan": "inputs"},
}
"""Every model and its variants, each with the check made for its defect (None: correct)."""

SHARED_PARAMETERS = "self.parameters = DEFAULTS  # the module's own dict: shared by every instance, kept by fmi2Reset"
MUTATIONS: dict[tuple[str, str], str] = {
    ("Lag", "reset"): SHARED_PARAMETERS,
    ("Lag", "nan"): ('target = self.parameters["K"] * (interpolate(TABLE, self.u) if self.u <= TABLE[-1][0] '
                     'else math.nan)  # no extrapolation above the table'),
    ("Lag", "euler"): 'self.y += step_size / self.parameters["tau"] * (target - self.y)  # one Euler step per step',
    ("Thermostat", "reset"): SHARED_PARAMETERS,
    ("Thermostat", "nan"): ("cop = interpolate(COP, self.T_out) if self.T_out <= COP[-1][0] else math.nan  "
                            "# no extrapolation above the data sheet"),
    ("Thermostat", "state"): "pass  # the relay forgotten: pythonfmu saves the registered variables only",
    ("Thermostat", "step"): ('to_switch = 0.0 if (self.T >= self.parameters["T_set"] + self.parameters["band"] / 2 '
                             'if self.on else self.T <= self.parameters["T_set"] - self.parameters["band"] / 2) '
                             'else math.inf  # switched at communication points only'),
    ("Slider", "step"): "to_stop = math.inf  # the stop inside a step not located: friction's sign set per step",
}
"""(Python model, variant): the line that replaces the one marked `# MUTATION <variant>`."""

HELPERS = "corpus_helpers.py"
"""The module the Python models share, packed into each of their FMUs."""

C_FLAGS = ("-std=c99", "-O2", "-fPIC", "-shared", "-fvisibility=default", "-Wall", "-Wextra", "-Werror")


def build(model: str, variant: str, out_dir: str | Path) -> Path:
    """Build `model` as `variant` ("ok" or a key of CORPUS[model]) into out_dir; returns the FMU.

    Raises ValueError for an unknown model or variant, RuntimeError with the tool's output
    when pythonfmu or gcc fails."""
    if variant not in CORPUS.get(model, {}):
        known = ", ".join(f"{m}: {'/'.join(v)}" for m, v in CORPUS.items())
        raise ValueError(f"unknown corpus FMU {model!r} variant {variant!r}; known: {known}")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    if (HERE / f"{model}.c").exists():
        return _build_c(model, variant, out_dir)
    return _build_python(model, variant, out_dir)


def build_all(out_dir: str | Path) -> dict[tuple[str, str], Path]:
    """Every FMU of the corpus: {(model, variant): path}."""
    return {(model, variant): build(model, variant, out_dir) for model, variants in CORPUS.items()
            for variant in variants}


def mutated_source(model: str, variant: str) -> tuple[str, str]:
    """(module name, source) of a Python model's variant: the marked line replaced, the class
    renamed `<model>_<variant>`; the source itself for "ok"."""
    source = (HERE / f"{model}.py").read_text()
    if variant == "ok":
        return model, source
    marker = re.compile(rf"^(\s*)\S.*# MUTATION {variant}$", re.MULTILINE)
    if len(marker.findall(source)) != 1:
        raise RuntimeError(f"{model}.py needs exactly one line marked '# MUTATION {variant}'")
    source = marker.sub(lambda found: found.group(1) + MUTATIONS[model, variant], source)
    name = f"{model}_{variant}"
    return name, source.replace(f"class {model}(Fmi2Slave):", f"class {name}(Fmi2Slave):")


def _build_python(model: str, variant: str, out_dir: Path) -> Path:
    name, source = mutated_source(model, variant)
    fmu = out_dir / f"{model}_{variant}.fmu"
    with tempfile.TemporaryDirectory(prefix=f"{name}-") as work:
        script = Path(work) / f"{name}.py"
        script.write_text(source)
        helpers = shutil.copy(HERE / HELPERS, work)
        command = [sys.executable, "-m", "pythonfmu", "build", "-f", str(script), "-d", str(fmu),
                   "--handle-state", "--serialize-state", str(helpers)]
        done = subprocess.run(command, capture_output=True, text=True, cwd=work)
        if done.returncode != 0 or not fmu.is_file():
            raise RuntimeError(f"building {fmu.name} failed:\n{' '.join(command)}\n{done.stdout}{done.stderr}")
    return fmu


def _build_c(model: str, variant: str, out_dir: Path) -> Path:
    compiler = shutil.which("gcc")
    if compiler is None or not sys.platform.startswith("linux"):
        raise RuntimeError(f"{model} is built with gcc for linux64")
    headers = Path(fmpy.__file__).resolve().parent / "c-code"
    define = [] if variant == "ok" else [f"-DBREAK_{variant.upper()}"]
    if define and f"#ifdef BREAK_{variant.upper()}" not in (HERE / f"{model}.c").read_text():
        raise RuntimeError(f"{model}.c has no '#ifdef BREAK_{variant.upper()}': the variant would be the correct FMU")
    fmu = out_dir / f"{model}_{variant}.fmu"
    with tempfile.TemporaryDirectory(prefix=f"{model}-") as work:
        library = Path(work) / f"{model}.so"
        command = [compiler, *C_FLAGS, *define, f"-I{headers}", str(HERE / f"{model}.c"), "-o", str(library), "-lm"]
        done = subprocess.run(command, capture_output=True, text=True)
        if done.returncode != 0:
            raise RuntimeError(f"building {fmu.name} failed:\n{' '.join(command)}\n{done.stderr}")
        with zipfile.ZipFile(fmu, "w", zipfile.ZIP_DEFLATED) as archive:
            archive.write(HERE / f"{model}.xml", "modelDescription.xml")
            archive.write(library, f"binaries/linux64/{model}.so")
    return fmu


if __name__ == "__main__":
    target = Path(sys.argv[1]) if len(sys.argv) > 1 else Path("corpus-fmus")
    for built in build_all(target).values():
        print(built)
