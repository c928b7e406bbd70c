"""The one checked binding to FMU binaries: every FMI call goes through one wrapper.

fmpy mirrors each C function of the FMI standard by a method that hands its arguments to
one function, `_call`, and offers Pythonic methods above those (getReal, doStep,
getFMUstate, ...). The classes here are fmpy's with that one function replaced: a call
that returns a status worse than Warning raises pendfmu.errors.FMUError naming the
instance, the function, the time and what the FMU logged during the call, so that the
simulator, the check battery and the pytest plugin all meet the same error. Besides, they
keep what the FMU logs, build fmpy's table of the C functions once per class instead of
once per instance (fmpy inspects every function's signature: 2 ms of the 3 ms an FMU takes
to load), and give the native loop (native.py) the C functions' addresses.

    fmu = instantiate_fmu(directory, description, "CS")   # FMI 2.0 or 3.0, "CS" or "ME"
    fmu.setupExperiment(startTime=0.0)                    # fmpy's methods, every one checked
    ...
    fmu.close()

`unpacked_fmu` unpacks an FMU once per file and GUID; the classes are picked by the model
description's FMI version and the interface (CLASSES). Neither loads a library from an FMU
whose model description names a file the standard does not allow (`refuse_unsafe_names`): the
loader builds binaries/<platform>/<modelIdentifier>.<suffix>, and a modelIdentifier such as
"../../x/evil" would load any library on the machine.
"""

from __future__ import annotations

import ctypes
import itertools
import re
import weakref
from pathlib import Path, PurePosixPath

from fmpy import calloc, extract, free
from fmpy.fmi1 import printLogMessage
from fmpy.fmi2 import (FMU2Model, FMU2Slave, fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                       fmi2CallbackFunctions, fmi2CallbackLoggerTYPE)
from fmpy.fmi3 import FMU3Model, FMU3Slave
from fmpy.logging import addLoggerProxy

from pendfmu.errors import BadInput, FMUError
from pendfmu.tempfolders import temporary_folder

WARNING = 1
"""fmi2Status and fmi3Status: a call that returns more than Warning failed."""
STATUS = ("OK", "Warning", "Discard", "Error", "Fatal", "Pending")

TIME_ARGUMENT = {"fmi2SetupExperiment": 3, "fmi2SetTime": 1, "fmi2DoStep": 1,
                 "fmi3EnterInitializationMode": 3, "fmi3SetTime": 1, "fmi3DoStep": 1}
"""The position of the time among a function's arguments (after the instance): the time
the instance is at from that call on, and that a failure is reported at."""
STEP_SIZE = {"fmi2DoStep": 2, "fmi3DoStep": 2}
"""Where a step's size is: after a step the instance is that much further."""

_UNPACKED: dict[str, tuple[Path, object]] = {}
C_IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


class UnsafeFMU(BadInput):
    """A model description that names a file the FMI standard does not allow (a modelIdentifier
    that is not a C identifier, a source file outside the sources folder): nothing of the FMU
    is loaded. `description` is the model description refused."""

    def __init__(self, message: str, description=None):
        super().__init__(message)
        self.description = description


def unsafe_names(description) -> list[str]:
    """What in a model description names a file outside what FMI allows, each in words: every
    interface's and build configuration's modelIdentifier must be a C identifier (FMI 2.0 and
    3.0: a name in C syntax that names the binary and prefixes its functions), and every source
    file and include folder must stay inside the sources folder."""
    named = [(f"<{element} modelIdentifier>", getattr(interface, "modelIdentifier", None))
             for element, interface in (("CoSimulation", description.coSimulation),
                                        ("ModelExchange", description.modelExchange),
                                        ("ScheduledExecution", getattr(description, "scheduledExecution", None)))
             if interface is not None]
    files = []
    for build in getattr(description, "buildConfigurations", None) or []:
        named.append(("<BuildConfiguration modelIdentifier>", build.modelIdentifier))
        for fileset in build.sourceFileSets:
            files += [("<SourceFiles><File name>", name) for name in fileset.sourceFiles]
            files += [("<IncludeDirectory name>", name) for name in fileset.includeDirectories]
    problems = [f"{where} {value!r} is not a C identifier (FMI: letters, digits and '_', not starting with a digit)"
                for where, value in named if not isinstance(value, str) or not C_IDENTIFIER.fullmatch(value)]
    problems += [f"{where} {value!r} leaves the FMU's sources folder" for where, value in files
                 if not _inside(value)]
    return problems


def _inside(name) -> bool:
    """A relative POSIX path that stays where it is put: no '..', no root, drive or backslash."""
    if not isinstance(name, str) or not name or any(c in name for c in "\\:\0"):
        return False
    path = PurePosixPath(name)
    return not path.is_absolute() and ".." not in path.parts


