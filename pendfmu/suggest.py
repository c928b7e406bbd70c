""""Did you mean ...?" for every name a user types: one rule, so commands, options, signal
and parameter names all answer a typo the same way."""

from __future__ import annotations

import difflib
from collections.abc import Iterable


def did_you_mean(name: object, valid: Iterable[str]) -> str:
    """' (did you mean 'phi'?)' for a near miss, '' otherwise.

    A different case wins first (``Phi`` for ``phi`` is the usual slip), then the same
    letters in another order (``k_fcw`` for ``k_fwc``: difflib scores ``k_fwp`` as close),
    then the closest spelling difflib finds at a similarity of 0.75 or more: lower cut-offs
    suggested unrelated names of the same length.
    """
    valid = [str(v) for v in valid]
    text = str(name)
    for same in (lambda c: c.lower() == text.lower(), lambda c: sorted(c) == sorted(text)):
        for candidate in valid:
            if same(candidate):
                return f" (did you mean {candidate!r}?)"
    close = difflib.get_close_matches(text, valid, n=1, cutoff=0.75)
    return f" (did you mean {close[0]!r}?)" if close else ""
