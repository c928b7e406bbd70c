"""The fit report: ``write_report(result, "report/")`` writes ``report/index.html`` (and
a PNG per identified friction curve), for a person to judge a fit by eye.

It shows, for each recording fitted or only predicted, an interactive plot of the
recorded against the simulated signals with the residual (zoom, pan: interactive.py);
the identified friction laws as the paper's Fig. 1 draws them; the estimates with their
uncertainty and the reasons they are flagged; the correlations; what the cost means;
the values each recording ran with; and where the result came from (provenance).
``content`` computes what is shown, ``figures`` draws the PNGs, ``interactive`` the
plots, ``html`` writes the page, ``compare`` the page comparing two results.

A report folder may be reused: the files the previous report wrote there (listed in its
manifest, manifest.py) are removed first, the user's own files are left alone.
"""

from __future__ import annotations

from pathlib import Path

from pendfmu.fitting.result import FitResult

__all__ = ["write_report", "write_comparison"]


def write_report(result: FitResult, directory: str | Path) -> Path:
    """Write the report of `result` into `directory` (created if needed); returns the
    path of its index.html. Figures are written first, so the page never refers to a
    PNG that is not there."""
    from pendfmu.report.figures import write_friction_figures
    from pendfmu.report.html import page

    directory = _fresh(directory)
    friction = write_friction_figures(result, directory)
    return _finish(directory, page(result, friction), [directory / p.file for p in friction])


def write_comparison(first: FitResult, second: FitResult, directory: str | Path,
                     names: tuple[str, str] = ("A", "B"), sources: tuple[str, str] | None = None) -> Path:
    """Write a report comparing two results into `directory` (`names` label them, `sources`
    are their files, if any); returns its index.html."""
    from pendfmu.report.compare import comparison_page

    directory = _fresh(directory)
    return _finish(directory, comparison_page(first, second, names, sources), [])


def _fresh(directory: str | Path) -> Path:
    from pendfmu.report.manifest import remove_previous

    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    remove_previous(directory)
    return directory


def _finish(directory: Path, text: str, files: list[Path]) -> Path:
    from pendfmu.report.manifest import write_manifest

    index = directory / "index.html"
    index.write_text(text, encoding="utf-8")
    write_manifest(directory, [*files, index])
    return index
