"""What stick-slip recordings say about stiction: a value, or only a set of values.

Stiction (F_Sc of the cart, T_Sp of the pendulum) acts at two kinds of instant only:

- a stuck joint whose active force grows through the threshold breaks away there, so the
  recording pins the threshold to the force at that instant (a *crossing*);
- a sliding joint that comes to rest sticks if the force it must then hold is within the
  threshold and reverses otherwise; a joint released from rest slides at once if the force
  already exceeds it. Each such instant bounds the threshold from one side.

Recordings without a crossing therefore only bound stiction: every threshold between the
largest force a stuck joint held and the smallest force at which it reversed or slid
from rest gives the same trajectories, and the least-squares cost is flat in between. A
bootstrap cannot see that (its refits do not move along a flat direction), and a global
search stops anywhere in it, so that the value would depend on the seed. Such a
parameter is reported as the set instead, the same for every seed, widened by the sets
of the bootstrap's replicates (the set's ends move with the other estimates), with the
least stiction the recordings demand as its value.

Stuck is exact in the FMUs (speed and acceleration are exactly zero), so the modes can be
read from their outputs at the samples.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, replace

import numpy as np

from pendfmu.errors import FMUError
from pendfmu.fitting.residuals import Residuals, unit_of
from pendfmu.fitting.result import Estimate, Flag
from pendfmu.friction import JOINTS, Joint


HELD_BEFORE_CROSSING = 2  # samples a joint must have been stuck for its breakaway to pin the threshold


@dataclass(frozen=True)
class Evidence:
    """What one set of simulations shows about a joint's threshold."""

    crossings: int  # breakaways of a joint that had been stuck: each pins the threshold
    low: float  # the largest force held while stuck: the threshold is at least this
    high: float  # the smallest force at a reversal or a slide from rest: the threshold is below


def evidence(simulations: Iterable[Mapping[str, np.ndarray]], joint: Joint) -> Evidence:
    crossings, low, high = 0, 0.0, math.inf
    for simulated in simulations:
        force = np.abs(simulated[joint.active])
        speed = simulated[joint.speed]
        moving = (speed != 0) | (simulated[joint.acceleration] != 0)
        stuck = ~moving
        if stuck.any():
            low = max(low, float(force[stuck].max()))
        reversal = moving[:-1] & moving[1:] & (np.sign(speed[:-1]) * np.sign(speed[1:]) < 0)
        if reversal.any():
            high = min(high, float(force[1:][reversal].min()))
        if moving[0] and speed[0] == 0:  # released from rest and sliding at once
            high = min(high, float(force[0]))
        starts = np.flatnonzero(moving[1:] & stuck[:-1]) + 1
        crossings += int(sum(k >= HELD_BEFORE_CROSSING and stuck[k - HELD_BEFORE_CROSSING:k].all() for k in starts))
    return Evidence(crossings, low, high)


def bounded_set(found: Evidence, replicates: Iterable[Evidence], coulomb: float) -> tuple[float, float] | None:
    """The set of thresholds the recordings allow (None when they pin it): the estimate's
    set widened by the replicates' sets. Below the
    Coulomb friction stiction has no effect (the threshold is max(F_S, F_K)), so the set
    starts there at the least."""
    if found.crossings:
        return None
    replicates = list(replicates)
    lows = [found.low] + [r.low for r in replicates if not r.crossings]
    highs = [found.high] + [r.high for r in replicates if not r.crossings]
    low, high = max(min(lows), coulomb), max(highs)
    # The forces are read at the samples, not at the instants of sticking and reversing: a
    # force held may then exceed one reversed at by a sample's change. The threshold is
    # between them either way.
    return (low, high) if high >= low else (high, low)


def bound_stiction(stage: str, residuals: Residuals, u: np.ndarray, estimates: dict[str, Estimate],
                    fitted: dict[str, float], replicates: np.ndarray | None) -> list[str]:
    """Stiction that the recordings only bound (stiction.py: no breakaway of a joint at
    rest in any of them) is reported as that set, the same for every seed, with the least
    stiction the recordings demand as its value."""
    joint = JOINTS[stage]
    if joint.stiction not in estimates:
        return []
    extra = (joint.active, joint.speed, joint.acceleration)
    found = evidence(residuals.simulate(u, extra=extra), joint)
    others = []
    for row in replicates if replicates is not None else []:
        if not np.isnan(row).any():
            try:
                others.append(evidence(residuals.simulate(unit_of(residuals.free, row), extra=extra), joint))
            except FMUError:
                continue
    coulomb = fitted.get(joint.coulomb, residuals.shared.get(joint.coulomb, 0.0))
    bounds = bounded_set(found, others, coulomb)
    if bounds is None:
        return []
    low, high = bounds
    fitted[joint.stiction] = low
    estimates[joint.stiction] = replace(
        estimates[joint.stiction], value=low, stderr=None, ci95=(low, high), method="bounded", flags=[Flag(
            f"bounded only: every {joint.stiction} in [{low:.4g}, {high:.4g}] {joint.unit} gives the same recordings "
            f"(no joint at rest broke away in them: they only show where it stuck or reversed); the value given is "
            f"the least stiction the recordings demand"
            + (". Record the 'pendulum-stiction' experiment (pendfmu rig) to pin it down" if stage == "pendulum"
               else ". Record a slow ramp of the drive from rest to pin it down"), "bounded-only")])
    return [f"{joint.stiction} is set-identified: [{low:.4g}, {high:.4g}] {joint.unit}"]
