"""What a run exercised: how far each output moved and which events were seen from outside.

A check that exercised nothing (outputs that never moved, a parameter that changes nothing,
no event to roll back over) must not say PASS (issue 24); the rows ask here what was
exercised and say it. Events are seen from outside the FMU, so that an FMU without pendfmu's
mode variables is judged like one with them:

- mode changes: any discrete Integer or Boolean local or output that changes value;
- event iterations of the Model Exchange driver (an event indicator that changed sign, a step
  event, a time event), counted per communication step (fmu.Driver.events);
- sign changes of an output (a speed through zero: where friction switches);
- kinks and jumps of an output: a second (first) difference many times those of its
  neighbourhood, unless the input has a kink or a jump there too (the output only follows it).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from pendfmu.check.fmu import Driver, Target

FEATURE = 20.0
"""A difference this many times the largest of its neighbourhood's median is a kink or a jump."""
NEIGHBOURS = 6
"""Points either side a kink is compared with (the two next to it excluded: a kink between two
points shows in both)."""
ROUNDING = 1e-12
"""Relative size below which a movement or a difference is rounding (of the output's scale)."""
MAX_LISTED = 3


@dataclass
class Observed:
    """A run at step h: outputs at every communication point (first row at t = 0), the
    discrete modes there, the inputs given at each point, and the steps (by index) in which
    the Model Exchange driver handled an event."""
    rows: np.ndarray
    modes: list
    inputs: np.ndarray
    driver_events: list[int] = field(default_factory=list)


@dataclass
class Events:
    """Events seen in a run: the points where each kind was seen (the index of the first
    communication point after it), and all of them merged (neighbours count once)."""
    kinds: dict[str, list[int]]
    points: list[int]

    def __len__(self) -> int:
        return len(self.points)

    def describe(self, h: float) -> str:
        """'5 events (mode changes 2, kinks in v 3), the first at t = 0.12 s' or 'no event'."""
        if not self.points:
            return "no event"
        parts = [f"{kind} {len(found)}" for kind, found in self.kinds.items() if found]
        shown = ", ".join(parts[:MAX_LISTED + 1]) + (", ..." if len(parts) > MAX_LISTED + 1 else "")
        return f"{len(self.points)} events ({shown}), the first at t = {self.points[0] * h:.6g} s"


def observe(target: Target, kind: str, stimulus, h: float, stop: float, parameters=None) -> Observed:
    """A fresh instance run from 0 to `stop` at step h with `stimulus`, observed."""
    unit = Driver(target, kind)
    try:
        unit.initialize(parameters, stimulus(0.0))
        first, recorded = unit.modes(), []
        rows = unit.run(h, stop, stimulus, record_modes=recorded)
        times = np.arange(len(rows)) * h
        inputs = np.array([stimulus(t) for t in times]) if target.inputs else np.zeros((len(rows), 0))
        steps = sorted({int(round(t / h)) + 1 for t in unit.events})
        return Observed(rows, [first] + [m for _, m in recorded], inputs, steps)
    finally:
        unit.free()


def scales(target: Target, rows: np.ndarray) -> np.ndarray:
    """Each output's scale: the larger of its declared nominal and how far it moved (range),
    else 1. A nominal is a scaling hint and may sit far below what the output does (Roberts
    declares 1e-4 for a y1 that falls from 1): a difference small against how far the output
    moved is small, whatever the hint."""
    spread = ranges(rows)
    nominal = np.array([abs(float(v.nominal)) if getattr(v, "nominal", None) else 0.0 for v in target.outputs])
    scale = np.maximum(nominal, spread)
    return np.where(scale > 0, scale, 1.0)


def ranges(rows: np.ndarray) -> np.ndarray:
    """max - min of each output's finite values over the run (0 for none)."""
    finite = np.isfinite(rows)
    if not rows.size:
        return np.zeros(rows.shape[1] if rows.ndim == 2 else 0)
    high = np.where(finite, rows, -np.inf).max(axis=0)
    low = np.where(finite, rows, np.inf).min(axis=0)
    return np.where(finite.any(axis=0), high - low, 0.0)


def moved(rows: np.ndarray) -> np.ndarray:
    """Which outputs moved by more than rounding of their size."""
    size = np.where(np.isfinite(rows), np.abs(rows), 0.0).max(axis=0) if rows.size else np.zeros(rows.shape[1])
    return ranges(rows) > ROUNDING * np.maximum(size, 1e-300)


