"""The stimulus of the dynamic checks: one that makes the FMU do something (issue 24).

A cautious stimulus (an input held around its start value) can leave an FMU doing nothing, a
cart that never breaks away, and every check then passes on a run that tested nothing. So
without `--input`, `search` looks for excitation, cheaply and in a bounded number of runs:

- each Real input is driven over its declared [min, max] when it has one (a declared range
  comes first: it says what the FMU is made for); without one, around its start value with an
  amplitude of 1, 10, 100, ... times its nominal (1 when not declared), by decades up to
  `target.input_limit` times it (`pendfmu check --input-limit`, default
  fmu.DEFAULT_INPUT_LIMIT, 1000); one side of a half-declared range still bounds it;
- at each amplitude three shapes, in this order: a sine (one and a half periods over the run,
  each input its own phase), steps (up, back, down, back) and a ramp (a triangle up, down,
  back); every input is held over each communication step;
- each candidate is one short run (at most PROBE_POINTS communication points: the step is a
  multiple of h) on one interface (Co-Simulation when the FMU has it), and the search stops at
  the first that moves an output and shows an event (exercise.py); when none does, the one
  that showed most (events, then outputs moved) at the smallest amplitude is used.

Budget: at most 3 x (1 + log10(limit)) probe runs (12 by default) of at most PROBE_POINTS
points each; an FMU that moves and switches at the first sine takes one. Every row names the
stimulus it used (`Excitation.label`); the events row lists what was tried.

`probe_values` gives the values the inputs check holds an input at: five over a declared
range, else the start value and start +- 1, 10, 100, ... times the nominal up to the limit.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from pendfmu.check import exercise
from pendfmu.check.fmu import Target, call_error

PROBE_POINTS = 500
"""Communication points of a probe run at most (its step is a multiple of h)."""
SHAPES = ("sine", "steps", "ramp")
DECLARED_SAMPLES = 5
MAX_LABELLED = 2  # inputs named one by one in a label; more are summarized


@dataclass
class Drive:
    """How one input is driven: center + amplitude x shape(t), clipped to [low, high]."""
    name: str
    center: float
    amplitude: float
    low: float
    high: float
    unit: str
    declared: bool

    def label(self) -> str:
        if self.declared:
            return f"{self.name} over [{self.low:g}, {self.high:g}]{self.unit}"
        return f"{self.name} {self.center:g} ± {self.amplitude:g}{self.unit}"


@dataclass
class Excitation:
    """A stimulus: a shape at one amplitude level for every input, or a recording. `tried`
    says what the search tried before it and what each candidate showed."""
    shape: str
    level: float | None
    drives: list[Drive]
    recording: tuple | None = None
    origin: str = ""
    ignored: list[str] = field(default_factory=list)
    tried: list[tuple[str, str]] = field(default_factory=list)  # (label, what it showed)
    stop: float = 1.0

    def tried_text(self) -> str:
        """What the search tried, candidates that showed the same grouped: 'no output moved
        with 3 stimuli (sine u 0 ± 1 V ... ramp u 0 ± 1 V); 2 of 2 outputs moved, ... with
        sine u 0 ± 10 V'."""
        grouped: dict[str, list[str]] = {}
        for label, outcome in self.tried:
            grouped.setdefault(outcome, []).append(label)
        return "; ".join(f"{outcome} with {labels[0]}" if len(labels) == 1 else
                         f"{outcome} with {len(labels)} stimuli ({labels[0]} ... {labels[-1]})"
                         for outcome, labels in grouped.items())

    @property
    def label(self) -> str:
        if self.recording is not None:
            ignored = f", its columns {', '.join(self.ignored)} ignored (not inputs)" if self.ignored else ""
            return f"recording {self.origin}{ignored}"
        if not self.drives:
            return "its own dynamics (no inputs)"
        if len(self.drives) <= MAX_LABELLED:
            return f"{self.shape} " + ", ".join(d.label() for d in self.drives)
        declared = sum(d.declared for d in self.drives)
        around = f"±{self.level:g} x nominal around the start values" if declared < len(self.drives) else ""
        over = "over the declared ranges" if declared else ""
        return f"{self.shape} on {len(self.drives)} inputs, " + (" and ".join(p for p in (over, around) if p))

    def at(self, hold: float) -> Callable[[float], np.ndarray]:
        """The inputs at time t, held constant over intervals of `hold` (so that runs with
        the communication step hold, hold/2, ... see the same input); recorded columns
        replace the shape for the inputs they name."""
        shape, stop = SHAPE_FUNCTIONS[self.shape], self.stop
        index = np.arange(len(self.drives))
        center, amplitude, low, high = (np.array([getattr(d, a) for d in self.drives], dtype=float)
                                        for a in ("center", "amplitude", "low", "high"))
        times, columns = self.recording if self.recording is not None else (None, {})
        recorded = [(k, columns[d.name]) for k, d in enumerate(self.drives) if d.name in columns]

        def value(t: float) -> np.ndarray:
            t = math.floor(t / hold + 1e-9) * hold
            row = np.minimum(high, np.maximum(low, center + amplitude * shape(t / stop, index)))
            if times is not None:  # recorded inputs: the last sample at or before t
                i = max(0, int(np.searchsorted(times, t + 1e-12 * max(1.0, abs(t)), side="right")) - 1)
                for k, column in recorded:
                    row[k] = column[i]
            return row
        return value


