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
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

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
    cheaper model of the global search (every k-th sample, a longer internal step)."""

    name: str
    model: Model
    drives: Mapping[str, tuple[str, str]]
    match: Mapping[str, str]
    estimated_initial: Mapping[str, str] = field(default_factory=dict)
    refine: Refinement | None = None
    coarse_decimate: int = 1
    coarse_values: Mapping[str, float] = field(default_factory=dict)


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
    differences = np.diff(recording.signal(name))
    spread = 1.4826 * np.median(np.abs(differences - np.median(differences))) / math.sqrt(2)
    fallback = 1e-6 * max(np.ptp(recording.signal(name)), 1e-12)
    return float(max(spread, fallback))


@dataclass
class Experiment:
    """One recording prepared for a fit."""

    recording: Recording
    setup: Setup
    fixed: dict[str, float]  # known parameter values for this recording
    estimated: dict[str, tuple[float, float, float]] = field(default_factory=dict)  # name -> (guess, low, high)
    scales: dict[str, float] = field(default_factory=dict)  # recorded column -> error scale

    @property
    def name(self) -> str:
        path = self.recording.path
        return Path(path).stem if path else "recording"

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


def prepare(recording: Recording, setup: Setup, fixed: Mapping[str, float]) -> Experiment:
    """The experiment of one recording: `fixed` are its known values (given, sidecar and
    initial states merged by the caller); initial states it does not state are estimated
    in a box of +-2 sensor steps around the first reading."""
    where = str(recording.path)
    for column in (*setup.match.values(), *(c for c, _ in setup.drives.values())):
        if column not in recording.signals:
            raise RecordingError(f"{where}: {setup.name} needs the recorded signal {column!r}; "
                                 f"columns: {', '.join(('time', *recording.signals))}")
    experiment = Experiment(recording, setup, dict(fixed))
    for column, parameter in setup.estimated_initial.items():
        if column not in recording.initial:
            first = float(recording.signal(column)[0])
            step = recording.resolution(column) or signal_scale(recording, column)
            experiment.estimated[parameter] = (first, first - 2 * step, first + 2 * step)
    for column in setup.match.values():
        experiment.scales[column] = signal_scale(recording, column)
    return experiment
