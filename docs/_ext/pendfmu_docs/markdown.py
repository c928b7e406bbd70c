"""Small helpers to write Markdown (MyST) from the code's own texts."""

from __future__ import annotations

import re

# CommonMark's backslash escapes: what could start emphasis, a link, HTML, a table cell or a heading.
_SPECIAL = re.compile(r"([\\*_\[\]<>|#~$])")
_CODE = re.compile(r"(`+)(.+?)\1", re.S)


def plain(text: str) -> str:
    """`text` as Markdown that shows it as written: code spans (`x`, ``x``) kept, every other
    character that Markdown would read as markup escaped."""
    out, last = [], 0
    for match in _CODE.finditer(text):
        out.append(_SPECIAL.sub(r"\\\1", text[last:match.start()]))
        out.append(f"`{match.group(2).strip()}`")
        last = match.end()
    out.append(_SPECIAL.sub(r"\\\1", text[last:]))
    return "".join(out)


def fence(text: str, language: str = "text") -> str:
    """A fenced block of `text` as it is (a longer fence where the text holds one)."""
    ticks = "`" * max(3, 1 + max((len(run) for run in re.findall(r"`+", text)), default=0))
    return f"{ticks}{language}\n{text.rstrip()}\n{ticks}\n"


def docstring(text: str) -> str:
    """A docstring-style description (pendfmu's commands have them): prose paragraphs
    joined and escaped, a paragraph whose lines are all indented (examples) as a block."""
    parts = []
    for paragraph in re.split(r"\n\s*\n", text.strip("\n")):
        lines = paragraph.split("\n")
        if all(line.startswith("    ") for line in lines):
            parts.append(fence("\n".join(line[4:] for line in lines)))
        else:
            parts.append(plain(" ".join(line.strip() for line in lines)) + "\n")
    return "\n".join(parts)


def table(header: list[str], rows: list[list[str]], right: tuple[int, ...] = ()) -> str:
    """A pipe table of Markdown cells (a | left in a cell, in a code span too, is escaped);
    the columns numbered in `right` aligned right (numbers)."""

    def cell(text: str) -> str:
        return re.sub(r"(?<!\\)\|", r"\\|", text.replace("\n", " "))

    rule = "|" + "".join("---:|" if k in right else "---|" for k in range(len(header)))
    lines = ["| " + " | ".join(header) + " |", rule]
    lines += ["| " + " | ".join(cell(text) for text in row) + " |" for row in rows]
    return "\n".join(lines) + "\n"
