"""Static checks: the model description, the binary's exports, the GUID or instantiation
token, the capabilities.

Nothing here steps the model further than a few calls: fmpy's `validate_fmu` reads the XML
only, and so do the checks of what it leaves out (`description_rows`: variable ranges, an
interface at all, file names the loader may build); then the binary is asked directly whether
it has every function FMI requires for the interfaces it declares (ctypes lookups), whether
instantiation refuses a GUID (FMI 2.0) or instantiation token (FMI 3.0) other than the one in
modelDescription.xml, and whether what the FMU declares it can do works (`run`, one
job per interface in a child process: pendfmu/check/contain.py). An FMU whose file names FMI
does not allow gets no binary rows: nothing of it is loaded.
"""

from __future__ import annotations

import ctypes
import platform
import sys

import numpy as np
from fmpy.validation import validate_fmu

from pendfmu.check.driver import StiffModel
from pendfmu.check.fmu import INCONCLUSIVE, WARN, CheckResult, Driver, Target, call_error
from pendfmu.check.variables import FLOAT, Element
from pendfmu.errors import FMUError

COMMON = ("GetTypesPlatform", "GetVersion", "SetDebugLogging", "Instantiate", "FreeInstance", "SetupExperiment",
          "EnterInitializationMode", "ExitInitializationMode", "Terminate", "Reset", "GetReal", "GetInteger",
          "GetBoolean", "GetString", "SetReal", "SetInteger", "SetBoolean", "SetString", "GetFMUstate",
          "SetFMUstate", "FreeFMUstate", "SerializedFMUstateSize", "SerializeFMUstate", "DeSerializeFMUstate",
          "GetDirectionalDerivative")
REQUIRED = {
    "ME": COMMON + ("EnterEventMode", "NewDiscreteStates", "EnterContinuousTimeMode", "CompletedIntegratorStep",
                    "SetTime", "SetContinuousStates", "GetDerivatives", "GetEventIndicators", "GetContinuousStates",
                    "GetNominalsOfContinuousStates"),
    "CS": COMMON + ("SetRealInputDerivatives", "GetRealOutputDerivatives", "DoStep", "CancelStep", "GetStatus",
                    "GetRealStatus", "GetIntegerStatus", "GetBooleanStatus", "GetStringStatus"),
}
"""The functions FMI 2.0 requires a binary to export for each interface it declares (without
the "fmi2" prefix); those of an optional capability are required too, as stubs."""

TYPES3 = ("Float32", "Float64", "Int8", "UInt8", "Int16", "UInt16", "Int32", "UInt32", "Int64", "UInt64", "Boolean",
          "String", "Binary", "Clock")
COMMON3 = (("GetVersion", "SetDebugLogging", "FreeInstance", "EnterInitializationMode", "ExitInitializationMode",
            "EnterEventMode", "Terminate", "Reset")
           + tuple(f"{way}{t}" for t in TYPES3 for way in ("Get", "Set"))
           + ("GetNumberOfVariableDependencies", "GetVariableDependencies", "GetFMUState", "SetFMUState",
              "FreeFMUState", "SerializedFMUStateSize", "SerializeFMUState", "DeserializeFMUState",
              "GetDirectionalDerivative", "GetAdjointDerivative", "EnterConfigurationMode", "ExitConfigurationMode",
              "GetIntervalDecimal", "GetIntervalFraction", "GetShiftDecimal", "GetShiftFraction",
              "SetIntervalDecimal", "SetIntervalFraction", "SetShiftDecimal", "SetShiftFraction",
              "EvaluateDiscreteStates", "UpdateDiscreteStates"))
REQUIRED3 = {
    "ME": COMMON3 + ("InstantiateModelExchange", "EnterContinuousTimeMode", "CompletedIntegratorStep", "SetTime",
                     "SetContinuousStates", "GetContinuousStateDerivatives", "GetEventIndicators",
                     "GetContinuousStates", "GetNominalsOfContinuousStates", "GetNumberOfEventIndicators",
                     "GetNumberOfContinuousStates"),
    "CS": COMMON3 + ("InstantiateCoSimulation", "EnterStepMode", "GetOutputDerivatives", "DoStep"),
}
"""The functions FMI 3.0 requires for each interface (section 2.5, FMU Distribution: the
common functions and all of the interface's, present "even if they are only needed for
optional capabilities"); of the three instantiation functions only the interface's own."""

WRONG_GUID = "{00000000-0000-0000-0000-000000000000}"


