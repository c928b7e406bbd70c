"""The friction laws' ranking: held-out error first, an information criterion beside it.

What each candidate law (laws.py) brings here is two fits: one to the whole recordings, one
to their early halves with its prediction of the late halves (the held-out data). The
numbers are the residuals in units of each signal's error scale (the sensor noise: 1 at a
fit as good as the sensors allow).

Held-out error. The RMS of the late halves' residuals, predicted by the law fitted to the
early halves (only each late half's own initial states refitted: the law itself is not).
For a free decay the late half is the small amplitude, so a law that describes the large
swings by the wrong mechanism (a viscous term standing in for Coulomb friction) predicts the
small ones badly. This ranks the laws.

The recommendation: the simplest law (the lowest rung of the ladder) whose held-out error is
within MARGIN of the best. Why 5 % of the RMS: a richer law is preferred only when its
held-out RMS is below 1/1.05 = 0.952 of the simpler law's, that is when it removes more than
9 % (1 - 0.952^2), about a tenth, of the held-out mean square: less is not worth its
parameters. Near the noise (RMS about 1) the margin is a missing term whose effect is a
third of the sensor noise (sqrt(1.05^2 - 1) = 0.32), which the recordings cannot show; on the
real recordings of the user guide ("Choosing a friction law", docs/user-guide/friction.md), whose residuals stand 20-200
times above the noise, the richer laws' held-out errors lay within 0.2 % of the recommended
law's or above it.

Information criterion: BIC, not AIC. The ladder asks which terms the rig has, and among
nested laws of which one is true BIC picks it with a probability that tends to 1 as the data
grow, where AIC keeps adding a spurious term with a fixed probability (about 16 % per
term); prediction is already judged on the held-out halves. Its Gaussian form with the
noise unknown is n ln(RSS/n) + k ln(n), and its n is the *effective* number of samples:
residuals that stay correlated over L samples (statistics.correlation_length: a quantized
encoder's error while the joint moves slowly, a model error that follows the swing) carry
about n/L independent errors, and counting every sample would make any term that lowers the
cost by a fraction of a per mille "significant". The same effective count, that of the
best-fitting law's residuals, is used for every law, so that all are judged on the same data.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pendfmu.atomic import write_atomically
from pendfmu.fitting.result import ExperimentFit
from pendfmu.fitting.statistics import correlation_length

MARGIN = 0.05
"""The simplest law whose held-out RMS is at most (1 + MARGIN) times the best is recommended
(module docstring: why 5 %)."""


@dataclass
class Misfit:
    """A fit's residuals in units of their error scale, summarized.

    Attributes
    ----------
    samples : int
        Residuals (samples of every compared signal, missing readings left out).
    squares : float
        Their sum of squares.
    effective : float
        Their effective count: each series' samples over its correlation length.
    """

    samples: int = 0
    squares: float = 0.0
    effective: float = 0.0

    @property
    def rms(self) -> float:
        return math.sqrt(self.squares / self.samples) if self.samples else math.nan


def summarize(fits: Sequence[ExperimentFit]) -> Misfit:
    """The scaled residuals (recorded minus simulated over the error scale) of every
    recording and compared signal."""
    found = Misfit()
    for fit in fits:
        for column, recorded in fit.recorded.items():
            error = (np.asarray(recorded, float) - np.asarray(fit.simulated[column], float)) / fit.scale[column]
            error = error[np.isfinite(error)]
            if not len(error):
                continue
            found.samples += len(error)
            found.squares += float(error @ error)
            found.effective += len(error) / correlation_length(error)
    return found


@dataclass
class PartFit:
    """One law fitted to one part of the data (the whole recordings, or their early halves).

    Attributes
    ----------
    values : dict
        The fitted rig parameters (the recordings' own initial states left out).
    parameters : dict
        Every value the fit ran with, fitted and known: the start of a richer law's fit.
    boxes : dict
        The search box of each fitted parameter, (low, high); a stiction fitted relative to
        the Coulomb friction has its ratio's box.
    residuals : Misfit
        Of the fit, on the data it was fitted to.
    free : int
        Parameters estimated, the recordings' own initial states included.
    seconds : float
        The fit's time (the held-out prediction's included).
    own : dict
        The recordings' own estimates (their initial states), by label: a richer law's start.
    held_out : Misfit or None
        Of the held-out data, predicted by this fit (the early halves' fit only).
    failed : str or None
        Why the fit failed, if it did (it is then not ranked).
    note : str or None
        How it was obtained when not by its own search (refitted from a simpler law).
    """

    values: dict[str, float] = field(default_factory=dict)
    parameters: dict[str, float] = field(default_factory=dict)
    boxes: dict[str, tuple[float, float]] = field(default_factory=dict)
    residuals: Misfit = field(default_factory=Misfit)
    free: int = 0
    seconds: float = 0.0
    own: dict[str, float] = field(default_factory=dict)
    held_out: Misfit | None = None
    failed: str | None = None
    note: str | None = None

    def to_dict(self) -> dict:
        document = {"rms": _finite(self.residuals.rms), "samples": self.residuals.samples,
                    "effective_samples": self.residuals.effective, "sum_of_squares": self.residuals.squares,
                    "free": self.free, "values": dict(self.values),
                    "boxes": {name: list(box) for name, box in self.boxes.items()}, "seconds": self.seconds}
        if self.own:
            document["initial"] = dict(self.own)
        if self.held_out is not None:
            document["held_out"] = {"rms": _finite(self.held_out.rms), "samples": self.held_out.samples}
        for key in ("failed", "note"):
            if getattr(self, key):
                document[key] = getattr(self, key)
        return document


@dataclass
class LawRow:
    """One candidate law and its two fits.

    Attributes
    ----------
    name, label : str
        The law's short name ('stiction') and its rung in words ('+ stiction').
    terms : tuple of str
        The joint's parameters of this law (the stage's other parameters aside).
    added : tuple of str
        The parameters this rung adds to the one below.
    whole, early : PartFit
        Fitted to the whole recordings; fitted to the early halves, predicting the late.
    bic : float or None
        Its information criterion on the whole recordings (module docstring).
    """

    name: str
    label: str
    terms: tuple[str, ...]
    added: tuple[str, ...]
    whole: PartFit
    early: PartFit | None = None
    bic: float | None = None

    @property
    def failed(self) -> str | None:
        return self.whole.failed or (self.early.failed if self.early else None)

    @property
    def held_out(self) -> float | None:
        """The held-out RMS, or None (no held-out data, or a fit that failed)."""
        if self.failed or self.early is None or self.early.held_out is None:
            return None
        return self.early.held_out.rms


def information(rows: Sequence[LawRow]) -> float:
    """Each row's BIC on the effective sample count of the best-fitting law's residuals;
    returns that count."""
    fitted = [row for row in rows if not row.failed]
    if not fitted:
        return math.nan
    best = min(fitted, key=lambda row: row.whole.residuals.squares)
    effective = max(best.whole.residuals.effective, 1.0)
    for row in fitted:
        residuals = row.whole.residuals
        mean_square = max(residuals.squares / residuals.samples, 1e-300)  # a perfect fit: no log of 0
        row.bic = effective * math.log(mean_square) + row.whole.free * math.log(effective)
    return effective


def ranked(rows: Sequence[LawRow]) -> list[LawRow]:
    """The rows in the order of their held-out error (then BIC; a failed fit last)."""
    def key(row: LawRow):
        held = row.held_out
        return (row.failed is not None, math.inf if held is None else held,
                math.inf if row.bic is None else row.bic)
    return sorted(rows, key=key)


def recommend(rows: Sequence[LawRow], margin: float = MARGIN) -> tuple[str | None, str]:
    """The recommended law's name and the reason, in words (module docstring). Without
    held-out data, the law of the lowest BIC."""
    fitted = [row for row in rows if not row.failed]
    if not fitted:
        return None, "every law's fit failed: nothing to recommend"
    lowest = min(fitted, key=lambda row: row.bic)
    held = [row for row in fitted if row.held_out is not None]
    if not held:
        return lowest.name, (f"{lowest.label} has the lowest BIC; no recording is long enough to hold out its late "
                             f"half, so the laws' predictions were not compared")
    best = min(held, key=lambda row: row.held_out)
    chosen = next(row for row in held if row.held_out <= (1 + margin) * best.held_out)
    leader = "its own" if best is chosen else f"{best.label}: {best.held_out:.3g}"
    reason = (f"the simplest law whose held-out error ({chosen.held_out:.3g} x noise) is within {margin:.0%} of "
              f"the best ({leader})")
    richer = [row for row in held if rows.index(row) > rows.index(chosen)]
    if richer:
        gain = 1 - min(row.held_out for row in richer) / chosen.held_out
        reason += f"; no richer law predicts the held-out data more than {max(gain, 0.0):.1%} better"
    below = [row for row in held if rows.index(row) < rows.index(chosen)]
    if below:
        step = below[-1]
        reason += f"; the law below it ({step.label}) predicts them {step.held_out / chosen.held_out:.3g} times worse"
    if lowest is not chosen:
        reason += (f"; BIC prefers {lowest.label} (by {chosen.bic - lowest.bic:.3g}), which fits the whole "
                   f"recordings better but does not predict the held-out halves better by the margin")
    else:
        reason += "; BIC agrees"
    return chosen.name, reason


@dataclass
class LawComparison:
    """The candidate friction laws of a stage, fitted and ranked (compare_laws).

    Attributes
    ----------
    stage : str
        The stage whose joint's friction is compared ('cart' or 'pendulum').
    rows : list of LawRow
        The laws in the ladder's order, simplest first.
    recommended : str or None
        The recommended law's name (None when every fit failed).
    reason : str
        Why, in words: the held-out errors and BIC that decided it.
    held_out : str
        Which data were held out, in words.
    effective_samples : float
        The BIC's sample count (module docstring).
    margin : float
        The held-out error's margin of the recommendation.
    notes : list of str
        What the user should know about the comparison (refits from a simpler law, failures).
    seconds : float
        The comparison's time.
    request : dict
        The fit specification the laws shared (FitSpec.request), and the command line.
    """

    stage: str
    rows: list[LawRow]
    recommended: str | None
    reason: str
    held_out: str
    effective_samples: float
    margin: float = MARGIN
    notes: list[str] = field(default_factory=list)
    seconds: float = 0.0
    request: dict = field(default_factory=dict)

    def row(self, name: str) -> LawRow:
        return next(row for row in self.rows if row.name == name)

    def table(self) -> str:
        """The ranking as the console shows it."""
        best = min((row.bic for row in self.rows if row.bic is not None), default=math.nan)
        lines = [f"{'rank':>4}  {'law':<24}{'adds':<16}{'free':>5}{'whole RMS':>11}{'held-out RMS':>14}"
                 f"{'dBIC':>11}"]
        for rank, row in enumerate(ranked(self.rows), 1):
            mark = " <- recommended" if row.name == self.recommended else ""
            if row.failed:
                lines.append(f"{'-':>4}  {row.label:<24}{', '.join(row.added):<16}  failed: {row.failed}")
                continue
            held = "-" if row.held_out is None else f"{row.held_out:.4g}"
            lines.append(f"{rank:>4}  {row.label:<24}{', '.join(row.added):<16}{row.whole.free:>5}"
                         f"{row.whole.residuals.rms:>11.4g}{held:>14}{row.bic - best:>11.4g}{mark}")
        return "\n".join(lines)

    def to_dict(self) -> dict:
        best = min((row.bic for row in self.rows if row.bic is not None), default=None)
        order = {row.name: rank for rank, row in enumerate(ranked(self.rows), 1) if not row.failed}
        return {
            "stage": self.stage, "recommended": self.recommended, "reason": self.reason,
            "criteria": {"ranking": "held-out RMS of the scaled residuals (1: the sensor noise)",
                         "held_out": self.held_out, "margin": self.margin, "information": "BIC",
                         "effective_samples": _finite(self.effective_samples)},
            "laws": [{"name": row.name, "label": row.label, "terms": list(row.terms), "added": list(row.added),
                      "rank": order.get(row.name), "held_out_rms": _finite(row.held_out),
                      "bic": _finite(row.bic), "delta_bic": None if row.bic is None else row.bic - best,
                      "whole": row.whole.to_dict(), "early": row.early.to_dict() if row.early else None}
                     for row in self.rows],
            "notes": list(self.notes), "seconds": self.seconds, "request": self.request,
        }

    def write_json(self, path: str | Path) -> Path:
        return write_atomically(path, json.dumps(self.to_dict(), indent=2, allow_nan=False) + "\n")


def _finite(value: float | None) -> float | None:
    return value if value is not None and math.isfinite(value) else None
