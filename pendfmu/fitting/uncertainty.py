"""The uncertainty of a fit's estimates, by the method the user chose.

- "bootstrap" (the default): calibrated intervals from refitting synthetic replicates of
  the recordings (bootstrap.py). Costs `replicates` local refits, run in parallel.
- "jacobian": the classic s^2 (J^T J)^-1 interval at the optimum. Instant, but it assumes
  independent residuals; on quantized recordings its intervals are tens of times too narrow.
  Kept as the fast option, and labelled as such in the result.

Whatever happens here, the fit's result is still written: a failure of the statistics
gives estimates without intervals and says why.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from pendfmu.fitting.bootstrap import REPLICATES, bootstrap, bootstrap_estimates
from pendfmu.fitting.progress import Progress
from pendfmu.fitting.result import Estimate, Flag
from pendfmu.fitting.statistics import estimate_uncertainty, sandwich_estimates, unknown_uncertainty
from pendfmu.fitting.residuals import Residuals, physical
from pendfmu.friction import JOINTS

METHODS = ("bootstrap", "jacobian", "sandwich")
MIN_REPLICATES = 8  # fewer successful refits than this: no bootstrap interval


@dataclass
class Assessment:
    estimates: dict[str, Estimate]
    correlation: dict[str, dict[str, float | None]]
    notes: list[str] = field(default_factory=list)
    summary: dict = field(default_factory=dict)
    replicates: list[dict[str, float]] = field(default_factory=list)  # per replicate, the stage's rig values
    values: np.ndarray | None = None  # replicates x free parameters (physical; NaN: a failed refit)


def assess_uncertainty(method: str, residuals: Residuals, outcome, replicates: int = REPLICATES,
                       upstream: Sequence[Mapping[str, float]] | None = None, options=None,
                       progress: Progress | None = None) -> Assessment:
    """Intervals for the optimum in `outcome` (optimizer.Outcome) by `method`; `progress`
    shows the bootstrap's refits and the time they have left."""
    if method not in METHODS:
        raise ValueError(f"uncertainty must be one of {', '.join(METHODS)}, not {method!r}")
    start = time.perf_counter()
    free = residuals.free
    if method == "bootstrap" and len(free):
        try:
            assessment = _bootstrap(residuals, outcome, replicates, upstream, options, progress)
        except KeyboardInterrupt:
            assessment = _jacobian(residuals, outcome)
            assessment.notes.append("the bootstrap was interrupted: the intervals are the fast Jacobian ones, "
                                    "which are too narrow on quantized recordings")
    elif method == "sandwich" and len(free):
        assessment = _sandwich(residuals, outcome)
    else:
        assessment = _jacobian(residuals, outcome)
    assessment.summary["seconds"] = time.perf_counter() - start
    return assessment


def _sandwich(residuals: Residuals, outcome) -> Assessment:
    """Intervals from the sandwich covariance (statistics.sandwich_covariance): what the
    residuals' own size and correlation say, where the model misses something and a
    bootstrap through the sensor model would not see it."""
    try:
        estimates, correlation, batch = sandwich_estimates(residuals.free, outcome.u, outcome.jacobian,
                                                           outcome.residual, residuals.series())
    except (ArithmeticError, ValueError, np.linalg.LinAlgError) as error:
        fallback = _jacobian(residuals, outcome)
        fallback.notes.append(f"the sandwich intervals could not be computed ({type(error).__name__}: {error}); the "
                              f"intervals are the Jacobian ones")
        return fallback
    return Assessment(estimates, correlation, summary={"method": "sandwich", "batch_samples": batch})


FLAT = 1e-8  # a Jacobian column this small against the largest: the recordings do not depend on it
STICTION = {joint.stiction for joint in JOINTS.values()}


def undetermined(free, u: np.ndarray, jacobian: np.ndarray, estimates: dict[str, Estimate]) -> list[str]:
    """Parameters the recordings do not depend on at all (a zero Jacobian column) get the
    whole search box as their set: a refit never moves along a flat direction, so their
    bootstrap spread is nil and would claim a precision the data do not have."""
    if not jacobian.size:
        return []
    norms = np.linalg.norm(jacobian, axis=0)
    notes = []
    for k, p in enumerate(free):
        if norms[k] > FLAT * max(float(norms.max()), 1e-300) or p.name in STICTION:
            continue  # stiction's set is stiction.py's to find, from where the joints stick
        ends = []
        for end in (0.0, 1.0):
            corner = np.array(u, dtype=float)
            corner[k] = end
            ends.append(float(physical(free, corner)[k]))
        low, high = min(ends), max(ends)
        estimate = estimates[p.label]
        estimate.ci95, estimate.stderr, estimate.method = (low, high), None, "bounded"
        estimate.flags = [Flag(f"not determined: the recordings do not depend on it here, so every value of the "
                               f"search box [{low:.4g}, {high:.4g}] fits them as well; the value given is where the "
                               f"search stopped", "not-determined")]
        notes.append(f"{p.label} is not determined by the recordings (zero sensitivity)")
    return notes


def _jacobian(residuals: Residuals, outcome) -> Assessment:
    try:
        estimates, correlation = estimate_uncertainty(residuals.free, outcome.u, outcome.jacobian, outcome.residual)
        return Assessment(estimates, correlation, summary={"method": "jacobian"})
    except (ArithmeticError, ValueError, np.linalg.LinAlgError) as error:
        reason = f"{type(error).__name__}: {error}"
        return Assessment(unknown_uncertainty(residuals.free, outcome.u, reason), {},
                          [f"the uncertainty could not be computed ({reason}); the estimates carry no interval"],
                          {"method": "none"})


def _bootstrap(residuals: Residuals, outcome, count: int, upstream, options, progress: Progress | None) -> Assessment:
    above = list(upstream) if upstream is not None and len(upstream) == count else None
    workers = getattr(options, "workers", 0)
    scheduler = getattr(options, "scheduler", None)
    done = progress.phase("bootstrap", count, "refit") if progress is not None else (lambda: None)
    found = bootstrap(residuals, outcome.u, count, above, workers, scheduler, done)
    good = count - found.failures
    summary = {"method": "bootstrap", "replicates": count, "failed": found.failures, "errors_from": found.source,
               "upstream": above is not None}
    why = f" (last: {found.last_failure or 'no reason reported'})" if found.failures else ""
    lost = [f"bootstrap: {incident}" for incident in found.incidents]
    if good < MIN_REPLICATES:
        fallback = _jacobian(residuals, outcome)
        fallback.notes.append(f"only {good} of {count} bootstrap refits succeeded{why}: the intervals are the fast "
                              f"Jacobian ones, too narrow on quantized recordings")
        fallback.notes += lost
        fallback.summary.update(summary, method="jacobian (bootstrap failed)")
        return fallback
    estimates, correlation = bootstrap_estimates(residuals.free, outcome.u, found)
    notes = undetermined(residuals.free, outcome.u, outcome.jacobian, estimates)
    if found.failures:
        notes.append(f"{found.failures} of {count} bootstrap refits failed and were left out{why}")
    notes += lost
    modelled = [name for name, source in found.source.items() if source == "residuals"]
    if modelled:
        notes.append(f"the residuals of {', '.join(modelled)} stand above the sensor noise: their bootstrap errors "
                     f"are the fit's own residuals, circularly shifted, not the sensor model")
    return Assessment(estimates, correlation, notes, summary, found.fitted, found.values)
