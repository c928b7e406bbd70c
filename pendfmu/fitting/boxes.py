"""Search boxes cut to what is physically possible: a parameter's declared range and the
rules between parameters (pendfmu/physics.py).

Why: a box chosen by a policy (a decade around a prior, DEFAULT_BOUNDS, --bounds) may reach
values the FMU refuses. Each such candidate is a failed simulation, penalized and wasted:
with J_p free, the box [1e-6, 10] kg m2 reached below m_p l^2, and a pendulum fit on the
virtual rig's decay lost 341 of its 1760 simulations there. The box of both the paper's
stages (stages.py) and a user's model (models.py) is cut here, once.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Iterable, Mapping, Sequence

from pendfmu import physics
from pendfmu.errors import BadInput
from pendfmu.fitting.residuals import FreeParameter

Declared = Callable[[str], tuple[float | None, float | None]]
"""name -> the (low, high) its variable declares (None: unbounded)."""


def rule_limits(name: str, free: Sequence[FreeParameter], known: Iterable[Mapping[str, float]]
                ) -> tuple[float, float]:
    """The values of `name` the rules allow for every set of known values in `known` (one
    per recording: a sidecar may set m_p), whatever the other free parameters are in
    their boxes."""
    boxes = {p.name: (p.low, p.high) for p in free if p.experiment is None and p.relative_to is None}
    low, high = -math.inf, math.inf
    for values in known:
        ranges = {**{n: (v, v) for n, v in values.items() if n in physics.DEFAULTS}, **boxes}
        ranges.pop(name, None)
        own_low, own_high = physics.limits(name, ranges)
        low, high = max(low, own_low), min(high, own_high)
    return low, high


def cut_to_physics(free: Sequence[FreeParameter], known: Mapping[str, Mapping[str, float]], declared: Declared
                   ) -> list[FreeParameter]:
    """Every box cut to its parameter's declared range and to the rules between parameters,
    with the known values of each recording (`known`: recording name -> its values; a
    recording's own parameter with that recording's alone). A box left unchanged is the
    same object: the paper's standard fits stay bit-identical. A relative box (stiction
    over Coulomb friction) is a ratio, not a value: left as it is."""
    result = []
    for p in free:
        if p.relative_to is not None:
            result.append(p)
            continue
        runs = known.values() if p.experiment is None else [known[p.experiment]]
        rule_low, rule_high = rule_limits(p.name, free, runs)
        own_low, own_high = declared(p.name)
        allowed = (max(rule_low, -math.inf if own_low is None else own_low),
                   min(rule_high, math.inf if own_high is None else own_high))
        low, high = max(p.low, allowed[0]), min(p.high, allowed[1])
        if low == p.low and high == p.high:
            result.append(p)
            continue
        if not high > low:
            raise BadInput(f"parameter {p.label}: its search box [{p.low:g}, {p.high:g}] holds no physically possible "
                           f"value (its range and the rules between parameters allow [{allowed[0]:g}, "
                           f"{allowed[1]:g}]); give another with --bounds")
        result.append(dataclasses.replace(p, low=float(low), high=float(high)))
    return result
