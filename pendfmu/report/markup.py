"""The pieces every report page is built of: escaped text, numbers and intervals for
table cells, tables, sections and figures. Every text that comes from a result is escaped
here, by `_text`; markup is only ever built from escaped pieces (html.py, compare.py,
assessment.py build their pages of them).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence

from pendfmu.escaping import html_text
from pendfmu.report.content import finite, interval_text
from pendfmu.report.figures import Picture

DASH = "—"  # what a missing or undefined number shows


def _text(value) -> str:
    """Any value as escaped HTML text (escaping.py's, the one HTML escape of pendfmu)."""
    return html_text(value)


def number(value, digits: int = 6) -> str:
    """A number for a table cell: a dash when it is missing or not finite."""
    if not finite(value):
        return DASH
    return f"{float(value):.{digits}g}"


def interval(bounds: Sequence[float] | None) -> str:
    """An interval for a table cell; an unbounded side shows as inf."""
    if bounds is None or any(math.isnan(float(b)) for b in bounds):
        return DASH
    return interval_text(*bounds)


def _cell(content: str, css: str = "") -> str:
    """A table cell from already escaped markup."""
    return f'<td class="{css}">{content}</td>' if css else f"<td>{content}</td>"


def _table(headers: Iterable[str], rows: Iterable[str], caption: str = "") -> str:
    head = "".join(f'<th scope="col">{_text(h)}</th>' for h in headers)
    caption = f"<caption class=\"muted\">{_text(caption)}</caption>" if caption else ""
    return f"<table>{caption}<thead><tr>{head}</tr></thead><tbody>\n" + "\n".join(rows) + "\n</tbody></table>"


def _section(title: str, body: str) -> str:
    return f"<section>\n<h2>{_text(title)}</h2>\n{body}\n</section>"


def _figures(pictures: list[Picture]) -> str:
    return "\n".join(
        f'<figure><img src="{_text(p.file)}" alt="{_text(p.title)}">'
        f"<figcaption>{_text(p.title)}: {_text(p.caption)}</figcaption></figure>" for p in pictures)
