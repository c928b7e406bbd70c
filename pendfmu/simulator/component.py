"""One component FMU in Co-Simulation through fmpy, addressed by variable names.

This is the thin layer every simulator of pendfmu stands on: it unpacks the FMU once per
GUID, instantiates it with a logger that keeps the FMU's messages (so a failing call
raises an error that says *why*, not just "status 3"), checks parameter names against
the variable table, and steps with inputs held or interpolated by input derivatives.
"""

from __future__ import annotations

import atexit
import shutil
import tempfile
from collections.abc import Callable, Mapping, Sequence
from ctypes import byref
from pathlib import Path

import numpy as np
from fmpy import extract
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE
from fmpy.fmi2 import fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE
from fmpy.logging import addLoggerProxy

from pendfmu.errors import BadInput, FMUError
from pendfmu.components import ALL_COMPONENTS as COMPONENTS
from pendfmu.fmubuild import ensure_fmu
from pendfmu.fmubuild.compiler import model_description
from pendfmu.simulator.native import unit_of

FMI2_WARNING = 1  # fmi2Status: a call that returns more than fmi2Warning failed

_UNPACKED: dict[str, tuple[Path, object]] = {}


class ParameterError(BadInput):
    """A parameter name that the component does not have."""


def unpacked_fmu(name: str, fmu: str | Path | None = None, copy: int = 0) -> tuple[Path, object]:
    """(unzip directory, model description) of component `name`, unpacked once per GUID.

    Without `fmu` the component is built from source if needed; with it, that file is used
    (an FMU from an .ssp archive or an exported, re-parameterized one). `copy` > 0 unpacks
    another copy: its binary is loaded as a library of its own, with its own globals, so
    that instances in different threads share nothing (see Residuals' Jacobian threads)."""
    path = Path(fmu) if fmu is not None else ensure_fmu(name)
    md = model_description(path)
    key = f"{path.resolve()}:{md.guid}:{copy}"
    if key not in _UNPACKED:
        directory = Path(tempfile.mkdtemp(prefix=f"pendfmu-{name}-"))
        extract(str(path), str(directory))
        atexit.register(shutil.rmtree, directory, True)
        _UNPACKED[key] = (directory, md)
    return _UNPACKED[key]


def discrete_outputs(name: str, fmu: str | Path | None = None) -> set[str]:
    """The outputs of component `name` (or of the FMU file) whose variability is discrete:
    piecewise constant, changing only at events (a sampled controller's output, held from
    one sample to the next). A master holds such a signal over a communication step instead
    of interpolating it: a line towards the next sample's value would apply it early."""
    md = unpacked_fmu(name, fmu)[1]
    return {v.name for v in md.modelVariables if v.causality == "output" and v.variability == "discrete"}


