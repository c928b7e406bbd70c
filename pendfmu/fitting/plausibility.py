"""Plausibility of recordings before a fit: data that look mis-scaled or incomplete.

A fit to a recording in the wrong units does not fail: it converges to confident, wrong
values (time in ms makes every friction a thousand times too large). These checks look
for the usual slips before any simulation runs, each against something physical the
recording must agree with, and return warnings that name the file and the column:

- time in ms: the sample period and the duration against what the stage's dynamics
  allow, and a free swing's period against the pendulum's own (from m_p, l, J_p, g);
- positions in mm or angles in degrees: the smallest step between readings against the
  resolution the sidecar states (one count), or, without one, magnitudes no lab rig has;
- a missing sidecar: the values a sidecar usually states for a run (the pendulum removed
  from the cart, the initial speed) are then assumed, and the warning says which.

Warnings are not errors: unusual data can be right. The command line prints them at once
and `--strict` turns them into a non-zero exit code.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from pendfmu.components import CART, SELF_LOCKING_ETA
from pendfmu.errors import Suspicious
from pendfmu.fitting.experiment import Experiment
from pendfmu.fitting.residuals import FreeParameter

# Slowest plausible sampling per stage [s]: a current loop of ~1 ms needs sub-ms samples;
# a cart or pendulum sampled below 20 Hz shows nothing of its friction.
MAX_SAMPLE_PERIOD = {"current": 1e-3, "cart": 0.05, "pendulum": 0.05}
MAX_DURATION = 3600.0  # [s] one identification run; longer is most likely time in ms
# Magnitudes no lab rig of this kind reaches in SI units.
MAX_MAGNITUDE = {"x": (5.0, "m", "mm"), "I": (200.0, "A", "mA"), "I_c": (200.0, "A", "mA")}
MAX_ANGLE_SPAN = 3 * math.pi  # more than a turn and a half of a pendulum's swing
PERIOD_RATIO = 3.0  # a free swing's period may differ this much from the small-angle one
# Values a sidecar usually states for one run, per stage, and what assuming them means.
RUN_VALUES = {"cart": ("m_p", "x0", "v0"), "pendulum": ("w0",), "current": ("I0",)}
UNIT_SLIPS = ((1000.0, "1000 times: is it in milli-units (mm, mA, ms)?"),
              (180.0 / math.pi, "180/pi times: is the angle in degrees?"))


class SuspiciousData(Suspicious):
    """Warnings about the recordings, raised instead of fitting when the caller is strict."""

    def __init__(self, warnings: list[str]):
        super().__init__(f"{len(warnings)} warning(s) about the recordings (strict: not fitted): " + "; ".join(warnings))
        self.warnings = list(warnings)


def self_locking_switch(free: Sequence[FreeParameter], experiments: Sequence[Experiment]) -> list[str]:
    """A warning when a fit frees eta over a box that straddles the self-locking limit (0.5)
    while the paper's switch is on (eta_back = -1) and a recording has a pendulum on the cart:
    inside the box the screw turns from self-locking to back-drivable, so the model the fit
    explores changes its kind, not only its efficiency (docs/user-guide/drives.md)."""
    box = next((p for p in free if p.name == "eta" and p.experiment is None), None)
    if box is None or not box.low <= SELF_LOCKING_ETA < box.high:
        return []
    cart_default = CART.parameters
    switched = [e.name for e in experiments
                if e.fixed.get("eta_back", cart_default["eta_back"].start) < 0
                and e.fixed.get("m_p", cart_default["m_p"].start) > 0]
    if not switched:
        return []
    return [f"eta is searched over [{box.low:g}, {box.high:g}], which straddles {SELF_LOCKING_ETA}: with the "
            f"pendulum on the cart ({', '.join(switched)}: m_p > 0) the screw's self-locking switches inside the "
            f"box (eta > {SELF_LOCKING_ETA} makes it back-drivable); if eta is only the drive's efficiency, set "
            f"eta_back=0 (never back-driven), or bound eta to one side (bounds eta=LOW:HIGH)"]


def viscous_twins(free: Sequence[FreeParameter], experiments: Sequence[Experiment]) -> list[str]:
    """A warning when a fit frees both k_fwc and k_emf without an electrical lag: the back-EMF
    then acts on x as viscous friction does (docs/user-guide/drives.md), and only k_fwc + eta k_emf is
    determined."""
    names = {p.name for p in free if p.experiment is None}
    if not {"k_fwc", "k_emf"} <= names or "tau_e" in names:
        return []
    if any(e.fixed.get("tau_e", 0.0) > 0 for e in experiments):
        return []
    return ["k_fwc and k_emf are both fitted, but without an electrical lag (tau_e = 0) the back-EMF acts on "
            "the cart as viscous friction does: only k_fwc + eta*k_emf is determined. Fix k_fwc at the value of a "
            "current-driven run (fix k_fwc), or k_emf"]


def check_experiment(experiment: Experiment) -> list[str]:
    """Every warning about one recording as its stage sees it."""
    warnings = _time_scale(experiment)
    stage = experiment.setup.name
    for name in dict.fromkeys((*experiment.match.values(), *(c for c, _ in experiment.setup.drives.values()))):
        warnings += _signal_scale(experiment, name)
    if stage == "pendulum" and not experiment.setup.drives:
        warnings += _swing_period(experiment)
    if experiment.recording.undescribed:
        warnings += _missing_sidecar(experiment)
    return warnings


def _where(experiment: Experiment) -> str:
    return str(experiment.recording.path or "recording")


def _time_scale(experiment: Experiment) -> list[str]:
    time = experiment.time
    if len(time) < 2:
        return []
    period = float(np.median(np.diff(time)))
    duration = float(time[-1] - time[0])
    warnings = []
    limit = MAX_SAMPLE_PERIOD.get(experiment.setup.name, math.inf)  # a user's model: no rule known
    if period > limit:
        warnings.append(f"{_where(experiment)}: column 'time': samples {period:.4g} s apart ({1 / period:.3g} Hz), "
                        f"slower than a {experiment.setup.name} recording can be (at most {limit:g} s): time must be "
                        f"in seconds; is it in ms?")
    if duration > MAX_DURATION:
        warnings.append(f"{_where(experiment)}: column 'time': the recording lasts {duration:.4g} s "
                        f"({duration / 3600:.3g} h): time must be in seconds; is it in ms?")
    return warnings


def _signal_scale(experiment: Experiment, name: str) -> list[str]:
    recording = experiment.recording
    values = recording.signal(name)
    resolution = recording.resolution(name)
    if resolution:
        return _against_resolution(experiment, name, values, resolution)
    warnings = []
    if name in MAX_MAGNITUDE:
        limit, unit, slip = MAX_MAGNITUDE[name]
        largest = float(np.max(np.abs(values)))
        if largest > limit:
            warnings.append(f"{_where(experiment)}: column {name!r}: values up to {largest:.4g} {unit}, more than a "
                            f"lab rig reaches ({limit:g} {unit}): {name} must be in {unit}; is it in {slip}?")
    if name == "phi" and float(np.ptp(values)) > MAX_ANGLE_SPAN:
        warnings.append(f"{_where(experiment)}: column 'phi': the angle spans {float(np.ptp(values)):.4g} rad, more "
                        f"than a turn and a half: phi must be in rad; is it in degrees?")
    return warnings


def _against_resolution(experiment: Experiment, name: str, values: np.ndarray, resolution: float) -> list[str]:
    """A quantized signal moves in whole counts: its smallest change between samples is
    one count. A smallest change of 1000 counts is a signal in mm against a resolution in
    m; 57.3 counts an angle in degrees; a fraction of a count a wrong resolution."""
    steps = np.abs(np.diff(values))
    steps = steps[steps > 1e-3 * resolution]  # below: the same reading, written with rounding errors
    if len(steps) < 3:
        return []
    smallest = float(np.min(steps)) / resolution
    where = f"{_where(experiment)}: column {name!r}"
    for factor, hint in UNIT_SLIPS:
        if abs(smallest / factor - 1) < 0.02:
            return [f"{where}: the smallest change between readings is {smallest:.4g} times the sidecar's "
                    f"resolution {resolution:.4g}, not one count; the values look {hint}"]
    if smallest < 0.5:
        return [f"{where}: readings change by {smallest:.3g} of the sidecar's resolution {resolution:.4g}: the "
                f"stated resolution is too coarse for these values (or the signal is not in SI units)"]
    return []


def _swing_period(experiment: Experiment) -> list[str]:
    """A free swing's period against the small-angle period 2 pi sqrt(J / (m g l))."""
    values = experiment.fixed
    m, l, g = values.get("m_p", 0.0), values.get("l", 0.0), values.get("g", 0.0)
    if not (m > 0 and l > 0 and g > 0):
        return []
    inertia = values.get("J_p") or 4.0 / 3.0 * m * l * l
    expected = 2 * math.pi * math.sqrt(inertia / (m * g * l))
    phi = experiment.recording.signal("phi")
    centred = phi - np.median(phi[len(phi) // 2:])
    signs = np.sign(centred)
    signs = signs[signs != 0]
    crossings = np.flatnonzero(np.diff(signs) != 0)
    if len(crossings) < 4:
        return []
    time = experiment.time[np.flatnonzero(np.sign(centred))][crossings]
    measured = 2 * float(np.median(np.diff(time)))
    ratio = measured / expected
    if 1 / PERIOD_RATIO <= ratio <= PERIOD_RATIO:
        return []
    return [f"{_where(experiment)}: column 'phi': the recorded swing has a period of {measured:.4g} s, but a pendulum "
            f"with m_p = {m:g} kg, l = {l:g} m, J_p = {inertia:.4g} kg.m2 swings with {expected:.4g} s: check that "
            f"time is in seconds, phi in rad, and the pendulum's m_p, l, J_p"]


def _missing_sidecar(experiment: Experiment) -> list[str]:
    path = experiment.recording.path
    sidecar = path.with_suffix(".json").name if path else "a sidecar"
    assumed = [f"{name} = {experiment.fixed[name]:g}" for name in RUN_VALUES.get(experiment.setup.name, ())
               if name in experiment.fixed and name not in experiment.estimated]  # estimated: read off the data
    text = (f"{_where(experiment)}: no sidecar ({sidecar}): the run is assumed to have "
            f"{', '.join(assumed) or 'the default values'} (the given params, or the reference rig), and the "
            f"sensor's error scale is estimated from the data")
    if experiment.setup.name == "cart" and experiment.fixed.get("m_p", 0.0) > 0:
        text += "; if the pendulum was removed for this run, state \"parameters\": {\"m_p\": 0} in the sidecar"
    return [text]
