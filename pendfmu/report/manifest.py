"""Which files of a report folder pendfmu wrote, so that a new report can remove them.

A report written into a folder that held an earlier one must not show, or leave lying
beside it, the earlier report's figures (a recording since dropped, a friction curve no
longer fitted). But the folder may hold files of the user's own (notes, a README, the
recordings themselves): only what pendfmu wrote may go. Each report therefore lists
the files it wrote in MANIFEST; the next report removes exactly those (plain names of
files directly in the folder, nothing else) before writing its own.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
from collections.abc import Iterable, Iterator
from pathlib import Path

from pendfmu.atomic import write_atomically
from pendfmu.jsontext import parse_json

MANIFEST = ".pendfmu-report.json"
KIND = "pendfmu report"


def previous_files(directory: Path) -> list[Path]:
    """The files an earlier report listed in `directory`'s manifest and that are still
    there; an unreadable or foreign manifest lists none (nothing is removed on a guess)."""
    try:
        document = parse_json((directory / MANIFEST).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return []
    if not isinstance(document, dict) or document.get("kind") != KIND or not isinstance(document.get("files"), list):
        return []
    found = []
    for name in document["files"]:
        # a plain file name only: never a path that leads out of the folder or into a sub-folder
        if isinstance(name, str) and name and name == Path(name).name and name not in (".", "..", MANIFEST):
            path = directory / name
            if path.is_file() and not path.is_symlink():
                found.append(path)
    return found


LEGACY_FIGURE = re.compile(r"(fit-\d\d-[A-Za-z0-9_.-]*|friction-(cart|pendulum))\.png")


def legacy_files(directory: Path) -> list[Path]:
    """The files of a report pendfmu wrote before it kept a manifest: its index.html (a
    page titled "pendfmu fit report") and the figures that page shows under the names
    pendfmu gave them. Anything else stays."""
    index = directory / "index.html"
    if not is_pendfmu_page(index):
        return []
    text = index.read_text(encoding="utf-8", errors="replace")
    shown = set(re.findall(r'<img src="([^"/\\]+)"', text))
    figures = [directory / name for name in sorted(shown) if LEGACY_FIGURE.fullmatch(name)]
    return [index] + [f for f in figures if f.is_file() and not f.is_symlink()]


def earlier_report_files(directory: Path) -> list[Path]:
    """The files of the report written earlier into `directory` (by its manifest, or as a
    report from before manifests): those a new report may remove."""
    return previous_files(directory) if (directory / MANIFEST).exists() else legacy_files(directory)


def is_pendfmu_page(path: Path) -> bool:
    """Whether `path` is a page a pendfmu report wrote (its title says so): a new report
    may replace it even where the manifest is gone or broken, never a page of the user's."""
    try:
        head = path.read_text(encoding="utf-8", errors="replace")[:4000]
    except OSError:
        return False
    return re.search(r"<title>pendfmu (fit report|comparison)", head) is not None


def remove_previous(earlier: Iterable[Path], keep: Iterable[Path] = ()) -> list[Path]:
    """Remove the files of the report written earlier (`earlier`, as earlier_report_files
    found them before the new report was written) but those in `keep` (the new report's,
    already in place); returns the removed. The manifest is then written anew."""
    kept = {Path(path) for path in keep}
    removed = sorted(Path(path) for path in earlier if Path(path) not in kept)
    for path in removed:
        path.unlink(missing_ok=True)
    return removed


def write_manifest(directory: Path, files: Iterable[Path]) -> Path:
    """List the files this report wrote (names relative to `directory`)."""
    names = sorted({Path(f).name for f in files})
    return write_atomically(directory / MANIFEST, json.dumps({"kind": KIND, "files": names}, indent=1) + "\n")


@contextlib.contextmanager
def folder_lock(directory: Path) -> Iterator[None]:
    """Hold `directory` for one report at a time: an exclusive lock on the folder itself
    (flock, released when the process ends, however it ends; no lock file to leave behind).
    Why: a second report reading the folder while the first replaces its files took the
    first one's new files for a stranger's ("was not written by a pendfmu report") or
    removed them under it. Where flock does not exist (Windows) reports do not take turns."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover - Windows
        yield
        return
    handle = os.open(directory, os.O_RDONLY)
    try:
        fcntl.flock(handle, fcntl.LOCK_EX)
        yield
    finally:
        os.close(handle)
