"""The exception types of openimp.

Every error a user can cause is an :class:`InputError` whose message names the
element (body, joint, statement, line) and says what to change.  Failures of an
analysis on valid input (an unreachable posture, a singular system) are
:class:`AnalysisError` and carry whatever was already computed.
"""

from __future__ import annotations

from typing import Any


class OpenIMPError(Exception):
    """Base class of every exception raised on purpose by openimp."""


class InputError(OpenIMPError, ValueError):
    """Bad model data or bad input: the message says which element and what to do.

    ``where`` optionally holds ``(file, line)`` of the offending statement; a
    line of 0 means the file as a whole (shown as ``file: message``).
    """

    def __init__(self, message: str, where: tuple[str, int] | None = None) -> None:
        super().__init__(message)
        self.where = where

    def __str__(self) -> str:
        msg = super().__str__()
        if self.where is not None:
            if self.where[1] <= 0:
                return f"{self.where[0]}: {msg}"
            return f"{self.where[0]}:{self.where[1]}: {msg}"
        return msg


class OutputError(OpenIMPError, OSError):
    """A result file cannot be written; ``path`` names it (never a temporary file)."""

    def __init__(self, message: str, path: str) -> None:
        super().__init__(message)
        self.path = path

    def __str__(self) -> str:
        return str(self.args[0])


class AnalysisError(OpenIMPError, RuntimeError):
    """An analysis failed on valid input; ``partial`` holds what was computed."""

    def __init__(self, message: str, partial: Any = None) -> None:
        super().__init__(message)
        self.partial = partial
