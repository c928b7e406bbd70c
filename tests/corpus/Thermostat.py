"""Thermostat: a room heated by a heat pump under a hysteresis relay, written for pythonfmu.

    C T' = (T_out - T) / R + on * P_el * COP(T_out)
    on switches off when T reaches T_set + band/2 and on when T falls to T_set - band/2

The outdoor temperature T_out [degC] is the input, with no declared range; COP(T_out) is
interpolated in a manufacturer's table and held at its end values outside it. The relay
state `on` is a hidden discrete variable (the output is T only), so the FMU state carries
it explicitly. Between switches T relaxes exponentially; each step is integrated exactly
and the switching instants are found inside the step in closed form, so the result does
not depend on the communication step beyond rounding.

tests/corpus/build.py builds this file as it is ("ok") and broken variants rewritten from
it: each line marked `# MUTATION <variant>` is replaced there, nothing else changes.
"""

import math

from corpus_helpers import interpolate, register_parameters
from pythonfmu import DefaultExperiment, Fmi2Causality, Fmi2Initial, Fmi2Slave, Fmi2Variability, Real

DEFAULTS = {"T_set": 20.0, "band": 1.0, "P_el": 2.0, "R": 5.0, "C": 1440.0}
"""Setpoint and hysteresis band [degC], electrical power [kW], loss resistance [K/kW],
heat capacity [kJ/K]: a time constant R C of 2 h."""
COP = ((-20.0, 2.0), (-10.0, 2.5), (0.0, 3.0), (10.0, 3.8), (20.0, 4.6), (35.0, 5.5))
"""(outdoor temperature [degC], coefficient of performance): the heat pump's data sheet."""
T_START = 18.0
ACTIVITY = {"switches": 0}
"""How often the relay switched in this process, for tests/test_check_corpus.py to know
whether a check exercised it (an observer, not part of the model)."""


class Thermostat(Fmi2Slave):
    """The heated room as a Co-Simulation slave: parameters in `self.parameters`, the relay in
    `self.on`."""

    default_experiment = DefaultExperiment(start_time=0.0, stop_time=14400.0, step_size=60.0)

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.parameters = dict(DEFAULTS)  # MUTATION reset
        self.T_out = 5.0
        self.T = T_START
        self.on = True
        self.register_variable(Real("T_out", causality=Fmi2Causality.input, variability=Fmi2Variability.continuous))
        register_parameters(self, DEFAULTS)
        self.register_variable(Real("T", causality=Fmi2Causality.output, variability=Fmi2Variability.continuous,
                                    initial=Fmi2Initial.exact))

    def exit_initialization_mode(self):
        self.on = self.T < self.parameters["T_set"]

    def _get_fmu_state(self):
        state = super()._get_fmu_state()  # the registered variables only
        state["on"] = self.on  # MUTATION state
        return state

    def _equilibrium(self):
        cop = interpolate(COP, self.T_out)  # MUTATION nan
        heat = self.parameters["P_el"] * cop if self.on else 0.0
        return self.T_out + self.parameters["R"] * heat

    def _time_to_switch(self, t_eq, tau):
        """Time until T reaches the relay's next threshold, inf if it never does."""
        half = self.parameters["band"] / 2
        if self.on:
            high = self.parameters["T_set"] + half
            return tau * math.log((t_eq - self.T) / (t_eq - high)) if t_eq > high else math.inf
        low = self.parameters["T_set"] - half
        return tau * math.log((self.T - t_eq) / (low - t_eq)) if t_eq < low else math.inf

    def do_step(self, current_time, step_size):
        tau = self.parameters["R"] * self.parameters["C"]
        left = step_size
        while left > 0.0:
            t_eq = self._equilibrium()
            to_switch = max(0.0, self._time_to_switch(t_eq, tau))  # MUTATION step
            span = min(to_switch, left)
            self.T = t_eq + (self.T - t_eq) * math.exp(-span / tau)
            if to_switch > left:
                break
            self.on = not self.on
            ACTIVITY["switches"] += 1
            left -= span
        return True
