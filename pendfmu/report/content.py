"""What a report says, independent of how it is drawn: units, error measures, joints.

The figures and the HTML page both need the unit of a name, the per-recording error and
which friction curves a result determines; computing them once here keeps the two views
of the same numbers from drifting apart.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

import numpy as np

from pendfmu.components import COMPONENTS
from pendfmu.fitting.result import Estimate, ExperimentFit, FitResult


def unit(name: str) -> str:
    """The unit of a variable or parameter from the FMU tables (pendfmu.components).

    Per-recording estimates are labelled ``phi0[recording]``; they take the unit of the
    parameter before the bracket. An unknown name has no unit (empty string)."""
    base = name.split("[", 1)[0]
    for component in COMPONENTS.values():
        for variable in component.variables:
            if variable.name == base:
                return variable.unit
    return ""


def component_of(name: str) -> str:
    """The FMUs a parameter belongs to (m_p and l belong to two), for the known-values table."""
    return ", ".join(c.name for c in COMPONENTS.values() if name in c.parameters)


def description(name: str) -> str:
    base = name.split("[", 1)[0]
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

    @property
    def steps(self) -> float | None:
        return self.rms / self.resolution if self.resolution else None


def signal_errors(fit: ExperimentFit) -> list[SignalError]:
    """RMS error per fitted signal of one recording: the per-experiment counterpart of
    the pooled nrmse, in the signal's own unit so it can be compared with the sensor."""
    errors = []
    for name, recorded in fit.recorded.items():
        residual = np.asarray(recorded, float) - np.asarray(fit.simulated[name], float)
        rms = float(np.sqrt(np.mean(residual**2))) if residual.size else math.nan
        errors.append(SignalError(fit.name, name, rms, (getattr(fit, "resolution", None) or {}).get(name)))
    return errors


@dataclass(frozen=True)
class Joint:
    """A joint with the friction law of MODEL.md, as the paper's Fig. 1 draws it."""

    name: str
    viscous: str
    coulomb: str
    stiction: str
    speed: str  # the joint's speed variable, for its unit
    speed_label: str
    force_label: str

    @property
    def parameters(self) -> tuple[str, str, str]:
        return self.viscous, self.coulomb, self.stiction


JOINTS = (
    Joint("cart", "k_fwc", "F_Kc", "F_Sc", "v", "cart speed v", "friction force F_F"),
    Joint("pendulum", "k_fwp", "T_Kp", "T_Sp", "w", "angular speed w", "friction torque T_F"),
)


def fitted_joints(result: FitResult) -> list[Joint]:
    """The joints whose friction the result identified: any of the three fitted.

    Every result carries all rig values in `parameters` (the defaults of stages not run),
    so the estimates, not the parameters, say which curves are the fit's own."""
    return [joint for joint in JOINTS if any(name in result.estimates for name in joint.parameters)]


def friction_values(result: FitResult, joint: Joint) -> tuple[float, float, float]:
    """(k_fw, F_K, F_S) of a joint: fitted values first, the values the stage ran with otherwise."""
    def value(name: str) -> float:
        if name in result.estimates:
            return float(result.estimates[name].value)
        return float(result.parameters.get(name, 0.0))

    return value(joint.viscous), value(joint.coulomb), value(joint.stiction)
