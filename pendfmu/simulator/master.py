"""The co-simulation master on fmpy: connected component FMUs stepped at a fixed
communication step, with external inputs from a recording.

Coupling. A component steps after the components it takes inputs from (Gauss-Seidel,
see graph.py), so over [t, t+h] it knows each connected input at both ends: it gets the
value at t and the slope to t+h through fmi2SetRealInputDerivatives, i.e. linear
interpolation, second-order accurate, instead of a value held (and so delayed by h/2).

Coupled groups (components that feed each other, e.g. cart and pendulum with a
back-drivable screw) are stepped together and solved (coupled.py): the loop is torn at one
signal (graph.tear_of; the cart's acceleration for the rig), its end value at t+h is
guessed, the members step in turn with inputs interpolated towards the guess and towards
the outputs of the members stepped before them, and the torn signal's end value is
compared with the guess; the members are rolled back with fmi2SetFMUstate and the guess
improved by a safeguarded root finder that also handles the jumps stick-slip events cause
(tear.py). Events inside a coupled step are located and crossed with consistent partners.
A group without a single-signal tear is iterated on all its internal signals (fixed
point). A group that does not converge is an error naming the loop and the time, never a
silent delay.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from pendfmu.errors import FMUError, UsageError
from pendfmu.simulator.component import PROCESS_POOL, ComponentFMU, discrete_outputs, once_per_process, pooled_instance
from pendfmu.simulator.coupled import CoupledSteps, CouplingError
from pendfmu.simulator.fmi import unpacked_fmu
from pendfmu.simulator.graph import Wire, algebraic_loops, stepping_order, tear_of

# The most communication points one run may plan. Each point costs about 50 bytes across the
# grid and the arrays drawn on it (flags, step sizes, each drive's values and slopes, the
# outputs), so this is ~2.5 GB: hours of a recording at the default step of 0.2 ms. More
# is a time column in ms or us, or a step far too small for the span.
MAX_POINTS = 50_000_000


def check_plan(times: np.ndarray, step: float, where: str = "the sample times") -> None:
    """Refuse (UsageError naming `where`) sample times whose intervals, cut into steps no
    longer than `step`, make more than MAX_POINTS communication points, before anything is
    allocated: a two-row recording spanning 1e7 s asked for 373 GiB."""
    planned = 1.0 + float(np.sum(np.maximum(1.0, np.ceil(np.diff(times) / step - 1e-9))))
    if planned > MAX_POINTS:
        raise UsageError(f"{where}: {float(times[0]):g} s to {float(times[-1]):g} s in communication steps of "
                         f"{step:g} s make {planned:.3g} points, more than a run may hold ({MAX_POINTS:.0e}); is "
                         f"the time in seconds (not ms)? else choose a longer step")


@dataclass
class ExternalInput:
    """A signal from a recording driving an input: held at samples, or linear between."""

    times: np.ndarray
    values: np.ndarray
    interpolation: str = "hold"  # hold | linear

    def __post_init__(self) -> None:
        if self.interpolation not in ("hold", "linear"):
            raise UsageError(f"interpolation must be 'hold' or 'linear', not {self.interpolation!r}")
        self.times = np.asarray(self.times, dtype=float)
        self.values = np.asarray(self.values, dtype=float)

    def value(self, t: float) -> float:
        if self.interpolation == "linear":
            return float(np.interp(t, self.times, self.values))
        k = int(np.searchsorted(self.times, t, side="right")) - 1
        return float(self.values[max(k, 0)])

    def value_and_slope(self, t: float, h: float) -> tuple[float, float]:
        """Value at t and, for linear interpolation, the slope over [t, t+h]."""
        start = self.value(t)
        if self.interpolation == "hold" or h <= 0:
            return start, 0.0
        return start, (self.value(t + h) - start) / h

    def values_and_slopes(self, t: np.ndarray, h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """value_and_slope for arrays of steps: the same operations, vectorized."""
        if self.interpolation == "linear":
            start = np.interp(t, self.times, self.values)
            positive = h > 0
            slopes = np.zeros_like(start)
            slopes[positive] = (np.interp(t[positive] + h[positive], self.times, self.values) - start[positive]) \
                / h[positive]
            return start, slopes
        index = np.maximum(np.searchsorted(self.times, t, side="right") - 1, 0)
        return self.values[index], np.zeros(len(t))


def feedthrough_of(component_type: str, fmu: str | Path | None = None) -> dict[str, set[str]]:
    """output -> inputs it depends on directly, from the FMU's ModelStructure."""
    _, md = unpacked_fmu(component_type, fmu)
    inputs = {v.name for v in md.modelVariables if v.causality == "input"}
    result = {}
    for unknown in md.outputs:
        dependencies = unknown.dependencies if unknown.dependencies is not None else []
        result[unknown.variable.name] = {d.name for d in dependencies if d.name in inputs}
    return result


