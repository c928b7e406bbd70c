"""Physical constraints between parameters: the one home in Python of the rules that tie
one parameter's possible values to another's.

A parameter's own range (m_p > 0, 0 < eta <= 1) is the variable table's (components.py,
ranges.py). The rules here need two or more values at once, so no single range can say
them. The FMUs check the same rules in C when they leave initialization
(model_check_parameters in csrc/Pendulum/model.c, csrc/Cart/model.c, csrc/Controller/model.c;
friction.h's friction_asymmetry_ok): there they fail a simulation after the work has
started; here they refuse the input before it, as a BadInput (exit 2).

- The pendulum's inertia J_p is about the pivot: at least m_p l^2, the inertia of its mass
  concentrated at its centre of mass (parallel-axis theorem); J_p = 0 means a uniform rod,
  (4/3) m_p l^2.
- A friction law's direction asymmetry leaves both directions' term >= 0: |dk| <= k.
- The Controller's saturation: u_min <= u_max.

Published data often give the inertia about the centre of mass. It is accepted under its
own name, J_cm, and converted where the values of a run are assembled:
J_p = J_cm + m_p l^2, with the m_p and l of that run (a recording's sidecar may set them).
The name follows the convention of J_p (J, subscript of the axis: p the pivot, cm the centre
of mass), reads as the centre-of-mass inertia in any mechanics text and cannot be mistaken
for a parameter of an FMU. Giving one quantity both ways is refused.

Values missing from a mapping are the variable table's defaults (the reference rig).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass

from pendfmu.components import ALL_COMPONENTS, Variable
from pendfmu.errors import BadInput
from pendfmu.ranges import number

CENTRE_OF_MASS_INERTIA = Variable(
    "J_cm", "parameter", "fixed", 0.0, "kg.m2",
    "Moment of inertia of the pendulum about its centre of mass: J_p = J_cm + m_p*l^2", low=0.0)
"""J_cm: not a variable of any FMU, an input that becomes J_p (module docstring)."""

J_CM = CENTRE_OF_MASS_INERTIA.name

# (mean, asymmetry, unit) of each friction law's direction-dependent terms (friction.h)
ASYMMETRIES = (("k_fwc", "dk_fwc", "N.s/m"), ("F_Kc", "dF_Kc", "N"), ("k_fwp", "dk_fwp", "N.m.s"),
               ("T_Kp", "dT_Kp", "N.m"))

POINT_MASS_TOLERANCE = 1e-12  # relative: as the Pendulum's C check, so that a converted J_cm = 0 passes both


class PhysicsError(BadInput):
    """Values that each lie in their range but together describe no physical rig (exit 2)."""


def _defaults() -> dict[str, float]:
    """Every component's table defaults by name (the first owner's where several share one)."""
    found: dict[str, float] = {}
    for component in ALL_COMPONENTS.values():
        for name, variable in component.parameters.items():
            found.setdefault(name, float(variable.start))
    return found


DEFAULTS = _defaults()


def _reader(values: Mapping[str, float]) -> Callable[[str], float]:
    return lambda name: float(values[name]) if name in values else DEFAULTS[name]


def point_mass_inertia(m_p: float, l: float) -> float:
    """m_p l^2: the least inertia about the pivot a pendulum of mass m_p, centre of mass at l, has."""
    return m_p * l * l


def pivot_inertia(values: Mapping[str, float]) -> float:
    """J_p as the Pendulum computes with it: the given one, or (4/3) m_p l^2 for J_p = 0."""
    get = _reader(values)
    return get("J_p") or 4.0 / 3.0 * point_mass_inertia(get("m_p"), get("l"))


def inertia_problem(values: Mapping[str, float]) -> str | None:
    """Why J_p cannot be the inertia about the pivot of the values' m_p and l, or None."""
    get = _reader(values)
    J_p, m_p, l = get("J_p"), get("m_p"), get("l")
    least = point_mass_inertia(m_p, l)
    if J_p == 0.0 or J_p >= least * (1.0 - POINT_MASS_TOLERANCE):
        return None
    return (f"J_p = {number(J_p)} kg.m2 is below m_p*l^2 = {least:.6g} kg.m2 (m_p = {number(m_p)} kg, "
            f"l = {number(l)} m): J_p is the inertia about the pivot, at least that of the mass m_p at distance l; "
            f"an inertia about the centre of mass is given as {J_CM} (J_p = {J_CM} + m_p*l^2), and J_p = 0 means "
            f"a uniform rod")


def asymmetry_problem(values: Mapping[str, float], mean: str, asymmetry: str, unit: str) -> str | None:
    """Why a direction asymmetry would make one direction's friction term negative, or None."""
    get = _reader(values)
    k, dk = get(mean), get(asymmetry)
    if abs(dk) <= k:
        return None
    return (f"|{asymmetry}| = {number(abs(dk))} {unit} exceeds {mean} = {number(k)} {unit}: {mean} +- {asymmetry} "
            f"of one direction would be negative")


