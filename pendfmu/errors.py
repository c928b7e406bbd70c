"""pendfmu's exceptions: the base classes that the command line maps to exit codes.

A leaf module: it imports nothing of pendfmu, so any module can raise these without
pulling in the others. Each module defines its narrow classes on these bases::

    PendfmuError                   anything pendfmu raises on purpose
    +-- BadInput (ValueError)      exit 2: the input is wrong; one line naming the file,
    |   |                          column, key or value
    |   +-- UsageError             command-line usage (and what no narrower class covers)
    |   +-- OptionError            a fit's option that does not apply to its target (fitting.spec)
    |   +-- RecordingError         recording.schema
    |   +-- ParameterFileError     parameters
    |   +-- ParameterError         simulator.component
    |   +-- SspError               ssp
    |   +-- OutputError (OSError)  atomic: a file cannot be written (a full disk, a read-only folder)
    |   +-- UnsafeFMU              a file name FMI does not allow: nothing loaded (simulator.fmi)
    +-- Suspicious                 exit 3 under --strict: the data look wrong (fitting.plausibility)
    +-- Interrupted                exit 130: a fit stopped by Ctrl-C, with its best values (fitting.checkpoint)
    +-- FMUError (RuntimeError)    exit 4: an FMU refused a call (which instance, function,
    |   |                          time, what it logged): the model failed, not pendfmu
    |   +-- CouplingError          an algebraic loop that did not settle (simulator.coupled)
    +-- BuildError (RuntimeError)  exit 5: pendfmu cannot build its FMUs on this machine (no C
    |                              compiler, or the compiler refused the sources)
    +-- StiffModel (RuntimeError)  a model too stiff for `pendfmu check`'s own Model Exchange
    |                              integrator (check.driver): a limit of the check, not the FMU's
    +-- WorkLimit (RuntimeError)   a check group past its cap of communication steps (check.driver)
    +-- WorkersFailed (RuntimeError)  exit 6: the worker processes or the Dask cluster failed
        |                          the work (killed, every worker lost): the machine, not the input
        +-- WorkerDied             a job killed every local worker it ran on (fitting.pool)
        +-- WorkersLost            every Dask worker lost or frozen (fitting.cluster)

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


class OptionError(BadInput):
    """An option of a fit that is malformed or does not apply to the fit's target.

    `option` is the specification's field (``fix``, ``bounds``, ...); the API shows it as
    it is, the command line as its flag (``--fix``), so each says it in its user's words."""

    def __init__(self, option: str, detail: str):
        super().__init__(f"{option}: {detail}")
        self.option = option
        self.detail = detail


class OutputError(BadInput, OSError):
    """A file pendfmu was asked to write cannot be written (a full disk, a read-only folder):
    the message names the file and the system's reason; the previous file, if any, is
    unchanged (atomic.py). An OSError too, so that code handling a failed write as one
    still does."""


class Suspicious(PendfmuError):
    """Input that may be right but looks wrong (exit code 3 under --strict)."""


class FMUError(PendfmuError, RuntimeError):
    """An FMU call failed (fmi2Error or worse): the message says what the FMU logged.

    A RuntimeError and exit code 4 (the model failed, not the input). Each attribute is
    None (or empty) where it is not known.

    Parameters
    ----------
    message : str
        The failure in words.

    Attributes
    ----------
    instance : str or None
        The instance's (the component's) name.
    function : str or None
        The FMI function that failed, e.g. "fmi2DoStep".
    time : float or None
        The communication point of the call [s].
    messages : list of str
        What the FMU logged, newest last.
    status : int or None
        What the call returned: 2 Discard, 3 Error, 4 Fatal.
    """

    def __init__(self, message: str, instance: str | None = None, function: str | None = None,
                 time: float | None = None, messages: Sequence[str] = (), status: int | None = None):
        super().__init__(message)
        self.instance = instance
        self.function = function
        self.time = time
        self.messages = list(messages)
        self.status = status

    def reason(self) -> str:
        """The failure in words, never empty: the message, else what is known of where it
        happened (instance, function, time, the FMU's last words).

        Why: a fit reports the last failed simulation, and "(last: )" told the user nothing.

        Returns
        -------
        str
            The message, or "<where> failed: <what the FMU logged last>".
        """
        said = str(self)
        if said:
            return said
        where = [f"{label} {value}" for label, value in (("instance", self.instance), ("function", self.function))
                 if value]
        if self.time is not None:
            where.append(f"t = {self.time:.9g} s")
        logged = self.messages[-1] if self.messages else "no message logged"
        return f"{', '.join(where) or 'an FMU call'} failed: {logged}"


class BuildError(PendfmuError, RuntimeError):
    """The FMUs cannot be built here: no C compiler, the sources missing, or the compiler
    refused them (the message holds what it printed)."""


class WorkersFailed(PendfmuError, RuntimeError):
    """The machine failed the work, not the input or pendfmu: a job killed every worker
    process it ran on (a segfaulting FMU with no penalty to give it, the OOM killer), or
    every worker of the Dask cluster was lost or stopped answering."""


EXIT_BAD_INPUT = 2
EXIT_SUSPICIOUS = 3
EXIT_MODEL_FAILED = 4
EXIT_BUILD_FAILED = 5
EXIT_WORKERS_FAILED = 6
