"""JSON text read from a user's file: what the json module would crash on is refused as malformed.

Python's json parser recurses once per nesting level and gives up with RecursionError
(an "internal failure") past about a thousand levels; and it refuses an integer of more than
4300 digits with a ValueError that is no JSONDecodeError. A file someone sent us may hold
either. `parse_json` raises json.JSONDecodeError for both, with the line and column where
the file goes wrong, so every reader that already says "not valid JSON at line L, column
C" (sidecars, parameters files, result files) says it for these too.
"""

from __future__ import annotations

import json
import re
from collections.abc import Callable

# The longest integer literal: 309 digits already exceed the largest double (1.8e308), so
# a longer one is a corrupted file, not a value (Python refuses to convert beyond 4300).
MAX_INTEGER_DIGITS = 309

_BRACKETS_AND_STRINGS = re.compile(r'"(?:[^"\\]|\\.)*"|[\[\]{}]', re.DOTALL)


class _LongInteger(Exception):
    """An integer literal longer than MAX_INTEGER_DIGITS met while parsing (its text)."""


def parse_json(text: str, object_pairs_hook: Callable | None = None):
    """`json.loads(text)`, raising json.JSONDecodeError also for a document nested too deeply
    for the parser and for an integer longer than MAX_INTEGER_DIGITS."""
    try:
        return json.loads(text, object_pairs_hook=object_pairs_hook, parse_int=_integer)
    except RecursionError:
        depth, position = _deepest(text)
        raise json.JSONDecodeError(f"nested too deeply to read ({depth} levels)", text, position) from None
    except _LongInteger as long:
        literal = long.args[0]
        raise json.JSONDecodeError(f"an integer of {len(literal.lstrip('-'))} digits (at most "
                                   f"{MAX_INTEGER_DIGITS})", text, max(text.find(literal), 0)) from None


def _integer(literal: str) -> int:
    if len(literal.lstrip("-")) > MAX_INTEGER_DIGITS:
        raise _LongInteger(literal)
    return int(literal)


def _deepest(text: str) -> tuple[int, int]:
    """The deepest nesting of `text` and where it is first reached (brackets inside strings
    do not count)."""
    depth = deepest = where = 0
    for token in _BRACKETS_AND_STRINGS.finditer(text):
        mark = token.group()
        if mark in "[{":
            depth += 1
            if depth > deepest:
                deepest, where = depth, token.start()
        elif mark in "]}":
            depth -= 1
    return deepest, where
