"""The statistics of a fit's estimates: the Jacobian interval, flags, error measures.

Uncertainty from the Jacobian J of the scaled residuals at the optimum (in the unit box):
cov = s^2 (J^T J)^+, with s^2 the residual variance per degree of freedom, carried to each
parameter through its mapping (so log-mapped intervals stay positive). This is the fast
method and the bootstrap's linearization (uncertainty.py chooses). A parameter is flagged,
with the reason, when it sits at a bound, when its 95 % interval is wider than its value,
when it correlates above 0.95 with another, or when the recordings do not depend on it at
all (a zero Jacobian column).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from pendfmu.fitting.diagnostics import MIN_BATCHES, correlation_length
from pendfmu.fitting.residuals import FreeParameter, physical, physical_jacobian
from pendfmu.fitting.result import Estimate, ExperimentFit, Flag

Z95 = 1.959963984540054
CORRELATION_LIMIT = 0.95


def estimate_uncertainty(free: list[FreeParameter], u: np.ndarray, jacobian: np.ndarray,
                         residual: np.ndarray) -> tuple[dict[str, Estimate], dict[str, dict[str, float]]]:
    """The fast interval ("jacobian"): cov = s^2 (J^T J)^+ at the optimum, as if the
    residuals were independent. Quantization and model errors come in long correlated
    runs, so on real recordings this is far too narrow; it is kept as a labelled fast
    option and as the bootstrap's linearization."""
    m, n = jacobian.shape
    variance = float(residual @ residual) / max(m - n, 1)
    norms = np.linalg.norm(jacobian, axis=0) if n else np.zeros(0)
    sensitive = norms > 1e-9 * (norms.max() if n and norms.max() > 0 else 1.0)
    G = physical_jacobian(free, u)
    covariance = np.zeros((n, n))
    if sensitive.any():
        J = jacobian[:, sensitive]
        with np.errstate(all="ignore"):
            covariance_u = variance * np.linalg.pinv(J.T @ J)
            covariance = G[:, sensitive] @ covariance_u @ G[:, sensitive].T
    # A parameter that moves with an insensitive coordinate is not determined at all.
    undetermined = (np.abs(G[:, ~sensitive]) > 0).any(axis=1) if n else np.zeros(0, bool)
    covariance[undetermined, :] = np.nan
    covariance[:, undetermined] = np.nan
    sigma = np.sqrt(np.clip(np.diag(covariance), 0, None))
    values = physical(free, u)
    estimates: dict[str, Estimate] = {}
    for k, p in enumerate(free):
        estimate = Estimate(p.label, float(values[k]), None, None, p.low, p.high, method="jacobian")
        if not undetermined[k] and np.isfinite(sigma[k]):
            estimate.stderr = float(sigma[k])
            estimate.ci95 = interval(estimate.value, estimate.stderr, positive(p), p.name)
        elif not at_bound(u[k]):
            estimate.flags.append(Flag("the recordings do not depend on it (zero sensitivity): not identifiable here",
                                       "not-determined"))
        estimates[p.label] = estimate
    correlation = correlation_table(free, covariance)
    add_flags(estimates, correlation, free, u)
    return estimates, correlation


def positive(p: FreeParameter) -> bool:
    """Whether a parameter's interval is taken on the log scale (it is positive by nature)."""
    return p.log or p.relative_to is not None


LOG_LIMIT = 700.0  # exp() of more overflows a double


def interval(value: float, sigma: float, log_scale: bool, name: str = "", quantile: float = Z95) -> tuple[float, float]:
    """value -+ quantile * sigma, on the log scale for a positive quantity (sigma / value
    is then its relative spread), so that it stays positive; clipped to the parameter's
    physical range (eta <= 1). A spread too large for floating point is an unbounded side,
    never an overflow: the result must be written whatever the statistics do."""
    if not math.isfinite(sigma) or not math.isfinite(value):
        low, high = -math.inf, math.inf
    elif log_scale and value > 0:
        spread = quantile * sigma / value
        if spread > LOG_LIMIT:
            low, high = 0.0, math.inf
        else:
            factor = math.exp(spread)
            low, high = value / factor, value * factor
    else:
        low, high = value - quantile * sigma, value + quantile * sigma
    return clip_to_range(name, (low, high))


