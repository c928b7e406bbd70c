"""Inputs: finite outputs over each input's range.

Each Real input in turn is held at five values spread over its declared [min, max] (or, when
the FMU declares no range, over its start value +- max(1, |start|/2), and the row says so)
while the others stay at their start values, for a short run (a fifth of the run, at most 200
steps); every output must stay finite. A failure names the input, the value and the output.
A value inside the declared range refused with an error status fails too; outside a
declared range a refusal is the FMU's right.
"""

from __future__ import annotations

import numpy as np

from pendfmu.check.fmu import CheckResult, Driver, Target, call_error
from pendfmu.errors import FMUError

SAMPLES = 5


def run(target: Target, kind: str) -> list[CheckResult]:
    name = f"inputs: finite outputs {kind}"
    if not target.inputs:
        return [CheckResult(name, True, "no Real inputs")]
    if not target.outputs:
        return [CheckResult(name, True, "no outputs to compare")]
    h = target.step
    steps = max(1, min(200, int(round(target.stop / h / 5))))
    starts = np.array([float(v.start) if v.start is not None else 0.0 for v in target.inputs])
    declared, assumed, refused = [], [], []
    for j, v in enumerate(target.inputs):
        span = target.span(v)
        (declared if span.declared else assumed).append(f"{v.name} [{span.low:g}, {span.high:g}]")
        for value in np.linspace(span.low, span.high, SAMPLES):
            held = starts.copy()
            held[j] = value
            unit = Driver(target, kind)
            try:
                unit.initialize(None, held)
                rows = unit.run(h, steps * h, lambda t: held)
            except FMUError as error:
                if span.declared:
                    return [CheckResult(name, False, f"{v.name} = {value:g} refused",
                                        f"input {v.name} = {value:g} is inside its declared range "
                                        f"[{span.low:g}, {span.high:g}] but the FMU refused it: "
                                        + call_error(error))]
                refused.append(f"{v.name} = {value:g}")
                continue
            finally:
                unit.free()
            bad = np.argwhere(~np.isfinite(rows))
            if len(bad):
                k, o = bad[0]
                return [CheckResult(name, False, f"{v.name} = {value:g}: {target.outputs[o].name} = {rows[k, o]}",
                                    f"with input {v.name} held at {value:g} (in its "
                                    f"{'declared' if span.declared else 'assumed'} range [{span.low:g}, {span.high:g}]) "
                                    f"output {target.outputs[o].name} turned {rows[k, o]} at t = {k * h:.6g} s "
                                    f"while every call returned OK")]
    parts = []
    if declared:
        parts.append("declared " + ", ".join(declared))
    if assumed:
        parts.append("around start " + ", ".join(assumed))
    figure = f"{len(target.inputs) * SAMPLES} runs finite; " + "; ".join(parts)
    message = f"refused (no declared range): {', '.join(refused)}" if refused else ""
    return [CheckResult(name, True, figure, message)]


