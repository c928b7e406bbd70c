"""A free decay started at a turning point of its swing (the fit's start 'turning').

A pendulum released by hand starts from an angle nobody read and at an instant nobody
marked: the recording's first samples may still be held, or already swinging. At a
turning point of the swing the state is known far better: the rate is zero there, and the
angle is the extreme reading. `start='turning'` cuts each recording (window, segment) to
begin at the sample nearest its first turning point and estimates the angle there in the
box of that reading (experiment.reading_box).

The rate at that sample is not zero: the extreme falls between samples, and within half a
sample interval dt of it the rate is at most |alpha| dt / 2 (alpha the angular
acceleration at the extreme, from a parabola through the readings around it). The fit
estimates it in [-|alpha| dt, |alpha| dt] (twice that, for alpha's own error), starting
from the parabola's slope at the sample. It cannot be taken as known: a rate off by
|alpha| dt / 3 shifts the whole swing by a third of a sample, and the fit pays for that
phase with the friction. Measured on a reference-simulator decay (4096-count encoder,
1 ms, released from a hold at pi + 0.6): the rate fixed at the parabola's value (0.0057
against the true 0.0096 rad/s; the Coulomb friction's kink at the turning point bends the
parabola) gave T_Kp 64 % low and k_fwp 62 % high, far outside their intervals; the true
rate gave both within 1 %.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pendfmu.fitting.experiment import Experiment, StartState, signal_scale
from pendfmu.recording import Recording, RecordingError

REVERSAL = 10.0
"""Sensor error scales by which the readings must move back from an extreme before it counts
as a turning point: a reversal that noise and quantization cannot fake."""

TOP_BAND = 0.05
"""The readings within this fraction of the swing (from where the readings started to the
extreme) of the extreme make the parabola: on a sinusoid the top +-7 % of a period."""

MIN_SIDE = 5  # readings either side of the extreme the parabola needs at least


@dataclass(frozen=True)
class TurningPoint:
    """The first turning point of a recorded swing.

    Attributes
    ----------
    index : int
        The sample nearest the extreme, where the fit starts.
    extreme : float
        The time of the extreme (the parabola's vertex) [s].
    rate : float
        The rate at the sample `index`: the parabola's slope there.
    curvature : float
        The angular acceleration at the extreme: twice the parabola's leading coefficient.
    """

    index: int
    extreme: float
    rate: float
    curvature: float


def first_reversal(values: np.ndarray, reach: float) -> tuple[int, int] | None:
    """(index of the extreme, its direction +1 for a maximum) of the first reversal of
    `values`: they move more than `reach` one way from the first reading, reach an extreme
    and move back more than `reach`. A hand's release from rest is not one: the readings
    never approached it. None when the readings never reverse so."""
    finite = np.flatnonzero(np.isfinite(values))
    if not len(finite):
        return None
    first = values[finite[0]]
    direction, extreme = 0, int(finite[0])
    for i in finite:
        value = values[i]
        if direction == 0:
            if abs(value - first) > reach:
                direction, extreme = (1 if value > first else -1), int(i)
        elif direction * (value - values[extreme]) > 0:
            extreme = int(i)
        elif direction * (values[extreme] - value) > reach:
            return extreme, direction
    return None


def turning_point(time: np.ndarray, values: np.ndarray, reach: float) -> TurningPoint | None:
    """The first turning point of a swing recorded as `values` at `time`, or None; `reach`
    as first_reversal. The parabola takes the readings around the extreme that lie within
    TOP_BAND of the swing (at least `reach`) of it, and at least MIN_SIDE on either side."""
    found = first_reversal(values, reach)
    if found is None:
        return None
    extreme, direction = found
    first = values[np.flatnonzero(np.isfinite(values))[0]]
    band = max(reach, TOP_BAND * abs(values[extreme] - first))
    near = np.isfinite(values) & (direction * (values[extreme] - values) <= band)
    low = high = extreme
    while low > 0 and (near[low - 1] or extreme - low < MIN_SIDE):
        low -= 1
    while high < len(values) - 1 and (near[high + 1] or high - extreme < MIN_SIDE):
        high += 1
    chosen = np.flatnonzero(np.isfinite(values[low:high + 1])) + low
    tau = time[chosen] - time[extreme]
    c2, c1, _ = np.polyfit(tau, values[chosen], 2)
    if not direction * c2 < 0:
        return None
    vertex = float(time[extreme] - c1 / (2 * c2))
    index = int(chosen[np.argmin(np.abs(time[chosen] - vertex))])
    rate = float(c1 + 2 * c2 * (time[index] - time[extreme]))
    return TurningPoint(index, vertex, rate, float(2 * c2))


def from_turning_point(recording: Recording, column: str = "phi") -> tuple[Recording, TurningPoint]:
    """The recording from the sample nearest the first turning point of its `column` on,
    and that turning point. A recording without one is refused, naming it."""
    values = recording.signal(column)
    reach = REVERSAL * signal_scale(recording, column)
    found = turning_point(recording.time, values, reach)
    if found is None:
        raise RecordingError(f"{recording.source}: start 'turning': the recorded {column} never turns (it never moves "
                             f"back by more than {reach:.3g}, {REVERSAL:g} times its sensor's error, after an "
                             f"extreme); fit it from its first sample (leave out start)")
    part = recording.window(float(recording.time[found.index]), float(recording.time[-1]))
    return part, found


TURNING_RATE = StartState("w0", "phi", rate=True, turning=True)


def start_at_turning(experiment: Experiment, point: TurningPoint) -> Experiment:
    """The experiment of a recording cut at its turning point (from_turning_point), with
    its initial rate estimated in the box a turning point allows (module docstring)."""
    time = experiment.time
    interval = float(time[1] - time[0]) if len(time) > 1 else 0.0
    reach = max(abs(point.curvature) * interval, 2 * abs(point.rate), 1e-12)  # never an empty box
    experiment.estimated["w0"] = (point.rate, -reach, reach)
    experiment.read_from["w0"] = TURNING_RATE
    return experiment