def saturation_problem(values: Mapping[str, float]) -> str | None:
    get = _reader(values)
    if get("u_min") <= get("u_max"):
        return None
    return f"the Controller's saturation u_min = {number(get('u_min'))} is above u_max = {number(get('u_max'))}"


@dataclass(frozen=True)
class Rule:
    """One constraint: the parameters it ties (checked when any of them is in the values)
    and the function that says why values break it."""

    names: tuple[str, ...]
    problem: Callable[[Mapping[str, float]], str | None]


RULES = (Rule(("J_p", "m_p", "l"), inertia_problem),
         *(Rule((mean, asym), lambda v, m=mean, a=asym, u=unit: asymmetry_problem(v, m, a, u))
           for mean, asym, unit in ASYMMETRIES),
         Rule(("u_min", "u_max"), saturation_problem))


def problems(values: Mapping[str, float]) -> list[str]:
    """Every rule that `values` (missing names: the table's defaults) break, in words. A
    rule none of whose names are in `values` is not asked: its defaults keep it."""
    return [problem for rule in RULES if any(n in values for n in rule.names) and (problem := rule.problem(values))]


def check(values: Mapping[str, float], where: str = "") -> None:
    """Raise PhysicsError for the first rule `values` break, naming `where`."""
    found = problems(values)
    if found:
        raise PhysicsError(f"{where + ': ' if where else ''}{found[0]}")


def overlay(base: Mapping[str, float], layer: Mapping[str, float], where: str = "") -> dict[str, float]:
    """`layer` (a parameters file, a sidecar, API params) over `base`. J_p and J_cm are one
    quantity: a layer that gives one replaces the base's other, and a layer that gives both
    is refused."""
    twice = both_ways(layer)
    if twice:
        raise PhysicsError(f"{where + ': ' if where else ''}{twice}")
    result = {k: v for k, v in base.items() if not (k in ("J_p", J_CM) and ({"J_p", J_CM} & set(layer)))}
    result.update(layer)
    return result


def settled(values: Mapping[str, float], where: str = "") -> dict[str, float]:
    """The values a run computes with: J_cm converted to J_p with the values' own m_p and l,
    every rule checked (PhysicsError naming `where`)."""
    result = dict(values)
    if J_CM in result:
        get = _reader(result)
        result["J_p"] = result.pop(J_CM) + point_mass_inertia(get("m_p"), get("l"))
    check(result, where)
    return result


def own_problems(values: Mapping[str, float]) -> list[str]:
    """The rules broken among the values one source gives, where it gives every name a rule
    ties (a parameters file with m_p, l and J_p): said against that source before it is
    combined with others. J_p and J_cm both given is one of them."""
    found = [problem for rule in RULES if all(n in values for n in rule.names) and (problem := rule.problem(values))]
    twice = both_ways(values)
    return [twice, *found] if twice else found


def both_ways(values: Mapping[str, float]) -> str | None:
    """Why one source may not give the pendulum's inertia both about the pivot and about the
    centre of mass, if it does."""
    if "J_p" not in values or J_CM not in values:
        return None
    return (f"J_p = {number(values['J_p'])} and {J_CM} = {number(values[J_CM])} both given: J_p is the inertia about "
            f"the pivot, {J_CM} about the centre of mass (J_p = {J_CM} + m_p*l^2); give one of them")


def limits(name: str, ranges: Mapping[str, tuple[float, float]]) -> tuple[float, float]:
    """The values of `name` the rules allow, whatever the other values are within `ranges`
    (name -> (low, high): a free parameter's search box, or a known value twice). Missing
    names take the table's defaults. Why: a search box that reaches outside them spends
    simulations that fail (J_p below m_p l^2 with J_p free)."""
    def span(other: str) -> tuple[float, float]:
        return tuple(ranges.get(other, (DEFAULTS[other], DEFAULTS[other])))  # type: ignore[return-value]

    low, high = -math.inf, math.inf
    if name == "J_p":
        (m_low, _), (l_low, _) = span("m_p"), span("l")
        low = point_mass_inertia(max(m_low, 0.0), max(l_low, 0.0))
    for mean, asymmetry, _ in ASYMMETRIES:
        if name == asymmetry:
            high = span(mean)[1]
            low = -high
        elif name == mean:
            a_low, a_high = span(asymmetry)
            low = 0.0 if a_low <= 0.0 <= a_high else min(abs(a_low), abs(a_high))
    if name in ("u_min", "u_max"):
        other_low, other_high = span("u_max" if name == "u_min" else "u_min")
        low, high = (-math.inf, other_high) if name == "u_min" else (other_low, math.inf)
    return low, high
