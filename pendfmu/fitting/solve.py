"""Solve one fit: a stage's or a model's problem, from the search to the written result.

`solve(spec, session)` builds the problem of the spec (problem.py), searches (optimizer.py),
assesses the intervals (uncertainty.py), reads what stick-slip recordings say about
stiction (stiction.py) and gathers the FitResult with its provenance. The current stage
with its PWM ripple takes two passes (ripple.py); the paper's sequence runs this per stage
(sequence.py). What watches a fit -- its progress bar, the Ctrl-C checkpoint, where
warnings go, --strict -- is its Session, not part of what it fits.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from pendfmu.errors import FMUError, OptionError
from pendfmu.fitting.checkpoint import Checkpoint, Interrupted, best_candidate
from pendfmu.fitting.edges import explain_edges
from pendfmu.fitting.experiment import Experiment
from pendfmu.fitting.adequacy import MODEL_ERROR_LIMIT, RESTARTS, assess, search_until_settled, verdict_warning
from pendfmu.fitting.labels import is_own
from pendfmu.fitting.plausibility import SuspiciousData
from pendfmu.fitting.problem import Problem, build_problem, start_vector
from pendfmu.fitting.progress import Progress
from pendfmu.fitting.provenance import fit_record
from pendfmu.fitting.residuals import Residuals, physical, unit_of
from pendfmu.fitting.result import ExperimentFit, FitResult
from pendfmu.fitting.statistics import flag_warnings, nrmse, sandwich_estimates, without_zero_widths
from pendfmu.fitting.ripple import fit_with_ripple, looks_for_ripple
from pendfmu.fitting.spec import FitSpec
from pendfmu.fitting.stiction import JOINTS, bound_stiction
from pendfmu.fitting.uncertainty import assess_uncertainty
from pendfmu.fitting.validation import (Started, hold_the_halves, mark_moving, moving, separately, split_states,
                                       validate)


@dataclass
class Session:
    """What watches a fit, not what it fits.

    Attributes
    ----------
    progress : bool or None
        A progress bar (None: on a terminal only).
    checkpoint : Checkpoint or None
        Where an interrupted fit keeps the costs it had computed (--resume).
    warn : callable or None
        Called with each warning about the recordings and the set-up, before the fit starts.
    strict : bool
        Raise SuspiciousData instead of fitting when the recordings look wrong.
    """

    progress: bool | None = None
    checkpoint: Checkpoint | None = None
    warn: Callable[[str], None] | None = None
    strict: bool = False

    def say(self, warnings: Sequence[str]) -> None:
        for warning in warnings:
            if self.warn:
                self.warn(warning)

    def quiet(self) -> Session:
        """The same session without its warnings (a later pass over recordings already judged)."""
        return Session(self.progress, self.checkpoint, None, False)


def solve(spec: FitSpec, session: Session, upstream: Sequence[Mapping[str, float]] | None = None) -> FitResult:
    """Fit one stage or model as `spec` says. `upstream`: per bootstrap replicate, an
    earlier stage's values (the sequence passes them), so that the intervals carry them."""
    if looks_for_ripple(spec):
        return fit_with_ripple(spec, lambda one, final: solve_problem(
            build_problem(one), one, session.quiet() if final else session, upstream, validating=final))
    return solve_problem(build_problem(spec), spec, session, upstream)


def solve_problem(problem: Problem, spec: FitSpec, session: Session,
                  upstream: Sequence[Mapping[str, float]] | None = None, validating: bool = True) -> FitResult:
    """Search, assess and gather the result of one built problem; `validating`: search again
    where the fit may have missed (adequacy.py) and refit the halves of long recordings to see
    whether the model holds its parameters (validation.py); a pass that only prepares or
    checks a fit does neither."""
    if not problem.free:
        raise OptionError("fix", f"{', '.join(spec.fix)} leaves nothing to fit on {spec.target_name} (and no "
                                 f"recording estimates its own values)")
    session.say(problem.data_warnings)
    if session.strict and problem.data_warnings:
        raise SuspiciousData(problem.data_warnings)
    session.say(problem.setup_warnings)
    free, values, experiments = problem.free, problem.values, problem.experiments
    residuals = Residuals(experiments, free, values, spec.cost)
    setup = experiments[0].setup
    coarse = Residuals(experiments, free, {**values, **setup.coarse_values}, spec.cost,
                       decimate=setup.coarse_decimate)
    options = spec.global_search
    bar = Progress(problem.name, options.maxiter if options.enabled else 0, session.progress)
    names = ",".join(e.name for e in experiments)
    cache = session.checkpoint.cache(f"{problem.name}:{names}") if session.checkpoint else {}
    try:
        u0 = start_vector(free, values, experiments)
        try:
            outcome, searches = search_until_settled(residuals, coarse, u0, spec.seed_value, options, bar, cache,
                                                     RESTARTS if validating else 0)
        except KeyboardInterrupt:
            raise _interrupted(problem, u0, cache) from None
        bar("uncertainty")
        verdict = assess(outcome, searches)
        method = interval_method(spec.uncertainty, verdict)
        assessed = assess_uncertainty(method, residuals, outcome, spec.replicate_count, upstream, options, bar)
        found = _Found(problem, residuals, outcome, assessed, verdict)
        if method != spec.uncertainty:
            found.notes.append(f"intervals by the {method} instead of the {spec.uncertainty}: the residuals stand far "
                               f"above the sensor noise, which a bootstrap through the sensor model does not see")
        found.failures_note()
        found.at_least_the_sandwich()
        found.stiction()
        found.edges()
        if validating:
            bar("validation")
            found.validate(spec)
        found.notes += without_zero_widths(found.estimates)
        found.statistics()
    finally:
        bar.close()
        residuals.close()
        coarse.close()
    return found.result(spec, physical(free, u0))


