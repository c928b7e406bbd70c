"""Lag: a first-order lag behind a calibrated sensor, written for pythonfmu as a user would.

    tau y' = K c(u) - y,    c(u) = the calibration table TABLE, interpolated

The input u [V] has a declared range [0, 10]; the table covers [0, 8] and holds its last
value above. Each step is integrated exactly (the input is held over a step), so the result
does not depend on the communication step beyond rounding.

tests/corpus/build.py builds this file as it is ("ok") and broken variants rewritten from
it: each line marked `# MUTATION <variant>` is replaced there, nothing else changes.
"""

import math

from corpus_helpers import interpolate, register_parameters
from pythonfmu import DefaultExperiment, Fmi2Causality, Fmi2Initial, Fmi2Slave, Fmi2Variability, Real

DEFAULTS = {"K": 2.0, "tau": 0.5}
TABLE = ((0.0, 0.0), (2.0, 1.9), (4.0, 4.1), (6.0, 5.8), (8.0, 8.3))
"""(input u [V], calibrated drive c [V]): a measured, slightly nonlinear sensor line."""
ACTIVITY = {"moves": 0}
"""How many steps moved the output in this process, for tests/test_check_corpus.py to know
whether a check exercised the lag (an observer, not part of the model)."""


class RangedReal(Real):
    """A Real with min and max in the model description (pythonfmu 0.7's Real has neither)."""

    def __init__(self, name, low, high, **kwargs):
        super().__init__(name, **kwargs)
        self.low, self.high = low, high

    def to_xml(self):
        node = super().to_xml()
        node.find("Real").set("min", repr(self.low))
        node.find("Real").set("max", repr(self.high))
        return node


class Lag(Fmi2Slave):
    """The lag as a Co-Simulation slave: its parameters live in `self.parameters`; the output
    starts at 0 (initial="exact": pythonfmu writes no InitialUnknowns for a calculated one)."""

    default_experiment = DefaultExperiment(start_time=0.0, stop_time=5.0, step_size=0.01)

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.parameters = dict(DEFAULTS)  # MUTATION reset
        self.u = 0.0
        self.y = 0.0
        self.register_variable(RangedReal("u", 0.0, 10.0, causality=Fmi2Causality.input,
                                          variability=Fmi2Variability.continuous))
        register_parameters(self, DEFAULTS)
        self.register_variable(Real("y", causality=Fmi2Causality.output, variability=Fmi2Variability.continuous,
                                    initial=Fmi2Initial.exact))

    def do_step(self, current_time, step_size):
        target = self.parameters["K"] * interpolate(TABLE, self.u)  # MUTATION nan
        decay = math.exp(-step_size / self.parameters["tau"])
        before = self.y
        self.y = target + (self.y - target) * decay  # MUTATION euler
        ACTIVITY["moves"] += abs(self.y - before) > 1e-9
        return True
