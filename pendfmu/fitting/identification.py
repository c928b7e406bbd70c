"""Fit a stage's parameters to recordings: the Python API behind `pendfmu fit`.

    result = pendfmu.fit("cart", ["run1.csv", "run2.csv"], params=known, seed=1)
    result.write_json("cart.json"); result.write_report("report/")

Stages follow the paper (experiment.py). `fit_all` runs current -> cart -> pendulum on a
folder of recordings, each stage starting from the previous one's result.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace
from pathlib import Path

import numpy as np

from pendfmu.fitting.checkpoint import Checkpoint, Interrupted, best_candidate
from pendfmu.components import COMPONENTS
from pendfmu.fitting.experiment import Experiment
from pendfmu.fitting.models import (checked_values, initial_map, load_model, mapping, model_experiments,
                                    model_free_parameters, read_for)
from pendfmu.fitting.stages import STAGES, make_experiment
from pendfmu.fitting.optimizer import GlobalOptions, optimize
from pendfmu.parameters import ParameterFileError, check_parameters
from pendfmu.fitting.plausibility import SuspiciousData, check_experiment
from pendfmu.recording import Recording, RecordingError, read_recording
from pendfmu.fitting.residuals import FreeParameter, Residuals, physical, unit_of
from pendfmu.simulator.component import FMUError
from pendfmu.simulator.model import Model
from pendfmu.fitting.stiction import JOINTS, bounded_set
from pendfmu.fitting.stiction import evidence as stiction_evidence
from pendfmu.fitting.result import Estimate, ExperimentFit, FitResult, flag_warnings, nrmse
from pendfmu.fitting.uncertainty import REPLICATES, assess_uncertainty

# name: (low, high, logarithmic). Physical ranges wide enough for any lab rig.
DEFAULT_BOUNDS: dict[str, tuple[float, float, bool]] = {
    "T_i": (1e-5, 1e-1, True), "dIdt_max": (10.0, 1e6, True),
    "a_h": (0.0, 1.0, False), "f_h": (1.0, 1e5, True), "phase_h": (-math.pi, math.pi, False),
    "eta": (0.05, 1.0, False), "k_fwc": (1e-2, 1e3, True), "F_Kc": (1e-2, 1e3, True), "F_Sc": (1e-2, 1e3, True),
    "k_fwp": (1e-7, 1e-1, True), "T_Kp": (1e-7, 1e-1, True), "T_Sp": (1e-7, 1e-1, True),
    "m_c": (0.05, 100.0, True), "x0": (-1.0, 1.0, False), "v0": (-5.0, 5.0, False),
    "J_p": (1e-6, 10.0, True), "w0": (-20.0, 20.0, False),
}


def rig_defaults() -> dict[str, float]:
    """Every rig parameter at its FMU default (the reference rig of MODEL.md)."""
    values: dict[str, float] = {}
    for component in COMPONENTS.values():
        for name, variable in component.parameters.items():
            if name != "solver_step":
                values.setdefault(name, float(variable.start))
    return values


class Progress:
    """A progress bar on stderr when it is a terminal (tqdm), silent otherwise."""

    def __init__(self, stage: str, total: int, enabled: bool | None = None):
        enabled = sys.stderr.isatty() if enabled is None else enabled
        self.bar = None
        if enabled:
            from tqdm import tqdm

            self.bar = tqdm(total=total, desc=f"fit {stage}", unit="gen", file=sys.stderr, leave=False)

    def __call__(self, message: str) -> None:
        if self.bar is not None:
            self.bar.set_postfix_str(message.split(":")[0])
            if message.startswith("global"):
                self.bar.update(1)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def _recordings(recordings: Sequence[str | Path | Recording]) -> list[Recording]:
    if not recordings:
        raise RecordingError("no recordings given")
    return [r if isinstance(r, Recording) else read_recording(r) for r in recordings]


SEARCH_DECADE = 10.0  # default search box: the given value divided and multiplied by this
STICTION_OF = {"F_Sc": "F_Kc", "T_Sp": "T_Kp"}  # stiction -> the Coulomb friction it is fitted relative to
STICTION_RATIO = (1.0, 10.0)
# RMS of the scaled residuals (1 at the truth) above which the fit says the model is missing something
MODEL_ERROR_LIMIT = 3.0


def _free_parameters(stage: str, experiments: list[Experiment], free: Sequence[str] | None,
                     fix: Sequence[str], bounds: Mapping[str, tuple[float, float]],
                     values: Mapping[str, float]) -> list[FreeParameter]:
    spec = STAGES[stage]
    component = COMPONENTS[spec.component]
    names = list(spec.default_free) + [n for n in (free or []) if n not in spec.default_free]
    for name in list(names) + list(fix):
        if name not in component.parameters and name not in {"phi0"}:
            raise ParameterFileError(f"stage {stage} fits parameters of {spec.component}; {name!r} is not one "
                                     f"(valid: {', '.join(n for n in component.parameters if n != 'solver_step')})")
    estimated = {name for experiment in experiments for name in experiment.estimated}
    valid = [n for n in names if n not in fix] + sorted(estimated - set(fix))
    for name in bounds:
        if name not in valid:
            raise ParameterFileError(f"bounds for {name!r}, which this fit does not estimate; its free "
                                     f"parameters: {', '.join(valid) or 'none'}")
    result = []
    for name in names:
        if name in fix:
            continue
        low, high, log = DEFAULT_BOUNDS.get(name, (None, None, False))
        prior = values.get(name)
        if log and prior and prior > 0 and name not in bounds:
            # Search a decade either side of the given value: a lab engineer's prior is
            # rarely off by more, and a box of five decades leaves the global search lost.
            low, high = max(low, prior / SEARCH_DECADE), min(high, prior * SEARCH_DECADE)
        relative_to = None
        if name in bounds:
            low, high = bounds[name]
            log = log and low > 0
        elif name in STICTION_OF and STICTION_OF[name] in names and STICTION_OF[name] not in fix:
            relative_to, (low, high), log = STICTION_OF[name], STICTION_RATIO, True
        elif name in STICTION_OF:
            low = max(low, values.get(STICTION_OF[name], 0.0))  # below Coulomb friction it has no effect
        if low is None or not high > low:
            raise ParameterFileError(f"parameter {name}: give bounds as --bounds {name}=LOW:HIGH (LOW < HIGH)")
        result.append(FreeParameter(name, float(low), float(high), log, relative_to=relative_to))
    for experiment in experiments:
        for name, (_guess, low, high) in experiment.estimated.items():
            if name not in fix:  # an initial state's box: +-2 sensor steps, or what --bounds gives
                low, high = bounds.get(name, (low, high))
                result.append(FreeParameter(name, low, high, False, experiment.name))
    return result


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
    guesses = {e.name: e.estimated for e in experiments}
    start = [guesses[p.experiment][p.name][0] if p.experiment else values.get(p.name, p.low) for p in free]
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
        interpolation: str = "hold") -> FitResult:
    """Fit a model's parameters to one or more recordings jointly.

    `model` is one of the paper's stages ('current', 'cart' or 'pendulum', with its own
    drives, matches and free parameters: stages.py; `drive` then names the recorded
    column that drives it), or a user's model: an FMU or SSP file, or a Model
    (models.py: `drive` and `match` map model inputs and outputs to recorded columns,
    {name: column} or ["name=column", ...], by default by equal names; `free` names the
    parameters to fit; `initial` maps a signal of the sidecars' "initial" to the
    parameter of its initial value; `interpolation` is how drives go between samples).

    `uncertainty` chooses the intervals (uncertainty.py): "bootstrap" (calibrated, the
    default; `replicates` refits) or "jacobian" (fast, too narrow on quantized data).
    `upstream` gives, per replicate, the values an earlier stage's bootstrap found, so
    that this stage's intervals carry that stage's uncertainty (fit_all passes them).

    With a checkpoint, the global search's evaluations are remembered in it (and taken from
    it on a resumed run); Ctrl-C raises Interrupted with the best values found so far.
    Recordings that look mis-scaled or undescribed (plausibility.py) are reported through
    `warn` before the fit starts, and kept in the result's warnings; with `strict` they
    raise SuspiciousData instead, before any simulation."""
    preset = isinstance(model, str) and model in STAGES
    if preset:
        stage = model
        values = {**rig_defaults(), **check_parameters(params or {})}
        experiments = [make_experiment(r, stage, values, drive) for r in _recordings(recordings)]
    else:
        user = _user_model(model)
        stage = user.name
        drives, matches, initials = mapping(drive), mapping(match), initial_map(user, initial)
        values = {**user.defaults(), **checked_values(user, params or {})}
        read = read_for(user, _listed(recordings), drives, matches, initials)
        experiments = model_experiments(user, read, values, drives, matches, initials, interpolation)
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
        free_parameters = _free_parameters(stage, experiments, free, list(fix), dict(bounds or {}), values)
    else:
        free_parameters = model_free_parameters(user, list(free or []), list(fix), dict(bounds or {}), values)
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
                         f"(last: {residuals.last_failure or coarse.last_failure})")
        found = physical(free_parameters, outcome.u)
        fitted = {p.name: float(v) for p, v in zip(free_parameters, found) if p.experiment is None}
        if preset and stage in JOINTS:
            try:
                notes += _bound_stiction(stage, residuals, outcome.u, estimates, fitted, assessed.values)
            except FMUError as error:  # the result is written regardless
                notes.append(f"the stiction's set could not be checked: the simulation at the result fails ({error})")
        final_values = [fitted.get(p.name, v) if p.experiment is None else v for p, v in zip(free_parameters, found)]
        try:
            fits = _experiment_fits(residuals, unit_of(free_parameters, final_values))
        except FMUError as error:
            fits = []
            notes.append(f"the simulation at the result fails ({error}): no fit statistics")
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
    return FitResult(stage, final, estimates, correlation, 0.5 * float(outcome.residual @ outcome.residual),
                     nrmse(fits), outcome.nfev, outcome.failures, outcome.seconds, fits, initial_states, notes,
                     warnings=warnings, uncertainty=assessed.summary, replicates=assessed.replicates)


def _experiment_fits(residuals: Residuals, u: np.ndarray) -> list[ExperimentFit]:
    fits = []
    for experiment, simulated in zip(residuals.experiments, residuals.simulate(u)):
        recorded = {column: experiment.recorded(column) for column in experiment.match.values()}
        resolution = {name: step for name in recorded if (step := experiment.recording.resolution(name))}
        fits.append(ExperimentFit(experiment.name, experiment.time, recorded,
                                  {column: simulated[output] for output, column in experiment.match.items()},
                                  resolution))
    return fits


def _bound_stiction(stage: str, residuals: Residuals, u: np.ndarray, estimates: dict[str, Estimate],
                    fitted: dict[str, float], replicates: np.ndarray | None) -> list[str]:
    """Stiction that the recordings only bound (stiction.py: no breakaway of a joint at
    rest in any of them) is reported as that set, the same for every seed, with the least
    stiction the recordings demand as its value."""
    joint = JOINTS[stage]
    if joint.stiction not in estimates:
        return []
    extra = (joint.force, joint.speed, joint.acceleration)
    found = stiction_evidence(residuals.simulate(u, extra=extra), joint)
    others = []
    for row in replicates if replicates is not None else []:
        if not np.isnan(row).any():
            try:
                others.append(stiction_evidence(residuals.simulate(unit_of(residuals.free, row), extra=extra), joint))
            except FMUError:
                continue
    coulomb = fitted.get(joint.coulomb, residuals.shared.get(joint.coulomb, 0.0))
    bounds = bounded_set(found, others, coulomb)
    if bounds is None:
        return []
    low, high = bounds
    fitted[joint.stiction] = low
    estimates[joint.stiction] = replace(
        estimates[joint.stiction], value=low, stderr=None, ci95=(low, high), method="bounded", flags=[
            f"bounded only: every {joint.stiction} in [{low:.4g}, {high:.4g}] {joint.unit} gives the same recordings "
            f"(no joint at rest broke away in them: they only show where it stuck or reversed); the value given is "
            f"the least stiction the recordings demand"
            + (". Record the 'pendulum-stiction' experiment (pendfmu rig) to pin it down" if stage == "pendulum"
               else ". Record a slow ramp of the drive from rest to pin it down")])
    return [f"{joint.stiction} is set-identified: [{low:.4g}, {high:.4g}] {joint.unit}"]


HARMONIC = ("a_h", "f_h", "phase_h")
HARMONIC_SIGNIFICANCE = 4.0  # peak amplitude over the residual's noise amplitude, to count as ripple


def detect_harmonic(result: FitResult) -> dict[str, float] | None:
    """The PWM ripple left in a current fit's residual: the strongest periodogram peak of
    the residuals (evenly sampled recordings), if it stands well above the noise floor.
    A sinusoid's frequency makes a cost with many local minima, so it is seeded from the
    spectrum rather than searched; amplitude and phase follow by linear least squares."""
    best = None
    for fit_ in result.experiments:
        time, residual = fit_.time, fit_.recorded["I"] - fit_.simulated["I"]
        steps = np.diff(time)
        if len(time) < 64 or np.ptp(steps) > 1e-6 * steps.mean():
            continue
        spectrum = np.abs(np.fft.rfft(residual - residual.mean())) * 2 / len(residual)
        frequencies = np.fft.rfftfreq(len(residual), steps.mean())
        k = int(np.argmax(spectrum[1:])) + 1
        floor = float(np.median(spectrum[1:])) or 1e-300
        if spectrum[k] > HARMONIC_SIGNIFICANCE * floor * 3 and (best is None or spectrum[k] > best[0]):
            # refine the frequency by a parabola through the peak's neighbours (log amplitude)
            if 1 <= k < len(spectrum) - 1:
                a, b, c = np.log(spectrum[k - 1:k + 2] + 1e-300)
                shift = 0.5 * (a - c) / (a - 2 * b + c) if (a - 2 * b + c) else 0.0
            else:
                shift = 0.0
            frequency = float(frequencies[k] + shift * (frequencies[1] - frequencies[0]))
            basis = np.column_stack([np.sin(2 * np.pi * frequency * time), np.cos(2 * np.pi * frequency * time)])
            (s, c), *_ = np.linalg.lstsq(basis, residual, rcond=None)
            best = (float(spectrum[k]), {"a_h": float(math.hypot(s, c)), "f_h": frequency,
                                         "phase_h": float(math.atan2(c, s))})
    return best[1] if best else None


def fit_current(recordings, params=None, seed: int = 0, cost: str = "plain", harmonic: bool | None = None,
                global_search: GlobalOptions | None = None, progress: bool | None = None,
                checkpoint: Checkpoint | None = None, **options) -> FitResult:
    """The current stage, with the PWM ripple: unless harmonic=False, a harmonic found in
    the residual of the lag fit is added to the free parameters and fitted with them."""
    uncertainty = options.pop("uncertainty", "bootstrap")
    settled = harmonic is False or any(name in (options.get("free") or ()) for name in HARMONIC)
    first = fit("current", recordings, params, seed=seed, cost=cost, global_search=global_search,
                progress=progress, checkpoint=checkpoint, uncertainty=uncertainty if settled else "jacobian",
                **options)
    if settled:
        return first
    found = detect_harmonic(first)
    options.pop("warn", None)  # the recordings' warnings were given by the first pass
    if found is None:
        # The lag alone it is: its intervals, by the method asked for, from the optimum found.
        final = fit("current", recordings, {**(params or {}), **_fitted(first)}, seed=seed, cost=cost,
                    global_search=GlobalOptions(enabled=False), progress=progress, uncertainty=uncertainty, **options)
        final.notes.append("no PWM ripple found in the residual (harmonic not fitted)")
        final.nfev += first.nfev
        final.seconds += first.seconds
        return final
    bounds = {"a_h": (0.0, max(4 * found["a_h"], 1e-3)), "f_h": (0.9 * found["f_h"], 1.1 * found["f_h"]),
              "phase_h": (found["phase_h"] - math.pi, found["phase_h"] + math.pi), **options.pop("bounds", {})}
    second = fit("current", recordings, {**first.parameters, **found}, free=list(HARMONIC), bounds=bounds,
                 seed=seed, cost=cost, global_search=GlobalOptions(enabled=False), progress=progress,
                 uncertainty=uncertainty, **options)
    second.notes.append(f"PWM ripple found in the residual near {found['f_h']:.6g} Hz and fitted")
    second.nfev += first.nfev
    second.seconds += first.seconds
    return second


def _fitted(result: FitResult) -> dict[str, float]:
    """The stage's fitted rig parameters (not per-recording initial states)."""
    return {label: e.value for label, e in result.estimates.items() if "[" not in label}


