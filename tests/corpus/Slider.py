"""Slider: a mass on a rough surface pushed by a force, with stiction, written for pythonfmu.

    sliding:  m v' = F - c v - F_c sgn(v)
    stuck (v = 0) while |F| <= F_s; it breaks away when |F| > F_s

The force F [N] is the input, with no declared range: below the breakaway force F_s = 20 N
nothing moves. Between a breakaway and a stop the motion has a closed form; each step is
integrated exactly, the stop found inside the step, so the result does not depend on the
communication step beyond rounding. `stuck` is a hidden discrete variable, carried
explicitly in the FMU state.

tests/corpus/build.py builds this file as it is ("ok") and broken variants rewritten from
it: each line marked `# MUTATION <variant>` is replaced there, nothing else changes.
"""

import math

from corpus_helpers import register_parameters
from pythonfmu import DefaultExperiment, Fmi2Causality, Fmi2Initial, Fmi2Slave, Fmi2Variability, Real

DEFAULTS = {"m": 2.0, "c": 4.0, "F_c": 15.0, "F_s": 20.0}
"""Mass [kg], viscous friction [N s/m], Coulomb and breakaway forces [N]."""
ACTIVITY = {"breakaways": 0}
"""How often the mass broke away in this process, for tests/test_check_corpus.py to know
whether a check moved it (an observer, not part of the model)."""


class Slider(Fmi2Slave):
    """The mass as a Co-Simulation slave: parameters in `self.parameters`, stiction in
    `self.stuck`."""

    default_experiment = DefaultExperiment(start_time=0.0, stop_time=2.0, step_size=0.005)

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.parameters = dict(DEFAULTS)
        self.F = 0.0
        self.x = 0.0
        self.v = 0.0
        self.stuck = True
        self.register_variable(Real("F", causality=Fmi2Causality.input, variability=Fmi2Variability.continuous))
        register_parameters(self, DEFAULTS)
        for name in ("x", "v"):
            self.register_variable(Real(name, causality=Fmi2Causality.output, variability=Fmi2Variability.continuous,
                                        initial=Fmi2Initial.exact))

    def _get_fmu_state(self):
        state = super()._get_fmu_state()  # the registered variables only
        state["stuck"] = self.stuck
        return state

    def _slide(self, span, v_end, rate):
        """Moves for `span` seconds towards the speed v_end at `rate` (c/m)."""
        decay = math.exp(-rate * span)
        self.x += v_end * span + (self.v - v_end) * (1 - decay) / rate
        self.v = v_end + (self.v - v_end) * decay

    def _time_to_stop(self, v_end, rate):
        """Time until the speed reaches 0 when it decays towards v_end, inf if it does not."""
        return math.log((self.v - v_end) / -v_end) / rate if self.v * v_end < 0 else math.inf

    def do_step(self, current_time, step_size):
        p = self.parameters
        rate = p["c"] / p["m"]
        left = step_size
        while left > 0.0:
            if self.stuck:
                if abs(self.F) <= p["F_s"]:
                    break
                self.stuck = False
                ACTIVITY["breakaways"] += 1
            direction = math.copysign(1.0, self.v if self.v != 0.0 else self.F)
            v_end = (self.F - direction * p["F_c"]) / p["c"]
            to_stop = self._time_to_stop(v_end, rate)  # MUTATION step
            self._slide(min(to_stop, left), v_end, rate)
            if to_stop > left:
                break
            self.v = 0.0
            self.stuck = abs(self.F) <= p["F_s"]
            left -= to_stop
        return True
