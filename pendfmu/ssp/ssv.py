"""SSP 1.0 parameter value files (SystemStructureParameterValues, ``.ssv``).

An SSV file is one named ``ssv:ParameterSet``: a list of ``ssv:Parameter`` elements,
each with one typed value (``ssv:Real value=".." unit=".."``), followed by the
definitions of the units those values name (the standard requires them to be defined
in the same file).
"""

from __future__ import annotations

from pathlib import Path

from lxml import etree

from pendfmu import __version__
from pendfmu.atomic import write_atomically
from pendfmu.ssp._xml import (
    SSV_NSMAP, SSV_SCHEMA, Locator, SspError, format_double, parse_bool, read_units,
    read_validated, serialize_validated, ssv, units_element,
)
from pendfmu.ssp.model import TYPES, ParameterSet, ParameterValue


def _value_text(value: ParameterValue) -> str:
    """The value attribute of a typed parameter value."""
    if value.type == "Real":
        return format_double(value.value)
    if value.type == "Boolean":
        return "true" if value.value else "false"
    if value.type == "Integer":
        return str(int(value.value))
    return str(value.value)


def parameter_set_element(parameter_set: ParameterSet, file: Path | str | None = None) -> etree._Element:
    """The ssv:ParameterSet element for `parameter_set`.

    Raises SspError (naming `file`) for a value whose unit the set does not define or whose
    type SSV cannot hold, before anything is serialized.
    """
    root = etree.Element(ssv("ParameterSet"), nsmap=SSV_NSMAP, version="1.0", name=parameter_set.name,
                         generationTool=f"pendfmu {__version__}")
    parameters = etree.SubElement(root, ssv("Parameters"))
    for name, value in parameter_set.values.items():
        if value.type not in TYPES:
            raise SspError(file, f"type {value.type!r} is not one of {', '.join(TYPES)}", element=f"parameter {name}")
        if value.unit is not None and value.type != "Real":
            raise SspError(file, "only Real values carry a unit in SSV", element=f"parameter {name}")
        if value.unit is not None and value.unit not in parameter_set.units:
            raise SspError(file, f"unit {value.unit!r} is not among the set's unit definitions",
                           element=f"parameter {name}")
        parameter = etree.SubElement(parameters, ssv("Parameter"), name=name)
        typed = etree.SubElement(parameter, ssv(value.type), value=_value_text(value))
        if value.unit is not None:
            typed.set("unit", value.unit)
    if parameter_set.units:  # ssv:Units must hold at least one unit when present
        root.append(units_element(ssv("Units"), parameter_set.units))
    return root


def write_ssv(parameter_set: ParameterSet, path: str | Path) -> Path:
    """Write a parameter set as an SSV file, validated against the SSV schema first.

    Parameters
    ----------
    parameter_set : ParameterSet
        The values and their units.
    path : str or Path
        The SSV file; its folder is created if needed.

    Returns
    -------
    Path
        The SSV file written (`path`).

    Raises
    ------
    SspError
        The document fails the schema.
    """
    path = Path(path)
    data = serialize_validated(parameter_set_element(parameter_set, path), path, SSV_SCHEMA)
    path.parent.mkdir(parents=True, exist_ok=True)
    return write_atomically(path, data)


def _read_value(typed: etree._Element, locator: Locator) -> ParameterValue:
    """The typed value of one ssv:Parameter; the schema has already checked its syntax."""
    kind = etree.QName(typed).localname
    text = typed.get("value")
    if kind == "Real":
        return ParameterValue(float(text), typed.get("unit"), "Real")
    if kind == "Integer":
        return ParameterValue(int(text), None, "Integer")
    if kind == "Boolean":
        return ParameterValue(parse_bool(text), None, "Boolean")
    if kind == "String":
        return ParameterValue(text, None, "String")
    raise locator.at(typed, f"{kind} parameter values are not supported by pendfmu")


def read_parameter_set(path: Path) -> tuple[ParameterSet, dict[str, etree._Element]]:
    """Read an SSV file; also return each parameter's element, to locate later errors."""
    locator = Locator(path)
    root = read_validated(path, SSV_SCHEMA).getroot()
    units = read_units(root.find(ssv("Units")), locator)
    values: dict[str, ParameterValue] = {}
    elements: dict[str, etree._Element] = {}
    for parameter in root.iterfind(f"{ssv('Parameters')}/{ssv('Parameter')}"):
        name = parameter.get("name")
        if name in values:
            raise locator.at(parameter, f"parameter {name!r} is given twice in the set")
        typed = next(child for child in parameter if etree.QName(child).localname != "Annotations")
        value = _read_value(typed, locator)
        if value.unit is not None and value.unit not in units:
            raise locator.at(typed, f"unit {value.unit!r} is not defined in the file's Units")
        values[name] = value
        elements[name] = parameter
    return ParameterSet(root.get("name"), values, units), elements


def read_ssv(path: str | Path) -> ParameterSet:
    """Read an SSV file, validated against the SSV schema.

    Parameters
    ----------
    path : str or Path
        The SSV file.

    Returns
    -------
    ParameterSet
        Its values and unit definitions.

    Raises
    ------
    SspError
        The file fails the schema; the message names file, line and element.
    """
    path = Path(path)
    return read_parameter_set(path)[0]