def classify(recording: Recording) -> str | None:
    """Which stage a recording of a folder belongs to (None: a validation recording)."""
    signals = set(recording.signals)
    if "x" in signals and "phi" in signals:
        return None
    if "phi" in signals:
        return "pendulum"
    if "x" in signals:
        return "cart"
    if {"I_c", "I"} <= signals:
        return "current"
    return None


def sort_folder(folder: str | Path) -> dict[str | None, list[Recording]]:
    """A folder's recordings by the stage they belong to (None: validation recordings)."""
    folder = Path(folder)
    files = sorted(p for p in folder.iterdir() if p.suffix.lower() in (".csv", ".mat"))
    if not files:
        raise RecordingError(f"{folder}: no recordings (.csv or .mat) in this folder")
    groups: dict[str | None, list[Recording]] = {}
    for path in files:
        recording = read_recording(path)
        groups.setdefault(classify(recording), []).append(recording)
    if not any(groups.get(stage) for stage in STAGES):
        raise RecordingError(f"{folder}: no recording fits a stage (current: I_c and I; cart: x; pendulum: phi)")
    return groups


def check_recordings(stage: str, recordings: Sequence[str | Path | Recording],
                     params: Mapping[str, float] | None = None, drive: str | None = None) -> list[str]:
    """The plausibility warnings of a stage's recordings (plausibility.py), without fitting."""
    values = {**rig_defaults(), **check_parameters(params or {})}
    return [w for r in _recordings(recordings) for w in check_experiment(make_experiment(r, stage, values, drive))]


