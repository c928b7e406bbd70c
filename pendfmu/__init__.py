"""pendfmu: identify an inverted-pendulum rig with FMI component FMUs.

The flow is one-way: recording -> experiment -> simulator -> residuals -> optimizer ->
result -> report/export. The component FMUs (CurrentLoop, Cart, Pendulum) are built from
C sources in fmus/ by ``pendfmu build``; their variables are defined once, in
:mod:`pendfmu.components`.
"""

__version__ = "0.1.0"


def __getattr__(name: str):
    """The fitting API at the top level, imported on first use (keeps `import pendfmu`
    light for the command line and the FMU build)."""
    if name in ("fit", "fit_all", "fit_current"):
        from pendfmu.fitting import identification

        return getattr(identification, name)
    if name == "FitResult":
        from pendfmu.fitting.result import FitResult

        return FitResult
    raise AttributeError(f"module 'pendfmu' has no attribute {name!r}")
