"""The candidate friction laws: a ladder, each rung the one below plus a term.

The terms are friction.h's (pendfmu/friction.py names each joint's parameters):

    viscous only           k_fw; Coulomb friction and stiction fixed at 0
    + Coulomb              F_K; stiction 0: the breakaway threshold is max(F_S, F_K) = F_K
                           (docs/user-guide/friction.md), so a stiction below the Coulomb
                           friction is no stiction
    + stiction             F_S: the paper's law (docs/user-guide/model.md), the stage's own
    + Stribeck             v_S
    + direction asymmetry  dk_fw and dF_K
    + offset               F_O
    + air drag             drag (the pendulum only)

A law is a fit of the stage as `pendfmu fit` makes it: the same FitSpec with the law's
terms free and the others fixed at 0 (law_spec). A chosen subset of the rungs adds each
rung's terms to the one before it among them; the paper's three include the ones below them,
named or not (law_terms).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

from pendfmu.errors import OptionError
from pendfmu.fitting.ranking import PartFit
from pendfmu.fitting.spec import FitSpec
from pendfmu.friction import Joint


@dataclass(frozen=True)
class Rung:
    """One candidate law: its name, its rung in words, the terms (friction.Law's fields) it
    adds to the law below it, and whether that law is inside its search box (its new terms
    at their off end give the law below: then it can never fit worse)."""

    name: str
    label: str
    adds: tuple[str, ...]
    nests: bool = True


LADDER = (Rung("viscous", "viscous only", ("k_fw",)), Rung("coulomb", "+ Coulomb", ("F_K",), nests=False),
          Rung("stiction", "+ stiction", ("F_S",)), Rung("stribeck", "+ Stribeck", ("v_S",), nests=False),
          Rung("asymmetry", "+ direction asymmetry", ("dk_fw", "dF_K")), Rung("offset", "+ offset", ("F_O",)),
          Rung("drag", "+ air drag", ("drag",)))
"""Coulomb friction's box starts above 0 (stages.DERIVED_BOUNDS); a Stribeck law is the
stiction law only in the limit v_S -> 0, where the FMU's step shrinks with the Stribeck
slope and the refinement crawled (4000 simulations, still 2.4 times the stiction law's
RMS at v_S = 1e-4 m/s): neither is refitted from the law below (nested)."""
BASE_LAWS = ("viscous", "coulomb", "stiction")  # the paper's: each includes the ones below it
FIRST_ROUND = (*BASE_LAWS, "stribeck")  # the laws whose terms have boxes of their own


def ladder(joint: Joint, names: Sequence[str] | None = None) -> list[Rung]:
    """The rungs compared: `names` (default: every rung the joint has; the cart has no air
    drag), in the ladder's order."""
    own = [rung for rung in LADDER if all(term in joint.terms for term in rung.adds)]
    if names is None:
        return own
    unknown = [name for name in names if name not in {rung.name for rung in own}]
    if unknown:
        raise OptionError("laws", f"{', '.join(map(repr, unknown))}: the {joint.name}'s laws are "
                                  f"{', '.join(rung.name for rung in own)}")
    chosen = [rung for rung in own if rung.name in names]
    if len(chosen) < 2:
        raise OptionError("laws", "name two laws at least: the comparison ranks them")
    if not any(rung.name in FIRST_ROUND for rung in chosen):
        raise OptionError("laws", f"name one of {', '.join(FIRST_ROUND)} as well: the laws above them start "
                                  f"from its fit")
    return chosen


def law_terms(rungs: Sequence[Rung], k: int) -> list[str]:
    """The terms (friction.Law's fields) of rung k's law among the rungs compared: the
    viscous term, the paper's terms up to the highest of its laws among rungs[:k + 1] (each
    includes the ones below it), and the terms of each extra rung among them."""
    chosen = rungs[:k + 1]
    highest = max((BASE_LAWS.index(rung.name) for rung in chosen if rung.name in BASE_LAWS), default=0)
    base = [term for rung in LADDER[:highest + 1] for term in rung.adds]
    return [*base, *(term for rung in chosen if rung.name not in BASE_LAWS for term in rung.adds)]


def law_parameters(joint: Joint, rungs: Sequence[Rung], k: int) -> tuple[str, ...]:
    """The joint's parameters of rung k's law."""
    return tuple(joint.terms[term] for term in law_terms(rungs, k))


def law_spec(spec: FitSpec, joint: Joint, rungs: Sequence[Rung], k: int, given: Mapping[str, float],
             start: Mapping[str, float] | None = None, boxes: Mapping[str, tuple[float, float]] | None = None,
             local: bool = False, nested: bool = False) -> FitSpec:
    """The spec of rung k's law: its terms free (those the stage fits anyway need no
    mention), the others fixed at 0, started at `start` (else the given values); `boxes`:
    of terms without a box of their own; `local`: without a global search; `nested`:
    `start` is a lower law's optimum, and the terms it lacks start at their off end, so
    that the start is that law (_extra_boxes)."""
    on = law_parameters(joint, rungs, k)
    off = [name for name in joint.parameters if name not in on]
    known = {**given, **(start or {})}
    extras = [name for name in on if name not in joint.plain]
    bounds, middles = _extra_boxes(joint, extras, known, {**(boxes or {}), **spec.bounds}, nested)
    search = replace(spec.global_search, workers=1, scheduler=None, enabled=spec.global_search.enabled and not local)
    return spec.with_options(
        params={**known, **middles, **{name: 0.0 for name in off}}, free=(*spec.free, *extras),
        fix=(*spec.fix, *(name for name in off if name in joint.plain)),
        bounds={name: box for name, box in bounds.items() if name not in off and name not in spec.fix},
        uncertainty="jacobian", global_search=search, seed=None if local else spec.seed)


def _extra_boxes(joint: Joint, extras: Sequence[str], known: Mapping[str, float],
                 bounds: Mapping[str, tuple[float, float]], off_end: bool = False) -> tuple[dict, dict]:
    """The bounds of a law's spec, and the start of each extra term whose known value is not
    inside its box: the box's middle (geometric for a positive box), or with `off_end` its
    end nearest to off (a refit from the law below). Why the middle: an extra is off at 0,
    which a Stribeck speed's or a drag's box (decades above 0) does not hold, and a search
    started at the box's low end found no gradient there (a Stribeck speed of 1e-4 m/s
    hides the stiction's ratio to the Coulomb friction: 4500 simulations of a wandering
    refinement). The joint's own box is passed as bounds, so that the start does not
    narrow it to a decade around itself as a given value would."""
    bounds, middles = dict(bounds), {}
    for name in extras:
        box = bounds.get(name) or joint.boxes.get(name, (None, None))[:2]
        if box[0] is None or box[0] <= known.get(name, math.nan) <= box[1]:
            continue
        bounds[name] = box
        if box[0] > 0:
            middles[name] = box[0] if off_end else math.sqrt(box[0] * box[1])
        else:
            middles[name] = min(max(0.0, box[0]), box[1]) if off_end else 0.5 * (box[0] + box[1])
    return bounds, middles


NEGLIGIBLE = 1e-4
"""The drag's box reaches this far below the joint's physical decades (friction.py), so that
its low end is no drag: 1e-9 N.m.s2, the physical box's end, raised the Furuta pendulum's
RMS (J_p = 8.8e-5 kg.m2) by 0.7 % against no drag, 1e-13 by 7e-7 %; a law that does not hold
the one below it cannot be refitted from it (Rung.nests)."""


def second_round_boxes(joint: Joint, base: PartFit, reach: float = 0.0) -> dict[str, tuple[float, float]]:
    """Boxes of the terms without their own (module docstring), from the base law's fit:
    an asymmetry up to the term it skews; an offset up to `reach` (the largest Coulomb
    friction the stage searches without a given value, stages.derived_box) or the base
    law's Coulomb box, whichever is larger; the drag's physical box reaching down to no
    drag (NEGLIGIBLE)."""
    boxes = {}
    for mean, skew in ((joint.viscous, joint.viscous_asymmetry), (joint.coulomb, joint.coulomb_asymmetry)):
        size = abs(base.parameters.get(mean, 0.0))
        if size > 0:
            boxes[skew] = (-size, size)
    reach = max(reach, base.boxes.get(joint.coulomb, (0.0, 0.0))[1])
    if reach > 0:
        boxes[joint.offset] = (-reach, reach)
    if joint.drag in joint.boxes:
        low, high, _ = joint.boxes[joint.drag]
        boxes[joint.drag] = (low * NEGLIGIBLE, high)
    return boxes