def fit_all(folder: str | Path, params: Mapping[str, float] | None = None, seed: int = 0, cost: str = "plain",
            global_search: GlobalOptions | None = None, progress: bool | None = None,
            checkpoint: Checkpoint | None = None, warn: Callable[[str], None] | None = None,
            strict: bool = False, uncertainty: str = "bootstrap", replicates: int = REPLICATES) -> FitResult:
    """The paper's sequence on a folder of recordings: current, then cart, then pendulum,
    each stage starting from the previous stage's result. Recordings with both x and phi
    are not fitted; they check the identified model (see validate). Every recording is
    checked for plausibility before the first stage starts (see fit)."""
    groups = sort_folder(folder)
    data_warnings = [w for stage in STAGES if groups.get(stage)
                     for w in check_recordings(stage, groups[stage], params)]
    for warning in data_warnings:
        if warn:
            warn(warning)
    if strict and data_warnings:
        raise SuspiciousData(data_warnings)
    values = dict(params or {})
    results = []
    upstream: list[dict[str, float]] = []  # per bootstrap replicate, every earlier stage's values
    for stage in ("current", "cart", "pendulum"):
        if groups.get(stage):
            run = fit_current if stage == "current" else (lambda *a, **k: fit(stage, *a, **k))
            result = run(groups[stage], values, seed=seed, cost=cost, global_search=global_search,
                         progress=progress, checkpoint=checkpoint, uncertainty=uncertainty, replicates=replicates,
                         upstream=upstream or None)
            values = dict(result.parameters)
            upstream = [{**(upstream[b] if upstream else {}), **replicate}
                        for b, replicate in enumerate(result.replicates)] or upstream
            results.append(result)
    return _combine(results, values, groups.get(None, []))


