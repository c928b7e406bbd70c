"""The data model of an SSP system: plain dataclasses, free of XML.

They hold what pendfmu needs from an SSD and its parameter files and nothing else, so
that a round trip through the files gives back an equal object. Names follow the SSP
1.0 standard (component, connector, connection, parameter set) so that a reader who
knows the standard recognises them.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import ClassVar

# Connector kinds of SSP 1.0 that an FMI 2.0 variable can have (its causality).
KINDS = ("input", "output", "parameter", "calculatedParameter")
# Scalar types a connector or parameter value can have (Enumeration and Binary are not used).
TYPES = ("Real", "Integer", "Boolean", "String")


@dataclass(frozen=True)
class Unit:
    """A unit as exponents of SI base units, like FMI's BaseUnit and SSP's ssc:Unit.

    SSP requires every unit a connector or parameter names to be defined in the same
    file, so the definitions travel with the system instead of being looked up. A value in
    the unit is ``factor * value + offset`` in the SI base units (``degC``: factor 1,
    offset 273.15, K = 1).

    Attributes
    ----------
    name : str
        The unit's name as connectors and values cite it, e.g. "m/s2", "N.m".
    kg, m, s, A, K, mol, cd, rad : int
        The exponent of each SI base unit (and of the radian, which FMI counts too), e.g.
        N: kg = 1, m = 1, s = -2.
    factor : float
        The factor to the SI base units.
    offset : float
        The offset to the SI base units.
    """

    EXPONENTS: ClassVar[tuple[str, ...]] = ("kg", "m", "s", "A", "K", "mol", "cd", "rad")

    name: str
    kg: int = 0
    m: int = 0
    s: int = 0
    A: int = 0
    K: int = 0
    mol: int = 0
    cd: int = 0
    rad: int = 0
    factor: float = 1.0
    offset: float = 0.0

    def dimension(self) -> tuple[int, ...]:
        """The exponents alone: two units with the same dimension can be converted.

        Returns
        -------
        tuple of int
            The exponents of kg, m, s, A, K, mol, cd and rad, in that order.
        """
        return tuple(getattr(self, e) for e in self.EXPONENTS)


@dataclass(frozen=True)
class Connector:
    """One variable of a component made visible to the system (or one of the system's own
    inputs and outputs).

    Attributes
    ----------
    name : str
        The variable's name, e.g. "x".
    kind : str
        Its FMI 2.0 causality: "input", "output", "parameter" or "calculatedParameter".
    type : str
        "Real", "Integer", "Boolean" or "String".
    unit : str or None
        The name of its unit (defined in the system's units); None for none.
    """

    name: str
    kind: str  # one of KINDS: the FMI 2.0 causality of the variable
    type: str = "Real"
    unit: str | None = None


@dataclass(frozen=True)
class FmuComponent:
    """A component of the system implemented by an FMU.

    ``source`` is the URI written in the SSD, relative to it ("resources/Cart.fmu", as the
    standard requires inside an SSP); ``fmu`` is where that file is on this machine, if
    known. ``fmu`` does not take part in comparisons: the same system read from another
    directory is still the same system.

    Attributes
    ----------
    name : str
        The component's name in the system, e.g. "Cart".
    source : str
        The FMU's URI as the SSD writes it, relative to the SSD.
    connectors : tuple of Connector
        The FMU variables the system sees.
    implementation : str
        The FMI interface the system uses: "any", "CoSimulation" or "ModelExchange".
    fmu : Path or None
        Where the FMU file is on this machine; None when not known.
    """

    name: str
    source: str
    connectors: tuple[Connector, ...]
    implementation: str = "any"  # any | CoSimulation | ModelExchange
    fmu: Path | None = field(default=None, compare=False)

    def connector(self, name: str) -> Connector | None:
        """Find one of the component's connectors by name.

        Parameters
        ----------
        name : str
            The variable's name.

        Returns
        -------
        Connector or None
            The connector; None when the component has none of that name.
        """
        return next((c for c in self.connectors if c.name == name), None)


@dataclass(frozen=True)
class Connection:
    """Data flows from the start connector (an output) to the end connector (an input).

    An empty element ("") is the system itself, as an absent startElement/endElement is in
    SSP 1.0: "" -> Component.input feeds a component from a system input connector, and
    Component.output -> "" makes a component's output a system output.

    Attributes
    ----------
    start_element : str
        The component the data comes from; "" for the system itself.
    start_connector : str
        Its connector (an output, or a system input).
    end_element : str
        The component the data goes to; "" for the system itself.
    end_connector : str
        Its connector (an input, or a system output).
    """

    start_element: str
    start_connector: str
    end_element: str
    end_connector: str

    @classmethod
    def between(cls, start: str, end: str) -> Connection:
        """A connection written as its two ends, e.g. ``Connection.between("Cart.a",
        "Pendulum.a")``.

        Parameters
        ----------
        start, end : str
            "Component.variable"; a bare name is a connector of the system itself (at most
            one end).

        Returns
        -------
        Connection
            The connection from `start` to `end`.

        Raises
        ------
        ValueError
            An end with no connector, or both ends bare names.
        """
        start_element, start_connector = _end(start)
        end_element, end_connector = _end(end)
        if not (start_connector and end_connector) or not (start_element or end_element):
            raise ValueError(f"connect {start!r} to {end!r}: write the ends as Component.variable "
                             "(one end may be a bare name: a connector of the system)")
        return cls(start_element, start_connector, end_element, end_connector)

    @property
    def at_boundary(self) -> bool:
        """Whether one end is a connector of the system itself rather than of a component."""
        return not (self.start_element and self.end_element)

    def __str__(self) -> str:
        start = f"{self.start_element}.{self.start_connector}" if self.start_element else self.start_connector
        end = f"{self.end_element}.{self.end_connector}" if self.end_element else self.end_connector
        return f"{start} -> {end}"


def _end(text: str) -> tuple[str, str]:
    """(element, connector) of "Component.variable", or ("", name) for a system connector."""
    element, dot, connector = text.partition(".")
    return (element, connector) if dot else ("", element)


@dataclass(frozen=True)
class ParameterValue:
    """A value given to a parameter (or the start value of an input), with its unit.

    Attributes
    ----------
    value : float or int or bool or str
        The value, in `unit`.
    unit : str or None
        The name of its unit; None for none.
    type : str
        "Real", "Integer", "Boolean" or "String".
    """

    value: float | int | bool | str
    unit: str | None = None
    type: str = "Real"


@dataclass
class ParameterSet:
    """The content of one SSV file: a named set of values with the units they use.

    Attributes
    ----------
    name : str
        The set's name.
    values : dict of str to ParameterValue
        The values by parameter name.
    units : dict of str to Unit
        The definitions of the units the values name, by name.
    """

    name: str
    values: dict[str, ParameterValue]
    units: dict[str, Unit] = field(default_factory=dict)


@dataclass(frozen=True)
class DefaultExperiment:
    """Default experiment: SSP's DefaultExperiment has start and stop time; the
    communication step size has no place in SSP 1.0 and goes into a pendfmu annotation.

    Attributes
    ----------
    start_time : float or None
        The start time [s]; None when the file gives none.
    stop_time : float or None
        The stop time [s]; None when the file gives none.
    step_size : float or None
        The communication step [s] (pendfmu's annotation); None when not given.
    """

    start_time: float | None = 0.0
    stop_time: float | None = None
    step_size: float | None = None


@dataclass
class System:
    """A flat system of FMU components, its connections and its parameter values.

    The parameter values form one named parameter set, stored as one SSV file per
    component.

    Attributes
    ----------
    name : str
        The system's name.
    components : dict of str to FmuComponent
        The components by name.
    connections : list of Connection
        Between components, and between components and the system's own connectors.
    parameters : dict of str to dict of str to ParameterValue
        Per component name, that component's values by variable name.
    units : dict of str to Unit
        The definitions of every unit the connectors and values name, by name.
    parameter_set : str
        The parameter set's name.
    experiment : DefaultExperiment or None
        The default experiment; None when not given.
    description : str
        Free text, written into the SSD.
    connectors : tuple of Connector
        The system's own inputs and outputs (kind "input" or "output"), wired to the
        components by connections with an empty element (see Connection): the names
        other tools drive and record the system by.
    """

    name: str
    components: dict[str, FmuComponent]
    connections: list[Connection]
    parameters: dict[str, dict[str, ParameterValue]] = field(default_factory=dict)
    units: dict[str, Unit] = field(default_factory=dict)
    parameter_set: str = "parameters"
    experiment: DefaultExperiment | None = None
    description: str = ""
    connectors: tuple[Connector, ...] = ()

    def connector(self, name: str) -> Connector | None:
        """Find one of the system's own connectors by name.

        Parameters
        ----------
        name : str
            The connector's name, e.g. "I_c".

        Returns
        -------
        Connector or None
            The connector; None when the system has none of that name.
        """
        return next((c for c in self.connectors if c.name == name), None)

    def component_connections(self) -> list[Connection]:
        """The connections between components: what a master couples (the system's own
        connectors are where a caller feeds inputs and reads outputs).

        Returns
        -------
        list of Connection
            Those with a component at both ends.
        """
        return [c for c in self.connections if not c.at_boundary]

    def boundary(self, kind: str) -> dict[str, list[tuple[str, str]]]:
        """What the system's own inputs feed, or what feeds its outputs.

        Parameters
        ----------
        kind : str
            "input" or "output".

        Returns
        -------
        dict of str to list of (str, str)
            Per system connector of that kind, the (component, variable) pairs it feeds
            (an input) or is fed by (an output).
        """
        found: dict[str, list[tuple[str, str]]] = {c.name: [] for c in self.connectors if c.kind == kind}
        for c in self.connections:
            if kind == "input" and not c.start_element and c.start_connector in found and c.end_element:
                found[c.start_connector].append((c.end_element, c.end_connector))
            elif kind == "output" and not c.end_element and c.end_connector in found and c.start_element:
                found[c.end_connector].append((c.start_element, c.start_connector))
        return found

    def parameter_source(self, component: str) -> str:
        """Where a component's values are stored.

        Parameters
        ----------
        component : str
            A component of the system, by name.

        Returns
        -------
        str
            The URI of its SSV file, relative to the SSD: ``resources/<component>.ssv``.
        """
        return f"resources/{component}.ssv"

    def parameter_set_of(self, component: str) -> ParameterSet:
        """A component's share of the parameter set, as it goes into its SSV file.

        Parameters
        ----------
        component : str
            The component's name.

        Returns
        -------
        ParameterSet
            Its values, with the definitions of the units they name.
        """
        values = dict(self.parameters.get(component, {}))
        used = {v.unit for v in values.values() if v.unit is not None}
        return ParameterSet(self.parameter_set, values, {u: self.units[u] for u in sorted(used) if u in self.units})

    def value(self, component: str, name: str) -> float | int | bool | str | None:
        """The value the parameter set gives one variable of a component.

        Parameters
        ----------
        component : str
            The component's name.
        name : str
            The variable's name.

        Returns
        -------
        float or int or bool or str or None
            The value, in its unit; None when the set gives it none.
        """
        given = self.parameters.get(component, {}).get(name)
        return None if given is None else given.value
