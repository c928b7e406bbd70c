"""The report's interactive plots: recorded against simulated signals, with plotly.

A 30 s decay squeezed into a static 800 px image hides everything a person wants to see
in it (the last swings, the quantization steps, where the simulation leaves the record);
a plot that zooms and pans shows them all. plotly draws them in the browser from data
embedded in the page; its JavaScript library is inlined once in the page's head
(`library_script`), so the report needs no network when it is opened.

Long recordings are reduced to their min/max envelope (envelope.py) before they are
embedded: every spike stays, the page stays a few megabytes. Legends sit above the plot
area, never over the data.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from pendfmu.escaping import html_text
from pendfmu.fitting.result import ExperimentFit
from pendfmu.report.content import signal_errors, unit
from pendfmu.fitting.envelope import BUCKETS, envelope_indices

RECORDED = "#7f7f7f"
SIMULATED = "#d62728"
OTHER = "#1f77b4"  # the second result of a comparison
BAND = "rgba(31, 119, 180, 0.15)"
CONFIG = {"responsive": True, "displaylogo": False, "scrollZoom": True,
          "modeBarButtonsToRemove": ["select2d", "lasso2d"]}
TOP_HEIGHT = 300
RESIDUAL_HEIGHT = 170


def library_script() -> str:
    """plotly.js, inlined: the one script every plot of the page uses."""
    from plotly.offline import get_plotlyjs

    return f'<script type="text/javascript">{get_plotlyjs()}</script>'


def recording_plot(fit: ExperimentFit, element_id: str, others: Sequence[tuple[str, ExperimentFit]] = (),
                   label: str = "simulated") -> str:
    """One recording's plot as a <div> and its script: per signal, recorded and simulated
    on top and the residual below (in sensor steps where the sidecar gives the step, with
    the ±half-step band of a perfect fit; else in the signal's unit), all sharing one
    zoomable time axis. `others` adds further simulations of the same recording (a
    comparison: (name, fit) pairs), drawn over it in their own colours."""
    import plotly.graph_objects as go
    from plotly.subplots import make_subplots

    names = list(fit.recorded)
    rows = max(2 * len(names), 1)
    heights = [TOP_HEIGHT if k % 2 == 0 else RESIDUAL_HEIGHT for k in range(rows)]
    figure = make_subplots(rows=rows, cols=1, shared_xaxes=True, vertical_spacing=0.12 / rows,
                           row_heights=heights)
    errors = {e.signal: e for e in signal_errors(fit)}
    # plotly reads a few tags in names and titles (<b>, <br>, <a>): a user's file or signal name is shown as typed
    simulations = [(html_text(label), fit, SIMULATED)] + [(html_text(name), other, colour) for (name, other), colour
                                                          in zip(others, (OTHER, "#2ca02c", "#9467bd"))]
    for k, name in enumerate(names):
        shown = html_text(name)
        step = fit.resolution.get(name)
        time, recorded = np.asarray(fit.time, float), np.asarray(fit.recorded[name], float)
        keep = envelope_indices([recorded, np.asarray(fit.simulated[name], float)])
        figure.add_trace(go.Scatter(x=time[keep], y=recorded[keep], name=f"recorded {shown}",
                                    line=dict(color=RECORDED, width=3, shape="hv" if step else "linear"),
                                    opacity=0.6, legendgroup=name), row=2 * k + 1, col=1)
        for what, simulation, colour in simulations:
            if name not in simulation.simulated or name not in simulation.recorded:
                continue
            # each result at its own samples: a result read from its file holds its own envelope
            time = np.asarray(simulation.time, float)
            recorded = np.asarray(simulation.recorded[name], float)
            simulated = np.asarray(simulation.simulated[name], float)
            residual = (recorded - simulated) / step if step else recorded - simulated
            keep = envelope_indices([recorded, simulated, residual])
            figure.add_trace(go.Scatter(x=time[keep], y=simulated[keep], name=f"{what} {shown}",
                                        line=dict(color=colour, width=1.2), legendgroup=name), row=2 * k + 1, col=1)
            figure.add_trace(go.Scatter(x=time[keep], y=residual[keep], name=f"residual {shown} ({what})",
                                        line=dict(color=colour, width=0.8), legendgroup=name,
                                        showlegend=False), row=2 * k + 2, col=1)
        if step:
            figure.add_hrect(y0=-0.5, y1=0.5, fillcolor=BAND, line_width=0, row=2 * k + 2, col=1)
        figure.update_yaxes(title_text=_label(shown, unit(name)), row=2 * k + 1, col=1)
        figure.update_yaxes(title_text="residual [steps]" if step else _label("residual", unit(name)),
                            row=2 * k + 2, col=1)
        error = errors.get(name)
        if error is not None:
            figure.add_annotation(text=_rms_text(error, name), xref="x domain", yref="y domain", x=0, y=1.0,
                                  xanchor="left", yanchor="bottom", showarrow=False, font=dict(size=11),
                                  row=2 * k + 2, col=1)
    figure.update_xaxes(title_text="time [s]", row=rows, col=1)
    figure.update_layout(height=sum(heights) + 140, margin=dict(l=70, r=20, t=70, b=50), template="plotly_white",
                         legend=dict(orientation="h", x=0, y=1.0, xanchor="left", yanchor="bottom"),
                         hovermode="x unified", uirevision=element_id)
    return figure.to_html(full_html=False, include_plotlyjs=False, div_id=element_id, config=CONFIG)


def _label(name: str, unit_: str) -> str:
    return f"{name} [{unit_}]" if unit_ else name


def _rms_text(error, name: str) -> str:
    parts = [f"RMS error {error.rms:.3g} {unit(name)}".strip()]
    if error.steps is not None:
        parts.append(f"{error.steps:.3g} sensor steps")
    if error.sigmas is not None:
        parts.append(f"{error.sigmas:.3g} noise σ")
    return " = ".join(parts)


def plot_note(fits: Sequence[ExperimentFit]) -> str:
    """What the plots show of long recordings (the envelope), for the page's caption."""
    long = [f.name for f in fits if (f.samples or len(f.time)) > 4 * BUCKETS or len(f.time) < (f.samples or 0)]
    if not long:
        return "Every sample is plotted."
    return (f"Long recordings ({', '.join(long)}) are plotted as their envelope: of each of {BUCKETS} equal "
            f"time buckets, the lowest and highest sample of every curve, so no spike is hidden; zoom in for the "
            f"shape, the RMS errors are computed from every sample.")
