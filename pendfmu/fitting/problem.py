"""From a fit's specification to the problem the optimizer solves.

A Problem is what one fit runs on: its experiments (each recording, window or segment
with the model that replays it and the values it fixes), its free parameters with their
search boxes, the known values, and the warnings about the data and the set-up that are
given before the fit starts. A stage of the paper (stages.py) and a user's FMU or SSP
system (models.py) are built here alike from a FitSpec (spec.py); the optimizer and
the intervals never see which it was.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pendfmu.errors import OptionError
from pendfmu.fitting.experiment import Experiment, unseen_at_a_late_start
from pendfmu.fitting.models import (checked_values, initial_map, mapping, model_experiments,
                                    model_free_parameters, read_for, without_aliases)
from pendfmu.fitting.plausibility import check_experiment, self_locking_switch, viscous_twins
from pendfmu.fitting.residuals import FreeParameter, unit_of
from pendfmu.fitting.spec import STAGE_NAMES, TURNING, FitSpec
from pendfmu.fitting.stages import make_experiment, stage_free_parameters
from pendfmu.fitting.turning import from_turning_point, start_at_turning
from pendfmu.parameters import check_parameters, read_parameters, rig_values
from pendfmu.physics import pivot_inertia, settled
from pendfmu.recording import Recording, RecordingError, read_recording
from pendfmu.recording.measurement import measurement_signal, no_effect
from pendfmu.recording.windows import cut
from pendfmu.simulator.model import Model


@dataclass
class Problem:
    """One fit's experiments, free parameters and known values, ready to optimize.

    Attributes
    ----------
    name : str
        The stage's name, or the user's model's.
    experiments : list of Experiment
        Each recording (window, segment) with its model, drives, matches and values.
    free : list of FreeParameter
        The estimated parameters with their search boxes, shared ones first.
    values : dict
        Every known value (the model's defaults, then the given ones).
    data_warnings : list of str
        What looks wrong in the recordings (plausibility.py).
    setup_warnings : list of str
        What looks wrong in the fit's set-up (a box straddling a switch, twin parameters).
    model_file : str or None
        A user's FMU or SSP file (None for a stage, or a Model given as an object).
    stage : str or None
        The paper's stage the problem is a preset of (None for a user's model).
    """

    name: str
    experiments: list[Experiment]
    free: list[FreeParameter]
    values: dict[str, float]
    data_warnings: list[str]
    setup_warnings: list[str]
    model_file: str | None = None
    stage: str | None = None

    @property
    def warnings(self) -> list[str]:
        return self.data_warnings + self.setup_warnings


def build_problem(spec: FitSpec) -> Problem:
    """The problem of a stage's or a model's spec (the sequence 'all' builds one per stage)."""
    return stage_problem(spec) if spec.kind == "stage" else model_problem(spec)


def stage_problem(spec: FitSpec) -> Problem:
    """A stage of the paper: its components, drives, matches and free parameters (stages.py)."""
    stage = spec.target
    known = given_values(spec)
    values = rig_values(known)  # J_cm becomes J_p with each recording's m_p and l, then here
    parts = _parts(_read(spec.recordings), spec)
    if spec.start == TURNING:  # each part from its first turning point, its rate in the box one allows
        turned = [from_turning_point(part) for part in parts]
        experiments = [start_at_turning(make_experiment(part, stage, values, spec.drive, spec.per_recording,
                                                        match=spec.match), point) for part, point in turned]
    else:
        experiments = [make_experiment(r, stage, values, spec.drive, spec.per_recording, spec.start or "estimated",
                                       spec.match) for r in parts]
    values = settled(values, "params")
    _distinct(experiments)
    _check_starts(spec, f"the {stage} stage", experiments)
    data_warnings = [w for e in experiments for w in check_experiment(e)]
    # the values the user gave (the rest are the reference rig's): a friction parameter
    # without one is searched in a box derived from the rig's sizes (stages.derived_box)
    given = {*known, *(n for e in experiments for n in e.recording.parameters)}
    free = stage_free_parameters(stage, experiments, spec.free, spec.fix, spec.bounds, values, given)
    setup_warnings = self_locking_switch(free, experiments) + viscous_twins(free, experiments)
    return Problem(stage, experiments, free, values, data_warnings, setup_warnings, stage=stage)


def model_problem(spec: FitSpec) -> Problem:
    """A user's FMU or SSP system, driven and matched by name unless the spec maps them (models.py)."""
    model = user_model(spec.target)
    drives = {spec.drive: spec.drive} if isinstance(spec.drive, str) else mapping(spec.drive)
    matches, initials = mapping(spec.match), initial_map(model, spec.initial)
    given = _known(spec.params, lambda values, where="": checked_values(model, values, where))
    values = without_aliases(model, model.defaults(), [*given, *spec.free, *spec.fix, *spec.per_recording]) | given
    read = _parts(read_for(model, spec.recordings, drives, matches, initials), spec)
    experiments = model_experiments(model, read, values, drives, matches, initials, spec.interpolation or "hold",
                                    spec.per_recording, spec.start or "estimated")
    _distinct(experiments)
    _check_starts(spec, model.name, experiments)
    data_warnings = [w for e in experiments for w in check_experiment(e)]
    free = model_free_parameters(model, list(spec.free), list(spec.fix), dict(spec.bounds), values, experiments)
    model_file = None if isinstance(spec.target, Model) else str(spec.target)
    setup_warnings = [w for e in experiments for w in unseen_at_a_late_start(e, {p.name for p in free})]
    return Problem(model.name, experiments, free, values, data_warnings, setup_warnings, model_file)


