"""The report's PNG figures: the identified friction curves (the recordings are interactive.py's).

Figures are drawn on bare matplotlib ``Figure`` objects (the Agg canvas), never through
pyplot: a report written from a server, a test or a thread must not depend on, or
change, the process's interactive backend, and nothing stays open after a figure is
saved.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from pendfmu.report.content import Joint, bounded_only, fitted_joints, friction_values, interval_text, unit
from pendfmu.fitting.result import FitResult

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
        if not all(math.isfinite(v) for v in friction_values(result, joint)):
            continue  # a failed fit's NaN draws no curve; the table shows the values
        file = f"friction-{joint.name}.png"
        _save(friction_figure(result, joint), directory / file)
        friction.append(Picture(file, f"{joint.name} friction",
                                f"identified friction law of the {joint.name} ({', '.join(joint.parameters)})"))
    return friction


def _save(figure: Figure, path: Path) -> None:
    FigureCanvasAgg(figure)
    figure.savefig(path, dpi=DPI)


def _axis_label(name: str, unit_: str) -> str:
    return f"{name} [{unit_}]" if unit_ else name


def friction_figure(result: FitResult, joint: Joint) -> Figure:
    """The friction law of the paper's Fig. 1 with the identified values: the viscous
    line offset by the Coulomb step for a sliding joint, and at zero speed the vertical
    stiction segment from -F_S to +F_S (any force within it holds the joint at rest).
    A stiction interval (95 % interval, or the set a free decay confines it to) is shaded."""
    k_fw, f_k, f_s = friction_values(result, joint)
    v_max = _speed_range(k_fw, f_k, f_s)
    figure = Figure(figsize=(6.4, 5.0), layout="constrained")
    axis = figure.add_subplot()
    speed = np.linspace(0.0, v_max, 50)
    sliding = k_fw * speed + f_k  # forward; backward is its mirror image, the step at 0 joins them
    axis.plot(np.concatenate([-speed[::-1], speed]), np.concatenate([-sliding[::-1], sliding]), color=SIMULATED,
              lw=2, label=f"sliding: {joint.viscous}·{joint.speed} + {joint.coulomb}·sgn({joint.speed})")
    # The curve, not a wide stiction interval, sets the scale; the interval is clipped.
    limit = 1.15 * max(k_fw * v_max + f_k, f_s, 1e-300)
    _stiction_band(axis, result, joint, v_max, limit)
    axis.plot([0, 0], [-f_s, f_s], color=STICTION, lw=3.5, solid_capstyle="butt",
              label=f"stuck ({joint.speed} = 0): |F_F| ≤ {joint.stiction}")
    axis.plot([0, 0], [-f_s, f_s], "o", color=STICTION, ms=5)
    axis.axhline(0.0, color="black", lw=0.6)
    axis.axvline(0.0, color="black", lw=0.6)
    _annotate(axis, joint, k_fw, f_k, f_s, v_max)
    axis.set_xlim(-v_max, v_max)
    axis.set_ylim(-limit, limit)
    axis.set_xlabel(_axis_label(joint.speed_label, unit(joint.speed)))
    axis.set_ylabel(_axis_label(joint.force_label, unit(joint.coulomb)))
    axis.set_title(f"Identified friction of the {joint.name} (cf. the paper's Fig. 1)", fontsize="medium")
    axis.grid(alpha=0.3)
    figure.legend(loc="outside lower center", fontsize="small")
    return figure


def _speed_range(k_fw: float, f_k: float, f_s: float) -> float:
    """Wide enough that the viscous slope shows next to the Coulomb step: the speed at
    which viscous friction reaches about 1.5 times the larger of the two thresholds."""
    threshold = max(f_k, f_s, 0.0)
    if k_fw > 0 and threshold > 0:
        return 1.5 * threshold / k_fw
    return 1.0


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


def _annotate(axis, joint: Joint, k_fw: float, f_k: float, f_s: float, v_max: float) -> None:
    """Name the identified values where they show in the curve, each in a region of its
    own: stiction left of the spike's top, Coulomb right of the step below the line, the
    slope above the backward branch, which falls away from the text."""
    force_unit = unit(joint.coulomb)
    axis.annotate(f"{joint.stiction} = {f_s:.4g} {force_unit}", (0, f_s), xytext=(-8, 0),
                  textcoords="offset points", color=STICTION, fontsize="small", ha="right", va="center")
    axis.annotate(f"{joint.coulomb} = {f_k:.4g} {force_unit}", (0, f_k), xytext=(8, -4),
                  textcoords="offset points", color=SIMULATED, fontsize="small", ha="left", va="top")
    left = -0.3 * v_max
    axis.annotate(f"slope {joint.viscous} = {k_fw:.4g} {unit(joint.viscous)}", (left, k_fw * left - f_k),
                  xytext=(-6, 10), textcoords="offset points", color=SIMULATED, fontsize="small",
                  ha="right", va="bottom")
