"""The one way pendfmu writes a file that someone may rely on: whole or not at all.

A result, a report page, an export or a checkpoint is first written to a new file beside
its target and then renamed over it (a rename within one folder is atomic on POSIX and on
Windows' NTFS). A write that fails (a full disk, an interrupt, an error while writing)
removes its partial file and leaves the previous target untouched, so a reader never sees
half a file, and two writers racing for one path leave one whole file, the last renamed.
Several files that belong together (a report's page and figures) are written all before
any is renamed (`write_together`). A write the system refuses is OutputError (exit 2),
naming the file.
"""

from __future__ import annotations

import os
import secrets
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import BinaryIO

from pendfmu.errors import OutputError


Data = bytes | str | Iterable[bytes] | None


def write_atomically(path: str | Path, data: Data = None, writer: Callable[[BinaryIO], None] | None = None) -> Path:
    """Write `data` (bytes, text as UTF-8, or byte chunks), or call `writer` with the open
    binary file, to a new file in `path`'s folder, then rename it over `path`. The file is
    made with mode 0666 less the umask, as any new file (mkstemp's 0600 would hide a result
    from the group). Returns `path`. A write the system refuses (a full disk, a read-only
    folder) raises OutputError naming `path`, the previous file left as it was."""
    path = Path(path)
    _commit([(_partial(path, data, writer), path)])
    return path


def write_together(files: Mapping[Path, Data]) -> list[Path]:
    """Write several files (path -> data, as write_atomically's) so that a failure changes
    none of them: each is written to its partial file first, and only when all are written
    are they renamed over their targets (renames need no room on the disk). Why: a report's
    page and its figures; a full disk while writing them must leave the earlier report whole,
    not its page with half the new figures. Returns the paths."""
    partials: list[tuple[Path, Path]] = []
    try:
        for path, data in files.items():
            partials.append((_partial(Path(path), data, None), Path(path)))
    except BaseException:
        for temporary, _ in partials:
            temporary.unlink(missing_ok=True)
        raise
    _commit(partials)
    return [path for _, path in partials]


def _partial(path: Path, data: Data, writer: Callable[[BinaryIO], None] | None) -> Path:
    """The written, closed partial file of `path` (removed again if the writing fails)."""
    try:
        handle, temporary = _new_beside(path)
    except OSError as error:
        raise _refused(path, error) from error
    try:
        with os.fdopen(handle, "wb") as out:
            if writer is not None:
                writer(out)
            elif isinstance(data, str):
                out.write(data.encode("utf-8"))
            elif isinstance(data, bytes | bytearray):
                out.write(data)
            else:
                for chunk in data or ():
                    out.write(chunk)
    except BaseException as error:
        temporary.unlink(missing_ok=True)
        if isinstance(error, OSError) and error.filename in (None, str(temporary)) \
                and not isinstance(error, OutputError):  # about this file, not one a `writer` reads
            raise _refused(path, error) from error
        raise
    return temporary


def _commit(partials: list[tuple[Path, Path]]) -> None:
    """Rename each partial file over its target; on a failure the partials not yet renamed go."""
    for k, (temporary, path) in enumerate(partials):
        try:
            os.replace(temporary, path)
        except OSError as error:
            for left, _ in partials[k:]:
                left.unlink(missing_ok=True)
            raise _refused(path, error) from error


def _refused(path: Path, error: OSError) -> OutputError:
    """The one-line error of a write the system refused, naming the file the user knows."""
    reason = error.strerror or str(error) or type(error).__name__
    return OutputError(f"{path}: cannot write it ({reason}); any earlier file of that name is unchanged")


def _new_beside(path: Path) -> tuple[int, Path]:
    """An exclusively created, hidden partial file beside `path`, and its name."""
    while True:
        temporary = path.with_name(f".{path.name}.{os.getpid()}.{secrets.token_hex(4)}.part")
        try:
            return os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666), temporary
        except FileExistsError:  # pragma: no cover - a 32-bit random name taken
            continue
