"""The fit report: ``write_report(result, "report/")`` writes ``report/index.html`` (and
its PNG figures), for a person to judge a fit by eye.

It shows the fit's verdict (adequate, model-inadequate, fit-failed) with its evidence;
for each recording fitted or only predicted, an interactive plot of the recorded against
the simulated signals with the residual (zoom, pan: interactive.py), and the residuals'
diagnostics (autocorrelation, against amplitude and speed); the identified friction laws
as the paper's Fig. 1 draws them; the estimates with their uncertainty and the reasons
they are flagged; the correlations, and the joint region of a pair determined only as a
combination; the validation of early against late halves; what the cost means; the
values each recording ran with; and where the result came from (provenance).
``content`` computes what is shown, ``figures`` draws the PNGs, ``interactive`` the
plots, ``html`` writes the page (``assessment`` its verdict, validation and diagnostics,
``markup`` the escaped pieces), ``compare`` the page comparing two results, ``laws`` the
page of a friction-law comparison.

A report folder may be reused: the files the previous report wrote there (listed in its
manifest, manifest.py) are removed first, the user's own files are left alone.
"""

from __future__ import annotations

from pathlib import Path

from pendfmu.fitting.result import FitResult

__all__ = ["write_report", "write_comparison", "write_laws_report"]


def write_report(result: FitResult, directory: str | Path) -> Path:
    """Write the HTML report of a fit into a folder.

    Everything is drawn first, into a temporary folder: a report that fails to render
    leaves the folder's earlier report as it was. The earlier report's files are then
    replaced; the user's own files in the folder are left alone.

    Parameters
    ----------
    result : FitResult
        The fit to report (from :func:`pendfmu.fit` or :func:`pendfmu.read_result`).
    directory : str or Path
        The report's folder, created if needed; it may hold an earlier report.

    Returns
    -------
    Path
        The report's ``index.html`` in `directory`.

    Raises
    ------
    UsageError
        `directory` is a file, or holds an ``index.html`` (or a figure's name) that no
        pendfmu report wrote: nothing is changed.
    """
    import tempfile

    from pendfmu.report.figures import write_diagnostics_figures, write_friction_figures, write_joint_figures
    from pendfmu.report.html import page

    directory = Path(directory)
    with tempfile.TemporaryDirectory(prefix="pendfmu-report-") as drawn:
        friction = write_friction_figures(result, Path(drawn))
        diagnostics = write_diagnostics_figures(result, Path(drawn))
        joints = write_joint_figures(result, Path(drawn))
        text = page(result, friction, diagnostics, joints)
        figures = {p.file: Path(drawn) / p.file for p in [*friction, *diagnostics, *joints] if p}
        return _replace(directory, text, figures)


def write_comparison(first: FitResult, second: FitResult, directory: str | Path,
                     names: tuple[str, str] = ("A", "B"), sources: tuple[str, str] | None = None) -> Path:
    """Write a page comparing two fits of the same system side by side.

    Parameters
    ----------
    first, second : FitResult
        The two fits compared.
    directory : str or Path
        The page's folder, created if needed (an earlier report there is replaced, as
        :func:`write_report` does).
    names : tuple of (str, str), optional
        The labels of the two fits in the page's tables.
    sources : tuple of (str, str), optional
        The files the fits were read from, shown with them; None when they were not read
        from files.

    Returns
    -------
    Path
        The page's ``index.html`` in `directory`.

    Raises
    ------
    UsageError
        `directory` is a file, or holds an ``index.html`` no pendfmu report wrote.
    """
    from pendfmu.report.compare import comparison_page

    return _replace(Path(directory), comparison_page(first, second, names, sources), {})


def write_laws_report(comparison, directory: str | Path) -> Path:
    """Write the page of a friction-law comparison: the candidate laws ranked, with the
    recommended one.

    Parameters
    ----------
    comparison : LawComparison
        What :func:`pendfmu.compare_laws` returns (pendfmu.fitting.laws).
    directory : str or Path
        The page's folder, as for :func:`write_comparison`.

    Returns
    -------
    Path
        The page's ``index.html`` in `directory`.
    """
    from pendfmu.report.laws import laws_page

    return _replace(Path(directory), laws_page(comparison), {})


def _replace(directory: Path, text: str, figures: dict[str, Path]) -> Path:
    """Put a rendered report (page text, figure name -> drawn file) into `directory`: the
    earlier report's files go (manifest.py), the user's stay. A file of the new report's
    name that pendfmu did not write (someone's own index.html) stops it: BadInput, nothing
    changed. The page and its figures are written together or not at all (atomic.py), and
    two reports into one folder take turns (manifest.folder_lock): the last one is the
    folder's."""
    from pendfmu.atomic import write_together
    from pendfmu.errors import UsageError
    from pendfmu.report.manifest import folder_lock, remove_previous, write_manifest

    if directory.exists() and not directory.is_dir():
        raise UsageError(f"{directory}: is a file, not a report folder")
    directory.mkdir(parents=True, exist_ok=True)
    index = directory / "index.html"
    with folder_lock(directory):
        earlier = _earlier_report(directory, ["index.html", *figures])
        files = write_together({**{directory / name: drawn.read_bytes() for name, drawn in figures.items()},
                                index: text})  # all or none: a full disk leaves the earlier report whole
        remove_previous(earlier, keep=files)
        write_manifest(directory, files)
    return index


def _earlier_report(directory: Path, names: list[str]) -> set[Path]:
    """The files of the report written earlier into `directory` (manifest.py); stop
    (UsageError) where a file the new report would write is there and is not pendfmu's."""
    from pendfmu.errors import UsageError
    from pendfmu.report.manifest import earlier_report_files, is_pendfmu_page

    ours = set(earlier_report_files(directory))
    if is_pendfmu_page(directory / "index.html"):
        ours.add(directory / "index.html")
    for name in names:
        if (directory / name).exists() and directory / name not in ours:
            raise UsageError(f"{directory / name}: exists and was not written by a pendfmu report; give another "
                             f"folder or remove it")
    return ours
