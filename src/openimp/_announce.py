"""Saying that kernels compile: once per group of kernels, with the expected time.

numba compiles a kernel the first time it is called with new argument types (or
loads it from the on-disk cache).  A cold compile takes seconds to a minute per
analysis, so the user is told: :class:`Announcer` listens to numba's compile
events and says, once per group of kernels (kinematic, force, equilibrium,
linearization, time response), that it compiles and about how long it takes.
The command line writes that on stderr with a progress line on a terminal
(:mod:`openimp.cli`); a Python session or a notebook gets it through the
``openimp`` logger (:func:`announce`, started when the first kernel module is
imported), which ``logging.getLogger("openimp").setLevel(logging.ERROR)`` silences.
"""

from __future__ import annotations

import time
from typing import Any, TextIO

from openimp._interrupt import PENDING

#: CPU seconds a cold kinematic run compiles, measured on the reference 2-core machine
#: (``python -m benchmarks.coldstart``, ``benchmarks/coldstart.md``: a sweep, 23 s);
#: said to the user as the expected time
COMPILE_SECONDS = 25
#: CPU seconds a first force analysis compiles on top of the kinematic kernels
#: (openimp.dynamics; measured 48 s in all for openimp.forces)
FORCE_COMPILE_SECONDS = 25
#: CPU seconds the linearization kernel compiles on top of the force stages it calls
#: (openimp.dynamics.linear; linearize and modes after an equilibrium measured 110 s in all)
LINEAR_COMPILE_SECONDS = 45
#: CPU seconds the equilibrium search compiles on top of the force stages (openimp.dynamics.
#: statics with the stiffness stage of openimp.dynamics.linear; measured 106 s in all)
STATIC_COMPILE_SECONDS = 60
#: CPU seconds a first time response compiles (openimp.dynamics.stepping with the
#: equations-of-motion stage it calls; measured 250 s for the Dormand-Prince run and 346 s
#: for the book's run in all, cold cache: the next compile to cut)
DYNAMIC_COMPILE_SECONDS = 250


class Announcer:
    """Says once that a run compiles kernels, and shows progress on a terminal.

    Listens to numba's compile events; an event of a kernel of openimp that
    is not nested in another compile is one step of progress.  ``stream``:
    where to write (stderr); ``live``: rewrite a progress line in place (a
    terminal).  :meth:`close` stops listening and, if anything compiled,
    says how long it took.
    """

    def __init__(self, stream: TextIO | None, live: bool, what: str = "kinematic",
                 prefix: str = "") -> None:
        #: None: the notes go to the ``openimp`` logger (a Python session, a notebook)
        self.stream = stream
        self.prefix = prefix
        self.live = live and stream is not None
        self.what = what
        #: while True nothing is said (the command line says it with its own announcer)
        self.muted = False
        self.depth = 0
        self.count = 0
        self.started: float | None = None
        self.said: set[str] = set()
        self.finished = 0.0
        self._listener: Any = None
        try:
            from numba.core import event
        except ImportError:  # pragma: no cover - without numba nothing compiles
            return

        announcer = self

        class _Listener(event.Listener):  # type: ignore[misc]
            def on_start(self, ev: Any) -> None:
                announcer._on_start(ev.data.get("dispatcher"))

            def on_end(self, ev: Any) -> None:
                announcer.depth = max(0, announcer.depth - 1)
                announcer.finished = time.monotonic()
                if announcer.depth == 0 and PENDING[0]:  # a Ctrl-C kept during the compile
                    PENDING[0] = False
                    raise KeyboardInterrupt

        self._listener = _Listener()
        event.register("numba:compile", self._listener)

    def _group(self, module: str) -> tuple[str, int]:
        """The kernels a compile belongs to and their expected CPU seconds."""
        if module == "openimp.dynamics.linear":
            return "linearization", LINEAR_COMPILE_SECONDS
        if module == "openimp.dynamics.statics":
            return "equilibrium", STATIC_COMPILE_SECONDS
        if module == "openimp.dynamics.stepping":
            return "time-response", DYNAMIC_COMPILE_SECONDS
        if module.startswith("openimp.dynamics"):
            return "force", FORCE_COMPILE_SECONDS
        return self.what, COMPILE_SECONDS

    def _on_start(self, dispatcher: Any) -> None:
        self.depth += 1
        fn = getattr(dispatcher, "py_func", None)
        if self.muted or fn is None or not getattr(fn, "__module__", "").startswith("openimp"):
            return
        # a group is said by the kernel the analysis calls, not by the stages it compiles
        what, secs = self._group(fn.__module__)
        if self.started is None:
            self.started = time.monotonic()
            self.said.add(what)
            self._note(f"compiling the {what} kernels (the first run of this version of "
                       f"openimp does this once: about {secs} s of CPU, later runs load them "
                       "from the cache)")
        elif self.depth == 1 and what not in self.said:
            self.said.add(what)
            self._note(f"compiling the {what} kernels too (once: about {secs}"
                       " s of CPU more)")
        if self.depth == 1:
            self.count += 1
        if self.live:
            name = fn.__qualname__
            self.stream.write(f"\r  compiling {name[:40]:<40} ({self.count} kernels)")
            self.stream.flush()

    def _note(self, text: str) -> None:
        if self.stream is None:
            import logging

            logging.getLogger("openimp").warning("%s%s", self.prefix, text)
            return
        if self.live and self.count:
            self.stream.write("\r" + " " * 70 + "\r")
        self.stream.write(f"openimp: note: {self.prefix}{text}\n")
        self.stream.flush()

    def close(self) -> None:
        """Stop listening; say how long compiling took when anything compiled."""
        if self._listener is not None:
            from numba.core import event

            event.unregister("numba:compile", self._listener)
            self._listener = None
        if self.started is not None:
            if self.live and not self.count:  # (_note clears the progress line otherwise)
                self.stream.write("\r" + " " * 70 + "\r")
            self._note(f"{self.count} kernels compiled and cached in "
                       f"{self.finished - self.started:.0f} s")
            self.started = None


#: the announcer of a Python session (:func:`announce`): compiles said through logging
SESSION: Announcer | None = None


def announce() -> Announcer:
    """Say every compile of a Python session through the ``openimp`` logger (a warning once
    per group of kernels, with the expected time: stderr by default, a notebook's
    output too; ``logging.getLogger("openimp").setLevel(logging.ERROR)`` silences it).
    Started once, when the first kernel module is imported (:mod:`openimp._jit`)."""
    global SESSION
    if SESSION is None:
        SESSION = Announcer(None, False, "kinematic")
    return SESSION
