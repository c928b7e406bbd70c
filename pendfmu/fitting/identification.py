"""Fit a model's parameters to recordings: the Python API behind `pendfmu fit`.

    result = pendfmu.fit("cart", ["run1.csv", "run2.csv"], params=known, seed=1)
    result = pendfmu.fit("motor.fmu", ["run1.csv"], free=["R", "L"])
    result.write_json("cart.json"); result.write_report("report/")

A stage of the paper (stages.py) or a user's FMU or SSP system (models.py), both through
the same experiments, optimizer and intervals. The paper's sequence of stages on a folder
is sequence.py, the current stage's ripple ripple.py.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

import numpy as np

from pendfmu.fitting.checkpoint import Checkpoint, Interrupted, best_candidate
from pendfmu.fitting.experiment import Experiment
from pendfmu.fitting.models import (checked_values, initial_map, load_model, mapping, model_experiments,
                                    model_free_parameters, read_for, without_aliases)
from pendfmu.fitting.optimizer import GlobalOptions, optimize
from pendfmu.fitting.plausibility import SuspiciousData, check_experiment, self_locking_switch, viscous_twins
from pendfmu.fitting.progress import Progress
from pendfmu.fitting.provenance import fit_record
from pendfmu.fitting.residuals import FreeParameter, Residuals, physical, unit_of
from pendfmu.fitting.result import ExperimentFit, FitResult, flag_warnings, nrmse
from pendfmu.fitting.stages import STAGES, make_experiment, stage_free_parameters
from pendfmu.fitting.stiction import JOINTS, bound_stiction
from pendfmu.fitting.uncertainty import REPLICATES, assess_uncertainty
from pendfmu.parameters import ParameterFileError, check_parameters, rig_values
from pendfmu.physics import settled
from pendfmu.recording import Recording, RecordingError, read_recording
from pendfmu.recording.measurement import measurement_signal, no_effect
from pendfmu.recording.windows import cut
from pendfmu.simulator.component import FMUError
from pendfmu.simulator.model import Model


def _recordings(recordings: Sequence[str | Path | Recording]) -> list[Recording]:
    if not recordings:
        raise RecordingError("no recordings given")
    return [r if isinstance(r, Recording) else read_recording(r) for r in recordings]


def _parts(recordings: Sequence[Recording], windows: Sequence[tuple[float, float]] | None,
           segment: float | None) -> list[Recording]:
    """Each recording's windows and segments (recording/windows.py), in order."""
    return [part for r in recordings for part in cut(r, windows or (), segment)]


# RMS of the scaled residuals (1 at the truth) above which the fit says the model is missing something
MODEL_ERROR_LIMIT = 3.0


def _user_model(model: str | Path | Model) -> Model:
    if isinstance(model, str) and not Path(model).suffix:
        raise ParameterFileError(f"unknown stage {model!r}; stages: {', '.join(STAGES)}, all; or an FMU (.fmu) "
                                 f"or SSP (.ssp) file")
    return load_model(model)


def _listed(recordings: Sequence[str | Path | Recording]) -> list[str | Path | Recording]:
    if not recordings:
        raise RecordingError("no recordings given")
    return list(recordings)


def _start(free: list[FreeParameter], values: Mapping[str, float], experiments: list[Experiment]) -> np.ndarray:
    """The start of the search: given values, a recording's own guesses for its own
    parameters; where none is known, the middle of the box (the low end where that is
    0: a delay or an extra that is off)."""
    by_name = {e.name: e for e in experiments}

    def default(p: FreeParameter) -> float:
        if p.name not in values and measurement_signal(p.name):
            return no_effect(p.name)
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


