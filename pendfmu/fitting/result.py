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

from pendfmu.fitting.residuals import FreeParameter, physical, physical_jacobian

Z95 = 1.959963984540054
CORRELATION_LIMIT = 0.95


@dataclass
class Estimate:
    """One fitted quantity.

    `ci95` is the 95 % interval (an unbounded side is +-inf; None when none could be
    given), `method` says what gave it ("jacobian", "bootstrap", "bounded", ...), `low`
    and `high` are the search bounds, `flags` what the user must know about it."""

    label: str
    value: float
    stderr: float | None
    ci95: tuple[float, float] | None
    low: float
    high: float
    flags: list[str] = field(default_factory=list)
    method: str = "jacobian"


@dataclass
class ExperimentFit:
    """Recorded against simulated signals of one recording, for reports."""

    name: str
    time: np.ndarray
    recorded: dict[str, np.ndarray]
    simulated: dict[str, np.ndarray]
    resolution: dict[str, float] = field(default_factory=dict)  # quantization step per recorded signal, if stated
    scale: dict[str, float] = field(default_factory=dict)  # the error scale (noise sigma) the cost divides by
    values: dict[str, float] = field(default_factory=dict)  # every parameter value this recording ran with
    overrides: dict[str, float] = field(default_factory=dict)  # what its sidecar set (parameters, initial states)
    # the RMS error per signal over every sample, when time/recorded/simulated are a
    # display envelope (a result read back from its file): the envelope's own RMS is not it
    rms: dict[str, float] = field(default_factory=dict)
    samples: int | None = None  # the recording's samples, when the arrays hold fewer


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
    # what looks wrong (mis-scaled data, residuals far above the noise, an estimate at a
    # bound, a value assumed for want of a sidecar): printed on the console, and with
    # --strict a non-zero exit code
    warnings: list[str] = field(default_factory=list)
    uncertainty: dict = field(default_factory=dict)  # how the intervals were made (method, replicates, time)
    model: str | None = None  # a user's FMU or SSP file (None: pendfmu's own components)
    # per bootstrap replicate, the stage's fitted values (not written: later stages take them)
    replicates: list[dict[str, float]] = field(default_factory=list, repr=False)
    # where it came from (fitting/provenance.py): inputs with sha256, seed, bounds, start
    # values, free and fixed sets, versions, date, command line
    provenance: dict = field(default_factory=dict)
    # the recordings predicted with the result but not fitted (fit_all: x and phi together)
    predicted: list[ExperimentFit] = field(default_factory=list)

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
            "ci95": {k: _json_interval(e.ci95) for k, e in shared.items()},
            "interval_method": {k: e.method for k, e in shared.items()},
            # the estimates' correlations (None where a standard error is 0 or undefined):
            # what a derived quantity's interval needs besides stderr
            "correlation": {k: {q: c for q, c in row.items() if q in shared}
                            for k, row in self.correlation.items() if k in shared},
            "flags": {k: e.flags for k, e in self.estimates.items() if e.flags},
            "initial": self.initial,
            "fit": {"stage": self.stage, "cost": self.cost, "nrmse": self.nrmse, "nfev": self.nfev,
                    "failures": self.failures, "seconds": self.seconds, "notes": self.notes,
                    "warnings": self.warnings, "uncertainty": self.uncertainty, "validation": self.validation,
                    **({"model": self.model} if self.model else {})},
            "provenance": self.provenance,
            # per recording the values it ran with and its signals, long ones as their
            # display envelope (report/envelope.py): enough to re-render and compare reports
            "recordings": [experiment_dict(e) for e in self.experiments],
            "predicted": [experiment_dict(e) for e in self.predicted],
        }

    def write_json(self, path: str | Path) -> Path:
        path = Path(path)
        path.write_text(json.dumps(self.to_dict(), indent=2, allow_nan=False, default=_plain) + "\n")
        return path

    def write_report(self, directory: str | Path) -> Path:
        from pendfmu.report import write_report

        return write_report(self, directory)

    def export(self, directory: str | Path) -> list[Path]:
        """Parameterized FMUs and an SSV file (pendfmu's components: also Modelica modifiers)."""
        if self.model:
            from pendfmu.export.model import export_model
            from pendfmu.fitting.models import load_model

            return export_model(load_model(self.model), self.parameters, directory, f"a pendfmu fit ({self.stage})")
        from pendfmu.export import export_all

        return export_all(self.parameters, directory)