def refuse_unsafe_names(fmu, description) -> None:
    """UnsafeFMU (bad input, exit 2) naming the FMU and the attribute, before anything is loaded."""
    problems = unsafe_names(description)
    if problems:
        raise UnsafeFMU(f"{fmu}: {problems[0]}; pendfmu loads no library from it", description)


def unpacked_fmu(name: str, fmu: str | Path | None = None, copy: int = 0) -> tuple[Path, object]:
    """Unpack a component's FMU into a temporary folder, once per GUID, and read its model
    description.

    The unpacked copy is shared by every instance in the process, so a fit that runs an FMU
    thousands of times unzips it once; its names are checked on every call (the file may
    have changed under the same GUID).

    Parameters
    ----------
    name : str
        A pendfmu component ("CurrentLoop", "Cart", "Pendulum", ...:
        components.ALL_COMPONENTS); without `fmu` it is built from source if needed. With
        `fmu`, a label for the temporary folder.
    fmu : str or Path, optional
        The FMU file to use instead (an FMU from an .ssp archive, or an exported,
        re-parameterized one).
    copy : int, optional
        0 for the shared copy; a number > 0 unpacks another copy, whose binary is loaded as
        a library of its own, with its own globals, so that instances in different threads
        share nothing (see Residuals' Jacobian threads).

    Returns
    -------
    directory : Path
        The folder the FMU is unpacked into (removed when the process ends).
    description : fmpy.model_description.ModelDescription
        The FMU's model description, as fmpy reads it.
    """
    from pendfmu.fmubuild import ensure_fmu
    from pendfmu.fmubuild.compiler import model_description

    path = Path(fmu) if fmu is not None else ensure_fmu(name)
    md = model_description(path)
    refuse_unsafe_names(path, md)  # on every call: the file may have changed under the same GUID
    key = f"{path.resolve()}:{md.guid}:{copy}"
    if key not in _UNPACKED:
        directory = temporary_folder(f"pendfmu-{name}-")
        extract(str(path), str(directory))
        _UNPACKED[key] = (directory, md)
    return _UNPACKED[key]


class CheckedFMU:
    """What pendfmu adds to fmpy's FMU classes (a mixin, first among a class's bases).

    Attributes:
        messages: what the FMU logged, oldest first (its logger callback appends them).
        time: the instance's time as its last timed call left it (TIME_ARGUMENT); None
            before the first.
    """

    INSTANTIATE = ""  # the C function that creates an instance: named when it refuses
    _tables: dict[type, list] = {}

    def __init__(self, **kwargs):
        self.messages: list[str] = []
        self.time: float | None = None
        super().__init__(**kwargs)

    def _loadFunctions(self) -> None:
        """fmpy's table of C functions (argument and result types), built by fmpy for the
        first instance of each class and set on the same C functions for the others."""
        table = CheckedFMU._tables.get(type(self))
        if table is None:
            super()._loadFunctions()
            CheckedFMU._tables[type(self)] = [(name, f.argnames, f.argtypes, f.restype)
                                              for name, f in self._functions.items()]
            return
        for name, argnames, argtypes, restype in table:
            function = getattr(self.dll, name)
            function.argnames, function.argtypes, function.restype = argnames, argtypes, restype
            self._functions[name] = function

    def call(self, name: str, *args):
        """The one wrapper every FMI call goes through: fmpy's methods call it by name (as
        `_call`), and so can a caller that passes the C arguments itself, where fmpy's
        Pythonic layer costs more than the call (ComponentFMU's restart, once per run)."""
        function = self._functions[name]
        logged = len(self.messages)
        at = TIME_ARGUMENT.get(name)
        time = self.time if at is None else args[at]
        result = function(*args)
        if function.restype is ctypes.c_int and result > WARNING:
            label = STATUS[result] if 0 <= result < len(STATUS) else f"status {result}"
            raise self.failure(f"{name} returned {label}", name, logged, time, result)
        if at is not None:  # the instance is at the call's time now, after a step at its end
            self.time = time + args[STEP_SIZE[name]] if name in STEP_SIZE else time
        return result

    _call = call  # the name fmpy's methods use

    def failure(self, what: str, function: str | None = None, since: int = 0, time: float | None = None,
                status: int | None = None) -> FMUError:
        """The FMUError of a failed call: `what` went wrong (in `function`), the instance at
        `time` (default: its own), with what the FMU logged from message `since` on. Also
        for a failure the native loop reports, which knows the time but not the function."""
        time = self.time if time is None else time
        where = self.instanceName + ("" if time is None else f" at t = {float(time):.9g} s")
        logged = [message for message in self.messages[since:] if message]
        said = f"{'; '.join(logged[-3:])} ({what})" if logged else f"{what}; the FMU logged nothing"
        return FMUError(f"{where}: {said}", instance=self.instanceName, function=function,
                        time=None if time is None else float(time), messages=logged, status=status)

    def _log(self, message: bytes | None) -> None:
        self.messages.append(message.decode("utf-8", "replace") if message else "")

    def open(self, logging: bool = False) -> None:
        """Instantiate, with a logger that keeps the FMU's messages; FMUError if refused."""
        logged = len(self.messages)
        try:
            self._instantiate(logging)  # FMI2Logging's or FMI3Logging's
        except Exception as error:
            if type(error) is not Exception or self.component:  # fmpy's bare Exception: a NULL instance
                raise
            raise self.failure(f"{self.INSTANTIATE} returned no instance", self.INSTANTIATE, logged) from None

    def close(self) -> None:
        """Terminate (where allowed) and free the instance; fmpy unloads the library too."""
        if not self.component:
            return
        try:
            self.terminate()
        except FMUError:
            pass  # not running (instantiated, reset, or in error): freeing is allowed from any phase
        self.freeInstance()
        self.component = None

    def address(self, function: str) -> int:
        """The address of a C function of the FMU's library (for the native loop)."""
        return ctypes.cast(getattr(self.dll, function), ctypes.c_void_p).value


