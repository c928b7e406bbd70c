"""Parameter files: JSON ``{"parameters": {"name": value, ...}}`` with MODEL.md names.

Names are those of the component tables. A name that several components share (m_p and l
are in Cart and Pendulum) means the same physical quantity and goes to all of them.
Absent names keep the FMU defaults. An unknown name, a value that is not a finite number,
or a value outside its physical range is a :class:`ParameterFileError` that names the
file, the parameter and what is allowed.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Mapping
from pathlib import Path

from pendfmu.components import COMPONENTS, parameter_table
from pendfmu.errors import BadInput
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
    problem = outside(name, value, [COMPONENTS[c].parameters[name] for c in parameter_owners(name)])
    if problem:
        raise ParameterFileError(f"{prefix}parameter {problem}")
    return value


def check_parameters(values: Mapping[str, object], where: str = "") -> dict[str, float]:
    return {name: check_value(name, value, where) for name, value in values.items()}


def read_parameters(path: str | Path, check: Callable[[Mapping[str, object], str], dict[str, float]] | None = None
                    ) -> dict[str, float]:
    """The checked parameter values of a parameters file: checked against MODEL.md's
    table, or by `check(values, file)` (a user's model checks its own names)."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as error:
        raise ParameterFileError(f"{path}: cannot read parameters file ({error.strerror})") from None
    try:
        document = json.loads(text)
    except json.JSONDecodeError as error:
        raise ParameterFileError(f"{path}: not valid JSON (line {error.lineno}, column {error.colno}: {error.msg})") from None
    if not isinstance(document, dict) or not isinstance(document.get("parameters"), dict):
        raise ParameterFileError(f'{path}: expected an object {{"parameters": {{"name": value, ...}}}}')
    return (check or check_parameters)(document["parameters"], str(path))


def write_parameters(values: Mapping[str, float], path: str | Path, **extra: object) -> None:
    document = {"parameters": dict(values), **extra}
    Path(path).write_text(json.dumps(document, indent=2) + "\n")


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