def fit_a_half(spec: FitSpec) -> tuple[dict, float] | None:
    """A half of the recordings fitted as the whole was (validation.py): its shared estimates
    and its sum of squares; None when it cannot be simulated."""
    try:
        result = solve_problem(build_problem(spec), spec, Session(progress=False), validating=False)
    except FMUError:
        return None
    return {label: e for label, e in result.estimates.items() if not is_own(label)}, 2.0 * result.cost


def interval_method(asked: str, verdict: dict) -> str:
    """The intervals' method: as asked, but the sandwich for a bootstrap of a fit that misses
    what its recordings show (a bootstrap through the sensor model cannot see the model's
    error, and on such recordings it cost 6-9 times the fit)."""
    return "sandwich" if asked == "bootstrap" and verdict["verdict"] != "adequate" else asked


def _interrupted(problem: Problem, u0: np.ndarray, cache: dict) -> Interrupted:
    """Ctrl-C during the search: the best values found so far, for the command to write."""
    best = best_candidate(cache)
    found = physical(problem.free, u0 if best is None else best)
    shared = {p.name: float(v) for p, v in zip(problem.free, found) if p.experiment is None}
    return Interrupted({**problem.values, **shared}, problem.name)


class _Found:
    """What a search found, on its way to a FitResult: the estimates and their intervals,
    the notes and warnings each step adds, and the fit statistics per recording."""

    def __init__(self, problem: Problem, residuals: Residuals, outcome, assessed, verdict: dict):
        self.problem, self.residuals, self.outcome, self.assessed = problem, residuals, outcome, assessed
        self.verdict = verdict
        self.estimates = assessed.estimates
        self.notes = list(outcome.messages) + assessed.notes
        self.warnings = list(problem.warnings)
        self.found = physical(problem.free, outcome.u)
        self.fitted = {p.name: float(v) for p, v in zip(problem.free, self.found) if p.experiment is None}
        self.fits: list[ExperimentFit] = []
        marked = verdict_warning(verdict)
        if marked:
            self.warnings.append(f"{marked} (or the data are mis-scaled, or the sidecar understates the noise)")

    def failures_note(self) -> None:
        if self.outcome.failures:
            self.notes.append(f"{self.outcome.failures} simulations failed during the fit and were penalized "
                              f"(last: {self.outcome.last_failure or 'no reason reported'})")

    def at_least_the_sandwich(self) -> None:
        """No interval of a fit that misses what its recordings show is narrower than the
        sandwich one (its residuals' own size and correlation), whatever method was asked."""
        if self.verdict["verdict"] == "adequate" or self.assessed.summary.get("method") == "sandwich":
            return
        sandwich, _, _ = sandwich_estimates(self.problem.free, self.outcome.u, self.outcome.jacobian,
                                            self.outcome.residual, self.residuals.series())
        for label, estimate in self.estimates.items():
            wide = sandwich.get(label)
            if estimate.ci95 is None or wide is None or wide.ci95 is None or estimate.method == "bounded":
                continue
            low, high = min(estimate.ci95[0], wide.ci95[0]), max(estimate.ci95[1], wide.ci95[1])
            if (low, high) != tuple(estimate.ci95):
                estimate.ci95, estimate.method = (low, high), f"{estimate.method}, widened to the sandwich"

    def validate(self, spec: FitSpec) -> None:
        """The halves of long recordings refitted (validation.py): on a fit that misses
        something a parameter that moves is marked and its interval widened; on a fit as good
        as the sensors the halves are reported, not judged."""
        adequate = self.verdict["verdict"] == "adequate"
        started = time.perf_counter()
        at_the_split = split_states(self.problem, lambda outputs: self.residuals.simulate(self.outcome.u, outputs))
        residual = self.outcome.residual
        whole = Started(float(residual @ residual), len(residual))
        consistency = validate(spec, self.problem, {**self.problem.values, **self.fitted}, whole,
                               None if adequate else fit_a_half, at_the_split)
        if consistency:  # what the validation cost, beside the search's fit.seconds (scripts/interval_cost.py)
            consistency["seconds"] = time.perf_counter() - started
        self.verdict["windows"] = consistency
        if "note" in consistency:
            self.notes.append(consistency["note"])
        if not adequate:
            hold_the_halves(self.estimates, consistency)
        self.verdict["evidence"] += mark_moving(self.estimates, moving(consistency, adequate))
        if self.verdict["verdict"] != "adequate":
            self.verdict["combinations"] = separately(self.estimates, self.assessed.correlation)

    def stiction(self) -> None:
        """A stage's stiction that the recordings only bound becomes that set (stiction.py)."""
        stage = self.problem.stage
        if stage not in JOINTS:
            return
        try:
            self.notes += bound_stiction(stage, self.residuals, self.outcome.u, self.estimates, self.fitted,
                                         self.assessed.values)
        except FMUError as error:  # the result is written regardless
            self.notes.append(f"the stiction's set could not be checked: the simulation at the result fails "
                              f"({error.reason()})")

    def edges(self) -> None:
        """An estimate at the edge of its box: its flag names the cause, its interval is not a point (edges.py)."""
        explain_edges(self.problem.free, self.outcome, self.estimates, self.assessed.correlation,
                      self.problem.experiments, self.verdict["spread"], MODEL_ERROR_LIMIT)

    def statistics(self) -> None:
        free = self.problem.free
        final = [self.fitted.get(p.name, v) if p.experiment is None else v for p, v in zip(free, self.found)]
        try:
            self.fits = experiment_fits(self.residuals, unit_of(free, final))
        except FMUError as error:
            self.notes.append(f"the simulation at the result fails ({error.reason()}): no fit statistics")
        if self.verdict["verdict"] != "adequate":
            self.warnings += drift_warnings(self.fits)

    def result(self, spec: FitSpec, start: np.ndarray) -> FitResult:
        problem, outcome = self.problem, self.outcome
        initial: dict[str, dict[str, float]] = {}
        for p, value in zip(problem.free, self.found):
            if p.experiment is not None:
                initial.setdefault(p.experiment, {})[p.name] = float(value)
        warnings = self.warnings + flag_warnings(self.estimates)
        warnings += [note for note in self.notes if note.startswith("the local refinement stopped")]
        origin = fit_record(problem, spec, start)
        return FitResult(problem.name, {**problem.values, **self.fitted}, self.estimates, self.assessed.correlation,
                         0.5 * float(outcome.residual @ outcome.residual), nrmse(self.fits), outcome.nfev,
                         outcome.failures, outcome.seconds, self.fits, initial, self.notes, warnings=warnings,
                         uncertainty=self.assessed.summary, replicates=self.assessed.replicates,
                         model=problem.model_file, provenance=origin, assessment=self.verdict)