def fit(model: str | Path | Model, recordings: Sequence[str | Path | Recording],
        params: Mapping[str, float] | None = None, free: Sequence[str] | None = None, fix: Sequence[str] = (),
        bounds: Mapping[str, tuple[float, float]] | None = None, seed: int = 0,
        drive: str | Mapping[str, str] | Sequence[str] | None = None, cost: str = "plain",
        global_search: GlobalOptions | None = None, progress: bool | None = None,
        checkpoint: Checkpoint | None = None, warn: Callable[[str], None] | None = None,
        strict: bool = False, uncertainty: str = "bootstrap", replicates: int = REPLICATES,
        upstream: Sequence[Mapping[str, float]] | None = None,
        match: Mapping[str, str] | Sequence[str] | None = None, initial: Mapping[str, str] | None = None,
        interpolation: str = "hold", per_recording: Sequence[str] = (),
        windows: Sequence[tuple[float, float]] | None = None, segment: float | None = None,
        start: str = "estimated") -> FitResult:
    """Fit a model's parameters to one or more recordings jointly.

    Parameters
    ----------
    model : str, path or Model
        A stage of the paper ('current', 'cart', 'pendulum': stages.py, with its own drives,
        matches and free parameters) or a user's model: an FMU or SSP file, or a Model.
    recordings : sequence of paths or Recording
        Recorded time responses (CSV + sidecar, or .mat), fitted jointly.
    params : mapping, optional
        Known values and the start of the fitted ones (names of the model). A stage's
        friction parameter given neither here nor in a recording's sidecar is searched in
        a box derived from the rig's known sizes and the recordings (stages.DERIVED_BOUNDS),
        not around the reference rig's value.
    free, fix : sequences of names
        Parameters to fit besides a stage's own (a user's model: all of them), and ones to
        keep at their given values.
    bounds : mapping name -> (low, high), optional
        Search boxes (default: stages.py's policy, or models.py's for a user's model).
    seed : int
        Seed of the global search (the intervals do not depend on it).
    drive : str, or mapping / sequence of "INPUT=COLUMN"
        A stage: the recorded column that drives it (I_c, I or a). A model: its inputs by
        recorded column (default: equal names).
    match : mapping / sequence of "OUTPUT=COLUMN", optional
        A model: its outputs compared with recorded columns (default: equal names).
    initial : mapping signal -> parameter, optional
        A model: the parameter a sidecar's initial value of a signal sets (default x -> x0).
    interpolation : {"hold", "linear"}
        A model: its drives between samples.
    per_recording : sequence of names
        Parameters estimated for each recording (or window, segment) on its own: initial
        states (x0, v0, phi0, w0, or a model's), a sensor offset, any parameter.
    windows, segment
        Fit only these time windows (T0, T1) of each recording, and/or split them into
        segments of `segment` seconds; each part is fitted as a recording of its own and
        starts from its own initial states (recording/windows.py).
    start : {"estimated", "measured"}
        A later window's initial states: estimated (default), or taken from its first
        readings (a position the first reading, a speed the slope through the first 20).
    cost : {"plain", "quantized"}
        Residuals: plain least squares or zero inside each reading's quantization step.
    global_search : GlobalOptions, optional
        The global search (workers, Dask scheduler; enabled=False for a local fit only).
    uncertainty : {"bootstrap", "jacobian"}
        Calibrated intervals from `replicates` refits (default), or the fast Jacobian ones.
    upstream : sequence of mappings, optional
        Per bootstrap replicate, an earlier stage's values (fit_all passes them), so that
        this stage's intervals carry that stage's uncertainty.
    checkpoint, progress, warn, strict
        Ctrl-C handling (raises Interrupted with the best values found so far), a progress
        bar, a callback for warnings about the recordings (given before the fit starts),
        and whether such warnings raise SuspiciousData instead of fitting.

    Returns
    -------
    FitResult
        Values, intervals (each with its method), flags, warnings, fit statistics.
    """
    preset = isinstance(model, str) and model in STAGES
    if preset:
        stage = model
        values = rig_values(params)  # J_cm becomes J_p with each recording's m_p and l, then here
        experiments = [make_experiment(r, stage, values, drive, per_recording, start)
                       for r in _parts(_recordings(recordings), windows, segment)]
        values = settled(values, "params")
    else:
        user = _user_model(model)
        stage = user.name
        drives, matches, initials = mapping(drive), mapping(match), initial_map(user, initial)
        given = checked_values(user, params or {})
        values = without_aliases(user, user.defaults(), [*given, *(free or ()), *(fix or ())]) | given
        read = _parts(read_for(user, _listed(recordings), drives, matches, initials), windows, segment)
        experiments = model_experiments(user, read, values, drives, matches, initials, interpolation,
                                        per_recording, start)
    names = [e.name for e in experiments]
    if len(set(names)) != len(names):
        raise RecordingError(f"two recordings share the name {sorted(n for n in names if names.count(n) > 1)[0]!r}")
    data_warnings = [w for e in experiments for w in check_experiment(e)]
    for warning in data_warnings:
        if warn:
            warn(warning)
    if strict and data_warnings:
        raise SuspiciousData(data_warnings)
    if preset:
        # the values the user gave (the rest are the reference rig's): a friction parameter
        # without one is searched in a box derived from the rig's sizes (stages.derived_box)
        given = {*check_parameters(params or {}), *(n for e in experiments for n in e.recording.parameters)}
        free_parameters = stage_free_parameters(stage, experiments, free, list(fix), dict(bounds or {}), values,
                                                given)
        # warnings about the fit's set-up (README, Drives): printed as the data's are
        setup_warnings = self_locking_switch(free_parameters, experiments) + viscous_twins(free_parameters, experiments)
        for warning in setup_warnings:
            data_warnings.append(warning)
            if warn:
                warn(warning)
    else:
        free_parameters = model_free_parameters(user, list(free or []), list(fix), dict(bounds or {}), values,
                                                experiments)
    options = global_search or GlobalOptions()
    residuals = Residuals(experiments, free_parameters, values, cost)
    setup = experiments[0].setup
    coarse = Residuals(experiments, free_parameters, {**values, **setup.coarse_values}, cost,
                       decimate=setup.coarse_decimate)
    bar = Progress(stage, options.maxiter if options.enabled else 0, progress)
    cache = checkpoint.cache(f"{stage}:{','.join(names)}") if checkpoint else {}
    try:
        u0 = _start(free_parameters, values, experiments)
        try:
            outcome = optimize(residuals, coarse, u0, seed, options, bar, cache)
        except KeyboardInterrupt:
            best = best_candidate(cache)
            found = physical(free_parameters, u0 if best is None else best)
            shared = {p.name: float(v) for p, v in zip(free_parameters, found) if p.experiment is None}
            raise Interrupted({**values, **shared}, stage) from None
        notes = list(outcome.messages)
        bar("uncertainty")
        assessed = assess_uncertainty(uncertainty, residuals, outcome, replicates, upstream, options)
        estimates, correlation = assessed.estimates, assessed.correlation
        notes += assessed.notes
        warnings = list(data_warnings)
        spread = float(np.sqrt(np.mean(outcome.residual**2))) if len(outcome.residual) else 0.0
        if spread > MODEL_ERROR_LIMIT:
            warnings.append(f"the residuals are {spread:.3g} times the sensor noise: the model misses something "
                            f"the recordings show, the data are mis-scaled, or the sidecar understates the noise")
        if outcome.failures:
            notes.append(f"{outcome.failures} simulations failed during the fit and were penalized "
                         f"(last: {outcome.last_failure or 'no reason reported'})")
        found = physical(free_parameters, outcome.u)
        fitted = {p.name: float(v) for p, v in zip(free_parameters, found) if p.experiment is None}
        if preset and stage in JOINTS:
            try:
                notes += bound_stiction(stage, residuals, outcome.u, estimates, fitted, assessed.values)
            except FMUError as error:  # the result is written regardless
                notes.append(f"the stiction's set could not be checked: the simulation at the result fails "
                             f"({error.reason()})")
        final_values = [fitted.get(p.name, v) if p.experiment is None else v for p, v in zip(free_parameters, found)]
        try:
            fits = _experiment_fits(residuals, unit_of(free_parameters, final_values))
        except FMUError as error:
            fits = []
            notes.append(f"the simulation at the result fails ({error.reason()}): no fit statistics")
        if spread > MODEL_ERROR_LIMIT:
            warnings += drift_warnings(fits)
    finally:
        bar.close()
        residuals.close()
        coarse.close()
    initial_states: dict[str, dict[str, float]] = {}
    for p, value in zip(free_parameters, found):
        if p.experiment is not None:
            initial_states.setdefault(p.experiment, {})[p.name] = float(value)
    final = {**values, **fitted}
    warnings += flag_warnings(estimates)
    warnings += [note for note in notes if note.startswith("the local refinement stopped")]
    model_file = None if preset or isinstance(model, Model) else str(model)
    origin = fit_record(stage, [e.recording for e in experiments], seed, free_parameters,
                        physical(free_parameters, u0), values, cost, model_file)
    return FitResult(stage, final, estimates, correlation, 0.5 * float(outcome.residual @ outcome.residual),
                     nrmse(fits), outcome.nfev, outcome.failures, outcome.seconds, fits, initial_states, notes,
                     warnings=warnings, uncertainty=assessed.summary, replicates=assessed.replicates,
                     model=model_file, provenance=origin)


