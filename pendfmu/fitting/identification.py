"""Fit a model's parameters to recordings: the one front door, `pendfmu.fit`.

    result = pendfmu.fit("cart", ["run1.csv", "run2.csv"], params=known, seed=1)
    result = pendfmu.fit("all", "recordings/")                  # the paper's sequence
    result = pendfmu.fit("motor.fmu", ["run1.csv"], free=["R", "L"])
    result = pendfmu.fit(FitSpec(...))                          # a specification built elsewhere
    result.write_json("cart.json")

The keywords are the fields of a FitSpec (spec.py), which `pendfmu fit` builds from its
command line the same way, so both fit the same problem. What watches the fit (progress,
checkpoint, warnings, strict) is not part of it.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path

from pendfmu.fitting.checkpoint import Checkpoint
from pendfmu.fitting.result import FitResult
from pendfmu.fitting.sequence import fit_sequence
from pendfmu.fitting.solve import Session, solve
from pendfmu.fitting.spec import FitSpec, check_applicable


def fit(target, recordings: Sequence | str | Path | None = None, params=None, *, progress: bool | None = None,
        checkpoint: Checkpoint | None = None, warn: Callable[[str], None] | None = None, strict: bool = False,
        **options) -> FitResult:
    """Fit a stage of the paper, the paper's sequence, or a user's FMU or SSP system to recordings.

    Parameters
    ----------
    target : str, path, Model or FitSpec
        'current', 'cart' or 'pendulum' (a stage of the paper, with its own drives, matches
        and free parameters), 'all' (the stages in order on one folder of recordings), an
        FMU or SSP file or a Model; or a whole FitSpec (then give nothing else but the
        session's keywords).
    recordings : sequence of paths or Recording, or one folder for 'all'
        Recorded time responses (CSV + sidecar, or .mat), fitted jointly.
    params : mapping or path, optional
        Known values and the start of the fitted ones, or a parameters or result file.
    progress : bool, optional
        A progress bar (default: on a terminal only).
    checkpoint : Checkpoint, optional
        Ctrl-C raises Interrupted with the best values found so far and keeps the costs
        computed, so that a rerun with the checkpoint repeats none of them.
    warn : callable, optional
        Called with each warning about the recordings and the set-up, before the fit starts.
    strict : bool
        Raise SuspiciousData instead of fitting when the recordings look wrong.
    **options
        The other fields of FitSpec: free, fix, bounds, drive, match, initial,
        interpolation, per_recording, windows, segment, start, cost, harmonic, seed,
        global_search, uncertainty, replicates. An option that does not apply to the
        target is refused (OptionError) before any work.

    Returns
    -------
    FitResult
        Values, intervals (each with its method), flags, warnings, fit statistics and the
        provenance, which records the specification as it was fitted.
    """
    if params is not None:
        options["params"] = params
    if isinstance(target, FitSpec):
        if recordings is not None or options:
            raise TypeError("fit(spec) takes the specification whole: give recordings and options to FitSpec")
        spec = target
    else:
        spec = FitSpec(target, recordings, **options)
    check_applicable(spec)
    session = Session(progress, checkpoint, warn, strict)
    return fit_sequence(spec, session) if spec.kind == "sequence" else solve(spec, session)
