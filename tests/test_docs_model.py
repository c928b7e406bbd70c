"""The user guide's model page (docs/user-guide/model.md) states the paper's model that the
FMUs implement: its tables must say what the FMUs have. Each FMU's inputs, outputs and
parameters named in "The blocks" are variables of that component with that causality, and
each value of "The reference rig" is the FMUs' default (to the digits the page prints), so
neither a renamed variable nor a changed default leaves the page behind.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from pendfmu.components import COMPONENTS, rig_defaults

PAGE = Path(__file__).resolve().parents[1] / "docs" / "user-guide" / "model.md"
UNIT_SCALE = {"ms": 1e-3}  # a unit the page prints its value in, to SI


def table(heading: str) -> list[list[str]]:
    """The body rows (cells, stripped) of the first table after `heading`."""
    text = PAGE.read_text()
    lines = text[text.index(f"## {heading}\n"):].splitlines()
    first = next(k for k, line in enumerate(lines) if line.startswith("|"))
    rows = []
    for line in lines[first:]:
        if not line.startswith("|"):
            break
        rows.append([cell.strip() for cell in line.strip("|").split("|")])
    return rows[2:]  # the header and its rule left out


def names(cell: str) -> list[str]:
    return re.findall(r"`([A-Za-z_][A-Za-z_0-9]*)`", cell)


BLOCKS = table("The blocks")


@pytest.mark.parametrize("row", BLOCKS, ids=[names(row[0])[0] for row in BLOCKS])
def test_each_block_names_its_fmus_variables(row):
    component = COMPONENTS[names(row[0])[0]]
    for cell, causality in zip(row[1:], ("input", "output", "parameter")):
        found = {v.name for v in component.of(causality=causality)}
        named = names(cell)
        assert named, f"{component.name}: no {causality} named in {cell!r}"
        assert set(named) <= found, f"{component.name}: not {causality}s of the FMU: {set(named) - found}"


def test_the_reference_rig_is_the_fmus_defaults():
    defaults = rig_defaults()
    checked = 0
    for row in table("The reference rig"):
        for name_cell, value_cell in zip(row[0::2], row[1::2]):
            for name, value in zip(names(name_cell), value_cell.split(" / ")):
                number, unit = re.match(r"\s*([-+0-9.e]+)\s*(\S*)", value).groups()
                scale = UNIT_SCALE.get(unit, 1.0)
                mantissa, _, exponent = number.partition("e")
                decimals = len(mantissa.partition(".")[2])
                half_a_digit = 0.5 * 10.0 ** (int(exponent or 0) - decimals) * scale  # of the last one printed
                assert abs(defaults[name] - float(number) * scale) <= half_a_digit, f"{name}: {value}, {defaults[name]}"
                checked += 1
    assert checked == 14  # every name of the table
