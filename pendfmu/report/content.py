"""What a report says, independent of how it is drawn: units, error measures, joints, the
verdicts and the limit of their validation, the joint region of a pair determined together.

The figures and the HTML page both need the unit of a name, the per-recording error and
which friction curves a result determines (and the points they are drawn through);
computing them once here keeps the two views of the same numbers from drifting apart.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

import numpy as np

from pendfmu.components import COMPONENTS
from pendfmu.fitting.adequacy import MODEL_ERROR_LIMIT
from pendfmu.fitting.result import Estimate, ExperimentFit, FitResult
from pendfmu.fitting.statistics import Z95
from pendfmu.fitting.validation import moving
from pendfmu.fitting.labels import label, parameter_of
from pendfmu.friction import JOINTS, Joint, Law


def unit(name: str) -> str:
    """The unit of a variable or parameter from the FMU tables (pendfmu.components).

    Per-recording estimates are labelled ``phi0[recording]``; they take the unit of the
    parameter before the bracket. An unknown name has no unit (empty string)."""
    base = parameter_of(name)
    for component in COMPONENTS.values():
        for variable in component.variables:
            if variable.name == base:
                return variable.unit
    return ""


def component_of(name: str) -> str:
    """The FMUs a parameter belongs to (m_p and l belong to two), for the known-values table."""
    return ", ".join(c.name for c in COMPONENTS.values() if name in c.parameters)


def description(name: str) -> str:
    base = parameter_of(name)
    for component in COMPONENTS.values():
        if base in component.parameters:
            return component.parameters[base].description
    return ""


def finite(value) -> bool:
    """A number that can be shown as one (not None, NaN or infinite)."""
    return isinstance(value, numbers.Real) and not isinstance(value, bool) and math.isfinite(value)


def interval_text(low: float, high: float) -> str:
    """An interval with as many digits as it takes for its ends to differ: a tight
    interval of 12 N printed as [12, 12] would say nothing."""
    low, high = float(low), float(high)
    digits = 4
    if high > low and math.isfinite(high - low):
        digits = min(12, max(4, math.ceil(math.log10(max(abs(low), abs(high)) / (high - low))) + 2))
    return f"[{low:.{digits}g}, {high:.{digits}g}]"


def relative_stderr(estimate: Estimate) -> float | None:
    """Standard error in percent of the value; None when either is missing or the value is 0."""
    if not finite(estimate.stderr) or not finite(estimate.value) or estimate.value == 0:
        return None
    return 100.0 * float(estimate.stderr) / abs(float(estimate.value))


def bounded_only(estimate: Estimate) -> bool:
    """A parameter the recordings only confine to an interval (fit._bound_stiction): it
    has an interval but no standard error, and says so in its flags."""
    return estimate.stderr is None and estimate.ci95 is not None and any(
        "bounded only" in flag for flag in estimate.flags)


@dataclass(frozen=True)
class SignalError:
    """How far one simulated signal lies from its recording."""

    experiment: str
    signal: str
    rms: float
    resolution: float | None  # the sensor step, when the recording states it
    scale: float | None = None  # the error scale the fit divided by (noise and quantization)

    @property
    def steps(self) -> float | None:
        return self.rms / self.resolution if self.resolution else None

    @property
    def sigmas(self) -> float | None:
        """The RMS error in units of the error scale: about 1 for a fit as good as the
        sensor allows; this is what the cost sums (squared, halved, over every sample)."""
        return self.rms / self.scale if self.scale else None


def signal_errors(fit: ExperimentFit) -> list[SignalError]:
    """RMS error per fitted signal of one recording: the per-experiment counterpart of
    the pooled nrmse, in the signal's own unit so it can be compared with the sensor.
    Missing samples (NaN) have no error; a result read back from its file keeps the RMS
    of every sample (`fit.rms`), its arrays being only their envelope."""
    errors = []
    for name, recorded in fit.recorded.items():
        if name in fit.rms:
            rms = float(fit.rms[name])
        else:
            residual = np.asarray(recorded, float) - np.asarray(fit.simulated[name], float)
            residual = residual[np.isfinite(residual)]
            rms = float(np.sqrt(np.mean(residual**2))) if residual.size else math.nan
        errors.append(SignalError(fit.name, name, rms, (fit.resolution or {}).get(name), (fit.scale or {}).get(name)))
    return errors


COST_DEFINITION = (
    "The cost is ½ Σ r², summed over every fitted sample of every recording, where r is the "
    "residual (simulated − recorded) divided by its signal's error scale σ = √(noise² + step²/12) "
    "(sensor noise and quantization from the sidecar, or the spread of the signal's sample-to-sample "
    "differences where it states neither). A fit as good as the sensors allow has r of spread 1, so "
    "a cost of about half the number of samples; the RMS of r below says how many times the noise "
    "the fit misses by.")


def fitted_samples(result: FitResult) -> int:
    """The samples the cost sums over: every fitted signal's samples of every recording."""
    return sum((fit.samples or len(fit.time)) * len(fit.recorded) for fit in result.experiments)


