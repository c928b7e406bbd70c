"""FMI 2.0 and 3.0 variables as `pendfmu check` reads, sets and names them.

FMI 2.0 has Real, Integer, Enumeration, Boolean and String; FMI 3.0 has Float64 and Float32,
eight integer types, Enumeration, Boolean, String, Binary and Clock, each possibly an array.
The checks drive the floating-point inputs, compare the numeric outputs (an array output as
one column per element, named like FMI 3.0's structured names: `y[1]`, `A[2,1]`) and leave
the rest (strings, binaries, clocks, array inputs) at their start values, saying so.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

FLOAT = frozenset({"Real", "Float64", "Float32"})
INTEGER = frozenset({"Integer", "Enumeration", "Int8", "UInt8", "Int16", "UInt16", "Int32", "UInt32", "Int64",
                     "UInt64"})
NUMERIC = FLOAT | INTEGER | {"Boolean"}


def accessor(variable_type: str, fmi3: bool) -> str:
    """The suffix of fmpy's getter and setter for a type: getReal, setFloat64, getInt64 (an
    FMI 3.0 Enumeration), getInteger (an FMI 2.0 Enumeration)."""
    if fmi3:
        return "Int64" if variable_type == "Enumeration" else variable_type
    return {"Real": "Real", "Integer": "Integer", "Enumeration": "Integer", "Boolean": "Boolean"}[variable_type]


def is_array(variable) -> bool:
    return bool(getattr(variable, "dimensions", None))


def size(variable) -> int:
    """How many values the variable holds (1 for a scalar; an array's shape as its model
    description's start values and structural parameters give it)."""
    return math.prod(getattr(variable, "shape", ()) or (1,)) if is_array(variable) else 1


@dataclass
class Element:
    """One element of an array variable, a column of its own. Other attributes (type,
    valueReference, causality, nominal...) are the array's."""
    array: object
    index: int  # position in the array's values (row-major, as FMI 3.0 serializes them)
    name: str

    def __getattr__(self, attribute):
        return getattr(self.array, attribute)

    @property
    def start(self):
        starts = str(self.array.start).split() if self.array.start is not None else []
        return starts[self.index] if self.index < len(starts) else None


def elements(variable) -> list:
    """The variable itself (a scalar), else one Element per value of the array."""
    if not is_array(variable):
        return [variable]
    shape = tuple(getattr(variable, "shape", ())) or (size(variable),)
    return [Element(variable, k, f"{variable.name}[{','.join(str(i + 1) for i in np.unravel_index(k, shape))}]")
            for k in range(size(variable))]


def slot(variable) -> tuple[str, int, int, int]:
    """(type, value reference, values in the variable, index of this one) of a scalar or an
    Element: where its value is among what a getter returns."""
    if isinstance(variable, Element):
        return variable.type, variable.valueReference, size(variable.array), variable.index
    return variable.type, variable.valueReference, 1, 0


class Reader:
    """Reads a list of slots with one getter call per type (an array's values come in one
    call), in the order of the slots."""

    def __init__(self, slots, fmi3: bool):
        self.slots = [tuple(s) + (1, 0) if len(s) == 2 else tuple(s) for s in slots]
        self.calls: dict[str, tuple[list[int], dict[int, int]]] = {}  # suffix: (vrs, offset of each)
        total: dict[str, int] = {}
        for kind, vr, count, _ in self.slots:
            suffix = accessor(kind, fmi3)
            vrs, offsets = self.calls.setdefault(suffix, ([], {}))
            if vr not in offsets:
                offsets[vr] = total.get(suffix, 0)
                total[suffix] = offsets[vr] + count
                vrs.append(vr)
        self.totals = total
        self.fmi3 = fmi3

    def read(self, fmu) -> np.ndarray:
        values = {}
        for suffix, (vrs, _) in self.calls.items():
            getter = getattr(fmu, "get" + suffix)
            values[suffix] = getter(vrs, self.totals[suffix]) if self.fmi3 else getter(vrs)
        row = np.empty(len(self.slots))
        for j, (kind, vr, _, index) in enumerate(self.slots):
            suffix = accessor(kind, self.fmi3)
            row[j] = float(values[suffix][self.calls[suffix][1][vr] + index])
        return row