_BY_ENVIRONMENT: weakref.WeakValueDictionary[int, CheckedFMU] = weakref.WeakValueDictionary()
_ENVIRONMENTS = itertools.count(1)


def _route(environment, instance_name, status, category, message) -> None:
    """The one logger of every FMI 2.0 instance: fmpy's logger proxy (a C function that
    formats the FMU's printf-style arguments) keeps a single Python logger for the whole
    process, so each instance's callbacks carry an environment of its own, and this hands
    the message to that instance. A message of an instance made elsewhere is printed, as
    fmpy's default logger does."""
    fmu = _BY_ENVIRONMENT.get(environment)
    if fmu is None:
        printLogMessage(environment, instance_name, status, category, message)
    else:
        fmu._log(message)


_ROUTE = fmi2CallbackLoggerTYPE(_route)


class FMI2Logging:
    """FMI 2.0's instantiation: the logger sits in a callback structure."""

    def _instantiate(self, logging: bool) -> None:
        callbacks = fmi2CallbackFunctions()
        callbacks.logger = _ROUTE
        callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        callbacks.componentEnvironment = environment = next(_ENVIRONMENTS)
        _BY_ENVIRONMENT[environment] = self
        addLoggerProxy(ctypes.byref(callbacks))  # (again: another caller may have taken the proxy since)
        self.instantiate(callbacks=callbacks, loggingOn=logging)


class FMI3Logging:
    """FMI 3.0's instantiation: the logger is an argument of its own."""

    def _instantiate(self, logging: bool) -> None:
        self.instantiate(loggingOn=logging, logMessage=lambda env, status, category, message: self._log(message))


# The class names start with FMU2 or FMU3: fmpy picks the C functions' prefix by them.

class FMU2CS(CheckedFMU, FMI2Logging, FMU2Slave):
    """An FMI 2.0 Co-Simulation instance, every call checked."""
    INSTANTIATE = "fmi2Instantiate"


class FMU2ME(CheckedFMU, FMI2Logging, FMU2Model):
    """An FMI 2.0 Model Exchange instance, every call checked."""
    INSTANTIATE = "fmi2Instantiate"


class FMU3CS(CheckedFMU, FMI3Logging, FMU3Slave):
    """An FMI 3.0 Co-Simulation instance, every call checked."""
    INSTANTIATE = "fmi3InstantiateCoSimulation"


class FMU3ME(CheckedFMU, FMI3Logging, FMU3Model):
    """An FMI 3.0 Model Exchange instance, every call checked."""
    INSTANTIATE = "fmi3InstantiateModelExchange"


CLASSES = {("2", "CS"): FMU2CS, ("2", "ME"): FMU2ME, ("3", "CS"): FMU3CS, ("3", "ME"): FMU3ME}
"""The class for (FMI major version, interface)."""


def instantiate_fmu(directory: str | Path, description, interface: str = "CS", name: str | None = None,
                    guid: str | None = None, logging: bool = False) -> CheckedFMU:
    """Load the FMU unpacked in `directory` (`description`: its model description) and
    instantiate it as `interface` ("CS" or "ME"), named `name` (default: its model
    identifier). `guid` another than the description's (to see it refused); `logging`
    turns the FMU's debug logging on."""
    refuse_unsafe_names(directory, description)
    declared = description.coSimulation if interface == "CS" else description.modelExchange
    major = str(description.fmiVersion).split(".")[0]
    if (major, interface) not in CLASSES or declared is None:
        raise BadInput(f"{directory}: no {interface} interface of FMI {description.fmiVersion} here (pendfmu "
                       f"instantiates FMI 2.0 and 3.0, CS and ME, as the FMU declares them)")
    fmu = CLASSES[(major, interface)](guid=guid or description.guid, unzipDirectory=str(directory),
                                      modelIdentifier=declared.modelIdentifier,
                                      instanceName=name or declared.modelIdentifier)
    fmu.open(logging)
    return fmu
