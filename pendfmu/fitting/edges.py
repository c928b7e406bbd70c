"""Estimates at the edge of their box: what the edge means, and an interval that is not a point.

An initial state read off a recording (the release angle, a tachometer's first reading) is
searched within what its sensor allows (experiment.reading_box). A fit that ends at the
edge of that box wants a start the sensor rules out, and the residuals tell why:

- far above the sensor noise (above the fit's model-error limit): the model cannot follow
  the recording, and the start absorbs part of its error. On the real free decays
  (MultiArm, 8 windows) every release angle ended at its edge with residuals 16-134 times
  the sensor noise; freed to +-200 encoder steps, one window's angle moved 53 steps from its
  reading and the residuals fell only from 134 to 98 times the noise. A wider box lets the
  start hide more of the model's error; the cause is what the model misses.
- near the sensor noise: the sensor's description may be off (its step, quantizer or noise
  as the sidecar states them, or its zero), or the model misses a term small enough to
  hide in the noise (measured: a reference-simulator decay with air drag, read by a 10-bit
  encoder, fitted without drag: residuals 2.8 times the noise, the start at its edge 5.4 mrad
  from the truth, the drag taken up by k_fwp).

The flag says which, instead of advising a wider box. Advice for any other parameter at a
bound gains the same evidence when the residuals are far above the noise.

The interval. Every bootstrap refit starts at the estimate and stays at the edge as the fit
did, so the replicates' spread is nil and the interval a point (MultiArm's windows printed
[2.281, 2.281]); a Jacobian interval straddles the edge, half of it where the sensor rules
the value out. An estimate at the edge of a sensor's box has its interval cut to the box;
any estimate at a bound whose interval is (almost) a point gets one that reaches from the
edge into the box by the Jacobian's 95 % half-width (the whole box where that is unknown),
and a flag that says so. Its correlations, computed from no spread at all, are dropped.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

from pendfmu.fitting.experiment import Experiment, StartState
from pendfmu.fitting.residuals import FreeParameter
from pendfmu.fitting.result import Estimate, Flag
from pendfmu.fitting.statistics import Z95, at_bound, estimate_uncertainty

POINT = 1e-6
"""An interval narrower than this fraction of its box is a point (the bootstrap rounds the
estimate to 1e-6 of the box before its refits)."""

BOUND_FLAGS = ("at its lower bound", "at its upper bound")


def explain_edges(free: Sequence[FreeParameter], outcome, estimates: dict[str, Estimate],
                  correlation: dict[str, dict[str, float | None]], experiments: Sequence[Experiment],
                  spread: float, limit: float) -> None:
    """Name the cause in the flag of every estimate at a bound, and give it an interval that
    is not a point (module docstring). `outcome` is the search's (u, jacobian, residual);
    `spread` the RMS of the scaled residuals, `limit` where the model is said to miss
    something."""
    by_name = {e.name: e for e in experiments}
    linear: dict[str, Estimate] | None = None
    for k, p in enumerate(free):
        estimate = estimates[p.label]
        if not at_bound(outcome.u[k]) or p.relative_to or estimate.method == "bounded":
            continue  # stiction relative to Coulomb friction: its bound is stiction.py's to read
        lower = bool(outcome.u[k] <= 0.5)
        experiment = by_name.get(p.experiment) if p.experiment else None
        state = experiment.read_from.get(p.name) if experiment is not None and _sensors_box(p, experiment) else None
        if state is not None:
            _set_bound_flag(estimate, sensor_edge(p, lower, experiment, state, spread, limit))
        elif spread > limit:
            _extend_bound_flag(estimate, f"; the residuals are {spread:.3g} times the sensor noise, though: the model "
                                         f"misses something, which a parameter at its bound may be absorbing, so a "
                                         f"wider box may not help")
        if estimate.ci95 is None:
            continue
        if state is not None:
            estimate.ci95 = (max(estimate.ci95[0], p.low), min(estimate.ci95[1], p.high))
        if _is_point(estimate.ci95, p):
            if linear is None:
                linear = estimate_uncertainty(list(free), outcome.u, outcome.jacobian, outcome.residual)[0]
            _one_sided(estimate, p, lower, linear[p.label].stderr)
            _drop_correlations(p.label, estimates, correlation)


def sensor_edge(p: FreeParameter, lower: bool, experiment: Experiment, state: StartState, spread: float,
                limit: float) -> str:
    """The flag of an initial state at the edge of the box its first readings allow."""
    recording = experiment.recording
    reading = experiment.estimated[p.name][0]
    if state.turning:
        told = (f"what a turning point of {state.column} allows (the swing turns within a sample interval of "
                f"t = {recording.time[0]:g} s; the parabola through the readings there: {reading:.6g}")
    else:
        what = (f"the slope of the first readings of {state.column}" if state.rate else
                f"the reading of {state.column} at t = {recording.time[0]:g} s")
        told = f"what its sensor allows ({what}: {reading:.6g}"
    head = (f"at its {'lower' if lower else 'upper'} bound {p.low if lower else p.high:.6g}, the edge of {told}, "
            f"box [{p.low:.6g}, {p.high:.6g}])")
    if spread > limit:
        return (f"{head}: the residuals are {spread:.3g} times the sensor noise, so the model cannot follow this "
                f"recording and the start absorbs part of its error. The box is not the cause (a wider one lets the "
                f"start absorb more): look at what the model misses, in the residuals against time and amplitude "
                f"(--report): a friction term, the inertia, the sensor's zero or gain "
                f"({state.column}_offset, {state.column}_scale)")
    return (f"{head}: the data pull the start beyond what the sensor allows while the residuals stay near its "
            f"noise ({spread:.2g} times): either the sensor is described wrong (check the resolution, quantizer and "
            f"noise the sidecar states for {state.column}, or fit its zero: --free {state.column}_offset), or the "
            f"model misses a small term that the start absorbs (free the term you suspect, e.g. a friction extra, "
            f"and compare the fits)")


def _sensors_box(p: FreeParameter, experiment: Experiment) -> bool:
    """Whether p's box is the one its sensor's first readings gave (not the user's --bounds:
    then the box, not the sensor, set the edge, and the usual advice to widen it holds)."""
    _, low, high = experiment.estimated.get(p.name, (None, None, None))
    return low is not None and high is not None and math.isclose(p.low, low) and math.isclose(p.high, high)


def _set_bound_flag(estimate: Estimate, text: str) -> None:
    estimate.flags = [Flag(text, "at-bound") if flag.startswith(BOUND_FLAGS) else flag for flag in estimate.flags]


def _extend_bound_flag(estimate: Estimate, more: str) -> None:
    estimate.flags = [Flag(flag + more, "at-bound") if flag.startswith(BOUND_FLAGS) else flag
                      for flag in estimate.flags]


def _is_point(interval: tuple[float, float], p: FreeParameter) -> bool:
    low, high = interval
    return bool(math.isfinite(low) and math.isfinite(high) and high - low <= POINT * (p.high - p.low))


def _one_sided(estimate: Estimate, p: FreeParameter, lower: bool, stderr: float | None) -> None:
    """The interval from the edge into the box by the Jacobian's 95 % half-width."""
    known = stderr is not None and math.isfinite(stderr) and stderr > 0
    reach = Z95 * stderr if known else p.high - p.low
    edge = p.low if lower else p.high
    low, high = (edge, min(edge + reach, p.high)) if lower else (max(edge - reach, p.low), edge)
    estimate.ci95 = (float(low), float(high))
    why = "the Jacobian's half-width" if known else "the whole box: the Jacobian gives no width either"
    estimate.flags.append(Flag(f"one-sided 95 % interval [{low:.6g}, {high:.6g}] from the edge of its box ({why}): "
                               f"every refit stayed at the edge, so the refits' spread is nil", "at-bound"))


def _drop_correlations(label: str, estimates: Mapping[str, Estimate],
                       correlation: dict[str, dict[str, float | None]]) -> None:
    """Correlations with an estimate that did not move in any refit are noise: dropped."""
    for other, row in correlation.items():
        if label in row and other != label:
            row[label] = None
    for other in correlation.get(label, {}):
        if other != label:
            correlation[label][other] = None
    for other, estimate in estimates.items():
        estimate.flags = [flag for flag in estimate.flags if not flag.startswith("correlated")
                          or (other != label and f" with {label}: " not in flag)]