def _sine(tau: float, index: np.ndarray) -> np.ndarray:
    """One and a half periods over the run, each input its own phase."""
    return np.sin(3 * math.pi * tau + 0.7 * index)


def _steps(tau: float, index: np.ndarray) -> float:
    """Up at a tenth of the run, back at 0.35, down at a half, back at 0.75."""
    return 1.0 if 0.1 <= tau < 0.35 else -1.0 if 0.5 <= tau < 0.75 else 0.0


def _ramp(tau: float, index: np.ndarray) -> float:
    """A triangle: up to 1 at a quarter, down to -1 at three quarters, back to 0 at the end."""
    return 4 * tau if tau < 0.25 else 2 - 4 * tau if tau < 0.75 else 4 * tau - 4


SHAPE_FUNCTIONS = {"sine": _sine, "steps": _steps, "ramp": _ramp}


def _bounds(v) -> tuple[float, float]:
    low = float(v.min) if v.min is not None else -math.inf
    high = float(v.max) if v.max is not None else math.inf
    return low, high


def declared(v) -> bool:
    """Whether the input declares a finite [min, max] (not an 'any number' placeholder)."""
    low, high = _bounds(v)
    return math.isfinite(low) and math.isfinite(high) and high - low < 1e12


def start(v) -> float:
    """The variable's start value, 0 when it has none."""
    return float(v.start) if v.start is not None else 0.0


def nominal(v) -> float:
    """The variable's declared nominal (its size), 1 when it declares none (FMI's default)."""
    value = getattr(v, "nominal", None)
    return abs(float(value)) if value not in (None, "") and float(value) != 0 else 1.0


def levels(limit: float) -> list[float]:
    """1, 10, 100, ... up to `limit` (in multiples of an input's nominal)."""
    if limit < 1:
        return [limit]
    return [10.0 ** k for k in range(int(math.floor(math.log10(limit) + 1e-9)) + 1)]


def drives(target: Target, level: float | None) -> list[Drive]:
    """Every Real input's drive at `level` (a declared range is driven over the whole of it)."""
    found = []
    for v in target.inputs:
        low, high = _bounds(v)
        unit = f" {v.unit}" if getattr(v, "unit", None) else ""
        if declared(v):
            found.append(Drive(v.name, (low + high) / 2, (high - low) / 2, low, high, unit, True))
        else:
            amplitude = nominal(v) * (level if level is not None else 1.0)
            found.append(Drive(v.name, start(v), amplitude, low, high, unit, False))
    return found


