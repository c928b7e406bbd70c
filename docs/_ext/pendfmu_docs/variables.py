"""The FMU variables' reference, from the one variable table every FMU's modelDescription.xml,
its C header and the Modelica check are generated from (pendfmu.components)."""

from __future__ import annotations

import math

from pendfmu_docs.markdown import plain, table

CAUSALITY_ORDER = ("parameter", "input", "output", "local")


def number(value) -> str:
    """A start value or bound as the table shows it: None (computed by the FMU) as a dash."""
    if value is None:
        return "–"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        if math.isinf(value):
            return "∞" if value > 0 else "−∞"
        return f"{value:.10g}"
    return str(value)


def bounds(variable) -> str:
    """The allowed range of a parameter, as the FMU checks it ([ or ( for an open bound)."""
    if variable.low is None and variable.high is None:
        return ""
    low = "−∞" if variable.low is None else number(variable.low)
    high = "∞" if variable.high is None else number(variable.high)
    opening = "(" if variable.low_open or variable.low is None else "["
    text = f"{opening}{low}, {high}{']' if variable.high is not None else ')'}"
    if variable.excluded:
        text += f" except ({number(variable.excluded[0])}, {number(variable.excluded[1])})"
    return text


def component_section(component, role: str) -> str:
    rows = []
    ordered = sorted(component.variables, key=lambda v: CAUSALITY_ORDER.index(v.causality))
    for variable in ordered:
        kind = variable.causality + ("" if variable.type == "Real" else f" ({variable.type})")
        rows.append([f"`{variable.name}`", kind, plain(variable.unit), number(variable.start), bounds(variable),
                     plain(variable.description)])
    indicators = component.event_indicators
    counted = f"{len(component.variables)} variables, {indicators or 'no'} event indicator" + \
        ("" if indicators == 1 else "s")
    header = f"## {component.name}\n\n{plain(component.description)}.\n\n`{component.name}.fmu`, {role}: {counted}.\n"
    return header + "\n" + table(["name", "causality", "unit", "start", "range", "description"], rows)


def markdown(app=None) -> str:
    from pendfmu.components import ALL_COMPONENTS, COMPONENTS

    parts = []
    for name, component in ALL_COMPONENTS.items():
        role = "one of the rig's FMUs" if name in COMPONENTS else "used around the rig (a controller in the loop)"
        parts.append(component_section(component, role))
    return "\n".join(parts)
