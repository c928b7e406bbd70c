"""Tuning the controller to requirements by simulation (issue 27, step 4: response optimization).

The LQR weights (design.Weights) are searched so that the closed-loop runs of verify.py, on
the identified model and on every bootstrap replicate of the fit, meet the requirements:
robust by construction, since a design is judged over every rig the recordings allow.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from pendfmu.control.verify import Outcome, Requirements, Verification, plan, runner, shortfall

TUNED = ("x", "phi", "v", "w", "a")  # the LQR weights a tuning moves (design.Weights)
TUNING_BUDGET = 40  # designs tried at most


def score(outcomes: Sequence[Outcome], requirements: Requirements, track: float) -> tuple[float, float]:
    """A design's standing over its runs, lower better: (how far its runs miss, summed over
    the runs as the logarithm of each shortfall beyond 1; the worst run's shortfall). 0 first:
    every run meets the requirements. Robust by construction: a design is judged over every
    rig it may meet, not the identified model alone; and a sum of how far each misses, not a
    count of misses, so that a move that brings runs closer is seen (stick-slip makes the
    count jump from one design to the next)."""
    shortfalls = [shortfall(o, requirements, track) for o in outcomes]
    return sum(math.log(s) for s in shortfalls if s > 1.0), max(shortfalls)


@dataclass
class Tuning:
    """The weights found, their verification, and every design tried (weights, score)."""

    weights: object
    verification: Verification
    tried: list[tuple[dict[str, float], tuple[int, float]]]


def tune(values: Mapping[str, float], options, replicates: Sequence[Mapping[str, float]], ssp: Path,
         duration: float, requirements: Requirements, workers: int = 0, scheduler: str | None = None,
         budget: int = TUNING_BUDGET, say: Callable[[str], None] = lambda line: None) -> Tuning:
    """Tune the LQR weights to the requirements by simulation (response optimization): a
    coordinate search in the weights' logarithms from `options.weights`, each weight scaled
    by 2 and by 1/2 in turn, a move kept when it improves the score over the identified
    model and every replicate (the compensation as designed); the steps shrink (square root
    of the factor) once no move helps. It stops when every run meets the requirements, when
    the steps are below a tenth of a doubling, or after `budget` designs. The runs are
    deterministic, so the same request tunes to the same weights."""
    with runner(workers, scheduler) as run:
        return _search(values, options, replicates, ssp, duration, requirements, run, budget, say)


def _search(values, options, replicates, ssp, duration, requirements, run, budget, say) -> Tuning:
    """tune's search, its runs made by `run` (verify.runner)."""
    import dataclasses
    import time

    from pendfmu.control.design import design

    start = time.perf_counter()

    def judged(weights) -> tuple[tuple[float, float], list[Outcome]]:
        the_design = design(values, dataclasses.replace(options, weights=weights))
        outcomes = run(plan(the_design, values, replicates, ssp, duration, both_compensations=False))
        return score(outcomes, requirements, the_design.x_max), outcomes

    best = options.weights
    best_score, best_outcomes = judged(best)
    tried = [(dataclasses.asdict(best), best_score)]
    say(f"tuning: start {best.text()}: {_score_text(best_score)}")
    factor = 2.0
    while best_score[0] > 0 and len(tried) < budget:  # tuned to the requirements once every run meets them
        improved = False
        for name in TUNED:
            for scale in (factor, 1 / factor):
                moved = False
                while len(tried) < budget and best_score[0] > 0:  # on along a move while it helps
                    candidate = dataclasses.replace(best, **{name: getattr(best, name) * scale})
                    found, outcomes = judged(candidate)
                    tried.append((dataclasses.asdict(candidate), found))
                    if not found < best_score:
                        break
                    best, best_score, best_outcomes, improved, moved = candidate, found, outcomes, True, True
                    say(f"tuning: {best.text()}: {_score_text(found)}")
                if moved:
                    break
        if not improved:
            if factor < 2 ** 0.1:
                break
            factor = math.sqrt(factor)
    the_design = design(values, dataclasses.replace(options, weights=best))
    return Tuning(best, Verification(requirements, the_design.x_max, best_outcomes, time.perf_counter() - start),
                  tried)


def _score_text(found: tuple[float, float]) -> str:
    return f"missed by {found[0]:.3g} in all (log), worst run at {found[1]:.3g} of its limits"
