"""The pendulum rig (docs/user-guide/model.md) as an SSP system of the CurrentLoop, Cart and
Pendulum FMUs."""

from __future__ import annotations

from pathlib import Path

from pendfmu.components import COMPONENTS, ETA_BACK_FROM_ETA, back_drive_efficiency
from pendfmu.ranges import outside
from pendfmu.ssp.fmu import FmuDescription, describe_fmu
from pendfmu.ssp.model import Connection, Connector, DefaultExperiment, FmuComponent, ParameterValue, System

RIG_COMPONENTS = ("CurrentLoop", "Cart", "Pendulum")

#: The parameters two rig components share, set in both whenever either is given: one
#: pendulum sits on the cart, so its mass m_p [kg] and pivot-to-centre-of-mass distance
#: l [m] appear in the Cart (back-drive force) and the Pendulum (its dynamics) and must be
#: the same number.
SHARED_PARAMETERS = ("m_p", "l")

DRIVE = (("CurrentLoop.I_mean", "Cart.I"), ("Cart.a", "Pendulum.a"))

# The system's own connectors: the recorded command current drives the rig, and the signals
# `pendfmu simulate` writes (the rig's measured I, x, phi and their rates) come out, so
# other tools drive and record the rig by these names, as pendfmu does.
RIG_INPUTS = (("I_c", "CurrentLoop.I_c"),)
RIG_OUTPUTS = (("I", "CurrentLoop.I"), ("x", "Cart.x"), ("v", "Cart.v"), ("a", "Cart.a"),
               ("phi", "Pendulum.phi"), ("w", "Pendulum.w"))
BACK_DRIVE = (("Pendulum.phi", "Cart.phi"), ("Pendulum.w", "Cart.w"), ("Pendulum.alpha", "Cart.alpha"))


def rig_connections(eta: float, eta_back: float = ETA_BACK_FROM_ETA) -> list[Connection]:
    """The connections between the rig's components: current -> cart -> pendulum, and for a
    back-drivable screw the pendulum's state back to the cart.

    Parameters
    ----------
    eta : float
        The screw efficiency [-].
    eta_back : float, optional
        The Cart's eta_back parameter: -1 for the paper's A(eta) (back-drivable above
        eta = 0.5), 0 for self-locking, > 0 for back-drivable with that factor A on the
        pendulum's push (docs/user-guide/drives.md).

    Returns
    -------
    list of Connection
        2 connections for a self-locking screw, 5 for a back-drivable one.
    """
    pairs = DRIVE + (BACK_DRIVE if back_drive_efficiency(eta, eta_back) > 0.0 else ())
    return [Connection.between(start, end) for start, end in pairs]


def rig_boundary(components: dict[str, FmuComponent], connections: list[Connection]
                 ) -> tuple[tuple[Connector, ...], list[Connection]]:
    """The system connectors RIG_INPUTS and RIG_OUTPUTS (typed and united like the variables
    they stand for), then one for every other input no connection feeds (the Cart's command u,
    and its pendulum inputs on a self-locking screw: named u, Cart_phi, ..., see
    compose.free_inputs), and the connections that wire them to the components."""
    from pendfmu.ssp.compose import free_inputs

    connectors, wires = [], []
    for kind, pairs in (("input", RIG_INPUTS), ("output", RIG_OUTPUTS)):
        for name, port in pairs:
            element, _, variable = port.partition(".")
            inner = components[element].connector(variable)
            connectors.append(Connector(name, kind, inner.type, inner.unit))
            wires.append(Connection.between(name, port) if kind == "input" else Connection.between(port, name))
    others, other_wires = free_inputs(components, connections + wires, [c.name for c in connectors])
    return tuple(connectors) + others, wires + other_wires


def _targets(key: str, starts: dict[str, dict[str, ParameterValue]]) -> list[tuple[str, str]]:
    """The (component, parameter) pairs a user's key sets.

    "T_i" sets every component's T_i; "Cart.k_fwc" sets one. A shared parameter is set in
    every component that has it, however it is written, so the two can never disagree.
    """
    component, dot, name = key.partition(".")
    if not dot:
        component, name = None, key
    elif component not in starts:
        raise ValueError(f"parameter {key!r}: no rig component {component!r} ({', '.join(starts)})")
    elif name not in starts[component]:
        raise ValueError(f"parameter {key!r}: {component} has no parameter {name!r} "
                         f"({', '.join(starts[component])})")
    if component is None or name in SHARED_PARAMETERS:
        targets = [(c, name) for c in starts if name in starts[c]]
        if not targets:
            raise ValueError(f"no rig component has a parameter {key!r}")
        return targets
    return [(component, name)]


