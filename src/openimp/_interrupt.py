"""Ctrl-C while results already solved are being made and written.

Solving stops at Ctrl-C and keeps what it solved (each analysis catches
KeyboardInterrupt).  Once solved, the listing, the forces of those steps, the
tables and the files are what the user asked to keep: :func:`held_interrupt`
holds a first Ctrl-C over that work (it says so, the work finishes, and the
caller then ends the run as interrupted), and a second Ctrl-C abandons it at once.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from types import FrameType

__all__ = ["PENDING", "caused_by_interrupt", "deferred_interrupt", "held_interrupt"]

#: a Ctrl-C that landed where Python could not raise it (numba's compiler calls back
#: through ctypes): the command's unraisable hook sets it, and the compile listener
#: (:mod:`openimp._warm`) raises KeyboardInterrupt once the compile is over
PENDING = [False]


def deferred_interrupt() -> contextlib.AbstractContextManager[list[bool]]:
    """Within the block a first SIGINT only sets ``flag[0]``; a second raises
    KeyboardInterrupt (:func:`held_interrupt` with nothing to say).  For Python called
    back from compiled kernels (numba's object mode cannot take an exception raised at an
    arbitrary bytecode: it surfaces as a SystemError): the callbacks and the kernels'
    clock poll the flag and stop at a safe point, where the caller raises
    KeyboardInterrupt.  Yields ``flag``."""
    return held_interrupt(lambda: None)


def caused_by_interrupt(exc: BaseException) -> bool:
    """``exc`` was caused by a Ctrl-C (a KeyboardInterrupt in its chain of causes: a
    SystemError out of a compiled callback, a RuntimeError out of an import)."""
    seen: set[int] = set()
    e: BaseException | None = exc
    while e is not None and id(e) not in seen:
        if isinstance(e, KeyboardInterrupt):
            return True
        seen.add(id(e))
        e = e.__cause__ or e.__context__
    return False


@contextmanager
def held_interrupt(say: Callable[[], None]) -> Iterator[list[bool]]:
    """Within the block a first SIGINT sets ``held[0]`` and calls ``say()`` (which tells
    the user what is being finished), a second raises KeyboardInterrupt.  Yields
    ``held``.  Outside the main thread (where Python does not deliver SIGINT) and
    when SIGINT is not Python's default handler, nothing changes."""
    held = [False]
    if (threading.current_thread() is not threading.main_thread()
            or signal.getsignal(signal.SIGINT) is not signal.default_int_handler):
        yield held
        return

    def handler(signum: int, frame: FrameType | None) -> None:
        if held[0]:
            raise KeyboardInterrupt
        held[0] = True
        say()

    signal.signal(signal.SIGINT, handler)
    try:
        yield held
    finally:
        signal.signal(signal.SIGINT, signal.default_int_handler)
