"""The page of a friction-law comparison (pendfmu laws --report): the recommendation and
why, the ranking, each law's fitted values, and how the laws were compared."""

from __future__ import annotations

import json

from pendfmu.fitting.ranking import LawComparison, ranked
from pendfmu.report.content import unit
from pendfmu.report.html import DASH, _cell, _section, _table, _text, document, number


def laws_page(comparison: LawComparison) -> str:
    """The comparison as an HTML5 document."""
    sections = [
        _section("Recommendation", _recommendation(comparison)),
        _section("Ranking", _ranking(comparison)),
        _section("Each law's values, fitted to the whole recordings", _values(comparison)),
        _section("How the laws were compared", _method(comparison)),
        _section("Request", f'<pre class="command">{_text(json.dumps(comparison.request, indent=2))}</pre>'),
    ]
    return document(f"pendfmu: friction laws of the {comparison.stage} stage", sections, False)


def _recommendation(comparison: LawComparison) -> str:
    if comparison.recommended is None:
        return f"<p>No law is recommended: {_text(comparison.reason)}.</p>"
    chosen = comparison.row(comparison.recommended)
    return (f"<p><strong>{_text(chosen.label)}</strong> (<code>{_text(', '.join(chosen.terms))}</code>): "
            f"{_text(comparison.reason)}.</p>")


def _ranking(comparison: LawComparison) -> str:
    best = min((row.bic for row in comparison.rows if row.bic is not None), default=None)
    rows = []
    for rank, row in enumerate(ranked(comparison.rows), 1):
        chosen = row.name == comparison.recommended
        head = _cell(f"<strong>{_text(row.label)}</strong>" if chosen else _text(row.label))
        if row.failed:
            rows.append("<tr>" + _cell(DASH) + head + _cell(_text(", ".join(row.added)))
                        + f'<td colspan="4" class="muted">failed: {_text(row.failed)}</td></tr>')
            continue
        delta = None if row.bic is None or best is None else row.bic - best
        rows.append("<tr>" + _cell(str(rank), "num") + head + _cell(f"<code>{_text(', '.join(row.added))}</code>")
                    + _cell(str(row.whole.free), "num") + _cell(number(row.whole.residuals.rms, 4), "num")
                    + _cell(number(row.held_out, 4), "num differs" if chosen else "num")
                    + _cell(number(delta, 4), "num") + "</tr>")
    return _table(("rank", "law", "adds", "free", "whole RMS", "held-out RMS", "ΔBIC"), rows,
                  "RMS of the residuals in units of the sensor noise (1: as good as the sensors allow); held-out: "
                  "the held-out data predicted by the law fitted without them; ΔBIC: BIC minus the lowest")


def _values(comparison: LawComparison) -> str:
    laws = [row for row in comparison.rows if not row.failed]
    names = list(dict.fromkeys(name for row in laws for name in row.whole.values))
    if not names:
        return "<p>No law was fitted.</p>"
    rows = ["<tr>" + _cell(f"<code>{_text(name)}</code>") + _cell(_text(unit(name)))
            + "".join(_cell(number(row.whole.values.get(name), 5), "num") for row in laws) + "</tr>"
            for name in names]
    return _table(("parameter", "unit", *(row.label for row in laws)), rows,
                  "a dash: the law does not have the term (it is fixed at 0), or it is not fitted")


def _method(comparison: LawComparison) -> str:
    facts = [("held out", comparison.held_out),
             ("recommendation", f"the simplest law whose held-out RMS is within {comparison.margin:.0%} of the best"),
             ("information criterion", f"BIC on {comparison.effective_samples:.4g} effective samples (the samples "
                                       f"over their residuals' correlation length, of the best-fitting law)"),
             ("time", f"{comparison.seconds:.1f} s")]
    parts = [_table(("what", "how"), ["<tr>" + _cell(_text(k)) + _cell(_text(v)) + "</tr>" for k, v in facts])]
    if comparison.notes:
        parts.append("<h3>Notes</h3>\n<ul>" + "".join(f"<li>{_text(note)}</li>" for note in comparison.notes)
                     + "</ul>")
    return "\n".join(parts)