def clip_to_range(name: str, bounds: tuple[float, float]) -> tuple[float, float]:
    """An interval cut to the physical range of the parameter `name` (its row of
    docs/reference/variables.md)."""
    from pendfmu.components import parameter_table

    variable = parameter_table().get(name)
    low, high = bounds
    if variable is not None:
        if variable.low is not None:
            low = max(low, variable.low)
        if variable.high is not None:
            high = min(high, variable.high)
    return float(low), float(high)


def at_bound(u: float) -> bool:
    return u <= 1e-6 or u >= 1 - 1e-6


def correlation_table(free: list[FreeParameter], covariance: np.ndarray) -> dict[str, dict[str, float | None]]:
    sigma = np.sqrt(np.clip(np.diag(covariance), 0, None)) if len(free) else np.zeros(0)
    table: dict[str, dict[str, float | None]] = {}
    for i, p in enumerate(free):
        table[p.label] = {}
        for j, q in enumerate(free):
            denominator = sigma[i] * sigma[j]
            value = covariance[i, j] / denominator if denominator > 0 else float("nan")
            table[p.label][q.label] = float(value) if math.isfinite(value) else None
    return table


def add_flags(estimates: dict[str, Estimate], correlation: dict[str, dict[str, float | None]],
              free: list[FreeParameter], u: np.ndarray) -> None:
    """The flags every method shares: at a search bound, an interval wider than the value
    or unbounded, a correlation above the limit. Each flag gives its true reason."""
    for k, p in enumerate(free):
        estimate = estimates[p.label]
        if at_bound(u[k]):
            estimate.flags.append(Flag(_bound_flag(p, u[k] <= 1e-6), "at-bound"))
        if estimate.ci95 is not None:
            low, high = estimate.ci95
            if not (math.isfinite(low) and math.isfinite(high)):
                estimate.flags.append(Flag(f"unbounded: the 95 % interval is [{low:.4g}, {high:.4g}]; the recordings "
                                           f"do not bound it on that side", "unbounded"))
            elif high - low > abs(estimate.value):
                estimate.flags.append(Flag(f"95 % interval [{low:.4g}, {high:.4g}] is wider than the value: the "
                                           f"recordings hardly determine it", "wide-interval"))
        for q in free:
            value = correlation.get(p.label, {}).get(q.label)
            if q is not p and value is not None and abs(value) > CORRELATION_LIMIT:
                estimate.flags.append(Flag(f"correlated {value:+.3f} with {q.label}: only a combination of the two "
                                           f"is determined", "correlated"))


WARNING_KINDS = ("at-bound", "unbounded", "no-interval", "not-determined")


def flag_warnings(estimates: dict[str, Estimate]) -> list[str]:
    """The flags that must reach the console as warnings: an estimate at a search bound
    (the optimum may lie beyond), an unbounded interval, no interval at all, a parameter
    the recordings do not depend on."""
    return [f"{label}: {flag}" for label, estimate in estimates.items() for flag in estimate.flags
            if getattr(flag, "kind", "note") in WARNING_KINDS]


def unknown_uncertainty(free: list[FreeParameter], u: np.ndarray, reason: str) -> dict[str, Estimate]:
    """Estimates without intervals, when the statistics themselves failed: the values are
    still the fit's, and the result is still written."""
    values = physical(free, u)
    return {p.label: Estimate(p.label, float(v), None, None, p.low, p.high,
                              [Flag(f"no interval: the uncertainty could not be computed ({reason})", "no-interval")],
                              method="none")
            for p, v in zip(free, values)}


def _bound_flag(p: FreeParameter, lower: bool) -> str:
    if p.relative_to:
        ratio = p.low if lower else p.high
        if lower:
            return f"at its lower bound: equal to {p.relative_to} (no stiction beyond Coulomb friction)"
        return (f"at {ratio:g} times {p.relative_to}, the upper bound of the search: widen it with "
                f"bounds {p.name}=LOW:HIGH (absolute values)")
    bound = p.low if lower else p.high
    # the name as --bounds takes it: a recording's own parameter (phi0[run1]) by its plain
    # name, which sets the box of every recording's
    return (f"at its {'lower' if lower else 'upper'} bound {bound:g}: the optimum may lie beyond; "
            f"widen its bounds ({p.name}=LOW:HIGH) or check the model")


