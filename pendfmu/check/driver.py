"""One instance of an FMI 2.0 or 3.0 FMU, stepped the same way in Co-Simulation and Model
Exchange, for the checks.

`Driver(target, "CS" | "ME")` instantiates the FMU on the checked binding
(pendfmu.simulator.fmi: a failing call raises FMUError with what the FMU logged),
initializes it with parameter values, and steps from one communication point to the next
with the inputs held over the step. In Model Exchange the step is integrated here (classical
Runge-Kutta, one stage set per communication step or time-event interval), with state events
located by bisection on the event indicators, so that a discrete change happens at the same
instant whatever the communication step; a discrete input (FMI: settable only in Event Mode
there) that changes at a communication point is set in an event.

When the FMU asks to end the simulation (terminateSimulation from fmi2NewDiscreteStates or
fmi2CompletedIntegratorStep, FMI 2.0 section 3.2.2, or fmi2DoStep's fmi2Discard with
fmi2Terminated, section 4.2.3; the terminateSimulation arguments of fmi3UpdateDiscreteStates,
fmi3CompletedIntegratorStep and fmi3DoStep in FMI 3.0), that is its right, not a failure: the driver calls nothing more that computes, the time goes on,
the outputs keep the values they had at the end, and `ended` says when it was. A state
restored from before that instant (rollback) runs again.
"""

from __future__ import annotations

import ctypes
import math
from collections.abc import Callable, Mapping

import numpy as np

from pendfmu.check.variables import Reader, accessor, slot
from pendfmu.errors import FMUError, PendfmuError
from pendfmu.simulator.fmi import instantiate_fmu

DOUBLE_P = ctypes.POINTER(ctypes.c_double)
DISCARD = 2
FMI2_LAST_SUCCESSFUL_TIME, FMI2_TERMINATED = 2, 3  # fmi2StatusKind
STABLE = 2.0
"""The largest h|lambda| an integration step takes (classical Runge-Kutta is stable up to 2.78)."""
MAX_SUBSTEPS = 20_000
"""Substeps one communication step may take before the model counts as too stiff for the driver."""


MAX_GROUP_STEPS = 2_000_000
"""Communication steps one check group may take in all (its runs and the stimulus search): 100
runs at fmu.MAX_RUN_STEPS, more than any group needs at the cap."""


class WorkLimit(PendfmuError, RuntimeError):
    """A check group took more than MAX_GROUP_STEPS communication steps: the planned work has
    a cap a model description (many inputs, a long reference) cannot exceed."""


class StepBudget:
    """The communication steps left to the check group running in this process: contain.py
    starts one per group and stops it after; outside a group (the pytest plugin's fmu_runner)
    there is no cap."""

    def __init__(self):
        self.left = math.inf

    def start(self) -> None:
        self.left = MAX_GROUP_STEPS

    def stop(self) -> None:
        self.left = math.inf

    def spend(self) -> None:
        self.left -= 1
        if self.left < 0:
            raise WorkLimit(f"the check group took more than {MAX_GROUP_STEPS} communication steps, the cap of its "
                            f"work: stopped there")


BUDGET = StepBudget()


class StiffModel(PendfmuError, RuntimeError):
    """The driver's explicit integrator cannot follow the model at this step: a limit of the
    check, not a defect of the FMU (a row that meets it is INCONCLUSIVE)."""


