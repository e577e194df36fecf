"""The exception types of openimp.

Every error a user can cause is an :class:`InputError` whose message names the
element (body, joint, statement, line) and says what to change.  Failures of an
analysis on valid input (an unreachable posture, a singular system) are
:class:`AnalysisError` and carry whatever was already computed.  A renamed
argument keeps its old name for one release: :func:`deprecated` and :func:`renamed`
give the one warning every analysis uses.
"""

from __future__ import annotations

import sys
import warnings
from collections.abc import Mapping
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



class PassedOverError(InputError):
    """An input IMP answered with a message and passed over: the statement is ignored
    with a located warning and the deck goes on, unless it is read strictly
    (``openimp check --strict``, ``load(strict=True)``), where it is an input error."""

class UnknownNameError(InputError, KeyError):
    """A name a result does not hold (:class:`Named`): an :class:`InputError` that is
    also the ``KeyError`` a mapping raises."""


class Named(dict):  # type: ignore[type-arg]
    """A result's mapping name -> values whose missing name is an :class:`UnknownNameError`
    naming the mapping and the names it holds."""

    def __init__(self, what: str, items: Mapping[str, Any]) -> None:
        super().__init__(items)
        self.what = what

    def __missing__(self, key: Any) -> Any:
        names = ", ".join(map(str, self)) or "none"
        raise UnknownNameError(f"{self.what} has no {key!r}; it holds: {names}")


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


# ----------------------------------------------------------------------------- deprecations
def _caller_level() -> int:
    """The ``stacklevel`` of the first frame outside openimp, as seen from the caller of
    :func:`deprecated` (so the warning names the user's line, however deep the call)."""
    frame = sys._getframe(2)
    level = 2
    while frame is not None:
        name = frame.f_globals.get("__name__", "")
        if name != "openimp" and not name.startswith("openimp."):
            return level
        frame = frame.f_back
        level += 1
    return level


def deprecated(where: str, old: str, new: str) -> None:
    """Warn (:class:`DeprecationWarning`, attributed to the user's line) that ``old`` is a
    name of ``where`` kept for one release and that ``new`` replaces it."""
    warnings.warn(f"{where}: {old} is deprecated and will be removed in the next release; "
                  f"use {new}", DeprecationWarning, stacklevel=_caller_level())


def renamed(where: str, options: dict[str, Any], renames: Mapping[str, str]) -> dict[str, Any]:
    """Keyword arguments under their current names: every old name of ``renames`` (old ->
    new) found in ``options`` is moved to its new name with a :func:`deprecated` warning.
    Giving both names is an :class:`InputError`.  ``options`` is not changed."""
    out = dict(options)
    for old, new in renames.items():
        if old in out:
            if new in out:
                raise InputError(f"{where}: give {new} only ({old} is its deprecated name)")
            deprecated(where, old, new)
            out[new] = out.pop(old)
    return out