def candidates(target: Target) -> list[Excitation]:
    """The search's candidates in order: amplitude levels up (one, when every input declares
    its range), each as a sine, steps and a ramp."""
    every_declared = all(declared(v) for v in target.inputs)
    chosen = [None] if every_declared else levels(target.input_limit)
    return [Excitation(shape, level, drives(target, level), stop=target.stop) for level in chosen for shape in SHAPES]


def excitation(target: Target) -> Excitation:
    """The stimulus of the dynamic checks: `search`'s answer, found once per target."""
    if "_excitation" not in target.__dict__:
        target._excitation = search(target)
    return target._excitation


def reference_run(target: Target, kind: str) -> exercise.Observed:
    """The run every check starts from (the stimulus over the whole run at step h, a fresh
    instance), observed once per target and interface."""
    cache = target.__dict__.setdefault("_observed", {})
    if kind not in cache:
        h = target.step
        cache[kind] = exercise.observe(target, kind, excitation(target).at(h), h, target.stop)
    return cache[kind]


def unexercised(target: Target, what: str) -> str:
    """The reason of an INCONCLUSIVE row: 'nothing was exercised under <stimulus>: <what>',
    with what the search tried and what the user can do about it."""
    used = excitation(target)
    searched = f" (the search: {used.tried_text()})" if len(used.tried) > 1 else ""
    advice = ("a recording that moves it" if used.recording is not None
              else "--input REC.csv, or a larger --input-limit")
    return f"nothing was exercised under {used.label}{searched}: {what}; drive the FMU with {advice}"


def search(target: Target) -> Excitation:
    """The recording when there is one, else the first candidate that moves an output and
    shows an event (or the one that showed most); see the module's docstring."""
    first = candidates(target)[0] if target.inputs else Excitation("sine", None, [], stop=target.stop)
    if target.recording is not None:
        first.recording, first.origin, first.ignored = target.recording, target.recording_name, target.ignored_columns
        return first
    if not target.inputs:
        return first
    tried, best, best_score = [], None, None
    for candidate in candidates(target):
        outcome, score = _probe(target, candidate)
        tried.append((candidate.label, outcome))
        if score is not None and (best_score is None or score > best_score):
            best, best_score = candidate, score
        if score is not None and score[0] and score[1]:
            break
    chosen = best or first
    chosen.tried = tried
    return chosen


def _probe(target: Target, candidate: Excitation) -> tuple[str, tuple | None]:
    """What one short run with the candidate showed: a description and a score (events
    seen, outputs moved), or None when the FMU refused it."""
    kind = target.interfaces[0]
    h = target.step
    factor = max(1, math.ceil(target.stop / h / PROBE_POINTS))
    for step in dict.fromkeys((h * factor, h)):  # a coarse step first; h when the FMU refuses it
        try:
            seen = exercise.observe(target, kind, candidate.at(step), step, target.stop)
            break
        except Exception as error:  # the FMU refused this amplitude or step: try on
            refusal = call_error(error)
    else:
        return f"refused ({refusal.splitlines()[0][:120]})", None
    moved = int(np.sum(exercise.moved(seen.rows)))
    found = exercise.events(target, seen)
    if not moved:
        return "no output moved", (False, 0)
    return f"{moved} of {len(target.outputs)} outputs moved, {found.describe(step)}", (len(found) > 0, moved)


def probe_values(target: Target, v) -> tuple[list[float], bool]:
    """The values the inputs check holds input v at, nearest its start first, and whether
    they span a declared range."""
    if declared(v):
        low, high = _bounds(v)
        return [float(x) for x in np.linspace(low, high, DECLARED_SAMPLES)], True
    low, high = _bounds(v)
    values = [start(v)]
    for level in levels(target.input_limit):
        for sign in (1, -1):
            value = start(v) + sign * level * nominal(v)
            if low <= value <= high and value not in values:
                values.append(value)
    return values, False