def movement(target: Target, rows: np.ndarray) -> str:
    """'x moved 0.52 m, v 2.1 m/s' (the outputs that moved), or 'no output moved'."""
    spread, which = ranges(rows), moved(rows)
    parts = [f"{v.name} {spread[j]:.3g}{' ' + v.unit if getattr(v, 'unit', None) else ''}"
             for j, v in enumerate(target.outputs) if which[j]]
    if not parts:
        return "no output moved"
    still = [v.name for j, v in enumerate(target.outputs) if not which[j]]
    shown = ", ".join(parts[:MAX_LISTED * 2]) + (", ..." if len(parts) > MAX_LISTED * 2 else "")
    return "moved " + shown + (f" ({', '.join(still[:MAX_LISTED])}{', ...' if len(still) > MAX_LISTED else ''} "
                               f"constant)" if still else "")


def events(target: Target, seen: Observed) -> Events:
    """Every event seen from outside in the observed run."""
    kinds: dict[str, list[int]] = {}
    kinds["mode changes"] = [k for k in range(1, len(seen.modes)) if seen.modes[k] != seen.modes[k - 1]]
    kinds["event iterations"] = [k for k in seen.driver_events if k < len(seen.rows)]
    excused = set(_features(seen.inputs)) if seen.inputs.size else set()
    excused |= {k + d for k in excused for d in (-2, -1, 1, 2)}
    rows = seen.rows
    for j, v in enumerate(target.outputs):
        y = rows[:, j]
        if not np.all(np.isfinite(y)):
            continue
        crossings = np.nonzero(y[:-1] * y[1:] < 0)[0] + 1
        if len(crossings):
            kinds.setdefault("sign changes", []).extend(int(k) for k in crossings)
        for name, found in (("kinks", _kinks(y)), ("jumps", _jumps(y))):
            found = [k for k in found if k not in excused and k < len(rows)]
            if found:
                kinds.setdefault(f"{name} in {v.name}", []).extend(found)
    kinds = {kind: sorted(set(found)) for kind, found in kinds.items() if found}
    return Events(kinds, _merge(sorted({k for found in kinds.values() for k in found})))


def _merge(points: list[int]) -> list[int]:
    """Points within two steps of the one before count as the same event."""
    merged: list[int] = []
    for k in points:
        if not merged or k - merged[-1] > 2:
            merged.append(k)
    return merged


def _kinks(y: np.ndarray) -> list[int]:
    """Where the slope changes far more than around: the first point after the kink (a kink
    at point k or inside the step from k - 1 to k shows in the second difference centred on
    k - 1, first; the one after it may show too and is merged)."""
    return [k + 2 for k in _outstanding(np.abs(np.diff(y, 2)), _floor(y))]


def _jumps(y: np.ndarray) -> list[int]:
    """Where the value changes far more than around: the first point after the jump."""
    return [k + 1 for k in _outstanding(np.abs(np.diff(y)), _floor(y))]


def _floor(y: np.ndarray) -> float:
    return ROUNDING * max(float(np.max(np.abs(y))), float(np.ptp(y)), 1e-300)


def _outstanding(d: np.ndarray, floor: float) -> list[int]:
    """Indices where d exceeds FEATURE times the median of its neighbourhood (NEIGHBOURS either
    side, the adjacent ones left out) and the rounding floor."""
    n = len(d)
    if n < 3:
        return []
    padded = np.concatenate([np.full(NEIGHBOURS + 1, np.nan), d, np.full(NEIGHBOURS + 1, np.nan)])
    windows = sliding_window_view(padded, 2 * NEIGHBOURS + 3)
    around = np.concatenate([windows[:, :NEIGHBOURS], windows[:, -NEIGHBOURS:]], axis=1)
    with np.errstate(invalid="ignore"):
        typical = np.nanmedian(np.where(np.isnan(around), np.nan, around), axis=1)
    typical = np.nan_to_num(typical, nan=0.0)
    found = np.nonzero((d > floor) & (d > FEATURE * typical))[0]
    return [int(k) for k in found]


def _features(inputs: np.ndarray) -> list[int]:
    """Points where any input has a kink or a jump (an output following it is no event)."""
    found: set[int] = set()
    for column in inputs.T:
        if np.ptp(column) == 0:
            continue
        found.update(_kinks(column))
        found.update(_jumps(column))
    return sorted(found)
