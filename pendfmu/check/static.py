"""Static checks: the model description, the binary's exports, the GUID, the capabilities.

Nothing here steps the model further than a few calls: fmpy's `validate_fmu` reads the XML
only, so the binary is asked directly whether it has every function FMI 2.0 requires for the
interfaces it declares (ctypes lookups), whether `fmi2Instantiate` refuses a GUID other than
the one in modelDescription.xml, and whether what the FMU declares it can do works.
"""

from __future__ import annotations

import ctypes
import sys

import numpy as np
from fmpy.validation import validate_fmu

from pendfmu.check.fmu import CheckResult, Driver, Target, call_error
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

WRONG_GUID = "{00000000-0000-0000-0000-000000000000}"


def library_path(target: Target, kind: str):
    platform = {"linux": "linux64", "darwin": "darwin64", "win32": "win64"}.get(sys.platform, sys.platform)
    suffix = {"linux64": ".so", "darwin64": ".dylib", "win64": ".dll"}.get(platform, ".so")
    return target.directory / "binaries" / platform / (target.interface(kind).modelIdentifier + suffix)


def check_xml(target: Target) -> CheckResult:
    problems = validate_fmu(str(target.path))
    if problems:
        return CheckResult("static: model description", False, f"{len(problems)} problems",
                           "; ".join(str(p).strip() for p in problems[:3]))
    return CheckResult("static: model description", True, f"{len(target.md.modelVariables)} variables valid")


def check_exports(target: Target, kind: str) -> CheckResult:
    name = f"static: exports {kind}"
    path = library_path(target, kind)
    if not path.is_file():
        return CheckResult(name, False, "no binary", f"{path.relative_to(target.directory)} is missing")
    try:
        library = ctypes.CDLL(str(path))
    except OSError as error:
        return CheckResult(name, False, "not loadable", str(error))
    missing = [f"fmi2{f}" for f in REQUIRED[kind] if not hasattr(library, f"fmi2{f}")]
    if missing:
        return CheckResult(name, False, f"{len(missing)} missing",
                           f"the binary does not export {', '.join(missing)} (FMI 2.0 requires them for {kind})")
    return CheckResult(name, True, f"{len(REQUIRED[kind])} functions")


def check_guid(target: Target, kind: str) -> CheckResult:
    name = f"static: GUID {kind}"
    try:
        wrong = Driver(target, kind, guid=WRONG_GUID)
    except FMUError:
        wrong = None
    if wrong is not None:
        wrong.free()
        return CheckResult(name, False, "wrong GUID accepted",
                           f"fmi2Instantiate accepted {WRONG_GUID}: the binary does not check the GUID of the "
                           f"model description it is used with")
    try:
        right = Driver(target, kind)
    except FMUError as error:
        return CheckResult(name, False, "own GUID refused",
                           f"fmi2Instantiate refused the GUID {target.md.guid} of modelDescription.xml: {error}")
    right.free()
    return CheckResult(name, True, "own accepted, wrong refused")


def check_capabilities(target: Target, kind: str) -> CheckResult:
    """What the interface declares it can do, tried: FMU state get/set, serialization round
    trip, variable communication steps (CS)."""
    name = f"static: capabilities {kind}"
    interface = target.interface(kind)
    tried = []
    unit = None
    try:
        unit = Driver(target, kind)
        unit.initialize()
        h = target.step
        unit.step(h, None)
        if interface.canGetAndSetFMUstate:
            state, time = unit.fmu.getFMUstate(), unit.time
            before = unit.outputs()

            def restores(saved) -> bool:
                """Step on, set `saved` back: the outputs are those at the save."""
                unit.step(h, None)
                unit.fmu.setFMUstate(saved)
                unit.time = time
                return np.array_equal(unit.outputs(), before, equal_nan=True)

            if not restores(state):
                return CheckResult(name, False, "state get/set",
                                   "canGetAndSetFMUstate: after fmi2SetFMUstate the outputs are not those at the save")
            tried.append("get/set state")
            if interface.canSerializeFMUstate:
                data = unit.fmu.serializeFMUstate(state)
                copy = unit.fmu.deSerializeFMUstate(data)
                if not restores(copy):
                    return CheckResult(name, False, "serialize",
                                       "canSerializeFMUstate: a deserialized state does not give the saved outputs")
                unit.fmu.freeFMUstate(copy)
                tried.append(f"serialize ({len(data)} bytes)")
            unit.fmu.freeFMUstate(state)
        if kind == "CS" and interface.canInterpolateInputs and target.inputs:
            unit.fmu.setRealInputDerivatives([target.inputs[0].valueReference], [1], [0.0])
            tried.append("input derivatives")
        reals = [v for v in target.outputs if v.type == "Real"]
        if getattr(interface, "providesDirectionalDerivative", False) and reals and target.inputs:
            slope = unit.fmu.getDirectionalDerivative([reals[0].valueReference], [target.inputs[0].valueReference],
                                                      [1.0])
            if not np.all(np.isfinite(slope)):
                return CheckResult(name, False, "directional derivative",
                                   f"providesDirectionalDerivative: d{reals[0].name}/d{target.inputs[0].name} = "
                                   f"{slope[0]} is not finite")
            tried.append("directional derivative")
        if kind == "CS" and interface.canHandleVariableCommunicationStepSize:
            unit.step(h / 2, None)
            unit.step(h / 3, None)
            tried.append("variable steps")
    except Exception as error:
        return CheckResult(name, False, "call failed", "a declared capability failed: " + call_error(error))
    finally:
        if unit is not None:
            unit.free()
    return CheckResult(name, True, ", ".join(tried) or "none declared")


def run(target: Target) -> list[CheckResult]:
    results = [check_xml(target)]
    for kind in target.interfaces:
        results.append(check_exports(target, kind))
        if not results[-1].passed:
            continue
        results.append(check_guid(target, kind))
        results.append(check_capabilities(target, kind))
    return results
