"""The report's page: one self-contained HTML5 file beside its PNG figures.

No JavaScript, no web fonts, no network: the page must open the same from a lab PC
without internet, an e-mail attachment folder or a CI artifact. Every text that comes
from a result (names, notes, flags, recording names) is escaped here, in one place, by
`_text`; markup is only ever built from escaped pieces.
"""

from __future__ import annotations

import html
import math
from collections.abc import Iterable, Sequence

from pendfmu.report.content import (SignalError, bounded_only, component_of, description, finite,
                                    interval_text, relative_stderr, signal_errors, unit)
from pendfmu.report.figures import Picture
from pendfmu.fitting.result import Estimate, FitResult

DASH = "—"  # what a missing or undefined number shows
NO_FRICTION = "<p>No friction curve: no friction parameters were fitted (or their values are not finite).</p>"

STYLE = """
body { font-family: system-ui, -apple-system, "Segoe UI", Roboto, Helvetica, Arial, sans-serif;
       margin: 2em auto; max-width: 72em; padding: 0 1em; color: #222; line-height: 1.4; }
h1 { font-size: 1.6em; margin-bottom: 0.2em; }
h2 { font-size: 1.25em; margin-top: 2em; border-bottom: 1px solid #ccc; padding-bottom: 0.2em; }
h3 { font-size: 1.05em; margin-bottom: 0.3em; }
table { border-collapse: collapse; margin: 0.6em 0; font-size: 0.92em; }
caption { text-align: left; padding-bottom: 0.3em; }
th, td { border: 1px solid #d0d0d0; padding: 0.25em 0.6em; text-align: left; vertical-align: top; }
th { background: #f2f2f2; }
td.num { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
tr.flagged td { background: #fff3cd; }
tr.flagged td.name { border-left: 4px solid #e0a800; }
td.flags ul { margin: 0; padding-left: 1.1em; }
td.corr { text-align: center; min-width: 3.5em; font-variant-numeric: tabular-nums; }
td.strong { font-weight: bold; }
.muted { color: #666; }
figure { margin: 1em 0 2em 0; }
figure img { max-width: 100%; height: auto; border: 1px solid #e0e0e0; }
figcaption { color: #555; font-size: 0.9em; }
ul.notes li { margin-bottom: 0.3em; }
code { font-family: ui-monospace, "DejaVu Sans Mono", Menlo, Consolas, monospace; }
"""


def _text(value) -> str:
    """Any value as escaped HTML text."""
    return html.escape(str(value), quote=True)


def number(value, digits: int = 6) -> str:
    """A number for a table cell: a dash when it is missing or not finite."""
    if not finite(value):
        return DASH
    return f"{float(value):.{digits}g}"


def interval(bounds: Sequence[float] | None) -> str:
    """An interval for a table cell; an unbounded side shows as inf."""
    if bounds is None or any(math.isnan(float(b)) for b in bounds):
        return DASH
    return interval_text(*bounds)


def _cell(content: str, css: str = "") -> str:
    """A table cell from already escaped markup."""
    return f'<td class="{css}">{content}</td>' if css else f"<td>{content}</td>"


def _table(headers: Iterable[str], rows: Iterable[str], caption: str = "") -> str:
    head = "".join(f'<th scope="col">{_text(h)}</th>' for h in headers)
    caption = f"<caption class=\"muted\">{_text(caption)}</caption>" if caption else ""
    return f"<table>{caption}<thead><tr>{head}</tr></thead><tbody>\n" + "\n".join(rows) + "\n</tbody></table>"


def page(result: FitResult, experiments: list[Picture], friction: list[Picture]) -> str:
    """The whole report as an HTML5 document."""
    sections = [
        _summary(result),
        _section("Fitted parameters", _estimates(result.estimates)),
        _section("Correlation of the estimates", _correlation(result.correlation)),
        _section("Identified friction", _figures(friction) or NO_FRICTION),
        _section("Recorded and simulated signals", _recordings(result) + _figures(experiments)),
        _validation(getattr(result, "validation", None) or {}),
        _section("Known parameters (not fitted)", _known(result)),
    ]
    title = f"pendfmu fit report: stage {result.stage}"
    return (f'<!DOCTYPE html>\n<html lang="en">\n<head>\n<meta charset="utf-8">\n'
            f'<meta name="viewport" content="width=device-width, initial-scale=1">\n'
            f"<title>{_text(title)}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n"
            f"<h1>{_text(title)}</h1>\n" + "\n".join(s for s in sections if s) + "\n</body>\n</html>\n")


