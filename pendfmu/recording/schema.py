"""What a recording may contain: signal, parameter and state names (from the component
tables), the sidecar's keys, and the checks of single values, with their messages."""

from __future__ import annotations

import math
import numbers
from collections.abc import Callable, Mapping
from dataclasses import dataclass

from pendfmu.components import COMPONENTS, parameter_table
from pendfmu.errors import BadInput
from pendfmu.physics import CENTRE_OF_MASS_INERTIA
from pendfmu.ranges import outside
from pendfmu.recording.measurement import is_measurement, measurement_problem
from pendfmu.suggest import did_you_mean


def _signal_names() -> tuple[str, ...]:
    """Inputs and outputs of all components, in table order: the only column names."""
    names: dict[str, None] = {}
    for component in COMPONENTS.values():
        for var in component.variables:
            if var.causality in ("input", "output"):
                names[var.name] = None
    return tuple(names)


def _initial_names() -> tuple[str, ...]:
    """Signals whose initial value fixes a state: outputs that are states (x, v, phi, w)
    and outputs computed from one state alone (I, from the current loop's I_mean)."""
    names: dict[str, None] = {}
    for component in COMPONENTS.values():
        states = {v.name for v in component.states}
        for var in component.of(causality="output"):
            if var.state or (var.depends_on is not None and len(var.depends_on) == 1
                             and var.depends_on[0] in states):
                names[var.name] = None
    return tuple(names)


SIGNAL_NAMES: tuple[str, ...] = _signal_names()
"""Valid column names of a recording: the components' inputs and outputs."""


PARAMETER_NAMES: tuple[str, ...] = (*parameter_table(), CENTRE_OF_MASS_INERTIA.name)
"""Valid keys of the sidecar's ``parameters``: every parameter once (m_p and l are shared by
two), and J_cm, the pendulum's inertia about its centre of mass (physics.py)."""


INITIAL_NAMES: tuple[str, ...] = _initial_names()
"""Valid keys of the sidecar's ``initial``: signals that are (or follow one) state."""


@dataclass(frozen=True)
class Vocabulary:
    """The names a recording may use: its columns, the sidecar's parameters (with a check
    of each value) and its known initial states.

    The paper's rig (docs/user-guide/model.md) by default (:data:`RIG`); a fit of a user's
    model reads recordings with the model's names (``Model.vocabulary``).

    Attributes
    ----------
    signals : tuple of str
        The valid column names.
    parameter_problem : callable
        ``parameter_problem(name, value)``: why `value` cannot be parameter `name` in a
        sidecar (unknown, not finite, out of range), or None when it can.
    initial_problem : callable
        ``initial_problem(name, value)``: why `value` cannot be the known initial value of
        `name`, or None when it can.
    """

    signals: tuple[str, ...]
    parameter_problem: Callable[[str, float], str | None]
    initial_problem: Callable[[str, float], str | None]


QUANTIZERS: tuple[str, ...] = ("round", "floor")
"""How a reading is quantized: ``round`` is the paper's default, ``floor`` what a
counter that truncates reports."""


MAT_TIME_NAMES: tuple[str, ...] = ("time", "t", "tout")
"""Names under which a .mat file's time vector is recognised (``tout``: Simulink)."""


SIDECAR_KEYS: tuple[str, ...] = ("experiment", "signals", "parameters", "initial", "comment")


SIGNAL_INFO_KEYS: tuple[str, ...] = ("resolution", "quantizer", "noise", "missing", "ignore")


class RecordingError(BadInput):
    """A recording (or its sidecar) that cannot be used; the message says where and why."""


def _checked_values(values: Mapping[str, float], problem_of, src: str, what: str) -> dict[str, float]:
    """Constructor-side check of parameters/initial (the sidecar reader has its own, with JSON keys)."""
    out = {}
    for name, value in dict(values).items():
        try:
            number = float(value)
        except (TypeError, ValueError):
            raise RecordingError(f"{src}: {what}[{name!r}] must be a number, got {value!r}") from None
        problem = problem_of(name, number)
        if problem:
            raise RecordingError(f"{src}: {what}[{name!r}]: {problem}")
        out[name] = number
    return out


