"""Files for Simulink's FMU Import block: ``set_parameters.m`` and ``parameters.mat``.

Simulink's FMU Import block (block type ``FMU``, the FMU file in its ``FMUName`` parameter)
makes each parameter of the FMU a block parameter named like the FMU variable, whose value
is MATLAB text; its default is the start value of modelDescription.xml, and a value set on
the block overrides it (https://www.mathworks.com/help/simulink/ref_extras/fmu.html,
https://www.mathworks.com/help/simulink/ug/work-with-fmi-in-simulink.html). The exported
FMUs already declare the exported values as start values; the script matters for a block
whose values were edited, or that was set up with an earlier export, and it says in the
model which values came from where.

- ``set_parameters.m``: a MATLAB function (the template ``set_parameters.m`` beside this
  module, with the values appended as one table per component) that finds the blocks (named
  like the components in the current system, or given), refuses a block that is not an FMU
  block or whose FMU's GUID is not the exported FMU's, and sets *every* parameter of the
  component, like the SSV file: the given values and the FMU's defaults, each row saying
  which. Values are written ``%.17g``: the text reads back to the same double.
- ``parameters.mat`` (MATLAB 5 format, readable by every MATLAB and Octave): per component
  a struct of its values (``Cart.k_fwc``: usable in block dialogs and scripts), and
  ``pendfmu_export`` with what the script needs to set them from the file
  (``set_parameters('mat', 'parameters.mat')``): ``source``, ``generated_by``, ``date`` and
  ``blocks``, a cell of structs with ``component``, ``fmu``, ``guid`` and column lists
  ``names``, ``values``, ``units``, ``types``, ``origins``. No flat ``Cart_k_fwc`` variables:
  the struct reads the same in a dialog, and flat names could pass MATLAB's 63-character
  limit. A component or parameter name that is not a MATLAB identifier (an FMU of the user's
  may have ``der(x)`` or ``a[1]``) is left out of the friendly structs; ``blocks`` has it.
"""

from __future__ import annotations

import datetime
import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np

from pendfmu import __version__
from pendfmu.atomic import write_atomically
from pendfmu.errors import BadInput
from pendfmu.escaping import matlab_string, one_line

MATLAB_FILE = "set_parameters.m"
MAT_FILE = "parameters.mat"
DEFAULT_ORIGIN = "FMU default"
TEMPLATE = "set_parameters.m"

_IDENTIFIER = re.compile(r"[A-Za-z][A-Za-z0-9_]{0,62}")
_MATLAB_KEYWORDS = {"break", "case", "catch", "classdef", "continue", "else", "elseif", "end", "for", "function",
                    "global", "if", "otherwise", "parfor", "persistent", "return", "spmd", "switch", "try", "while"}


@dataclass(frozen=True)
class BlockValues:
    """What the FMU Import block of one exported FMU receives: a row per parameter."""

    component: str                 # the block name looked for by default
    fmu: str                       # the exported FMU's file name
    guid: str                      # its GUID: the script refuses a block loading another FMU
    names: tuple[str, ...]
    values: tuple[float, ...]
    units: tuple[str, ...]
    types: tuple[str, ...]         # Real, Integer or Boolean (a Boolean is a check box: on/off)
    origins: tuple[str, ...]       # the parameters file, or DEFAULT_ORIGIN

    def texts(self) -> list[str]:
        return [matlab_value(v, t, f"{self.component}.{n}") for n, v, t in zip(self.names, self.values, self.types)]


def block_values(component: str, fmu: str | Path, values: Mapping[str, float], given: Iterable[str],
                 source: str) -> BlockValues:
    """The block values of the written FMU `fmu`: GUID, units and types from its model
    description; `values` (FMU variable name -> value) in the FMU's order; the names in
    `given` came from `source`, the others are the FMU's defaults."""
    from fmpy import read_model_description

    md = read_model_description(str(fmu), validate=False)
    declared = {v.name: v for v in md.modelVariables}
    unknown = [n for n in values if n not in declared]
    if unknown:
        raise BadInput(f"{fmu}: no variable {', '.join(unknown)}")
    given = set(given)
    names = [v.name for v in md.modelVariables if v.name in values]
    units = [declared[n].unit or (declared[n].declaredType.unit if declared[n].declaredType else None) or ""
             for n in names]
    return BlockValues(component, Path(fmu).name, md.guid, tuple(names), tuple(float(values[n]) for n in names),
                       tuple(units), tuple(declared[n].type for n in names),
                       tuple(source if n in given else DEFAULT_ORIGIN for n in names))


