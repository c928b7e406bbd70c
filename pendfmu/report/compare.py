"""Two results side by side: did a refit, new recordings or another seed change anything?

A value that moved is only news if it moved by more than the two results' uncertainty
allows: each difference is given in units of the combined standard error
√(se_A² + se_B²) (as if the two were independent; results fitted to the same recordings
are correlated, so the number is then a lower bound on how surprising the move is).
Where both results hold the same recording, their simulations are drawn over it in one
plot.
"""

from __future__ import annotations

import math

from pendfmu.fitting.result import FitResult
from pendfmu.fitting.labels import parameter_of
from pendfmu.report.content import finite, scaled_rms, unit
from pendfmu.report.html import (DASH, _cell, _section, _table, _text, document, interval, number, provenance)
from pendfmu.report.interactive import plot_note, recording_plot

SIGNIFICANT = 2.0
"""|difference| / combined standard error above which a row is highlighted (about the
5 % two-sided level of a normal difference)."""


def difference(a: float | None, se_a: float | None, b: float | None, se_b: float | None
               ) -> tuple[float | None, float | None, float | None]:
    """(b - a, the combined standard error, the difference in its units); None where a
    value or both errors are missing. Errors of 0 on both sides give an infinite ratio
    for a non-zero difference (two exact values that differ)."""
    if not (finite(a) and finite(b)):
        return None, None, None
    delta = float(b) - float(a)
    errors = [float(e) for e in (se_a, se_b) if finite(e)]
    if not errors:
        return delta, None, None
    combined = math.sqrt(sum(e * e for e in errors))
    if combined == 0:
        return delta, 0.0, (0.0 if delta == 0 else math.inf)
    return delta, combined, delta / combined


def comparison_page(first: FitResult, second: FitResult, names: tuple[str, str] = ("A", "B"),
                    sources: tuple[str, str] | None = None) -> str:
    sections = [
        _section("Results compared", _overview(first, second, names, sources or ("", ""))),
        _section("Fitted values", _values(first, second, names)),
        _section("Known values that differ", _known(first, second, names)),
        _section("Recordings of both, overlaid", _overlays(first, second, names)),
        _section(f"Provenance of {names[0]}", provenance(first.provenance)),
        _section(f"Provenance of {names[1]}", provenance(second.provenance)),
    ]
    plots = any(fit.name in {f.name for f in second.experiments + second.predicted}
                for fit in first.experiments + first.predicted)
    return document(f"pendfmu comparison: {names[0]} and {names[1]}", sections, plots)


def _overview(first: FitResult, second: FitResult, names: tuple[str, str], sources: tuple[str, str]) -> str:
    rows = []
    for label, result, source in zip(names, (first, second), sources):
        record = result.provenance or {}
        rows.append("<tr>" + _cell(_text(label)) + _cell(f"<code>{_text(source)}</code>" if source else DASH)
                    + _cell(_text(result.stage)) + _cell(number(result.cost), "num")
                    + _cell(number(scaled_rms(result), 3), "num") + _cell(_text(len(result.experiments)), "num")
                    + _cell(_text(record.get("date", DASH))) + "</tr>")
    return _table(("result", "file", "stage", "cost", "RMS of the scaled residuals", "recordings", "date (UTC)"), rows,
                  "cost: ½ Σ r², r the residual in units of its signal's error scale (see a single report)")


def _values(first: FitResult, second: FitResult, names: tuple[str, str]) -> str:
    labels = list(dict.fromkeys([*first.estimates, *second.estimates]))
    if not labels:
        return "<p>Neither result fitted any parameter.</p>"
    rows = []
    for label in labels:
        a, b = first.estimates.get(label), second.estimates.get(label)
        delta, combined, ratio = difference(a.value if a else None, a.stderr if a else None,
                                            b.value if b else None, b.stderr if b else None)
        css = "num differs" if ratio is not None and abs(ratio) > SIGNIFICANT else "num"
        rows.append("<tr>" + _cell(f"<code>{_text(label)}</code>") + _cell(_text(unit(label)))
                    + _cell(number(a.value) if a else DASH, "num") + _cell(interval(a.ci95) if a else DASH, "num")
                    + _cell(number(b.value) if b else DASH, "num") + _cell(interval(b.ci95) if b else DASH, "num")
                    + _cell(number(delta, 4), "num") + _cell(number(combined, 3), "num")
                    + _cell(number(ratio, 3), css) + "</tr>")
    return _table(("name", "unit", f"{names[0]}", f"{names[0]} 95 % interval", f"{names[1]}",
                   f"{names[1]} 95 % interval", f"{names[1]} − {names[0]}", "combined stderr",
                   "difference [stderr]"), rows,
                  f"combined stderr = √(se_{names[0]}² + se_{names[1]}²); highlighted: more than "
                  f"{SIGNIFICANT:g} of them apart. {DASH}: fitted in one result only, or no standard error")


def _known(first: FitResult, second: FitResult, names: tuple[str, str]) -> str:
    fitted = {parameter_of(key) for key in [*first.estimates, *second.estimates]}
    rows = []
    for name in sorted(set(first.parameters) | set(second.parameters)):
        a, b = first.parameters.get(name), second.parameters.get(name)
        if name in fitted or a == b:
            continue
        rows.append("<tr>" + _cell(f"<code>{_text(name)}</code>") + _cell(_text(unit(name)))
                    + _cell(number(a), "num") + _cell(number(b), "num") + "</tr>")
    if not rows:
        return "<p>Both results ran with the same known values.</p>"
    return _table(("name", "unit", names[0], names[1]), rows)


def _overlays(first: FitResult, second: FitResult, names: tuple[str, str]) -> str:
    theirs = {fit.name: fit for fit in second.experiments + second.predicted}
    shared = [fit for fit in first.experiments + first.predicted if fit.name in theirs]
    missing = [label for label, result in zip(names, (first, second)) if not result.experiments]
    if not shared:
        why = (f"{' and '.join(missing)} holds no recordings (a result file written by an older pendfmu)"
               if missing else "the results share no recording (by name)")
        return f"<p>No overlay: {_text(why)}.</p>"
    parts = [f'<p class="muted">{_text(plot_note(shared))} The recorded signal is {_text(names[0])}\'s.</p>']
    for number_, fit in enumerate(shared, 1):
        parts.append(f"<h3>{_text(fit.name)}</h3>\n<div class=\"plot\">"
                     f"{recording_plot(fit, f'compare-{number_:02d}', [(names[1], theirs[fit.name])], names[0])}"
                     f"</div>")
    return "\n".join(parts)
