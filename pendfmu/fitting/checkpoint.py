"""Checkpoints of interrupted fits.

A fit interrupted by Ctrl-C, SIGTERM or SIGHUP writes the best parameters found so far and
a checkpoint: the cost of every candidate the global search had evaluated, keyed by its
exact coordinates. `--resume` runs the same seeded fit again; the search takes the same path
(it is deterministic), and every candidate already evaluated is looked up instead of
simulated. So a resumed fit ends at the same result, to the bit, as an uninterrupted one,
and repeats no finished simulation (only the short local refinement of the stage that was
interrupted runs again). Restarting an optimizer from its internal state instead would
tie the checkpoint to scipy's private bookkeeping.

The checkpoint is also saved every SAVE_PERIOD seconds while the search adds costs, so a fit
killed without warning (kill -9, the out-of-memory killer, a lost machine) loses at most that
much of its global search. Every save is atomic (pendfmu.atomic): a kill during a save leaves
the previous checkpoint. A checkpoint is deleted at the end only if the file is still this
fit's (its header names this fit's fingerprint), and a path that names the fit's output, one
of its inputs or any file that is not a pendfmu checkpoint is refused before the fit starts.
"""

from __future__ import annotations

import hashlib
import json
import re
import signal
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pendfmu.atomic import write_atomically
from pendfmu.errors import PendfmuError, UsageError
from pendfmu.jsontext import parse_json

SAVE_PERIOD = 30.0
"""Seconds between the saves of a running search's checkpoint. A save of a long search's
costs (3000 candidates, 0.4 MB of JSON) took 20 ms on the 2-core test machine, 0.07 % of
the period; a kill -9 loses at most this much of the search (plus the candidates then in
flight), while a shorter period would rewrite the file more often on a shared file system."""


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
    return fingerprint(request, files=input_files(spec))


def input_files(spec) -> list[Path]:
    """The files a fit reads besides the recordings' sidecars: its recordings (a folder's
    CSV and MAT files), its model's file and its parameters."""
    files = []
    model = (spec.target,) if spec.kind == "model" else ()
    for item in (*spec.recordings, *model, spec.params):
        if isinstance(item, (str, Path)) and Path(item).is_dir():
            files += sorted(f for f in Path(item).iterdir() if f.suffix.lower() in (".csv", ".mat") and f.is_file())
        elif isinstance(item, (str, Path)) and Path(item).is_file():
            files.append(Path(item))
    return files


HEADER = re.compile(rb'\{"pendfmu_checkpoint": 1, "fingerprint": "([^"\\]*)"')


def written_for(path: Path) -> str | None:
    """The fingerprint in the header of a pendfmu checkpoint at `path`; None for any other
    file. Only the first bytes are read (the header comes first): the path may name a
    recording of gigabytes."""
    try:
        with open(path, "rb") as file:
            found = HEADER.match(file.read(256))
    except OSError:
        return None
    return found.group(1).decode() if found else None


def refuse_unsafe_path(path: Path, out: str | Path, spec) -> None:
    """Refuse, before any work, a checkpoint path that would destroy a file when the
    checkpoint is written or deleted: the result (`out`), an input of the fit, or any
    existing file that is not a pendfmu checkpoint."""
    def same(other: Path) -> bool:
        try:
            return path.resolve() == other.resolve() or (other.exists() and path.exists() and path.samefile(other))
        except OSError:
            return False

    if same(Path(out)):
        raise UsageError(f"--checkpoint {path}: is the --out file; the checkpoint would replace the result")
    for item in input_files(spec):
        for name in (item, item.with_suffix(".json")):
            if same(name):
                raise UsageError(f"--checkpoint {path}: is an input of the fit ({name}); give another file")
    if path.exists() and written_for(path) is None:
        raise UsageError(f"--checkpoint {path}: the file exists and is not a pendfmu checkpoint; it would be "
                         f"overwritten and then deleted: give another file")


class CostMemory(dict):
    """A stage's costs by candidate: a dict that saves its checkpoint when SAVE_PERIOD has
    passed as costs are added (the search adds one as each is known)."""

    def __init__(self, checkpoint: Checkpoint, costs: dict[bytes, float] = ()):
        super().__init__(costs)
        self.checkpoint = checkpoint

    def __setitem__(self, key: bytes, cost: float) -> None:
        super().__setitem__(key, cost)
        self.checkpoint.save_if_due()


@dataclass
class Checkpoint:
    path: Path
    fingerprint: str
    costs: dict[str, dict[bytes, float]] = field(default_factory=dict)  # stage -> candidate -> cost
    saved: float = field(default_factory=time.monotonic)  # when last saved (or started)

    def __post_init__(self):
        self.costs = {stage: CostMemory(self, cache) for stage, cache in self.costs.items()}

    def cache(self, stage: str) -> dict[bytes, float]:
        return self.costs.setdefault(stage, CostMemory(self))

    def save(self) -> Path:
        document = {"pendfmu_checkpoint": 1, "fingerprint": self.fingerprint,  # the header: first, in this order
                    "costs": {stage: {key.hex(): cost for key, cost in cache.items()}
                              for stage, cache in self.costs.items()}}
        write_atomically(self.path, json.dumps(document))
        self.saved = time.monotonic()
        return self.path

    def save_if_due(self) -> None:
        if time.monotonic() - self.saved >= SAVE_PERIOD:
            self.save()

    def discard(self) -> None:
        """Delete the checkpoint of a completed fit: only if the file is this fit's."""
        if written_for(self.path) == self.fingerprint:
            self.path.unlink()

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
        try:
            costs = {stage: {bytes.fromhex(key): float(cost) for key, cost in cache.items()}
                     for stage, cache in document.get("costs", {}).items()}
        except (AttributeError, TypeError, ValueError) as error:
            raise UsageError(f"{path}: a damaged checkpoint ({error}); delete it and fit again") from None
        return cls(path, expected, costs)


@contextmanager
def stop_signals_interrupt() -> Iterator[None]:
    """SIGTERM and SIGHUP (what `timeout`, systemd, batch schedulers and CI time limits send,
    and a closed terminal) raise KeyboardInterrupt, as Ctrl-C does, while the block runs: the
    fit then writes its best values and its checkpoint. A signal the process was started
    ignoring (nohup) stays ignored."""
    def interrupt(number, frame):
        raise KeyboardInterrupt(signal.Signals(number).name)

    names = [name for name in ("SIGTERM", "SIGHUP") if hasattr(signal, name)]
    previous = {name: signal.getsignal(getattr(signal, name)) for name in names}
    for name in names:
        if previous[name] is not signal.SIG_IGN:
            signal.signal(getattr(signal, name), interrupt)
    try:
        yield
    finally:
        for name in names:  # None: a handler not set from Python, which Python cannot put back
            signal.signal(getattr(signal, name), previous[name] if previous[name] is not None else signal.SIG_DFL)


def best_candidate(cache: dict[bytes, float]) -> np.ndarray | None:
    """The unit-box vector with the lowest cost evaluated so far."""
    if not cache:
        return None
    key = min(cache, key=cache.get)
    return np.frombuffer(key, dtype=float).copy()
