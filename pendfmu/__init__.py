"""pendfmu: identify an inverted-pendulum rig, or any FMU, from recorded time responses.

The flow is one-way: recording -> experiment -> simulator -> residuals -> optimizer ->
result -> report/export. The component FMUs (CurrentLoop, Cart, Pendulum; and Controller, a
discrete PID controller for systems with a controller in the loop) are built from
C sources in pendfmu/csrc/ by ``pendfmu build``; their variables are defined once, in
:mod:`pendfmu.components`.

The public API (pinned by tests/test_api.py; everything else may change):

fit(model, recordings, ...)
    Fit a stage of the paper ('current', 'cart', 'pendulum') or a user's FMU or SSP system
    to recordings; returns a FitResult (pendfmu.fitting.identification.fit).
fit_all(folder, ...)
    The paper's sequence of stages on a folder of recordings (pendfmu.fitting.sequence).
fit_current(recordings, ...)
    The current stage with its PWM ripple (pendfmu.fitting.ripple).
FitResult, Estimate
    A fit's values, intervals, flags, warnings; write_json, write_report, export.
GlobalOptions
    The global search's settings: population, generations, workers, Dask scheduler.
Model
    Component FMUs and connections: Model.from_fmu(path), Model.from_ssp(path).
Recording, read_recording, write_recording
    Recorded time responses (CSV + sidecar JSON, or MATLAB .mat).
"""

__version__ = "0.1.0"

_API = {
    "fit": "pendfmu.fitting.identification",
    "fit_all": "pendfmu.fitting.sequence",
    "fit_current": "pendfmu.fitting.ripple",
    "FitResult": "pendfmu.fitting.result",
    "Estimate": "pendfmu.fitting.result",
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