def _check_range(component: str, name: str, value: float) -> None:
    """Reject a value the FMU would reject at instantiation, while the cause is still obvious."""
    problem = outside(f"{component}.{name}", value, [COMPONENTS[component].variable(name)])
    if problem:
        raise ValueError(problem)


def rig_parameters(eta: float, parameters: dict | None,
                   fmus: dict[str, FmuDescription]) -> dict[str, dict[str, ParameterValue]]:
    """Every parameter of every component: the FMU's start value unless `parameters` or `eta` set it.

    The full set is written, not just the changes, so an SSP states the whole rig and does
    not depend on the defaults of whichever FMU build it is later combined with.
    """
    starts = {name: dict(d.starts) for name, d in fmus.items()}
    given: dict[tuple[str, str], tuple[float, str]] = {}
    requests = [("eta (argument)", "Cart.eta", eta)] + [(k, k, v) for k, v in (parameters or {}).items()]
    for label, key, value in requests:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ValueError(f"parameter {key!r}: {value!r} is not a number")
        for target in _targets(key, starts):
            previous = given.get(target)
            if previous is not None and previous[0] != float(value):
                raise ValueError(f"{label} = {value!r} contradicts {previous[1]} = {previous[0]!r} for "
                                 f"{'.'.join(target)}; give each parameter one value")
            given[target] = (float(value), label)
    for (component, name), (value, _) in given.items():
        _check_range(component, name, value)
        starts[component][name] = ParameterValue(value, starts[component][name].unit, "Real")
    return starts


def rig_system(eta: float, fmu_dir: str | Path, parameters: dict | None = None, *,
               start_time: float = 0.0, stop_time: float = 1.0, step_size: float = 2e-4,
               name: str = "PendulumRig", parameter_set: str = "rig") -> System:
    """The rig as an SSP system of the FMUs in `fmu_dir` (CurrentLoop.fmu, Cart.fmu, Pendulum.fmu).

    The system's own connectors (RIG_INPUTS, RIG_OUTPUTS) take the command current I_c in
    and give I, x, v, a, phi, w out; every other input no connection feeds is a system input
    too (rig_boundary).
    `eta` is the screw efficiency: above SELF_LOCKING_ETA (0.5) the pendulum's phi, w and alpha feed back into
    the cart (5 connections), otherwise only current -> cart -> pendulum (2 connections). A Cart parameter
    `eta_back` in `parameters` overrides that switch (0: self-locking, > 0: back-drivable; docs/user-guide/drives.md).
    `parameters` maps "name" (every component that has it) or "Component.name" to a value
    in the FMU's unit; m_p and l always go to both Cart and Pendulum. The default step size
    is the sensors' sample period (0.2 ms).

    Parameters
    ----------
    eta : float
        The screw efficiency [-]; it sets the Cart's eta.
    fmu_dir : str or Path
        The folder of CurrentLoop.fmu, Cart.fmu and Pendulum.fmu.
    parameters : dict, optional
        Values by "name" or "Component.name", in the FMU's (SI) units; every other
        parameter keeps its FMU's start value (all are written into the system).
    start_time, stop_time : float, optional
        The default experiment's start and stop [s].
    step_size : float, optional
        The default experiment's communication step [s].
    name : str, optional
        The system's name.
    parameter_set : str, optional
        The parameter set's name.

    Returns
    -------
    System
        The rig, its FMUs referred to as ``resources/<Name>.fmu``.

    Raises
    ------
    ValueError
        A name no component has, a value that is not a number, or a value outside its
        parameter's range.
    FileNotFoundError
        An FMU is missing from `fmu_dir`.
    """
    fmu_dir = Path(fmu_dir)
    fmus = {c: describe_fmu(fmu_dir / f"{c}.fmu") for c in RIG_COMPONENTS}
    components = {c: FmuComponent(c, f"resources/{c}.fmu", d.connectors, "CoSimulation", d.path)
                  for c, d in fmus.items()}
    used = {conn.unit for d in fmus.values() for conn in d.connectors if conn.unit}
    units = {u: d.units[u] for d in fmus.values() for u in sorted(used) if u in d.units}
    given = parameters or {}
    eta_back = float(given.get("Cart.eta_back", given.get("eta_back", ETA_BACK_FROM_ETA)))
    kind = "back-drivable" if back_drive_efficiency(eta, eta_back) > 0.0 else "self-locking"
    connections = rig_connections(eta, eta_back)
    connectors, boundary = rig_boundary(components, connections)
    return System(
        name=name,
        components=components,
        connections=connections + boundary,
        connectors=connectors,
        parameters=rig_parameters(eta, parameters, fmus),
        units=units,
        parameter_set=parameter_set,
        experiment=DefaultExperiment(start_time, stop_time, step_size),
        description=f"Inverted-pendulum rig: current loop, cart on a {kind} lead screw (eta={eta!r}), pendulum",
    )
