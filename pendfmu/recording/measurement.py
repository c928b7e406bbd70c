"""How a recording relates to the model's signals, beyond the sensor's noise and step:
parameters of the measurement, not of the model.

Real sensors and drives are rarely exactly where the model puts them: an angle encoder's
zero sits half a degree off, a counts-per-unit factor is 1 % wrong, a command reaches the
motor a few tens of milliseconds after it was logged. Those are three parameters per
fit, named after the signal they belong to, fixed at "no effect" unless given or freed:

    <signal>_offset   the reading at a true zero, in the signal's unit   (default 0)
    <signal>_scale    readings per true unit, > 0                        (default 1)
    input_delay       how long the recorded drives take to act, >= 0 s   (default 0)

A recorded column is compared with ``scale * simulated + offset``; the model's drives at
time t are the recorded ones at t - input_delay. They can be given in a sidecar's
"parameters" (a known calibration) or in --params, and fitted with --free like any other.
None of them reaches an FMU.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

INPUT_DELAY = "input_delay"
_SUFFIXES = {"_offset": 0.0, "_scale": 1.0}


def measurement_signal(name: str) -> tuple[str, str] | None:
    """(kind, signal) of a measurement parameter name: ("offset", "phi") for phi_offset,
    ("delay", "") for input_delay; None for any other name."""
    if name == INPUT_DELAY:
        return "delay", ""
    for suffix in _SUFFIXES:
        if name.endswith(suffix) and len(name) > len(suffix):
            return suffix[1:], name[: -len(suffix)]
    return None


def is_measurement(name: str, signals) -> bool:
    """Whether `name` is a measurement parameter of one of `signals` (or the input delay)."""
    found = measurement_signal(name)
    return found is not None and (found[0] == "delay" or found[1] in signals)


def no_effect(name: str) -> float:
    """The value at which a measurement parameter changes nothing: offset 0, scale 1, delay 0."""
    kind = measurement_signal(name)[0]
    return 1.0 if kind == "scale" else 0.0


def measurement_problem(name: str, value: float) -> str | None:
    """Why `value` cannot be measurement parameter `name`, or None."""
    if not math.isfinite(value):
        return f"must be finite, got {value!r}"
    kind = measurement_signal(name)[0]
    if kind == "scale" and not value > 0:
        return f"a scale is readings per true unit and must be > 0, got {value!r}"
    if kind == "delay" and value < 0:
        return f"a delay must be >= 0 s, got {value!r}"
    return None


def sensed(column: str, simulated: np.ndarray, values: Mapping[str, float]) -> np.ndarray:
    """What the sensor of `column` reads when the model's signal is `simulated`."""
    scale = values.get(f"{column}_scale", 1.0)
    offset = values.get(f"{column}_offset", 0.0)
    if scale == 1.0 and offset == 0.0:
        return simulated
    return scale * simulated + offset


def default_box(name: str, recording) -> tuple[float, float, bool]:
    """The search box of a measurement parameter that --bounds does not give, from the
    recording: an offset within a tenth of its signal's range either way, a scale within
    20 %, a delay up to ten sample intervals. (low, high, logarithmic)."""
    kind, column = measurement_signal(name)
    times = recording.time
    recorded = recording.signals.get(column)
    if kind == "delay":
        step = float(np.median(np.diff(times))) if len(times) > 1 else 0.0
        return 0.0, 10.0 * step, False
    if kind == "scale":
        return 0.8, 1.25, False
    finite = recorded[np.isfinite(recorded)] if recorded is not None else np.zeros(1)
    reach = 0.1 * float(np.ptp(finite)) if len(finite) else 0.0
    reach = reach or 1.0
    return -reach, reach, False