def experiment_dict(fit: ExperimentFit) -> dict:
    """One recording's fit for the result file: long signals reduced to their envelope,
    with the RMS error of every sample kept beside it; a missing sample (NaN) is null."""
    from pendfmu.report.envelope import envelope_indices

    signals = list(fit.recorded)
    residuals = [np.asarray(fit.recorded[s], float) - np.asarray(fit.simulated[s], float) for s in signals]
    arrays = [np.asarray(fit.recorded[s], float) for s in signals] + [np.asarray(fit.simulated[s], float)
                                                                       for s in signals] + residuals
    reduced = fit.samples is not None and len(fit.time) < fit.samples  # read back: already its envelope
    index = envelope_indices(arrays) if arrays and not reduced else np.arange(len(fit.time))
    rms = {s: (fit.rms[s] if s in fit.rms else _rms(r)) for s, r in zip(signals, residuals)}
    return {"name": fit.name, "samples": fit.samples or len(fit.time), "time": _json_array(fit.time, index),
            "recorded": {s: _json_array(fit.recorded[s], index) for s in signals},
            "simulated": {s: _json_array(fit.simulated[s], index) for s in signals},
            "resolution": dict(fit.resolution), "scale": dict(fit.scale), "rms": rms,
            "values": dict(fit.values), "overrides": dict(fit.overrides)}


def _rms(residual: np.ndarray) -> float | None:
    present = residual[np.isfinite(residual)]
    return float(np.sqrt(np.mean(present**2))) if present.size else None


def _json_array(values, index: np.ndarray) -> list[float | None]:
    return [float(v) if math.isfinite(v) else None for v in np.asarray(values, float)[index]]


def _array(values) -> np.ndarray:
    return np.array([math.nan if v is None else v for v in values], float)


def _experiment_from(entry: dict) -> ExperimentFit:
    return ExperimentFit(
        entry["name"], _array(entry["time"]), {s: _array(v) for s, v in entry["recorded"].items()},
        {s: _array(v) for s, v in entry["simulated"].items()}, dict(entry.get("resolution", {})),
        dict(entry.get("scale", {})), dict(entry.get("values", {})), dict(entry.get("overrides", {})),
        {s: v for s, v in entry.get("rms", {}).items() if v is not None}, entry.get("samples"))


def read_result(path: str | Path) -> FitResult:
    """A result file (write_json) read back. Files written before provenance and
    recordings were stored read as results without them; per-recording estimates
    (phi0[run1]), whose intervals the file does not keep, come back without intervals."""
    from pendfmu.errors import BadInput

    path = Path(path)
    try:
        document = json.loads(path.read_text(encoding="utf-8"))
    except OSError as error:
        raise BadInput(f"{path}: cannot read the result file ({error.strerror})") from None
    except (json.JSONDecodeError, UnicodeDecodeError) as error:
        raise BadInput(f"{path}: not a result file (not valid JSON: {error})") from None
    if not isinstance(document, dict) or not isinstance(document.get("parameters"), dict) \
            or not isinstance(document.get("fit"), dict) or "stage" not in document["fit"]:
        raise BadInput(f'{path}: not a result file of pendfmu fit (expected "parameters" and "fit" with a "stage")')
    try:
        return _result_from(document)
    except (KeyError, TypeError, ValueError, AttributeError) as error:
        raise BadInput(f"{path}: a result file with a malformed entry ({type(error).__name__}: {error})") from None