DRIFT_RATIO = 10.0
DRIFT_START = 0.05
"""A recording's error after its first DRIFT_START (a twentieth) DRIFT_RATIO times the error
within it, and beyond MODEL_ERROR_LIMIT times the noise: the simulation runs away from the
recording (drift_warnings)."""


def drift_warnings(fits: Sequence[ExperimentFit]) -> list[str]:
    """A hint where a fit is poor because the simulation drifts: an open-loop replay of a
    closed-loop or unstable run (a balanced pendulum, a stage under position control) leaves
    the recording further and further behind from a start where it agreed, and no parameter
    value can fix that. Said when the RMS error of a recorded signal after its first
    twentieth is DRIFT_RATIO times the error within it (the start is where the replay and
    the recording agree best: both begin from the same state) and stands above the noise
    by more than a fit's residuals may (MODEL_ERROR_LIMIT): a cart at rest before its ramp
    starts with no error at all, and the quantization's error after it is no drift."""
    found = []
    for fit in fits:
        for column, recorded in fit.recorded.items():
            error = fit.simulated[column] - recorded
            error = error[np.isfinite(error)]
            start = max(10, int(DRIFT_START * len(error)))
            if len(error) < 2 * start:
                continue
            early, late = (float(np.sqrt(np.mean(part**2))) for part in (error[:start], error[start:]))
            if late > DRIFT_RATIO * early and late > MODEL_ERROR_LIMIT * fit.scale.get(column, 0.0):
                growth = f"{late / early:.3g}-fold" if early > 0 else "from nothing"
                found.append(f"{fit.name}: the simulated {column} drifts away from the recording (its error grows "
                             f"{growth} after the first twentieth of the run): the model misses something that "
                             f"adds up over the run (a friction term, a drive constant), or the run was closed-loop "
                             f"or unstable, which an open-loop replay cannot follow; for the latter fit it in "
                             f"segments with their own initial states (segment, or windows), or with its controller "
                             f"in the loop (an SSP system)")
    return found


def experiment_fits(residuals: Residuals, u: np.ndarray) -> list[ExperimentFit]:
    """Recorded against simulated signals of each experiment at `u`, with the values it ran with."""
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
