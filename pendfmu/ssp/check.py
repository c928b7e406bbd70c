"""Checks the schema cannot express: that connections and parameter values name
components and connectors that exist, that data flows from outputs to inputs, and that
every unit is defined.

The same checks run before writing (on a system built in memory) and after reading (on
a system parsed from files, where a Locator turns a failure back into file and line).
"""

from __future__ import annotations

from pendfmu.escaping import xml_name
from pendfmu.ssp._xml import Locator
from pendfmu.ssp.model import KINDS, TYPES, Connection, System

# Which connector kinds may feed which: SSP 1.0, Connection element.
_FLOWS = {("output", "input"), ("calculatedParameter", "parameter")}
# At the system's own connectors the kinds are the system's: its input feeds a component's
# input, a component's output feeds the system's output.
_FROM_SYSTEM = {("input", "input")}
_TO_SYSTEM = {("output", "output")}
# What a system connector can be: pendfmu's systems pass signals, not parameters, through.
SYSTEM_KINDS = ("input", "output")

_PYTHON_TYPES = {"Real": (float, int), "Integer": (int,), "Boolean": (bool,), "String": (str,)}


def check_system(system: System, locator: Locator | None = None) -> None:
    """Check a system before it is written or run: the names XML can hold, connections
    naming existing connectors, each input fed once, values for parameters that exist,
    every unit defined.

    Parameters
    ----------
    system : System
        The system.
    locator : Locator, optional
        Where each part of the system was read from, so that an error names the file, line
        and element; a system built in memory is named by its parts instead.

    Raises
    ------
    SspError
        At the first inconsistency.
    """
    locator = locator or Locator(f"system {system.name!r}")
    if not system.parameter_set:
        raise locator.error(("system",), "system", "the parameter set needs a name")
    _check_names(system)
    _check_components(system, locator)
    _check_system_connectors(system, locator)
    _check_connections(system, locator)
    _check_parameters(system, locator)


def _check_names(system: System) -> None:
    """Every name the files will hold is one XML can hold (escaping.xml_name), before any
    element is built: a control character in a name given on the command line is refused."""
    xml_name(system.name, "the system")
    xml_name(system.parameter_set, "the parameter set")
    for connector in system.connectors:
        xml_name(connector.name, "a system connector")
    for name, component in system.components.items():
        xml_name(name, "a component")
        for connector in component.connectors:
            xml_name(connector.name, f"component {name}: a connector")
    for name, values in system.parameters.items():
        for parameter in values:
            xml_name(parameter, f"component {name}: a parameter")


def _check_unit(system: System, unit: str | None, key: tuple, what: str, locator: Locator) -> None:
    """SSP: a unit attribute must name a unit defined in the same file."""
    if unit is not None and unit not in system.units:
        raise locator.error(key, what, f"unit {unit!r} is not defined in the Units of the file")


def _check_components(system: System, locator: Locator) -> None:
    """Names are consistent and unique; connector kinds, types and units are known."""
    for name, component in system.components.items():
        key = ("component", name)
        if component.name != name:
            raise locator.error(key, f"component {name}", f"is filed under {name!r} but named {component.name!r}")
        seen: set[str] = set()
        for connector in component.connectors:
            ckey, what = ("connector", name, connector.name), f"connector {name}.{connector.name}"
            if connector.name in seen:
                raise locator.error(ckey, what, f"{name} has two connectors named {connector.name!r}")
            seen.add(connector.name)
            if connector.kind not in KINDS:
                raise locator.error(ckey, what, f"kind {connector.kind!r} is not one of {', '.join(KINDS)}")
            if connector.type not in TYPES:
                raise locator.error(ckey, what, f"type {connector.type!r} is not one of {', '.join(TYPES)}")
            _check_unit(system, connector.unit, ckey, what, locator)