def _parameter_problem(name: str, value: float) -> str | None:
    """Why `value` cannot be parameter `name` (unknown, not finite, out of range), or None.
    m_p and l belong to two components with different ranges (the Cart takes m_p = 0,
    pendulum removed); a value is fine if one of them accepts it. A signal's measurement
    parameters (measurement.py: phi_offset, x_scale, input_delay) are valid too."""
    if is_measurement(name, SIGNAL_NAMES):
        return measurement_problem(name, value)
    if name not in PARAMETER_NAMES:
        return f"unknown parameter{did_you_mean(name, PARAMETER_NAMES)}; valid: {', '.join(PARAMETER_NAMES)}"
    if not math.isfinite(value):
        return f"must be finite, got {value!r}"
    return outside(name, value, [c.parameters[name] for c in COMPONENTS.values() if name in c.parameters] or
                   [CENTRE_OF_MASS_INERTIA])


def _initial_problem(name: str, value: float) -> str | None:
    """Why `value` cannot be the known initial value of `name`, or None."""
    if name not in INITIAL_NAMES:
        return f"not a state{did_you_mean(name, INITIAL_NAMES)}; valid: {', '.join(INITIAL_NAMES)}"
    if not math.isfinite(value):
        return f"must be finite, got {value!r}"
    return None


# The largest sensor noise or resolution a sidecar may state: the error model squares them
# (a signal's scale is sqrt(noise^2 + resolution^2/12)), and the square of more overflows a
# double. No sensor's step is anywhere near it; a larger value is a typo or a corrupted file.
LARGEST_ERROR = 1e150


def _noise_problem(noise: float | None) -> str | None:
    if noise is None:
        return None
    if not math.isfinite(noise) or noise < 0:
        return f"noise {noise!r} must be a finite standard deviation >= 0"
    if noise > LARGEST_ERROR:
        return f"noise {noise!r} is beyond any sensor's (at most {LARGEST_ERROR:g})"
    return None


def _missing_problem(missing) -> str | None:
    if missing is None or missing == "nan":
        return None
    if isinstance(missing, bool) or not isinstance(missing, numbers.Real) or not math.isfinite(missing):
        return f'missing must be "nan" or the finite number that marks a missing sample, got {missing!r}'
    return None


def _resolution_problem(resolution) -> str | None:
    if resolution is None:
        return None
    if isinstance(resolution, bool) or not isinstance(resolution, numbers.Real):
        return f"resolution must be a number, got {resolution!r}"
    if not (math.isfinite(resolution) and resolution > 0):
        return f"resolution must be a positive finite number, got {resolution!r}"
    if resolution > LARGEST_ERROR:
        return f"resolution {resolution!r} is beyond any sensor's step (at most {LARGEST_ERROR:g})"
    return None


def _quantizer_problem(quantizer) -> str | None:
    if quantizer not in QUANTIZERS:
        return f"quantizer must be one of {', '.join(QUANTIZERS)}, got {quantizer!r}"
    return None


def _bytes(size: int) -> str:
    """A file size for messages: bytes below 1 MB, else MB or GB."""
    if size < 1024**2:
        return f"{size} bytes"
    if size < 1024**3:
        return f"{size / 1024**2:.1f} MB"
    return f"{size / 1024**3:.2f} GB"


@dataclass(frozen=True)
class WithMeasurements:
    """A model's parameter check that also takes its signals' measurement parameters."""

    problem_of: Callable[[str, float], str | None]
    signals: tuple[str, ...]

    def __call__(self, name: str, value: float) -> str | None:
        if is_measurement(name, self.signals):
            return measurement_problem(name, value)
        return self.problem_of(name, value)


RIG = Vocabulary(SIGNAL_NAMES, _parameter_problem, _initial_problem)
"""The paper's names (docs/user-guide/model.md): the rig's signals, parameters and states."""
