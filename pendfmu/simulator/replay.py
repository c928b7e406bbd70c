"""Replay a recording's drives through a model, fast: what every fit evaluation runs.

A fit simulates the same recording thousands of times with different parameter values,
so a Replay keeps its FMU instances (reset per run, or instantiated anew where an FMU
cannot reset) and steps each with the native loop (native.py). The model's instances run
one after the other in stepping order, each over the whole recording: an instance's
inputs are either recorded drives or the outputs of instances before it, passed with
their slope over each step where the receiving FMU can interpolate inputs (linear, as the
co-simulation master couples them) and held otherwise. An instance whose parameters, and
whose predecessors' parameters, did not change since the last run is not run again (in
the cart stage the current loop runs once per current-loop parameter set).

What an FMU declares is honoured: input derivatives only where canInterpolateInputs,
an uneven time grid only where canHandleVariableCommunicationStepSize. A model whose
components feed each other (an algebraic loop, or a group coupled through states) is run
by the co-simulation master instead (master.py), which iterates the group per step.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from pendfmu.recording.measurement import INPUT_DELAY
from pendfmu.simulator.component import PROCESS_POOL, ComponentFMU, InstancePool, discrete_outputs, pooled_instance
from pendfmu.simulator.model import Model, ModelError, Port
from pendfmu.simulator.native import run_single

INTERPOLATIONS = ("hold", "linear")


@dataclass(frozen=True)
class Drive:
    """A model input driven by a recorded signal, held or linear between samples."""

    values: np.ndarray
    interpolation: str = "hold"


# (times, drives, parameter values) -> (communication points, index of each sample among them)
Refinement = Callable[[np.ndarray, Mapping[str, np.ndarray], Mapping[str, float]], tuple[np.ndarray, np.ndarray]]


def _slopes(times: np.ndarray, values: np.ndarray) -> np.ndarray:
    """The slope of each step towards the next point (the last one is unused)."""
    return np.append(np.diff(values) / np.diff(times), 0.0)


class Replay:
    """Runs `model` at a recording's time stamps (every `decimate`-th one, for a cheaper
    first look in a global search), its inputs driven by `drives` (input name -> Drive).
    `refine`, where given, adds communication points between samples (the cart stage
    steps the settling current on a finer grid). `pool` shares FMU instances with other
    replays run from the same thread; `copy` > 0 loads the FMUs from a copy of their
    binaries of their own (for a replay run in another thread, see unpacked_fmu)."""

    def __init__(self, model: Model, time: np.ndarray, drives: Mapping[str, Drive], decimate: int = 1,
                 refine: Refinement | None = None, pool: InstancePool | None = None, copy: int = 0):
        self.coupled = any(len(group) > 1 for group in model.order)
        if self.coupled and refine is not None:
            raise ModelError(f"{model.name}: a refined grid is for models without coupled components")
        self._master = None
        self.model = model
        self.index = np.arange(0, len(time), max(1, int(decimate)))
        self.times = np.asarray(time, dtype=float)[self.index]
        # A name stands for every port it feeds: an SSP system input may feed several components.
        self.drives = {port: Drive(np.asarray(d.values, dtype=float)[self.index], d.interpolation)
                       for name, d in drives.items() for port in model.resolve(name, "input")}
        for port, drive in self.drives.items():
            if drive.interpolation not in INTERPOLATIONS:
                raise ModelError(f"{port}: interpolation must be hold or linear, not {drive.interpolation!r}")
        self.refine = refine
        self._fmus = InstancePool() if pool is None else pool
        if model.instantiated_once_per_process():
            self._fmus, copy = PROCESS_POOL, 0
        self.copy = copy
        self._kept: dict[str, tuple[bytes, dict[Port, np.ndarray]]] = {}
        self._layouts: dict[tuple[str, ...], tuple] = {}
        self._drive_columns: dict[str, tuple] = {}
        self._times_key = _grid_key(self.times)
        # connections from discrete outputs, held over a step (master.py); looked up once, not
        # per run: finding a component's FMU checks its build (0.2 ms a connection)
        self._held = {(c.source, c.output) for c in model.connections
                      if c.output in discrete_outputs(*_fmu_of(model.instances[c.source]))}

    # -- instances

    def _fmu(self, name: str, parameters: Mapping[str, float]) -> ComponentFMU:
        instance = self.model.instances[name]
        key = (name, str(instance.fmu) if instance.fmu is not None else instance.kind)
        start = float(self.times[0])
        label = instance.kind if instance.fmu is None else name
        return pooled_instance(key, self._fmus, lambda: ComponentFMU(label, parameters, start_time=start,
                                                                      fmu=instance.fmu, instance=name, copy=self.copy),
                               parameters, start)

    # -- running

    def simulate(self, values: Mapping[str, float], outputs: Sequence[str]) -> dict[str, np.ndarray]:
        """The named outputs at the recording's (decimated) time stamps for these values."""
        if self.coupled:
            return self._coupled(values, {name: self.model.port(name, "output") for name in outputs})
        wanted, runs = self._layout(tuple(outputs))
        delay = float(values.get(INPUT_DELAY, 0.0))
        points, samples = self._grid(values, delay)
        grid_key = self._times_key if points is self.times else _grid_key(points, delay)
        per = self.model.split(values)
        signals: dict[Port, np.ndarray] = {}
        upstream: dict[str, bytes] = {}
        for name, needed, sources in runs:
            key = _key(per[name], [upstream[s] for s in sources], grid_key)
            upstream[name] = key
            kept = self._kept.get(name)
            if kept is not None and kept[0] == key and all(p in kept[1] for p in needed):
                signals.update(kept[1])
                continue
            result = self._run(name, per[name], points, samples, signals, needed, delay)
            self._kept[name] = (key, result)
            signals.update(result)
        return {name: signals[port][samples] for name, port in wanted.items()}

    def _layout(self, outputs: tuple[str, ...]):
        """(output name -> port, [(instance, ports it must record, instances feeding it)] in
        stepping order) for these outputs: the same for every run, so worked out once."""
        layout = self._layouts.get(outputs)
        if layout is None:
            wanted = {name: self.model.port(name, "output") for name in outputs}
            runs = []
            for (name,) in self.model.order:
                feeding = {Port(c.source, c.output) for c in self.model.connections if c.source == name}
                needed = sorted({p for p in wanted.values() if p.instance == name} | feeding, key=str)
                runs.append((name, needed, [c.source for c in self.model.connections if c.target == name]))
            layout = self._layouts[outputs] = (wanted, runs)
        return layout

    def _grid(self, values: Mapping[str, float], delay: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """The communication points and the index of each sample among them: the samples;
        with an input delay also the instants the delayed samples arrive (so that a held
        drive changes exactly then, and the fit's cost is smooth in the delay)."""
        if delay:
            if self.refine is not None:
                raise ModelError(f"{self.model.name}: an input delay needs the drive on the recording's own grid; "
                                 f"this model refines it (drive the cart by I or u instead of I_c)")
            return _delayed_grid(self.times, delay)
        if self.refine is None:
            return self.times, np.arange(len(self.times))
        drives = {str(port): drive.values for port, drive in self.drives.items()}
        return self.refine(self.times, drives, values)

    def _run(self, name: str, parameters: Mapping[str, float], points: np.ndarray, samples: np.ndarray,
             signals: Mapping[Port, np.ndarray], outputs: list[Port], delay: float = 0.0) -> dict[Port, np.ndarray]:
        fmu = self._fmu(name, parameters)
        names, columns, slopes = self._driven(name, fmu, points, samples, delay)
        names, columns, slopes = list(names), list(columns), list(slopes)
        for c in self.model.connections:
            if c.target == name:
                names.append(c.input)
                column = signals[Port(c.source, c.output)]
                columns.append(column)
                held = (c.source, c.output) in self._held
                slopes.append(_slopes(points, column) if fmu.can_interpolate_inputs and not held else None)
        matrix = np.column_stack(columns) if columns else np.empty((len(points), 0))
        interpolate = any(s is not None and np.any(s) for s in slopes)
        slope_matrix = (np.column_stack([np.zeros(len(points)) if s is None else s for s in slopes])
                        if interpolate else None)
        logged = len(fmu.messages)
        result, failed = run_single(fmu.unit, points, [fmu.vr[n] for n in names], matrix,
                                    [fmu.vr[p.variable] for p in outputs], slope_matrix)
        if failed >= 0:
            raise fmu.slave.failure("an FMI call of the native loop failed", since=logged, time=points[failed])
        return {port: result[:, j] for j, port in enumerate(outputs)}

    def _driven(self, name: str, fmu: ComponentFMU, points: np.ndarray, samples: np.ndarray, delay: float = 0.0):
        """(input names, columns on the grid, slopes or None where held) of the instance's
        recorded drives, `delay` seconds late; on the recording's own grid the same for
        every run, so kept."""
        if points is self.times and name in self._drive_columns:
            return self._drive_columns[name]
        steps = np.diff(points)
        if not fmu.can_vary_step and len(steps) and np.ptp(steps) > 1e-9 * float(np.mean(steps)):
            raise ModelError(f"{name}: the FMU cannot vary its communication step "
                             f"(canHandleVariableCommunicationStepSize is false), and the recording's time stamps "
                             f"are not evenly spaced")
        names, columns, slopes = [], [], []
        for port, drive in self.drives.items():
            if port.instance == name:
                names.append(port.variable)
                column = _delayed(drive, self.times, points, delay) if delay else _on_grid(drive, self.times,
                                                                                           points, samples)
                columns.append(column)
                linear = drive.interpolation == "linear"
                if linear and not fmu.can_interpolate_inputs:
                    raise ModelError(f"{port}: linear interpolation asked for, but the FMU cannot interpolate "
                                     f"inputs (canInterpolateInputs is false): its inputs are held")
                slopes.append(_slopes(points, column) if linear else None)
        driven = (tuple(names), tuple(columns), tuple(slopes))
        if points is self.times:
            self._drive_columns[name] = driven
        return driven

    def _coupled(self, values: Mapping[str, float], wanted: Mapping[str, Port]) -> dict[str, np.ndarray]:
        """A model whose components feed each other runs in the co-simulation master
        (master.py: Gauss-Seidel with slopes, algebraic loops torn and solved per step with
        FMU-state rollback), one communication step per sample, native engine."""
        from pendfmu.simulator.master import ExternalInput, Master

        if values.get(INPUT_DELAY):
            raise ModelError(f"{self.model.name}: an input delay is not available for a model whose components "
                             f"feed each other (it is run by the co-simulation master on the samples' grid)")
        per = self.model.split(values)
        if self._master is None:
            step = float(np.max(np.diff(self.times))) if len(self.times) > 1 else 1.0
            self._master = Master({n: i.kind for n, i in self.model.instances.items()}, self.model.connections, per,
                                  step=step, fmus={n: i.fmu for n, i in self.model.instances.items() if i.fmu})
        self._master.parameters = {name: dict(per[name]) for name in self.model.instances}
        external = {str(port): ExternalInput(self.times, drive.values, drive.interpolation)
                    for port, drive in self.drives.items()}
        frame = self._master.run(self.times, [str(port) for port in wanted.values()], external)
        return {name: frame[str(port)].to_numpy() for name, port in wanted.items()}

    def close(self) -> None:
        if self._fmus is not PROCESS_POOL:  # those stay for the process's next replay
            for fmu in self._fmus.values():
                fmu.free()
            self._fmus.clear()
        self._kept.clear()
        if self._master is not None:
            self._master.close()
            self._master = None

    def __getstate__(self):
        """Sent to worker processes without its FMU instances; each worker makes its own."""
        state = dict(self.__dict__)
        state["_kept"] = {}
        state["_master"] = None
        return state

    def __setstate__(self, state):
        self.__dict__.update(state)
        if self.model.instantiated_once_per_process():
            self._fmus = PROCESS_POOL  # the worker's own one instance


def _on_grid(drive: Drive, times: np.ndarray, points: np.ndarray, samples: np.ndarray) -> np.ndarray:
    """A drive's values at the communication points: the sample's own at samples; between
    them held (the last sample's) or linear."""
    if len(points) == len(times):
        return drive.values
    if drive.interpolation == "linear":
        return np.interp(points, times, drive.values)
    return drive.values[np.searchsorted(samples, np.arange(len(points)), side="right") - 1]


def _fmu_of(instance) -> tuple[str, object]:
    """(name, FMU file or None) as discrete_outputs takes them: a pendfmu component by its
    kind, an FMU from a file by the instance's name and the file."""
    return (instance.kind, None) if instance.fmu is None else (instance.name, instance.fmu)


def _delayed_grid(times: np.ndarray, delay: float) -> tuple[np.ndarray, np.ndarray]:
    """The samples and the instants t_k + delay inside the recording, merged (an arrival
    within a billionth of a step of a sample is that sample), with each sample's index."""
    tolerance = 1e-9 * (float(times[-1] - times[0]) / max(len(times) - 1, 1))
    arrivals = times + delay
    arrivals = arrivals[arrivals < times[-1]]
    near = np.searchsorted(times, arrivals)
    distinct = np.ones(len(arrivals), bool)
    for side in (near - 1, near):
        inside = (side >= 0) & (side < len(times))
        distinct[inside] &= np.abs(times[side[inside]] - arrivals[inside]) > tolerance
    points = np.union1d(times, arrivals[distinct])
    return points, np.searchsorted(points, times)


def _delayed(drive: Drive, times: np.ndarray, points: np.ndarray, delay: float) -> np.ndarray:
    """A drive `delay` seconds late at the communication points: held, the last sample that
    has arrived (before the first arrives, the first); linear, interpolated at t - delay."""
    if drive.interpolation == "linear":
        return np.interp(points - delay, times, drive.values)
    tolerance = 1e-9 * (float(times[-1] - times[0]) / max(len(times) - 1, 1))
    arrived = np.searchsorted(times + delay, points + tolerance, side="right") - 1
    return drive.values[np.maximum(arrived, 0)]


def _grid_key(points: np.ndarray, delay: float = 0.0) -> bytes:
    """A digest of a time grid and the drives' delay (the recording's own grid is hashed
    once per Replay)."""
    digest = hashlib.sha256(np.ascontiguousarray(points).tobytes())
    digest.update(repr(delay).encode())
    return digest.digest()


def _key(parameters: Mapping[str, float], upstream: Sequence[bytes], grid: bytes) -> bytes:
    """What an instance's outputs depend on: its parameters, its predecessors' keys, the grid."""
    digest = hashlib.sha256(repr(sorted(parameters.items())).encode())
    for key in upstream:
        digest.update(key)
    digest.update(grid)
    return digest.digest()
