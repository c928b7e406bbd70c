"""Parameter files: JSON ``{"parameters": {"name": value, ...}}`` with the rig's names.

Names are those of the component tables (docs/reference/variables.md). A name that several
components share (m_p and l are in Cart and Pendulum) means the same physical quantity and
goes to all of them.
Absent names keep the FMU defaults. An unknown name, a value that is not a finite number,
or a value outside its physical range is a :class:`ParameterFileError` that names the
file, the parameter and what is allowed. The pendulum's inertia may be given about its
centre of mass, as J_cm (physics.py); values that break a rule between parameters
(physics.py: J_p below m_p l^2, an asymmetry above its mean) are refused before any work.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Mapping
from pathlib import Path

from pendfmu import physics
from pendfmu.atomic import write_atomically
from pendfmu.components import COMPONENTS, parameter_table, rig_defaults
from pendfmu.errors import BadInput
from pendfmu.jsontext import parse_json
from pendfmu.ranges import outside
from pendfmu.recording.measurement import is_measurement, measurement_problem
from pendfmu.recording.schema import SIGNAL_NAMES
from pendfmu.suggest import did_you_mean

# Initial states set through the sidecar's "initial" block (signal name -> parameter).
INITIAL_STATE_PARAMETERS = {"x": "x0", "v": "v0", "phi": "phi0", "w": "w0", "I": "I0", "I_mean": "I0"}


class ParameterFileError(BadInput):
    """Bad parameter input: reported to the user in one line (exit code 2)."""


def parameter_owners(name: str) -> list[str]:
    return [c.name for c in COMPONENTS.values() if name in c.parameters]


def check_value(name: str, value: object, where: str = "") -> float:
    """The value as a float, or a ParameterFileError naming the parameter and its range."""
    prefix = f"{where}: " if where else ""
    known = parameter_table()
    if name == physics.J_CM:  # the pendulum's inertia about its centre of mass: becomes J_p
        known = {**known, name: physics.CENTRE_OF_MASS_INERTIA}
    if name not in known and is_measurement(name, SIGNAL_NAMES):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ParameterFileError(f"{prefix}parameter {name} = {value!r} is not a number")
        problem = measurement_problem(name, float(value))
        if problem:
            raise ParameterFileError(f"{prefix}parameter {name} = {value!r}: {problem}")
        return float(value)
    if name not in known:
        raise ParameterFileError(f"{prefix}unknown parameter {name!r}{did_you_mean(name, known)}; valid names: "
                                 f"{', '.join(sorted(known))}")
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ParameterFileError(f"{prefix}parameter {name} = {value!r} is not a number")
    value = float(value)
    if not math.isfinite(value):
        raise ParameterFileError(f"{prefix}parameter {name} = {value} is not finite")
    # A shared name is valid when one of its components takes it: m_p = 0 is a cart with
    # the pendulum removed, although a Pendulum cannot have zero mass (it then must not run).
    problem = outside(name, value, [COMPONENTS[c].parameters[name] for c in parameter_owners(name)] or
                      [known[name]])
    if problem:
        raise ParameterFileError(f"{prefix}parameter {problem}")
    return value


def check_parameters(values: Mapping[str, object], where: str = "") -> dict[str, float]:
    """Each value checked (check_value), and the rules between parameters among those one
    source gives (physics.own_problems): a file with m_p, l and a J_p below m_p l^2 is
    refused naming that file."""
    checked = {name: check_value(name, value, where) for name, value in values.items()}
    broken = physics.own_problems(checked)
    if broken:
        raise physics.PhysicsError(f"{where + ': ' if where else ''}{broken[0]}")
    return checked


def rig_values(params: Mapping[str, object] | None, where: str = "") -> dict[str, float]:
    """The reference rig's values with `params` (checked) over them: a fit's known values
    before each recording's sidecar (recording_values). J_cm stays as given: it becomes J_p
    with each recording's m_p and l."""
    return physics.overlay(rig_defaults(), check_parameters(params or {}, where), where)


def recording_values(values: Mapping[str, float], recording) -> dict[str, float]:
    """The values one recording runs with: `values`, then what its sidecar fixes, then its
    known initial states; J_cm converted to J_p and every rule between parameters checked
    (physics.settled), so that an impossible rig is refused before any simulation."""
    where = str(recording.path)
    fixed = physics.overlay(values, check_parameters(recording.parameters, where), where)
    return physics.settled(with_initial_states(fixed, recording.initial, where), where)


def read_parameters(path: str | Path, check: Callable[[Mapping[str, object], str], dict[str, float]] | None = None
                    ) -> dict[str, float]:
    """The checked parameter values of a parameters file: checked against the
    parameter table (docs/reference/variables.md), or by `check(values, file)` (a user's model
    checks its own names)."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as error:
        raise ParameterFileError(f"{path}: cannot read parameters file ({error.strerror})") from None
    try:
        document = parse_json(text)
    except json.JSONDecodeError as error:
        raise ParameterFileError(f"{path}: not valid JSON (line {error.lineno}, column {error.colno}: {error.msg})") from None
    if not isinstance(document, dict) or not isinstance(document.get("parameters"), dict):
        raise ParameterFileError(f'{path}: expected an object {{"parameters": {{"name": value, ...}}}}')
    return (check or check_parameters)(document["parameters"], str(path))


def write_parameters(values: Mapping[str, float], path: str | Path, **extra: object) -> None:
    document = {"parameters": dict(values), **extra}
    write_atomically(path, json.dumps(document, indent=2) + "\n")


def with_initial_states(values: Mapping[str, float], initial: Mapping[str, float], where: str = "") -> dict[str, float]:
    """Override initial-state parameters (x0, v0, phi0, w0, I0) by a sidecar's "initial"."""
    result = dict(values)
    for signal, value in initial.items():
        if signal not in INITIAL_STATE_PARAMETERS:
            raise ParameterFileError(f"{where}: unknown initial state {signal!r}{did_you_mean(signal, INITIAL_STATE_PARAMETERS)}; valid: "
                                     f"{', '.join(INITIAL_STATE_PARAMETERS)}")
        name = INITIAL_STATE_PARAMETERS[signal]
        result[name] = check_value(name, value, where)
    return result
