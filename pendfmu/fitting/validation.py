"""Validation built into the fit: the model against data it did not fit.

Every recording long enough is split in two halves, early and late (for a free decay: large
amplitude and small); the early halves are fitted together on their own, and so are the
late ones. A parameter whose two estimates differ by more than their combined 95 % interval
(the hypotenuse of the two half-widths) moves with time or amplitude: the model does not hold
it fixed over the recordings. How the halves are fitted depends on the fit: one as good as
the sensors allow is refitted locally from its optimum with sandwich intervals
(statistics.sandwich_covariance), which is cheap; one that misses something is fitted as the
whole was (its global search and intervals), because there a half may have minima the
whole does not (a cart's late half alone put eta at 0.065 where the whole put it at 0.99).

What follows from it (solve.py): on a fit whose residuals stand far above the noise
(adequacy.py), every interval is widened to hold both halves' estimates (what the validation
sees), and each parameter that moves is flagged `model-inadequate`; a pair the data determine
only as a combination is flagged `not-separately-identified` with that combination. On a fit
whose residuals are as small as the sensors allow, the halves are reported, not judged: the
model follows every recording within the noise, and recordings precise enough tell its
halves apart by what no sensor shows. On the wide coverage benchmark (recordings of the
model by the independent reference simulator) a cart fitted after the current loop, whose
estimates it takes as known and which are 0.1 % from the truth, moved eta by 6e-5 between
its halves, 13 sandwich intervals; another's late halves alone ended in another basin (eta
0.12 for 0.28). Judged by their intervals, 18 of 25 such carts were called model-inadequate
on recordings of their own model, while their 95 % intervals held the truth 97 % of the
time. Nor does a half's prediction of the other settle it: with the half's own initial
states kept, a shift of 1.5e-4 in eta put a cart's late half at 264 times the noise (its
stick-slip moved).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace

import numpy as np

from pendfmu.errors import FMUError
from pendfmu.fitting.labels import is_own
from pendfmu.fitting.optimizer import local_search
from pendfmu.fitting.problem import Problem, build_problem, start_vector
from pendfmu.fitting.residuals import Residuals, physical, unit_of
from pendfmu.fitting.result import Estimate, Flag
from pendfmu.fitting.spec import FitSpec
from pendfmu.fitting.statistics import CORRELATION_LIMIT, Z95, sandwich_estimates

MIN_HALF = 400  # samples each half of a recording must hold for it to be split
WHICH = ("early", "late")
# A half whose refit leaves more than this times the whole fit's squared error (Started)
# did not start where its recordings are: no validation by halves.
START_LIMIT = 2.0


def halves(problem: Problem, at_the_split: Mapping[str, Mapping[str, float]] | None = None) -> dict[str, list]:
    """The early and the late halves (Recordings) of every recording long enough; a late
    half knows the initial states of `at_the_split` (split_states) as its own parameters."""
    found: dict[str, list] = {which: [] for which in WHICH}
    for experiment in problem.experiments:
        recording = experiment.recording
        if not long_enough(recording):
            continue
        middle = float(recording.time[split_index(recording)])
        late = recording.window(middle, float(recording.time[-1]))
        states = (at_the_split or {}).get(experiment.name)
        if states:
            late = replace(late, parameters={**late.parameters, **states})
        found["early"].append(recording.window(float(recording.time[0]), middle))
        found["late"].append(late)
    return found


def long_enough(recording) -> bool:
    """Whether a recording is split: each half holds at least MIN_HALF samples."""
    return len(recording.time) >= 2 * MIN_HALF


def split_index(recording) -> int:
    """The sample where the early half ends and the late one starts (both hold it)."""
    return len(recording.time) // 2


def split_states(problem: Problem, simulate: Callable[[tuple[str, ...]], list[dict[str, np.ndarray]]]
                 ) -> dict[str, dict[str, float]]:
    """Per recording to be split, each initial state its late half cannot tell (Setup.unseen:
    a foreign cart's v0 where only x is recorded), as the fit's simulation has it at the
    split. Without this the late half started at the file's first speed: a foreign cart
    moving at the split was refitted from rest, its late half ending 40 % to 180 % off in
    every parameter after 2,900 simulations (the early half: 22). `simulate(outputs)` is
    the fit's simulation at its optimum (Residuals.simulate); {} when it fails."""
    experiments = [e for e in problem.experiments if e.setup.unseen and long_enough(e.recording)]
    outputs = tuple(dict.fromkeys(o for e in experiments for o in e.setup.unseen.values()))
    if not outputs:
        return {}
    try:
        simulated = dict(zip((e.name for e in problem.experiments), simulate(outputs)))
    except (FMUError, ArithmeticError):
        return {}
    found = {}
    for experiment in experiments:
        middle = split_index(experiment.recording)
        states = {p: float(simulated[experiment.name][o][middle]) for p, o in experiment.setup.unseen.items()}
        found[experiment.name] = {p: v for p, v in states.items() if math.isfinite(v)}
    return found


def part_spec(spec: FitSpec, recordings: list, values: Mapping[str, float], search: bool) -> FitSpec:
    """The spec of a part: the same fit on these recordings only, from `values` (the fit's
    optimum); with the fit's own global search, or locally with Jacobian intervals."""
    local = {} if search else dict(seed=None, uncertainty="jacobian", replicates=None,
                                   global_search=replace(spec.global_search, enabled=False))
    return spec.with_options(recordings=tuple(recordings), params=dict(values), windows=(), segment=None,
                             start=None, **local)


class LocalPart:
    """A half refitted locally from the fit's optimum, with sandwich intervals, kept open so
    that the other half's values can be tried on it (`spread_with`). Close it after use."""

    def __init__(self, spec: FitSpec):
        self.problem = build_problem(spec)
        self.residuals = Residuals(self.problem.experiments, self.problem.free, self.problem.values, spec.cost)
        self.u: np.ndarray | None = None
        self.squares = math.nan  # the refit's sum of squared scaled residuals

    def refit(self) -> dict[str, Estimate] | None:
        """The shared estimates refitted; None when the half cannot be simulated."""
        problem = self.problem
        try:
            u, jacobian, residual, _ = local_search(self.residuals, start_vector(problem.free, problem.values,
                                                                                   problem.experiments), rounds=1)
            estimates, _, _ = sandwich_estimates(problem.free, u, jacobian, residual, self.residuals.series())
        except (FMUError, ArithmeticError, np.linalg.LinAlgError):
            return None
        self.u, self.squares = u, float(residual @ residual)
        return {label: e for label, e in estimates.items() if not is_own(label)}

    def spread_with(self, shared: Mapping[str, Estimate]) -> float | None:
        """The RMS of this half's scaled residuals (1 at the noise) with the shared values
        of `shared` and its own initial states; None when that cannot be simulated."""
        free = self.problem.free
        own = physical(free, self.u)
        values = [shared[p.label].value if p.label in shared else own[k] for k, p in enumerate(free)]
        try:
            residual = self.residuals(unit_of(free, values))
        except (FMUError, ArithmeticError):
            return None
        return float(np.sqrt(np.mean(residual ** 2))) if len(residual) else None

    def close(self) -> None:
        self.residuals.close()


def local_parts(specs: Mapping[str, FitSpec]) -> tuple[dict, dict | None]:
    """Both halves refitted locally (LocalPart): per half (its shared estimates, its sum of
    squares), None for a half that could not be simulated; and how each half's values
    predict the other: {"early on late": spread, "late on early": spread}."""
    parts = {which: LocalPart(spec) for which, spec in specs.items()}
    try:
        found = {which: part.refit() for which, part in parts.items()}
        if any(estimates is None for estimates in found.values()):
            return dict.fromkeys(parts), None
        early, late = WHICH
        prediction = {f"{early} on {late}": parts[late].spread_with(found[early]),
                      f"{late} on {early}": parts[early].spread_with(found[late])}
        return {which: (found[which], part.squares) for which, part in parts.items()}, prediction
    finally:
        for part in parts.values():
            part.close()


def validate(spec: FitSpec, problem: Problem, values: Mapping[str, float], whole: Started,
             fit_part: Callable[[FitSpec], tuple[dict[str, Estimate], float] | None] | None = None,
             at_the_split: Mapping[str, Mapping[str, float]] | None = None) -> dict:
    """The early and late halves refitted and compared (module docstring): per part its
    estimates, and per parameter how far it moves, in combined intervals, and which way.
    `fit_part` fits a part as the whole was fitted (its global search and intervals: a fit
    that misses something), returning its shared estimates and its sum of squares; without
    it each part is refitted locally (LocalPart), and each half's values tried on the other.
    `whole`: what the whole fit left (Started); `at_the_split`: split_states."""
    split = halves(problem, at_the_split)
    if not split["early"]:
        return {}
    search = fit_part is not None
    specs = {which: part_spec(spec, split[which], values, search) for which in WHICH}
    if search:
        fitted, prediction = {which: fit_part(s) for which, s in specs.items()}, None
    else:
        fitted, prediction = local_parts(specs)
    if any(part is None for part in fitted.values()):
        return {"note": "a half could not be simulated at the fit's optimum: no validation"}
    squares = {which: value for which, (_, value) in fitted.items()}
    astray = whole.astray(squares)
    if astray:
        return {"note": whole.note(astray, squares[astray], [r.label for r in split[astray]])}
    parts = {which: estimates for which, (estimates, _) in fitted.items()}
    parameters = {name: _movement(parts["early"][name], parts["late"].get(name)) for name in parts["early"]}
    found = {"recordings": [r.label for r in split["early"]],
             "method": "fits of the halves" if search else "local refits of the halves, sandwich intervals",
             "halves": {which: {name: _row(e) for name, e in part.items()} for which, part in parts.items()},
             "parameters": {name: moved for name, moved in parameters.items() if moved is not None}}
    if prediction is not None:
        found["prediction"] = prediction
    return found


@dataclass(frozen=True)
class Started:
    """What the whole fit left, to tell whether a half started where its recordings are.
    At the whole fit's values a half that starts where the whole fit's simulation has its
    recordings reproduces the whole fit's residuals on its samples, a part of the whole's
    sum of squares, and its refit can only lower that. A half whose refit leaves more than
    START_LIMIT times that sum (at least one per sample: the noise) started elsewhere, and
    its estimates say nothing of the model: an FMU with no parameter for a state at the
    split (a pythonfmu slider with no x0 started its late half at rest at x = 0, 13,000
    times the noise from its recording, and reported c 40 [0.037, 43420] for the truth 4),
    or an initial state given as a parameter, which holds for every window (EMPS's late
    half began at the file's first position, 66 times the whole's squared error, said M
    76.3 kg for 94.9, and widened M's interval to [76.3, 95.2])."""

    squares: float  # the whole fit's sum of squared scaled residuals
    samples: int  # and their number

    def astray(self, squares: Mapping[str, float]) -> str | None:
        """The first half (of `squares`: its refit's sum of squares) that did not start
        where its recordings are, or None."""
        limit = START_LIMIT * max(self.squares, self.samples)
        return next((which for which, value in squares.items() if not value <= limit), None)

    def note(self, which: str, squares: float, recordings: list[str]) -> str:
        return (f"not validated by halves: refitted alone, the {which} halves ({', '.join(recordings)}) leave a sum "
                f"of squared scaled errors of {squares:.4g} where the whole fit left {self.squares:.4g} on all its "
                f"samples, so they cannot start where their recordings are: the model has no initial-value "
                f"parameter for a state at the split, or nothing recorded tells it (name it with --initial "
                f"SIGNAL=PARAMETER)")


def _movement(early: Estimate, late: Estimate | None) -> dict | None:
    """How far a parameter moves from the early halves to the late, in combined intervals;
    None when the halves give no finite interval to measure it by (a half at its box's edge
    whose refits never moved has a zero-width one: no scale, not an infinite move)."""
    if late is None or early.ci95 is None or late.ci95 is None:
        return None
    combined = math.hypot((early.ci95[1] - early.ci95[0]) / 2, (late.ci95[1] - late.ci95[0]) / 2)
    if not (math.isfinite(combined) and combined > 0):
        return None
    change = late.value - early.value
    return {"early": early.value, "late": late.value, "ratio": abs(change) / combined,
            "direction": "rises" if change > 0 else "falls"}


def moving(consistency: Mapping, adequate: bool) -> dict[str, dict]:
    """The parameters whose halves disagree beyond their combined interval, on a fit that
    misses something; none on a fit as good as the sensors (module docstring)."""
    if adequate:
        return {}
    return {name: moved for name, moved in consistency.get("parameters", {}).items() if moved["ratio"] > 1.0}


def hold_the_halves(estimates: dict[str, Estimate], consistency: Mapping) -> None:
    """Every interval widened to hold both halves' estimates: on a fit that misses
    something, what the validation sees is part of the uncertainty."""
    for name, moved in consistency.get("parameters", {}).items():
        estimate = estimates.get(name)
        if estimate is None or estimate.ci95 is None:
            continue
        low = min(estimate.ci95[0], moved["early"], moved["late"])
        high = max(estimate.ci95[1], moved["early"], moved["late"])
        if (low, high) != tuple(estimate.ci95):
            estimate.ci95, estimate.method = (low, high), f"{estimate.method}, widened to the halves"


def mark_moving(estimates: dict[str, Estimate], moved: Mapping[str, dict]) -> list[str]:
    """Each moving parameter flagged model-inadequate; the evidence, one line per parameter."""
    evidence = []
    for name, m in moved.items():
        estimate = estimates.get(name)
        if estimate is None:
            continue
        text = (f"model-inadequate: refitted on the early and on the late halves of the recordings it "
                f"{m['direction']} from {m['early']:.4g} to {m['late']:.4g}, {m['ratio']:.2g} times their "
                f"combined 95 % interval: the model does not hold it fixed over the recordings (for a decay: with "
                f"amplitude)")
        estimate.flags.append(Flag(text, "model-inadequate"))
        evidence.append(f"{name} {m['direction']} from {m['early']:.4g} (early halves) to {m['late']:.4g} (late)")
    return evidence


def _row(estimate: Estimate) -> list[float | None]:
    """[value, low, high] for the result file (an open or missing end: None)."""
    ends = estimate.ci95 or (math.nan, math.nan)
    return [v if math.isfinite(v) else None for v in (estimate.value, *ends)]


def separately(estimates: dict[str, Estimate], correlation: Mapping[str, Mapping[str, float | None]]
               ) -> list[dict]:
    """Pairs the recordings determine only as a combination (correlation beyond the
    statistics' limit), on a fit that misses something: each member flagged
    `not-separately-identified`, and the combination that is determined, for positive
    quantities a power product a^p * b^q (the principal axis of the pair's log-scale
    covariance with the smallest spread), with its 95 % interval."""
    found = []
    names = [n for n in estimates if not is_own(n)]
    for k, a in enumerate(names):
        for b in names[k + 1:]:
            rho = (correlation.get(a) or {}).get(b)
            if rho is None or abs(rho) <= CORRELATION_LIMIT:
                continue
            combination = _combination(estimates[a], estimates[b], rho)
            if combination is None:
                continue
            found.append(combination)
            for member, other in ((a, b), (b, a)):
                estimates[member].flags.append(Flag(
                    f"not-separately-identified: correlated {rho:+.3f} with {other} on a fit that misses what the "
                    f"recordings show: only {combination['text']} is determined; the split between the two is "
                    f"not, and may lie anywhere along it within the search box", "not-separately-identified"))
    return found


def _combination(a: Estimate, b: Estimate, rho: float) -> dict | None:
    """The determined power product of two positive estimates, or None (a sign change, no spread)."""
    if not (a.value > 0 and b.value > 0 and a.stderr and b.stderr):
        return None
    sa, sb = a.stderr / a.value, b.stderr / b.value
    covariance = np.array([[sa * sa, rho * sa * sb], [rho * sa * sb, sb * sb]])
    variances, axes = np.linalg.eigh(covariance)
    axis = axes[:, 0]
    largest = axis[int(np.argmax(np.abs(axis)))]  # the larger power is +1: k_fwp * T_Kp^0.84, not k_fwp^-1 ...
    p, q = axis / largest
    log_value = p * math.log(a.value) + q * math.log(b.value)
    half = Z95 * math.sqrt(max(variances[0], 0.0)) / abs(largest)
    text = f"{a.label}^{p:.3g} * {b.label}^{q:.3g} = {math.exp(log_value):.6g}"
    return {"pair": [a.label, b.label], "powers": [float(p), float(q)], "value": math.exp(log_value),
            "ci95": [math.exp(log_value - half), math.exp(log_value + half)], "text": text}
