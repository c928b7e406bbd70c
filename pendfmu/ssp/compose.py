"""A system of any FMUs, wired by name: what `pendfmu system` writes.

The rig has its own builder (rig.py); anything else, such as pendfmu's controller around
the cart (a closed-loop recording), a user's controller FMU around pendfmu's cart, or
a drive FMU from another tool, is composed here:

    compose({"Controller": "Controller", "Cart": "Cart"},
            ["Controller.u=Cart.I", "Cart.x=Controller.y"],
            {"Controller.K_p": 3.9e4, "Cart.m_c": 95.1})

A component is a pendfmu component name (built on demand) or an FMU file. A parameter
is written "Component.name", or bare: it then sets the one component that has it, or
every one of pendfmu's components that has it (their names are physical quantities: m_p
and l are one mass and one length for Cart and Pendulum, docs/user-guide/model.md); a bare
name a user's FMU shares with another component must be qualified. Values for what the
system does not hold are left out and said (`warn`), so that one parameters or result file
of the rig serves any system of its components: a parameter of one of pendfmu's components
the system lacks (T_i in a loop of Controller and Cart), and a measurement parameter
(x_offset: the recordings', pendfmu/recording/measurement.py). Any other name no component
has is an error naming it. Every parameter of every component is written, as the rig does, so
the SSP states the whole system whatever FMU build it is later combined with.

Every component input no connection feeds becomes an input of the system (an SSP system
connector wired to it), named like the variable, or Component_variable where two
components leave inputs of the same name free: that is where a recording drives the
system (`pendfmu simulate --system`), and other tools need it too (fmpy's simulate_ssp
fails on an input nothing feeds). Outputs stay the components' own: every tool records
them by Component.variable.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

from pendfmu.components import ALL_COMPONENTS
from pendfmu.errors import BadInput
from pendfmu.physics import J_CM, overlay, settled
from pendfmu.ssp.fmu import FmuDescription, describe_fmu
from pendfmu.suggest import did_you_mean
from pendfmu.ssp.model import Connection, Connector, DefaultExperiment, FmuComponent, ParameterValue, System

_KINDS = {"Real": float, "Integer": int, "Boolean": bool}


def _fmu_of(name: str, source: str | Path) -> Path:
    """The FMU file of a component: a file, or pendfmu's own component of that name."""
    from pendfmu.fmubuild import ensure_fmu

    path = Path(source)
    if path.suffix.lower() == ".fmu":
        if not path.is_file():
            raise BadInput(f"component {name}: no FMU file {path}")
        return path
    if str(source) in ALL_COMPONENTS:
        return ensure_fmu(str(source))
    raise BadInput(f"component {name}: {source!r} is neither an FMU file (.fmu) nor a pendfmu component "
                   f"({', '.join(ALL_COMPONENTS)})")


def compose(components: Mapping[str, str | Path], connections: Sequence[str],
            parameters: Mapping[str, float] | None = None, *, name: str = "System",
            step_size: float | None = None, description: str = "",
            warn: Callable[[str], None] | None = None) -> System:
    """The System of these components (name -> pendfmu component or FMU file), connected
    "Start.output=End.input", with these parameter values (see the module docstring;
    `warn` hears of the values left out)."""
    fmus = {n: describe_fmu(_fmu_of(n, source)) for n, source in components.items()}
    # An FMU used by several components is packed once per component (resources/<component>.fmu),
    # so that each copy can carry its component's values (archive.py).
    shared = {d.path.name for d in fmus.values() if sum(e.path.name == d.path.name for e in fmus.values()) > 1}
    parts = {n: FmuComponent(n, f"resources/{n if d.path.name in shared else d.path.stem}.fmu", d.connectors,
                             "CoSimulation", d.path)
             for n, d in fmus.items()}
    wires = []
    for text in connections:
        start, equals, end = text.partition("=")
        if not equals:
            raise BadInput(f"connection {text!r}: write it Start.output=End.input")
        try:
            wire = Connection.between(start.strip(), end.strip())
        except ValueError as error:
            raise BadInput(str(error)) from None
        for element, connector, kind in ((wire.start_element, wire.start_connector, "output"),
                                         (wire.end_element, wire.end_connector, "input")):
            declared = {c.name: c.kind for c in parts[element].connectors} if element in parts else None
            if declared is None:
                raise BadInput(f"connection {text!r}: no component {element!r} ({', '.join(parts)})")
            if declared.get(connector) != kind:
                names = [c for c, k in declared.items() if k == kind]
                raise BadInput(f"connection {text!r}: {element} has no {kind} {connector!r} ({', '.join(names)})")
        wires.append(wire)
    values = _values(components, fmus, parameters or {}, warn)
    used = {c.unit for d in fmus.values() for c in d.connectors if c.unit}
    units = {u: d.units[u] for d in fmus.values() for u in sorted(used) if u in d.units}
    connectors, boundary = free_inputs(parts, wires)
    return System(name, parts, wires + boundary, values, units, experiment=DefaultExperiment(0.0, None, step_size),
                  description=description or f"{', '.join(parts)} composed by pendfmu", connectors=connectors)


