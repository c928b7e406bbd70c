"""The code blocks of the README and of the documentation site's pages, and the one runner
that runs them all (tests/test_docs_runs.py; tests/test_docs_site.py checks their languages).

The rule, stated in the README and on the site's Getting started page: every ``sh`` and
``python`` block runs as written, in a checkout after the two commands and
``. .venv/bin/activate``; a ``text`` block is a template (its CAPITALS are placeholders) or a
command for another machine; an ``output`` block right after a runnable block lists lines its
run prints (``...`` stands for lines left out). The README's first block, the two commands
themselves, is the set-up the test already stands in. A docs page (MyST Markdown) also has
directives, fenced as ```{name} with the directive's arguments on the fence's line: they are
not code, except ```{include}, whose file is read as part of the page.

The order is the reader's: the README's blocks, then each page's in the site's reading order
(the toctrees from docs/index.md, depth first), all in one folder, so that a page may use
what an earlier one wrote (the walkthrough's rec/ and rig.json).
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import textwrap
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
DOCS = ROOT / "docs"
RUNNABLE = ("sh", "python")
# A fence may be indented (a block inside a list item); its lines are then dedented. Its
# language is a word, or a MyST directive ({name}) followed by its arguments.
FENCE = re.compile(r"^([ \t]*)```(?:(\{[\w:-]+\})[^\n]*|([\w-]*)[ \t]*)\n(.*?)^\1```[ \t]*$", re.M | re.S)
INCLUDE = re.compile(r"^```\{include\}[ \t]+(\S+)", re.M)
TOCTREE = re.compile(r"^```\{toctree\}[^\n]*\n(.*?)^```", re.M | re.S)


@dataclass(frozen=True)
class Block:
    language: str
    code: str
    line: int  # of the opening fence, 1-based
    expected: tuple[str, ...] = ()  # the lines of the output block that follows, if any
    page: str = "README.md"  # the file, as labels name it

    @property
    def label(self) -> str:
        return f"{self.page}:{self.line} ({self.language})"


def blocks(readme: Path, page: str | None = None) -> list[Block]:
    """Every fenced block, an output block attached to the runnable block before it; `page`
    names the file in labels (default: its name)."""
    text = readme.read_text()
    page = page or readme.name
    found: list[Block] = []
    for match in FENCE.finditer(text):
        language = match.group(2) or match.group(3)  # output as printed: a table's common indent is part of it
        code = match.group(4) if language == "output" else textwrap.dedent(match.group(4))
        line = text.count("\n", 0, match.start()) + 1
        if language == "output" and found and found[-1].language in RUNNABLE:
            previous = found.pop()
            expected = tuple(l.rstrip() for l in code.splitlines() if l.strip() and l.strip() != "...")
            found.append(Block(previous.language, previous.code, previous.line, expected, page))
        else:
            found.append(Block(language, code, line, page=page))
    return found


def runnable(readme: Path, setup: int = 1, page: str | None = None) -> list[Block]:
    """The blocks the test runs: sh and python, without the first `setup` ones (the
    README's first is the two commands; a docs page has none: setup=0)."""
    return [b for b in blocks(readme, page) if b.language in RUNNABLE][setup:]


def scratch(folder: Path) -> Path:
    """Links to the checkout's tracked top-level entries and its built FMUs only: what the
    blocks' commands write (rec/, rig.json, report/, ...) must land here, never in a
    checkout where someone followed the README by hand."""
    tracked = subprocess.run(["git", "-C", str(ROOT), "ls-files"], capture_output=True, text=True, check=True)
    for name in sorted({line.split("/", 1)[0] for line in tracked.stdout.splitlines()} | {"fmus"}):
        if (ROOT / name).exists():
            (folder / name).symlink_to(ROOT / name)
    (folder / ".venv").symlink_to(Path(sys.executable).parent.parent)  # the environment running the tests
    return folder


def run(block: Block, cwd: Path, code: str) -> subprocess.CompletedProcess:
    """One block's `code` (the block's own, or as a test changed it) run in `cwd`, with the
    project's venv first on PATH as `. .venv/bin/activate` puts it."""
    bin_dir = Path(sys.executable).parent
    env = {**os.environ, "PATH": f"{bin_dir}{os.pathsep}{os.environ.get('PATH', '')}",
           "VIRTUAL_ENV": str(bin_dir.parent)}
    env.pop("PYTHONPATH", None)
    command = ["bash", "-e", "-o", "pipefail", "-c", code] if block.language == "sh" else \
        [str(bin_dir / "python"), "-"]
    return subprocess.run(command, input=None if block.language == "sh" else code, cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=900)


def name(path: Path) -> str:
    """A file as labels name it: its path in the checkout."""
    return str(Path(path).resolve().relative_to(ROOT))


def page_blocks(page: Path) -> list[Block]:
    """A docs page's blocks, and those of each file it includes (as part of the page)."""
    found = blocks(page, name(page))
    for included in INCLUDE.findall(page.read_text()):
        found += page_blocks((page.parent / included).resolve())
    return found


def reading_order(page: Path = DOCS / "index.md") -> list[Path]:
    """The site's pages in its reading order: a page, then the pages its toctrees list, each
    followed by its own (depth first, as Sphinx's navigation reads them)."""
    order = [page]
    for tree in TOCTREE.findall(page.read_text()):
        for entry in tree.splitlines():
            entry = entry.strip()
            if entry and not entry.startswith(":"):
                order += reading_order((page.parent / entry).with_suffix(".md"))
    return order


def walk() -> list[Block]:
    """Every block the runner runs, in its order: the README's (without its set-up block),
    then each page's in the site's reading order."""
    found = runnable(README)
    for page in reading_order():
        found += [b for b in page_blocks(page) if b.language in RUNNABLE]
    return found
