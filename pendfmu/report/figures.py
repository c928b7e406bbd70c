"""The report's PNG figures: the identified friction curves, the residual diagnostics of each
recording and the joint region of each pair determined only as a combination (the
recordings themselves are interactive.py's plots).

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
from matplotlib.ticker import FuncFormatter

from pendfmu.fitting.diagnostics import CORRELATED, Binned, Diagnostics
from pendfmu.fitting.result import FitResult, diagnostics_of
from pendfmu.friction import Joint, Law
from pendfmu.report.content import (assessments, bounded_only, fitted_joints, fitted_law, fitted_values,
                                    friction_curve, interval_text, joint_region, residual_fits, unit,
                                    white_noise_band)

SIMULATED = "#d62728"
STICTION = "#1f77b4"
HALVES = {"early": "#2ca02c", "late": "#9467bd"}
ROW_HEIGHT = 3.0  # inches per signal of a diagnostics figure
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
    """The law's parameters a figure names: the paper's three, and each extra that was
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
    """The paper's law, and the extras that shape the sliding friction with their values."""
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


def write_diagnostics_figures(result: FitResult, directory: Path) -> list[Picture | None]:
    """Per recording of content.residual_fits, the PNG of its residual diagnostics
    (fitting/diagnostics.py), or None where the result holds none (an older file's long
    recording, of which only the display envelope is stored). A PNG is the same 100 to
    200 kB whatever the recording's length: it draws the summary, not the samples."""
    pictures: list[Picture | None] = []
    for number, (fit, name) in enumerate(residual_fits(result), 1):
        found = diagnostics_of(fit)
        if not found:
            pictures.append(None)
            continue
        file = f"diagnostics-{number:02d}.png"
        _save(diagnostics_figure(found), directory / file)
        pictures.append(Picture(file, f"residual diagnostics of {name}", _diagnostics_caption(found)))
    return pictures


def _diagnostics_caption(found: dict[str, Diagnostics]) -> str:
    each = [f"{signal}: {d.samples} samples, correlation length {d.correlation_length} "
            f"({d.correlation_length * d.step:.3g} s), speed from {d.speed_from}" for signal, d in found.items()]
    return "residual = recorded − simulated; " + "; ".join(each)


def diagnostics_figure(found: dict[str, Diagnostics]) -> Figure:
    """A row per signal: the residuals' autocorrelation with the white-noise band and the
    correlation length, and their mean in bins of the recorded value and of its rate. Its
    margins are fixed (in inches), not a layout engine's: that would draw it twice, and a
    report of many recordings draws many."""
    height = 0.2 + ROW_HEIGHT * len(found)
    figure = Figure(figsize=(11.0, height))
    figure.subplots_adjust(left=0.07, right=0.99, wspace=0.4, bottom=0.55 / height, top=1 - 0.3 / height,
                           hspace=0.85 / ROW_HEIGHT)
    for row, (signal, d) in zip(figure.subplots(len(found), 3, squeeze=False), found.items()):
        _acf_panel(row[0], signal, d)
        _binned_panel(row[1], d.amplitude, _axis_label(signal, unit(signal)), signal, "against amplitude")
        rate = d.speed_from.removesuffix(" (recorded)")
        speed = _axis_label(rate, unit(rate)) if rate != d.speed_from else _axis_label(
            f"d{signal}/dt", f"{unit(signal)}/s" if unit(signal) else "")
        _binned_panel(row[2], d.speed, speed, signal, "against speed")
    return figure


