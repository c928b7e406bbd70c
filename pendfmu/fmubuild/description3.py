"""modelDescription.xml of a component's FMI 3.0 FMU, from the same table as the FMI 2.0 one.

What FMI 3.0 changes for our components: variables are typed elements (Float64, Int32,
Boolean) referenced by value reference rather than by index; the GUID is the
instantiationToken; source files are listed only in sources/buildDescription.xml; and
event indicators and the independent variable (time) are variables. The table has none
for them (FMI 2.0 only counts the indicators, and has time implicitly), so each FMI 3.0 FMU
declares local Float64 variables ``event_indicator_<k>`` and then ``time`` after the
table's, with the next free value references; the FMI 3.0 facade computes them when read.
Capabilities are the FMI 2.0 description's, plus Co-Simulation's event mode.
"""

from __future__ import annotations

from lxml import etree

from pendfmu import __version__
from pendfmu.components import Component, Variable
from pendfmu.fmubuild.description import CAUSALITY_INITIAL, add_units_logging_and_experiment

FMI3_TYPES = {"Real": "Float64", "Integer": "Int32", "Boolean": "Boolean"}


def event_indicator_names(component: Component) -> list[str]:
    """The names of the FMI 3.0 event-indicator variables, value references len(table) + k."""
    return [f"event_indicator_{k + 1}" for k in range(component.event_indicators)]


def time_value_reference(component: Component) -> int:
    """The value reference of the FMI 3.0 independent variable ``time``."""
    return len(component.variables) + component.event_indicators


def _start_text(var: Variable) -> str:
    if var.type == "Boolean":
        return "true" if var.start else "false"
    if var.type == "Integer":
        return str(int(var.start))
    return repr(float(var.start))


def _variable(component: Component, vr: int, var: Variable) -> etree._Element:
    attributes = {"name": var.name, "valueReference": str(vr), "causality": var.causality,
                  "variability": var.variability}
    initial = CAUSALITY_INITIAL[var.causality]
    if initial:
        attributes["initial"] = initial
    if var.description:
        attributes["description"] = var.description
    if var.start is not None:
        attributes["start"] = _start_text(var)
    if var.type == "Real":
        if var.unit:
            attributes["unit"] = var.unit
        if var.derivative_of:
            attributes["derivative"] = str(component.value_reference(var.derivative_of))
        if var.low is not None:
            attributes["min"] = repr(float(var.low))
        if var.high is not None:
            attributes["max"] = repr(float(var.high))
    return etree.Element(FMI3_TYPES[var.type], attributes)


def _unknown(parent: etree._Element, kind: str, component: Component, var: Variable, with_dependencies: bool) -> None:
    element = etree.SubElement(parent, kind, valueReference=str(component.value_reference(var.name)))
    if with_dependencies and var.depends_on is not None:
        references = sorted(component.value_reference(name) for name in var.depends_on)
        element.set("dependencies", " ".join(map(str, references)))


def model_description(component: Component, token: str, sources: list[str]) -> bytes:
    """The FMI 3.0 modelDescription.xml of `component` as bytes (UTF-8, with declaration);
    `sources` is unused (FMI 3.0 lists them in the build description only)."""
    del sources
    root = etree.Element(
        "fmiModelDescription",
        fmiVersion="3.0",
        modelName=component.name,
        instantiationToken=token,
        description=component.description,
        generationTool=f"pendfmu {__version__}",
        variableNamingConvention="flat",
    )
    common = {"modelIdentifier": component.name, "canGetAndSetFMUState": "true", "canSerializeFMUState": "true",
              "providesDirectionalDerivatives": "false"}
    etree.SubElement(root, "ModelExchange", common, needsCompletedIntegratorStep="true")
    # Inputs are held over a step: FMI 3.0 has no call for input derivatives.
    etree.SubElement(root, "CoSimulation", common, canHandleVariableCommunicationStepSize="true",
                     hasEventMode="true", canInterpolateInputs="false", maxOutputDerivativeOrder="0")
    add_units_logging_and_experiment(root, component)

    variables = etree.SubElement(root, "ModelVariables")
    etree.SubElement(variables, "Float64", name="time", valueReference=str(time_value_reference(component)),
                     causality="independent", variability="continuous", unit="s", description="simulation time")
    for vr, var in enumerate(component.variables):
        variables.append(_variable(component, vr, var))
    first_indicator = len(component.variables)
    for k, name in enumerate(event_indicator_names(component)):
        etree.SubElement(variables, "Float64", name=name, valueReference=str(first_indicator + k), causality="local",
                         variability="continuous", initial="calculated",
                         description="event indicator: >= 0 while the mode is consistent with the states")

    structure = etree.SubElement(root, "ModelStructure")
    for var in component.of(causality="output"):
        _unknown(structure, "Output", component, var, with_dependencies=True)
    for var in component.variables:
        if var.derivative_of:
            _unknown(structure, "ContinuousStateDerivative", component, var, with_dependencies=True)
    for var in component.variables:
        if var.causality == "output" or var.state or var.derivative_of:
            _unknown(structure, "InitialUnknown", component, var, with_dependencies=False)
    for k in range(component.event_indicators):
        etree.SubElement(structure, "EventIndicator", valueReference=str(first_indicator + k))
    return etree.tostring(root, xml_declaration=True, encoding="UTF-8", pretty_print=True)
