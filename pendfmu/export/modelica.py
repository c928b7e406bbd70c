"""The exported parameters as Modelica text for the PendulumID library (``modifiers.mo``).

The file is one small package, ``PendfmuExport``, that any Modelica tool (and rumoca)
loads next to ``modelica/PendulumID``:

- ``partial model IdentifiedComponents``: one declaration per exported component, e.g.
  ``PendulumID.Cart cart(m_c = 3.0, ..., k_fwc = 25.5, ...)``, to copy into a model;
- a complete model: ``IdentifiedRig extends PendulumID.Examples.Rig(eta = ..., m_p = ...,
  l = ..., currentLoop(...), cart(...), pendulum(...))``, or, when the pendulum is removed
  (m_p = 0, which no Pendulum accepts), ``IdentifiedCartStartStop extends
  PendulumID.Examples.CartStartStop(currentLoop(...), cart(...))``.

Every parameter of each component is written (the default ones marked so), with its unit
in a comment and the value in repr precision, so the text states the whole component.
``Examples.Rig`` declares ``eta``, ``m_p`` and ``l`` itself and binds them into its cart
and pendulum (``eta`` also chooses the coupling equations); the rig model sets those
three at the Rig's level, since a ``cart(eta = ...)`` modifier would override the binding
and leave the Rig's own ``eta`` and the pendulum's ``m_p`` behind. ``solver_step`` is the
FMU integrator's step and has no Modelica counterpart; a given one is noted in a comment.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

from pendfmu import __version__
from pendfmu.atomic import write_atomically
from pendfmu.components import COMPONENTS
from pendfmu.errors import UsageError
from pendfmu.escaping import modelica_identifier, modelica_string, one_line
from pendfmu.export.plan import ExportPlan, refusal

LIBRARY = "PendulumID"
PACKAGE = "PendfmuExport"
# Instance names in PendulumID.Examples.Rig and CartStartStop.
INSTANCES = {"CurrentLoop": "currentLoop", "Cart": "cart", "Pendulum": "pendulum"}
# Parameters of the FMUs that the Modelica classes do not have.
FMU_ONLY = ("solver_step",)
# Parameters that PendulumID.Examples.Rig declares and binds into cart and pendulum.
RIG_LEVEL = ("eta", "m_p", "l")
INDENT = "  "


def _number(value: float) -> str:
    """A Modelica real literal that reads back to the same double (repr: '1e-05', '30.0')."""
    return repr(float(value))


def _entries(component: str, values: Mapping[str, float], given: Mapping[str, float]) -> list[tuple[str, str]]:
    """(modification, comment) for each Modelica parameter among `values`, in table order."""
    table = COMPONENTS[component].parameters
    out = []
    for name, value in values.items():
        if name in FMU_ONLY:
            continue
        unit = table[name].unit or "1"
        out.append((f"{modelica_identifier(name)} = {_number(value)}", unit if name in given else f"{unit} (default)"))
    return out


def _fmu_only_notes(component: str, given: Mapping[str, float]) -> list[str]:
    """Comment lines for given values that exist only in the FMU."""
    return [f"// {name} = {_number(given[name])} [{COMPONENTS[component].parameters[name].unit}]: "
            f"FMU only, no {LIBRARY} counterpart" for name in FMU_ONLY if name in given]


def _modification_lines(entries: list[tuple[str, str]], indent: str) -> list[str]:
    """One `name = value, // unit` line per entry; commas between, none after the last."""
    lines = []
    for k, (text, comment) in enumerate(entries):
        comma = "," if k < len(entries) - 1 else ""
        lines.append(f"{indent}{text}{comma} // {comment}")
    return lines


def _nested(instance: str, entries: list[tuple[str, str]], notes: list[str], indent: str) -> list[str]:
    """`instance(...)` as a block of lines (no trailing comma): a modification of a component."""
    inner = indent + INDENT
    return [f"{indent}{instance}(", *(inner + n for n in notes), *_modification_lines(entries, inner),
            f"{indent})"]


def _join_blocks(blocks: list[list[str]]) -> list[str]:
    """Blocks of lines separated by commas: a comma goes after each block's last line but
    before a trailing `// comment`, so that the comment does not swallow it."""
    lines = []
    for k, block in enumerate(blocks):
        block = list(block)
        if k < len(blocks) - 1:
            text, sep, comment = block[-1].partition(" // ")
            block[-1] = f"{text},{' // ' + comment if sep else ''}"
        lines.extend(block)
    return lines


def declarations(plan: ExportPlan) -> list[str]:
    """The partial model with one declaration per exported component."""
    lines = [f'{INDENT}partial model IdentifiedComponents "The exported components: copy a declaration into '
             f'a model"']
    for component in plan.components:
        values = plan.start_values(component)
        given = plan.components[component]
        body = _nested(f"{LIBRARY}.{component} {INSTANCES[component]}", _entries(component, values, given),
                       _fmu_only_notes(component, given), INDENT * 2)
        body[-1] += f' "{component} with the exported parameters";'
        lines.extend(body)
    lines.append(f"{INDENT}end IdentifiedComponents;")
    return lines


def _pendulum_removed(rig_level: Mapping[str, float]) -> bool:
    """True when a Rig-level value (m_p = 0) is one that no Pendulum can take."""
    pendulum = COMPONENTS["Pendulum"]
    return any(refusal(pendulum, p, v) for p, v in rig_level.items() if p in pendulum.parameters)


def _rig_level(plan: ExportPlan) -> dict[str, float]:
    """eta, m_p, l as the exported components have them (shared values agree by construction)."""
    found: dict[str, float] = {}
    for component in plan.components:
        for name, value in plan.start_values(component).items():
            if name in RIG_LEVEL:
                if found.setdefault(name, value) != value:
                    raise UsageError(f"{name} differs between components: {found[name]!r} and {value!r}")
    return {name: found[name] for name in RIG_LEVEL if name in found}


def complete_model(plan: ExportPlan) -> list[str]:
    """IdentifiedRig (or IdentifiedCartStartStop without a pendulum) with the exported values."""
    rig_level = _rig_level(plan)
    removed = _pendulum_removed(rig_level) or "Pendulum" in plan.skipped
    example, model = ("CartStartStop", "IdentifiedCartStartStop") if removed else ("Rig", "IdentifiedRig")
    lifted = () if removed else RIG_LEVEL
    inner = INDENT * 3
    given_names = {n for values in plan.components.values() for n in values}
    blocks = [[f"{inner}{name} = {_number(value)} // {COMPONENTS['Cart'].parameters[name].unit or '1'}"
               f"{'' if name in given_names else ' (default)'}"] for name, value in rig_level.items()
              if name in lifted]
    for component in plan.components:
        if removed and component == "Pendulum":
            continue
        values = {n: v for n, v in plan.start_values(component).items() if n not in lifted}
        given = plan.components[component]
        blocks.append(_nested(INSTANCES[component], _entries(component, values, given),
                              _fmu_only_notes(component, given), inner))
    return [f'{INDENT}model {model} "{LIBRARY}.Examples.{example} with the exported parameters"',
            f"{INDENT * 2}extends {LIBRARY}.Examples.{example}(",
            *_join_blocks(blocks),
            f"{INDENT * 2});",
            f"{INDENT}end {model};"]


def modifiers_text(plan: ExportPlan) -> str:
    """The whole modifiers.mo: header comments, then package PendfmuExport."""
    header = [
        f"// Parameters for the Modelica library {LIBRARY}, written by pendfmu {__version__} export",
        f"// from {one_line(plan.source)}. Load modelica/{LIBRARY}/package.mo first, then this file.",
        "// Units in comments are those of the declarations; '(default)' marks values not given.",
        *(f"// {one_line(name)} not exported: {one_line(why)}" for name, why in plan.skipped.items()),
    ]
    body = [f'package {PACKAGE} {modelica_string(f"Parameters exported by pendfmu from {plan.source}")}',
            *declarations(plan), "", *complete_model(plan), f"end {PACKAGE};"]
    return "\n".join(header + body) + "\n"


def write_modifiers(plan: ExportPlan, path: str | Path) -> Path:
    """Write the Modelica text of `plan` to `path`."""
    return write_atomically(path, modifiers_text(plan))