def _section(title: str, body: str) -> str:
    return f"<section>\n<h2>{_text(title)}</h2>\n{body}\n</section>"


def _summary(result: FitResult) -> str:
    flagged = sum(1 for e in result.estimates.values() if e.flags)
    count = len(result.experiments)
    overview = (f"<p>{len(result.estimates)} estimates from {count} recording{'' if count == 1 else 's'}; "
                f"{flagged} flagged (highlighted below).</p>")
    statistics = _table(("stage", "cost", "function evaluations", "failed simulations", "seconds"), [
        "<tr>" + _cell(_text(result.stage)) + _cell(number(result.cost), "num") + _cell(_text(result.nfev), "num")
        + _cell(_text(result.failures), "num") + _cell(number(result.seconds, 3), "num") + "</tr>"])
    nrmse = _table(("signal", "NRMSE (RMS error / recorded range)"), [
        "<tr>" + _cell(f"<code>{_text(name)}</code>") + _cell(number(value, 4), "num") + "</tr>"
        for name, value in result.nrmse.items()]) if result.nrmse else ""
    notes = ("<h3>Notes</h3>\n<ul class=\"notes\">" + "".join(f"<li>{_text(n)}</li>" for n in result.notes)
             + "</ul>") if result.notes else ""
    return _section("Fit", overview + statistics + nrmse + notes)


def _estimates(estimates: dict[str, Estimate]) -> str:
    if not estimates:
        return "<p>No parameters were fitted.</p>"
    rows = []
    for label, estimate in estimates.items():
        flags = ("<ul>" + "".join(f"<li>{_text(f)}</li>" for f in estimate.flags) + "</ul>") if estimate.flags else ""
        what = "bounded to" if bounded_only(estimate) else "95 % interval"
        rows.append(
            ('<tr class="flagged">' if estimate.flags else "<tr>")
            + _cell(f"<code>{_text(label)}</code>", "name") + _cell(number(estimate.value), "num")
            + _cell(_text(unit(label))) + _cell(number(estimate.stderr, 3), "num")
            + _cell(number(relative_stderr(estimate), 3), "num")
            + _cell(interval(estimate.ci95) + (f' <span class="muted">({what})</span>' if estimate.ci95 else ""),
                    "num")
            + _cell(_text(estimate.method)) + _cell(flags, "flags") + "</tr>")
    return _table(("name", "value", "unit", "stderr", "stderr %", "interval", "method", "flags"), rows,
                  "method: bootstrap = spread of refits of synthetic recordings read through each sensor "
                  "(calibrated); jacobian = s²(JᵀJ)⁻¹ at the optimum (fast, too narrow on quantized data); "
                  "bounded = the set the recordings allow. A positive quantity's interval is taken on the log scale")


def _correlation(correlation: dict[str, dict[str, float | None]]) -> str:
    """The correlation matrices, shaded like a heatmap (red +1, blue -1): one per group
    of estimates fitted together (a combined result's stages were fitted apart and have
    no correlations between them)."""
    groups: list[list[str]] = []
    for label, row in correlation.items():
        if not any(label in group for group in groups):
            groups.append([label] + [other for other in row if other != label and other in correlation])
    tables = [_correlation_table(group, correlation) for group in groups if len(group) >= 2]
    if not tables:
        return "<p>Fewer than two estimates fitted together: no correlations.</p>"
    return ("\n".join(tables) + f'<p class="muted">Bold: |r| &gt; 0.95, only a combination of the two is '
            f"determined. {DASH}: undefined (a parameter without a standard error).</p>")


