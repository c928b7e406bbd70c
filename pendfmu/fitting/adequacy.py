"""Whether a fit can be trusted: the search tried again where it may have missed, and a verdict.

Residuals far above the sensor noise on data the model could explain mean a missed
minimum as often as a missing model term: one seeded global search can settle in a poor
basin (a virtual rig whose ramp never breaks the cart away ended at 179 times the noise
with a wrong eta, k_fwc and F_Sc, and intervals of +-0.0003 %). So a fit whose residuals
stay above MODEL_ERROR_LIMIT times the noise searches again, seeded and escalating (the seed
plus k; the second time with twice the population), up to RESTARTS times, until two global
searches end in the best minimum found, and keeps the best. Then:

- adequate: the residuals are within the limit;
- model-inadequate: they are not, and the global searches of two seeds end at the best cost
  found (within SAME_COST): the minimum is found, and the model cannot follow the recordings;
- fit-failed: they are not, and the global searches end at different costs, or there was only
  one search (the global search switched off): a missed minimum cannot be told from a missing
  term.

A search's own end is where the refinement of its global search's best ends, not the outcome
it keeps: each search also refines the starting values and keeps the lower, and those are the
same in every search. A wide coverage benchmark's cart whose global searches ended at 135 times
the cost of the start's refinement kept that refinement twice, at 137 times the noise: the
two searches 'agreed' on the one minimum neither had found, and the fit was called
model-inadequate on recordings its model had made.

The verdict and its evidence go into the result (FitResult.assessment) and the warnings;
a marked fit's intervals are widened by what its validation sees (validation.py).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from pendfmu.fitting.optimizer import GlobalOptions, Outcome, optimize
from pendfmu.fitting.residuals import Residuals

MODEL_ERROR_LIMIT = 3.0
"""RMS of the scaled residuals (1 at the truth) above which the fit is not taken at its word."""
RESTARTS = 2  # further global searches at most
SAME_COST = 0.01  # searches whose costs differ by less than this fraction ended in the same minimum
VERDICTS = ("adequate", "model-inadequate", "fit-failed")


@dataclass(frozen=True)
class Search:
    """One global search and where it ended."""

    seed: int
    population: int
    cost: float  # of the outcome it kept
    searched: float  # where its global search's refinement ended (the kept cost without one)


def spread(outcome: Outcome) -> float:
    """The RMS of the scaled residuals: 1 for a fit as good as the sensors allow."""
    return float(np.sqrt(np.mean(outcome.residual ** 2))) if len(outcome.residual) else 0.0


def cost(outcome: Outcome) -> float:
    return 0.5 * float(outcome.residual @ outcome.residual)


def search_until_settled(residuals: Residuals, coarse: Residuals, u0: np.ndarray, seed: int, options: GlobalOptions,
                         progress: Callable[[str], None] | None = None, cache: dict | None = None,
                         restarts: int = RESTARTS) -> tuple[Outcome, list[Search]]:
    """The fit's search (optimizer.optimize), repeated from other seeds (the second time with
    a larger population) while the residuals stay far above the noise and the searches disagree;
    the best outcome, with every search's counts, and the searches made. `restarts`: at most
    this many more searches (0 for a pass that only prepares or checks the fit)."""
    outcome = optimize(residuals, coarse, u0, seed, options, progress, cache)
    searches = [_search(seed, options.popsize, outcome)]
    for k in range(1, restarts + 1):
        if not options.enabled or spread(outcome) <= MODEL_ERROR_LIMIT or _settled(searches):
            break
        wider = replace(options, popsize=options.popsize * 2 ** (k - 1))  # another seed, then wider too
        again = optimize(residuals, coarse, u0, seed + k, wider, progress, cache)
        searches.append(_search(seed + k, wider.popsize, again))
        outcome = _better(outcome, again, searches)
    return outcome, searches


def _search(seed: int, population: int, outcome: Outcome) -> Search:
    searched = outcome.searched_cost if outcome.searched_cost is not None else cost(outcome)
    return Search(seed, population, cost(outcome), searched)


def _settled(searches: list[Search]) -> bool:
    """Whether the global searches of two seeds ended in the best minimum found."""
    best = min(s.cost for s in searches)
    return sum(s.searched - best <= SAME_COST * max(best, 1e-300) for s in searches) >= 2


def _better(first: Outcome, second: Outcome, searches: list[Search]) -> Outcome:
    """The lower-cost outcome, carrying both searches' evaluations, time and messages."""
    best = second if cost(second) < cost(first) else first
    note = (f"the residuals stood at {spread(first):.3g} times the sensor noise: the global search ran again from "
            f"seed {searches[-1].seed} with population {searches[-1].population} per parameter, ending at cost "
            f"{searches[-1].cost:.6g} (before: {min(s.cost for s in searches[:-1]):.6g})")
    return replace(best, nfev=first.nfev + second.nfev, failures=first.failures + second.failures,
                   seconds=first.seconds + second.seconds, messages=[*first.messages, note],
                   last_failure=second.last_failure or first.last_failure)


def assess(outcome: Outcome, searches: list[Search]) -> dict:
    """The verdict on a fit and its evidence (module docstring)."""
    level = spread(outcome)
    evidence = [f"the residuals are {level:.3g} times the sensor noise (limit {MODEL_ERROR_LIMIT:g})"]
    if level <= MODEL_ERROR_LIMIT:
        return {"verdict": "adequate", "spread": level, "evidence": evidence}
    costs = ", ".join(f"{s.searched:.6g} (seed {s.seed}, population {s.population})" for s in searches)
    if len(searches) == 1:
        evidence.append("the global search ran once (or was off): a missed minimum cannot be told from a missing "
                        "model term; fit with the global search on")
        verdict = "fit-failed"
    elif _settled(searches):
        evidence.append(f"{len(searches)} global searches end in the same minimum (costs {costs}): the model "
                        f"cannot follow the recordings")
        verdict = "model-inadequate"
    else:
        best = min(s.cost for s in searches)
        start = (f"; the best, {best:.6g}, is the refinement of the starting values, which no global search reached"
                 if all(s.searched > best * (1 + SAME_COST) for s in searches) else "")
        evidence.append(f"{len(searches)} global searches end at different costs ({costs}){start}: the optimum is "
                        f"not settled")
        verdict = "fit-failed"
    return {"verdict": verdict, "spread": level, "evidence": evidence}


def verdict_warning(assessment: dict) -> str | None:
    """The console's line for a marked fit."""
    if assessment.get("verdict", "adequate") == "adequate":
        return None
    return f"{assessment['verdict']}: " + "; ".join(assessment["evidence"])
