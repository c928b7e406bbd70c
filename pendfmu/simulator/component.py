"""One component FMU in Co-Simulation, addressed by variable names.

This is the thin layer every simulator of pendfmu stands on. It stands on the checked
binding (fmi.py: the FMU unpacked once per GUID, every call raising FMUError with what the
FMU logged), checks parameter names against the variable table, and steps with inputs held
or interpolated by input derivatives.
"""

from __future__ import annotations

import atexit
import ctypes
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

import numpy as np

from pendfmu.errors import BadInput, FMUError
from pendfmu.components import ALL_COMPONENTS
from pendfmu.simulator.fmi import CheckedFMU, instantiate_fmu, unpacked_fmu
from pendfmu.simulator.native import unit_of

class _CArrays:
    """Value references, their derivative orders and a value buffer, as the C arrays that
    fmi2GetReal, fmi2SetReal and fmi2SetRealInputDerivatives take."""

    def __init__(self, refs: Sequence[int], orders: Sequence[int] = ()):
        self.size = len(refs)
        self.refs = (ctypes.c_uint * self.size)(*refs)
        self.orders = (ctypes.c_int * self.size)(*orders)
        self.values = np.zeros(self.size)
        self.values_c = self.values.ctypes.data_as(ctypes.POINTER(ctypes.c_double))


class ParameterError(BadInput):
    """A parameter name that the component does not have."""


def discrete_outputs(name: str, fmu: str | Path | None = None) -> set[str]:
    """The outputs of component `name` (or of the FMU file) whose variability is discrete:
    piecewise constant, changing only at events (a sampled controller's output, held from
    one sample to the next). A master holds such a signal over a communication step instead
    of interpolating it: a line towards the next sample's value would apply it early."""
    md = unpacked_fmu(name, fmu)[1]
    return {v.name for v in md.modelVariables if v.causality == "output" and v.variability == "discrete"}


class InstancePool(dict):
    """FMU instances shared by the replays of one fit, by (instance name, FMU file or kind).
    Every run resets and initializes its instance first, so replays that run one after
    the other can share it: a fit of several recordings loads each FMU once, and an FMU
    that declares canBeInstantiatedOnlyOncePerProcess gets one instance. Pickled empty
    (a worker process makes its own), and as one object for all the replays that share it."""

    def __reduce__(self):
        return (InstancePool, ())


PROCESS_POOL = InstancePool()
"""The instances of FMUs that declare canBeInstantiatedOnlyOncePerProcess: one per FMU for
every replay and master of the process, freed when the process ends."""
atexit.register(lambda: [fmu.free() for fmu in PROCESS_POOL.values()])


def once_per_process(description) -> bool:
    """Whether a model description declares canBeInstantiatedOnlyOncePerProcess."""
    return bool(getattr(description.coSimulation, "canBeInstantiatedOnlyOncePerProcess", False))


def pooled_instance(key: tuple[str, str], pool: InstancePool, make: Callable[[], "ComponentFMU"],
                    parameters: Mapping[str, float], start_time: float) -> "ComponentFMU":
    """The pool's instance under `key`, restarted with these values, or a new one."""
    fmu = pool.get(key)
    if fmu is None:
        fmu = pool[key] = make()
    else:
        fmu.restart(parameters, start_time=start_time)
    return fmu