def library_path(target: Target, kind: str):
    """binaries/<platform>/<modelIdentifier>.<suffix>: FMI 2.0's platform names (linux64) or
    FMI 3.0's platform tuples (x86_64-linux)."""
    system = {"linux": "linux", "darwin": "darwin", "win32": "win"}.get(sys.platform, sys.platform)
    if target.fmi3:
        machine = {"amd64": "x86_64", "arm64": "aarch64"}.get(platform.machine().lower(), platform.machine().lower())
        folder = f"{machine}-{'windows' if system == 'win' else system}"
    else:
        folder = f"{system}64"
    suffix = {"linux": ".so", "darwin": ".dylib", "win": ".dll"}.get(system, ".so")
    return target.directory / "binaries" / folder / (target.interface(kind).modelIdentifier + suffix)


def check_xml(target: Target) -> CheckResult:
    """fmpy's validation, the file names (simulator.fmi.unsafe_names) and the variable ranges."""
    problems = ([target.refused] if target.refused else []) + [str(p).strip() for p in validate_fmu(str(target.path))]
    problems += range_problems(target.md.modelVariables)
    if problems:
        count = f"{len(problems)} problem{'s' if len(problems) > 1 else ''}"
        return CheckResult("static: model description", False, count, "; ".join(problems[:3]))
    figure = "; ".join([f"FMI {target.md.fmiVersion}, {len(target.md.modelVariables)} variables valid",
                        *target.unchecked, *([target.shortened] if target.shortened else [])])
    return CheckResult("static: model description", True, figure)


def range_problems(variables) -> list[str]:
    """Each variable whose declared min exceeds its max, or whose start value (every element
    of an array's) lies outside [min, max]: FMI requires min <= start <= max."""
    problems = []
    for v in variables:
        low, high = _number(getattr(v, "min", None)), _number(getattr(v, "max", None))
        if low is not None and high is not None and low > high:
            problems.append(f"variable {v.name}: min {low:g} exceeds max {high:g} (FMI: min <= max)")
            continue
        starts = [_number(part) for part in str(v.start).split()] if getattr(v, "start", None) is not None else []
        bounds = (-np.inf if low is None else low, np.inf if high is None else high)
        outside = [x for x in starts if x is not None and not bounds[0] <= x <= bounds[1]]
        if outside:
            problems.append(f"variable {v.name}: start {outside[0]:g} outside [{bounds[0]:g}, {bounds[1]:g}] "
                            f"(FMI: min <= start <= max)")
    return problems


def _number(text) -> float | None:
    try:
        return float(text) if text is not None else None
    except (TypeError, ValueError):
        return None  # not a number (a Boolean's true): no range to check


def check_exports(target: Target, kind: str) -> CheckResult:
    name = f"static: exports {kind}"
    path = library_path(target, kind)
    if not path.is_file():
        return CheckResult(name, False, "no binary", f"{path.relative_to(target.directory)} is missing")
    try:
        library = ctypes.CDLL(str(path))
    except OSError as error:
        return CheckResult(name, False, "not loadable", str(error))
    prefix, required = ("fmi3", REQUIRED3[kind]) if target.fmi3 else ("fmi2", REQUIRED[kind])
    missing = [f"{prefix}{f}" for f in required if not hasattr(library, f"{prefix}{f}")]
    if missing:
        return CheckResult(name, False, f"{len(missing)} missing",
                           f"the binary does not export {', '.join(missing)} (FMI {target.md.fmiVersion} requires "
                           f"them for {kind})")
    return CheckResult(name, True, f"{len(required)} functions")


def check_guid(target: Target, kind: str) -> CheckResult:
    """The binary accepts the GUID (FMI 2.0) or instantiation token (FMI 3.0) of its model
    description, and refuses another: a WARN if it accepts one, as FMI 2.0 section 2.1.5
    (fmi2Instantiate) and FMI 3.0 (fmi3InstantiateXXX, in the state FMU State Setable) say the
    FMU "can" use it to check the XML, not that it must."""
    token = "instantiation token" if target.fmi3 else "GUID"
    name = f"static: {token} {kind}"
    instantiate = target_instantiate(target, kind)
    try:
        wrong = Driver(target, kind, guid=WRONG_GUID)
    except FMUError:
        wrong = None
    if wrong is not None:
        wrong.free()
        return CheckResult(name, WARN, f"wrong {token} accepted",
                           f"{instantiate} accepted {WRONG_GUID}: the binary does not check that the model "
                           f"description it is used with is its own (FMI lets it: the {token} 'can be used' for that)")
    try:
        right = Driver(target, kind)
    except FMUError as error:
        return CheckResult(name, False, f"own {token} refused",
                           f"{instantiate} refused the {token} {target.md.guid} of modelDescription.xml: {error}")
    right.free()
    return CheckResult(name, True, "own accepted, wrong refused")


def target_instantiate(target: Target, kind: str) -> str:
    if not target.fmi3:
        return "fmi2Instantiate"
    return "fmi3InstantiateCoSimulation" if kind == "CS" else "fmi3InstantiateModelExchange"


