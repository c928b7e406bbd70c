"""What the Python models of the corpus share, packed into each of their FMUs beside the
model (a pythonfmu project file): table interpolation and parameter registration."""

from pythonfmu import Fmi2Causality, Fmi2Variability, Real


def interpolate(table, x):
    """The (x, y) rows of `table` (x increasing) interpolated at x; outside, the end values."""
    if x <= table[0][0]:
        return table[0][1]
    for (x0, y0), (x1, y1) in zip(table, table[1:]):
        if x <= x1:
            return y0 + (y1 - y0) * (x - x0) / (x1 - x0)
    return table[-1][1]


def register_parameters(slave, names):
    """Registers each name as a fixed Real parameter kept in the dict `slave.parameters`."""
    for name in names:
        slave.register_variable(Real(name, causality=Fmi2Causality.parameter, variability=Fmi2Variability.fixed,
                                     getter=lambda n=name: slave.parameters[n],
                                     setter=lambda value, n=name: slave.parameters.__setitem__(n, value)))
