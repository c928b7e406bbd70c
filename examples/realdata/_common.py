"""What every real-data example shares: where the raw files are, the rate and turning
points of a swinging angle, and the conversion-fit-result flow behind each ``run``.

Why one module: the tests (``tests/realdata*.py``) and ``scripts/realdata_fits.py`` use the
same conversions as the examples, so there is a single copy of each adapter, in
``<name>/convert.py``, loaded by :func:`load_example` (the folder names are the data sets'
own, with hyphens, so they cannot be imported as packages).

The raw files are third-party recordings licensed for internal testing only: they are read
in place from ``PENDFMU_REALDATA`` (default ``<repo>/../shared/realdata``) and everything
derived from them goes to the OUTDIR the user names, never into the repository.
"""

from __future__ import annotations

import importlib.util
import json
import os
import re
import shlex
import sys
from pathlib import Path


def _use_the_project_interpreter() -> None:
    """A `run` is started by the first python3 on PATH, which may not have pendfmu's
    dependencies: they live in the project's .venv (made by `make demo` or `make test`).
    Switch to that interpreter, or say how to get one (exit 2), instead of an ImportError."""
    if all(importlib.util.find_spec(module) for module in ("fmpy", "scipy", "numpy")):
        return
    venv = Path(__file__).resolve().parents[2] / ".venv"
    python = venv / "bin" / "python"
    if python.exists() and Path(sys.prefix).resolve() != venv.resolve():
        os.execv(str(python), [str(python), *sys.argv])
    print(f"{sys.argv[0]}: pendfmu's dependencies are not installed for {sys.executable}; `make test` makes "
          f"the project's .venv, which this script then uses", file=sys.stderr)
    sys.exit(2)


_use_the_project_interpreter()

import numpy as np  # noqa: E402

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
REALDATA = Path(os.environ.get("PENDFMU_REALDATA") or ROOT / ".." / "shared" / "realdata")


def available(*paths: Path) -> bool:
    return all(Path(p).is_file() for p in paths)


def load_example(name: str):
    """``examples/realdata/<name>/convert.py`` as a module (cached in sys.modules under a
    name of its own, so that its dataclasses pickle and load once per process)."""
    module_name = "realdata_example_" + re.sub(r"\W", "_", name)
    if module_name not in sys.modules:
        spec = importlib.util.spec_from_file_location(module_name, HERE / name / "convert.py")
        module = importlib.util.module_from_spec(spec)
        sys.modules[module_name] = module
        spec.loader.exec_module(module)
    return sys.modules[module_name]


# ------------------------------------------------------------------ swinging angles


def angular_rate(time: np.ndarray, phi: np.ndarray, window: int) -> np.ndarray:
    """The rate from a local cubic fit over `window` samples (odd)."""
    from scipy.signal import savgol_filter  # here: scipy.signal takes a second to import, which a run
                                            # that stops at a missing file should not spend
    return savgol_filter(phi, window, 3, deriv=1, delta=float(np.median(np.diff(time))))


def turning_points(time: np.ndarray, phi: np.ndarray, window: int) -> tuple[np.ndarray, np.ndarray]:
    """Indices (the sample of smallest |rate| at each sign change of the smoothed rate)
    and the extreme angles, refined by a parabola through the samples of one smoothing
    window around each (the extreme usually falls between samples)."""
    rate = angular_rate(time, phi, window)
    change = np.nonzero(np.sign(rate[1:]) != np.sign(rate[:-1]))[0]
    half = window // 2
    indices, extremes = [], []
    for i in change:
        i = i if abs(rate[i]) <= abs(rate[i + 1]) else i + 1
        if i < half or i + half >= len(phi):
            continue
        s = slice(i - half, i + half + 1)
        c = np.polyfit(time[s] - time[i], phi[s], 2)
        indices.append(i)
        extremes.append(np.polyval(c, -c[1] / (2 * c[0])))
    return np.array(indices), np.array(extremes)


# ------------------------------------------------------------------ the run flow


def write_inputs(recordings, params: dict[str, float], folder: Path) -> list[str]:
    """Recordings as CSV + sidecar and the parameters file, written into `folder`;
    returns their paths (recordings first, the parameters file last)."""
    from pendfmu.parameters import write_parameters
    from pendfmu.recording.writer import write_recording

    folder.mkdir(parents=True, exist_ok=True)
    files = [str(write_recording(r, folder / f"{r.path.stem}.csv")) for r in recordings]
    write_parameters(params, folder / "params.json")
    return [*files, str(folder / "params.json")]


def seeded(arguments) -> list[str]:
    """The global search's seed, where there is a global search to seed (--no-global has none)."""
    return [] if "--no-global" in arguments else ["--seed", "0"]


def fit_arguments(stage, recordings, params: dict[str, float], options, folder: Path) -> list[str]:
    """``fit STAGE RECORDING... --params P OPTIONS``, the recordings and parameters
    written into `folder` (the command up to --out and --seed). `stage` is a stage's name,
    or the arguments that stand in its place for a model fit (``("--fmu", "Cart.fmu")``)."""
    *files, params_file = write_inputs(recordings, params, folder)
    head = [stage] if isinstance(stage, str) else [str(a) for a in stage]
    return ["fit", *head, *files, "--params", params_file, *options]


def missing_source(convert) -> Path | None:
    return next((Path(p) for p in convert.SOURCES if not Path(p).is_file()), None)


def committable(folder: Path) -> bool:
    """Whether files in `folder` could end up in a commit: inside the repository and not
    under its git-ignored ``out/``. Derived data must not (the raw files' licences)."""
    folder = folder.resolve()
    return folder.is_relative_to(ROOT) and not folder.is_relative_to(ROOT / "out")


def run_example(convert, argv: list[str] | None = None, finish=None) -> int:
    """``run OUTDIR``: convert the raw files into OUTDIR, fit through pendfmu's command
    line, leave ``OUTDIR/result.json`` (what ``pendfmu fit --out`` writes) and
    ``OUTDIR/command.txt`` (the command, to repeat by hand). `finish(path)` may add to the
    result afterwards. Exit code: pendfmu's, or 2 when the raw data are absent or OUTDIR
    lies where git could pick it up (:func:`committable`)."""
    argv = sys.argv[1:] if argv is None else argv
    name = Path(convert.__file__).parent.name
    if len(argv) != 1:
        print(f"usage: examples/realdata/{name}/run OUTDIR", file=sys.stderr)
        return 2
    if committable(Path(argv[0])):
        print(f"{name}: OUTDIR {argv[0]} is inside the repository: the converted data must stay out of it "
              f"(use a folder outside it, or under {ROOT / 'out'}, which git ignores)", file=sys.stderr)
        return 2
    missing = missing_source(convert)
    if missing is not None:
        print(f"{name}: raw data file missing: {missing} (set PENDFMU_REALDATA to the folder that holds "
              f"{name}/)", file=sys.stderr)
        return 2
    from pendfmu.cli import main

    outdir = Path(argv[0])
    out = outdir / "result.json"
    arguments = fit_arguments(convert.STAGE, *convert.build(), convert.OPTIONS, outdir)
    command = [*arguments, "--out", str(out), *seeded(arguments), *convert.RUN_OPTIONS]
    (outdir / "command.txt").write_text("pendfmu " + shlex.join(command) + "\n")
    print("pendfmu " + shlex.join(command), flush=True)
    code = main(command)
    if out.is_file() and finish is not None:
        document = json.loads(out.read_text())
        finish(document)
        out.write_text(json.dumps(document, indent=1) + "\n")
    return code
