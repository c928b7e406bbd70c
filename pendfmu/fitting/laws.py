"""Which friction law do the recordings support: the candidate laws fitted and ranked.

    comparison = pendfmu.compare_laws("pendulum", ["decay.csv"], "params.json", seed=0)
    print(comparison.table())
    comparison.recommended, comparison.reason

The candidates are the ladder of ladder.py: viscous only, + Coulomb, + stiction (the paper's
law, docs/user-guide/model.md), + Stribeck, + direction asymmetry, + offset, + air drag (the
pendulum), each the one below plus a term of friction.h's law.

Each law is a fit of the stage as `pendfmu fit` makes it (the same FitSpec, with the law's
terms free and the others fixed at 0), made twice: to the whole recordings (for its BIC) and
to their early halves (validation.halves), which then predicts the late halves with only
their own initial states refitted (the held-out error). ranking.py ranks the laws and
recommends one. Where no recording is long enough to halve and there are several, the last
is held out and predicted from a fit of the others.

`laws` chooses some of the rungs (ladder.law_terms), so that a slow rung can be left out.

The fits are independent jobs, run on the global search's workers or Dask scheduler
(bootstrap.parallel_map), each with a global search of one process, in three rounds:

1. the laws whose new terms have search boxes of their own (up to Stribeck), fitted to the
   whole recordings from the given values (an extra term from its box's middle: ladder._extra_boxes);
2. the laws above them (asymmetry, offset, drag), from the optimum of the highest one, their
   new terms off; and the first laws' early halves, each from its own whole-data optimum;
3. the early halves of the laws above.

Every fit after the first round searches the first round's boxes (keep_boxes), not a decade
around its start. An asymmetry or an offset has a sign and a size only the rig knows
(docs/user-guide/friction.md): unless bounds are given, an asymmetry is searched up to the size of the term it
skews in the law below, an offset up to the largest Coulomb friction the stage would search
(ladder.second_round_boxes).

A law that holds the one below it (its new terms at their off end are that law: Rung.nests)
can fit at least as well. One whose search ended above it missed, and is fitted again locally
from the lower law's optimum (the comparison's notes say which), so the table reads as a
ladder. Each law's fit is the stage's search without its restarts and validation
(adequacy.py, validation.py): the comparison is itself the validation, and the nested refit
its restart.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace

from pendfmu.errors import OptionError, PendfmuError
from pendfmu.fitting.adequacy import SAME_COST
from pendfmu.fitting.bootstrap import parallel_map
from pendfmu.fitting.labels import is_own
from pendfmu.fitting.ladder import FIRST_ROUND, Rung, ladder, law_parameters, law_spec, second_round_boxes
from pendfmu.fitting.optimizer import local_search
from pendfmu.fitting.problem import Problem, build_problem, given_values, start_vector
from pendfmu.fitting.ranking import LawComparison, LawRow, Misfit, PartFit, information, recommend, summarize
from pendfmu.fitting.residuals import Residuals
from pendfmu.fitting.result import FitResult
from pendfmu.fitting.solve import Session, experiment_fits, solve_problem
from pendfmu.fitting.spec import FitSpec, check_applicable
from pendfmu.fitting.stages import derived_box
from pendfmu.fitting.validation import halves, part_spec
from pendfmu.friction import JOINTS, Joint

NOT_TAKEN = {"uncertainty": "the comparison ranks the laws by their errors and gives no intervals; fit the law "
                            "it recommends with pendfmu fit for them",
             "replicates": "counts the bootstrap's refits; the comparison makes none"}


@dataclass(frozen=True)
class HeldOut:
    """The data a law is fitted to (`fitted`) and the data its fit predicts (`predicted`),
    and which they are, in words."""

    fitted: tuple = ()
    predicted: tuple = ()
    how: str = ""


def held_out(problem: Problem) -> HeldOut:
    """The early halves against the late (validation.halves), else the last recording
    against the others, else nothing."""
    split = halves(problem)
    if split["early"]:
        names = ", ".join(sorted({r.path.stem if r.path else r.label for r in split["early"]}))
        return HeldOut(tuple(split["early"]), tuple(split["late"]),
                       f"the late half of each recording long enough to halve ({names}), predicted by the law "
                       f"fitted to the early halves")
    recordings = [e.recording for e in problem.experiments]
    if len(recordings) > 1:
        return HeldOut(tuple(recordings[:-1]), tuple(recordings[-1:]),
                       f"{recordings[-1].label}, predicted by the law fitted to the other recordings")
    return HeldOut(how="none: the recording is too short to halve, and there is no other")


@dataclass(frozen=True)
class Job:
    """One law fitted to one part of the data; an early part's fit predicts `predicted`.
    `own`: starts of the recordings' own estimates (a lower law's initial states, by label)."""

    law: str
    part: str
    spec: FitSpec
    predicted: tuple = ()
    own: Mapping[str, float] = field(default_factory=dict)


def run_job(job: Job) -> PartFit:
    """Fit a law (the stage's own search, no restarts or validation: the comparison is the
    validation) and predict the held-out data; a failure is recorded, never raised (the
    job may run in a worker process or on a Dask worker)."""
    started = time.perf_counter()
    try:
        problem = build_problem(job.spec)
        start_own(problem, job.own)
        result = solve_problem(problem, job.spec, Session(progress=False), validating=False)
        found = part_fit(result)
        if job.predicted:
            found.held_out = predict(job.spec, result, job.predicted)
    except PendfmuError as error:
        found = PartFit(failed=f"{type(error).__name__}: {error}")
    found.seconds = time.perf_counter() - started
    return found


def failed_job(job: Job, reason: str) -> PartFit:
    """The fit of a job whose worker died on every try."""
    return PartFit(failed=reason)


def start_own(problem: Problem, own: Mapping[str, float]) -> None:
    """Start each recording's own estimates (its initial states) at `own`'s values where
    they lie in their search boxes. Why: a fit from a lower law's optimum must start at
    that law whole; from the first readings instead (a Furuta swing's release angle, 0.65
    rad from the optimum's with a free encoder offset and scale) the asymmetry's refinement
    ended at 3.7 times the lower law's RMS."""
    experiments = {experiment.name: experiment for experiment in problem.experiments}
    for p in problem.free:
        value = own.get(p.label)
        if p.experiment is not None and value is not None and p.low <= value <= p.high:
            _, low, high = experiments[p.experiment].estimated[p.name]
            experiments[p.experiment].estimated[p.name] = (value, low, high)


def part_fit(result: FitResult) -> PartFit:
    """What the ranking needs of a fit."""
    shared = {label: e for label, e in result.estimates.items() if not is_own(label)}
    misfit = summarize(result.experiments)
    failed = None if misfit.samples else "the simulation at the result fails: no residuals"
    return PartFit({label: e.value for label, e in shared.items()}, dict(result.parameters),
                   {label: (e.low, e.high) for label, e in shared.items()}, misfit, len(result.estimates),
                   own={label: e.value for label, e in result.estimates.items() if is_own(label)}, failed=failed)


def predict(spec: FitSpec, result: FitResult, recordings: Sequence) -> Misfit:
    """The held-out recordings simulated with the fit's values, only their own initial
    states refitted (a late half starts mid-motion): their scaled residuals."""
    shared = tuple(label for label in result.estimates if not is_own(label))
    bounds = {name: box for name, box in spec.bounds.items() if name not in shared}
    part = part_spec(spec.with_options(fix=(*spec.fix, *shared), bounds=bounds), list(recordings), result.parameters,
                     search=False)
    problem = build_problem(part)
    residuals = Residuals(problem.experiments, problem.free, problem.values, part.cost)
    try:
        u = start_vector(problem.free, problem.values, problem.experiments)
        if problem.free:
            u, _, _, _ = local_search(residuals, u)
        return summarize(experiment_fits(residuals, u))
    finally:
        residuals.close()


class _Ladder:
    """The laws of one stage's comparison, their specs and their fits."""

    def __init__(self, spec: FitSpec, joint: Joint, rungs: list[Rung], given: dict[str, float],
                 say: Callable[[str], None]):
        self.spec, self.joint, self.rungs, self.given, self.say = spec, joint, rungs, given, say
        self.split = HeldOut()  # until the stage's own problem tells the halves
        self.reach = 0.0  # the largest offset searched (second_round_boxes), from the stage's own problem
        self.fits: dict[tuple[str, str], PartFit] = {}
        self.boxes: dict[str, dict[str, tuple[float, float]]] = {}  # per law: its terms without boxes of their own
        self.first_boxes: dict[str, tuple[float, float]] = {}  # keep_boxes
        self.notes: list[str] = []

    def job(self, k: int, part: str, start: PartFit | None = None, local: bool = False, nested: bool = False
            ) -> Job:
        """Rung k's fit to `part`, from the given values or from the fit `start` (its values
        and its recordings' initial states)."""
        rung = self.rungs[k]
        boxes = {**self.first_boxes, **self.boxes.get(rung.name, {})}
        values, own = (start.values, start.own) if start else (None, {})
        spec = law_spec(self.spec, self.joint, self.rungs, k, self.given, values, boxes, local, nested)
        if part == "whole":
            return Job(rung.name, part, spec, own=own)
        return Job(rung.name, part, part_spec(spec, list(self.split.fitted), spec.params, search=True),
                   self.split.predicted, own)

    def run(self, jobs: list[Job], what: str) -> None:
        if not jobs:
            return
        search = self.spec.global_search
        self.say(f"{len(jobs)} fits: {what}")
        for job, found in zip(jobs, parallel_map(run_job, jobs, search.workers, search.scheduler, failed=failed_job)):
            self.fits[job.law, job.part] = found

    def fitted(self, k: int, part: str) -> PartFit | None:
        found = self.fits.get((self.rungs[k].name, part))
        return None if found is None or found.failed else found

    def rounds(self) -> None:
        """Three rounds of parallel fits (module docstring): the laws with boxes of their own
        to the whole recordings; then the others from the highest one's optimum, and the
        first ones' early halves from their own optimum; then the others' early halves."""
        first = [k for k, rung in enumerate(self.rungs) if rung.name in FIRST_ROUND]
        second = [k for k in range(len(self.rungs)) if k not in first]
        self.run([self.job(k, "whole") for k in first], "the laws with boxes of their own, whole recordings")
        self.keep_boxes(first)
        base = self.fitted(first[-1], "whole")
        if second and base is None:
            self.notes.append(f"the {self.rungs[first[-1]].label} law's fit failed, so the laws above it were not "
                              f"fitted")
            second = []
        for k in second:
            self.boxes[self.rungs[k].name] = second_round_boxes(self.joint, base, self.reach)
        self.run([self.job(k, "whole", base, nested=True) for k in second] + self.early_jobs(first),
                 f"the laws above {self.rungs[first[-1]].label} from its optimum, whole recordings; "
                 f"the laws up to it, early halves")
        self.run(self.early_jobs(second), f"the laws above {self.rungs[first[-1]].label}, early halves")

    def keep_boxes(self, ks: Sequence[int]) -> None:
        """The first round's search boxes, for every later fit: a fit started from a law's
        optimum would otherwise search a decade around it (a given value's box), and where
        that law is wrong (a stiction law's Coulomb friction at its lower bound on a rig with
        an offset torque) the right value lay outside. The stiction's box is a ratio to the
        Coulomb friction (stages.py), which bounds cannot give: it is left to the stage."""
        for k in ks:
            found = self.fitted(k, "whole")
            for name, box in (found.boxes if found else {}).items():
                if name != self.joint.stiction:
                    self.first_boxes.setdefault(name, box)

    def base_index(self) -> int:
        """The highest law whose terms have boxes of their own: the second round's start."""
        return max(k for k, rung in enumerate(self.rungs) if rung.name in FIRST_ROUND)

    def early_jobs(self, ks: Sequence[int]) -> list[Job]:
        """The early halves' fits, each started (besides its global search) from its law's
        optimum on the whole recordings: the search finds the early halves' own minimum,
        the start only helps it there."""
        if not self.split.fitted:
            return []
        return [self.job(k, "early", whole) for k in ks if (whole := self.fitted(k, "whole"))]

    def nested(self) -> None:
        """A law that holds the law below it (Rung.nests) but whose search ended above it,
        fitted again locally from that law's optimum."""
        for part in ("whole", "early"):
            for k in range(1, len(self.rungs)):
                lower, found = self.fitted(k - 1, part), self.fits.get((self.rungs[k].name, part))
                if not self.rungs[k].nests or lower is None or found is None:
                    continue
                if not found.failed and found.residuals.squares <= (1 + SAME_COST) * lower.residuals.squares:
                    continue
                self.refit(k, part, lower, found)

    def refit(self, k: int, part: str, lower: PartFit, found: PartFit) -> None:
        rung, below = self.rungs[k], self.rungs[k - 1]
        before = f"failed: {found.failed}" if found.failed else \
            f"RMS {found.residuals.rms:.4g} against {lower.residuals.rms:.4g}"
        start = replace(lower, values=dict(lower.values))
        if rung.name == "stiction":  # at the Coulomb friction: the law below
            start.values[self.joint.stiction] = lower.values.get(self.joint.coulomb, 0.0)
        again = run_job(self.job(k, part, start, local=True, nested=True))
        if again.failed or not (found.failed or again.residuals.squares < found.residuals.squares):
            self.notes.append(f"{rung.label} ({part}): its search ended above {below.label} ({before}), and a local "
                              f"refit from {below.label}'s optimum did not do better")
            return
        again.note = f"refitted locally from {below.label}'s optimum: its own search ended above it ({before})"
        self.notes.append(f"{rung.label} ({part}): {again.note}")
        again.seconds += found.seconds
        self.fits[rung.name, part] = again

    def rows(self) -> list[LawRow]:
        rows = []
        for k, rung in enumerate(self.rungs):
            whole = self.fits.get((rung.name, "whole")) or PartFit(failed="not fitted")
            terms = law_parameters(self.joint, self.rungs, k)
            below = law_parameters(self.joint, self.rungs, k - 1) if k else ()
            rows.append(LawRow(rung.name, rung.label, terms, tuple(n for n in terms if n not in below), whole,
                               self.fits.get((rung.name, "early"))))
        return rows


def laws_spec(stage: str, recordings, params, options: Mapping) -> FitSpec:
    """The comparison's FitSpec, with what does not apply to it refused (OptionError)."""
    for option, why in NOT_TAKEN.items():
        if option in options:
            raise OptionError(option, why)
    spec = FitSpec(stage, recordings, {} if params is None else params, **options)
    if spec.kind != "stage" or spec.target not in JOINTS:
        raise OptionError("target", f"the laws compared are a joint's friction: the cart or the pendulum stage, not "
                                    f"{spec.target_name}")
    joint = JOINTS[spec.target]
    varied = [name for name in joint.parameters if name != joint.viscous]
    for option in ("free", "fix", "per_recording"):
        named = [name for name in getattr(spec, option) if name in varied]
        if named:
            raise OptionError(option, f"{', '.join(named)}: the comparison frees and fixes the friction law's terms "
                                      f"itself, one rung of the ladder at a time; give their boxes with bounds")
    check_applicable(spec)
    return spec


def compare_laws(stage: str, recordings, params=None, *, laws: Sequence[str] | None = None,
                 say: Callable[[str], None] | None = None, warn: Callable[[str], None] | None = None,
                 **options) -> LawComparison:
    """Fit the candidate friction laws of a stage's joint and rank them (module docstring).

    Parameters
    ----------
    stage : {'cart', 'pendulum'}
        The stage whose joint's friction is compared.
    recordings : sequence of paths or Recording
        The stage's recordings, as for fit.
    params : mapping or path, optional
        Known values and the start of the fitted ones, as for fit.
    laws : sequence of str, optional
        The rungs to compare (default: all the joint has): viscous, coulomb, stiction,
        stribeck, asymmetry, offset, drag. Each adds its terms to the one before it among
        them; the paper's three include the ones below them whether named or not.
    say : callable, optional
        Called with a line on each round of fits (progress).
    warn : callable, optional
        Called with each warning about the recordings and the set-up, before any fit.
    **options
        The fields of FitSpec that apply (free, fix, bounds, drive, match, per_recording,
        windows, segment, start, cost, seed, global_search); free and fix may not name the
        law's terms, and uncertainty and replicates are refused (OptionError).

    Returns
    -------
    LawComparison
        The laws with their fits, the ranking (table()), the recommended law and the reason
        (to_dict() for the file).
    """
    started = time.perf_counter()
    spec = laws_spec(stage, recordings, params, options)
    joint, given = JOINTS[spec.target], given_values(spec)
    steps = _Ladder(spec, joint, ladder(joint, laws), given, say or (lambda line: None))
    own = build_problem(steps.job(steps.base_index(), "whole").spec)  # reads and checks the recordings
    for warning in own.warnings:
        if warn:
            warn(warning)
    steps.split = held_out(own)
    steps.reach = (derived_box(joint.coulomb, own.values, own.experiments) or (0.0, 0.0))[1]
    steps.rounds()
    steps.nested()
    rows = steps.rows()
    effective = information(rows)
    recommended, reason = recommend(rows)
    notes = steps.notes + [f"{row.label}: its fit failed ({row.failed})" for row in rows if row.failed]
    return LawComparison(spec.target, rows, recommended, reason, steps.split.how, effective, notes=notes,
                         seconds=time.perf_counter() - started, request=spec.request())
