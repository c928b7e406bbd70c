"""The report's PNG figures: recorded against simulated signals, and friction curves.

Figures are drawn on bare matplotlib ``Figure`` objects (the Agg canvas), never through
pyplot: a report written from a server, a test or a thread must not depend on, or
change, the process's interactive backend, and nothing stays open after a figure is
saved.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from pendfmu.report.content import (Joint, bounded_only, fitted_joints, friction_values, interval_text,
                                    signal_errors, unit)
from pendfmu.fitting.result import ExperimentFit, FitResult

RECORDED = "#555555"
RECORDED_WIDE = "#a8a8a8"
SIMULATED = "#d62728"
STICTION = "#1f77b4"
DPI = 110
ENVELOPE_ABOVE = 2000  # residuals longer than this are drawn as a per-bin envelope
ENVELOPE_BINS = 400


@dataclass(frozen=True)
class Picture:
    """A written figure: the file name (relative to the report folder) and what it shows."""

    file: str
    title: str
    caption: str


def write_figures(result: FitResult, directory: Path) -> tuple[list[Picture], list[Picture]]:
    """Every figure of the report: (one per recording, one per identified friction curve)."""
    experiments = []
    for number, fit in enumerate(result.experiments, 1):
        file = f"fit-{number:02d}-{_slug(fit.name)}.png"
        _save(experiment_figure(fit), directory / file)
        experiments.append(Picture(file, fit.name, "recorded and simulated signals, residual below"))
    friction = []
    for joint in fitted_joints(result):
        if not all(math.isfinite(v) for v in friction_values(result, joint)):
            continue  # a failed fit's NaN draws no curve; the table shows the values
        file = f"friction-{joint.name}.png"
        _save(friction_figure(result, joint), directory / file)
        friction.append(Picture(file, f"{joint.name} friction",
                                f"identified friction law of the {joint.name} ({', '.join(joint.parameters)})"))
    return experiments, friction


def _slug(name: str) -> str:
    """A file-name-safe form of a recording's name (names come from users' files)."""
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", name).strip("._")[:60] or "recording"


def _literal(text: str) -> str:
    """A user's name shown as typed: matplotlib reads text between two $ as TeX math,
    which mangles a file name like "run$1$" or fails on one that is not valid TeX."""
    return text.replace("$", r"\$")


def _save(figure: Figure, path: Path) -> None:
    FigureCanvasAgg(figure)
    figure.savefig(path, dpi=DPI)


def _quantized(recorded: np.ndarray, resolution: float | None) -> bool:
    """Draw a recording as steps when it is a sensor's quantized reading: stated by its
    sidecar, or evident from few distinct levels (an encoder without a sidecar)."""
    return bool(resolution) or (recorded.size > 20 and np.unique(recorded).size < 0.5 * recorded.size)


def experiment_figure(fit: ExperimentFit) -> Figure:
    """For each fitted signal: recorded vs simulated on top, the residual below it.

    The residual axis carries the sensor's steps on its right side and the quantization
    interval (±half a step) as a band: a residual inside the band is as good as the
    sensor can tell."""
    errors = {e.signal: e for e in signal_errors(fit)}
    names = list(fit.recorded)
    figure = Figure(figsize=(9.0, 4.2 * max(len(names), 1)), layout="constrained")
    grid = figure.add_gridspec(2 * max(len(names), 1), 1, height_ratios=[3, 1.4] * max(len(names), 1))
    time = np.asarray(fit.time, float)
    for k, name in enumerate(names):
        recorded = np.asarray(fit.recorded[name], float)
        simulated = np.asarray(fit.simulated[name], float)
        error = errors[name]
        top = figure.add_subplot(grid[2 * k])
        bottom = figure.add_subplot(grid[2 * k + 1], sharex=top)
        steps = _quantized(recorded, error.resolution)
        # The recording wide and light under the simulation: where they agree, both show.
        top.plot(time, recorded, color=RECORDED_WIDE, lw=3.0, drawstyle="steps-post" if steps else "default",
                 label=f"recorded {name}" + (" (quantized)" if steps else ""))
        top.plot(time, simulated, color=SIMULATED, lw=1.0, label=f"simulated {name}")
        top.set_ylabel(_axis_label(name, unit(name)))
        top.legend(loc="best", fontsize="small")
        top.grid(alpha=0.3)
        top.tick_params(labelbottom=False)
        top.set_title(f"{_literal(fit.name)}: {name}, RMS error {_rms_text(error, unit(name))}", fontsize="medium")
        _residual_axis(bottom, time, recorded - simulated, name, error.resolution)
    if not names:
        figure.text(0.5, 0.5, f"{_literal(fit.name)}: no fitted signals", ha="center")
    return figure


def _residual_axis(axis, time: np.ndarray, residual: np.ndarray, name: str, resolution: float | None) -> None:
    factor, residual_unit = _prefixed(residual, unit(name))
    residual = residual * factor
    if resolution:
        step = resolution * factor
        axis.axhspan(-step / 2, step / 2, color=STICTION, alpha=0.15, lw=0, label="± half a sensor step")
        steps = axis.secondary_yaxis("right", functions=(lambda r: r / step, lambda s: s * step))
        steps.set_ylabel("sensor steps")
    if residual.size > ENVELOPE_ABOVE:
        _envelope(axis, time, residual)
    else:
        axis.plot(time, residual, color=RECORDED, lw=0.8)
    axis.axhline(0.0, color="black", lw=0.6)
    axis.set_ylabel(_axis_label("residual", residual_unit))
    if axis.get_legend_handles_labels()[0]:
        axis.legend(loc="upper right", fontsize="x-small", ncols=3)
    axis.set_xlabel("time [s]")
    axis.grid(alpha=0.3)


PREFIXES = {-3: "m", -6: "µ", -9: "n"}
PREFIXABLE = {"m", "rad", "A", "N", "N.m", "s"}


def _prefixed(values: np.ndarray, unit_: str) -> tuple[float, str]:
    """(factor, unit) that show small residuals as plain numbers, 2.5 µm rather than an
    axis of 2.5 under a detached "1e-6" that collides with the plot above."""
    largest = float(np.max(np.abs(values))) if values.size else 0.0
    if unit_ not in PREFIXABLE or not math.isfinite(largest) or largest <= 0:
        return 1.0, unit_
    exponent = max(-9, min(0, 3 * math.floor(math.log10(largest) / 3)))
    return (10.0 ** -exponent, PREFIXES[exponent] + unit_) if exponent else (1.0, unit_)


def _envelope(axis, time: np.ndarray, residual: np.ndarray) -> None:
    """A long residual as its range and mean per time bin. Drawn sample by sample, a
    residual flipping between quantization levels fills the axis with solid ink; the
    range still shows whether it stays within half a step, the mean shows any drift."""
    edges = np.linspace(0, residual.size, ENVELOPE_BINS + 1).astype(int)
    bins = [slice(a, b) for a, b in zip(edges[:-1], edges[1:]) if b > a]
    middle = np.array([time[b].mean() for b in bins])
    axis.fill_between(middle, [residual[b].min() for b in bins], [residual[b].max() for b in bins],
                      color=RECORDED, alpha=0.35, lw=0, label="range per bin")
    axis.plot(middle, [residual[b].mean() for b in bins], color="black", lw=1.0, label="mean per bin")


def _axis_label(name: str, unit_: str) -> str:
    return f"{name} [{unit_}]" if unit_ else name


def _rms_text(error, unit_: str) -> str:
    factor, unit_ = _prefixed(np.array([error.rms]), unit_)
    text = f"{error.rms * factor:.3g} {unit_}".strip()
    return f"{text} = {error.steps:.3g} steps" if error.steps is not None else text


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
