"""The report's page: one self-contained HTML5 file beside its friction PNGs.

No network, no web fonts: the page must open the same from a lab PC without internet,
an e-mail attachment folder or a CI artifact. The recordings' plots are interactive
(interactive.py: plotly, its library inlined in the page); everything else (tables,
provenance, the friction curves as PNG) is plain HTML and shows without JavaScript too,
with a <noscript> note where the plots would be. Every text that comes from a result
(names, notes, flags, recording names, file paths, the command line) is escaped in one
place, by markup.py's `_text`; markup is only ever built from escaped pieces.
"""

from __future__ import annotations

from collections.abc import Sequence

from pendfmu.report.content import (COST_DEFINITION, SignalError, bounded_only, component_of, description, finite,
                                    fitted_samples, ran_with, recording_values, relative_stderr, scaled_rms,
                                    signal_errors, unit)
from pendfmu.report.assessment import STYLE as VERDICT_STYLE
from pendfmu.report.assessment import diagnostics_section, joint_section, validation_section, verdict_box
from pendfmu.report.figures import Picture
from pendfmu.report.markup import DASH, _cell, _figures, _section, _table, _text, interval, number
from pendfmu.report.interactive import library_script, plot_note, recording_plot
from pendfmu.fitting.result import Estimate, ExperimentFit, FitResult
from pendfmu.fitting.labels import parameter_of

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
td.differs { background: #fde2e1; font-weight: bold; }
.plot { margin: 0.5em 0 2em 0; border: 1px solid #e0e0e0; }
noscript p { background: #fff3cd; padding: 0.5em; }
pre.command { white-space: pre-wrap; word-break: break-all; background: #f6f6f6; padding: 0.5em; }
td.hash { font-family: ui-monospace, "DejaVu Sans Mono", Menlo, Consolas, monospace; font-size: 0.85em;
          word-break: break-all; }
"""
NO_SCRIPT = ("<noscript><p>The recordings' plots need JavaScript (they zoom and pan); it is switched off here. "
             "The tables show every number; open index.html in a browser to see the plots.</p></noscript>")


def page(result: FitResult, friction: list[Picture], diagnostics: Sequence[Picture | None] = (),
         joints: Sequence[Picture] = ()) -> str:
    """The whole report as an HTML5 document: the verdict first (assessment.py), then the
    fit, its estimates and how far they hold, the friction, the recordings and their residuals."""
    sections = [
        verdict_box(result),
        _summary(result),
        _section("Fitted parameters", _estimates(result.estimates)),
        _section("Correlation of the estimates", _correlation(result.correlation)),
        validation_section(result),
        joint_section(list(joints)),
        _section("Identified friction", _figures(friction) or NO_FRICTION),
        _section("Recorded and simulated signals", _recordings(result) + _plots(result.experiments, "fit")),
        diagnostics_section(result, list(diagnostics)),
        _validation(result),
        _section("Parameter values per recording", _per_recording(result)),
        _section("Known parameters (not fitted)", _known(result)),
        _section("Provenance", provenance(result.provenance)),
    ]
    return document(f"pendfmu fit report: stage {result.stage}", sections,
                    bool(result.experiments or result.predicted))


def document(title: str, sections: list[str], plots: bool) -> str:
    """An HTML5 page of `sections`; with `plots`, plotly's library inlined in its head."""
    script = library_script() + "\n" if plots else ""
    return (f'<!DOCTYPE html>\n<html lang="en">\n<head>\n<meta charset="utf-8">\n'
            f'<meta name="viewport" content="width=device-width, initial-scale=1">\n'
            f"<title>{_text(title)}</title>\n<style>{STYLE}{VERDICT_STYLE}</style>\n{script}</head>\n<body>\n"
            f"<h1>{_text(title)}</h1>\n" + (NO_SCRIPT + "\n" if plots else "")
            + "\n".join(s for s in sections if s) + "\n</body>\n</html>\n")


def _plots(fits: list[ExperimentFit], prefix: str) -> str:
    """One interactive plot per recording, each under its name."""
    if not fits:
        return ""
    parts = [f'<p class="muted">{_text(plot_note(fits))} Drag to zoom, double-click to reset, click a legend '
             f"entry to hide its curve.</p>"]
    for index, fit in enumerate(fits, 1):
        parts.append(f"<h3>{_text(fit.name)}</h3>\n<div class=\"plot\">"
                     f"{recording_plot(fit, f'{prefix}-{index:02d}')}</div>")
    return "\n".join(parts)


def _summary(result: FitResult) -> str:
    flagged = sum(1 for e in result.estimates.values() if e.flags)
    count = len(result.experiments)
    overview = (f"<p>{len(result.estimates)} estimates from {count} recording{'' if count == 1 else 's'}; "
                f"{flagged} flagged (highlighted below).</p>")
    spread = scaled_rms(result)
    statistics = _table(("stage", "cost", "RMS of the scaled residuals", "function evaluations",
                         "failed simulations", "seconds"), [
        "<tr>" + _cell(_text(result.stage)) + _cell(number(result.cost), "num") + _cell(number(spread, 3), "num")
        + _cell(_text(result.nfev), "num") + _cell(_text(result.failures), "num")
        + _cell(number(result.seconds, 3), "num") + "</tr>"])
    samples = fitted_samples(result)
    cost = (f'<p class="muted">{_text(COST_DEFINITION)}'
            + (f" Here: {samples} samples, RMS of r = √(2 · {number(result.cost, 6)} / {samples}) = "
               f"{number(spread, 3)}." if spread is not None else "") + "</p>")
    nrmse = _table(("signal", "NRMSE (RMS error / recorded range)"), [
        "<tr>" + _cell(f"<code>{_text(name)}</code>") + _cell(number(value, 4), "num") + "</tr>"
        for name, value in result.nrmse.items()]) if result.nrmse else ""
    notes = ("<h3>Notes</h3>\n<ul class=\"notes\">" + "".join(f"<li>{_text(n)}</li>" for n in result.notes)
             + "</ul>") if result.notes else ""
    warnings = ("<h3>Warnings</h3>\n<ul class=\"notes\">" + "".join(f"<li>{_text(w)}</li>" for w in result.warnings)
                + "</ul>") if result.warnings else ""
    return _section("Fit", overview + statistics + cost + nrmse + notes + warnings)


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


def _error_table(fits: list[ExperimentFit], caption: str) -> str:
    errors: list[SignalError] = [e for fit in fits for e in signal_errors(fit)]
    rows = ["<tr>" + _cell(_text(e.experiment)) + _cell(f"<code>{_text(e.signal)}</code>")
            + _cell(f"{number(e.rms, 4)} {_text(unit(e.signal))}".strip(), "num")
            + _cell(f"{number(e.resolution, 4)} {_text(unit(e.signal)) if e.resolution else ''}".strip(), "num")
            + _cell(number(e.steps, 3), "num")
            + _cell(f"{number(e.scale, 4)} {_text(unit(e.signal)) if e.scale else ''}".strip(), "num")
            + _cell(number(e.sigmas, 3), "num") + "</tr>" for e in errors]
    return _table(("recording", "signal", "RMS error", "sensor step", "RMS error [steps]", "noise σ",
                   "RMS error [σ]"), rows, caption)


def _recordings(result: FitResult) -> str:
    if not result.experiments:
        return "<p>The result holds no recordings.</p>"
    return _error_table(result.experiments,
                        "a fit as good as the sensor allows has an RMS error of about 0.29 steps (quantization "
                        "alone) and about 1 σ (σ: the error scale the cost divides by)")


def _validation(result: FitResult) -> str:
    """Recordings predicted with the identified parameters but not fitted (fit_all's
    result.predicted; a result without the traces still has result.validation:
    per recording, "<signal>_rms" and "<signal>_rms_steps")."""
    caption = "the whole rig simulated with the identified parameters: a check of the model, not part of the fit"
    if result.predicted:
        return _section("Predicted recordings (not fitted)",
                        _error_table(result.predicted, caption) + _plots(result.predicted, "predicted"))
    validation = result.validation or {}
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
        ("recording", "signal", "RMS error", "RMS error [steps]"), rows, caption))


def _per_recording(result: FitResult) -> str:
    """The values each recording actually ran with, where they are not all the result's:
    a sidecar's own values (m_p = 0 for the cart without its pendulum), a recording's
    own initial state, fitted or stated."""
    fits, table = recording_values(result)
    if not any(f.values for f in fits):
        return ("<p>The result does not record the values per recording (written by an older pendfmu): see "
                "the known parameters below.</p>")
    if not table:
        return "<p>Every recording ran with the values of the result (no sidecar sets its own).</p>"
    head = ["name", "unit", "result's value"] + [f.name for f in fits]
    rows = []
    for name, values in table.items():
        known = result.parameters.get(name)
        cells = [_cell(f"<code>{_text(name)}</code>"), _cell(_text(unit(name))), _cell(number(known), "num")]
        for fit in fits:
            entry = values[fit.name]
            marks = [m for m, on in (("sidecar", entry.overridden), ("fitted", entry.fitted)) if on]
            text = number(entry.value) + (f' <span class="muted">({", ".join(marks)})</span>' if marks else "")
            cells.append(_cell(text, "num differs" if entry.differs(known) else "num"))
        rows.append("<tr>" + "".join(cells) + "</tr>")
    return _table(head, rows, "highlighted: a value other than the result's; sidecar: set by the recording's "
                              "sidecar JSON; fitted: estimated for that recording alone. Parameters every "
                              "recording ran with at the result's value are not listed")


def _known(result: FitResult) -> str:
    fitted = {parameter_of(key) for key in result.estimates}
    known = {name: value for name, value in result.parameters.items() if name not in fitted}
    if not known:
        return "<p>Every parameter was fitted.</p>"
    rows = []
    for name, value in known.items():
        other = ran_with(result, name)
        rows.append("<tr>" + _cell(f"<code>{_text(name)}</code>") + _cell(number(value), "num")
                    + _cell(_text(other) if other else "", "differs" if other else "")
                    + _cell(_text(unit(name))) + _cell(_text(component_of(name)))
                    + _cell(_text(description(name)), "muted") + "</tr>")
    return _table(("name", "value", "but the recordings ran with", "unit", "FMU", "description"), rows,
                  "the values the fit started from: measured, from data sheets or from an earlier stage; a "
                  "recording's sidecar may set its own (third column, and the table above)")


def provenance(record: dict) -> str:
    """Where the result came from (fitting/provenance.py), as tables."""
    if not record:
        return "<p>The result does not record its provenance (written by an older pendfmu).</p>"
    versions = record.get("versions", {})
    facts = [("date (UTC)", record.get("date")), ("platform", record.get("platform")), ("seed", record.get("seed")),
             *((name, version) for name, version in versions.items())]
    parts = [_table(("what", "value"), ["<tr>" + _cell(_text(k)) + _cell(_text(DASH if v is None else v)) + "</tr>"
                                        for k, v in facts])]
    command = record.get("command")
    parts.append("<h3>Command line</h3>\n" + (f'<pre class="command">{_text(_shell(command))}</pre>' if command
                                               else '<p class="muted">not run from the command line (Python API)</p>'))
    inputs = record.get("inputs", [])
    if inputs:
        rows = ["<tr>" + _cell(f"<code>{_text(entry.get('path'))}</code>"
                               + (' <span class="muted">(predicted)</span>' if entry.get("predicted") else ""))
                + _cell(number(entry.get("bytes"), 12), "num") + _cell(_text(entry.get("sha256") or DASH), "hash")
                + "</tr>" for entry in inputs]
        parts.append("<h3>Input files</h3>\n" + _table(("file", "bytes", "sha256"), rows))
    for stage, setup in record.get("stages", {}).items():
        free = setup.get("free", [])
        rows = ["<tr>" + _cell(f"<code>{_text(label)}</code>") + _cell(number(setup.get("start", {}).get(label)), "num")
                + _cell(interval(setup.get("bounds", {}).get(label)), "num") + _cell(_text(unit(label))) + "</tr>"
                for label in free]
        fixed = setup.get("fixed", {})
        fixed_text = ", ".join(f"{name} = {number(value)}" for name, value in fixed.items())
        parts.append(f"<h3>Stage {_text(stage)}: seed {_text(setup.get('seed'))}, cost "
                     f"{_text(setup.get('cost', ''))}</h3>\n"
                     + _table(("free parameter", "start value", "search bounds", "unit"), rows)
                     + f'<p class="muted">fixed ({len(fixed)}): {_text(fixed_text) or DASH}</p>')
    return "\n".join(parts)


def _shell(argv) -> str:
    """A command line as one could type it again (arguments with spaces quoted)."""
    import shlex

    return " ".join(shlex.quote(str(a)) for a in argv) if isinstance(argv, list) else str(argv)
