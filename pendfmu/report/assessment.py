"""The report's account of whether a fit can be trusted: the verdict (fitting/adequacy.py) in a
box near the top, the validation of the early against the late halves (validation.py) as a
table, the pairs the recordings determine only as a combination with their joint regions,
and the residual diagnostics of each recording (fitting/diagnostics.py).

A result written before fits were assessed has none of it: it shows no box and no such
sections, rather than an empty one.
"""

from __future__ import annotations

from pendfmu.fitting.diagnostics import MIN_SAMPLES, Diagnostics
from pendfmu.fitting.result import FitResult, diagnostics_of, whole
from pendfmu.fitting.validation import MIN_HALF, WHICH
from pendfmu.report.content import assessments, beyond_the_limit, residual_fits, white_noise_band
from pendfmu.report.figures import Picture
from pendfmu.report.markup import DASH, _cell, _figures, _section, _table, _text, interval, number

MEANING = {
    "adequate": "The model follows the recordings about as closely as the sensors allow: the estimates and their "
                "intervals can be taken at their word.",
    "model-inadequate": "The optimum is found, but the model cannot follow the recordings: the estimates are this "
                        "model's best compromise, not constants of the rig. A parameter that moves between the "
                        "halves of the recordings (validation below) depends on what the model misses; the "
                        "intervals were widened to what the validation sees. The residual diagnostics below show "
                        "what is missing (a residual that follows the speed: a drag term; the amplitude: "
                        "amplitude-dependent losses).",
    "fit-failed": "The search may not have found the optimum (its searches ended at different costs, or only one "
                  "ran): the estimates may lie in a wrong minimum. Fit again with a wider global search before "
                  "using them.",
}
LIMIT_CAPTION = ("highlighted: moved beyond one combined interval on a fit whose residuals stand far above the noise, "
                 "flagged model-inadequate; on a fit as good as the sensors the halves are shown, not judged (recordings "
                 "that precise tell apart what no sensor shows). Not compared: a half gives no finite interval")
TITLE = {"adequate": "Adequate", "model-inadequate": "Model inadequate", "fit-failed": "Fit failed"}
STYLE = """
div.verdict { border: 2px solid; border-radius: 4px; padding: 0.5em 1em; margin: 1em 0 1.5em 0; }
div.verdict p.title { font-size: 1.15em; margin: 0.2em 0; }
div.verdict ul { margin: 0.3em 0; }
div.verdict-adequate { border-color: #2e7d32; background: #e8f5e9; }
div.verdict-model-inadequate { border-color: #e0a800; background: #fff3cd; }
div.verdict-fit-failed { border-color: #c62828; background: #fde2e1; }
"""


def verdict_box(result: FitResult) -> str:
    """The verdict, its evidence and what it means, in a box coloured by the verdict; a
    sequence of stages shows the worst, with each stage's. "" when the result has none."""
    found = assessments(result)
    if not found:
        return ""
    worst = (result.assessment or {}).get("verdict") or next(iter(found.values()))["verdict"]
    parts = [f'<p class="title"><strong>Verdict: {_text(TITLE.get(worst, worst))}</strong> '
             f'<code>({_text(worst)})</code></p>']
    for stage, assessment in found.items():  # the evidence's first line says how far above the noise
        lead = f"Stage {_text(stage)}: {_text(assessment['verdict'])}. " if stage != result.stage else ""
        items = "".join(f"<li>{_text(line)}</li>" for line in assessment.get("evidence") or [])
        parts.append(f"<p>{lead}Evidence:</p>" + (f"<ul>{items}</ul>" if items else ""))
    parts.append(f"<p>{_text(MEANING.get(worst, ''))}</p>")
    return f'<div class="verdict verdict-{_text(worst)}" role="status">\n' + "\n".join(parts) + "\n</div>"


def validation_section(result: FitResult) -> str:
    """Per stage whose fit was validated, the early and late halves' estimates per parameter."""
    parts = []
    for stage, assessment in assessments(result).items():
        if "windows" not in assessment:
            continue
        heading = f"<h3>Stage {_text(stage)}</h3>\n" if stage != result.stage else ""
        parts.append(heading + _windows(assessment))
    if not parts:
        return ""
    intro = ("<p>Each recording long enough is cut into an early and a late half (for a free decay: large and small "
             "amplitude); the early halves are fitted together on their own, and so are the late. A parameter the "
             "model holds fixed should agree between them: <em>moved</em> is their difference in units of their "
             "combined 95 % interval (the hypotenuse of the two half-widths).</p>")
    return _section("Validation: early against late halves", intro + "\n".join(parts))


