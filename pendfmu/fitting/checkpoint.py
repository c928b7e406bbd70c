"""Checkpoints of interrupted fits.

A fit interrupted by Ctrl-C writes the best parameters found so far and a checkpoint:
the cost of every candidate the global search had evaluated, keyed by its exact
coordinates. `--resume` runs the same seeded fit again; the search takes the same path
(it is deterministic), and every candidate already evaluated is looked up instead of
simulated. So a resumed fit ends at the same result, to the bit, as an uninterrupted one,
and repeats no finished simulation (only the short local refinement of the stage that was
interrupted runs again). Restarting an optimizer from its internal state instead would
tie the checkpoint to scipy's private bookkeeping.
"""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pendfmu.errors import PendfmuError, UsageError
from pendfmu.jsontext import parse_json


class Interrupted(PendfmuError):
    """A fit stopped by the user; carries the best parameter values found so far."""

    def __init__(self, parameters: dict[str, float], stage: str):
        super().__init__(f"interrupted during the {stage} stage")
        self.parameters = parameters
        self.stage = stage


def fingerprint(*parts: object, files: list[Path] = ()) -> str:
    """A hash of the fit's inputs: a checkpoint only resumes the fit it was written by."""
    digest = hashlib.sha256(json.dumps(parts, sort_keys=True, default=str).encode())
    for path in files:
        path = Path(path)
        digest.update(path.name.encode() + path.read_bytes())
        sidecar = path.with_suffix(".json")
        if sidecar.is_file():
            digest.update(sidecar.read_bytes())
    return digest.hexdigest()


def spec_fingerprint(spec) -> str:
    """The fingerprint of a fit's specification (spec.FitSpec): what it asks and the bytes
    of every file it reads. Where the candidates run (workers, a Dask scheduler) changes no
    cost, so a fit may resume on another machine."""
    request = spec.request()
    request["global_search"] = {k: v for k, v in request["global_search"].items() if k not in ("workers", "scheduler")}
    files = []
    model = (spec.target,) if spec.kind == "model" else ()
    for item in (*spec.recordings, *model, spec.params):
        if isinstance(item, (str, Path)) and Path(item).is_dir():
            files += sorted(f for f in Path(item).iterdir() if f.suffix.lower() in (".csv", ".mat") and f.is_file())
        elif isinstance(item, (str, Path)) and Path(item).is_file():
            files.append(Path(item))
    return fingerprint(request, files=files)


@dataclass
class Checkpoint:
    path: Path
    fingerprint: str
    costs: dict[str, dict[bytes, float]] = field(default_factory=dict)  # stage -> candidate -> cost

    def cache(self, stage: str) -> dict[bytes, float]:
        return self.costs.setdefault(stage, {})

    def save(self) -> Path:
        document = {"pendfmu_checkpoint": 1, "fingerprint": self.fingerprint,
                    "costs": {stage: {key.hex(): cost for key, cost in cache.items()}
                              for stage, cache in self.costs.items()}}
        partial = self.path.with_name(f".{self.path.name}.{os.getpid()}")
        partial.write_text(json.dumps(document))
        os.replace(partial, self.path)
        return self.path

    @classmethod
    def load(cls, path: str | Path, expected: str) -> Checkpoint:
        path = Path(path)
        try:
            document = parse_json(path.read_text())
        except (OSError, ValueError) as error:  # not UTF-8, not JSON, nested too deep, a huge number
            raise UsageError(f"{path}: not a readable checkpoint ({error})") from None
        if not isinstance(document, dict) or document.get("pendfmu_checkpoint") != 1:
            raise UsageError(f"{path}: not a pendfmu checkpoint")
        if document.get("fingerprint") != expected:
            raise UsageError(f"{path}: this checkpoint belongs to another fit (other recordings, parameters, "
                             f"seed or options); resume the fit it was written by")
        costs = {stage: {bytes.fromhex(key): float(cost) for key, cost in cache.items()}
                 for stage, cache in document.get("costs", {}).items()}
        return cls(path, expected, costs)


def best_candidate(cache: dict[bytes, float]) -> np.ndarray | None:
    """The unit-box vector with the lowest cost evaluated so far."""
    if not cache:
        return None
    key = min(cache, key=cache.get)
    return np.frombuffer(key, dtype=float).copy()
