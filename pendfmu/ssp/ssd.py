"""SSP 1.0 system structure descriptions (``.ssd``): writing and reading.

Layout written (plain SSP 1.0 plus the annotations other tools need, see vendor.py)::

    ssd:SystemStructureDescription version="1.0" name=..
      ssd:System name=..
        ssd:Connectors/ssd:Connector name="I_c" kind="input|output" + ssc:Real unit=..
        ssd:Elements
          ssd:Component name="Cart" source="resources/Cart.fmu" implementation=..
            ssd:Connectors/ssd:Connector name=.. kind="input|output|parameter" + ssc:Real unit=..
            ssd:ParameterBindings/ssd:ParameterBinding source="resources/Cart.ssv"
        ssd:Connections/ssd:Connection startElement startConnector endElement endConnector
          (no startElement: from a system input; no endElement: to a system output)
        ssd:Annotations/ssc:Annotation type="org.openmodelica" (OMSimulator's system type)
      ssd:Units/ssc:Unit/ssc:BaseUnit
      ssd:DefaultExperiment startTime stopTime
        ssd:Annotations/ssc:Annotation type="org.pendfmu.experiment"/pendfmu:Experiment stepSize

Parameter values are bound per component, each binding naming an SSV file whose
parameter names are the FMU's variable names: the standard's simplest form (no prefix,
no mapping), and the one importers such as ecos and libcosim read (they ignore
system-level bindings; libcosim applies each component's first binding by default).

The system's own connectors are the standard's way to give a system inputs and outputs
(fmpy's simulate_ssp needs one for every input no component feeds). ecos 0.7.2 and
libcosim 0.0.6 refuse any connection to them ("No element named: ", "No such node
(<xmlattr>.startElement)"): for those, ``system_connectors=False`` writes the same system
without them (docs/user-guide/exchange.md, "Other SSP tools"; tests/test_ssp_tools.py pins the refusal).
"""

from __future__ import annotations

from pathlib import Path
from urllib.parse import unquote, urlparse

from lxml import etree

from pendfmu import __version__
from pendfmu.atomic import write_atomically
from pendfmu.escaping import xml_text
from pendfmu.ssp._xml import (
    SSC_NS, SSD_NSMAP, SSD_SCHEMA, Locator, format_double, read_units, read_validated,
    serialize_validated, ssc, ssd, units_element,
)
from pendfmu.ssp.check import check_system
from pendfmu.ssp.fmu import check_against_fmu
from pendfmu.ssp.model import Connection, Connector, DefaultExperiment, FmuComponent, ParameterValue, System
from pendfmu.ssp.ssv import read_parameter_set, write_ssv
from pendfmu.ssp.vendor import OMS_NS, omsimulator_annotation

# The communication step size has no attribute in SSP 1.0's DefaultExperiment; it goes
# into an annotation, the standard's extension point, which other tools ignore.
EXPERIMENT_ANNOTATION = "org.pendfmu.experiment"
PENDFMU_NS = "urn:pendfmu:ssp:experiment:1"
PARAMETER_SET_TYPE = "application/x-ssp-parameter-set"
FMU_TYPE = "application/x-fmu-sharedlibrary"


# ----------------------------------------------------------------------------- writing

def _connectors_element(connectors: tuple[Connector, ...]) -> etree._Element:
    """ssd:Connectors, each connector with its type and unit."""
    el = etree.Element(ssd("Connectors"))
    for connector in connectors:
        c = etree.SubElement(el, ssd("Connector"), name=connector.name, kind=connector.kind)
        typed = etree.SubElement(c, ssc(connector.type))
        if connector.unit is not None and connector.type == "Real":
            typed.set("unit", connector.unit)
    return el


