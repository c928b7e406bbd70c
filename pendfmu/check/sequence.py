"""Call sequence: misuse must be answered with an error status and a log message, never a
crash, and never an OK that leaves NaN in the outputs.

The misuses, each on a fresh instance: a step before initialization (Co-Simulation: fmi2DoStep;
Model Exchange: fmi2EnterContinuousTimeMode outside event mode), an unknown value reference,
a non-finite input (NaN, then +Inf) followed by a step, and a fixed parameter set while
stepping. They run in a child process (`python -m pendfmu.check.sequence FMU KIND`) that
prints one JSON line per misuse; a child that dies (a segfault) reports the misuse it was
on as "crashed", and a new child goes on with the rest.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

from pendfmu.check.fmu import CheckResult, Target

CASES = ("step before initialization", "unknown value reference", "NaN input", "Inf input",
         "fixed parameter set while stepping")
ERROR = 2  # fmi2Discard or worse answers a misuse
CHILD = [sys.executable, "-m", "pendfmu.check.sequence"]
"""The child's command line, before its arguments (FMU KIND STEP CASE...)."""


def run(target: Target, kind: str) -> list[CheckResult]:
    reports: dict[str, dict] = {}
    remaining = list(CASES)
    while remaining:
        command = [*CHILD, str(target.path.resolve()), kind, str(target.step), *remaining]
        package = str(Path(__file__).resolve().parents[2])  # this pendfmu, whatever the child's path
        env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [package, os.environ.get("PYTHONPATH")])))
        done = subprocess.run(command, capture_output=True, text=True, timeout=120, env=env)
        for line in done.stdout.splitlines():
            if line.startswith("{"):
                report = json.loads(line)
                reports[report["case"]] = report
        left = [case for case in remaining if case not in reports]
        if done.returncode != 0 and left:
            reason = f"signal {-done.returncode}" if done.returncode < 0 else f"exit code {done.returncode}"
            reports[left[0]] = {"case": left[0], "crashed": reason,
                                "stderr": done.stderr.strip().splitlines()[-1:] or [""]}
            left = left[1:]
        elif left:
            break
        remaining = left
    results = []
    for case in CASES:
        name = f"sequence: {case} {kind}"
        report = reports.get(case)
        if report is None:
            results.append(CheckResult(name, False, "no answer", "the child process reported nothing"))
        elif "crashed" in report:
            results.append(CheckResult(name, False, "crashed", f"the FMU crashed the process ({report['crashed']}) "
                                       f"on the misuse '{case}': {report['stderr'][0]}"))
        else:
            results.append(_judge(name, case, report))
    return results


def _judge(name: str, case: str, report: dict) -> CheckResult:
    if report.get("skip"):
        return CheckResult(name, True, "not applicable", report["skip"])
    status, logged, what = report["status"], report["logged"], report["call"]
    if status < 0:  # the child could not set the misuse up: the checker's trouble, said as such
        return CheckResult(name, False, "not run", f"the misuse could not be set up: {logged[0] if logged else '?'}")
    said = f"; it logged: {logged[0]}" if logged else ""
    if status >= ERROR:
        if not logged:
            return CheckResult(name, False, f"{what} status {status}, nothing logged",
                               f"{what} answered a {case} with status {status} but logged no message saying why")
        return CheckResult(name, True, f"{what} status {status}, logged", logged[0][:100])
    if report.get("nan_outputs"):
        return CheckResult(name, False, "OK with NaN outputs",
                           f"after a {case} every call returned OK but the outputs {', '.join(report['nan_outputs'])} "
                           f"are not finite{said}")
    if case in ("NaN input", "Inf input"):  # accepted, and the outputs stayed finite: harmless
        return CheckResult(name, True, "accepted, outputs finite", "")
    return CheckResult(name, False, f"{what} returned status {status}",
                       f"a {case} was accepted ({what} returned status {status}) instead of an error{said}")


# -- the child process

def _child(path: str, kind: str, step: float, cases: list[str]) -> None:
    target = Target(path)
    for case in cases:
        report = {"case": case}
        try:
            report.update(_misuse(target, kind, step, case))
        except Exception as error:  # the checker's own trouble: said, not crashed
            report.update(status=-1, logged=[f"{type(error).__name__}: {error}"], call="?")
        print(json.dumps(report), flush=True)


def _misuse(target: Target, kind: str, step: float, case: str) -> dict:
    from pendfmu.check.fmu import Driver
    from pendfmu.errors import FMUError

    unit = Driver(target, kind)
    fmu = unit.fmu

    def attempt(call: str, function, *args) -> dict:
        before = len(unit.messages)
        try:
            function(*args)
            status = 0
        except FMUError as error:  # no status: the FMU asked to terminate (Model Exchange), a refusal too
            status = ERROR if error.status is None else error.status
        return {"status": status, "logged": unit.messages[before:][:3], "call": call}

    try:
        if case == "step before initialization":
            if kind == "CS":
                return attempt("fmi2DoStep", lambda: fmu.doStep(0.0, step))
            return attempt("fmi2EnterContinuousTimeMode", fmu.enterContinuousTimeMode)
        unit.initialize()
        if case == "unknown value reference":
            used = {v.valueReference for v in target.md.modelVariables}
            unknown = max(used, default=0) + 1000
            return attempt("fmi2GetReal", lambda: fmu.getReal([unknown]))
        if case in ("NaN input", "Inf input"):
            if not target.inputs:
                return {"skip": "no Real inputs"}
            value = math.nan if case == "NaN input" else math.inf
            v = target.inputs[0]
            report = attempt(f"fmi2SetReal({v.name})", lambda: fmu.setReal([v.valueReference], [value]))
            if report["status"] >= ERROR:
                return report
            stepped = attempt("fmi2DoStep" if kind == "CS" else "a step", lambda: unit.step(step, None))
            if stepped["status"] >= ERROR:
                stepped["logged"] = report["logged"] + stepped["logged"]
                return stepped
            outputs = unit.outputs()
            stepped["nan_outputs"] = [o.name for o, x in zip(target.outputs, outputs) if not math.isfinite(x)]
            stepped["call"] = f"fmi2SetReal({v.name}) and a step"
            return stepped
        if case == "fixed parameter set while stepping":
            fixed = [v for v in target.md.modelVariables if v.causality == "parameter" and v.variability == "fixed"
                     and v.type == "Real"]
            if not fixed:
                return {"skip": "no fixed Real parameters"}
            v = fixed[0]
            unit.step(step, None)
            value = float(v.start) if v.start is not None else 0.0
            return attempt(f"fmi2SetReal({v.name})", lambda: fmu.setReal([v.valueReference], [value]))
        raise ValueError(f"unknown misuse {case!r}")
    finally:
        unit.free()


if __name__ == "__main__":
    _child(sys.argv[1], sys.argv[2], float(sys.argv[3]), sys.argv[4:])