def _result_from(document: dict) -> FitResult:
    fit = document["fit"]
    flags = document.get("flags", {})
    methods = document.get("interval_method", {})
    estimates = {}
    for label, stderr in document.get("stderr", {}).items():
        interval = document.get("ci95", {}).get(label)
        ci95 = None if interval is None else (-math.inf if interval[0] is None else float(interval[0]),
                                              math.inf if interval[1] is None else float(interval[1]))
        value = document["parameters"].get(label)
        estimates[label] = Estimate(label, math.nan if value is None else float(value), stderr, ci95,
                                    math.nan, math.nan, list(flags.get(label, [])), methods.get(label, "jacobian"))
    for recording, states in document.get("initial", {}).items():  # per-recording estimates: values only
        for name, value in states.items():
            label = f"{name}[{recording}]"
            estimates[label] = Estimate(label, float(value), None, None, math.nan, math.nan,
                                        list(flags.get(label, [])), "none")
    for label, label_flags in flags.items():  # a flagged estimate whose value the file does not hold
        estimates.setdefault(label, Estimate(label, math.nan, None, None, math.nan, math.nan, list(label_flags),
                                             "none"))
    for stage in document.get("provenance", {}).get("stages", {}).values():
        for label, (low, high) in stage.get("bounds", {}).items():
            if label in estimates:
                estimates[label].low, estimates[label].high = low, high
    return FitResult(
        fit["stage"], dict(document["parameters"]), estimates, document.get("correlation", {}),
        fit.get("cost", math.nan), fit.get("nrmse", {}), fit.get("nfev", 0), fit.get("failures", 0),
        fit.get("seconds", math.nan), [_experiment_from(e) for e in document.get("recordings", [])],
        document.get("initial", {}), list(fit.get("notes", [])), fit.get("validation", {}),
        list(fit.get("warnings", [])), fit.get("uncertainty", {}), fit.get("model"),
        provenance=document.get("provenance", {}),
        predicted=[_experiment_from(e) for e in document.get("predicted", [])])


def _json_interval(interval: tuple[float, float] | None) -> list[float | None] | None:
    """An interval for JSON: an unbounded side is null (JSON has no infinity)."""
    if interval is None:
        return None
    return [float(b) if math.isfinite(b) else None for b in interval]


def _plain(value):
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"cannot write {type(value).__name__} to JSON")


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
            estimate.flags.append("the recordings do not depend on it (zero sensitivity): not identifiable here")
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
    """An interval cut to the physical range of the parameter `name` (MODEL.md's table)."""
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
            estimate.flags.append(_bound_flag(p, u[k] <= 1e-6))
        if estimate.ci95 is not None:
            low, high = estimate.ci95
            if not (math.isfinite(low) and math.isfinite(high)):
                estimate.flags.append(f"unbounded: the 95 % interval is [{low:.4g}, {high:.4g}]; the recordings do "
                                      f"not bound it on that side")
            elif high - low > abs(estimate.value):
                estimate.flags.append(f"95 % interval [{low:.4g}, {high:.4g}] is wider than the value: the "
                                      f"recordings hardly determine it")
        for q in free:
            value = correlation.get(p.label, {}).get(q.label)
            if q is not p and value is not None and abs(value) > CORRELATION_LIMIT:
                estimate.flags.append(f"correlated {value:+.3f} with {q.label}: only a combination of the two is "
                                      f"determined")


WARNING_FLAGS = ("at its lower bound", "at its upper bound", "unbounded", "no interval", "not determined")


def flag_warnings(estimates: dict[str, Estimate]) -> list[str]:
    """The flags that must reach the console as warnings: an estimate at a search bound
    (the optimum may lie beyond), an unbounded interval, no interval at all."""
    warnings = []
    for label, estimate in estimates.items():
        for flag in estimate.flags:
            if flag.startswith(WARNING_FLAGS) or "the upper bound of the search" in flag:
                warnings.append(f"{label}: {flag}")
    return warnings


def unknown_uncertainty(free: list[FreeParameter], u: np.ndarray, reason: str) -> dict[str, Estimate]:
    """Estimates without intervals, when the statistics themselves failed: the values are
    still the fit's, and the result is still written."""
    values = physical(free, u)
    return {p.label: Estimate(p.label, float(v), None, None, p.low, p.high,
                              [f"no interval: the uncertainty could not be computed ({reason})"], method="none")
            for p, v in zip(free, values)}


def _bound_flag(p: FreeParameter, lower: bool) -> str:
    if p.relative_to:
        ratio = p.low if lower else p.high
        if lower:
            return f"at its lower bound: equal to {p.relative_to} (no stiction beyond Coulomb friction)"
        return (f"at {ratio:g} times {p.relative_to}, the upper bound of the search: widen it with "
                f"--bounds {p.name}=LOW:HIGH (absolute values)")
    bound = p.low if lower else p.high
    # the name as --bounds takes it: a recording's own parameter (phi0[run1]) by its plain
    # name, which sets the box of every recording's
    return (f"at its {'lower' if lower else 'upper'} bound {bound:g}: the optimum may lie beyond; "
            f"widen the bounds (--bounds {p.name}=LOW:HIGH) or check the model")


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