def _component_element(system: System, component: FmuComponent) -> etree._Element:
    """ssd:Component with its connectors and, if it has values, the binding to its SSV file."""
    el = etree.Element(ssd("Component"), name=component.name, source=component.source)
    if component.implementation != "any":
        el.set("implementation", component.implementation)
    if component.connectors:
        el.append(_connectors_element(component.connectors))
    if system.parameters.get(component.name):
        bindings = etree.SubElement(el, ssd("ParameterBindings"))
        etree.SubElement(bindings, ssd("ParameterBinding"), source=system.parameter_source(component.name))
    return el


def _experiment_element(experiment: DefaultExperiment) -> etree._Element:
    """ssd:DefaultExperiment, with the step size in a pendfmu annotation."""
    el = etree.Element(ssd("DefaultExperiment"))
    if experiment.start_time is not None:
        el.set("startTime", format_double(experiment.start_time))
    if experiment.stop_time is not None:
        el.set("stopTime", format_double(experiment.stop_time))
    if experiment.step_size is not None:
        annotations = etree.SubElement(el, ssd("Annotations"))
        annotation = etree.SubElement(annotations, ssc("Annotation"), type=EXPERIMENT_ANNOTATION)
        etree.SubElement(annotation, f"{{{PENDFMU_NS}}}Experiment", nsmap={"pendfmu": PENDFMU_NS},
                         stepSize=format_double(experiment.step_size))
    return el


def _connection_element(c: Connection) -> etree._Element:
    """ssd:Connection; an end at the system's own connector has no element attribute."""
    el = etree.Element(ssd("Connection"))
    if c.start_element:
        el.set("startElement", c.start_element)
    el.set("startConnector", c.start_connector)
    if c.end_element:
        el.set("endElement", c.end_element)
    el.set("endConnector", c.end_connector)
    return el


def ssd_element(system: System, *, system_connectors: bool = True) -> etree._Element:
    """The whole ssd:SystemStructureDescription for `system` (not yet validated); without
    `system_connectors` the system's own connectors and their connections are left out."""
    root = etree.Element(ssd("SystemStructureDescription"), nsmap={**SSD_NSMAP, "oms": OMS_NS}, version="1.0",
                         name=system.name, generationTool=f"pendfmu {__version__}")
    sys_el = etree.SubElement(root, ssd("System"), name=system.name)
    if system.description:
        sys_el.set("description", xml_text(system.description))
    if system.connectors and system_connectors:
        sys_el.append(_connectors_element(system.connectors))
    if system.components:
        elements = etree.SubElement(sys_el, ssd("Elements"))
        for component in system.components.values():
            elements.append(_component_element(system, component))
    wires = system.connections if system_connectors else system.component_connections()
    if wires:
        connections = etree.SubElement(sys_el, ssd("Connections"))
        for c in wires:
            connections.append(_connection_element(c))
    annotations = etree.SubElement(sys_el, ssd("Annotations"))
    annotations.append(omsimulator_annotation(None if system.experiment is None else system.experiment.step_size))
    if system.units:
        root.append(units_element(ssd("Units"), system.units))
    if system.experiment is not None:
        root.append(_experiment_element(system.experiment))
    return root


def write_ssd(system: System, path: str | Path, *, system_connectors: bool = True) -> list[Path]:
    """Write the SSD to `path` and each component's SSV file where its binding points
    (`system_connectors`: see the module docstring).

    The system is checked (connections name existing connectors, ...) and every document
    validated against its schema before anything is written. SSV files go to
    ``resources/`` next to the SSD, as in an SSP archive, so the directory is an unpacked
    SSP once the FMUs are copied there too.

    Parameters
    ----------
    system : System
        The system.
    path : str or Path
        The SSD file.
    system_connectors : bool, optional
        Whether the SSD holds the system's own connectors (False for ecos and libcosim,
        which refuse connections to them).

    Returns
    -------
    list of Path
        The files written, the SSD first.

    Raises
    ------
    SspError
        The system is inconsistent, or a document fails its schema.
    """
    path = Path(path)
    check_system(system)
    data = serialize_validated(ssd_element(system, system_connectors=system_connectors), path, SSD_SCHEMA)
    written = [path]
    for name in system.components:
        if system.parameters.get(name):
            written.append(write_ssv(system.parameter_set_of(name), path.parent / system.parameter_source(name)))
    path.parent.mkdir(parents=True, exist_ok=True)
    write_atomically(path, data)
    return written


