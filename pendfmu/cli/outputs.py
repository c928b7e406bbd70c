"""Output paths checked before any work: a fit of minutes must not end in "cannot write".

Each check raises UsageError (exit code 2) naming the option and the path.
"""

from __future__ import annotations

import os
from pathlib import Path

from pendfmu.errors import UsageError


def check_output_file(path: str | os.PathLike, option: str) -> Path:
    """A file the command will write: its folder exists and is writable, and the path is
    not a folder. An existing file is overwritten (as the user asked for it)."""
    path = Path(path)
    if path.is_dir():
        raise UsageError(f"{option} {path}: is a folder; give a file name")
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        raise UsageError(f"{option} {path}: the folder {folder} does not exist")
    if not os.access(folder, os.W_OK):
        raise UsageError(f"{option} {path}: cannot write into the folder {folder}")
    if path.exists() and not os.access(path, os.W_OK):
        raise UsageError(f"{option} {path}: the file exists and is not writable")
    return path


def check_output_folder(path: str | os.PathLike, option: str) -> Path:
    """A folder the command will write into (created if missing): not an existing file,
    and its nearest existing parent writable."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise UsageError(f"{option} {path}: exists and is not a directory")
    existing = path
    while not existing.exists():
        existing = existing.parent
    if not existing.is_dir():
        raise UsageError(f"{option} {path}: {existing} is a file, so the folder cannot be made")
    if not os.access(existing, os.W_OK):
        raise UsageError(f"{option} {path}: cannot write into {existing}")
    return path
