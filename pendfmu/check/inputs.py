"""Inputs: finite outputs over each input's range, and beyond an undeclared one.

Each Real input in turn is held at a series of values while the others stay at their start
values, for a short run (a fifth of the run, at most MAX_STEPS steps); every output must stay
finite at every communication point. The values (stimulus.probe_values): five spread over a
declared [min, max]; without a declared range, the start value and start +- 1, 10, 100, ...
times the input's nominal up to `pendfmu check --input-limit` times it (default 1000), nearest
first. A NaN or Inf output at any probed value fails and names the input, the value and the
output, also when the FMU refuses a later step (it returned OK with the NaN first). A value
inside the declared range refused with an error status fails too; outside a declared range
(or without one) a refusal is the FMU's right and is listed. An input whose values change no
output was not exercised; when none does, the row is INCONCLUSIVE.
"""

from __future__ import annotations

import numpy as np

from pendfmu.check.fmu import INCONCLUSIVE, CheckResult, Driver, Target, call_error
from pendfmu.check.stimulus import declared, levels, nominal, probe_values, start
from pendfmu.errors import FMUError

MAX_STEPS = 200


class _NotFinite(Exception):
    """An output turned NaN or Inf: at which step, which output, the value."""

    def __init__(self, step: int, output: int, value: float):
        super().__init__(f"output {output} = {value} at step {step}")
        self.step, self.output, self.value = step, output, value


def run(target: Target, kind: str) -> list[CheckResult]:
    name = f"inputs: finite outputs {kind}"
    if not target.inputs:
        return [CheckResult(name, True, "no Real inputs")]
    if not target.outputs:
        return [CheckResult(name, INCONCLUSIVE, "no outputs to compare", "nothing was exercised: no outputs")]
    steps = max(1, min(MAX_STEPS, int(round(target.stop / target.step / 5))))
    starts = np.array([float(v.start) if v.start is not None else 0.0 for v in target.inputs])
    runs, refused, silent = 0, [], []
    for j, v in enumerate(target.inputs):
        values, in_range = probe_values(target, v)
        baseline, responded = None, False
        for value in values:
            held = starts.copy()
            held[j] = value
            try:
                rows = _held_run(target, kind, held, steps)
            except _NotFinite as bad:
                return [_not_finite(target, kind, v, value, in_range, bad)]
            except FMUError as error:
                if in_range:
                    return [CheckResult(name, False, f"{v.name} = {value:g} refused",
                                        f"input {v.name} = {value:g} is inside its declared range "
                                        f"[{values[0]:g}, {values[-1]:g}] but the FMU refused it: "
                                        + call_error(error))]
                refused.append(f"{v.name} = {value:g}")
                continue
            runs += 1
            baseline = rows if baseline is None else baseline
            responded = responded or not np.array_equal(rows, baseline)
        if not responded:
            silent.append(v.name)
    return [_row(target, kind, _covered(target, runs), refused, silent)]


def _held_run(target: Target, kind: str, held: np.ndarray, steps: int) -> np.ndarray:
    """Outputs of a short run with the inputs held; raises _NotFinite at the first NaN/Inf."""
    h = target.step
    unit = Driver(target, kind)
    try:
        unit.initialize(None, held)
        rows = [unit.outputs()]
        for k in range(steps):
            _finite(rows[-1], k)
            unit.time = k * h
            unit.step(h, held)
            unit.time = (k + 1) * h
            rows.append(unit.outputs())
        _finite(rows[-1], steps)
        return np.array(rows)
    finally:
        unit.free()


def _finite(row: np.ndarray, step: int) -> None:
    bad = np.nonzero(~np.isfinite(row))[0]
    if len(bad):
        raise _NotFinite(step, int(bad[0]), float(row[bad[0]]))


def _covered(target: Target, runs: int) -> str:
    """'finite, 9 runs: u 0 ± 1, 10, 100, 1000 V by decades (no declared range)'."""
    parts = [f"{v.name} {len(values)} values over its declared [{min(values):g}, {max(values):g}]"
             for values, v in ((probe_values(target, v)[0], v) for v in target.inputs if declared(v))]
    around = [v for v in target.inputs if not declared(v)]
    if around:
        steps = ", ".join(f"{level:g}" for level in levels(target.input_limit))
        if len(around) == 1:
            v = around[0]
            unit = f" {v.unit}" if getattr(v, "unit", None) else ""
            scaled = ", ".join(f"{level * nominal(v):g}" for level in levels(target.input_limit))
            parts.append(f"{v.name} {start(v):g} ± {scaled}{unit} by decades (no declared range)")
        else:
            parts.append(f"{', '.join(v.name for v in around)} ± {steps} x nominal around their start values by "
                         f"decades (no declared range)")
    return f"finite, {runs} runs: " + "; ".join(parts)


def _not_finite(target: Target, kind: str, v, value: float, in_range: bool, bad: _NotFinite) -> CheckResult:
    name = f"inputs: finite outputs {kind}"
    output = target.outputs[bad.output].name
    values, _ = probe_values(target, v)
    where = (f"in its declared range [{values[0]:g}, {values[-1]:g}]" if in_range
             else "probed by decades, no declared range")
    return CheckResult(name, False, f"{v.name} = {value:g}: {output} = {bad.value}",
                       f"with input {v.name} held at {value:g} ({where}) output {output} turned {bad.value} at "
                       f"t = {bad.step * target.step:.6g} s while every call returned OK")


def _row(target: Target, kind: str, covered: str, refused: list[str], silent: list[str]) -> CheckResult:
    name = f"inputs: finite outputs {kind}"
    figure = covered
    if silent:
        figure += f"; no output responded to {', '.join(silent)}"
    message = f"refused (no declared range): {', '.join(refused)}" if refused else ""
    if len(silent) == len(target.inputs):
        return CheckResult(name, INCONCLUSIVE, figure, "nothing was exercised: no output changed with any input "
                           "value tried" + (f"; {message}" if message else ""))
    return CheckResult(name, True, figure, message)