# ----------------------------------------------------------------------------- reading

def resolve_source(base: Path, uri: str) -> Path | None:
    """The local file a relative URI names, or None for URIs pendfmu does not follow.

    Only relative references that stay below the SSD's directory are followed: the
    standard requires no more, and following ``..`` or absolute URIs from a file
    someone sent us is how archives escape their directory.
    """
    parsed = urlparse(uri)
    if parsed.scheme or parsed.netloc or uri.startswith("/"):
        return None
    parts = Path(unquote(parsed.path)).parts
    if ".." in parts:
        return None
    return base.joinpath(*parts)


def _reject_unsupported(system_el: etree._Element, locator: Locator) -> None:
    """pendfmu reads flat systems of FMU components; say so rather than silently drop parts."""
    unsupported = {
        ssd("ParameterBindings"): "parameter bindings on the system (bind them to components)",
        ssd("SignalDictionaries"): "signal dictionaries",
    }
    for child in system_el:
        if child.tag in unsupported:
            raise locator.at(child, f"{unsupported[child.tag]} are not supported by pendfmu")
    for element in system_el.iterfind(f"{ssd('Elements')}/*"):
        if element.tag != ssd("Component"):
            raise locator.at(element, "only FMU components are supported, not nested systems or "
                                      "signal dictionary references")
        if element.get("type", FMU_TYPE) != FMU_TYPE:
            raise locator.at(element, f"component type {element.get('type')!r} is not supported (only FMUs)")


def _read_connectors(el: etree._Element, component: str, locator: Locator) -> tuple[Connector, ...]:
    """The connectors of a component element (or of the system: component ""), each noted
    for error reporting."""
    connectors = []
    for c in el.iterfind(f"{ssd('Connectors')}/{ssd('Connector')}"):
        typed = next((t for t in c if etree.QName(t).namespace == SSC_NS), None)
        kind_of_type = "Real" if typed is None else etree.QName(typed).localname
        unit = None if typed is None else typed.get("unit")
        connectors.append(Connector(c.get("name"), c.get("kind"), kind_of_type, unit))
        locator.note(("connector", component, c.get("name")), c)
    return tuple(connectors)


def _read_bindings(el: etree._Element, ssd_path: Path, locator: Locator, found: dict):
    """The values bound to a component: its SSV files, read and merged in document order.

    `found` collects the parameter set name and units across components, since pendfmu's
    system has one named set: a second name is an error.
    """
    component = el.get("name")
    values: dict[str, ParameterValue] = {}
    for binding in el.iterfind(f"{ssd('ParameterBindings')}/{ssd('ParameterBinding')}"):
        source = binding.get("source")
        if binding.get("type", PARAMETER_SET_TYPE) != PARAMETER_SET_TYPE:
            raise locator.at(binding, f"parameter source type {binding.get('type')!r} is not supported")
        if not source or binding.find(ssd("ParameterValues")) is not None:
            raise locator.at(binding, "inline parameter values are not supported; reference an SSV file")
        if binding.find(ssd("ParameterMapping")) is not None or binding.get("prefix"):
            raise locator.at(binding, "parameter mappings and prefixes are not supported")
        if binding.get("sourceBase", "SSD") != "SSD":
            raise locator.at(binding, "parameter sources inside the component are not supported")
        ssv_path = resolve_source(ssd_path.parent, source)
        if ssv_path is None or not ssv_path.is_file():
            raise locator.at(binding, f"parameter file {source!r} not found"
                                      + ("" if ssv_path is None else f" at {ssv_path}"))
        parameter_set, elements = read_parameter_set(ssv_path)
        if found.setdefault("name", parameter_set.name) != parameter_set.name:
            raise locator.at(binding, f"binds parameter set {parameter_set.name!r}, but pendfmu uses one named "
                                      f"set and an earlier binding uses {found['name']!r}")
        for unit in parameter_set.units.values():
            if found["units"].setdefault(unit.name, unit) != unit:
                raise locator.at(binding, f"{source} defines unit {unit.name!r} differently from the SSD")
        for name, value in parameter_set.values.items():
            values[name] = value
            locator.note(("parameter", component, name), elements[name], ssv_path)
    return values


