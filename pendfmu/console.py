"""What a long command shows while it works: a progress bar over its steps on a terminal,
nothing in a pipe or a log file (where a bar's carriage returns are noise)."""

from __future__ import annotations

import sys
from collections.abc import Iterable, Iterator
from typing import TypeVar

T = TypeVar("T")


def on_terminal() -> bool:
    return sys.stderr.isatty()


def progress(items: Iterable[T], what: str, total: int | None = None, label=str) -> Iterator[T]:
    """`items`, with a tqdm bar on stderr named `what` (each item's `label` beside it)
    when stderr is a terminal; the items alone otherwise."""
    if not on_terminal():
        yield from items
        return
    from tqdm import tqdm

    with tqdm(items, desc=what, total=total, file=sys.stderr, leave=False) as bar:
        for item in bar:
            bar.set_postfix_str(label(item))
            yield item
