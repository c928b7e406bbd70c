"""The README's code blocks, as the README test runs them (tests/test_readme_runs.py).

The README's rule, stated at its top: every ``sh`` and ``python`` block runs as written, in
order, in a checkout after the two commands and ``. .venv/bin/activate``; a ``text`` block
is a template (its CAPITALS are placeholders) or a command for another machine; an
``output`` block right after a runnable block lists lines its run prints (``...`` stands
for lines left out). The first block, the two commands themselves, is the set-up the test
already stands in.
"""

from __future__ import annotations

import re
import textwrap
from dataclasses import dataclass
from pathlib import Path

RUNNABLE = ("sh", "python")
# A fence may be indented (a block inside a list item); its lines are then dedented.
FENCE = re.compile(r"^([ \t]*)```([\w-]*)[ \t]*\n(.*?)^\1```[ \t]*$", re.M | re.S)


@dataclass(frozen=True)
class Block:
    language: str
    code: str
    line: int  # of the opening fence, 1-based
    expected: tuple[str, ...] = ()  # the lines of the output block that follows, if any

    @property
    def label(self) -> str:
        return f"README.md:{self.line} ({self.language})"


def blocks(readme: Path) -> list[Block]:
    """Every fenced block, an output block attached to the runnable block before it."""
    text = readme.read_text()
    found: list[Block] = []
    for match in FENCE.finditer(text):
        language = match.group(2)  # output as printed: a table's common indent is part of it
        code = match.group(3) if language == "output" else textwrap.dedent(match.group(3))
        line = text.count("\n", 0, match.start()) + 1
        if language == "output" and found and found[-1].language in RUNNABLE:
            previous = found.pop()
            expected = tuple(l.rstrip() for l in code.splitlines() if l.strip() and l.strip() != "...")
            found.append(Block(previous.language, previous.code, previous.line, expected))
        else:
            found.append(Block(language, code, line))
    return found


def runnable(readme: Path) -> list[Block]:
    """The blocks the test runs: sh and python, without the first (the two commands)."""
    return [b for b in blocks(readme) if b.language in RUNNABLE][1:]
