"""Temporary folders that go when the process that made them ends, however it ends.

pendfmu unpacks SSP archives and FMUs into temporary folders that must outlive the function
that made them (a loaded model simulates from them), so a `with` block cannot remove them.
multiprocessing's finalizers run at the interpreter's exit (after a success, an error or
Ctrl-C) and also when a forked worker process ends normally, through os._exit, which skips
`atexit`; and only in the process that registered them, so a forked child never removes
its parent's folders. A process killed by a signal (kill -9, a pool's workers terminated)
runs neither: what it unpacked stays in the system's temporary folder.
"""

from __future__ import annotations

import shutil
import tempfile
from multiprocessing import util
from pathlib import Path


def temporary_folder(prefix: str) -> Path:
    """A new, empty folder in the system's temporary folder, removed with everything in it
    when this process ends (module docstring: how, and when not)."""
    folder = Path(tempfile.mkdtemp(prefix=prefix))
    util.Finalize(None, shutil.rmtree, args=(str(folder), True), exitpriority=0)
    return folder
