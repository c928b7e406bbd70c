"""Call sequence: misuse answered with an error status and a log message, never a crash.

The misuses, each on a fresh instance: a step before initialization (Co-Simulation: fmi2DoStep
or fmi3DoStep; Model Exchange: EnterContinuousTimeMode outside event mode), an unknown value
reference, a non-finite input (NaN, then +Inf) followed by a step, and a fixed parameter set
while stepping. Each misuse is a job of its own (`jobs`) for pendfmu/check/contain.py, in a
child process the other checks do not share: a misuse that crashes the process (a segfault)
is that misuse's FAIL row, and the others still run.

FMI makes avoiding a misuse the importer's duty and leaves detecting it, and what to do with
a non-finite input, to the FMU: a misuse accepted, an error without a message, or a NaN
carried on to the outputs is a WARN with the section that says so (STANDARD), not a FAIL.
"""

from __future__ import annotations

import math
from functools import partial

from pendfmu.check.contain import Job
from pendfmu.check.fmu import INCONCLUSIVE, WARN, CheckResult, Target
from pendfmu.check.variables import FLOAT, accessor, is_array

CASES = ("step before initialization", "unknown value reference", "NaN input", "Inf input",
         "fixed parameter set while stepping")
ERROR = 2  # fmi2Discard or worse answers a misuse


def jobs(target: Target, kind: str) -> list[Job]:
    """One job per misuse, its row named like the job; the misuses of an interface share a
    child process of their own (contain.py: what a misuse breaks must not reach other checks)."""
    return [Job(f"sequence: {case} {kind}", partial(case_rows, target, kind, case), f"sequence {kind}")
            for case in CASES]


def case_rows(target: Target, kind: str, case: str) -> list[CheckResult]:
    """The row of one misuse on a fresh instance."""
    try:
        report = _misuse(target, kind, target.step, case)
    except Exception as error:  # the checker's own trouble: said, not crashed
        report = {"status": -1, "logged": [f"{type(error).__name__}: {error}"], "call": "?"}
    return [_judge(f"sequence: {case} {kind}", case, report)]


STANDARD = {
    "accepted": ("FMI leaves detecting it to the FMU: avoiding the call is the importer's duty (FMI 2.0 sections "
                 "3.2.3, 4.2.4, the calling sequences), and an error is asked for 'when detecting' it (FMI 3.0 "
                 "section 2.2.3, Status Returned by Functions)"),
    "silent": ("FMI leaves it to the FMU: it 'should' log why, as its logging settings (off here) allow "
               "(FMI 3.0 section 2.2.3, FMI 2.0 section 2.1.3, Status Returned by Functions)"),
    "non-finite": ("FMI has no rule for a non-finite input: refusing it or carrying it on is the FMU's choice "
                   "(FMI 2.0 section 2.1.3, FMI 3.0 section 2.2.3, Status Returned by Functions)"),
}
"""Why a row is a WARN: what FMI leaves to the FMU, with the section that says so."""


def _judge(name: str, case: str, report: dict) -> CheckResult:
    """PASS: the misuse answered with an error status and a message, or a non-finite input
    kept away from the outputs; WARN: what FMI leaves to the FMU (STANDARD); INCONCLUSIVE:
    the misuse does not apply or could not be set up (the check's trouble, not the FMU's)."""
    if report.get("skip"):
        return CheckResult(name, INCONCLUSIVE, "not applicable", report["skip"])
    status, logged, what = report["status"], report["logged"], report["call"]
    if status < 0:
        return CheckResult(name, INCONCLUSIVE, "not run",
                           f"the check could not set the misuse up: {logged[0] if logged else '?'}")
    said = f"; it logged: {logged[0]}" if logged else ""
    if status >= ERROR:
        if not logged:
            return CheckResult(name, WARN, f"{what} status {status}, nothing logged",
                               f"{what} answered a {case} with status {status} but logged no message saying why: "
                               f"{STANDARD['silent']}")
        return CheckResult(name, True, f"{what} status {status}, logged", logged[0][:100])
    if report.get("nan_outputs"):
        through = report.get("depends") or []
        how = f" (they depend on {report['input']} in the model structure)" if through else ""
        return CheckResult(name, WARN, "OK with non-finite outputs",
                           f"after {report['input']} = {report['value']} every call returned OK and the outputs "
                           f"{', '.join(report['nan_outputs'])} are not finite{how}{said}; {STANDARD['non-finite']}")
    if case in ("NaN input", "Inf input"):  # accepted, and the outputs stayed finite: harmless
        return CheckResult(name, True, "accepted, outputs finite", "")
    return CheckResult(name, WARN, f"{what} returned status {status}",
                       f"a {case} was accepted ({what} returned status {status}) instead of an error{said}; "
                       f"{STANDARD['accepted']}")


