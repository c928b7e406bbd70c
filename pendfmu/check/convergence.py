"""Step-size convergence: the same run with communication steps h, h/2 and h/4.

The inputs are held over intervals of h in all three runs, so they see the same input and
any difference comes from the step size. Compared at the points of the coarsest grid: d1 =
max |y(h) - y(h/2)|, d2 = max |y(h/2) - y(h/4)| per output, the observed order log2(d1/d2).
An FMU that integrates with its own fixed solver step and locates its events inside a step
gives differences at the level of its solver error; one that integrates with the
communication step converges with its order. It fails when the differences do not shrink
(d2 >= 0.8 d1) and are more than 1e-6 of the output's range: the result moves with the
step size, e.g. a stick/slip switch decided only at communication points.
"""

from __future__ import annotations

import math

import numpy as np

from pendfmu.check.fmu import CheckResult, Driver, Target, call_error

RELATIVE = 1e-6


def run(target: Target, kind: str) -> list[CheckResult]:
    name = f"convergence: h, h/2, h/4 {kind}"
    if not target.outputs:
        return [CheckResult(name, True, "no outputs to compare")]
    h = target.step
    stimulus = target.stimulus(h)
    runs = []
    for divisor in (1, 2, 4):
        unit = Driver(target, kind)
        try:
            unit.initialize(None, stimulus(0.0))
            runs.append(unit.run(h / divisor, target.stop, stimulus)[::divisor])
        except Exception as error:
            return [CheckResult(name, False, f"h/{divisor} failed", call_error(error))]
        finally:
            unit.free()
    coarse, half, quarter = runs
    d1 = np.nanmax(np.abs(coarse - half), axis=0)
    d2 = np.nanmax(np.abs(half - quarter), axis=0)
    scale = np.maximum(np.nanmax(quarter, axis=0) - np.nanmin(quarter, axis=0), np.nanmax(np.abs(quarter), axis=0))
    scale = np.where(scale > 0, scale, 1.0)
    relative = np.maximum(d1, d2) / scale
    j = int(np.argmax(relative))
    order = math.log2(d1[j] / d2[j]) if d1[j] > 0 and d2[j] > 0 else math.nan
    worst = target.outputs[j].name
    figure = f"{worst}: d1 {d1[j]:.3g}, d2 {d2[j]:.3g}"
    if math.isfinite(order) and min(d1[j], d2[j]) > 1e-12 * scale[j]:  # above rounding: an order
        figure += f", order {order:.2f}"
    if relative[j] <= RELATIVE:
        figure += " (within 1e-6 of its range)" if relative[j] > 1e-12 else " (rounding: step-independent)"
    moving = [k for k in range(len(d1)) if d2[k] > RELATIVE * scale[k] and d2[k] >= 0.8 * d1[k]]
    if moving:
        k = moving[0]
        o = target.outputs[k].name
        return [CheckResult(name, False, figure,
                            f"the result moves with the communication step: {o} changes by {d1[k]:.3g} from h = "
                            f"{h:g} s to h/2 and by {d2[k]:.3g} from h/2 to h/4 (not shrinking; {d2[k] / scale[k]:.2g} "
                            f"of its range), as when a switch (stick/slip, a mode) is decided only at communication "
                            f"points")]
    return [CheckResult(name, True, figure)]
