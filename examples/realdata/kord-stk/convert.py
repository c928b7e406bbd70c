"""kord-stk: a locked-rotor DC motor's current after an open-loop voltage step, converted
to a pendfmu current-stage recording.

``LaTest.CSV`` is an oscilloscope capture over a 0.05 ohm shunt. Electrically an R-L
circuit, ``I(t) = I_final (1 - exp(-(t - t0) R/L))``: in the CurrentLoop model a step of
``I_c`` with ``T_i = L/R`` and a slope limit that never binds. The step time and level are
not recorded (there is no command channel), so they are estimated from the current itself
(:func:`first_step_estimate`); ``tests/realdata.py`` refines them by a profile over
pendfmu fits, the example uses the plain statistics, as a user without that profile would.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from scipy.stats import trim_mean

from pendfmu.recording import Recording, RecordingError, SignalInfo, quantize

from _common import REALDATA

KORD_CSV = REALDATA / "kord-stk" / "LaTest.CSV"
SHUNT_OHM = 0.05  # LaPlot.m: I = V / 0.05
SCOPE_LSB_V = 3.125e-3  # Agilent 54621D, 8 bits on the chosen range (the file's values are multiples of it)
CURRENT_LSB = SCOPE_LSB_V / SHUNT_OHM  # 62.5 mA: the current's quantization step
PUBLISHED_L = 1.56e-4  # H, "commented out" in the project report
PUBLISHED_R = 0.8  # ohm
PUBLISHED_L_OVER_R = PUBLISHED_L / PUBLISHED_R  # 1.95e-4 s
NEVER_BINDING_SLOPE = 1e7  # A/s: with T_i ~ 1e-4 s the slope limit would bind only for steps > 1000 A

# An R-L step is the lag alone. The file has isolated spikes (one or two samples of up to
# +-2 A, pickup from the switching) that are not part of the current; a 9-sample running
# median (22.5 us, a few percent of the time constant) removes them for the *estimates*
# of levels and times. The fit itself sees every raw sample.
DESPIKE = 9


@dataclass(frozen=True)
class ScopeTrace:
    path: Path
    time: np.ndarray  # s, the scope's own time stamps
    current: np.ndarray  # A, shunt voltage / SHUNT_OHM


def read_scope_csv(path: Path = KORD_CSV) -> ScopeTrace:
    """The scope's "CSV": two header lines ("x-axis 1" and "second Volt"), then time and
    shunt voltage, separated by blanks (commas are accepted too). The units line is
    checked so that a different export (other units, other channel) fails here rather
    than producing a wrong time constant."""
    with open(path, encoding="ascii") as f:
        lines = [line.replace(",", " ") for line in f]
    if lines[1].split() != ["second", "Volt"]:
        raise RecordingError(f"{path}: expected the units line 'second Volt', got {lines[1].strip()!r}")
    data = np.loadtxt(lines[2:], ndmin=2)
    if data.shape[1] != 2:
        raise RecordingError(f"{path}: expected 2 columns (time, volts), got {data.shape[1]}")
    return ScopeTrace(Path(path), data[:, 0].copy(), data[:, 1] / SHUNT_OHM)


@dataclass(frozen=True)
class StepEstimate:
    """The unrecorded command of the step: current before it, level after it, and when."""

    baseline: float  # A, the current before the step (the scope's offset: no current flows)
    level: float  # A, the final current I_final
    t0: float  # s, the instant of the voltage step
    noise: float  # A, standard deviation of the reading before the step (robust)


def first_step_estimate(trace: ScopeTrace) -> StepEstimate:
    """Levels and step time from plain statistics, before any fit.

    * baseline: the mean of the samples before the step, trimmed 10 % each side (sub-LSB
      resolution like a mean, but the spikes do not pull it);
    * level: the same trimmed mean over the last 40 % of the record, where the current
      has settled (checked: the despiked current stays within 5 % of the step there; the
      rest of the record still creeps up by ~2 %, one reason the rise is not exactly one
      exponential);
    * t0: the last sample before the half-way crossing at which the despiked current is
      still inside the baseline noise band (baseline + 3 sigma, sigma from the median
      absolute deviation of the pre-step samples): where the current leaves the noise.

    The pre-step samples are those before 80 % of the time from the record's start to the
    half-way crossing, so that the rise itself never enters the baseline.
    """
    from scipy.signal import medfilt  # here, not at the top: a run that stops at a missing file imports no scipy.signal

    time, current = trace.time, trace.current
    smooth = medfilt(current, DESPIKE)
    n = len(time)
    rough_low, rough_high = np.median(current[: n // 10]), np.median(current[-n // 10:])
    half = int(np.argmax(smooth > 0.5 * (rough_low + rough_high)))
    if half == 0 or rough_high - rough_low < 10 * CURRENT_LSB:
        raise RecordingError(f"{trace.path}: no step of the current found")
    pre = current[: int(0.8 * half)]
    baseline = float(trim_mean(pre, 0.1))
    noise = float(1.4826 * np.median(np.abs(pre - np.median(pre))))
    noise = max(noise, CURRENT_LSB / math.sqrt(12))  # never below the quantization's own spread
    tail = current[int(0.6 * n):]
    level = float(trim_mean(tail, 0.1))
    if np.any(np.abs(smooth[int(0.6 * n):] - level) > 0.05 * abs(level - baseline)):
        raise RecordingError(f"{trace.path}: the current has not settled in the last 40 % of the record")
    inside = np.nonzero(smooth[:half] <= baseline + 3 * noise)[0]
    t0 = float(time[inside[-1]]) if len(inside) else float(time[0])
    return StepEstimate(baseline, level, t0, noise)


def step_command(time: np.ndarray, step: StepEstimate) -> np.ndarray:
    """I_c for a step at `step.t0`, which may fall between samples.

    The current stage holds I_c constant from one sample to the next. The sample whose
    hold interval contains t0 gets the fraction of the step that the interval holds after
    t0, so the command carries the same charge as a true step at t0; after that interval
    the response differs from the true one by f(1-f)(dt/T_i)^2/2 relative, below 1e-5
    here. This makes the cost a smooth function of t0 instead of a staircase."""
    command = np.where(time >= step.t0, step.level, step.baseline).astype(float)
    k = int(np.searchsorted(time, step.t0))  # first sample at or after t0
    if 0 < k < len(time):
        fraction = (time[k] - step.t0) / (time[k] - time[k - 1])
        command[k - 1] = step.baseline + (step.level - step.baseline) * fraction
    return command


def current_step_recording(trace: ScopeTrace, step: StepEstimate) -> Recording:
    """The trace as a current-stage Recording: the raw current I (every sample, spikes
    included: the fit is an honest least-squares fit to what the scope recorded), the
    reconstructed command I_c, the scope's quantization as I's resolution, the pre-step
    noise as its noise, and the current before the step as the initial state."""
    return Recording(
        trace.path, trace.time, {"I_c": step_command(trace.time, step), "I": trace.current},
        experiment="locked-rotor voltage step (R-L), command reconstructed",
        signal_info={"I": SignalInfo(CURRENT_LSB, "round", step.noise)},
        initial={"I": step.baseline})



STAGE = "current"
SOURCES = (KORD_CSV,)
OPTIONS = ("--fix", "dIdt_max")  # an R-L circuit has no slope limit: keep it out of the fit
RUN_OPTIONS = ("--uncertainty", "jacobian")  # one free parameter: the fast intervals suffice


def build() -> tuple[list[Recording], dict[str, float]]:
    """The R-L step with the command from plain statistics (:func:`first_step_estimate`):
    what a user can build without pendfmu's profile over the step's time and level.

    The current is put back on the scope's 62.5 mA grid: the export scales the readings
    by 1 + 1.5e-8 (+206.250003E-03 V for 66 LSB), up to 1.3e-6 LSB off the grid, and
    pendfmu's plausibility check then warns that the stated resolution is too coarse.
    Anything further off the grid is not the export's scaling but a different file: an
    error."""
    trace = read_scope_csv()
    recording = current_step_recording(trace, first_step_estimate(trace))
    current = recording.signal("I")
    snapped = quantize(current, CURRENT_LSB)
    if np.max(np.abs(snapped - current)) > 1e-5 * CURRENT_LSB:
        raise RecordingError(f"{trace.path}: the current is not on the scope's {CURRENT_LSB} A grid")
    return [replace(recording, signals={**recording.signals, "I": snapped})], {"dIdt_max": NEVER_BINDING_SLOPE}
