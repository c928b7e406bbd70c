"""pendfmu: identify an inverted-pendulum rig, or any FMU, from recorded time responses.

The flow is one-way: recording -> experiment -> simulator -> residuals -> optimizer ->
result -> report/export. The component FMUs (CurrentLoop, Cart, Pendulum; and Controller, a
discrete PID controller for systems with a controller in the loop) are built from
C sources in pendfmu/csrc/ by ``pendfmu build``; their variables are defined once, in
:mod:`pendfmu.components`.

The public API (pinned by tests/test_api.py; everything else may change):

fit(target, recordings, **options)
    Fit a stage of the paper ('current', 'cart', 'pendulum'), the paper's sequence on a
    folder ('all') or a user's FMU or SSP system to recordings; returns a FitResult
    (pendfmu.fitting.identification). The one front door: `pendfmu fit` calls it too.
compare_laws(stage, recordings, params, **options)
    Fit the candidate friction laws of the cart or the pendulum (viscous, + Coulomb,
    + stiction, + Stribeck, + asymmetry, + offset, + air drag) and rank them by their error on
    held-out data and BIC, with a recommendation; returns a LawComparison with table(),
    to_dict() and recommended (pendfmu.fitting.laws).
FitSpec
    What a fit is asked to do, whole: the keywords of fit as one object
    (pendfmu.fitting.spec).
FitResult, Estimate, read_result
    A fit's values, intervals, flags, warnings and provenance; write_json, and a result
    file read back (pendfmu.fitting.result).
write_report(result, folder)
    The HTML report of a result (pendfmu.report).
export_result(result, folder)
    Parameterized FMUs, SSV, SSP and Modelica and Simulink files of a result (pendfmu.export).
GlobalOptions
    The global search's settings: population, generations, workers, Dask scheduler.
Model
    Component FMUs and connections: Model.from_fmu(path), Model.from_ssp(path).
Recording, read_recording, write_recording
    Recorded time responses (CSV + sidecar JSON, or MATLAB .mat).
"""

#: pendfmu's version, written here once (pyproject.toml reads it); results record it in their
#: provenance, and a built FMU's GUID depends on it.
__version__ = "0.1.0"

_API = {
    "fit": "pendfmu.fitting.identification",
    "compare_laws": "pendfmu.fitting.laws",
    "FitSpec": "pendfmu.fitting.spec",
    "FitResult": "pendfmu.fitting.result",
    "Estimate": "pendfmu.fitting.result",
    "read_result": "pendfmu.fitting.result",
    "write_report": "pendfmu.report",
    "export_result": "pendfmu.export",
    "GlobalOptions": "pendfmu.fitting.optimizer",
    "Model": "pendfmu.simulator.model",
    "Recording": "pendfmu.recording",
    "read_recording": "pendfmu.recording",
    "write_recording": "pendfmu.recording",
}

__all__ = ["__version__", *_API]


def __getattr__(name: str):
    """The API at the top level, imported on first use (keeps `import pendfmu` light for
    the command line and the FMU build)."""
    if name in _API:
        import importlib

        return getattr(importlib.import_module(_API[name]), name)
    raise AttributeError(f"module 'pendfmu' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(__all__)
