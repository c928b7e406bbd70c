"""Residuals: the output error of a stage's simulations against its recordings.

Free parameters live in a unit box: each is mapped from u in [0, 1] to its physical
bounds, logarithmically for positive quantities spanning decades (friction, time
constants), linearly otherwise. The optimizers see well-scaled, simply bounded
coordinates, and a confidence interval mapped back through the log stays positive.

Each residual is divided by its signal's error scale (sensor noise and quantization, see
experiment.signal_scale), so recordings of different sensors weigh by information, and a
fit at the truth has residuals of unit spread. The quantization-aware variant treats a
simulated value that lies inside the recorded reading's quantization interval as exact
(residual 0) and only counts the distance beyond the interval's edge.
"""

from __future__ import annotations

import math
import threading
from concurrent.futures import ThreadPoolExecutor
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from pendfmu.fitting.experiment import Experiment
from pendfmu.fitting.labels import label
from pendfmu.recording.measurement import sensed
from pendfmu.simulator.component import FMUError
from pendfmu.simulator.replay import InstancePool, Replay

# Residual given to every sample of a simulation that failed. It must exceed any residual
# a poor but successful simulation produces (a centimetre against a 2.8 um encoder scale is
# already 3600), or failures would look better than bad fits and attract the optimizer.
PENALTY = 1e12
COSTS = ("plain", "quantized")


@dataclass(frozen=True)
class FreeParameter:
    """A fitted quantity: a rig parameter (experiment None), or an initial state of one
    experiment (e.g. the pendulum's release angle).

    With `relative_to`, the unit-box coordinate maps to a ratio in [low, high] of another
    free parameter: stiction is fitted as a multiple (>= 1) of Coulomb friction, because
    below it stiction has no effect at all (the breakaway threshold is max(F_S, F_K)) and
    a search that strayed there would find no gradient back."""

    name: str
    low: float
    high: float
    log: bool
    experiment: str | None = None
    relative_to: str | None = None

    @property
    def label(self) -> str:
        return label(self.name, self.experiment)

    def value(self, u: float) -> float:
        """The coordinate's own value (a ratio, for a relative parameter)."""
        if self.log:
            return self.low * (self.high / self.low) ** u
        return self.low + (self.high - self.low) * u

    def unit(self, value: float) -> float:
        if self.log:
            return math.log(value / self.low) / math.log(self.high / self.low)
        return (value - self.low) / (self.high - self.low)

    def derivative(self, u: float) -> float:
        """d value / du."""
        return self.value(u) * math.log(self.high / self.low) if self.log else self.high - self.low


def physical(free: Sequence[FreeParameter], u: Sequence[float]) -> np.ndarray:
    """The physical value of every free parameter (relative ones resolved)."""
    own = [p.value(float(x)) for p, x in zip(free, u)]
    index = {p.label: k for k, p in enumerate(free)}
    return np.array([own[k] * own[index[p.relative_to]] if p.relative_to else own[k]
                     for k, p in enumerate(free)])


def physical_jacobian(free: Sequence[FreeParameter], u: Sequence[float]) -> np.ndarray:
    """d physical / d u, to carry the unit-box covariance to the parameters."""
    n = len(free)
    index = {p.label: k for k, p in enumerate(free)}
    G = np.zeros((n, n))
    for k, p in enumerate(free):
        G[k, k] = p.derivative(float(u[k]))
        if p.relative_to:
            j = index[p.relative_to]
            G[k, k] *= free[j].value(float(u[j]))
            G[k, j] = p.value(float(u[k])) * free[j].derivative(float(u[j]))
    return G


def unit_of(free: Sequence[FreeParameter], values: Sequence[float]) -> np.ndarray:
    """The unit-box vector of physical values (inverse of `physical`), clipped to the box."""
    index = {p.label: k for k, p in enumerate(free)}
    u = []
    for p, value in zip(free, values):
        own = value / values[index[p.relative_to]] if p.relative_to else value
        own = min(max(own, p.low), p.high)
        u.append(p.unit(own))
    return np.array(u)


MIN_THREADED_COLUMNS = 3
"""A Jacobian of fewer columns is computed on one thread: the current stage's two columns took
9 ms on one thread and 15 ms on two (the second thread's instances are loaded per fit); the
foreign cart's six 0.11 s and 0.08-0.09 s."""


