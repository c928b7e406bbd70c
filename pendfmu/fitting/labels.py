"""The labels of estimates: a parameter's name, or `name[recording]` for a value estimated
for one recording (or window, segment) alone, such as a release angle `phi0[run1]`.

The one home of that spelling: the fit writes labels, the result file keys its estimates
by them, and the report and the sequence read them back.
"""

from __future__ import annotations


def label(name: str, recording: str | None = None) -> str:
    """The label of a shared estimate (`name`) or of one recording's own (`name[recording]`)."""
    return name if recording is None else f"{name}[{recording}]"


def is_own(text: str) -> bool:
    """Whether a label is one recording's own estimate (not a value all recordings share)."""
    return text.endswith("]") and "[" in text


def parameter_of(text: str) -> str:
    """The parameter a label estimates: `phi0` of `phi0[run1]`."""
    return text.split("[", 1)[0] if is_own(text) else text
