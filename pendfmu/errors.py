"""Which exceptions mean "bad input" (exit code 2) rather than an internal failure."""

from __future__ import annotations

from pendfmu.parameters import ParameterFileError
from pendfmu.recording import RecordingError
from pendfmu.simulator.component import ParameterError
from pendfmu.ssp import SspError


class UsageError(ValueError):
    """Bad input that no more specific error covers."""


BAD_INPUT_ERRORS: tuple[type[Exception], ...] = (ParameterFileError, RecordingError, ParameterError, SspError)