def _windows(assessment: dict) -> str:
    windows = assessment["windows"] or {}
    if not windows:
        return (f'<p class="muted">No recording is long enough to be split (each half needs {MIN_HALF} samples): '
                f"no validation.</p>")
    if "halves" not in windows:
        return f'<p class="muted">{_text(windows.get("note", "no validation"))}</p>'
    beyond = beyond_the_limit(assessment)
    early, late = (windows["halves"].get(which) or {} for which in WHICH)
    rows = [_moved_row(name, early.get(name), late.get(name), (windows.get("parameters") or {}).get(name),
                       name in beyond) for name in early]
    recordings = windows.get("recordings") or []
    facts = (f'<p class="muted">{_text(windows.get("method", ""))}; {len(recordings)} recording'
             f'{"" if len(recordings) == 1 else "s"} split'
             + (f", {number(windows['seconds'], 3)} s" if "seconds" in windows else "") + ".</p>")
    return facts + _table(("parameter", "early halves", "late halves", "moved [combined intervals]", "direction",
                           "beyond the limit"), rows, LIMIT_CAPTION)


def _moved_row(name: str, early, late, moved: dict | None, beyond: bool) -> str:
    """One parameter's row: both halves, how far it moved, which way, and whether beyond the limit."""
    return (('<tr class="flagged">' if beyond else "<tr>") + _cell(f"<code>{_text(name)}</code>", "name")
            + _half(early) + _half(late) + _cell(number(moved["ratio"], 3) if moved else "not compared", "num")
            + _cell(_text(moved["direction"]) if moved else DASH)
            + _cell("yes" if beyond else ("no" if moved else DASH)) + "</tr>")


def _half(row) -> str:
    """One half's estimate with its interval, from the result file's [value, low, high]."""
    if not row:
        return _cell(DASH, "num")
    value, *ends = row
    shown = interval(tuple(float("nan") if end is None else end for end in ends))
    return _cell(f"{number(value)} <span class=\"muted\">{shown}</span>", "num")


def joint_section(pictures: list[Picture]) -> str:
    """The joint region of each pair determined only as a combination."""
    if not pictures:
        return ""
    intro = ("<p>These pairs are so strongly correlated, on a fit that misses what the recordings show, that the "
             "data settle only a combination of the two (a power product): each member's own interval is not a "
             "statement about the rig.</p>")
    return _section("Determined only together", intro + _figures(pictures))


def diagnostics_section(result: FitResult, pictures: list[Picture | None]) -> str:
    """The residual diagnostics: a table of the numbers, and a figure per recording."""
    fits = residual_fits(result)
    if not fits:
        return ""
    intro = ("<p>The residual (recorded − simulated) of a model that misses nothing is the sensor's noise: its "
             "autocorrelation stays within the white-noise band (±1.96/√N) beyond lag 0, and its mean is zero at "
             "every amplitude and speed. A residual that stays correlated for a correlation length of many samples "
             "(the largest lag with |autocorrelation| above 0.1, plus one; the sandwich intervals' batches are "
             "four of them long) is a model error, and where its mean follows the speed (air drag, a viscous "
             "term) or the amplitude (amplitude-dependent losses, a stiffness, a sensor gain) it names the term. "
             "Computed from every sample (a result file stores them beside the recording's envelope).</p>")
    rows = [_diagnostics_row(name, signal, d) for fit, name in fits for signal, d in diagnostics_of(fit).items()]
    table = _table(("recording", "signal", "samples", "lag-1 autocorrelation", "correlation length [samples]",
                    "correlation length [s]", "white-noise band ±", "speed from"), rows) if rows else ""
    missing = [fit for (fit, _), picture in zip(fits, pictures) if picture is None]
    return _section("Residual diagnostics", intro + table + _without(missing) + _figures([p for p in pictures if p]))


def _diagnostics_row(name: str, signal: str, d: Diagnostics) -> str:
    """One signal's numbers; a correlation length that reaches the last lag looked at is "at least"."""
    length = ("≥ " if d.correlation_length > d.lags[-1] else "") + _text(d.correlation_length)
    return ("<tr>" + _cell(_text(name)) + _cell(f"<code>{_text(signal)}</code>") + _cell(_text(d.samples), "num")
            + _cell(number(d.acf[1] if len(d.acf) > 1 else None, 4), "num") + _cell(length, "num")
            + _cell(number(d.correlation_length * d.step, 3), "num")
            + _cell(number(white_noise_band(d.samples), 2), "num") + _cell(_text(d.speed_from)) + "</tr>")


def _without(missing: list) -> str:
    """Why a recording has no diagnostics: an older file's envelope, or too few residuals."""
    enveloped = ", ".join(fit.name for fit in missing if not whole(fit))
    short = ", ".join(fit.name for fit in missing if whole(fit))
    note = (f'<p class="muted">No diagnostics for {_text(enveloped)}: the result file holds only the display envelope '
            f"of these recordings, without their diagnostics (written by an older pendfmu); fit again to see "
            f"them.</p>" if enveloped else "")
    return note + (f'<p class="muted">No diagnostics for {_text(short)}: fewer than {MIN_SAMPLES} samples with a '
                   f"residual.</p>" if short else "")
