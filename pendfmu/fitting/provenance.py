"""Where a result came from: enough to rerun the fit and to tell two results apart.

A result file without its provenance cannot answer the first questions asked of it a month
later: which recordings (the same file names may hold new data: hence their sha256), which
seed, bounds and start values, which parameters were free, and which versions of pendfmu
and its numerical libraries computed it. `fit` records these per stage; `fit_all` merges
its stages' records; the command line adds its own argv (`with_command`).

The record is plain JSON (strings, numbers, lists, objects), so it is written to and read
back from the result file unchanged, and a result file written before provenance existed
simply has none.
"""

from __future__ import annotations

import hashlib
import platform
import sys
from collections.abc import Iterable, Mapping, Sequence
from datetime import datetime, timezone
from importlib import metadata
from pathlib import Path

LIBRARIES = ("numpy", "scipy", "fmpy")


def sha256(path: Path) -> str:
    with open(path, "rb") as stream:
        return hashlib.file_digest(stream, "sha256").hexdigest()


def input_file(path: str | Path) -> dict:
    """One input file: its path as given, its size and its sha256 (None when it cannot be
    read any more, e.g. a temporary recording deleted before the result was written)."""
    path = Path(path)
    try:
        return {"path": str(path), "bytes": path.stat().st_size, "sha256": sha256(path)}
    except OSError:
        return {"path": str(path), "bytes": None, "sha256": None}


def recording_files(recordings: Iterable) -> list[dict]:
    """The files of recordings (Recording objects): each data file and its sidecar, once."""
    seen: dict[str, dict] = {}
    for recording in recordings:
        for path in (getattr(recording, "path", None), getattr(recording, "sidecar", None)):
            if path is not None and str(path) not in seen:
                seen[str(path)] = input_file(path)
    return list(seen.values())


def versions() -> dict[str, str | None]:
    """pendfmu's, Python's and the numerical libraries' versions (None: not installed)."""
    from pendfmu import __version__

    found: dict[str, str | None] = {"pendfmu": __version__, "python": platform.python_version()}
    for name in LIBRARIES:
        try:
            found[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            found[name] = None
    return found


def environment() -> dict:
    """What does not depend on the fit: versions, platform and the date (UTC, ISO 8601)."""
    return {"versions": versions(), "platform": platform.platform(),
            "date": datetime.now(timezone.utc).isoformat(timespec="seconds")}


def stage_record(problem, spec, start: Sequence[float]) -> dict:
    """One stage's (or model's) set-up as it was fitted: its free parameters with search
    boxes, scales and start values (by label: a recording's own parameter is phi0[run1]),
    the fixed values it ran with, each recording's drives and matches, and the settings of
    the search and the intervals. Read from the problem that was solved, not from the
    options that were asked for, so that an option that changed nothing shows as such."""
    free = problem.free
    free_names = {p.name for p in free if p.experiment is None}
    search = spec.global_search
    return {
        "stage": problem.name, "seed": spec.seed_value, "cost": spec.cost,
        **({"model": problem.model_file} if problem.model_file else {}),
        "free": [p.label for p in free],
        "bounds": {p.label: [float(p.low), float(p.high)] for p in free},
        "scale": {p.label: "log" if p.log else "linear" for p in free},
        "relative_to": {p.label: p.relative_to for p in free if p.relative_to},
        "start": {p.label: float(v) for p, v in zip(free, start)},
        "fixed": {name: float(v) for name, v in sorted(problem.values.items()) if name not in free_names},
        "recordings": {e.name: _experiment_record(e) for e in problem.experiments},
        "search": {"global": search.enabled, "popsize": search.popsize, "maxiter": search.maxiter,
                   "workers": search.workers, "scheduler": search.scheduler},
        "uncertainty": {"method": spec.uncertainty,
                        **({"replicates": spec.replicate_count} if spec.uncertainty == "bootstrap" else {})},
        **({"harmonic": spec.harmonic} if problem.name == "current" else {}),
    }


def _experiment_record(experiment) -> dict:
    """What one recording (window, segment) was fitted with: its span, its drives (model
    input -> recorded column and interpolation), matches (a stage's recorded rate among
    them when asked), own values, the known initial states it started from (the sidecar's,
    or the rate at a turning point) and what told each estimated initial state's box."""
    recording = experiment.recording
    span = [float(recording.time[0]), float(recording.time[-1])]
    return {"file": str(recording.path) if recording.path else None, "span": span,
            "drives": {name: list(drive) for name, drive in experiment.setup.drives.items()},
            "match": dict(experiment.match), "estimated": sorted(experiment.estimated),
            "starts": [[s.parameter, s.source] for s in experiment.setup.starts],
            "read_from": {name: s.source for name, s in experiment.read_from.items()},
            "initial": {name: float(value) for name, value in recording.initial.items()},
            "sidecar": sorted(recording.parameters)}


def fit_record(problem, spec, start: Sequence[float]) -> dict:
    """The provenance of one fit: environment, input files, the request (the FitSpec as
    given) and its stage's set-up as fitted."""
    inputs = recording_files(e.recording for e in problem.experiments)
    if problem.model_file:
        inputs.append(input_file(problem.model_file))
    return {**environment(), "seed": spec.seed_value, "inputs": inputs, "request": spec.request(),
            "stages": {problem.name: stage_record(problem, spec, start)}}


def merged(records: Sequence[Mapping], extra_inputs: Iterable = ()) -> dict:
    """The provenance of a sequence of fits (fit_all): one environment, every input once,
    the stages side by side; `extra_inputs` are recordings only predicted."""
    if not records:
        return {}
    inputs: dict[str, dict] = {}
    for record in records:
        for entry in record.get("inputs", []):
            inputs.setdefault(entry["path"], entry)
    for entry in recording_files(extra_inputs):
        inputs.setdefault(entry["path"], {**entry, "predicted": True})
    stages = {name: stage for record in records for name, stage in record.get("stages", {}).items()}
    return {**environment(), "seed": records[0].get("seed"), "inputs": list(inputs.values()), "stages": stages}


def with_command(record: Mapping, argv: Sequence[str] | None = None) -> dict:
    """The record with the command line that ran the fit (sys.argv by default; the
    command line passes its own, as main(argv) is also called in-process)."""
    return {**record, "command": list(sys.argv if argv is None else argv)}
