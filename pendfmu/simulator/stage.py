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
from pendfmu.fitting.experiment import Experiment
from pendfmu.simulator.component import ComponentFMU, FMUError
from pendfmu.simulator.native import run_single


def _slopes(times: np.ndarray, values: np.ndarray) -> np.ndarray:
    """The slope of each step towards the next sample (the last one is unused)."""
    return np.append(np.diff(values) / np.diff(times), 0.0)


# The current after a jump of the command relaxes with time constant T_i (0.3 ms), which is
# not much longer than a 0.2 ms sample: passed to the cart linearly interpolated between
# samples, its impulse was off by enough to move the cart's estimates by many of their
# standard errors (the cart's position against an exact event-driven simulator: up to
# 0.9 encoder steps after a step, 0.5 on a staircase ramp, whose small steps all err the
# same way). Every step in which the current has not settled is stepped on a finer grid.
SUBSTEPS = 8  # communication steps per sample inside a transient: the chord error falls 64-fold
SETTLE = 8.0  # a transient lasts the slew |jump| / dIdt_max plus SETTLE time constants (e^-8)


def transient_grid(times: np.ndarray, command: np.ndarray, T_i: float, dIdt_max: float
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Communication points for a chain driven by a held command: the samples, with
    SUBSTEPS points per sample while the current settles after a jump. Returns the
    points and the index of each sample among them."""
    jumps = np.abs(np.diff(command))
    refine = np.zeros(len(times), bool)  # refine[k]: the step from sample k to k+1
    changes = np.flatnonzero(jumps > 0) + 1
    if len(changes):
        ends = times[changes] + jumps[changes - 1] / dIdt_max + SETTLE * T_i
        last = np.searchsorted(times, ends, side="right")
        # sample k is refined when a change at or before it has not settled by k
        marks = np.zeros(len(times) + 1, int)
        np.add.at(marks, changes, 1)
        np.add.at(marks, last, -1)
        refine = np.cumsum(marks[:-1]) > 0
    refine[-1] = False
    if not refine.any():
        return times, np.arange(len(times))
    counts = np.where(refine, SUBSTEPS, 1)
    starts = np.repeat(times, counts)
    within = np.arange(len(starts)) - np.repeat(np.cumsum(counts) - counts, counts)
    widths = np.repeat(np.append(np.diff(times), 0.0) / counts, counts)
    points = starts + within * widths
    return points, np.cumsum(counts) - counts


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
             outputs: list[str], interpolate: bool, times: np.ndarray | None = None) -> np.ndarray:
        times = self.times if times is None else times
        fmu = self._fmu(component, values)
        names = list(inputs)
        matrix = np.column_stack([inputs[n] for n in names]) if names else np.empty((len(times), 0))
        slopes = np.column_stack([_slopes(times, inputs[n]) for n in names]) if names and interpolate else None
        result, failed = run_single(fmu.slave, times, [fmu.vr[n] for n in names], matrix,
                                    [fmu.vr[n] for n in outputs], slopes)
        if failed >= 0:
            raise FMUError(f"{component} at t = {times[failed]:.9g} s: {'; '.join(fmu.messages[-3:])}",
                           instance=component, time=float(times[failed]), messages=fmu.messages[-3:])
        return result

    def current(self, values: Mapping[str, float]) -> tuple[np.ndarray, np.ndarray]:
        """The current that drives the cart, the current loop's ripple-free output I_mean
        driven by the recorded command (held at samples), on the transient grid; and the
        index of the samples in that grid."""
        key = tuple(sorted((k, v) for k, v in values.items() if k in COMPONENTS["CurrentLoop"].parameters))
        if self._current_cache is None or self._current_cache[0] != key:
            command = self.experiment.recording.signal("I_c")[self.index]
            points, samples = transient_grid(self.times, command, values["T_i"], values["dIdt_max"])
            held = command[np.searchsorted(samples, np.arange(len(points)), side="right") - 1]
            result = self._run("CurrentLoop", values, {"I_c": held}, ["I_mean"], interpolate=False, times=points)
            self._current_cache = (key, (result[:, 0], points, samples))
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
            outputs = ["x", *extra]
            if drive == "I_c":
                current, points, samples = self.current(values)
                result = self._run("Cart", values, {"I": current}, outputs, interpolate=True, times=points)[samples]
            else:
                current = self.experiment.recording.signal("I")[self.index]
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
