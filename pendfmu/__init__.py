"""pendfmu: identify an inverted-pendulum rig with FMI component FMUs.

The flow is one-way: recording -> experiment -> simulator -> residuals -> optimizer ->
result -> report/export. The component FMUs (CurrentLoop, Cart, Pendulum) are built from
C sources in fmus/ by ``pendfmu build``; their variables are defined once, in
:mod:`pendfmu.components`.
"""

__version__ = "0.1.0"
