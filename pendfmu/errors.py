"""pendfmu's exceptions: the base classes that the command line maps to exit codes.

A leaf module: it imports nothing of pendfmu, so any module can raise these without
pulling in the others. Each module defines its narrow classes on these bases::

    PendfmuError                   anything pendfmu raises on purpose
    +-- BadInput (ValueError)      exit 2: the input is wrong; one line naming the file,
    |   |                          column, key or value
    |   +-- UsageError             command-line usage (and what no narrower class covers)
    |   +-- RecordingError         recording.schema
    |   +-- ParameterFileError     parameters
    |   +-- ParameterError         simulator.component
    |   +-- SspError               ssp
    +-- Suspicious                 exit 3 under --strict: the data look wrong (fitting.plausibility)
    +-- FMUError (RuntimeError)    exit 4: an FMU refused a call (which instance, function,
        |                          time, what it logged): the model failed, not pendfmu
        +-- CouplingError          an algebraic loop that did not settle (simulator.coupled)

Anything else reaching the command line is an internal failure (exit 1).
"""

from __future__ import annotations

from collections.abc import Sequence


class PendfmuError(Exception):
    """Base of every error pendfmu raises on purpose."""


class BadInput(PendfmuError, ValueError):
    """The user's input is wrong (exit code 2); the message names where."""


class UsageError(BadInput):
    """Bad input that no more specific error covers."""


class Suspicious(PendfmuError):
    """Input that may be right but looks wrong (exit code 3 under --strict)."""


class FMUError(PendfmuError, RuntimeError):
    """An FMU call failed (fmi2Error or worse): the message says what the FMU logged.

    Attributes, where known: `instance` (the component's name), `function` (the FMI call),
    `time` (the communication point), `messages` (what the FMU logged, newest last),
    `status` (what the call returned: 2 Discard, 3 Error, 4 Fatal)."""

    def __init__(self, message: str, instance: str | None = None, function: str | None = None,
                 time: float | None = None, messages: Sequence[str] = (), status: int | None = None):
        super().__init__(message)
        self.instance = instance
        self.function = function
        self.time = time
        self.messages = list(messages)
        self.status = status


EXIT_BAD_INPUT = 2
EXIT_SUSPICIOUS = 3
EXIT_MODEL_FAILED = 4