def _correlation_table(labels: list[str], correlation: dict[str, dict[str, float | None]]) -> str:
    rows = []
    for row in labels:
        cells = [f'<th scope="row"><code>{_text(row)}</code></th>']
        cells += [_correlation_cell(correlation[row].get(column), diagonal=row == column) for column in labels]
        rows.append("<tr>" + "".join(cells) + "</tr>")
    head = '<th scope="col"></th>' + "".join(f'<th scope="col"><code>{_text(c)}</code></th>' for c in labels)
    return f"<table><thead><tr>{head}</tr></thead><tbody>\n" + "\n".join(rows) + "\n</tbody></table>"


def _correlation_cell(value, diagonal: bool) -> str:
    if not finite(value):
        return _cell(DASH, "corr")
    value = max(-1.0, min(1.0, float(value)))
    colour = "214, 39, 40" if value > 0 else "31, 119, 180"
    shade = "#eeeeee" if diagonal else f"rgba({colour}, {0.75 * abs(value):.2f})"
    css = "corr strong" if abs(value) > 0.95 and not diagonal else "corr"
    return f'<td class="{css}" style="background: {shade}">{value:+.2f}</td>'


def _figures(pictures: list[Picture]) -> str:
    return "\n".join(
        f'<figure><img src="{_text(p.file)}" alt="{_text(p.title)}">'
        f"<figcaption>{_text(p.title)}: {_text(p.caption)}</figcaption></figure>" for p in pictures)


def _recordings(result: FitResult) -> str:
    errors: list[SignalError] = [e for fit in result.experiments for e in signal_errors(fit)]
    if not errors:
        return "<p>The result holds no recordings.</p>"
    rows = ["<tr>" + _cell(_text(e.experiment)) + _cell(f"<code>{_text(e.signal)}</code>")
            + _cell(f"{number(e.rms, 4)} {_text(unit(e.signal))}".strip(), "num")
            + _cell(f"{number(e.resolution, 4)} {_text(unit(e.signal)) if e.resolution else ''}".strip(), "num")
            + _cell(number(e.steps, 3), "num") + "</tr>" for e in errors]
    return _table(("recording", "signal", "RMS error", "sensor step", "RMS error [steps]"), rows,
                  "a fit as good as the sensor allows has an RMS error of about 0.29 steps (quantization alone)")


def _validation(validation: dict[str, dict[str, float]]) -> str:
    """Recordings predicted with the identified parameters but not fitted (fit_all's
    result.validation: per recording, "<signal>_rms" and "<signal>_rms_steps")."""
    if not validation:
        return ""
    rows = []
    for name, entry in validation.items():
        for key, value in entry.items():
            if key.endswith("_rms_steps") and key[:-len("_steps")] in entry:
                continue  # shown with its RMS error
            signal = key[:-len("_rms")] if key.endswith("_rms") else key
            rows.append("<tr>" + _cell(_text(name)) + _cell(f"<code>{_text(signal)}</code>")
                        + _cell(f"{number(value, 4)} {_text(unit(signal))}".strip(), "num")
                        + _cell(number(entry.get(f"{key}_steps"), 3), "num") + "</tr>")
    return _section("Predicted recordings (not fitted)", _table(
        ("recording", "signal", "RMS error", "RMS error [steps]"), rows,
        "the whole rig simulated with the identified parameters: a check of the model, not part of the fit"))


def _known(result: FitResult) -> str:
    fitted = {label.split("[", 1)[0] for label in result.estimates}
    known = {name: value for name, value in result.parameters.items() if name not in fitted}
    if not known:
        return "<p>Every parameter was fitted.</p>"
    rows = ["<tr>" + _cell(f"<code>{_text(name)}</code>") + _cell(number(value), "num") + _cell(_text(unit(name)))
            + _cell(_text(component_of(name))) + _cell(_text(description(name)), "muted") + "</tr>"
            for name, value in known.items()]
    return _table(("name", "value", "unit", "FMU", "description"), rows,
                  "the values the fit ran with: measured, from data sheets or from an earlier stage")

