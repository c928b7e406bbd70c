"""The one way pendfmu writes a file that someone may rely on: whole or not at all.

A result, a report page, an export or a checkpoint is first written to a new file beside
its target and then renamed over it (a rename within one folder is atomic on POSIX and on
Windows' NTFS). A write that fails (a full disk, an interrupt, an error while writing)
removes its partial file and leaves the previous target untouched, so a reader never sees
half a file, and two writers racing for one path leave one whole file, the last renamed.
"""

from __future__ import annotations

import os
import secrets
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import BinaryIO

from pendfmu.errors import OutputError


def write_atomically(path: str | Path, data: bytes | str | Iterable[bytes] | None = None,
                     writer: Callable[[BinaryIO], None] | None = None) -> Path:
    """Write `data` (bytes, text as UTF-8, or byte chunks), or call `writer` with the open
    binary file, to a new file in `path`'s folder, then rename it over `path`. The file is
    made with mode 0666 less the umask, as any new file (mkstemp's 0600 would hide a result
    from the group). Returns `path`. A write the system refuses (a full disk, a read-only
    folder) raises OutputError naming `path`, the previous file left as it was."""
    path = Path(path)
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
        os.replace(temporary, path)
    except BaseException as error:
        temporary.unlink(missing_ok=True)
        if isinstance(error, OSError) and error.filename in (None, str(temporary), str(path)) \
                and not isinstance(error, OutputError):  # about this file, not one a `writer` reads
            raise _refused(path, error) from error
        raise
    return path


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