class ComponentFMU:
    """A Co-Simulation instance of CurrentLoop, Cart or Pendulum (or of any FMI 2.0 CS FMU),
    on the checked binding (fmi.py): `slave` is its instance, every call of which raises
    FMUError with what the FMU logged.

    >>> cart = ComponentFMU("Cart", {"m_p": 0.0})
    >>> cart.step(1e-3, inputs={"I": 2.0})
    >>> cart.get("x", "v")
    """

    def __init__(self, name: str, parameters: Mapping[str, float] | None = None, start_time: float = 0.0,
                 log_events: bool = False, fmu: str | Path | None = None, instance: str | None = None,
                 copy: int = 0):
        directory, md = unpacked_fmu(name, fmu, copy)
        if md.coSimulation is None:
            raise ParameterError(f"{fmu or name}: a Model-Exchange-only FMU; pendfmu co-simulates (export it with "
                                 f"Co-Simulation)")
        if not str(md.fmiVersion).startswith("2."):
            raise ParameterError(f"{fmu or name}: FMI {md.fmiVersion}; pendfmu's simulator co-simulates FMI 2.0 FMUs")
        kind = md.coSimulation.modelIdentifier
        if fmu is None and kind not in ALL_COMPONENTS:
            raise ParameterError(f"{name}: {kind!r} is not a pendfmu component ({', '.join(ALL_COMPONENTS)})")
        self.name = instance or name
        self.component = ALL_COMPONENTS.get(kind)  # None: an FMU pendfmu did not make
        self.vr = {v.name: v.valueReference for v in md.modelVariables}
        self.types = {v.name: v.type for v in md.modelVariables}
        self.parameter_names = (list(self.component.parameters) if self.component else
                                [v.name for v in md.modelVariables if v.causality == "parameter"])
        # What the FMU declares it can do; nothing else is ever called (FMI 2.0, 4.3.1).
        self.can_interpolate_inputs = bool(md.coSimulation.canInterpolateInputs)
        self.can_vary_step = bool(md.coSimulation.canHandleVariableCommunicationStepSize)
        self.resets = True  # until fmi2Reset has failed once: then it is re-instantiated per run
        self._load = (directory, md, "CS", self.name, None, log_events)
        self.slave: CheckedFMU | None = None
        self._instantiate()
        self._initialize(parameters, start_time)

    def _instantiate(self) -> None:
        """A new instance (fmpy's freeInstance also unloads the library: load it anew)."""
        self.slave = instantiate_fmu(*self._load)
        self.unit = unit_of(self.slave)  # what the native loop calls (native.py)

    @property
    def messages(self) -> list[str]:
        """What the FMU logged (the current instance's)."""
        return self.slave.messages

    def _refs(self, names: Sequence[str]) -> list[int]:
        unknown = [n for n in names if n not in self.vr]
        if unknown:
            raise ParameterError(f"{self.name} has no variable {', '.join(map(repr, unknown))}; "
                                 f"known: {', '.join(self.vr)}")
        return [self.vr[n] for n in names]

    def _initialize(self, parameters: Mapping[str, float] | None, start_time: float) -> None:
        """Set up, enter initialization mode, set the parameters, exit: the C functions through
        the binding's wrapper, not fmpy's methods (a fit does this before every simulation,
        and the methods cost more than the calls)."""
        fmu, component = self.slave, self.slave.component
        fmu.call("fmi2SetupExperiment", component, 0, 0.0, start_time, 0, 0.0)
        fmu.call("fmi2EnterInitializationMode", component)
        if parameters:
            self.set_parameters(parameters)
        fmu.call("fmi2ExitInitializationMode", component)
        self.time = start_time

    def restart(self, parameters: Mapping[str, float], start_time: float = 0.0) -> None:
        """Reset and initialize again with new parameter values (cheaper than a new instance).
        An FMU whose fmi2Reset fails (not every exporter implements it) is freed and
        instantiated anew, now and for every later run."""
        if self.resets:
            try:
                self.slave.call("fmi2Reset", self.slave.component)
            except FMUError:
                self.resets = False
        if not self.resets:
            self.slave.close()
            self._instantiate()
        self._initialize(parameters, start_time)

    # -- values

    def set_parameters(self, parameters: Mapping[str, float]) -> None:
        known = self.parameter_names
        unknown = [n for n in parameters if n not in known]
        if unknown:
            raise ParameterError(f"{self.name} has no parameter {', '.join(map(repr, unknown))}; "
                                 f"known: {', '.join(known)}")
        self.set(**parameters)

    def set(self, **values: float) -> None:
        names = list(values)
        refs = self._refs(names)
        if all(self.types[n] == "Real" for n in names):
            self.slave.setReal(refs, [float(values[n]) for n in names])
            return
        # Integer and Boolean variables (the Controller's n_d, delay, derivative_on_measurement)
        for kind, setter, cast in (("Real", self.slave.setReal, float), ("Integer", self.slave.setInteger, int),
                                   ("Boolean", self.slave.setBoolean, bool)):
            chosen = [(ref, values[n]) for n, ref in zip(names, refs) if self.types[n] == kind]
            if chosen:
                if kind != "Real" and any(float(value) != int(value) for _, value in chosen):
                    raise ParameterError(f"{self.name}: an {kind} variable needs a whole number, not "
                                         f"{', '.join(str(value) for _, value in chosen)}")
                setter([ref for ref, _ in chosen], [cast(value) for _, value in chosen])

    def get(self, *names: str) -> list[float]:
        refs = self._refs(names)
        out = []
        for name, ref in zip(names, refs):
            kind = self.types[name]
            getter = {"Real": self.slave.getReal, "Integer": self.slave.getInteger,
                      "Boolean": self.slave.getBoolean}[kind]
            out.append(getter([ref])[0])
        return out

    # -- time

    def step(self, h: float, inputs: Mapping[str, float] | None = None,
             derivatives: Mapping[str, Sequence[float]] | None = None) -> None:
        """Advance by h with inputs set at the current time; `derivatives` maps an input to
        its 1st, 2nd, ... time derivatives there (the FMU interpolates with them)."""
        if inputs:
            self.set(**inputs)
        if derivatives:
            self._require_interpolation()
            refs, orders, values = [], [], []
            for name, ders in derivatives.items():
                for order, value in enumerate(ders, start=1):
                    refs.append(self._refs([name])[0])
                    orders.append(order)
                    values.append(float(value))
            self.slave.setRealInputDerivatives(refs, orders, values)
        self.slave.doStep(currentCommunicationPoint=self.time, communicationStepSize=h)
        self.time += h

    def _require_interpolation(self) -> None:
        if not self.can_interpolate_inputs:
            raise ParameterError(f"{self.name}: the FMU cannot interpolate inputs (canInterpolateInputs is "
                                 f"false): its inputs are held between communication points")

    def run(self, times: np.ndarray, outputs: Sequence[str],
            inputs: Callable[[float], Mapping[str, float]] | None = None,
            derivatives: Callable[[float], Mapping[str, Sequence[float]]] | None = None) -> dict[str, np.ndarray]:
        """Step through `times` (the first is the current time) and record `outputs` at each.

        `inputs(t)` gives the input values at a communication point t, held over the step
        unless `derivatives(t)` also gives their derivatives there. The calls step() and
        get() make, with C arrays prepared once: the virtual rig's long recordings (200,000
        steps) spent three quarters of their time in fmpy's per-call conversions."""
        times = np.asarray(times, dtype=float)
        self._refs(outputs)  # unknown names refused before the first step
        if any(self.types[name] != "Real" for name in outputs):
            return self._run_by_name(times, outputs, inputs, derivatives)
        fmu, component = self.slave, self.slave.component
        read, prepared = _CArrays(self._refs(outputs)), {}
        result = np.empty((len(times), len(outputs)))
        for k in range(len(times)):
            if k:
                t = times[k - 1]
                self._set_inputs(inputs(t) if inputs else None, prepared)
                self._set_derivatives(derivatives(t) if derivatives else None, prepared)
                self.slave.call("fmi2DoStep", component, self.time, times[k] - t, 1)
                self.time += times[k] - t
            fmu.call("fmi2GetReal", component, read.refs, read.size, read.values_c)
            result[k] = read.values
        return {"time": times, **{name: result[:, j] for j, name in enumerate(outputs)}}

    def _set_inputs(self, values: Mapping[str, float] | None, prepared: dict) -> None:
        """set(**values), the C arrays of each set of names made once (in `prepared`)."""
        if not values:
            return
        if any(self.types.get(name) != "Real" for name in values):
            self.set(**values)
            return
        key = ("inputs", *values)
        arrays = prepared.get(key) or prepared.setdefault(key, _CArrays(self._refs(values)))
        arrays.values[:] = [float(v) for v in values.values()]
        self.slave.call("fmi2SetReal", self.slave.component, arrays.refs, arrays.size, arrays.values_c)

    def _set_derivatives(self, derivatives: Mapping[str, Sequence[float]] | None, prepared: dict) -> None:
        """step()'s input derivatives, the C arrays of each set of names and orders made once."""
        if not derivatives:
            return
        self._require_interpolation()
        key = ("derivatives", *((name, len(ders)) for name, ders in derivatives.items()))
        arrays = prepared.get(key)
        if arrays is None:
            refs = [ref for (_, count), ref in zip(key[1:], self._refs(derivatives)) for _ in range(count)]
            orders = [order for _, count in key[1:] for order in range(1, count + 1)]
            arrays = prepared[key] = _CArrays(refs, orders)
        arrays.values[:] = [float(v) for ders in derivatives.values() for v in ders]
        self.slave.call("fmi2SetRealInputDerivatives", self.slave.component, arrays.refs, arrays.size,
                        arrays.orders, arrays.values_c)

    def _run_by_name(self, times: np.ndarray, outputs: Sequence[str], inputs, derivatives) -> dict[str, np.ndarray]:
        """run() with outputs of any type (a mode as an Integer), a value at a time."""
        result = np.empty((len(times), len(outputs)))
        result[0] = self.get(*outputs)
        for k in range(1, len(times)):
            t = times[k - 1]
            self.step(times[k] - t, inputs(t) if inputs else None, derivatives(t) if derivatives else None)
            result[k] = self.get(*outputs)
        return {"time": times, **{name: result[:, j] for j, name in enumerate(outputs)}}

    def get_state(self):
        return self.slave.getFMUstate()

    def set_state(self, state, time: float) -> None:
        self.slave.setFMUstate(state)
        self.time = time

    def free(self) -> None:
        if self.slave is not None:
            self.slave.close()
            self.slave = None

    def __enter__(self) -> ComponentFMU:
        return self

    def __exit__(self, *exc) -> None:
        self.free()