def matlab_value(value: float, type_: str, what: str) -> str:
    """The block parameter text of a value: %.17g (reads back exactly), an integer, on/off."""
    if type_ == "Boolean":
        return "on" if value else "off"
    if type_ in ("Integer", "Enumeration"):
        if not float(value).is_integer():
            raise BadInput(f"{what} = {value!r}: an {type_} parameter needs a whole number")
        return f"{int(value):d}"
    return f"{float(value):.17g}"


def _table(block: BlockValues) -> list[str]:
    rows = [[matlab_string(x) for x in row] for row in zip(block.names, block.texts(), block.units, block.types,
                                                     block.origins)]
    if not rows:
        return ["c.parameters = cell(0, 5);"]
    widths = [max(len(row[i]) for row in rows) for i in range(4)]
    lines = ["    " + "  ".join(cell.ljust(w) for cell, w in zip(row, widths)) + "  " + row[4] for row in rows]
    return ["c.parameters = {", *lines, "};"]


def matlab_script(blocks: Sequence[BlockValues], source: str) -> str:
    """The text of set_parameters.m for `blocks`."""
    template = resources.files("pendfmu.export").joinpath(TEMPLATE).read_text(encoding="utf-8")
    data = ["function source = exported_source()", f"source = {matlab_string(source)};", "end", "", "",
            "function exported = exported_values()",
            "% A table per component, a row per FMU parameter: name, value (%.17g), unit, type, and",
            f"% origin ({one_line(source)}, or '{DEFAULT_ORIGIN}': the exported FMU's start value, not given).",
            f"exported = cell(1, {len(blocks)});"]
    for k, block in enumerate(blocks, 1):
        data += [f"c = struct('component', {matlab_string(block.component)}, 'fmu', {matlab_string(block.fmu)}, "
                 f"'guid', {matlab_string(block.guid)});", *_table(block), f"exported{{{k}}} = c;"]
    data += ["exported = table_to_components(exported);", "end"]
    about = (f"Written by pendfmu {__version__} export at {_now()}: the values of {source} for "
             f"{', '.join(b.fmu for b in blocks)}.")
    fills = {"@ABOUT@": one_line(about), "@COMPONENTS@": one_line(", ".join(b.component for b in blocks)),
             "@DATA@": "\n".join(data)}
    return re.sub("|".join(fills), lambda found: fills[found.group()], template)  # one pass: user text stays text


def _identifier(name: str) -> bool:
    return bool(_IDENTIFIER.fullmatch(name)) and name not in _MATLAB_KEYWORDS


def _friendly_struct(block: BlockValues) -> dict:
    """The values as nested fields (a.b -> struct a, field b); names that are no MATLAB
    identifiers, or clash with another (a and a.b), are left out."""
    root: dict = {}
    for name, value in zip(block.names, block.values):
        parts = name.split(".")
        if not all(_identifier(p) for p in parts):
            continue
        node = root
        for part in parts[:-1]:
            node = node.setdefault(part, {})
            if not isinstance(node, dict):
                break
        else:
            if parts[-1] not in node:
                node[parts[-1]] = value
    return root


def _column(items: Sequence, dtype) -> np.ndarray:
    return np.array(list(items), dtype=dtype).reshape(-1, 1)


def mat_contents(blocks: Sequence[BlockValues], source: str) -> dict:
    """The variables of parameters.mat (module docstring)."""
    cells = np.empty((1, len(blocks)), dtype=object)
    for k, block in enumerate(blocks):
        cells[0, k] = {"component": block.component, "fmu": block.fmu, "guid": block.guid,
                       "names": _column(block.names, object), "values": _column(block.values, float),
                       "units": _column(block.units, object), "types": _column(block.types, object),
                       "origins": _column(block.origins, object)}
    contents = {"pendfmu_export": {"source": source, "generated_by": f"pendfmu {__version__} export",
                                   "date": _now(), "blocks": cells}}
    for block in blocks:
        if _identifier(block.component) and block.component not in contents:
            contents[block.component] = _friendly_struct(block)
    return contents


def write_simulink_files(blocks: Sequence[BlockValues], out_dir: str | Path, source: str) -> list[Path]:
    """Write set_parameters.m and parameters.mat for `blocks` into `out_dir`; return their paths."""
    from scipy.io import savemat

    out_dir = Path(out_dir)
    for block in blocks:
        block.texts()  # a value the block cannot take stops the export before a file is written
    script = write_atomically(out_dir / MATLAB_FILE, matlab_script(blocks, source))
    mat = write_atomically(out_dir / MAT_FILE, writer=lambda out: savemat(
        out, mat_contents(blocks, source), long_field_names=True, do_compression=False, oned_as="column"))
    return [script, mat]


def _now() -> str:
    return datetime.datetime.now(datetime.timezone.utc).replace(microsecond=0).isoformat().replace("+00:00", "Z")