class Residuals:
    """The residual vector of a fit's experiments as a function of the unit-box vector."""

    def __init__(self, experiments: Sequence[Experiment], free: Sequence[FreeParameter],
                 shared: Mapping[str, float], cost: str = "plain", decimate: int = 1):
        if cost not in COSTS:
            raise ValueError(f"cost must be one of {', '.join(COSTS)}, not {cost!r}")
        self.experiments = list(experiments)
        self.free = list(free)
        self.shared = dict(shared)
        self.cost = cost
        self.decimate = decimate
        pool = InstancePool()  # one for all the experiments: each FMU is loaded once per fit
        self.simulators = [e.replay(decimate, pool) for e in self.experiments]
        self._owner: int | None = None  # the thread that runs self.simulators
        self._threads: dict[int, list[Replay]] = {}  # another thread's own replays (Jacobian columns)
        self._lock = threading.Lock()
        self._executor: ThreadPoolExecutor | None = None
        self.evaluations = 0
        self.failures = 0
        self.last_failure = ""
        self._target_cache: dict[tuple[int, str], tuple] = {}
        self.size = sum(len(self._targets(k, column)[0])
                        for k, e in enumerate(self.experiments) for column in e.match.values())

    def values(self, u: Sequence[float], experiment: Experiment) -> dict[str, float]:
        """All parameter values one experiment runs with."""
        values = {**self.shared, **experiment.fixed}
        for p, value in zip(self.free, physical(self.free, u)):
            if p.experiment is None or p.experiment == experiment.name:
                values[p.name] = float(value)
        return values

    def simulate(self, u: Sequence[float], extra: tuple[str, ...] = ()) -> list[dict[str, np.ndarray]]:
        """Per experiment, its matched outputs as their sensors read them (measurement.py:
        offset and scale) and `extra` outputs as simulated, by output name."""
        results = []
        for replay, experiment in zip(self._here(), self.experiments):
            values = self.values(u, experiment)
            result = replay.simulate(values, [*experiment.match, *extra])
            for output, column in experiment.match.items():
                result[output] = sensed(column, result[output], values)
            results.append(result)
        return results

    def __call__(self, u: Sequence[float]) -> np.ndarray:
        with self._lock:
            self.evaluations += 1
        try:
            simulated = self.simulate(u)
        except FMUError as error:
            with self._lock:
                self.failures += 1
                self.last_failure = error.reason()
            return np.full(self.size, PENALTY)
        parts = []
        for k, (experiment, result) in enumerate(zip(self.experiments, simulated)):
            for output, column in experiment.match.items():
                parts.append(self._scaled(k, column, result[output]))
        residual = np.concatenate(parts)
        if not np.all(np.isfinite(residual)):
            with self._lock:
                self.failures += 1
                self.last_failure = "the simulation returned NaN or Inf"
            return np.full(self.size, PENALTY)
        return residual

    # -- threads

    def _here(self) -> list[Replay]:
        """The replays of the calling thread: the first thread to simulate runs
        self.simulators; any other its own replays, with FMU instances loaded from a copy of
        the binaries of its own (no globals shared between threads, whatever the FMU)."""
        thread = threading.get_ident()
        if self._owner is None:
            self._owner = thread
        if thread == self._owner:
            return self.simulators
        replays = self._threads.get(thread)
        if replays is None:
            with self._lock:
                copy = len(self._threads) + 1
                pool = InstancePool()
                replays = self._threads[thread] = [e.replay(self.decimate, pool, copy) for e in self.experiments]
        return replays

    def jacobian_map(self, threads: int):
        """A map-like for least_squares' finite-difference columns (its `workers`) that
        runs them on `threads` threads, or None for one. The FMUs' C code runs without the
        GIL, so the columns' simulations overlap; each column is the same evaluation as in
        one thread, so the fit is the same to the bit. One thread where an FMU declares
        canBeInstantiatedOnlyOncePerProcess, and for fewer than MIN_THREADED_COLUMNS columns."""
        if threads <= 1 or any(e.model.instantiated_once_per_process() for e in self.experiments[:1]):
            return None
        if self._executor is None:
            self._executor = ThreadPoolExecutor(threads - 1, thread_name_prefix="pendfmu-jacobian")

        def columns(function, points):
            points = list(points)
            if len(points) < MIN_THREADED_COLUMNS:
                return [function(x) for x in points]
            theirs = {k: self._executor.submit(function, x) for k, x in enumerate(points) if k % threads}
            mine = {k: function(x) for k, x in enumerate(points) if k % threads == 0}
            return [mine[k] if k in mine else theirs[k].result() for k in range(len(points))]

        return columns

    def _scaled(self, k: int, column: str, simulated: np.ndarray) -> np.ndarray:
        recorded, scale, resolution, present = self._targets(k, column)
        error = (simulated if present is None else simulated[present]) - recorded
        if self.cost == "quantized" and resolution:
            error = np.sign(error) * np.maximum(np.abs(error) - resolution / 2, 0.0)
        return error / scale

    def _targets(self, k: int, column: str) -> tuple[np.ndarray, float, float | None, np.ndarray | None]:
        """(recorded values at the simulated samples, error scale, resolution, the samples
        that are there: None for all, else their indices) of one experiment's column. A
        missing sample (NaN, where the sidecar says so) has no residual. The same for every
        evaluation, so looked up once."""
        key = (k, column)
        if key not in self._target_cache:
            experiment, index = self.experiments[k], self.simulators[k].index
            recorded = experiment.recorded(column)[index]
            present = None
            if not np.all(np.isfinite(recorded)):
                present = np.flatnonzero(np.isfinite(recorded))
                recorded = recorded[present]
            self._target_cache[key] = (recorded, experiment.scales[column],
                                       experiment.recording.resolution(column), present)
        return self._target_cache[key]

    def series(self) -> list[tuple[int, int]]:
        """Where each recorded signal's residuals lie in the residual vector: [start, stop)
        per experiment and matched column, in the vector's order. Residuals of one series
        may be correlated in time; those of two series are taken as independent."""
        spans, start = [], 0
        for k, experiment in enumerate(self.experiments):
            for column in experiment.match.values():
                stop = start + len(self._targets(k, column)[0])
                spans.append((start, stop))
                start = stop
        return spans

    def sum_of_squares(self, u: Sequence[float]) -> float:
        residual = self(u)
        return float(residual @ residual)

    def close(self) -> None:
        if self._executor is not None:
            self._executor.shutdown(wait=True)
            self._executor = None
        for simulator in [*self.simulators, *(r for replays in self._threads.values() for r in replays)]:
            simulator.close()
        self._threads.clear()

    def __getstate__(self):
        """Sent to worker processes without threads, locks or other threads' replays."""
        state = dict(self.__dict__)
        state.update(_owner=None, _threads={}, _lock=None, _executor=None)
        return state

    def __setstate__(self, state):
        self.__dict__.update(state)
        self._lock = threading.Lock()
