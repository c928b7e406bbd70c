"""Experiments: a recording seen by a fit, with the model that replays it.

An :class:`Experiment` gathers what a fit needs from one recording: the model to simulate
(simulator/model.py), which of its inputs the recording drives and how (held or linear
between samples), which of its outputs are compared with which recorded column (each with
its sensor's error scale), the parameter values fixed for this recording (the given
values, then the sidecar's "parameters", then its "initial" states), and the initial
states the recording does not know, which the fit estimates.

The paper's stages are presets of this (stages.py): the same mechanism with pendfmu's own
components, the drives and matches the paper uses, and the free parameters it names. A
user's FMU or SSP system is the same thing with the names the user gives.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from pendfmu.recording import Recording, RecordingError
from pendfmu.simulator.model import Model
from pendfmu.simulator.replay import Drive, InstancePool, Refinement, Replay


@dataclass(frozen=True)
class Setup:
    """What a fit does with one recording, before its values are known: the model, the
    drives (model input -> (column, interpolation)), the matches (model output ->
    column), the initial states to estimate where the recording does not state them
    (column of the state -> the model's parameter for its initial value), and the
    cheaper model of the global search (every k-th sample, a longer internal step).
    `measured_initial`: initial states that a recording which holds their own column
    (a tachometer's w) tells by its first reading, estimated in that reading's box unless
    the sidecar states them."""

    name: str
    model: Model
    drives: Mapping[str, tuple[str, str]]
    match: Mapping[str, str]
    estimated_initial: Mapping[str, str] = field(default_factory=dict)
    refine: Refinement | None = None
    coarse_decimate: int = 1
    coarse_values: Mapping[str, float] = field(default_factory=dict)
    starts: tuple[StartState, ...] = ()  # every initial state the recordings can tell (estimated on request)
    measured_initial: Mapping[str, str] = field(default_factory=dict)  # recorded state column -> its parameter
    # initial-state parameter -> the model output that is its state, for states no recorded
    # column tells (a cart's v0 where only x is recorded): a window that starts late cannot
    # estimate them (problem.py warns; validation.py starts a late half with the fit's own)
    unseen: Mapping[str, str] = field(default_factory=dict)


@dataclass(frozen=True)
class StartState:
    """An initial-state parameter and the recorded column that tells it: its first
    reading (x0 from x), or, with `rate`, its slope at the start (v0 from x); with
    `turning`, the rate at a turning point of the column (turning.py)."""

    parameter: str
    column: str
    rate: bool = False
    turning: bool = False

    @property
    def source(self) -> str:
        """What tells it, as provenance writes it: x, x' (its slope), phi' at its turning point."""
        return self.column + ("'" if self.rate else "") + (" at its turning point" if self.turning else "")


START_SAMPLES = 20
"""Samples of the quadratic through a recording's first readings that gives a measured or
guessed initial rate (the EMPS benchmark's state initialization window)."""


def start_of(recording: Recording, state: StartState) -> tuple[float, float, float]:
    """(value, low, high) of an initial state from the recording's first readings: a
    state read directly (x0 from x, w0 from a recorded w) is the first reading, within
    what its sensor allows (reading_box); a rate the slope of a quadratic through the
    first START_SAMPLES readings (or a twentieth of a short recording, at least five: a
    segment's speed may reverse soon), within ten times that slope's standard error (the
    sensor's error scale through the least squares), a quarter of its size, or one step
    per window, whichever is widest."""
    values = recording.signal(state.column)
    present = np.flatnonzero(np.isfinite(values))
    if not len(present):
        raise RecordingError(f"{recording.source}: no reading of {state.column!r} to tell the initial {state.parameter}")
    if not state.rate:
        return reading_box(recording, state.column, int(present[0]))
    step = recording.resolution(state.column) or signal_scale(recording, state.column)
    chosen = present[:max(5, min(START_SAMPLES, len(present) // 20))]  # a twentieth of a short segment
    if len(chosen) < 3:
        raise RecordingError(f"{recording.source}: too few readings of {state.column!r} to tell the initial "
                             f"{state.parameter}")
    t = recording.time[chosen] - recording.time[0]
    design = np.column_stack([np.ones_like(t), t, t**2])
    coefficients, *_ = np.linalg.lstsq(design, values[chosen], rcond=None)
    slope = float(coefficients[1])
    standard_error = signal_scale(recording, state.column) * math.sqrt(np.linalg.inv(design.T @ design)[1, 1])
    reach = max(10 * standard_error, 0.25 * abs(slope), step / max(float(t[-1]), 1e-12))
    return slope, slope - reach, slope + reach


NOISE_REACH = 4.0
"""Standard deviations of a sensor's noise by which a true value may lie beyond the
quantization step of its reading (4: once in 16,000 readings)."""


def reading_box(recording: Recording, column: str, index: int = 0) -> tuple[float, float, float]:
    """(reading, low, high): the true values a sensor could have read as the reading of
    `column` at sample `index`, as the sidecar describes the sensor. A quantized reading
    stands for its step (round: half a step either side; floor: the step above it), and
    noise widens that by NOISE_REACH standard deviations; a sensor of unstated resolution
    and noise has the noise the fit estimates from the data (signal_scale).

    This is the box of an initial state read off a recording (the release angle, the
    first reading of a tachometer): the fit cannot move it further than the sensor could
    have erred, so a start at its edge says that the model wants a start the sensor
    rules out (fitting/edges.py says why)."""
    reading = float(recording.signal(column)[index])
    info = recording.signal_info.get(column)
    resolution = info.resolution if info and info.resolution else 0.0
    noise = info.noise if info and info.noise else 0.0
    if not (resolution or noise):
        noise = signal_scale(recording, column)
    low, high = (0.0, resolution) if recording.quantizer(column) == "floor" else (-resolution / 2, resolution / 2)
    return reading, reading + low - NOISE_REACH * noise, reading + high + NOISE_REACH * noise


def signal_scale(recording: Recording, name: str) -> float:
    """The standard deviation of a recorded signal's error: sensor noise and the
    quantization step (uniform error, variance delta^2/12), or, when the sidecar states
    neither, the spread of the signal's sample-to-sample differences (a robust noise
    floor)."""
    info = recording.signal_info.get(name)
    noise = info.noise if info and info.noise else 0.0
    resolution = info.resolution if info and info.resolution else 0.0
    if noise or resolution:
        return math.sqrt(noise**2 + resolution**2 / 12.0)
    values = recording.signal(name)
    values = values[np.isfinite(values)]  # missing samples (NaN) aside
    differences = np.diff(values)
    spread = 1.4826 * np.median(np.abs(differences - np.median(differences))) / math.sqrt(2) if len(differences) else 0.0
    fallback = 1e-6 * max(np.ptp(values) if len(values) else 0.0, 1e-12)
    return float(max(spread, fallback))


@dataclass
class Experiment:
    """One recording prepared for a fit."""

    recording: Recording
    setup: Setup
    fixed: dict[str, float]  # known parameter values for this recording
    estimated: dict[str, tuple[float, float, float]] = field(default_factory=dict)  # name -> (guess, low, high)
    scales: dict[str, float] = field(default_factory=dict)  # recorded column -> error scale
    read_from: dict[str, StartState] = field(default_factory=dict)  # an estimated initial state -> what told its box

    @property
    def name(self) -> str:
        return self.recording.label

    @property
    def time(self) -> np.ndarray:
        return self.recording.time

    @property
    def model(self) -> Model:
        return self.setup.model

    @property
    def match(self) -> Mapping[str, str]:
        return self.setup.match

    def recorded(self, column: str) -> np.ndarray:
        return self.recording.signal(column)

    def replay(self, decimate: int = 1, pool: InstancePool | None = None, copy: int = 0) -> Replay:
        """A simulator of this recording (every `decimate`-th sample); `pool` and `copy` as
        for Replay."""
        drives = {name: Drive(self.recording.signal(column), interpolation)
                  for name, (column, interpolation) in self.setup.drives.items()}
        return Replay(self.model, self.time, drives, decimate, self.setup.refine, pool, copy)


def through_sensor(experiment: Experiment, name: str, low: float, high: float, free: Mapping[str, object]
                   ) -> tuple[float, float]:
    """An initial state's box (read off its recording) widened to hold every true value
    that the free offset and scale of its sensor could have read so (measurement.py:
    reading = scale * true + offset): with the sensor's zero or gain unknown, the first
    reading says less. `free` maps the fit's shared free parameters to objects with
    .low and .high."""
    state = next((s for s in experiment.setup.starts if s.parameter == name), None)
    if state is None:
        return low, high
    offset, scale = free.get(f"{state.column}_offset"), free.get(f"{state.column}_scale")
    if offset is None and scale is None:
        return low, high
    offsets = (offset.low, offset.high) if offset is not None and not state.rate else (0.0, 0.0)
    scales = (scale.low, scale.high) if scale is not None else (1.0, 1.0)
    candidates = [(edge - o) / s for edge in (low, high) for o in offsets for s in scales]
    return min(candidates), max(candidates)


START_CHOICES = ("estimated", "measured")


def starts_of(setup: Setup, recording: Recording) -> dict[str, StartState]:
    """Each initial state the recording can tell, by what tells it best: the first of the
    setup's starts whose column the recording holds (a recorded w before the slope of phi)."""
    found: dict[str, StartState] = {}
    for state in setup.starts:
        if state.column in recording.signals:
            found.setdefault(state.parameter, state)
    return found


def prepare(recording: Recording, setup: Setup, fixed: Mapping[str, float], per_recording: Sequence[str] = (),
            start: str = "estimated") -> Experiment:
    """The experiment of one recording: `fixed` are its known values (given, sidecar and
    initial states merged by the caller).

    Estimated for this recording alone: the setup's initial states the recording does
    not state (the pendulum's release angle), those it records in a column of their own
    (a tachometer's w: measured_initial), every initial state it can tell when it is
    a window that starts after its file's first sample (a segment of a long run; with
    `start` "measured" these are taken from its first readings instead), and the
    parameters named in `per_recording`. An initial state's box comes from the data
    (start_of); any other parameter's box is the fit's (guess and box None here)."""
    where = str(recording.path)
    if start not in START_CHOICES:
        raise RecordingError(f"start must be one of {', '.join(START_CHOICES)}, not {start!r}")
    for column in (*setup.match.values(), *(c for c, _ in setup.drives.values())):
        if column not in recording.signals:
            raise RecordingError(f"{where}: {setup.name} needs the recorded signal {column!r}; "
                                 f"columns: {', '.join(('time', *recording.signals))}")
    for column, _ in setup.drives.values():
        gaps = np.flatnonzero(~np.isfinite(recording.signal(column)))
        if len(gaps):
            raise RecordingError(f"{where}: column {column!r} drives {setup.name} and has {len(gaps)} missing samples "
                                 f"(the first at t = {recording.time[gaps[0]]:g} s): a drive must be complete; "
                                 f"fit the windows between the gaps")
    experiment = Experiment(recording, setup, dict(fixed))
    starts = starts_of(setup, recording)
    stated = {setup.estimated_initial.get(column, column) for column in recording.initial}
    late = starts_late(recording)
    wanted = [p for c, p in setup.estimated_initial.items() if c not in recording.initial]
    wanted += [p for c, p in setup.measured_initial.items() if c in recording.signals and c not in recording.initial]
    if late:
        wanted += [p for p in starts if p not in stated]
    wanted += list(per_recording)
    for name in dict.fromkeys(wanted):
        if name in starts:
            value, low, high = start_of(recording, starts[name])
            if late and start == "measured" and name not in per_recording:
                experiment.fixed[name] = value
            else:
                experiment.estimated[name] = (value, low, high)
                experiment.read_from[name] = starts[name]
        else:
            experiment.estimated[name] = (fixed.get(name), None, None)  # the fit's box
    for column in setup.match.values():
        experiment.scales[column] = signal_scale(recording, column)
    return experiment


def starts_late(recording: Recording) -> bool:
    """A window or segment after its file's first sample: its sidecar's "initial" values,
    which belong to that sample, do not hold for it (Recording.window)."""
    return recording.span is not None and not recording.initial


def unseen_at_a_late_start(experiment: Experiment, fitted: Collection[str] = ()) -> list[str]:
    """A warning per initial state that a late window keeps from its file's first sample
    because nothing recorded tells it and it is not `fitted` (Setup.unseen: a cart's v0
    with only x recorded): the window would start the model at the file's start speed,
    whatever the speed is at the window's start."""
    recording = experiment.recording
    if not starts_late(recording):
        return []
    return [f"{recording.label}: starts after its file's first sample, and no recorded column tells the model's "
            f"initial {parameter} (the start of its output {output}): it keeps {experiment.fixed.get(parameter, 0.0):g}, "
            f"a value for the file's first sample; say which column's slope tells it (--initial COLUMN'={parameter}), "
            f"or fit it per recording (--per-recording {parameter}, with --bounds {parameter}=LOW:HIGH)"
            for parameter, output in experiment.setup.unseen.items()
            if parameter not in experiment.estimated and parameter not in recording.parameters
            and parameter not in fitted]