DRIFT_RATIO = 10.0
DRIFT_START = 0.05
"""A recording's error after its first DRIFT_START (a twentieth) DRIFT_RATIO times the error
within it: the simulation runs away from the recording (drift_warnings)."""


def drift_warnings(fits: Sequence[ExperimentFit]) -> list[str]:
    """A hint where a fit is poor because the simulation drifts: an open-loop replay of a
    closed-loop or unstable run (a balanced pendulum, a stage under position control) leaves
    the recording further and further behind from a start where it agreed, and no parameter
    value can fix that. Said when the RMS error of a recorded signal after its first
    twentieth is DRIFT_RATIO times the error within it (the start is where the replay and
    the recording agree best: both begin from the same state)."""
    found = []
    for fit in fits:
        for column, recorded in fit.recorded.items():
            error = fit.simulated[column] - recorded
            error = error[np.isfinite(error)]
            start = max(10, int(DRIFT_START * len(error)))
            if len(error) < 2 * start:
                continue
            early, late = (float(np.sqrt(np.mean(part**2))) for part in (error[:start], error[start:]))
            if late > DRIFT_RATIO * early:
                growth = f"{late / early:.3g}-fold" if early > 0 else "from nothing"
                found.append(f"{fit.name}: the simulated {column} drifts away from the recording (its error grows "
                             f"{growth} after the first twentieth of the run): an open-loop replay of a closed-loop "
                             f"or unstable run cannot follow it; fit it in segments with their own initial states "
                             f"(--segment SECONDS, or --window), or with its controller in the loop (pendfmu "
                             f"system, fit --system)")
    return found