def _physical(components: Mapping[str, str | Path], given: Mapping[str, Mapping[str, float]],
              values: dict[str, dict[str, ParameterValue]]) -> None:
    """pendfmu's components as the rules between their parameters allow (physics.py): a
    J_cm written as J_p, values that break a rule refused before the system is written. A
    foreign FMU's names need not mean what the rig's do: it takes no J_cm, and no rule."""
    for name, own in given.items():
        if str(components[name]) not in ALL_COMPONENTS:
            if J_CM in own:
                raise BadInput(f"parameter {name}.{J_CM}: the centre-of-mass inertia is for pendfmu's Pendulum; "
                               f"{name} is another FMU")
            continue
        starts = {p: float(v.value) for p, v in values[name].items() if v.type == "Real"}
        final = settled(overlay(starts, own, f"component {name}"), f"component {name}")
        if J_CM in own:
            declared = values[name]["J_p"]
            values[name]["J_p"] = ParameterValue(final["J_p"], declared.unit, declared.type)


def free_inputs(parts: Mapping[str, FmuComponent], wires: Sequence[Connection], taken: Sequence[str] = ()
                ) -> tuple[tuple[Connector, ...], list[Connection]]:
    """A system input for each component input no wire feeds (module docstring), and the
    connections from them; a name in `taken` (the system's other connectors) is qualified too.

    Why every one: fmpy's simulate_ssp resolves an input no connection feeds to the source
    of the input before it (0.3.32 keeps the previous loop's start_p): the rig's free Cart.u
    would silently follow CurrentLoop.I_mean there, or fail when it comes first."""
    fed = {(w.end_element, w.end_connector) for w in wires}
    free = [(n, c) for n, part in parts.items() for c in part.connectors
            if c.kind == "input" and (n, c.name) not in fed]
    names = [c.name for _, c in free] + list(taken)
    connectors, boundary = [], []
    for element, connector in free:
        name = connector.name if names.count(connector.name) == 1 else f"{element}_{connector.name}"
        connectors.append(Connector(name, "input", connector.type, connector.unit))
        boundary.append(Connection("", name, element, connector.name))
    return tuple(connectors), boundary


def _values(components: Mapping[str, str | Path], fmus: Mapping[str, FmuDescription],
            parameters: Mapping[str, float], warn: Callable[[str], None] | None) -> dict[str, dict[str, ParameterValue]]:
    """Every parameter of every component: its FMU's start value unless `parameters` set it
    (module docstring for the names), a J_cm as J_p, and pendfmu's components checked against
    the rules between their parameters (_physical)."""
    from pendfmu.ssp.archive import own_component

    values = {n: dict(d.starts) for n, d in fmus.items()}
    given: dict[str, dict[str, float]] = {n: {} for n in fmus}
    own = {n for n, d in fmus.items() if own_component(d.path)}
    left_out = []
    for key, value in parameters.items():
        centre_of_mass = key.rpartition(".")[2] == J_CM  # written as J_p (_physical)
        targets = _targets(key[:-len(J_CM)] + "J_p" if centre_of_mass else key, fmus, own)
        if not targets:
            left_out.append(key)
        for component, parameter in targets:
            checked = _checked(key, value, fmus[component], parameter)
            given[component][J_CM if centre_of_mass else parameter] = float(checked.value)
            if not centre_of_mass:
                values[component][parameter] = checked
    if left_out and warn:
        warn(_left_out(left_out))
    _physical(components, given, values)
    return values


def _checked(key: str, value: object, fmu: FmuDescription, parameter: str) -> ParameterValue:
    """`value` as the typed value of `parameter` of `fmu`, or an error naming `key`."""
    declared = next(c for c in fmu.connectors if c.name == parameter)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise BadInput(f"parameter {key} = {value!r}: not a finite number")
    if declared.type == "Integer" and float(value) != int(value):
        raise BadInput(f"parameter {key} = {value!r}: an Integer")
    return ParameterValue(_KINDS[declared.type](value), declared.unit, declared.type)


def _targets(key: str, fmus: Mapping[str, FmuDescription], own: set[str]) -> list[tuple[str, str]]:
    """The (component, parameter) pairs `key` sets; none for a value the system has no place
    for (module docstring), an error for a name it cannot place."""
    component, dot, parameter = key.partition(".")
    if dot:
        if component not in fmus:
            raise BadInput(f"parameter {key}: no component {component!r}{did_you_mean(component, fmus)} "
                           f"({', '.join(fmus)})")
        if parameter not in fmus[component].starts:
            raise BadInput(f"parameter {key}: {component} has no parameter {parameter!r}"
                           f"{did_you_mean(parameter, fmus[component].starts)} ({', '.join(fmus[component].starts)})")
        return [(component, parameter)]
    owners = [n for n, d in fmus.items() if key in d.starts]
    if len(owners) == 1 or (owners and set(owners) <= own):
        return [(n, key) for n in owners]
    if owners:
        raise BadInput(f"parameter {key}: {' and '.join(owners)} have it: write Component.{key}")
    if _elsewhere(key):
        return []
    known = {p for d in fmus.values() for p in d.starts}
    raise BadInput(f"parameter {key}: no component has it{did_you_mean(key, known)}")


def _elsewhere(key: str) -> str | None:
    """Where else a name no component has belongs: the pendfmu component that has it, "the
    recordings" for a measurement parameter, None for neither (module docstring)."""
    from pendfmu.components import ALL_COMPONENTS
    from pendfmu.recording.measurement import measurement_signal

    owner = next((c.name for c in ALL_COMPONENTS.values() if key in c.parameters), None)
    return owner or ("the recordings" if measurement_signal(key) else None)


def _left_out(keys: Sequence[str]) -> str:
    """The note on values no component of the system has, grouped by where they belong."""
    groups: dict[str, list[str]] = {}
    for key in keys:
        groups.setdefault(_elsewhere(key), []).append(key)
    parts = [f"{owner}: {', '.join(names)}" for owner, names in groups.items()]
    return f"left out, as no component of this system has them: {'; '.join(parts)}"
