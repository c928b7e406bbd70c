"""Temporary folders that go when the process that made them ends, however it ends.

pendfmu unpacks SSP archives and FMUs into temporary folders that must outlive the function
that made them (a loaded model simulates from them), so a `with` block cannot remove them.
`atexit` alone missed two exits: a worker process of multiprocessing or Dask ends through
os._exit, which skips it, and every worker that unpacked an FMU left its folder behind.
multiprocessing's finalizers run at the interpreter's exit and at a worker's exit alike,
and only in the process that registered them (a forked child never removes its parent's).
"""

from __future__ import annotations

import shutil
import tempfile
from multiprocessing import util
from pathlib import Path


def temporary_folder(prefix: str) -> Path:
    """A new, empty folder in the system's temporary folder, removed with everything in it
    when this process ends (normally, by an exception or Ctrl-C, or as a pool's worker)."""
    folder = Path(tempfile.mkdtemp(prefix=prefix))
    util.Finalize(None, shutil.rmtree, args=(str(folder), True), exitpriority=0)
    return folder
