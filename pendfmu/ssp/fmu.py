"""What an SSD needs to know about an FMU, read from its modelDescription.xml.

Connectors are taken from the FMU itself, not from pendfmu's variable tables, because
the SSD describes that file: a connector whose name, kind, type or unit disagrees with
the FMU is an error in the standard, and reading the FMU is the only way to be sure.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

from pendfmu.ssp._xml import Locator
from pendfmu.ssp.model import KINDS, Connector, FmuComponent, ParameterValue, Unit


@dataclass(frozen=True)
class FmuDescription:
    """The parts of an FMU's model description an SSD uses.

    Attributes
    ----------
    path : Path
        The FMU file.
    guid : str
        Its GUID.
    connectors : tuple of Connector
        Its inputs, outputs and parameters.
    units : dict of str to Unit
        The definitions of the units it declares, by name.
    starts : dict of str to ParameterValue
        The start values of its parameters, by name.
    """

    path: Path
    guid: str
    connectors: tuple[Connector, ...]
    units: dict[str, Unit]
    starts: dict[str, ParameterValue]  # start values of the parameters


def _start(variable) -> ParameterValue | None:
    """The start value of a variable as a typed value, or None when it has none."""
    if variable.start is None:
        return None
    text = str(variable.start)
    convert = {"Real": float, "Integer": int, "Boolean": lambda t: t in ("true", "1"), "String": str}
    return ParameterValue(convert[variable.type](text), _unit(variable), variable.type)


def _unit(variable) -> str | None:
    """The variable's unit, its own or its declared type's."""
    if variable.unit:
        return variable.unit
    declared = getattr(variable, "declaredType", None)
    return getattr(declared, "unit", None) or None


@lru_cache(maxsize=32)
def _describe(path: Path, mtime_ns: int, size: int) -> FmuDescription:
    """Parse the model description once per version of the file (rebuilds change mtime)."""
    from fmpy import read_model_description

    md = read_model_description(str(path))
    connectors, starts = [], {}
    for v in md.modelVariables:
        if v.causality not in KINDS:
            continue
        connectors.append(Connector(v.name, v.causality, v.type, _unit(v)))
        if v.causality == "parameter" and (start := _start(v)) is not None:
            starts[v.name] = start
    units = {}
    for u in md.unitDefinitions:
        b = u.baseUnit
        units[u.name] = Unit(u.name) if b is None else Unit(
            u.name, b.kg, b.m, b.s, b.A, b.K, b.mol, b.cd, b.rad, float(b.factor), float(b.offset))
    return FmuDescription(path, md.guid, tuple(connectors), units, starts)


def describe_fmu(path: str | Path) -> FmuDescription:
    """The FMU's connectors (inputs, outputs, parameters), unit definitions and parameter
    starts, parsed once per version of the file.

    Parameters
    ----------
    path : str or Path
        The FMU file.

    Returns
    -------
    FmuDescription
        What an SSD needs of the FMU.

    Raises
    ------
    FileNotFoundError
        No file at `path`.
    """
    path = Path(path).resolve()
    if not path.is_file():
        raise FileNotFoundError(f"no FMU at {path} (build the component FMUs with `python -m pendfmu build`)")
    stat = path.stat()
    return _describe(path, stat.st_mtime_ns, stat.st_size)


def fmu_component(name: str, fmu: str | Path, source: str | None = None,
                  implementation: str = "any") -> FmuComponent:
    """A system component for an FMU file, with a connector for each input, output and
    parameter.

    Parameters
    ----------
    name : str
        The component's name in the system.
    fmu : str or Path
        The FMU file.
    source : str, optional
        The URI the SSD writes, relative to it; ``resources/<file name>`` by default, as
        inside an SSP archive.
    implementation : str, optional
        "any", "CoSimulation" or "ModelExchange".

    Returns
    -------
    FmuComponent
        The component, its `fmu` set.
    """
    description = describe_fmu(fmu)
    return FmuComponent(name, source or f"resources/{Path(fmu).name}", description.connectors,
                        implementation, Path(fmu))


def check_against_fmu(component: FmuComponent, locator: Locator) -> None:
    """Raise SspError when a connector does not match its FMU variable (SSP requires they match)."""
    declared = {c.name: c for c in describe_fmu(component.fmu).connectors}
    fmu_name = component.fmu.name
    for connector in component.connectors:
        key, what = ("connector", component.name, connector.name), f"connector {component.name}.{connector.name}"
        actual = declared.get(connector.name)
        if actual is None:
            raise locator.error(key, what, f"{fmu_name} has no input, output or parameter {connector.name!r}")
        if actual.kind != connector.kind:
            raise locator.error(key, what, f"is a {connector.kind} here but the variable's causality in "
                                           f"{fmu_name} is {actual.kind}")
        if actual.type != connector.type:
            raise locator.error(key, what, f"is {connector.type} here but {actual.type} in {fmu_name}")
        if connector.unit and actual.unit and connector.unit != actual.unit:
            raise locator.error(key, what, f"has unit {connector.unit!r} here but {actual.unit!r} in {fmu_name}")