class FMU2SlaveCached(FMU2Slave):
    """fmpy's FMU2Slave, with its table of the FMU's C functions built once per process:
    fmpy builds it for every instance with an inspect.signature per function (2 ms of the
    3 ms an FMU takes to load, a tenth of `pendfmu simulate`). The same argument and result
    types are set on the same C functions; a fmpy without this hook builds its own. (The
    name must start with FMU2: fmpy picks the functions' prefix by the class name.)"""

    _table: list | None = None

    def _loadFunctions(self) -> None:
        if FMU2SlaveCached._table is None:
            super()._loadFunctions()
            FMU2SlaveCached._table = [(name, f.argnames, f.argtypes, f.restype) for name, f in self._functions.items()]
            return
        for name, argnames, argtypes, restype in FMU2SlaveCached._table:
            function = getattr(self.dll, name)
            function.argnames, function.argtypes, function.restype = argnames, argtypes, restype
            self._functions[name] = function


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
    """A Co-Simulation instance of CurrentLoop, Cart or Pendulum.

    >>> cart = ComponentFMU("Cart", {"m_p": 0.0})
    >>> cart.step(1e-3, inputs={"I": 2.0})
    >>> cart.get("x", "v")
    """

    def __init__(self, name: str, parameters: Mapping[str, float] | None = None, start_time: float = 0.0,
                 log_events: bool = False, fmu: str | Path | None = None, instance: str | None = None,
                 copy: int = 0):
        self.messages: list[str] = []
        directory, md = unpacked_fmu(name, fmu, copy)
        if md.coSimulation is None:
            raise ParameterError(f"{fmu or name}: a Model-Exchange-only FMU; pendfmu co-simulates (export it with "
                                 f"Co-Simulation)")
        kind = md.coSimulation.modelIdentifier
        if fmu is None and kind not in COMPONENTS:
            raise ParameterError(f"{name}: {kind!r} is not a pendfmu component ({', '.join(COMPONENTS)})")
        self.name = instance or name
        self.component = COMPONENTS.get(kind)  # None: an FMU pendfmu did not make
        self.vr = {v.name: v.valueReference for v in md.modelVariables}
        self.types = {v.name: v.type for v in md.modelVariables}
        self.parameter_names = (list(self.component.parameters) if self.component else
                                [v.name for v in md.modelVariables if v.causality == "parameter"])
        # What the FMU declares it can do; nothing else is ever called (FMI 2.0, 4.3.1).
        self.can_interpolate_inputs = bool(md.coSimulation.canInterpolateInputs)
        self.can_get_set_state = bool(md.coSimulation.canGetAndSetFMUstate)
        self.can_vary_step = bool(md.coSimulation.canHandleVariableCommunicationStepSize)
        self.resets = True  # until fmi2Reset has failed once: then it is re-instantiated per run
        self._log_events = log_events
        self._callbacks = self._make_callbacks()
        self._load = dict(guid=md.guid, unzipDirectory=str(directory), modelIdentifier=kind, instanceName=self.name)
        self.slave = None
        self._instantiate()
        self._initialize(parameters, start_time)

    def _instantiate(self) -> None:
        """A new instance (fmpy's freeInstance also unloads the library: load it anew)."""
        self.slave = FMU2SlaveCached(**self._load)
        self._call(self.slave.instantiate, callbacks=self._callbacks, loggingOn=self._log_events)
        self.unit = unit_of(self.slave)  # what the native loop calls (native.py)

    # -- plumbing

    def _make_callbacks(self) -> fmi2CallbackFunctions:
        def logger(env, instance, status, category, message):
            self.messages.append(message.decode("utf-8", "replace") if message else "")

        callbacks = fmi2CallbackFunctions()
        callbacks.logger = fmi2CallbackLoggerTYPE(logger)
        from fmpy import calloc, free

        callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        addLoggerProxy(byref(callbacks))
        return callbacks

    def _call(self, function: Callable, *args, **kwargs):
        before = len(self.messages)
        try:
            return function(*args, **kwargs)
        except FMICallException as error:
            said = "; ".join(self.messages[before:]) or str(error)
            raise FMUError(f"{self.name}: {said}", instance=self.name, function=getattr(function, "__name__", None),
                           messages=self.messages[before:]) from None

    def _refs(self, names: Sequence[str]) -> list[int]:
        unknown = [n for n in names if n not in self.vr]
        if unknown:
            raise ParameterError(f"{self.name} has no variable {', '.join(map(repr, unknown))}; "
                                 f"known: {', '.join(self.vr)}")
        return [self.vr[n] for n in names]

    def _initialize(self, parameters: Mapping[str, float] | None, start_time: float) -> None:
        """Set up, enter initialization mode, set the parameters, exit: straight through the
        FMU's functions, not fmpy's wrappers (a fit does this before every simulation, and
        the wrappers cost more than the calls)."""
        dll, component = self.slave.dll, self.slave.component
        self._check("fmi2SetupExperiment", dll.fmi2SetupExperiment(component, 0, 0.0, start_time, 0, 0.0))
        self._check("fmi2EnterInitializationMode", dll.fmi2EnterInitializationMode(component))
        if parameters:
            self.set_parameters(parameters)
        self._check("fmi2ExitInitializationMode", dll.fmi2ExitInitializationMode(component))
        self.time = start_time

    def _check(self, function: str, status: int) -> None:
        """Raise FMUError for a status worse than fmi2Warning, with what the FMU logged."""
        if status > FMI2_WARNING:
            said = "; ".join(self.messages[-3:]) or f"{function} returned status {status}"
            raise FMUError(f"{self.name}: {said}", instance=self.name, function=function,
                           messages=self.messages[-3:])

    def restart(self, parameters: Mapping[str, float], start_time: float = 0.0) -> None:
        """Reset and initialize again with new parameter values (cheaper than a new instance).
        An FMU whose fmi2Reset fails (not every exporter implements it) is freed and
        instantiated anew, now and for every later run."""
        if self.resets and self.slave.dll.fmi2Reset(self.slave.component) > FMI2_WARNING:
            self.resets = False
        if not self.resets:
            self.slave.freeInstance()
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
            self._call(self.slave.setReal, refs, [float(values[n]) for n in names])
            return
        # Integer and Boolean variables (the Controller's n_d, delay, derivative_on_measurement)
        for kind, setter, cast in (("Real", self.slave.setReal, float), ("Integer", self.slave.setInteger, int),
                                   ("Boolean", self.slave.setBoolean, bool)):
            chosen = [(ref, values[n]) for n, ref in zip(names, refs) if self.types[n] == kind]
            if chosen:
                if kind != "Real" and any(float(value) != int(value) for _, value in chosen):
                    raise ParameterError(f"{self.name}: an {kind} variable needs a whole number, not "
                                         f"{', '.join(str(value) for _, value in chosen)}")
                self._call(setter, [ref for ref, _ in chosen], [cast(value) for _, value in chosen])

    def get(self, *names: str) -> list[float]:
        refs = self._refs(names)
        out = []
        for name, ref in zip(names, refs):
            kind = self.types[name]
            getter = {"Real": self.slave.getReal, "Integer": self.slave.getInteger,
                      "Boolean": self.slave.getBoolean}[kind]
            out.append(self._call(getter, [ref])[0])
        return out

    # -- time

    def step(self, h: float, inputs: Mapping[str, float] | None = None,
             derivatives: Mapping[str, Sequence[float]] | None = None) -> None:
        """Advance by h with inputs set at the current time; `derivatives` maps an input to
        its 1st, 2nd, ... time derivatives there (the FMU interpolates with them)."""
        if inputs:
            self.set(**inputs)
        if derivatives:
            if not self.can_interpolate_inputs:
                raise ParameterError(f"{self.name}: the FMU cannot interpolate inputs (canInterpolateInputs is "
                                     f"false): its inputs are held between communication points")
            refs, orders, values = [], [], []
            for name, ders in derivatives.items():
                for order, value in enumerate(ders, start=1):
                    refs.append(self._refs([name])[0])
                    orders.append(order)
                    values.append(float(value))
            self._call(self.slave.setRealInputDerivatives, refs, orders, values)
        self._call(self.slave.doStep, currentCommunicationPoint=self.time, communicationStepSize=h)
        self.time += h

    def run(self, times: np.ndarray, outputs: Sequence[str],
            inputs: Callable[[float], Mapping[str, float]] | None = None,
            derivatives: Callable[[float], Mapping[str, Sequence[float]]] | None = None) -> dict[str, np.ndarray]:
        """Step through `times` (the first is the current time) and record `outputs` at each.

        `inputs(t)` gives the input values at a communication point t, held over the step
        unless `derivatives(t)` also gives their derivatives there."""
        times = np.asarray(times, dtype=float)
        refs = self._refs(outputs)
        result = np.empty((len(times), len(outputs)))
        result[0] = self.get(*outputs)
        for k in range(1, len(times)):
            t = times[k - 1]
            self.step(times[k] - t, inputs(t) if inputs else None, derivatives(t) if derivatives else None)
            result[k] = self.get(*outputs)
        del refs
        return {"time": times, **{name: result[:, j] for j, name in enumerate(outputs)}}

    def get_state(self):
        return self._call(self.slave.getFMUstate)

    def set_state(self, state, time: float) -> None:
        self._call(self.slave.setFMUstate, state)
        self.time = time

    def free(self) -> None:
        if self.slave is not None:
            try:
                self.slave.terminate()
            except FMICallException:
                pass  # not running (reset, or in error): freeing is allowed from any phase
            self.slave.freeInstance()
            self.slave = None

    def __enter__(self) -> ComponentFMU:
        return self

    def __exit__(self, *exc) -> None:
        self.free()
