"""Python callables reached from inside the compiled time step.

The step (:mod:`~openimp.dynamics.stepping`) is one compiled orchestration; what
only Python can compute (the motions of time of the specified coordinates, the
load laws, the switching functions of their events) is asked for from inside
it, as MuJoCo's one ``mj_step`` calls its ``mjcb_*`` hooks and as the curve
joints call their registered callables (:mod:`openimp.joints.curves`).  A run
registers one handler, ``handler(what) -> status``, and stores the id in its
work arrays; :func:`call_hook` enters Python through a numba ``objmode`` block
and back.  The handler reads and writes the run's arrays itself (it holds them:
the same memory as the kernel's), so nothing is boxed on the way.

A handler never raises into compiled code: it keeps the exception and returns
:data:`FAILED`; the kernel stops with ``Stage.PYTHON`` and the caller raises the
kept exception.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from enum import IntEnum

from openimp._jit import njit

try:  # object-mode blocks call the registered Python handler from compiled kernels
    from numba import objmode as _objmode
except ImportError:  # pragma: no cover - only without numba (OPENIMP_NOJIT debugging)
    import contextlib
    from typing import Any

    def _objmode(**_types: Any) -> contextlib.AbstractContextManager[None]:
        return contextlib.nullcontext()


class Hook(IntEnum):
    """What the step asks of its handler."""

    #: the SGC motions at the times w.mt[:w.nmt[0]] into the rows w.ms[:w.nmt[0]]
    MOTION = 0
    #: the load-law values at the stage state S (its joint rates set) into z.law
    LAWS = 1
    #: the laws' stiffness and damping added to the book step's linear model
    LAW_TERMS = 2
    #: an attempt is about to start from the step start: keep it (event location)
    SNAP = 3
    #: a step was accepted: did a switching function change sign over it?  (And the
    #: laws that watch the accepted steps are told of it.)
    SWITCH = 4
    #: the run's loop asks whether to return to Python (the clock: progress, Ctrl-C)
    TICK = 5


#: the handler's answers (TOLD: after SWITCH, laws that watch the accepted steps now
#: hold new values, so the step start is evaluated again)
DONE, CROSSED, TOLD, FAILED = 0, 1, 2, -1

_HANDLERS: dict[int, Callable[[int], int]] = {}
_IDS = itertools.count(1)


def register(handler: Callable[[int], int]) -> int:
    """Register a run's handler; returns the id the kernels call it by."""
    ident = next(_IDS)
    _HANDLERS[ident] = handler
    return ident


def unregister(ident: int) -> None:
    """Forget a handler (the run is over)."""
    _HANDLERS.pop(int(ident), None)


def dispatch(ident: int, what: int) -> int:
    """Call handler ``ident`` with ``what`` (object mode, or plain Python)."""
    return int(_HANDLERS[int(ident)](int(what)))


@njit(nogil=False)  # its object-mode block takes the GIL anyway
def call_hook(ident: int, what: int) -> int:
    """Ask the registered handler ``ident`` for ``what`` (a :class:`Hook`); its status."""
    with _objmode(st="int64"):
        st = dispatch(ident, what)
    return st