def _acf_panel(axis, signal: str, d: Diagnostics) -> None:
    lags = np.asarray(d.lags) * d.step
    band = white_noise_band(d.samples)
    axis.axhspan(-band, band, color="grey", alpha=0.25, lw=0, label=f"white noise 95 %: ±{band:.2g}")
    for sign in (1, -1):
        axis.axhline(sign * CORRELATED, color="grey", lw=0.8, ls=":",
                     label=f"±{CORRELATED:g}: counts as correlated" if sign > 0 else None)
    axis.plot(lags, d.acf, color=STICTION, lw=1.2, marker=".", ms=2.5)
    axis.axvline(d.correlation_length * d.step, color=SIMULATED, lw=1, ls="--",
                 label=f"correlation length {d.correlation_length} samples")
    axis.axhline(0.0, color="black", lw=0.6)
    axis.set_xlabel("lag [s]")
    axis.set_ylabel("autocorrelation")
    axis.set_title(f"{signal}: residual autocorrelation", fontsize="medium", parse_math=False)
    axis.legend(fontsize="x-small", loc="upper right")
    axis.grid(alpha=0.3)


def _binned_panel(axis, binned: Binned, xlabel: str, signal: str, against: str) -> None:
    """The residual's (recorded − simulated) mean per bin with the residuals' spread (±1
    standard deviation) in it."""
    centre, mean, spread = (np.asarray(v, float) for v in (binned.centre, binned.mean, binned.spread))
    axis.fill_between(centre, mean - spread, mean + spread, color=STICTION, alpha=0.2, lw=0, label="±1 sd in the bin")
    axis.plot(centre, mean, color=STICTION, marker="o", ms=3.5, lw=1.2, label="mean in the bin")
    axis.axhline(0.0, color="black", lw=0.6)
    axis.set_xlabel(xlabel, parse_math=False)
    axis.set_ylabel(_axis_label("residual", unit(signal)))
    axis.set_title(f"{signal}: residual {against}", fontsize="medium", parse_math=False)
    _plain_ticks(axis)
    if not binned.centre:
        axis.text(0.5, 0.5, "too few samples to bin", transform=axis.transAxes, ha="center", color="grey")
    else:
        axis.legend(fontsize="x-small", loc="best")
    axis.grid(alpha=0.3)


def write_joint_figures(result: FitResult, directory: Path) -> list[Picture]:
    """One PNG per pair the result determines only as a combination (its assessments'
    `combinations`, validation.separately): their joint region with the combination's line."""
    pictures = []
    for stage, assessment in assessments(result).items():
        halves = (assessment.get("windows") or {}).get("halves") or {}
        for combination in assessment.get("combinations") or []:
            figure = joint_figure(result, combination, halves)
            if figure is None:
                continue
            file = f"joint-{len(pictures) + 1:02d}.png"
            _save(figure, directory / file)
            a, b = combination["pair"]
            pictures.append(Picture(file, f"{a} and {b} ({stage})", _joint_caption(combination, halves)))
    return pictures


def _joint_caption(combination: dict, halves: dict) -> str:
    a, b = combination["pair"]
    caption = (f"the 95 % joint region of {a} and {b} (from their intervals and their correlation, on log "
               f"scales) and the line of the combination the recordings determine, {combination['text']} "
               f"(dashed: its 95 % interval {interval_text(*combination['ci95'])})")
    if any(a in halves.get(which, {}) for which in HALVES):
        caption += "; the points: the early and the late halves' estimates with their intervals"
    return caption + ": the data settle the combination (across the line), not each member (along it)"


def joint_figure(result: FitResult, combination: dict, halves: dict) -> Figure | None:
    """The pair's joint region, the determined line and the halves' estimates; None when
    the result lacks an estimate of the pair or its spread."""
    a, b = (result.estimates.get(name) for name in combination["pair"])
    if a is None or b is None:
        return None
    region = joint_region(a, b, (result.correlation.get(a.label) or {}).get(b.label))
    if region is None:
        return None
    figure = Figure(figsize=(6.4, 5.2), layout="constrained")
    axis = figure.add_subplot()
    axis.fill(*np.exp(region), fc=(0.12, 0.47, 0.71, 0.35), ec=STICTION, lw=1.5, zorder=3, label="95 % joint region")
    axis.plot([a.value], [b.value], "o", color="black", ms=4, zorder=4, label="the fit's estimate")
    shown = [region] + _halves(axis, a.label, b.label, halves)
    _limits(axis, np.hstack(shown))
    _power_line(axis, combination)
    axis.set_xlabel(_axis_label(a.label, unit(a.label)), parse_math=False)
    axis.set_ylabel(_axis_label(b.label, unit(b.label)), parse_math=False)
    axis.set_title(f"Determined together: {combination['text']}", fontsize="medium", parse_math=False)
    axis.grid(alpha=0.3, which="both")
    figure.legend(loc="outside lower center", fontsize="small", ncols=2)
    return figure


