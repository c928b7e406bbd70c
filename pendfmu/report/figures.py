"""The report's PNG figures: the identified friction curves (the recordings are interactive.py's).

Figures are drawn on bare matplotlib ``Figure`` objects (the Agg canvas), never through
pyplot: a report written from a server, a test or a thread must not depend on, or
change, the process's interactive backend, and nothing stays open after a figure is
saved.
"""

from __future__ import annotations

import math
from dataclasses import astuple, dataclass
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from pendfmu.fitting.result import FitResult
from pendfmu.friction import Joint, Law
from pendfmu.report.content import (bounded_only, fitted_joints, fitted_law, fitted_values, friction_curve,
                                    interval_text, unit)

SIMULATED = "#d62728"
STICTION = "#1f77b4"
DPI = 110


@dataclass(frozen=True)
class Picture:
    """A written figure: the file name (relative to the report folder) and what it shows."""

    file: str
    title: str
    caption: str


def write_friction_figures(result: FitResult, directory: Path) -> list[Picture]:
    """One PNG per identified friction curve. Static on purpose: the friction law is one
    small figure that needs no zoom, and as an image it shows where JavaScript does not
    run (a mail client, a locked-down viewer)."""
    friction = []
    for joint in fitted_joints(result):
        if not all(math.isfinite(v) for v in astuple(fitted_law(result, joint))):
            continue  # a failed fit's NaN draws no curve; the table shows the values
        file = f"friction-{joint.name}.png"
        _save(friction_figure(result, joint), directory / file)
        friction.append(Picture(file, f"{joint.name} friction", friction_caption(result, joint)))
    return friction


def shown_terms(result: FitResult, joint: Joint) -> list[str]:
    """The law's parameters a figure names: MODEL.md's three, and each extra that was
    fitted or is on (not 0)."""
    values = fitted_values(result, joint)
    return [name for name in joint.parameters
            if name in joint.plain or name in result.estimates or values.get(name, 0.0) != 0.0]


def friction_caption(result: FitResult, joint: Joint) -> str:
    """What the figure shows, and how an offset shows (it changes no friction)."""
    caption = f"identified friction law of the {joint.name} ({', '.join(shown_terms(result, joint))})"
    if fitted_law(result, joint).F_O != 0.0:
        caption += (f"; the offset {joint.offset} is no friction (it adds to the active force {joint.active}): the "
                    f"dashed curve is the {joint.active} that holds each speed, {joint.friction} − {joint.offset}")
    return caption


def _save(figure: Figure, path: Path) -> None:
    FigureCanvasAgg(figure)
    figure.savefig(path, dpi=DPI)


def _axis_label(name: str, unit_: str) -> str:
    return f"{name} [{unit_}]" if unit_ else name


def friction_figure(result: FitResult, joint: Joint) -> Figure:
    """The friction law of the paper's Fig. 1 with the identified values, every fitted term
    of friction.h included (content.friction_curve): the sliding friction either way, and
    at zero speed the vertical stiction segment between the breakaway thresholds (any force
    within it holds the joint at rest). An offset force does not change the friction: it
    shows as the dashed drive that holds each speed. A stiction interval (95 % interval,
    or the set a free decay confines it to) is shaded."""
    law = fitted_law(result, joint)
    speeds, forces = friction_curve(law)
    v_max = float(speeds[-1])
    figure = Figure(figsize=(6.4, 5.0), layout="constrained")
    axis = figure.add_subplot()
    axis.plot(speeds, forces, color=SIMULATED, lw=2, label=_sliding_label(result, joint))
    drawn = [forces]
    if law.F_O != 0.0:
        drawn.append(forces - law.F_O)
        axis.plot(speeds, drawn[-1], color=SIMULATED, lw=1.2, ls="--",
                  label=f"{joint.active} holding the speed: {joint.friction} − {joint.offset} "
                        f"({joint.offset} = {law.F_O:.4g} {joint.unit})")
    low, high = -float(law.threshold(-1.0)), float(law.threshold(1.0))
    # The curve, not a wide stiction interval, sets the scale; the interval is clipped.
    limit = 1.15 * max(*(float(np.max(np.abs(f))) for f in drawn), -low, high, 1e-300)
    _stiction_band(axis, result, joint, v_max, limit)
    axis.plot([0, 0], [low, high], color=STICTION, lw=3.5, solid_capstyle="butt", label=_stuck_label(joint, law))
    axis.plot([0, 0], [low, high], "o", color=STICTION, ms=5)
    axis.axhline(0.0, color="black", lw=0.6)
    axis.axvline(0.0, color="black", lw=0.6)
    _annotate(axis, joint, law, v_max)
    axis.set_xlim(-v_max, v_max)
    axis.set_ylim(-limit, limit)
    axis.set_xlabel(_axis_label(joint.speed_label, unit(joint.speed)))
    axis.set_ylabel(_axis_label(joint.force_label, joint.unit))
    axis.set_title(f"Identified friction of the {joint.name} (cf. the paper's Fig. 1)", fontsize="medium")
    axis.grid(alpha=0.3)
    figure.legend(loc="outside lower center", fontsize="small")
    return figure