def _attempt(unit, call: str, function, *args) -> dict:
    """Call `function`: its status (an FMUError's, else 0) and the first messages it logged."""
    from pendfmu.errors import FMUError

    before = len(unit.messages)
    try:
        function(*args)
        status = 0
    except FMUError as error:  # no status: the FMU asked to terminate (Model Exchange), a refusal too
        status = ERROR if error.status is None else error.status
    return {"status": status, "logged": unit.messages[before:][:3], "call": call}


def _misuse(target: Target, kind: str, step: float, case: str) -> dict:
    from pendfmu.check.fmu import Driver

    unit = Driver(target, kind)
    prefix = "fmi3" if target.fmi3 else "fmi2"
    try:
        if case == "step before initialization":
            if kind == "CS":
                return _attempt(unit, f"{prefix}DoStep", lambda: unit.fmu.doStep(0.0, step))
            return _attempt(unit, f"{prefix}EnterContinuousTimeMode", unit.fmu.enterContinuousTimeMode)
        unit.initialize()
        if case == "unknown value reference":
            unknown = max((v.valueReference for v in target.md.modelVariables), default=0) + 1000
            getter = "Float64" if target.fmi3 else "Real"
            return _attempt(unit, f"{prefix}Get{getter}", lambda: getattr(unit.fmu, "get" + getter)([unknown]))
        if case in ("NaN input", "Inf input"):
            return _non_finite_input(unit, step, math.nan if case == "NaN input" else math.inf)
        if case == "fixed parameter set while stepping":
            return _fixed_parameter(unit, step)
        raise ValueError(f"unknown misuse {case!r}")
    finally:
        unit.free()


def _setter(unit, v) -> tuple[str, object]:
    """(the C function's name, the Python method) that sets variable v."""
    suffix = accessor(v.type, unit.fmi3)
    return f"{'fmi3' if unit.fmi3 else 'fmi2'}Set{suffix}", getattr(unit.fmu, "set" + suffix)


def _non_finite_input(unit, step: float, value: float) -> dict:
    """The first floating-point input (a continuous one where there is one: Model Exchange
    takes a discrete input in an event only) set to NaN or Inf, then a step."""
    target = unit.target
    if not target.inputs:
        return {"skip": "no floating-point inputs to set"}
    v = min(target.inputs, key=lambda u: u.variability != "continuous")
    function, setter = _setter(unit, v)
    report = _attempt(unit, f"{function}({v.name})", lambda: setter([v.valueReference], [value]))
    if report["status"] >= ERROR:
        return report
    stepped = _attempt(unit, f"{'fmi3' if unit.fmi3 else 'fmi2'}DoStep" if unit.kind == "CS" else "a step",
                       lambda: unit.step(step, None))
    if stepped["status"] >= ERROR:
        stepped["logged"] = report["logged"] + stepped["logged"]
        return stepped
    outputs = unit.outputs()
    stepped["nan_outputs"] = [o.name for o, x in zip(target.outputs, outputs) if not math.isfinite(x)]
    stepped["depends"] = _depending_on(target, v, stepped["nan_outputs"])
    stepped["input"], stepped["value"] = v.name, str(value)
    stepped["call"] = f"{function}({v.name}) and a step"
    return stepped


def _depending_on(target: Target, source, names: list[str]) -> list[str]:
    """Which of the outputs `names` the model structure says depend on `source` (an output
    without a dependencies list depends on everything, FMI's default)."""
    depending = []
    for unknown in getattr(target.md, "outputs", []) or []:
        dependencies = getattr(unknown, "dependencies", None)
        if unknown.variable.name in names and (dependencies is None or source in dependencies):
            depending.append(unknown.variable.name)
    return depending


def _fixed_parameter(unit, step: float) -> dict:
    """A step, then the first fixed floating-point parameter set to its own start value."""
    fixed = [v for v in unit.target.md.modelVariables if v.causality == "parameter" and v.variability == "fixed"
             and v.type in FLOAT and not is_array(v)]
    if not fixed:
        return {"skip": "no fixed floating-point parameters"}
    v = fixed[0]
    unit.step(step, None)
    value = float(v.start) if v.start is not None else 0.0
    function, setter = _setter(unit, v)
    return _attempt(unit, f"{function}({v.name})", lambda: setter([v.valueReference], [value]))