def _check_system_connectors(system: System, locator: Locator) -> None:
    """The system's own connectors: unique names, kind input or output, known types and units."""
    seen: set[str] = set()
    for connector in system.connectors:
        key, what = ("connector", "", connector.name), f"system connector {connector.name}"
        if connector.name in seen:
            raise locator.error(key, what, f"the system has two connectors named {connector.name!r}")
        seen.add(connector.name)
        if connector.kind not in SYSTEM_KINDS:
            raise locator.error(key, what, f"kind {connector.kind!r}: a system connector is an input or an output")
        if connector.type not in TYPES:
            raise locator.error(key, what, f"type {connector.type!r} is not one of {', '.join(TYPES)}")
        _check_unit(system, connector.unit, key, what, locator)


def _endpoint(system: System, element: str, connector: str, key: tuple, what: str, locator: Locator):
    """The connector a connection end names, or an error saying what does not exist."""
    if not element:
        found = system.connector(connector)
        if found is None:
            raise locator.error(key, what, f"the system has no connector {connector!r} "
                                           f"(its connectors: {', '.join(c.name for c in system.connectors) or 'none'})")
        return found
    component = system.components.get(element)
    if component is None:
        raise locator.error(key, what, f"there is no component {element!r} "
                                       f"(components: {', '.join(system.components) or 'none'})")
    found = component.connector(connector)
    if found is None:
        raise locator.error(key, what, f"component {element!r} has no connector {connector!r}")
    return found


def _check_connections(system: System, locator: Locator) -> None:
    """Both ends exist, data flows output -> input, types agree, units convert, one driver per input."""
    driven: dict[tuple[str, str], Connection] = {}
    for index, connection in enumerate(system.connections):
        key, what = ("connection", index), f"connection {connection}"
        start = _endpoint(system, connection.start_element, connection.start_connector, key, what, locator)
        end = _endpoint(system, connection.end_element, connection.end_connector, key, what, locator)
        if not (connection.start_element or connection.end_element):
            raise locator.error(key, what, "connects two connectors of the system itself; one end must be a component")
        flows = _FROM_SYSTEM if not connection.start_element else _TO_SYSTEM if not connection.end_element else _FLOWS
        if (start.kind, end.kind) not in flows:
            if flows is _FLOWS:
                raise locator.error(key, what, f"goes from a connector of kind {start.kind} to one of kind "
                                               f"{end.kind}; the start must be an output and the end an input")
            raise locator.error(key, what, f"goes from a connector of kind {start.kind} to one of kind {end.kind}; "
                                           "a system input feeds a component input, a component output a "
                                           "system output")
        if start.type != end.type:
            raise locator.error(key, what, f"connects a {start.type} to a {end.type}")
        if start.unit and end.unit and start.unit != end.unit:
            a, b = system.units.get(start.unit), system.units.get(end.unit)
            if a is None or b is None or a.dimension() != b.dimension():
                raise locator.error(key, what, f"units {start.unit!r} and {end.unit!r} are not convertible")
        target = (connection.end_element, connection.end_connector)
        if target in driven:
            name = f"input {'.'.join(target)}" if target[0] else f"system output {target[1]}"
            raise locator.error(key, what, f"{name} is already driven by {driven[target]}")
        driven[target] = connection


def _check_parameters(system: System, locator: Locator) -> None:
    """Each value belongs to an existing parameter (or input start) of its type and unit."""
    for component_name, values in system.parameters.items():
        component = system.components.get(component_name)
        for name, given in values.items():
            key, what = ("parameter", component_name, name), f"parameter {component_name}.{name}"
            if component is None:
                raise locator.error(key, what, f"there is no component {component_name!r}")
            connector = component.connector(name)
            if connector is None or connector.kind not in ("parameter", "input"):
                raise locator.error(key, what, f"component {component_name!r} has no parameter {name!r}")
            if given.type != connector.type:
                raise locator.error(key, what, f"is a {given.type} value for a {connector.type} variable")
            if not isinstance(given.value, _PYTHON_TYPES[given.type]) or (
                    given.type in ("Real", "Integer") and isinstance(given.value, bool)):
                raise locator.error(key, what, f"value {given.value!r} is not a {given.type}")
            _check_unit(system, given.unit, key, what, locator)
            if given.unit and connector.unit and given.unit != connector.unit:
                raise locator.error(key, what, f"is given in {given.unit!r} but the variable is in "
                                               f"{connector.unit!r}; pendfmu does not convert units")
