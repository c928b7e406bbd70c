"""The paper's sequence on a folder of recordings: current, then cart, then pendulum.

`fit_sequence` (``pendfmu.fit("all", folder)``) sorts a folder's recordings by their signals, fits the stages in order, each
starting from the previous stage's result and carrying its bootstrap replicates, and
predicts the recordings with both x and phi (coupled, bang-bang) with the result.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from pendfmu.errors import OptionError
from pendfmu.fitting.adequacy import VERDICTS
from pendfmu.fitting.experiment import signal_scale
from pendfmu.fitting.plausibility import SuspiciousData
from pendfmu.fitting.problem import build_problem, given_values
from pendfmu.fitting.provenance import merged
from pendfmu.fitting.result import ExperimentFit, FitResult
from pendfmu.fitting.solve import Session, solve
from pendfmu.fitting.spec import STAGE_NAMES, FitSpec, for_stage, unplaced
from pendfmu.fitting.stages import STAGES, stage_has
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


def fit_sequence(spec: FitSpec, session: Session) -> FitResult:
    """The paper's sequence on a folder of recordings: current, then cart, then pendulum,
    each stage starting from the previous stage's result and carrying its bootstrap
    replicates. Recordings with both x and phi are not fitted; they check the identified
    model (predicted_fits). Every stage's problem is built before the first one is fitted:
    its recordings are judged (warnings, --strict) and every option reaches the stages that
    have its parameters or is refused (spec.for_stage), before any work."""
    folder = spec.recordings[0]
    groups = sort_folder(folder)
    stages = [stage for stage in STAGE_NAMES if groups.get(stage)]
    specs = _stage_specs(spec, stages, groups)
    problems = {stage: build_problem(specs[stage]) for stage in stages}
    data_warnings = [w for stage in stages for w in problems[stage].data_warnings]
    session.say(data_warnings)
    if session.strict and data_warnings:
        raise SuspiciousData(data_warnings)
    skipped = skipped_in_folder(folder, groups)
    for line in skipped:
        print(f"fit all: {line}", flush=True)
    values = given_values(spec)
    results = []
    upstream: list[dict[str, float]] = []  # per bootstrap replicate, every earlier stage's values
    for stage in stages:
        result = solve(specs[stage].with_options(params=values), session.quiet(), upstream or None)
        values = dict(result.parameters)
        upstream = [{**(upstream[b] if upstream else {}), **replicate}
                    for b, replicate in enumerate(result.replicates)] or upstream
        results.append(result)
    combined = _combine(results, values, groups.get(None, []))
    combined.replicates = upstream
    combined.notes.extend(skipped)
    combined.provenance["request"] = spec.request()
    return combined


def _stage_specs(spec: FitSpec, stages: Sequence[str], groups: Mapping[str | None, list[Recording]]
                 ) -> dict[str, FitSpec]:
    """Each stage's spec: its recordings, and the options that reach it (spec.for_stage)."""
    if spec.harmonic != "auto" and "current" not in stages:
        raise OptionError("harmonic", "is the current stage's PWM ripple; this folder has no current recording")
    accepted = {stage: {option: [name for name in getattr(spec, option) if stage_has(stage, name, groups[stage])]
                        for option in ("free", "fix", "bounds", "per_recording")} for stage in stages}
    unplaced(spec, accepted)
    return {stage: for_stage(spec, stage, accepted[stage]).with_options(recordings=tuple(groups[stage]))
            for stage in stages}


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
        uncertainty={r.stage: r.uncertainty for r in results}, assessment=worst_of(results))
    combined.provenance = merged([r.provenance for r in results if r.provenance], validation)
    if validation:
        combined.predicted = predicted_fits(values, validation)
        combined.validation = prediction_errors(combined.predicted)
        combined.notes.append("predicted, not fitted (recordings with both x and phi): "
                              + ", ".join(r.path.name for r in validation))
    return combined


def worst_of(results: Sequence[FitResult]) -> dict:
    """The sequence's verdict: the worst of its stages' (adequacy.py), with each stage's."""
    order = {verdict: k for k, verdict in enumerate(VERDICTS)}
    stages = {r.stage: r.assessment for r in results if r.assessment}
    worst = max((a["verdict"] for a in stages.values()), key=order.get, default="adequate")
    return {"verdict": worst, "stages": stages}