def scaled_rms(result: FitResult) -> float | None:
    """The RMS of the scaled residuals r (cost = ½ Σ r²): √(2 cost / N) over the samples of
    the fitted recordings; None when they are not known. (With --cost quantized, r is the
    distance beyond each reading's step, so this is smaller than the RMS errors in σ.)"""
    samples = fitted_samples(result)
    if not samples or not finite(result.cost):
        return None
    return math.sqrt(2.0 * float(result.cost) / samples)


@dataclass(frozen=True)
class RecordingValue:
    """One parameter value one recording ran with, and why it differs (if it does)."""

    value: float | None
    overridden: bool  # set by the recording's sidecar (or its own initial state)
    fitted: bool  # estimated for this recording alone (phi0[run1])

    def differs(self, known: float | None) -> bool:
        return self.value is not None and known is not None and not _same(self.value, known)


def _same(a: float, b: float) -> bool:
    return a == b or (math.isfinite(a) and math.isfinite(b) and math.isclose(a, b, rel_tol=1e-12, abs_tol=0.0))


def recording_values(result: FitResult) -> tuple[list[ExperimentFit], dict[str, dict[str, RecordingValue]]]:
    """(recordings, name -> recording name -> value) for every parameter that some
    recording ran with at a value other than the result's (a sidecar's m_p = 0, its own
    release angle), or that a sidecar or a per-recording estimate sets. Parameters every
    recording ran with at the result's value are left out: the known-values table shows them."""
    fits = [*result.experiments, *result.predicted]
    entries: dict[str, dict[str, RecordingValue]] = {}
    for fit in fits:
        values = {**fit.values, **result.initial.get(fit.name, {})}
        for name, value in values.items():
            own = label(name, fit.name) in result.estimates
            entries.setdefault(name, {})[fit.name] = RecordingValue(float(value), name in fit.overrides, own)
    shown = {name: row for name, row in entries.items()
             if any(v.overridden or v.fitted or v.differs(result.parameters.get(name)) for v in row.values())}
    missing = RecordingValue(None, False, False)  # a parameter this recording's model does not have
    return fits, {name: {fit.name: shown[name].get(fit.name, missing) for fit in fits} for name in sorted(shown)}


def ran_with(result: FitResult, name: str) -> str:
    """What the recordings ran with for a known parameter, when some differ from the
    result's value: e.g. "0 in 3 of 3 recordings (sidecar)"; "" when all agree or the
    result does not say (a file written before per-recording values were kept)."""
    fits = [f for f in [*result.experiments, *result.predicted] if name in f.values]
    known = result.parameters.get(name)
    if not fits or known is None:
        return ""
    different: dict[float, list[ExperimentFit]] = {}
    for fit in fits:
        if not _same(float(fit.values[name]), float(known)):
            different.setdefault(float(fit.values[name]), []).append(fit)
    parts = []
    for value, which in different.items():
        sidecar = " (sidecar)" if all(name in f.overrides for f in which) else ""
        parts.append(f"{value:.6g} in {len(which)} of {len(fits)} recordings{sidecar}")
    return "; ".join(parts)


def fitted_joints(result: FitResult) -> list[Joint]:
    """The joints whose friction the result identified: any term of their law fitted.

    Every result carries all rig values in `parameters` (the defaults of stages not run),
    so the estimates, not the parameters, say which curves are the fit's own."""
    return [joint for joint in JOINTS.values() if any(name in result.estimates for name in joint.parameters)]


def fitted_values(result: FitResult, joint: Joint) -> dict[str, float]:
    """The joint's law parameters: fitted values first, the values the stage ran with
    otherwise (a result from before a term existed: the table's default, which is off)."""
    values = {name: float(result.parameters[name]) for name in joint.parameters if name in result.parameters}
    values.update({name: float(result.estimates[name].value) for name in joint.parameters if name in result.estimates})
    return values


def fitted_law(result: FitResult, joint: Joint) -> Law:
    """The friction law the result identified for `joint`, every term included."""
    return joint.law(fitted_values(result, joint))


CURVE_POINTS = 200  # per direction, evenly over the speed range
STRIBECK_POINTS = 60  # per direction, evenly over the first STRIBECK_SPAN Stribeck speeds (the fall from F_S)
STRIBECK_SPAN = 3.0  # exp(-9): the Stribeck term has fallen to 1e-4 of its start
NEAR_REST = 1e-6  # the slowest speed drawn, in units of the range: the sliding branch's end at rest


