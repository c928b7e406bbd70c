"""A model: component FMUs, the connections between them, and the names a fit uses.

Everything pendfmu simulates or fits is a Model: one of its own components (the current
stage's CurrentLoop), a chain of them (CurrentLoop -> Cart), a user's FMU exported from
Simulink or OpenModelica (`Model.from_fmu`), or an SSP system of several FMUs
(`Model.from_ssp`). The fit and the simulator see only this interface.

Names. A variable is named `Instance.variable`; it is also known by its bare name where
that is unambiguous. Pendfmu's own rig is the exception it was built on: its components
share physical quantities by name (m_p and l are one mass and one length for Cart and
Pendulum), so in a model made of them (`shared=True`) a bare parameter name sets every
component that has it, as in the paper's model (docs/user-guide/model.md). In any other
model a bare name that two components have is ambiguous, and using it is an error that
lists the qualified names.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

from pendfmu.errors import BadInput
from pendfmu.ranges import outside
from pendfmu.recording.schema import Vocabulary, WithMeasurements
from pendfmu.simulator.component import once_per_process
from pendfmu.simulator.fmi import unpacked_fmu
from pendfmu.simulator.graph import Wire, algebraic_loops, stepping_order
from pendfmu.suggest import did_you_mean


class ModelError(BadInput):
    """A model that cannot be used as asked (a name it lacks, an FMU it cannot run)."""


@dataclass(frozen=True)
class Port:
    """One variable of one instance."""

    instance: str
    variable: str

    def __str__(self) -> str:
        return f"{self.instance}.{self.variable}"


@dataclass(frozen=True)
class Variable:
    """What a model description declares about a variable a fit may use."""

    port: Port
    causality: str  # parameter | input | output
    start: float | None
    low: float | None
    high: float | None
    unit: str
    type: str = "Real"  # Real, or Integer / Boolean for a parameter (values as numbers: Boolean 0 or 1)
    low_open = False  # FMI 2 ranges are closed: min <= value <= max (pendfmu.ranges)


@dataclass(frozen=True)
class Instance:
    """One FMU in a model: `fmu` is its file, or None for pendfmu's component `kind`
    (built from source when missing)."""

    name: str
    kind: str
    fmu: Path | None = None

    def description(self):
        return unpacked_fmu(self.kind if self.fmu is None else self.name, self.fmu)[1]


@dataclass
class Model:
    """Instances, connections, and the variables a fit names (module docstring).

    Build one with :meth:`from_fmu`, :meth:`from_ssp`, :meth:`load` or
    :meth:`of_components`; the constructor reads every FMU's model description and refuses
    one without Co-Simulation.

    Attributes
    ----------
    name : str
        The model's name, as results and messages name it.
    instances : dict of str to Instance
        The FMUs by instance name: each with its model identifier (`kind`) and its file
        (`fmu`, None for a pendfmu component built from source).
    connections : list of Wire
        Outputs feeding inputs between instances.
    shared : bool
        Whether a bare parameter name sets every component that has it (pendfmu's rig,
        whose components share m_p and l); otherwise a bare name two components have is
        ambiguous.
    boundary : dict of str to dict of str to list of Port
        An SSP system's own connectors: per causality ("input", "output"), each
        connector's name with the ports it feeds or reads. These names come first: they are
        the interface the system declares.
    variables : dict of Port to Variable
        Every Real parameter, input and output (and Integer and Boolean parameter) of every
        instance, with what its model description declares (start, range, unit).
    order : list of list of str
        The instances in the order they step; a group of several is coupled.
    loops : list of list of str
        The algebraic loops (cycles of direct feedthrough), as "Instance.variable" lists in
        signal order.

    Raises
    ------
    ModelError
        An FMU with no Co-Simulation interface.
    """

    name: str
    instances: dict[str, Instance]
    connections: list[Wire] = field(default_factory=list)
    shared: bool = False  # pendfmu's rig: a bare parameter name sets every component having it
    # An SSP system's own connectors: causality ("input"/"output") -> name -> the ports it
    # feeds or reads. These names come first: they are the interface the system declares.
    boundary: dict[str, dict[str, list[Port]]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.variables: dict[Port, Variable] = {}
        for instance in self.instances.values():
            md = instance.description()
            if md.coSimulation is None:
                raise ModelError(f"{instance.fmu or instance.kind}: a Model-Exchange-only FMU (it has no "
                                 f"Co-Simulation interface); pendfmu steps FMUs by co-simulation: export it "
                                 f"with Co-Simulation (both interfaces in one FMU are fine)")
            for v in md.modelVariables:
                if v.type == "Real" and v.causality in ("parameter", "input", "output"):
                    port = Port(instance.name, v.name)
                    self.variables[port] = Variable(port, v.causality, _number(v.start), _number(v.min),
                                                    _number(v.max), v.unit or "")
                elif v.type in ("Integer", "Boolean") and v.causality == "parameter":
                    # A setting such as a controller's delay in samples: given and set as a number.
                    port = Port(instance.name, v.name)
                    start = _boolean(v.start) if v.type == "Boolean" else _number(v.start)
                    self.variables[port] = Variable(port, v.causality, start, _number(v.min), _number(v.max), "",
                                                    v.type)
        connected = {Port(c.target, c.input) for c in self.connections}
        self.order = stepping_order({n: i.kind for n, i in self.instances.items()}, self.connections)
        self.loops = algebraic_loops(self.connections, {n: _feedthrough(i) for n, i in self.instances.items()}) \
            if self.connections else []
        self._names: dict[str, dict[str, list[Port]]] = {}
        for causality in ("parameter", "input", "output"):
            ports = [p for p, v in self.variables.items() if v.causality == causality
                     and not (causality == "input" and p in connected)]
            self._names[causality] = _names(ports, self.shared and causality == "parameter")
        for causality, connectors in self.boundary.items():
            for name, ports in connectors.items():
                # Only Real inputs and outputs are signals pendfmu drives and reads (as above).
                if ports and all(p in self.variables and self.variables[p].causality == causality for p in ports):
                    self._names[causality][name] = list(ports)

    # -- construction

    @classmethod
    def load(cls, model: str | Path | Model) -> Model:
        """A model from a file by its suffix, as every command and `fit` take one.

        Parameters
        ----------
        model : str or Path or Model
            An FMU (``.fmu``) or SSP (``.ssp``) file; a Model is returned as it is.

        Returns
        -------
        Model
            :meth:`from_fmu` or :meth:`from_ssp` of the file.

        Raises
        ------
        ModelError
            Any other suffix, or a file that cannot be read.
        """
        if isinstance(model, Model):
            return model
        path = Path(model)
        if path.suffix.lower() == ".fmu":
            return cls.from_fmu(path)
        if path.suffix.lower() == ".ssp":
            return cls.from_ssp(path)
        raise ModelError(f"{model}: a model is an FMU (.fmu) or an SSP system (.ssp)")

    @classmethod
    def from_fmu(cls, path: str | Path, name: str | None = None) -> Model:
        """A model of one FMU file (one instance, named by its model identifier).

        Parameters
        ----------
        path : str or Path
            An FMI 2.0 FMU with Co-Simulation (exported from Simulink, OpenModelica, ...).
        name : str, optional
            The model's name; the model identifier by default.

        Returns
        -------
        Model
            The model, not `shared`: a bare name is the FMU's variable.

        Raises
        ------
        ModelError
            No such file, not a readable FMU, not FMI 2.0, or Model Exchange only.
        """
        path = Path(path)
        if not path.is_file():
            raise ModelError(f"{path}: no such FMU file")
        try:
            md = unpacked_fmu(path.stem, path)[1]
        except BadInput:  # a file name FMI does not allow (simulator.fmi.UnsafeFMU): says it all
            raise
        except Exception as error:  # not a zip, no modelDescription.xml, not FMI 2.0 ...
            raise ModelError(f"{path}: cannot read this FMU ({type(error).__name__}: {error})") from None
        if md.fmiVersion != "2.0":
            raise ModelError(f"{path}: FMI {md.fmiVersion}; pendfmu runs FMI 2.0 FMUs")
        kind = (md.coSimulation or md.modelExchange).modelIdentifier
        return cls(name or kind, {kind: Instance(kind, kind, path)})

    @classmethod
    def from_ssp(cls, path: str | Path) -> Model:
        """A model of an SSP system (an .ssp archive): its FMU components and connections.

        Its parameter set's values become the parameters' start values (`defaults`); its own
        input and output connectors are names of the component ports they are wired to.

        Parameters
        ----------
        path : str or Path
            The SSP archive; it is unpacked into a temporary folder (pendfmu.ssp.read_ssp).

        Returns
        -------
        Model
            The system's components and connections, named as the system names them.

        Raises
        ------
        SspError
            The archive or its files are not acceptable.
        ModelError
            A component FMU that pendfmu cannot run (Model Exchange only).
        """
        from pendfmu.ssp import read_ssp

        system = read_ssp(path)
        instances = {}
        for name, component in system.components.items():
            md = unpacked_fmu(name, component.fmu)[1]
            kind = (md.coSimulation or md.modelExchange).modelIdentifier
            instances[name] = Instance(name, kind, component.fmu)
        connections = [Wire(c.start_element, c.start_connector, c.end_element, c.end_connector)
                       for c in system.component_connections()]
        boundary = {kind: {name: [Port(*pair) for pair in pairs] for name, pairs in system.boundary(kind).items()}
                    for kind in ("input", "output")}
        model = cls(system.name or Path(path).stem, instances, connections, boundary=boundary)
        for name, values in system.parameters.items():
            for variable, given in values.items():
                port = Port(name, variable)
                if port in model.variables and isinstance(given.value, (int, float)):
                    model.variables[port] = replace(model.variables[port], start=float(given.value))
        return model

    @classmethod
    def of_components(cls, name: str, kinds: Mapping[str, str], connections: Sequence[Wire] = ()) -> Model:
        """A model of pendfmu's own components, built from source when missing.

        Parameters
        ----------
        name : str
            The model's name, e.g. "cart" for the cart stage.
        kinds : mapping of str to str
            Instance name -> component ("CurrentLoop", "Cart", "Pendulum", ...:
            components.ALL_COMPONENTS).
        connections : sequence of Wire, optional
            Outputs feeding inputs between the instances.

        Returns
        -------
        Model
            The model, `shared`: a bare parameter name (m_p, l) sets every component that
            has it, as in the paper's model.
        """
        return cls(name, {n: Instance(n, k) for n, k in kinds.items()}, list(connections), shared=True)

    # -- names

    def instantiated_once_per_process(self) -> bool:
        """Whether an FMU of the model declares canBeInstantiatedOnlyOncePerProcess (then a
        fit keeps one instance of it, and runs no simulation in a second thread).

        Returns
        -------
        bool
            True when one of the model's FMU files declares it.
        """
        return any(instance.fmu is not None and once_per_process(instance.description())
                   for instance in self.instances.values())

    def names(self, causality: str) -> list[str]:
        """The names a fit may use for the model's parameters, free inputs or outputs.

        Parameters
        ----------
        causality : str
            "parameter", "input" (the inputs no connection feeds) or "output".

        Returns
        -------
        list of str
            Every qualified name ("Instance.variable"), the bare names that are unambiguous
            (or shared) and a system's own connector names.
        """
        return list(self._names[causality])

    def drive_names(self) -> list[str]:
        """The inputs a recording's equally named columns drive unless told otherwise.

        Returns
        -------
        list of str
            The system's own inputs where it declares them (so a column feeds each input
            once, through the system's interface), else every free input's unambiguous bare
            name.
        """
        declared = [name for name in self.boundary.get("input", {}) if name in self._names["input"]]
        if declared:
            return declared
        return [name for name in self._names["input"] if "." not in name and self._names["input"][name]]

    def interpolates(self, name: str) -> bool:
        """Whether every FMU an input name drives can interpolate its inputs between
        communication points (canInterpolateInputs): what a linear drive needs.

        Parameters
        ----------
        name : str
            An input's name (as :meth:`names` lists them).

        Returns
        -------
        bool
            True when every FMU it drives declares canInterpolateInputs.

        Raises
        ------
        ModelError
            An unknown or ambiguous name.
        """
        for port in self.resolve(name, "input"):
            cosimulation = self.instances[port.instance].description().coSimulation
            if cosimulation is None or not cosimulation.canInterpolateInputs:
                return False
        return True

    def resolve(self, name: str, causality: str) -> list[Port]:
        """The ports a name stands for.

        Parameters
        ----------
        name : str
            A qualified ("Instance.variable"), bare or system connector name.
        causality : str
            "parameter", "input" or "output".

        Returns
        -------
        list of Port
            One port, or several for a shared parameter or a system connector that feeds
            several inputs.

        Raises
        ------
        ModelError
            An unknown or ambiguous name; the message lists the valid names.
        """
        found = self._names[causality].get(name)
        if found is None:
            valid = ", ".join(n for n in self._names[causality] if "." not in n or self._ambiguous(n, causality))
            raise ModelError(f"{self.name}: no {_NOUN[causality]} {name!r}{did_you_mean(name, self._names[causality])}; "
                             f"valid: {valid or 'none'}")
        if not found:
            qualified = [n for n in self._names[causality] if n.endswith(f".{name}")]
            raise ModelError(f"{self.name}: {_NOUN[causality]} {name!r} is in several components; name one of "
                             f"{', '.join(qualified)}")
        return found

    def _ambiguous(self, qualified: str, causality: str) -> bool:
        return self._names[causality].get(qualified.split(".", 1)[1]) == []

    def split(self, values: Mapping[str, float]) -> dict[str, dict[str, float]]:
        """Parameter values by instance, as each FMU is given them.

        Parameters
        ----------
        values : mapping of str to float
            Values by parameter name. Names the model does not have are left out (a rig
            parameter dictionary covers every component; only the model's are used).

        Returns
        -------
        dict of str to dict of str to float
            Per instance name (every instance, perhaps with none), its values by variable
            name.
        """
        per: dict[str, dict[str, float]] = {name: {} for name in self.instances}
        for name, value in values.items():
            for port in self._names["parameter"].get(name) or ():
                per[port.instance][port.variable] = value
        return per

    def port(self, name: str, causality: str) -> Port:
        """The one port a name stands for (an input or output a recording's column maps).

        Parameters
        ----------
        name : str
            A qualified, bare or system connector name.
        causality : str
            "parameter", "input" or "output".

        Returns
        -------
        Port
            The port.

        Raises
        ------
        ModelError
            An unknown or ambiguous name.
        ValueError
            A name that stands for several ports (a shared parameter).
        """
        (found,) = self.resolve(name, causality)
        return found

    def name_of(self, port: Port) -> str:
        """The shortest name of a port, as results and messages show it.

        Parameters
        ----------
        port : Port
            One of the model's `variables`.

        Returns
        -------
        str
            The bare name where that is unambiguous (or shared), else "Instance.variable".
        """
        bare = self._names[self.variables[port].causality].get(port.variable)
        return port.variable if bare == [port] or (self.shared and bare and port in bare) else str(port)

    def defaults(self) -> dict[str, float]:
        """Every parameter's start value by its shortest name (a shared name once).

        Returns
        -------
        dict of str to float
            The start values the model descriptions declare (an SSP's parameter set
            overrides them), in each variable's unit.
        """
        values: dict[str, float] = {}
        for port, variable in self.variables.items():
            if variable.causality == "parameter" and variable.start is not None:
                values.setdefault(self.name_of(port), variable.start)
        return values

    def parameter_problem(self, name: str, value: float) -> str | None:
        """Why a value cannot be a parameter's: the check a recording's sidecar and a fit's
        values go through.

        Parameters
        ----------
        name : str
            The parameter's name.
        value : float
            The value, in the parameter's unit.

        Returns
        -------
        str or None
            Why not (unknown, ambiguous, not finite, not whole for an Integer, not 0 or 1
            for a Boolean, outside the range the model description declares); None when
            it can.
        """
        try:
            ports = self.resolve(name, "parameter")
        except ModelError as error:
            return str(error).split(": ", 1)[1]
        if not math.isfinite(value):
            return f"must be finite, got {value!r}"
        for port in ports:
            kind = self.variables[port].type
            if kind == "Integer" and value != int(value):
                return f"{port} is an Integer parameter: {value!r} is not a whole number"
            if kind == "Boolean" and value not in (0, 1):
                return f"{port} is a Boolean parameter: give 0 or 1 (false or true), not {value!r}"  # every port a name sets must take the value
            problem = outside(str(port), value, [self.variables[port]])
            if problem:
                return problem
        return None

    def vocabulary(self, columns: Iterable[str] = (), initial: Iterable[str] = ()) -> Vocabulary:
        """The names a recording of this model may use, for :func:`pendfmu.read_recording`.

        Parameters
        ----------
        columns : iterable of str, optional
            Column names besides the model's inputs and outputs: those a fit maps to them.
        initial : iterable of str, optional
            The signals whose initial values the sidecar may give (each mapped to a
            parameter by the fit).

        Returns
        -------
        Vocabulary
            Its inputs' and outputs' names and `columns` as signals, its parameters in the
            sidecar (checked against the declared ranges), `initial` as known states.
        """
        signals = dict.fromkeys([*self.names("input"), *self.names("output"), *columns])
        return Vocabulary(tuple(signals), WithMeasurements(self.parameter_problem, tuple(signals)),
                          _KnownNames(tuple(initial)))


_NOUN = {"parameter": "parameter", "input": "input", "output": "output"}


def _names(ports: Iterable[Port], shared: bool) -> dict[str, list[Port]]:
    """name -> ports: every qualified name, and each bare name with its ports (all of them
    when shared, else the one port if unique and [] when ambiguous)."""
    names: dict[str, list[Port]] = {}
    bare: dict[str, list[Port]] = {}
    for port in ports:
        names[str(port)] = [port]
        bare.setdefault(port.variable, []).append(port)
    for name, found in bare.items():
        names[name] = found if shared or len(found) == 1 else []
    return names


@dataclass(frozen=True)
class _KnownNames:
    """The sidecar's `initial` check for a user's model: names it maps, finite values."""

    names: tuple[str, ...]

    def __call__(self, name: str, value: float) -> str | None:
        if name not in self.names:
            return (f"not a state this fit knows; valid: {', '.join(self.names) or 'none'} (map a signal to the "
                    f"parameter of its initial value)")
        return None if math.isfinite(value) else f"must be finite, got {value!r}"




def _boolean(value) -> float | None:
    """A Boolean start value as a number (1.0 true, 0.0 false)."""
    if value is None or value == "":
        return None
    return 1.0 if str(value).lower() in ("true", "1") else 0.0


def _number(value) -> float | None:
    try:
        return None if value is None or value == "" else float(value)
    except (TypeError, ValueError):
        return None


def _feedthrough(instance: Instance) -> dict[str, set[str]]:
    md = instance.description()
    inputs = {v.name for v in md.modelVariables if v.causality == "input"}
    result = {}
    for unknown in md.outputs:
        dependencies = unknown.dependencies if unknown.dependencies is not None else None
        result[unknown.variable.name] = inputs if dependencies is None else {d.name for d in dependencies
                                                                               if d.name in inputs}
    return result
