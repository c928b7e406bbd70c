"""The result of a fit: values, uncertainty, identifiability flags, fit quality.

Uncertainty comes from the Jacobian J of the scaled residuals at the optimum (in the
unit box): cov = s^2 (J^T J)^+, with s^2 the residual variance per degree of freedom,
carried to each parameter through its mapping (so log-mapped intervals stay positive).
A parameter is flagged, with the reason, when it sits at a bound, when its 95 % interval
is wider than its value, when it correlates above 0.95 with another, or when the
recordings do not depend on it at all (a zero Jacobian column). Parameters a recording
only bounds (the pendulum's stiction in a free decay) carry the interval they are
confined to instead of a standard error.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pendfmu.residuals import FreeParameter, physical, physical_jacobian

Z95 = 1.959963984540054
CORRELATION_LIMIT = 0.95


@dataclass
class Estimate:
    """One fitted quantity."""

    label: str
    value: float
    stderr: float | None
    ci95: tuple[float, float] | None
    low: float
    high: float
    flags: list[str] = field(default_factory=list)


@dataclass
class ExperimentFit:
    """Recorded against simulated signals of one recording, for reports."""

    name: str
    time: np.ndarray
    recorded: dict[str, np.ndarray]
    simulated: dict[str, np.ndarray]
    resolution: dict[str, float] = field(default_factory=dict)  # quantization step per recorded signal, if stated


@dataclass
class FitResult:
    stage: str
    parameters: dict[str, float]  # every value the stage ran with, fitted and known
    estimates: dict[str, Estimate]  # the fitted ones, by label
    correlation: dict[str, dict[str, float]]
    cost: float
    nrmse: dict[str, float]
    nfev: int
    failures: int
    seconds: float
    experiments: list[ExperimentFit] = field(default_factory=list)
    initial: dict[str, dict[str, float]] = field(default_factory=dict)  # estimated initial states per recording
    notes: list[str] = field(default_factory=list)
    # recordings not fitted but predicted with the result: name -> {"phi_rms_steps": ..., ...}
    validation: dict[str, dict[str, float]] = field(default_factory=dict)

    @property
    def stderr(self) -> dict[str, float | None]:
        return {k: e.stderr for k, e in self.estimates.items()}

    @property
    def ci95(self) -> dict[str, tuple[float, float] | None]:
        return {k: e.ci95 for k, e in self.estimates.items()}

    @property
    def flags(self) -> dict[str, list[str]]:
        return {k: e.flags for k, e in self.estimates.items() if e.flags}

    def to_dict(self) -> dict:
        shared = {k: e for k, e in self.estimates.items() if "[" not in k}
        return {
            "parameters": dict(self.parameters),
            "stderr": {k: e.stderr for k, e in shared.items()},
            "ci95": {k: list(e.ci95) if e.ci95 else None for k, e in shared.items()},
            "flags": {k: e.flags for k, e in self.estimates.items() if e.flags},
            "initial": self.initial,
            "fit": {"stage": self.stage, "cost": self.cost, "nrmse": self.nrmse, "nfev": self.nfev,
                    "failures": self.failures, "seconds": self.seconds, "notes": self.notes,
                    "validation": self.validation},
        }

    def write_json(self, path: str | Path) -> Path:
        path = Path(path)
        path.write_text(json.dumps(self.to_dict(), indent=2, allow_nan=False, default=_plain) + "\n")
        return path

    def write_report(self, directory: str | Path) -> Path:
        from pendfmu.report import write_report

        return write_report(self, directory)

    def export(self, directory: str | Path) -> list[Path]:
        from pendfmu.export import export_all

        return export_all(self.parameters, directory)


def _plain(value):
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"cannot write {type(value).__name__} to JSON")


def estimate_uncertainty(free: list[FreeParameter], u: np.ndarray, jacobian: np.ndarray,
                         residual: np.ndarray) -> tuple[dict[str, Estimate], dict[str, dict[str, float]]]:
    """Estimates with standard errors, 95 % intervals, correlations and flags."""
    m, n = jacobian.shape
    variance = float(residual @ residual) / max(m - n, 1)
    norms = np.linalg.norm(jacobian, axis=0) if n else np.zeros(0)
    sensitive = norms > 1e-9 * (norms.max() if n and norms.max() > 0 else 1.0)
    G = physical_jacobian(free, u)
    covariance = np.zeros((n, n))
    if sensitive.any():
        J = jacobian[:, sensitive]
        covariance_u = variance * np.linalg.pinv(J.T @ J)
        covariance = G[:, sensitive] @ covariance_u @ G[:, sensitive].T
    # A parameter that moves with an insensitive coordinate is not determined at all.
    undetermined = (np.abs(G[:, ~sensitive]) > 0).any(axis=1) if n else np.zeros(0, bool)
    covariance[undetermined, :] = np.nan
    covariance[:, undetermined] = np.nan
    sigma = np.sqrt(np.clip(np.diag(covariance), 0, None))
    sensitive = ~undetermined
    values = physical(free, u)
    estimates: dict[str, Estimate] = {}
    for k, p in enumerate(free):
        value = float(values[k])
        estimate = Estimate(p.label, value, None, None, p.low, p.high)
        if sensitive[k] and np.isfinite(sigma[k]):
            estimate.stderr = float(sigma[k])
            estimate.ci95 = _interval(value, float(sigma[k]), positive=p.log or p.relative_to is not None)
            if estimate.ci95[1] - estimate.ci95[0] > abs(value):
                estimate.flags.append(f"95 % interval [{estimate.ci95[0]:.4g}, {estimate.ci95[1]:.4g}] is wider "
                                      f"than the value: the recordings hardly determine it")
        else:
            estimate.flags.append("the recordings do not depend on it (zero sensitivity): not identifiable here")
        if u[k] <= 1e-6 or u[k] >= 1 - 1e-6:
            estimate.flags.append(_bound_flag(p, u[k] <= 1e-6))
        estimates[p.label] = estimate
    correlation: dict[str, dict[str, float]] = {}
    for i, p in enumerate(free):
        correlation[p.label] = {}
        for j, q in enumerate(free):
            denominator = sigma[i] * sigma[j]
            value = covariance[i, j] / denominator if denominator > 0 else float("nan")
            correlation[p.label][q.label] = float(value) if math.isfinite(value) else None
            if i != j and math.isfinite(value) and abs(value) > CORRELATION_LIMIT:
                estimates[p.label].flags.append(f"correlated {value:+.3f} with {q.label}: only a combination of the "
                                                f"two is determined")
    return estimates, correlation


def _interval(value: float, sigma: float, positive: bool) -> tuple[float, float]:
    """95 % interval; for a positive quantity taken on the log scale, so it stays positive."""
    if positive and value > 0:
        factor = math.exp(Z95 * sigma / value)
        return value / factor, value * factor
    return value - Z95 * sigma, value + Z95 * sigma


def _bound_flag(p: FreeParameter, lower: bool) -> str:
    if p.relative_to:
        ratio = p.low if lower else p.high
        if lower:
            return f"at its lower bound: equal to {p.relative_to} (no stiction beyond Coulomb friction)"
        return f"at {ratio:g} times {p.relative_to}, the upper bound of the search: widen it with --bounds"
    bound = p.low if lower else p.high
    return (f"at its {'lower' if lower else 'upper'} bound {bound:g}: the optimum may lie beyond; "
            f"widen the bounds (--bounds) or check the model")


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
        spread = float(np.ptp(recorded)) or 1.0
        result[name] = float(np.sqrt(np.mean((simulated - recorded) ** 2)) / spread)
    return result