class Master(CoupledSteps):
    """A system of component FMUs connected output to input.

    `components` maps instance names to component types (CurrentLoop, Cart, Pendulum, Controller);
    `parameters` maps instance names to their parameter values; `fmus` optionally maps
    instance names to FMU files to use instead of the ones built from source."""

    def __init__(self, components: Mapping[str, str], connections: Sequence[Wire],
                 parameters: Mapping[str, Mapping[str, float]] | None = None, step: float = 2e-4,
                 loop_tolerance: float = 1e-10, max_iterations: int = 30,
                 fmus: Mapping[str, str | Path] | None = None):
        if step <= 0:
            raise UsageError(f"communication step must be positive, not {step}")
        self.types = dict(components)
        self.fmus = dict(fmus or {})
        self.connections = list(connections)
        self.parameters = {name: dict((parameters or {}).get(name, {})) for name in self.types}
        self.step = step
        self.loop_tolerance = loop_tolerance
        self.max_iterations = max_iterations
        self._check_connections()
        # Signals from discrete outputs (a sampled controller's) are held over a step, not
        # interpolated: they change only at events (discrete_outputs).
        self.held = {(c.source, c.output) for c in self.connections
                     if c.output in discrete_outputs(self.types[c.source], self.fmus.get(c.source))}
        self.order = stepping_order(self.types, self.connections)
        # Coupled groups with a single-signal tear step in the tear's order (see tear_of).
        self.tears: dict[tuple[str, ...], tuple[str, str]] = {}
        for k, group in enumerate(self.order):
            found = tear_of(group, self.connections, self.held) if len(group) > 1 else None
            if found is not None:
                self.order[k] = found[1]
                self.tears[tuple(found[1])] = found[0]
        self.loops = algebraic_loops(self.connections,
                                     {n: feedthrough_of(t, self.fmus.get(n)) for n, t in self.types.items()})
        self.iterations = 0  # loop iterations done in the last run, for diagnostics
        self.jumps = 0  # pieces of coupled steps in the last run whose loop map jumped (tear.py)
        self.events = 0  # events inside coupled steps crossed by held pieces (coupled.py)
        self._kept_timeline = None  # see _timeline and _drive
        self._kept_drives: dict[tuple[str, str], tuple] = {}

    @classmethod
    def from_system(cls, system, **options) -> Master:
        """A master for an SSP system (pendfmu.ssp.System, e.g. from read_ssd)."""
        components, fmus, parameters = {}, {}, {}
        for name, component in system.components.items():
            _, md = unpacked_fmu(name, component.fmu)
            components[name] = md.coSimulation.modelIdentifier
            fmus[name] = component.fmu
            parameters[name] = {key: float(value.value) for key, value in system.parameters.get(name, {}).items()}
        connections = [Wire(c.start_element, c.start_connector, c.end_element, c.end_connector)
                       for c in system.component_connections()]  # the system's own connectors are the caller's
        if system.experiment is not None and system.experiment.step_size and "step" not in options:
            options["step"] = system.experiment.step_size
        return cls(components, connections, parameters, fmus=fmus, **options)

    def _check_connections(self) -> None:
        for c in self.connections:
            for name, variable, causality in ((c.source, c.output, "output"), (c.target, c.input, "input")):
                if name not in self.types:
                    raise UsageError(f"connection {c}: no component {name!r}")
                _, md = unpacked_fmu(self.types[name], self.fmus.get(name))
                found = {v.name: v.causality for v in md.modelVariables}
                if found.get(variable) != causality:
                    raise UsageError(f"connection {c}: {name} has no {causality} {variable!r}")
        targets = [(c.target, c.input) for c in self.connections]
        if len(targets) != len(set(targets)):
            raise UsageError("an input is connected to more than one output")

    # ------------------------------------------------------------------ running

    def run(self, times: Sequence[float], outputs: Sequence[str],
            external: Mapping[str, ExternalInput] | None = None, engine: str = "native") -> pd.DataFrame:
        """Simulate from times[0] and return `outputs` ('Component.variable') at `times`.

        Communication points are `times`, each interval split evenly into steps no
        longer than the communication step, so outputs land exactly on the samples.
        `engine` "native" runs the loop in C (fast), "python" in Python (the reference);
        both give bit-identical results."""
        if engine not in ("native", "python"):
            raise UsageError(f"engine must be 'native' or 'python', not {engine!r}")
        times = np.asarray(times, dtype=float)
        check_plan(times, self.step)
        external = dict(external or {})
        for key in external:
            self._split(key)
        fmus = self._instances(float(times[0]))
        try:
            run = self._run_native if engine == "native" else self._run
            return run(fmus, times, [self._split(o) for o in outputs], external, list(outputs))
        except BaseException:
            self.close()  # an instance in error is not reused
            raise

    def _instances(self, start_time: float) -> dict[str, ComponentFMU]:
        """The system's FMU instances, made once and reset and re-initialized per run: a
        fit runs the same system thousands of times. An FMU that declares
        canBeInstantiatedOnlyOncePerProcess has its one instance in the process's pool."""
        if not getattr(self, "_fmus", None):
            self._fmus = {name: self._instance(name, kind, start_time) for name, kind in self.types.items()}
        else:
            for name, fmu in self._fmus.items():
                fmu.restart(self.parameters[name], start_time)
        return self._fmus

    def _instance(self, name: str, kind: str, start_time: float) -> ComponentFMU:
        path = self.fmus.get(name)

        def make() -> ComponentFMU:
            return ComponentFMU(kind, self.parameters[name], start_time=start_time, fmu=path, instance=name)

        if path is not None and once_per_process(unpacked_fmu(kind, path)[1]):
            return pooled_instance((name, str(path)), PROCESS_POOL, make, self.parameters[name], start_time)
        return make()

    def close(self) -> None:
        """Free the FMU instances (also done when the master is garbage-collected)."""
        for fmu in getattr(self, "_fmus", {}).values():
            if fmu not in PROCESS_POOL.values():  # the process's one instance stays
                fmu.free()
        self._fmus = {}

    def __del__(self) -> None:
        self.close()

    def _split(self, qualified: str) -> tuple[str, str]:
        name, _, variable = qualified.partition(".")
        if name not in self.types or not variable:
            raise UsageError(f"{qualified!r} is not 'Component.variable' of this system ({', '.join(self.types)})")
        return name, variable

    def _run(self, fmus, times, outputs, external, labels) -> pd.DataFrame:
        self.iterations = self.jumps = self.events = 0
        self._previous_end: dict[tuple[str, str], float] = {}  # predicted end values of loop signals
        self._tear_slope: dict[tuple[str, str], float] = {}  # r' of each tear's last step (tear.py)
        external = {self._split(k): v for k, v in external.items()}
        signals = {(c.source, c.output): 0.0 for c in self.connections}
        t = float(times[0])
        self._set_inputs(fmus, external, signals, signals, t, 0.0)
        self._solve_point(fmus, signals, t)
        grid, samples = self._grid(times)
        record = np.empty((len(times), len(outputs)))
        record[0] = [self._get(fmus[n], v) for n, v in outputs]
        row = 1
        for k in range(len(grid) - 1):
            a, b = float(grid[k]), float(grid[k + 1])
            self._interval(fmus, signals, external, a, b - a)
            for fmu in fmus.values():
                fmu.time = b
            if samples[k + 1]:
                record[row] = [self._get(fmus[n], v) for n, v in outputs]
                row += 1
        return pd.DataFrame({"time": times, **{label: record[:, j] for j, label in enumerate(labels)}})

    def _grid(self, times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Communication points, each sample interval split evenly into steps no longer
        than the communication step, and a flag for the points that are samples."""
        # 1e-9: sample times like k * 2e-4 differ from the step by rounding, not by design
        n_steps = np.maximum(1, np.ceil(np.diff(times) / self.step - 1e-9).astype(int))
        if np.all(n_steps == 1):
            return times.astype(float), np.ones(len(times), bool)
        # np.linspace(start, stop, n + 1)[1:] of every interval at once, with linspace's own
        # arithmetic (start + j * ((stop - start) / n), the last point stop itself): the same bits
        count = np.repeat(n_steps, n_steps)
        j = (np.arange(len(count)) - np.repeat(np.cumsum(n_steps) - n_steps, n_steps) + 1).astype(float)
        start, stop = np.repeat(times[:-1], n_steps), np.repeat(times[1:], n_steps)
        last = j == count
        points = np.where(last, stop, j * ((stop - start) / count) + start)
        return np.concatenate(([times[0]], points)), np.concatenate(([True], last))

    def _timeline(self, times: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(sample times, grid, record flags, step sizes) for a native run, kept for the next
        run with the same sample times. Why: a fit runs the same times thousands of times,
        and building these arrays anew touched fresh memory every run; on these machines the
        page faults cost more than the arithmetic (about 2 ms of a 20 ms run of the rig).
        The kept arrays are read-only, so that frames can share the time column safely."""
        kept = self._kept_timeline
        if kept is not None and kept[0].shape == times.shape and np.array_equal(kept[0], times):
            return kept
        grid, record = self._grid(times)
        kept = (times.copy(), grid, record.astype(np.uint8), np.append(np.diff(grid), 0.0))
        for array in kept:
            array.flags.writeable = False
        self._kept_timeline = kept
        return kept

    def _drive(self, target: tuple[str, str], signal: ExternalInput, grid: np.ndarray,
               steps: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The signal's values and slopes on the grid, kept (as the timeline is) while the
        signal's samples and the grid stay the same."""
        kept = self._kept_drives.get(target)
        if (kept is not None and kept[0] is grid and kept[1] == signal.interpolation
                and np.array_equal(kept[2], signal.times) and np.array_equal(kept[3], signal.values)):
            return kept[4], kept[5]
        values, slopes = signal.values_and_slopes(grid, steps)
        self._kept_drives[target] = (grid, signal.interpolation, signal.times.copy(), signal.values.copy(), values,
                                     slopes)
        return values, slopes

    def _run_native(self, fmus, times, outputs, external, labels) -> pd.DataFrame:
        from pendfmu.simulator.native import MAX_PORTS, Failure, run_system

        names = list(self.types)
        index = {name: k for k, name in enumerate(names)}
        external = {self._split(k): v for k, v in external.items()}
        sample_times, grid, record, steps = self._timeline(times)
        drives = []
        for (name, variable), signal in external.items():
            values, slopes = self._drive((name, variable), signal, grid, steps)
            drives.append((index[name], fmus[name].vr[variable], values, slopes))
        links = [(index[c.source], index[c.target], fmus[c.source].vr[c.output], fmus[c.target].vr[c.input],
                  int((c.source, c.output) in self.held)) for c in self.connections]
        groups = [[index[name] for name in group] for group in self.order]
        tears = [self.tears.get(tuple(group)) for group in self.order]
        tears = [(index[tear[0]], fmus[tear[0]].vr[tear[1]]) if tear else None for tear in tears]
        clocks = [fmus[n].vr.get("t_mode") for n in names]  # events inside coupled steps (coupled.py)
        logged = {n: len(fmus[n].messages) for n in names}
        recorded, system = run_system([fmus[n].slave for n in names], links, drives, groups, tears, clocks, grid,
                                      record, [(index[n], fmus[n].vr[v]) for n, v in outputs], self.loop_tolerance,
                                      self.max_iterations)
        self.iterations, self.jumps, self.events = int(system.iterations), int(system.jumps), int(system.events)
        failure = Failure(system.fail_kind)
        if failure in (Failure.NOT_CONVERGED, Failure.INCONSISTENT_POINT):
            t = system.fail_time
            where = (f"at t = {t:.9g} s" if failure is Failure.INCONSISTENT_POINT else
                     f"over [{t:.9g}, {grid[np.searchsorted(grid, t) + 1]:.9g}] s")
            raise CouplingError(f"algebraic loop {self._loop_text()} did not converge {where} "
                                f"after {self.max_iterations} iterations (last relative change "
                                f"{system.last_change:.3g})")
        if failure is Failure.TOO_MANY_PORTS:
            raise UsageError(f"the native engine takes at most {MAX_PORTS} inputs per component; use engine='python'")
        if failure is Failure.NO_MEMORY:  # as before: no unit to blame
            raise FMUError(f"the system at t = {system.fail_time:.9g} s: out of memory, or more connections than "
                           f"the native loop holds", time=system.fail_time)
        if failure is not Failure.NONE:
            name = names[system.fail_unit]
            raise fmus[name].slave.failure("an FMI call of the native loop failed", since=logged[name],
                                           time=system.fail_time)
        # copy=False: the columns stay the arrays filled above (no second pass over fresh memory)
        return pd.DataFrame({"time": sample_times, **{label: recorded[:, j] for j, label in enumerate(labels)}},
                            copy=False)

    def _get(self, fmu: ComponentFMU, variable: str) -> float:
        return fmu.get(variable)[0]

    def _set_inputs(self, fmus, external, start, end, t, h, members=None, length=None, offset=0.0) -> None:
        """Set every input of the members to its value at t, with the slope over [t, t+h]
        towards its value at t+h (`end`: outputs of sources already stepped, or guesses).
        For a piece of the step (coupled.py): `length` is the piece's, connected inputs go
        from `start` to `end` over it, and external ones start `offset` after t."""
        length = h if length is None else length
        for name in members or fmus:
            names, values, slopes = [], [], []
            for (target, variable), signal in external.items():
                if target == name:
                    value, slope = signal.value_and_slope(t, h)
                    if offset != 0.0:
                        value = value + slope * offset
                    names.append(variable), values.append(value), slopes.append(slope if length > 0 else 0.0)
            for c in self.connections:
                if c.target == name:
                    key = (c.source, c.output)
                    names.append(c.input), values.append(start[key])
                    slopes.append((end[key] - start[key]) / length if length > 0 and key not in self.held else 0.0)
            if not names:
                continue
            fmu = fmus[name]
            fmu.set(**dict(zip(names, values)))
            if length > 0 and any(slopes):
                refs = [fmu.vr[n] for n in names]
                fmu.slave.setRealInputDerivatives(refs, [1] * len(refs), slopes)

    def _solve_point(self, fmus, signals, t, links=None) -> None:
        """Make connected signals (`links`, default all) consistent at one instant: the
        start, and the end of a coupled step accepted at a jump (_settle)."""
        for _ in range(self.max_iterations):
            change = 0.0
            for c in links or self.connections:
                value = self._get(fmus[c.source], c.output)
                change = max(change, abs(value - signals[(c.source, c.output)]) / (1.0 + abs(value)))
                signals[(c.source, c.output)] = value
                fmus[c.target].set(**{c.input: value})
            if change <= self.loop_tolerance:
                return
        raise CouplingError(f"algebraic loop {self._loop_text()} did not converge at t = {t:.9g} s "
                            f"after {self.max_iterations} iterations (last relative change {change:.3g})")

    def _loop_text(self) -> str:
        return "; ".join(" -> ".join(loop + loop[:1]) for loop in self.loops) or "(no algebraic loop)"

    def _interval(self, fmus, signals, external, t, h) -> None:
        start = dict(signals)  # every connected signal at t; `signals` moves on to t+h
        for group in self.order:
            internal = [c for c in self.connections if c.source in group and c.target in group]
            if not internal:
                (name,) = group
                self._set_inputs(fmus, external, start, signals, t, h, members=[name])
                self._do_step(fmus[name], t, h)
                self._publish(fmus, signals, [name])
            else:
                self._coupled_step(fmus, signals, start, external, group, internal, t, h)

    def _do_step(self, fmu: ComponentFMU, t: float, h: float) -> None:
        fmu.slave.doStep(currentCommunicationPoint=t, communicationStepSize=h)

    def _publish(self, fmus, signals, names) -> None:
        for (source, output) in signals:
            if source in names:
                signals[(source, output)] = self._get(fmus[source], output)