def speed_range(law: Law) -> float:
    """Wide enough that the viscous slope shows next to the Coulomb step: the speed at
    which viscous friction reaches about 1.5 times the larger of the two thresholds, and
    at least the Stribeck fall."""
    threshold = max(law.F_K + abs(law.dF_K), law.F_S, 0.0)
    k_fw = law.k_fw - abs(law.dk_fw)  # the flatter direction
    v_max = 1.5 * threshold / k_fw if k_fw > 0 and threshold > 0 else 1.0
    return max(v_max, STRIBECK_SPAN * law.v_S)


def friction_curve(law: Law) -> tuple[np.ndarray, np.ndarray]:
    """(speeds, forces) of the sliding friction the report draws: backward then forward
    over the speed range, denser where a Stribeck term falls, from NEAR_REST of the range
    (a sliding joint never has speed 0: at rest it is stuck) to the range's end."""
    v_max = speed_range(law)
    forward = np.linspace(0.0, v_max, CURVE_POINTS + 1)[1:]
    if law.v_S > 0:
        forward = np.concatenate([forward, np.linspace(0.0, STRIBECK_SPAN * law.v_S, STRIBECK_POINTS + 1)[1:]])
    forward = np.unique(np.concatenate([[NEAR_REST * v_max], forward]))
    speeds = np.concatenate([-forward[::-1], forward])
    return speeds, law.sliding(speeds)


def residual_fits(result: FitResult) -> list[tuple[ExperimentFit, str]]:
    """The recordings whose residuals the report diagnoses, each with how to name it: the
    fitted ones, then those only predicted with the result (fit all's), which say the more
    for not having been fitted."""
    return [(fit, fit.name) for fit in result.experiments] + [(fit, f"{fit.name} (predicted, not fitted)")
                                                             for fit in result.predicted]


def assessments(result: FitResult) -> dict[str, dict]:
    """The result's verdicts by stage (fitting/adequacy.py): a stage's own, or, for a
    sequence of stages, each stage's; empty for a result written before there were any."""
    assessment = result.assessment or {}
    if "stages" in assessment:
        return {stage: own for stage, own in assessment["stages"].items() if own and own.get("verdict")}
    return {result.stage: assessment} if assessment.get("verdict") else {}


def beyond_the_limit(assessment: dict) -> dict[str, dict]:
    """The parameters whose early and late halves disagree by more than the validation
    allows (validation.moving): one combined interval on a fit whose residuals stand above
    the noise limit (adequacy.MODEL_ERROR_LIMIT); none on a fit within it, whose halves are
    shown, not judged."""
    spread = assessment.get("spread")
    adequate = spread <= MODEL_ERROR_LIMIT if finite(spread) else assessment.get("verdict") == "adequate"
    return moving(assessment.get("windows") or {}, adequate)


def white_noise_band(samples: int) -> float:
    """Half-width of the 95 % band the autocorrelation of `samples` values of white noise
    stays within at every lag but 0 (Bartlett: each is about normal with variance 1/N)."""
    return Z95 / math.sqrt(samples)


JOINT_LEVEL = math.sqrt(-2.0 * math.log(0.05))
"""The radius, in standard deviations, of a two-dimensional normal's 95 % region (the
chi-square quantile of two degrees of freedom, sqrt(5.99))."""


def log_spread(estimate: Estimate) -> float | None:
    """The standard deviation of a positive estimate's logarithm: from its 95 % interval
    (the reported one, widened where the fit widened it; an interval off the estimate's
    centre on the log scale counts by its mean half-width), else from its standard error."""
    if not (finite(estimate.value) and estimate.value > 0):
        return None
    if estimate.ci95 is not None and all(finite(end) and end > 0 for end in estimate.ci95):
        low, high = estimate.ci95
        if high > low:
            return (math.log(high) - math.log(low)) / (2.0 * Z95)
    if finite(estimate.stderr) and estimate.stderr > 0:
        return float(estimate.stderr) / float(estimate.value)
    return None


def joint_region(a: Estimate, b: Estimate, rho: float, points: int = 240) -> np.ndarray | None:
    """The 95 % region of two positive estimates, on the log scale, as the (2, points)
    logarithms of its boundary: the ellipse of their log-scale spreads (log_spread) and
    correlation `rho`. None when either has no spread."""
    sa, sb = log_spread(a), log_spread(b)
    if sa is None or sb is None or not finite(rho):
        return None
    rho = max(-1.0, min(1.0, float(rho)))
    covariance = np.array([[sa * sa, rho * sa * sb], [rho * sa * sb, sb * sb]])
    variances, axes = np.linalg.eigh(covariance)
    angle = np.linspace(0.0, 2.0 * math.pi, points)
    circle = np.vstack([np.cos(angle), np.sin(angle)]) * JOINT_LEVEL
    centre = np.array([[math.log(a.value)], [math.log(b.value)]])
    return centre + axes @ (np.sqrt(np.clip(variances, 0.0, None))[:, None] * circle)