def predict(parameters: Mapping[str, float], recordings: Sequence[Recording]) -> dict[str, dict[str, float]]:
    """Simulate the whole rig for recordings that were not fitted (the coupled and
    bang-bang experiments) and measure the prediction error of x and phi, in the signal's
    unit and in sensor steps where the sidecar gives the resolution."""
    from pendfmu.simulator.rig import simulate_recording

    errors: dict[str, dict[str, float]] = {}
    for recording in recordings:
        simulated = simulate_recording(parameters, recording)
        entry = {}
        for name in ("x", "phi"):
            if name in recording.signals:
                rms = float(np.sqrt(np.mean((simulated[name].to_numpy() - recording.signal(name)) ** 2)))
                entry[f"{name}_rms"] = rms
                if recording.resolution(name):
                    entry[f"{name}_rms_steps"] = rms / recording.resolution(name)
        errors[recording.path.stem] = entry
    return errors


def _combine(results: list[FitResult], values: dict[str, float], validation: list[Recording]) -> FitResult:
    combined = FitResult(
        "all", values, {k: e for r in results for k, e in r.estimates.items()},
        {k: c for r in results for k, c in r.correlation.items()}, sum(r.cost for r in results),
        {f"{r.stage}.{s}": v for r in results for s, v in r.nrmse.items()}, sum(r.nfev for r in results),
        sum(r.failures for r in results), sum(r.seconds for r in results),
        [e for r in results for e in r.experiments], {k: v for r in results for k, v in r.initial.items()},
        [f"{r.stage}: {n}" for r in results for n in r.notes],
        warnings=[f"{r.stage}: {w}" for r in results for w in r.warnings],
        uncertainty={r.stage: r.uncertainty for r in results})
    if validation:
        combined.validation = predict(values, validation)
        combined.notes.append("predicted, not fitted (recordings with both x and phi): "
                              + ", ".join(r.path.name for r in validation))
    return combined