def _check_starts(spec: FitSpec, name: str, experiments: Sequence[Experiment]) -> None:
    """A start option needs an initial state that a window's first readings can give."""
    if spec.start is not None and not any(e.setup.starts for e in experiments):
        raise OptionError("start", f"{name} has no initial state that a window's first readings could give")


def user_model(target: str | Path | Model) -> Model:
    """The Model of a user's target: an FMU or SSP file, or the Model itself."""
    if isinstance(target, str) and not Path(target).suffix:
        raise OptionError("target", f"unknown stage {target!r}; stages: {', '.join(STAGE_NAMES)}, all; or an FMU "
                                    f"(.fmu) or SSP (.ssp) file")
    return Model.load(target)


def given_values(spec: FitSpec) -> dict[str, float]:
    """The values a stage's spec gives, checked against the rig's parameter table
    (docs/reference/variables.md)."""
    return _known(spec.params, check_parameters)


def _known(params: Mapping[str, object] | str | Path, check) -> dict[str, float]:
    """The given values, checked: a mapping, or a parameters or result file."""
    if isinstance(params, (str, Path)):
        return read_parameters(params, check)
    return check(params or {})


def _read(recordings: Sequence[str | Path | Recording]) -> list[Recording]:
    if not recordings:
        raise RecordingError("no recordings given")
    return [r if isinstance(r, Recording) else read_recording(r) for r in recordings]


def _parts(recordings: Sequence[Recording], spec: FitSpec) -> list[Recording]:
    """Each recording's windows and segments (recording/windows.py), in order."""
    return [part for r in recordings for part in cut(r, spec.windows, spec.segment)]


def _distinct(experiments: Sequence[Experiment]) -> None:
    names = [e.name for e in experiments]
    if len(set(names)) != len(names):
        raise RecordingError(f"two recordings share the name {sorted(n for n in names if names.count(n) > 1)[0]!r}")


def start_vector(free: list[FreeParameter], values: Mapping[str, float], experiments: list[Experiment]) -> np.ndarray:
    """The start of the search: given values, a recording's own guesses for its own
    parameters; where none is known, the middle of the box (the low end where that is
    0: a delay or an extra that is off)."""
    by_name = {e.name: e for e in experiments}

    def default(p: FreeParameter) -> float:
        if p.name not in values and measurement_signal(p.name):
            return no_effect(p.name)
        if p.name == "J_p" and values.get("J_p") == 0.0:  # 0 is the rod's inertia by convention, not a value
            return pivot_inertia(values)
        middle = math.sqrt(p.low * p.high) if p.log else 0.5 * (p.low + p.high)
        return values.get(p.name, p.low if p.low == 0 else middle)

    start = []
    for p in free:
        if p.experiment is None:
            start.append(default(p))
            continue
        experiment = by_name[p.experiment]
        guess = experiment.estimated[p.name][0]
        start.append(guess if guess is not None else experiment.fixed.get(p.name, default(p)))
    return unit_of(free, start)
