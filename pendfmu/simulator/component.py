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
    """A parameter name that the component does not have, or a value or use its FMU cannot
    take (a fraction for an Integer, input derivatives for an FMU that cannot interpolate
    inputs). A BadInput: the user's input is wrong, exit code 2."""


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
    addressed by variable names.

    It stands on the checked binding (fmi.py): `slave` is its instance, every call of which
    raises FMUError with what the FMU logged. Parameter names are checked against the
    variable table before they reach the FMU, and only what the FMU declares it can do
    (interpolated inputs, a varying step) is ever called (FMI 2.0, 4.3.1). The instance is
    set up and initialized on construction, ready to step.

    Parameters
    ----------
    name : str
        A pendfmu component ("CurrentLoop", "Cart", "Pendulum", ...: components.ALL_COMPONENTS),
        built from source if needed; with `fmu`, a label: the instance's name by default.
    parameters : mapping of str to float, optional
        Parameter values set in initialization mode (SI units, as the variable table
        declares them); the others keep the FMU's start values.
    start_time : float, optional
        The simulation's start time [s].
    log_events : bool, optional
        Whether the FMU's debug logging is on (fmi2Instantiate's loggingOn): what it logs
        then goes to `messages` too.
    fmu : str or Path, optional
        An FMI 2.0 Co-Simulation FMU file to run instead of the built component (an FMU
        from an SSP archive, an exported one, one pendfmu did not make).
    instance : str, optional
        The instance's name, as the FMU and error messages see it; `name` by default.
    copy : int, optional
        0 for the shared unpacked copy; a number > 0 loads another copy of the binary, with
        globals of its own, so instances in different threads share nothing.

    Attributes
    ----------
    name : str
        The instance's name.
    component : Component or None
        The pendfmu component's variable table (pendfmu.components); None for an FMU
        pendfmu did not make.
    vr : dict of str to int
        Each variable's value reference, by name.
    types : dict of str to str
        Each variable's type by name: "Real", "Integer" or "Boolean".
    parameter_names : list of str
        The names `set_parameters` accepts: the component's parameters, or every variable
        of causality "parameter" of another FMU.
    can_interpolate_inputs : bool
        The FMU's canInterpolateInputs: whether `step` may be given input derivatives.
    can_vary_step : bool
        The FMU's canHandleVariableCommunicationStepSize.
    resets : bool
        True until fmi2Reset has failed once; then `restart` makes a new instance instead.
    slave : CheckedFMU or None
        The binding's instance (fmi.py); None once freed.
    unit : Unit
        The instance as the native master loop calls it (native.py).
    time : float
        The current communication point [s].

    Raises
    ------
    ParameterError
        The FMU is Model Exchange only, not FMI 2.0, or `name` is not a pendfmu component
        (without `fmu`), or a parameter is unknown.
    FMUError
        The FMU refused to instantiate or initialize.

    Examples
    --------
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
        """What the FMU logged, oldest first (the current instance's; a restart that makes a
        new instance starts a new list)."""
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
        instantiated anew, now and for every later run.

        Parameters
        ----------
        parameters : mapping of str to float
            Parameter values set in initialization mode; the others go back to the FMU's
            start values.
        start_time : float, optional
            The new start time [s].
        """
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
        """Set parameter values, refusing a name that is not a parameter (a typo would
        otherwise set nothing the user meant, or an input).

        Parameters
        ----------
        parameters : mapping of str to float
            Values by parameter name (SI units, as the variable table declares them).

        Raises
        ------
        ParameterError
            A name is not one of `parameter_names`.
        """
        known = self.parameter_names
        unknown = [n for n in parameters if n not in known]
        if unknown:
            raise ParameterError(f"{self.name} has no parameter {', '.join(map(repr, unknown))}; "
                                 f"known: {', '.join(known)}")
        self.set(**parameters)

    def set(self, **values: float) -> None:
        """Set variables by name, whatever their causality (inputs, parameters).

        Parameters
        ----------
        **values : float
            Values by variable name. Integer and Boolean variables take whole numbers
            (True/False or 1/0 for a Boolean).

        Raises
        ------
        ParameterError
            A name the FMU does not have, or a fraction given to an Integer or Boolean.
        """
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
        """Read variables by name at the current time.

        Parameters
        ----------
        *names : str
            The variables' names.

        Returns
        -------
        list
            Their values in the order of `names`: float for a Real, int for an Integer,
            bool for a Boolean.

        Raises
        ------
        ParameterError
            A name the FMU does not have.
        """
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
        """Advance by one communication step, with inputs set at the current time.

        Parameters
        ----------
        h : float
            The step [s].
        inputs : mapping of str to float, optional
            Input values at the current time, held over the step unless `derivatives`
            gives their slopes.
        derivatives : mapping of str to sequence of float, optional
            Per input, its 1st, 2nd, ... time derivatives at the current time; the FMU
            interpolates the input with them over the step.

        Raises
        ------
        ParameterError
            `derivatives` given to an FMU that cannot interpolate inputs.
        FMUError
            The step failed.
        """
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
        """Step through communication points and record outputs at each.

        The calls step() and get() make, with C arrays prepared once: the virtual rig's
        long recordings (200,000 steps) spent three quarters of their time in fmpy's
        per-call conversions.

        Parameters
        ----------
        times : array_like of float
            The communication points [s]; the first is the current time.
        outputs : sequence of str
            The variables recorded at each point.
        inputs : callable, optional
            ``inputs(t)`` gives the input values (a mapping of name to value) at a
            communication point t, held over the step that starts there.
        derivatives : callable, optional
            ``derivatives(t)`` gives, per input, its time derivatives at t, as for `step`.

        Returns
        -------
        dict of str to ndarray
            ``"time"``: `times`; and each of `outputs`: its value at each point.
        """
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
                fmu.call("fmi2DoStep", component, self.time, times[k] - t, 1)
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
        """Save the instance's state (fmi2GetFMUstate), to come back to it with `set_state`.

        Returns
        -------
        object
            The FMU's opaque state pointer; it lives as long as the instance.
        """
        return self.slave.getFMUstate()

    def set_state(self, state, time: float) -> None:
        """Restore a state saved by `get_state` (fmi2SetFMUstate).

        Parameters
        ----------
        state : object
            What `get_state` returned.
        time : float
            The communication point the state was saved at [s]: the FMU state does not
            tell the binding its time.
        """
        self.slave.setFMUstate(state)
        self.time = time

    def free(self) -> None:
        """Free the instance (and unload its library); calling it again does nothing."""
        if self.slave is not None:
            self.slave.close()
            self.slave = None

    def __enter__(self) -> ComponentFMU:
        return self

    def __exit__(self, *exc) -> None:
        self.free()
