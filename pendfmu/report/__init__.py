"""The fit report: ``write_report(result, "report/")`` writes ``report/index.html`` and
the PNG figures it shows, for a person to judge a fit by eye.

It shows, for each recording, the recorded signal against the simulated one with the
residual in sensor steps; the identified friction laws as the paper's Fig. 1 draws them;
the estimates with their uncertainty and the reasons they are flagged; the correlations;
and the values the fit took as known. ``content`` computes what is shown, ``figures``
draws the PNGs, ``html`` writes the page.
"""

from __future__ import annotations

from pathlib import Path

from pendfmu.report.figures import write_figures
from pendfmu.report.html import page
from pendfmu.fitting.result import FitResult

__all__ = ["write_report"]


def write_report(result: FitResult, directory: str | Path) -> Path:
    """Write the report of `result` into `directory` (created if needed); returns the
    path of its index.html. Figures are written first, so the page never refers to a
    PNG that is not there."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    experiments, friction = write_figures(result, directory)
    index = directory / "index.html"
    index.write_text(page(result, experiments, friction), encoding="utf-8")
    return index
