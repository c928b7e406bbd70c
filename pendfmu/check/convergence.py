"""Step-size convergence: the same run with communication steps h, h/2 and h/4.

The inputs are held over intervals of h in all three runs, so they see the same input and
any difference comes from the step size. Compared at the points of the coarsest grid: d1 =
max |y(h) - y(h/2)|, d2 = max |y(h/2) - y(h/4)| per output, the observed order log2(d1/d2).

With held inputs, an FMU that integrates with its own solver step and locates its events
inside a step gives the same result whatever the communication step, up to its solver's
tolerance. A result that moves by more than `step_rtol` (default fmu.DEFAULT_STEP_RTOL, 1e-4)
of the output's nominal (its range over the run when no nominal is declared) fails: usually
events (stick/slip, a mode switch) decided only at communication points, or a solver whose
step is tied to the communication step. For an FMU built around a fixed-step solver of order
p, `stated_order` p (`pendfmu check --order P`) accepts differences that shrink at that order
(observed >= p - ORDER_SLACK). Model Exchange is integrated by the checker itself (classical
Runge-Kutta on the communication step), so there order DRIVER_ORDER is always accepted.
Outputs that never moved are INCONCLUSIVE: step-independence of a constant says nothing.
"""

from __future__ import annotations

import math

import numpy as np

from pendfmu.check import exercise
from pendfmu.check.fmu import INCONCLUSIVE, CheckResult, Driver, Target, call_error
from pendfmu.check.stimulus import excitation, reference_run, unexercised

DRIVER_ORDER = 4.0
"""The order of the checker's own Model Exchange integration (classical Runge-Kutta)."""
ORDER_SLACK = 0.5
ROUNDING = 1e-12


def run(target: Target, kind: str) -> list[CheckResult]:
    name = f"convergence: h, h/2, h/4 {kind}"
    if not target.outputs:
        return [CheckResult(name, INCONCLUSIVE, "no outputs to compare", "nothing was exercised: no outputs")]
    try:
        coarse, half, quarter = _runs(target, kind)
    except _Failed as failed:
        return [CheckResult(name, False, failed.figure, failed.message)]
    return [verdict(target, kind, coarse, half, quarter)]


class _Failed(Exception):
    def __init__(self, figure: str, message: str):
        super().__init__(message)
        self.figure, self.message = figure, message


def _runs(target: Target, kind: str) -> list[np.ndarray]:
    """The runs at h, h/2, h/4 with inputs held over h, at the coarse points (the run at h
    is the one every check starts from, exercise.reference_run)."""
    h = target.step
    stimulus = excitation(target).at(h)
    try:
        runs = [reference_run(target, kind).rows]
    except Exception as error:
        raise _Failed("h failed", call_error(error)) from None
    for divisor in (2, 4):
        unit = Driver(target, kind)
        try:
            unit.initialize(None, stimulus(0.0))
            runs.append(unit.run(h / divisor, target.stop, stimulus)[::divisor])
        except Exception as error:
            raise _Failed(f"h/{divisor} failed", call_error(error)) from None
        finally:
            unit.free()
    return runs


def verdict(target: Target, kind: str, coarse: np.ndarray, half: np.ndarray, quarter: np.ndarray) -> CheckResult:
    """The row: PASS, FAIL (moves with the step beyond the tolerance) or INCONCLUSIVE."""
    name = f"convergence: h, h/2, h/4 {kind}"
    tolerance = target.step_rtol
    d1, d2 = _largest(coarse, half), _largest(half, quarter)
    scale = exercise.scales(target, quarter)
    relative = np.maximum(d1, d2) / scale
    j = int(np.argmax(relative))
    order = _order(d1[j], d2[j], scale[j])
    stimulus = f" [{excitation(target).label}]"
    figure = f"{target.outputs[j].name}: d1 {d1[j]:.3g}, d2 {d2[j]:.3g}" + (
        f", order {order:.2f}" if math.isfinite(order) else "")
    if relative[j] <= ROUNDING:
        figure += " (rounding: step-independent)"
    elif relative[j] <= tolerance:
        figure += f" ({relative[j]:.2g} of its {_scale_name(target, j, scale[j])}, tolerance {tolerance:g})"
    if not exercise.moved(quarter).any():
        return CheckResult(name, INCONCLUSIVE, figure + stimulus,
                           unexercised(target, "no output moved (a constant is step-independent)"))
    expected = DRIVER_ORDER if kind == "ME" else target.stated_order
    moving = [k for k in np.argsort(-relative) if relative[k] > tolerance
              and not (expected is not None and _order(d1[k], d2[k], scale[k]) >= expected - ORDER_SLACK)]
    figure += "; " + exercise.movement(target, quarter)
    if not moving:
        if relative[j] > tolerance:  # within the stated order
            figure += f"; converging at the stated order {expected:g}"
        return CheckResult(name, True, figure + stimulus)
    k = int(moving[0])
    return CheckResult(name, False, figure + stimulus, _moves(target, k, d1[k], d2[k], scale[k], expected))


def _largest(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Each output's largest difference between two runs (NaN in both: none; in one: inf)."""
    same = np.isnan(a) & np.isnan(b)
    difference = np.where(same, 0.0, np.abs(a - b))
    return np.where(np.isnan(difference), np.inf, difference).max(axis=0)


def _order(d1: float, d2: float, scale: float) -> float:
    """log2(d1/d2), NaN when either is at rounding level or not finite."""
    if not (math.isfinite(d1) and math.isfinite(d2)) or min(d1, d2) <= ROUNDING * scale:
        return math.nan
    return math.log2(d1 / d2)


def _scale_name(target: Target, j: int, scale: float) -> str:
    """Which scale exercise.scales took for output j: its declared nominal or its range."""
    nominal = getattr(target.outputs[j], "nominal", None)
    return "nominal" if nominal and abs(float(nominal)) >= scale else "range"


def _moves(target: Target, k: int, d1: float, d2: float, scale: float, expected: float | None) -> str:
    """What a result that moves with the step means, for the FAIL row."""
    o, h = target.outputs[k].name, target.step
    order = _order(d1, d2, scale)
    seen = f"order {order:.2f}" if math.isfinite(order) else "no order (not shrinking)"
    stated = f", below the expected order {expected:g}" if expected is not None else ""
    return (f"the result moves with the communication step: {o} changes by {d1:.3g} from h = {h:g} s to h/2 and by "
            f"{d2:.3g} from h/2 to h/4 ({max(d1, d2) / scale:.2g} of its {_scale_name(target, k, scale)} {scale:.3g}, "
            f"tolerance {target.step_rtol:g}; {seen}{stated}) with the inputs held: usually events (stick/slip, a "
            f"mode switch) decided only at communication points, or a solver whose step is tied to the "
            f"communication step (if it is a fixed-step solver of order p by design, say so: --order p)")