def nrmse(experiments: list[ExperimentFit]) -> dict[str, float]:
    """Root-mean-square error per signal over all recordings, divided by the recorded range."""
    pooled: dict[str, list[tuple[np.ndarray, np.ndarray]]] = {}
    for fit in experiments:
        for name, recorded in fit.recorded.items():
            pooled.setdefault(name, []).append((recorded, fit.simulated[name]))
    result = {}
    for name, pairs in pooled.items():
        recorded = np.concatenate([r for r, _ in pairs])
        simulated = np.concatenate([s for _, s in pairs])
        present = np.isfinite(recorded)  # a missing reading (sidecar "missing") has no error
        recorded, simulated = recorded[present], simulated[present]
        spread = float(np.ptp(recorded)) if len(recorded) else 0.0
        spread = spread or 1.0
        result[name] = float(np.sqrt(np.mean((simulated - recorded) ** 2)) / spread)
    return result


def without_zero_widths(estimates: dict[str, Estimate]) -> list[str]:
    """No interval of zero width is reported: it would claim the value exact. It arises
    where every bootstrap replicate ends at the same value, the edge of the search box
    (the data push the estimate against it). Such an estimate keeps its value and loses
    its interval, with a flag that says why; returns notes for the fit."""
    notes = []
    for label, estimate in estimates.items():
        if estimate.ci95 is None or not all(math.isfinite(end) for end in estimate.ci95):
            continue
        low, high = estimate.ci95
        if high - low > 1e-12 * max(abs(low), abs(high), 1e-300):
            continue
        estimate.ci95, estimate.stderr = None, None
        estimate.flags.append(Flag(f"no interval: the {estimate.method} interval had zero width at {low:.6g} "
                                   f"(every replicate ended there, at the search box's edge): the box, not the "
                                   f"recordings, bounds it", "no-interval"))
        notes.append(f"{label}: a zero-width interval was withheld")
    return notes


BATCH_LENGTHS = 4  # a batch spans this many correlation lengths (shorter ones underestimate the spread)


def sandwich_covariance(jacobian: np.ndarray, residual: np.ndarray, series: Sequence[tuple[int, int]]
                        ) -> tuple[np.ndarray, int]:
    """The covariance of the unit-box estimate that holds when the residuals are correlated
    in time and larger than the noise model says (a model that misses something): the
    sandwich (J'J)^+ M (J'J)^+, its middle M from overlapping batch means of the scores
    J_t r_t, each series' batches BATCH_LENGTHS times as long as its residuals stay
    correlated (correlation_length). With independent residuals of the noise model's size it
    is the Jacobian covariance (measured on AR(1) residuals of correlation 0 to 0.98: 0.8 to 1
    of the true variance). Returns it and the longest batch (samples)."""
    n = jacobian.shape[1]
    bread = np.linalg.pinv(jacobian.T @ jacobian)
    meat = np.zeros((n, n))
    longest = 1
    for start, stop in series:
        scores = jacobian[start:stop] * residual[start:stop, None]
        samples = len(scores)
        length = max(1, min(BATCH_LENGTHS * correlation_length(residual[start:stop]), samples // MIN_BATCHES))
        longest = max(longest, length)
        running = np.vstack([np.zeros((1, n)), np.cumsum(scores, axis=0)])
        sums = running[length:] - running[:-length]  # every batch of `length` consecutive scores
        meat += (sums.T @ sums) * samples / ((samples - length + 1) * length)
    return bread @ meat @ bread, longest


def sandwich_estimates(free: list[FreeParameter], u: np.ndarray, jacobian: np.ndarray, residual: np.ndarray,
                       series: Sequence[tuple[int, int]]) -> tuple[dict[str, Estimate], dict, int]:
    """Estimates with sandwich intervals (sandwich_covariance), carried to each parameter
    through its mapping like the Jacobian ones; flags as every method's. Returns the
    estimates, their correlations and the longest batch used."""
    covariance_u, longest = sandwich_covariance(jacobian, residual, series)
    G = physical_jacobian(free, u)
    covariance = G @ covariance_u @ G.T
    sigma = np.sqrt(np.clip(np.diag(covariance), 0, None))
    values = physical(free, u)
    estimates = {}
    for k, p in enumerate(free):
        estimate = Estimate(p.label, float(values[k]), None, None, p.low, p.high, method="sandwich")
        if np.isfinite(sigma[k]):
            estimate.stderr = float(sigma[k])
            estimate.ci95 = interval(estimate.value, estimate.stderr, positive(p), p.name)
        estimates[p.label] = estimate
    correlation = correlation_table(free, covariance)
    add_flags(estimates, correlation, free, u)
    return estimates, correlation, longest
