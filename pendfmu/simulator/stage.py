"""Simulate one experiment of an identification stage, fast.

A fit evaluates the same experiment thousands of times with different parameter values,
so each stage keeps its FMU instances (reset and re-initialized per run) and steps them
with the native loop (native.py). The stages are one-way chains, so a chain is run link
by link: in the cart stage the current loop does not depend on any cart parameter, so
its output is computed once per current-loop parameter set and fed to the cart with its
slope over each step, exactly as the co-simulation master couples them.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from pendfmu.components import COMPONENTS
from pendfmu.experiment import Experiment
from pendfmu.simulator.component import ComponentFMU, FMUError
from pendfmu.simulator.native import run_single


def _slopes(times: np.ndarray, values: np.ndarray) -> np.ndarray:
    """The slope of each step towards the next sample (the last one is unused)."""
    return np.append(np.diff(values) / np.diff(times), 0.0)


class StageSimulator:
    """Runs one experiment of a stage at its recording's time stamps (every
    `decimate`-th one, for a cheaper first look in a global search)."""

    def __init__(self, experiment: Experiment, decimate: int = 1):
        self.experiment = experiment
        self.index = np.arange(0, len(experiment.time), max(1, int(decimate)))
        self.times = experiment.time[self.index]
        self._fmus: dict[str, ComponentFMU] = {}
        self._current_cache: tuple[tuple, np.ndarray] | None = None

    def _fmu(self, component: str, values: Mapping[str, float]) -> ComponentFMU:
        parameters = {k: v for k, v in values.items() if k in COMPONENTS[component].parameters}
        fmu = self._fmus.get(component)
        if fmu is None:
            fmu = self._fmus[component] = ComponentFMU(component, parameters, start_time=float(self.times[0]))
        else:
            fmu.restart(parameters, start_time=float(self.times[0]))
        return fmu

    def _run(self, component: str, values: Mapping[str, float], inputs: dict[str, np.ndarray],
             outputs: list[str], interpolate: bool) -> np.ndarray:
        fmu = self._fmu(component, values)
        names = list(inputs)
        matrix = np.column_stack([inputs[n] for n in names]) if names else np.empty((len(self.times), 0))
        slopes = np.column_stack([_slopes(self.times, inputs[n]) for n in names]) if names and interpolate else None
        result, failed = run_single(fmu.slave, self.times, [fmu.vr[n] for n in names], matrix,
                                    [fmu.vr[n] for n in outputs], slopes)
        if failed >= 0:
            raise FMUError(f"{component} at t = {self.times[failed]:.9g} s: {'; '.join(fmu.messages[-3:])}")
        return result

    def current(self, values: Mapping[str, float]) -> np.ndarray:
        """The current that drives the cart: the current loop's ripple-free output I_mean,
        driven by the recorded command (held at samples)."""
        key = tuple(sorted((k, v) for k, v in values.items() if k in COMPONENTS["CurrentLoop"].parameters))
        if self._current_cache is None or self._current_cache[0] != key:
            command = self.experiment.recording.signal("I_c")[self.index]
            result = self._run("CurrentLoop", values, {"I_c": command}, ["I_mean"], interpolate=False)[:, 0]
            self._current_cache = (key, result)
        return self._current_cache[1]

    def simulate(self, values: Mapping[str, float], extra: tuple[str, ...] = ()) -> dict[str, np.ndarray]:
        """Simulated fitted signals (plus `extra` outputs of the stage's FMU)."""
        stage = self.experiment.stage.name
        drive = self.experiment.drive
        if stage == "current":
            command = self.experiment.recording.signal("I_c")[self.index]
            outputs = ["I", *extra]
            result = self._run("CurrentLoop", values, {"I_c": command}, outputs, interpolate=False)
        elif stage == "cart":
            current = self.current(values) if drive == "I_c" else self.experiment.recording.signal("I")[self.index]
            outputs = ["x", *extra]
            result = self._run("Cart", values, {"I": current}, outputs, interpolate=True)
        else:
            inputs = {"a": self.experiment.recording.signal("a")[self.index]} if drive == "a" else {}
            outputs = ["phi", *extra]
            result = self._run("Pendulum", values, inputs, outputs, interpolate=True)
        return {name: result[:, j] for j, name in enumerate(outputs)}

    def close(self) -> None:
        for fmu in self._fmus.values():
            fmu.free()
        self._fmus.clear()

    def __getstate__(self):
        """Sent to worker processes without its FMU instances; each worker makes its own."""
        state = dict(self.__dict__)
        state["_fmus"] = {}
        state["_current_cache"] = None
        return state
