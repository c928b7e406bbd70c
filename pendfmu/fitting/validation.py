"""Validation built into the fit: the model against data it did not fit.

Every recording long enough is split in two halves (early and late: for a free decay, large
amplitude and small), and each half is refitted on its own, locally from the fit's optimum,
with sandwich intervals (statistics.sandwich_covariance: right when the residuals are
correlated and larger than the noise, as where the model misses something). A parameter
whose halves differ by more than their combined 95 % interval (the hypotenuse of the two
half-widths) moves with time or amplitude: the model does not hold it fixed across the
recording.

What follows from it (solve.py): on a fit whose residuals stand far above the noise (adequacy.py),
each parameter that moves is flagged `model-inadequate`, its interval widened to hold both
halves' estimates; a pair the data determine only as a combination is flagged
`not-separately-identified` with that combination. On a fit whose residuals are as small as
the sensors allow, one in twenty parameters disagrees by chance, so only a disagreement of
twice the combined interval counts.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import replace

import numpy as np

from pendfmu.errors import FMUError
from pendfmu.fitting.labels import is_own
from pendfmu.fitting.optimizer import local_search
from pendfmu.fitting.problem import Problem, build_problem, start_vector
from pendfmu.fitting.residuals import Residuals
from pendfmu.fitting.result import Estimate, Flag
from pendfmu.fitting.spec import FitSpec
from pendfmu.fitting.statistics import CORRELATION_LIMIT, Z95, sandwich_estimates

MIN_HALF = 400  # samples each half must hold to be refitted on its own
STRICT = 2.0  # on a fit as good as the sensors, a disagreement counts beyond this many combined intervals


def halves(problem: Problem) -> list[tuple[str, str, object]]:
    """(recording, 'early' | 'late', the half as a Recording) of every recording long enough."""
    found = []
    for experiment in problem.experiments:
        recording = experiment.recording
        if len(recording.time) < 2 * MIN_HALF:
            continue
        middle = float(recording.time[len(recording.time) // 2])
        found.append((experiment.name, "early", recording.window(float(recording.time[0]), middle)))
        found.append((experiment.name, "late", recording.window(middle, float(recording.time[-1]))))
    return found


def refit_part(spec: FitSpec, recording, values: Mapping[str, float]) -> dict[str, Estimate] | None:
    """The shared estimates of one part refitted on its own: the same problem with only this
    recording, locally from `values` (the fit's optimum), with sandwich intervals; None when
    it cannot be simulated."""
    part = spec.with_options(recordings=(recording,), params=dict(values), windows=(), segment=None, start=None,
                             seed=None, uncertainty="jacobian", replicates=None,
                             global_search=replace(spec.global_search, enabled=False))
    problem = build_problem(part)
    residuals = Residuals(problem.experiments, problem.free, problem.values, spec.cost)
    try:
        u, jacobian, residual, _ = local_search(residuals, start_vector(problem.free, problem.values,
                                                                          problem.experiments), rounds=1)
        estimates, _, _ = sandwich_estimates(problem.free, u, jacobian, residual, residuals.series())
    except (FMUError, ArithmeticError, np.linalg.LinAlgError):
        return None
    finally:
        residuals.close()
    return {label: e for label, e in estimates.items() if not is_own(label)}


def validate(spec: FitSpec, problem: Problem, values: Mapping[str, float]) -> dict:
    """Each long recording's halves refitted and compared (module docstring): the parts, and
    per parameter the largest disagreement between a recording's halves in units of their
    combined interval, with which way it moves."""
    parts = {}
    for recording, which, half in halves(problem):
        estimates = refit_part(spec, half, values)
        if estimates is not None:
            parts.setdefault(recording, {})[which] = estimates
    parameters: dict[str, dict] = {}
    for recording, pair in parts.items():
        if set(pair) != {"early", "late"}:
            continue
        for name in pair["early"]:
            moved = _movement(pair["early"][name], pair["late"].get(name))
            if moved is not None and moved["ratio"] > parameters.get(name, {}).get("ratio", -1.0):
                parameters[name] = {**moved, "recording": recording}
    return {"halves": {recording: {which: {name: _row(e) for name, e in estimates.items()}
                                   for which, estimates in pair.items()} for recording, pair in parts.items()},
            "parameters": parameters}


def _row(estimate: Estimate) -> list[float | None]:
    """[value, low, high] for the result file (an open or missing end: None)."""
    ends = estimate.ci95 or (math.nan, math.nan)
    return [v if math.isfinite(v) else None for v in (estimate.value, *ends)]


def _movement(early: Estimate, late: Estimate | None) -> dict | None:
    """How far a parameter moves from the early half to the late, in combined intervals."""
    if late is None or early.ci95 is None or late.ci95 is None:
        return None
    half_widths = [(high - low) / 2 for low, high in (early.ci95, late.ci95)]
    combined = math.hypot(*half_widths)
    if not (math.isfinite(combined) and combined > 0):
        return None
    change = late.value - early.value
    return {"early": early.value, "late": late.value, "ratio": abs(change) / combined,
            "direction": "rises" if change > 0 else "falls"}


def moving(consistency: Mapping, adequate: bool) -> dict[str, dict]:
    """The parameters whose halves disagree: beyond their combined interval on a fit that
    misses something, beyond STRICT times it on one as good as the sensors."""
    limit = STRICT if adequate else 1.0
    return {name: moved for name, moved in consistency.get("parameters", {}).items() if moved["ratio"] > limit}


def mark_moving(estimates: dict[str, Estimate], moved: Mapping[str, dict]) -> list[str]:
    """Each moving parameter flagged model-inadequate, its interval widened to hold both
    halves' estimates; the evidence, one line per parameter."""
    evidence = []
    for name, m in moved.items():
        estimate = estimates.get(name)
        if estimate is None:
            continue
        low, high = estimate.ci95 if estimate.ci95 is not None else (estimate.value, estimate.value)
        estimate.ci95 = (min(low, m["early"], m["late"]), max(high, m["early"], m["late"]))
        estimate.method = f"{estimate.method}, widened to the halves"
        text = (f"model-inadequate: refitted on the two halves of {m['recording']} it {m['direction']} from "
                f"{m['early']:.4g} (early) to {m['late']:.4g} (late), {m['ratio']:.2g} times their combined 95 % "
                f"interval: the model does not hold it fixed over the recording (for a decay: with amplitude); "
                f"its interval is widened to hold both")
        estimate.flags.append(Flag(text, "model-inadequate"))
        evidence.append(f"{name} {m['direction']} from {m['early']:.4g} to {m['late']:.4g} between the halves of "
                        f"{m['recording']}")
    return evidence


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
    p, q = axes[:, 0] / np.max(np.abs(axes[:, 0]))
    log_value = p * math.log(a.value) + q * math.log(b.value)
    half = Z95 * math.sqrt(max(variances[0], 0.0)) / np.max(np.abs(axes[:, 0]))
    text = f"{a.label}^{p:.3g} * {b.label}^{q:.3g} = {math.exp(log_value):.6g}"
    return {"pair": [a.label, b.label], "powers": [float(p), float(q)], "value": math.exp(log_value),
            "ci95": [math.exp(log_value - half), math.exp(log_value + half)], "text": text}