class Driver:
    """One instance of the target as CS or ME, stepped from communication point to
    communication point (ME integrated here). `fmu` is its instance on the checked binding:
    every call raises FMUError (instance, function, time, what the FMU logged) on a status
    worse than Warning; `messages` is what the FMU logged; `ended` the time at which the FMU
    asked to end the simulation (None while it runs)."""

    def __init__(self, target, kind: str, name: str | None = None, guid: str | None = None):
        self.target, self.kind, self.fmi3 = target, kind, target.fmi3
        self.fmu = instantiate_fmu(target.directory, target.md, kind, name, guid)
        self.messages = self.fmu.messages
        self.in_vr = [v.valueReference for v in target.inputs]
        # Model Exchange sets a discrete input in Event Mode only (FMI 2.0 section 3.2.3; FMI 3.0 alike)
        self.discrete = [j for j, v in enumerate(target.inputs) if kind == "ME" and v.variability != "continuous"]
        self.out = [slot(v) for v in target.outputs]
        self._modes = Reader([slot(v) for v in target.modes], self.fmi3)
        self.time = 0.0
        self.ended: float | None = None
        self.held: np.ndarray | None = None  # the inputs last set
        md = target.md
        self.nx = md.numberOfContinuousStates if kind == "ME" else 0
        self.nz = md.numberOfEventIndicators if kind == "ME" else 0
        self.next_event = math.inf
        self.signs = None  # ME: the event indicators' signs at the end of the last step
        self.events: list[float] = []  # ME: the communication point before each event met (exercise.py)
        self._buffers()

    @property
    def out(self) -> list:
        """What outputs() reads: (type, value reference[, values in the variable, index])."""
        return self._out.slots

    @out.setter
    def out(self, slots) -> None:
        self._out = Reader(slots, self.fmi3)

    # -- set up

    def set_values(self, values: Mapping[str, float]) -> None:
        for name, value in values.items():
            v = self.target.variables[name]
            suffix = accessor(v.type, self.fmi3)
            cast = float if suffix.startswith(("Real", "Float")) else bool if suffix == "Boolean" else int
            getattr(self.fmu, "set" + suffix)([v.valueReference], [cast(value)])

    def initialize(self, parameters: Mapping[str, float] | None = None, inputs: np.ndarray | None = None) -> None:
        if parameters:
            self.set_values(parameters)
        if self.fmi3:
            self.fmu.enterInitializationMode(startTime=0.0)
        else:
            self.fmu.setupExperiment(startTime=0.0)
            self.fmu.enterInitializationMode()
        if inputs is not None:
            self._write(inputs, range(len(self.in_vr)))
        self.fmu.exitInitializationMode()
        self.time, self.ended = 0.0, None
        if self.kind == "ME":
            self._event_iteration()
            if self.ended is None:
                self.fmu.enterContinuousTimeMode()
                self.signs = self._indicators() > 0

    def reset(self) -> None:
        self.fmu.reset()
        self.ended, self.held = None, None

    def free(self) -> None:
        self.fmu.close()

    # -- values

    def outputs(self) -> np.ndarray:
        return self._out.read(self.fmu)

    def modes(self) -> tuple:
        return tuple(int(x) for x in self._modes.read(self.fmu)) if self.target.modes else ()

    def set_inputs(self, inputs: np.ndarray) -> None:
        """Set the inputs at the current communication point (ME: a changed discrete input
        in an event)."""
        if self.ended is not None or not len(self.in_vr):
            return
        if self.kind == "CS":
            self._write(inputs, range(len(self.in_vr)))
        elif self.discrete and (self.held is None or any(inputs[j] != self.held[j] for j in self.discrete)):
            self.fmu.enterEventMode()
            self._write(inputs, range(len(self.in_vr)))
            self._event_iteration()
            if self.ended is None:
                self.fmu.enterContinuousTimeMode()
                self.signs = self._indicators() > 0
        else:
            self._write(inputs, [j for j in range(len(self.in_vr)) if j not in self.discrete])
        self.held = np.array(inputs, dtype=float)

    def _write(self, inputs, which) -> None:
        """Set the inputs at positions `which`, one call per type."""
        by_type: dict[str, tuple[list, list]] = {}
        for j in which:
            v = self.target.inputs[j]
            vrs, values = by_type.setdefault(accessor(v.type, self.fmi3), ([], []))
            vrs.append(v.valueReference)
            values.append(float(inputs[j]))
        for suffix, (vrs, values) in by_type.items():
            getattr(self.fmu, "set" + suffix)(vrs, values)
        if len(which) == len(self.in_vr):
            self.held = np.array(inputs, dtype=float)

    # -- time

    def step(self, h: float, inputs: np.ndarray | None) -> None:
        if self.ended is not None:  # the FMU ended the simulation: nothing more to compute
            self.time += h
            return
        BUDGET.spend()
        if inputs is not None:
            self.set_inputs(inputs)
        if self.ended is not None:
            self.time += h
        elif self.kind == "CS":
            self._do_step(h)
            self.time += h
        else:
            self._integrate(self.time + h)

    def _do_step(self, h: float) -> None:
        if self.fmi3:
            _, terminate, _, reached = self.fmu.doStep(self.time, h, False)
            if terminate:
                self.ended = reached
            return
        try:
            self.fmu.doStep(self.time, h, False)
        except FMUError as error:
            if error.status != DISCARD or not self._fmi2_terminated():
                raise

    def _fmi2_terminated(self) -> bool:
        """After fmi2Discard from fmi2DoStep: whether the FMU wants to end (fmi2Terminated),
        and then where it got to (fmi2LastSuccessfulTime)."""
        try:
            if not self.fmu.getBooleanStatus(FMI2_TERMINATED):
                return False
            self.ended = self.fmu.getRealStatus(FMI2_LAST_SUCCESSFUL_TIME)
        except FMUError:
            return False
        return True

    def run(self, h: float, stop: float, stimulus: Callable[[float], np.ndarray] | None,
            record_modes: list | None = None) -> np.ndarray:
        """Step from the current time to `stop` with step h (inputs from `stimulus` at each
        communication point); returns the outputs at every point, the first row now."""
        first = int(round(self.time / h))  # times as whole multiples of h: a rerun from a
        n = int(round(stop / h)) - first     # restored state passes the very same numbers
        rows = [self.outputs()]
        for k in range(first, first + n):
            t = k * h
            self.time = t
            self.step(h, stimulus(t) if stimulus is not None else None)
            self.time = (k + 1) * h
            rows.append(self.outputs())
            if record_modes is not None:
                record_modes.append((self.time, self.modes()))
        return np.array(rows)

    # -- Model Exchange

    def _event_iteration(self) -> None:
        """Update the discrete states until the FMU needs no more; it may ask to end."""
        while True:
            if self.fmi3:
                needed, terminate, _, _, defined, next_time = self.fmu.updateDiscreteStates()
            else:
                needed, terminate, _, _, defined, next_time = self.fmu.newDiscreteStates()
            if terminate:
                self.ended = float(self.fmu.time or 0.0)
                return
            if not needed:
                self.next_event = next_time if defined else math.inf
                return

    def _buffers(self) -> None:
        """State, derivative and indicator arrays with their C pointers, made once: a
        pointer made per call costs as much as the FMU's own work (ME stepping a stiff model
        makes hundreds of thousands of calls)."""
        self._x, self._dx, self._z = np.zeros(self.nx), np.zeros(self.nx), np.zeros(self.nz)
        self._xp, self._dxp, self._zp = (a.ctypes.data_as(DOUBLE_P) for a in (self._x, self._dx, self._z))
        # the C functions by name, called through the checked binding's one wrapper without
        # fmpy's two layers of Python above it (half the cost of a call this small)
        v = "fmi3" if self.fmi3 else "fmi2"
        self._c = {"time": v + "SetTime", "set": v + "SetContinuousStates", "get": v + "GetContinuousStates",
                   "derivatives": "fmi3GetContinuousStateDerivatives" if self.fmi3 else "fmi2GetDerivatives",
                   "indicators": v + "GetEventIndicators"}

    def _states(self) -> np.ndarray:
        if self.nx:
            self.fmu.call(self._c["get"], self.fmu.component, self._xp, self.nx)
        return self._x.copy()

    def _set(self, t: float, x: np.ndarray) -> None:
        self.fmu.call(self._c["time"], self.fmu.component, t)
        if self.nx:
            self._x[:] = x
            self.fmu.call(self._c["set"], self.fmu.component, self._xp, self.nx)

    def _derivatives(self, t: float, x: np.ndarray) -> np.ndarray:
        self._set(t, x)
        if self.nx:
            self.fmu.call(self._c["derivatives"], self.fmu.component, self._dxp, self.nx)
        return self._dx.copy()

    def _indicators(self) -> np.ndarray:
        if self.nz:
            self.fmu.call(self._c["indicators"], self.fmu.component, self._zp, self.nz)
        return self._z.copy()

    def _rk4(self, t: float, x: np.ndarray, h: float, budget: list | None = None) -> np.ndarray:
        """One classical Runge-Kutta step, halved where the model is too stiff for it: h|lambda|
        is estimated from the stages (k3 - k2 ~ h/2 J (k2 - k1), each state weighted by 1/|x|) and
        kept below STABLE,
        inside RK4's stability interval (2.78 on the real axis), and a step whose stages
        overflow is halved too, so that a stiff model (Roberts) is integrated instead of
        blowing up to NaN; a non-stiff one gets the very same single step. Derivatives that
        are not finite at the step's own start are the FMU's and pass on. `budget` counts
        the halvings left in this communication step."""
        if not self.nx:
            return x
        k1 = self._derivatives(t, x)
        if not np.isfinite(k1).all():
            return x + h * k1
        with np.errstate(all="ignore"):  # overflowing stages are what the halving is for
            k2 = self._derivatives(t + h / 2, x + h / 2 * k1)
            k3 = self._derivatives(t + h / 2, x + h / 2 * k2)
            weight = 1.0 / (np.abs(x) + 1e-12)  # each state relative to its size: a small one can be the stiff one
            spread = float((np.abs(k2 - k1) * weight).max())
            noise = spread <= 1e-9 * float((np.abs(k1) * weight).max())  # stages equal to rounding: nothing to judge
            stiffness = 0.0 if noise else 2 * float((np.abs(k3 - k2) * weight).max()) / spread
            if stiffness <= STABLE:  # (False for NaN)
                k4 = self._derivatives(t + h, x + h * k3)
                x1 = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
                if np.isfinite(x1).all():
                    return x1
        budget = budget if budget is not None else [MAX_SUBSTEPS]
        budget[0] -= 1
        if budget[0] < 0 or h < 1e-12 * max(1.0, abs(t)):
            raise StiffModel(f"the model is too stiff for pendfmu check's explicit integrator at t = {t:.6g} s (more "
                             f"than {MAX_SUBSTEPS} substeps in one step, the last h|lambda| about {stiffness:.3g} at "
                             f"h = {h:.3g} s): run it in Co-Simulation or shorten --step")
        x = self._rk4(t, x, h / 2, budget)
        return self._rk4(t + h / 2, x, h / 2, budget)

    def _integrate(self, t_end: float) -> None:
        t = self.time
        eps = 1e-12 * max(1.0, abs(t_end))
        while t < t_end - eps and self.ended is None:
            # a time event within rounding of the communication point happens at it
            t_next = self.next_event if self.next_event <= t_end + eps else t_end
            x = self._states()
            self._set(t, x)
            z0 = self._indicators() > 0
            if self.signs is not None and (z0 != self.signs).any():
                # an indicator changed sign with the inputs set at this communication point:
                # the event is here, before integrating on
                self._event_at_point()
                if self.ended is not None:
                    break
                x = self._states()
                z0 = self._indicators() > 0
            t_next, crossed = self._advance(t, x, t_next, z0)
            step_event, terminate = self.fmu.completedIntegratorStep(False)
            if terminate:
                self.ended = t_next
            elif crossed or step_event or t_next >= self.next_event - eps:
                self._event_at_point()
            if self.ended is None:
                self.signs = self._indicators() > 0
            t = t_next
        self.time = t_end

    def _advance(self, t: float, x: np.ndarray, t_next: float, z0: np.ndarray) -> tuple[float, bool]:
        """Integrate from (t, x) to t_next, or to the first instant past an indicator's sign
        change (bisection); leaves the FMU there. Returns (that time, whether one crossed)."""
        dt = t_next - t
        self._set(t_next, self._rk4(t, x, dt))
        crossed = bool(self.nz and ((self._indicators() > 0) != z0).any())
        if not crossed:
            return t_next, False
        low, high = 0.0, dt
        for _ in range(50):
            if high - low <= 1e-13 * max(1.0, abs(t)):
                break
            mid = 0.5 * (low + high)
            self._set(t + mid, self._rk4(t, x, mid))
            if ((self._indicators() > 0) != z0).any():
                high = mid
            else:
                low = mid
        self._set(t + high, self._rk4(t, x, high))
        return t + high, True

    def _event_at_point(self) -> None:
        self.events.append(self.time)
        self.fmu.enterEventMode()
        self._event_iteration()
        if self.ended is None:
            self.fmu.enterContinuousTimeMode()

    # -- FMU state

    def get_state(self):
        state = self.fmu.getFMUState() if self.fmi3 else self.fmu.getFMUstate()
        held = None if self.held is None else self.held.copy()
        return (state, self.time, self.next_event, self.signs, self.ended, held)

    def set_state(self, saved) -> None:
        state, self.time, self.next_event, self.signs, self.ended, held = saved
        self.held = None if held is None else held.copy()
        if self.fmi3:
            self.fmu.setFMUState(state)
        else:
            self.fmu.setFMUstate(state)

    def free_state(self, saved) -> None:
        if self.fmi3:
            self.fmu.freeFMUState(saved[0])
        else:
            self.fmu.freeFMUstate(saved[0])

    def serialize_state(self, saved) -> bytes:
        """The bytes of a state from get_state (canSerializeFMUstate)."""
        return self.fmu.serializeFMUState(saved[0]) if self.fmi3 else self.fmu.serializeFMUstate(saved[0])

    def deserialize_state(self, data: bytes, like):
        """A state made from serialized bytes, with the driver's side of `like` (the state
        they were serialized from): give it to set_state, free it with free_state."""
        state = self.fmu.deserializeFMUState(data) if self.fmi3 else self.fmu.deSerializeFMUstate(data)
        return (state, *like[1:])