def _experiment_fits(residuals: Residuals, u: np.ndarray) -> list[ExperimentFit]:
    fits = []
    for experiment, simulated in zip(residuals.experiments, residuals.simulate(u)):
        recorded = {column: experiment.recorded(column) for column in experiment.match.values()}
        resolution = {name: step for name in recorded if (step := experiment.recording.resolution(name))}
        fits.append(ExperimentFit(experiment.name, experiment.time, recorded,
                                  {column: simulated[output] for output, column in experiment.match.items()},
                                  resolution, dict(experiment.scales), _used(residuals, u, experiment),
                                  _overrides(experiment, residuals.shared)))
    return fits


def _used(residuals: Residuals, u: np.ndarray, experiment: Experiment) -> dict[str, float]:
    """The values one recording ran with, of the parameters its model has (a stage's model
    is one or two components; the rig's other values are carried along but never used),
    the fit's free ones and any its sidecar sets."""
    names = {*experiment.model.names("parameter"), *(p.name for p in residuals.free), *experiment.recording.parameters}
    return {name: float(value) for name, value in residuals.values(u, experiment).items() if name in names}


def _overrides(experiment: Experiment, shared: Mapping[str, float]) -> dict[str, float]:
    """The values one recording sets for itself: its sidecar's parameters, and whatever
    else (its initial states) differs from the values shared by all recordings."""
    names = set(experiment.recording.parameters)
    names |= {name for name, value in experiment.fixed.items() if shared.get(name) != value}
    return {name: float(experiment.fixed[name]) for name in sorted(names) if name in experiment.fixed}