def _read_experiment(root: etree._Element) -> DefaultExperiment | None:
    """The DefaultExperiment, with the step size from pendfmu's annotation if present."""
    el = root.find(ssd("DefaultExperiment"))
    if el is None:
        return None
    step = None
    for annotation in el.iterfind(f"{ssd('Annotations')}/{ssc('Annotation')}"):
        if annotation.get("type") == EXPERIMENT_ANNOTATION:
            data = annotation.find(f"{{{PENDFMU_NS}}}Experiment")
            if data is not None and data.get("stepSize") is not None:
                step = float(data.get("stepSize"))
    start, stop = el.get("startTime"), el.get("stopTime")
    return DefaultExperiment(None if start is None else float(start), None if stop is None else float(stop), step)


def read_ssd(path: str | Path, *, require_fmus: bool = False) -> System:
    """Read an SSD and the SSV files its parameter bindings reference.

    Every file is validated against its SSP 1.0 schema, then the system is checked: a
    connection naming an unknown component or connector, an input driven twice, a value
    for a parameter that does not exist... raise SspError naming file, line and element.
    Where a component's FMU is present (relative to the SSD) its connectors are checked
    against the FMU's variables.

    Parameters
    ----------
    path : str or Path
        The SSD file.
    require_fmus : bool, optional
        Whether a component's missing FMU is an error too.

    Returns
    -------
    System
        The system, with its parameter values; a component's `fmu` is set where the file
        is present.

    Raises
    ------
    SspError
        A file fails its schema or the system is inconsistent; the message names file,
        line and element.
    """
    path = Path(path)
    root = read_validated(path, SSD_SCHEMA).getroot()
    locator = Locator(path)
    system_el = root.find(ssd("System"))
    _reject_unsupported(system_el, locator)
    found = {"units": read_units(root.find(ssd("Units")), locator)}
    components: dict[str, FmuComponent] = {}
    parameters: dict[str, dict[str, ParameterValue]] = {}
    for el in system_el.iterfind(f"{ssd('Elements')}/{ssd('Component')}"):
        name = el.get("name")
        if name in components:
            raise locator.at(el, f"a second component named {name!r}; names must be unique in a system")
        locator.note(("component", name), el)
        fmu = resolve_source(path.parent, el.get("source"))
        components[name] = FmuComponent(name, el.get("source"), _read_connectors(el, name, locator),
                                        el.get("implementation", "any"),
                                        fmu if fmu is not None and fmu.is_file() else None)
        if require_fmus and components[name].fmu is None:
            raise locator.at(el, f"its FMU {el.get('source')!r} is not there"
                                 + ("" if fmu is None else f" (looked for {fmu})"))
        if values := _read_bindings(el, path, locator, found):
            parameters[name] = values
    connections = []
    for index, el in enumerate(system_el.iterfind(f"{ssd('Connections')}/{ssd('Connection')}")):
        locator.note(("connection", index), el)
        connections.append(Connection(el.get("startElement", ""), el.get("startConnector"),
                                      el.get("endElement", ""), el.get("endConnector")))
    system = System(system_el.get("name"), components, connections, parameters, found["units"],
                    found.get("name", "parameters"), _read_experiment(root), system_el.get("description", ""),
                    _read_connectors(system_el, "", locator))
    check_system(system, locator)
    for component in components.values():
        if component.fmu is not None:
            check_against_fmu(component, locator)
    return system