def _halves(axis, a: str, b: str, halves: dict) -> list[np.ndarray]:
    """The early and late halves' estimates with their intervals (where positive); the
    log-scale points they span, for the limits."""
    spans = []
    for which, colour in HALVES.items():
        rows = halves.get(which) or {}
        if a not in rows or b not in rows:
            continue
        (x, *x_ends), (y, *y_ends) = rows[a], rows[b]
        if not (x and y and x > 0 and y > 0):
            continue
        xs, ys = _ends(x, x_ends), _ends(y, y_ends)
        axis.errorbar([x], [y], xerr=[[x - xs[0]], [xs[1] - x]], yerr=[[y - ys[0]], [ys[1] - y]], fmt="s",
                      color=colour, ms=5, capsize=3, label=f"{which} halves")
        spans.append(np.log([[xs[0], xs[1]], [ys[0], ys[1]]]))
    return spans


def _ends(value: float, ends: list) -> tuple[float, float]:
    """An interval's ends where they are positive numbers, else the value itself."""
    low, high = ends
    return (low if low and 0 < low <= value else value), (high if high and high >= value else value)


def _limits(axis, logs: np.ndarray) -> None:
    """Log axes that hold every point drawn, with a margin; fixed, so the line is clipped."""
    axis.set_xscale("log")
    axis.set_yscale("log")
    for low, high, setter in ((*_padded(logs[0]), axis.set_xlim), (*_padded(logs[1]), axis.set_ylim)):
        setter(math.exp(low), math.exp(high))
    axis.set_autoscale_on(False)
    _plain_ticks(axis)  # less than a decade: plain numbers, not 5.4 x 10^-4 at every tick


def _plain_ticks(axis) -> None:
    """Tick labels as plain numbers of three digits: no offset or power above the axis,
    which would run into the panel's title."""
    plain = FuncFormatter(lambda value, _: f"{value:.3g}")
    for ticks in (axis.xaxis, axis.yaxis):
        ticks.set_major_formatter(plain)
        ticks.set_minor_formatter(plain)


def _padded(logs: np.ndarray) -> tuple[float, float]:
    low, high = float(np.min(logs)), float(np.max(logs))
    margin = 0.15 * (high - low) if high > low else 0.1
    return low - margin, high + margin


def _power_line(axis, combination: dict) -> None:
    """p ln a + q ln b = ln(value): a straight line on log axes, and its interval's two."""
    p, q = combination["powers"]
    (x0, x1), (y0, y1) = (np.log(axis.get_xlim()), np.log(axis.get_ylim()))
    norm = p * p + q * q
    direction = np.array([-q, p]) / math.sqrt(norm)
    reach = math.hypot(x1 - x0, y1 - y0) + abs(x0) + abs(y0) + abs(x1) + abs(y1)
    t = np.linspace(-reach, reach, 400)
    for level, style in ((combination["value"], "-"), *((end, "--") for end in combination["ci95"])):
        base = math.log(level) * np.array([p, q]) / norm
        line = base[:, None] + direction[:, None] * t
        axis.plot(*np.exp(line), color=SIMULATED, lw=1.2 if style == "-" else 0.8, ls=style, zorder=2,
                  label=f"{combination['text']}" if style == "-" else None)