def _sliding_label(result: FitResult, joint: Joint) -> str:
    """MODEL.md's law, and the extras that shape the sliding friction with their values."""
    values = fitted_values(result, joint)
    extras = [name for name in shown_terms(result, joint) if name not in (*joint.plain, joint.offset)]
    label = f"sliding: {joint.viscous}·{joint.speed} + {joint.coulomb}·sgn({joint.speed})"
    if extras:
        label += " with " + ", ".join(f"{name} = {values.get(name, 0.0):.4g} {unit(name)}" for name in extras)
    return label


def _stuck_label(joint: Joint, law: Law) -> str:
    if law.threshold(-1.0) == law.threshold(1.0) == law.F_S:
        return f"stuck ({joint.speed} = 0): |{joint.friction}| ≤ {joint.stiction}"
    return (f"stuck ({joint.speed} = 0): {joint.friction} between the breakaway thresholds "
            f"−{float(law.threshold(-1.0)):.4g} and {float(law.threshold(1.0)):.4g} {joint.unit}")


def _stiction_band(axis, result: FitResult, joint: Joint, v_max: float, limit: float) -> None:
    estimate = result.estimates.get(joint.stiction)
    if estimate is None or estimate.ci95 is None:
        return
    low, high = (float(b) for b in estimate.ci95)
    if not (math.isfinite(low) and math.isfinite(high)):
        return
    what = "bounded only" if bounded_only(estimate) else "95 % interval"
    clipped = " (beyond the plot)" if high > limit else ""
    high = min(high, 1.02 * limit)
    width = 0.06 * v_max
    for sign in (1, -1):
        axis.fill_between([-width, width], sign * low, sign * high, color=STICTION, alpha=0.2, lw=0,
                          label=f"{joint.stiction} {what}: {interval_text(*estimate.ci95)} "
                                f"{unit(joint.stiction)}{clipped}" if sign > 0 else None)


def _annotate(axis, joint: Joint, law: Law, v_max: float) -> None:
    """Name the identified values where they show in the curve, each in a region of its
    own: stiction left of the spike's top, Coulomb right of the step below the line, the
    slope above the backward branch, which falls away from the text."""
    axis.annotate(f"{joint.stiction} = {law.F_S:.4g} {joint.unit}", (0, float(law.threshold(1.0))), xytext=(-8, 0),
                  textcoords="offset points", color=STICTION, fontsize="small", ha="right", va="center")
    axis.annotate(f"{joint.coulomb} = {law.F_K:.4g} {joint.unit}", (0, float(law.coulomb(1.0))), xytext=(8, -4),
                  textcoords="offset points", color=SIMULATED, fontsize="small", ha="left", va="top")
    left = -0.3 * v_max
    axis.annotate(f"slope {joint.viscous} = {law.k_fw:.4g} {unit(joint.viscous)}", (left, float(law.sliding(left))),
                  xytext=(-6, 10), textcoords="offset points", color=SIMULATED, fontsize="small",
                  ha="right", va="bottom")
