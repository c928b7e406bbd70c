"""Experiments: a recording seen by one identification stage.

The paper identifies the rig block by block; each stage simulates only the FMUs it needs
and compares them with the signals the block's sensor recorded:

    current   CurrentLoop driven by the recorded I_c          -> fitted to I
    cart      CurrentLoop -> Cart driven by I_c (or Cart driven
              by the recorded I, ``drive="I"``)                -> fitted to x
    pendulum  Pendulum driven by the recorded cart acceleration
              a (or a still cart)                              -> fitted to phi

An :class:`Experiment` gathers what a stage needs from one recording: the drive signal,
the fitted signals with their sensor scales, the parameter values fixed for this
recording (the parameters file, then the sidecar's "parameters", then its "initial"
states), and the initial states the recording does not know, which the fit estimates.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pendfmu.parameters import INITIAL_STATE_PARAMETERS, check_parameters, with_initial_states
from pendfmu.recording import Recording, RecordingError


@dataclass(frozen=True)
class Stage:
    name: str
    component: str  # the FMU whose parameters are fitted
    fitted: tuple[str, ...]  # recorded signals compared with the simulation
    default_free: tuple[str, ...]
    drives: tuple[str, ...]  # acceptable drive signals, preferred first ("" = none)
    estimated_initial: tuple[str, ...] = ()  # initial states estimated when a recording does not state them
    # The global search's cheaper model: every k-th sample, and a longer internal step.
    # Only where the drive is slow: the cart's drive current carries the PWM ripple, which
    # a coarser sampling would alias.
    coarse_decimate: int = 1
    coarse_solver_step: float | None = None


STAGES: dict[str, Stage] = {
    "current": Stage("current", "CurrentLoop", ("I",), ("T_i", "dIdt_max"), ("I_c",)),
    "cart": Stage("cart", "Cart", ("x",), ("eta", "k_fwc", "F_Kc", "F_Sc"), ("I_c", "I"),
                  coarse_solver_step=4e-4),
    "pendulum": Stage("pendulum", "Pendulum", ("phi",), ("k_fwp", "T_Kp", "T_Sp"), ("a", ""),
                      estimated_initial=("phi",), coarse_decimate=10, coarse_solver_step=4e-4),
}


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
    """One recording prepared for one stage."""

    recording: Recording
    stage: Stage
    drive: str  # the drive signal's name, "" when nothing drives it
    fixed: dict[str, float]  # known parameter values for this recording
    estimated: dict[str, tuple[float, float, float]] = field(default_factory=dict)  # name -> (guess, low, high)
    scales: dict[str, float] = field(default_factory=dict)

    @property
    def name(self) -> str:
        path = self.recording.path
        return Path(path).stem if path else "recording"

    @property
    def time(self) -> np.ndarray:
        return self.recording.time

    def drive_values(self) -> np.ndarray:
        return self.recording.signal(self.drive) if self.drive else np.zeros_like(self.time)

    def recorded(self, name: str) -> np.ndarray:
        return self.recording.signal(name)


def make_experiment(recording: Recording, stage: str, parameters: Mapping[str, float],
                    drive: str | None = None) -> Experiment:
    """Check that `recording` has what `stage` needs and gather its fixed values."""
    if stage not in STAGES:
        raise RecordingError(f"unknown stage {stage!r}; stages: {', '.join(STAGES)}")
    spec = STAGES[stage]
    where = str(recording.path)
    for name in spec.fitted:
        if name not in recording.signals:
            raise RecordingError(f"{where}: stage {stage} needs the recorded signal {name!r}; "
                                 f"columns: {', '.join(('time', *recording.signals))}")
    chosen = _choose_drive(recording, spec, drive)
    fixed = dict(parameters)
    fixed.update(check_parameters(recording.parameters, where))
    fixed = with_initial_states(fixed, recording.initial, where)
    experiment = Experiment(recording, spec, chosen, fixed)
    for state in spec.estimated_initial:
        if state not in recording.initial:
            first = float(recording.signal(state)[0])
            step = recording.resolution(state) or signal_scale(recording, state)
            experiment.estimated[INITIAL_STATE_PARAMETERS[state]] = (first, first - 2 * step, first + 2 * step)
    for name in spec.fitted:
        experiment.scales[name] = signal_scale(recording, name)
    return experiment


def _choose_drive(recording: Recording, spec: Stage, drive: str | None) -> str:
    if drive is not None:
        if drive not in spec.drives:
            raise RecordingError(f"stage {spec.name} is driven by {' or '.join(d for d in spec.drives if d)}, "
                                 f"not {drive!r}")
        if drive and drive not in recording.signals:
            raise RecordingError(f"{recording.path}: no column {drive!r} to drive the {spec.name} stage")
        return drive
    for candidate in spec.drives:
        if candidate == "" or candidate in recording.signals:
            return candidate
    raise RecordingError(f"{recording.path}: stage {spec.name} needs a drive signal "
                         f"({' or '.join(spec.drives)}); columns: {', '.join(('time', *recording.signals))}")