def check_capabilities(target: Target, kind: str) -> CheckResult:
    """What the interface declares it can do, tried: FMU state get/set, serialization round
    trip, input derivatives (FMI 2.0 CS), directional derivatives, variable communication
    steps (CS)."""
    name = f"static: capabilities {kind}"
    interface = target.interface(kind)
    tried: list[str] = []
    unit = None
    try:
        unit = Driver(target, kind)
        unit.initialize()
        unit.step(target.step, None)
        problem = _states(unit, interface, tried) or _derivatives(unit, interface, tried)
        if problem:
            return CheckResult(name, False, *problem)
        if kind == "CS" and interface.canHandleVariableCommunicationStepSize:
            unit.step(target.step / 2, None)
            unit.step(target.step / 3, None)
            tried.append("variable steps")
    except StiffModel as error:
        return CheckResult(name, INCONCLUSIVE, "not run to the end", str(error))
    except Exception as error:
        return CheckResult(name, False, "call failed", "a declared capability failed: " + call_error(error))
    finally:
        if unit is not None:
            unit.free()
    return CheckResult(name, True, ", ".join(tried) or "none declared")


def _states(unit: Driver, interface, tried: list[str]) -> tuple[str, str] | None:
    """canGetAndSetFMUstate and canSerializeFMUstate: a state saved, stepped past and set
    back gives the outputs at the save, and so does one serialized and deserialized.
    (figure, message) of what failed, else None."""
    if not interface.canGetAndSetFMUstate:
        return None
    saved, before = unit.get_state(), unit.outputs()

    def restores(state) -> bool:
        unit.step(unit.target.step, None)
        unit.set_state(state)
        return np.array_equal(unit.outputs(), before, equal_nan=True)

    setter = "fmi3SetFMUState" if unit.fmi3 else "fmi2SetFMUstate"
    if not restores(saved):
        return "state get/set", f"canGetAndSetFMUstate: after {setter} the outputs are not those at the save"
    tried.append("get/set state")
    if interface.canSerializeFMUstate:
        data = unit.serialize_state(saved)
        copy = unit.deserialize_state(data, saved)
        if not restores(copy):
            return "serialize", "canSerializeFMUstate: a deserialized state does not give the saved outputs"
        unit.free_state(copy)
        tried.append(f"serialize ({len(data)} bytes)")
    unit.free_state(saved)
    return None


def _derivatives(unit: Driver, interface, tried: list[str]) -> tuple[str, str] | None:
    """Input derivatives (FMI 2.0 CS canInterpolateInputs: FMI 3.0 has no such function) and
    a directional derivative of the first floating-point output by the first input."""
    target = unit.target
    if unit.kind == "CS" and not unit.fmi3 and interface.canInterpolateInputs and target.inputs:
        unit.fmu.setRealInputDerivatives([target.inputs[0].valueReference], [1], [0.0])
        tried.append("input derivatives")
    declared = getattr(interface, "providesDirectionalDerivative", False) or getattr(
        interface, "providesDirectionalDerivatives", False)
    floats = [v for v in target.outputs if v.type in FLOAT and not isinstance(v, Element)]
    if declared and floats and target.inputs:
        slope = unit.fmu.getDirectionalDerivative([floats[0].valueReference], [target.inputs[0].valueReference], [1.0])
        if not np.all(np.isfinite(slope)):
            return "directional derivative", (f"providesDirectionalDerivative: d{floats[0].name}/"
                                              f"d{target.inputs[0].name} = {slope[0]} is not finite")
        tried.append("directional derivative")
    return None


def description_rows(target: Target) -> list[CheckResult]:
    """The rows read from the model description alone (nothing loaded): its validity, and an
    interface to check: none at all is a FAIL (FMI requires one), Scheduled Execution only
    INCONCLUSIVE (pendfmu check drives Co-Simulation and Model Exchange)."""
    results = [check_xml(target)]
    if not target.interfaces and not target.refused:
        offered = getattr(target.md, "scheduledExecution", None) is not None
        results.append(CheckResult(
            "static: interfaces", INCONCLUSIVE if offered else False, "no Co-Simulation or Model Exchange",
            f"{target.name} offers Scheduled Execution only; pendfmu check drives Co-Simulation and Model Exchange, "
            f"so nothing ran" if offered else
            f"{target.name} declares no interface (FMI requires a <CoSimulation> or <ModelExchange> element, or FMI "
            f"3.0's <ScheduledExecution>): nothing can run it"))
    return results


def run(target: Target, kind: str) -> list[CheckResult]:
    """The rows that load the binary for one interface (a job of its own: contain.py)."""
    results = [check_exports(target, kind)]
    if results[-1].passed:
        results += [check_guid(target, kind), check_capabilities(target, kind)]
    return results
