"""The paper's sequence on a folder of recordings: current, then cart, then pendulum.

`fit_all` sorts a folder's recordings by their signals, fits the stages in order, each
starting from the previous stage's result and carrying its bootstrap replicates, and
predicts the recordings with both x and phi (coupled, bang-bang) with the result.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

import numpy as np

from pendfmu.components import rig_defaults
from pendfmu.fitting.checkpoint import Checkpoint
from pendfmu.fitting.identification import _recordings, fit
from pendfmu.fitting.optimizer import GlobalOptions
from pendfmu.fitting.plausibility import SuspiciousData, check_experiment
from pendfmu.fitting.experiment import signal_scale
from pendfmu.fitting.provenance import merged
from pendfmu.fitting.result import ExperimentFit, FitResult
from pendfmu.fitting.ripple import fit_current
from pendfmu.fitting.stages import STAGES, make_experiment
from pendfmu.fitting.uncertainty import REPLICATES
from pendfmu.parameters import check_parameters
from pendfmu.recording import Recording, RecordingError, read_recording


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


def skipped_in_folder(folder: str | Path, groups: Mapping[str | None, list[Recording]]) -> list[str]:
    """What `fit all` leaves out of a folder, said in words: the stages with no recording
    and the files it does not read (anything but recordings and their sidecars)."""
    folder = Path(folder)
    stems = {p.stem for p in folder.iterdir() if p.suffix.lower() in (".csv", ".mat")}
    others = sorted(p.name for p in folder.iterdir() if p.is_file() and p.suffix.lower() not in (".csv", ".mat")
                    and not (p.suffix.lower() == ".json" and p.stem in stems))
    needs = {"current": "I_c and I without x or phi", "cart": "x without phi", "pendulum": "phi without x"}
    lines = [f"skipped stage {stage}: no recording with {needs[stage]}" for stage in ("current", "cart", "pendulum")
             if not groups.get(stage)]
    if others:
        lines.append(f"not read (not a recording or its sidecar): {', '.join(others)}")
    return lines


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
    skipped = skipped_in_folder(folder, groups)
    for line in skipped:
        print(f"fit all: {line}", flush=True)
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
    combined = _combine(results, values, groups.get(None, []))
    combined.notes.extend(skipped)
    return combined


def predicted_fits(parameters: Mapping[str, float], recordings: Sequence[Recording]) -> list[ExperimentFit]:
    """The recordings not fitted, simulated as a whole rig with `parameters`: recorded
    against predicted x and phi, with the values each ran with, for the report."""
    from pendfmu.simulator.rig import experiment_parameters, simulate_recording

    fits = []
    for recording in recordings:
        simulated = simulate_recording(parameters, recording)
        names = [name for name in ("x", "phi") if name in recording.signals]
        values = experiment_parameters(parameters, recording)
        overrides = {k: float(v) for k, v in values.items()
                     if k in recording.parameters or parameters.get(k) != v}
        fits.append(ExperimentFit(
            recording.path.stem, recording.time, {n: recording.signal(n) for n in names},
            {n: simulated[n].to_numpy() for n in names},
            {n: step for n in names if (step := recording.resolution(n))},
            {n: signal_scale(recording, n) for n in names}, values, overrides))
    return fits


def prediction_errors(fits: Sequence[ExperimentFit]) -> dict[str, dict[str, float]]:
    """Per predicted recording, "<signal>_rms" and, with a stated resolution, "<signal>_rms_steps"."""
    errors: dict[str, dict[str, float]] = {}
    for prediction in fits:
        entry = {}
        for name, recorded in prediction.recorded.items():
            rms = float(np.sqrt(np.mean((prediction.simulated[name] - recorded) ** 2)))
            entry[f"{name}_rms"] = rms
            if prediction.resolution.get(name):
                entry[f"{name}_rms_steps"] = rms / prediction.resolution[name]
        errors[prediction.name] = entry
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
    combined.provenance = merged([r.provenance for r in results if r.provenance], validation)
    if validation:
        combined.predicted = predicted_fits(values, validation)
        combined.validation = prediction_errors(combined.predicted)
        combined.notes.append("predicted, not fitted (recordings with both x and phi): "
                              + ", ".join(r.path.name for r in validation))
    return combined
