"""modelDescription.xml and sources/buildDescription.xml of a component FMU, from its table."""

from __future__ import annotations

from lxml import etree

from pendfmu import __version__
from pendfmu.components import Component, Variable
from pendfmu.fmubuild.units import BASE_UNITS

CAUSALITY_INITIAL = {"parameter": "exact", "input": None, "output": "calculated", "local": "calculated"}


def _number(value: float) -> str:
    return repr(float(value))


def _start_text(var: Variable) -> str:
    if var.type == "Boolean":
        return "true" if var.start else "false"
    if var.type == "Integer":
        return str(int(var.start))
    return _number(var.start)


def _scalar_variable(component: Component, vr: int, var: Variable) -> etree._Element:
    attributes = {
        "name": var.name,
        "valueReference": str(vr),
        "causality": var.causality,
        "variability": var.variability,
    }
    initial = CAUSALITY_INITIAL[var.causality]
    if initial:
        attributes["initial"] = initial
    if var.description:
        attributes["description"] = var.description
    element = etree.Element("ScalarVariable", attributes)
    typed = etree.SubElement(element, var.type)
    if var.start is not None:
        typed.set("start", _start_text(var))
    if var.type == "Real":
        if var.unit:
            typed.set("unit", var.unit)
        if var.derivative_of:
            typed.set("derivative", str(component.value_reference(var.derivative_of) + 1))
        if var.low is not None:
            typed.set("min", _number(var.low))
        if var.high is not None:
            typed.set("max", _number(var.high))
    return element


def _unknown(parent: etree._Element, component: Component, var: Variable, with_dependencies: bool) -> None:
    element = etree.SubElement(parent, "Unknown", index=str(component.value_reference(var.name) + 1))
    if with_dependencies and var.depends_on is not None:
        indices = sorted(component.value_reference(name) + 1 for name in var.depends_on)
        element.set("dependencies", " ".join(map(str, indices)))


def _source_files(parent: etree._Element, sources: list[str]) -> None:
    files = etree.SubElement(parent, "SourceFiles")
    for name in sources:
        if name.endswith(".c"):
            etree.SubElement(files, "File", name=name)


def add_units_logging_and_experiment(root: etree._Element, component: Component) -> None:
    """UnitDefinitions, LogCategories and DefaultExperiment: the same in FMI 2.0 and 3.0."""
    units = etree.SubElement(root, "UnitDefinitions")
    for unit in sorted({v.unit for v in component.variables if v.unit}):
        if unit not in BASE_UNITS:
            raise ValueError(f"{component.name}: unit {unit!r} has no entry in pendfmu/fmubuild/units.py")
        etree.SubElement(etree.SubElement(units, "Unit", name=unit), "BaseUnit",
                         {k: str(e) for k, e in BASE_UNITS[unit].items()})
    categories = etree.SubElement(root, "LogCategories")
    etree.SubElement(categories, "Category", name="logEvents", description="Mode changes (stick, slip, saturation)")
    etree.SubElement(categories, "Category", name="logStatusError", description="Errors and why they happened")
    etree.SubElement(root, "DefaultExperiment", startTime="0.0", stopTime="1.0", stepSize="0.0002")


def model_description(component: Component, guid: str, sources: list[str]) -> bytes:
    """The modelDescription.xml of `component` as bytes (UTF-8, with declaration)."""
    root = etree.Element(
        "fmiModelDescription",
        fmiVersion="2.0",
        modelName=component.name,
        guid=guid,
        description=component.description,
        generationTool=f"pendfmu {__version__}",
        variableNamingConvention="flat",
        numberOfEventIndicators=str(component.event_indicators),
    )
    common = {"modelIdentifier": component.name, "canGetAndSetFMUstate": "true", "canSerializeFMUstate": "true",
              "providesDirectionalDerivative": "false"}
    me = etree.SubElement(root, "ModelExchange", common, completedIntegratorStepNotNeeded="false")
    _source_files(me, sources)
    cs = etree.SubElement(root, "CoSimulation", common, canHandleVariableCommunicationStepSize="true",
                          canInterpolateInputs="true", maxOutputDerivativeOrder="0")
    _source_files(cs, sources)

    add_units_logging_and_experiment(root, component)

    variables = etree.SubElement(root, "ModelVariables")
    for vr, var in enumerate(component.variables):
        variables.append(_scalar_variable(component, vr, var))

    structure = etree.SubElement(root, "ModelStructure")
    outputs = etree.SubElement(structure, "Outputs")
    for var in component.of(causality="output"):
        _unknown(outputs, component, var, with_dependencies=True)
    # The schema wants each list present only with at least one element (a model without
    # continuous states has no Derivatives).
    if any(var.derivative_of for var in component.variables):
        derivatives = etree.SubElement(structure, "Derivatives")
        for var in component.variables:
            if var.derivative_of:
                _unknown(derivatives, component, var, with_dependencies=True)
    if any(var.causality == "output" or var.state or var.derivative_of for var in component.variables):
        initial = etree.SubElement(structure, "InitialUnknowns")
        for var in component.variables:
            if var.causality == "output" or var.state or var.derivative_of:
                _unknown(initial, component, var, with_dependencies=False)
    return etree.tostring(root, xml_declaration=True, encoding="UTF-8", pretty_print=True)


def build_description(component: Component, sources: list[str]) -> bytes:
    """sources/buildDescription.xml (the FMI 3.0 format that FMI 2.0.4 also recommends)."""
    root = etree.Element("fmiBuildDescription", fmiVersion="3.0")
    config = etree.SubElement(root, "BuildConfiguration", modelIdentifier=component.name)
    files = etree.SubElement(config, "SourceFileSet", language="C99")
    for name in sources:
        if name.endswith(".c"):
            etree.SubElement(files, "SourceFile", name=name)
    etree.SubElement(config, "Library", name="m", description="the C math library")
    return etree.tostring(root, xml_declaration=True, encoding="UTF-8", pretty_print=True)
