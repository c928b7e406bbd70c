"""A parameter's declared range: whether a value lies inside it, and the message that says not.

The one home of this rule in Python, so that every check agrees on the ends of a range and
says the same thing: parameter files (parameters.py), recordings' sidecars
(recording/schema.py), SSP systems of the rig (ssp/rig.py), exports (export/plan.py) and
a user's model (simulator/model.py). The FMUs check the same ranges in C when a parameter
is set (pendfmu/csrc/framework, ranges generated from the table) and word their refusal the same
way: ``m_c = -1 is outside its physical range (0, inf)``.

A variable here is a row of the component table (components.Variable) or what a model
description declares (simulator.model.Variable): see Ranged. A table row may also exclude an
open interval inside its range (``excluded``): the Cart's eta_back is -1 (the paper's switch)
or a back-drive efficiency in [0, 1], nothing in between (docs/user-guide/drives.md).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Protocol


class Ranged(Protocol):
    """What a check reads of a variable: its ends (None: unbounded), whether the low end is
    excluded (a mass of 0 is not a mass) and its unit."""

    @property
    def low(self) -> float | None: ...

    @property
    def high(self) -> float | None: ...

    @property
    def low_open(self) -> bool: ...

    @property
    def unit(self) -> str: ...


def _excluded(variable: Ranged) -> tuple[float, float] | None:
    """The open interval a variable's range leaves out (None for most: only table rows have it)."""
    return getattr(variable, "excluded", None)


def admits(variable: Ranged, value: float) -> bool:
    """Whether `value` is finite and inside the variable's range (the high end is always
    closed: eta = 1 is a lossless screw), and not in the interval it excludes."""
    if not math.isfinite(value):
        return False
    if variable.low is not None and (value < variable.low or (variable.low_open and value == variable.low)):
        return False
    gap = _excluded(variable)
    if gap is not None and gap[0] < value < gap[1]:
        return False
    return variable.high is None or value <= variable.high


def interval(variable: Ranged) -> str:
    """The range as it reads in messages: ``(0.0, 1.0]``, ``[0.0, inf)``."""
    low = "-inf" if variable.low is None else repr(variable.low)
    high = "inf" if variable.high is None else repr(variable.high)
    opening = "(" if variable.low_open or variable.low is None else "["
    closing = ")" if variable.high is None else "]"
    gap = _excluded(variable)
    if gap is not None:  # [low, a] or [b, high]; a single value where a is the low end
        start = low if gap[0] == variable.low else f"{opening}{low}, {gap[0]!r}]"
        return f"{start} or [{gap[1]!r}, {high}{closing}"
    return f"{opening}{low}, {high}{closing}"


def number(value: float) -> str:
    """A value as a message shows it: as short as C's %g where that is exact (``-1``,
    ``1.5``), every digit where it is not (``1.0000001``, not ``1``, beside a range
    that ends at 1.0)."""
    short = f"{value:g}"
    return short if float(short) == value else repr(value)


def outside(subject: str, value: float, variables: Sequence[Ranged]) -> str | None:
    """None when one of `variables` admits `value`, else the message naming `subject`, the
    value, the range and the unit.

    Several variables are one quantity that several components declare (m_p in the Cart
    and the Pendulum): a value is valid when one of them takes it (m_p = 0 is a cart whose
    pendulum is removed); a caller for whom every one must take it asks one at a time."""
    if any(admits(variable, value) for variable in variables):
        return None
    ranges = " or ".join(sorted({interval(variable) for variable in variables}))
    unit = f" [{variables[0].unit}]" if variables[0].unit else ""
    return f"{subject} = {number(value)} is outside its physical range {ranges}{unit}"
