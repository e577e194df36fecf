"""The outputs of a time response: their times, the rows the compiled run writes, the
CSV stream that receives them as they come, and the progress report."""

from __future__ import annotations

import math
import os
import sys
import time as _time
from collections.abc import Callable
from typing import Any, TextIO

import numpy as np

from openimp.dynamics.stepping import OutputRows, Outputs
from openimp.errors import InputError
from openimp.system import System

#: most output times of a run (their times alone take 80 MB)
MAX_OUTPUTS = 10_000_000
#: output rows held at once when they are streamed and not kept
CHUNK_ROWS = 1024


def positive(name: str, v: Any, allow_zero: bool = False) -> float:
    """v as a positive (or non-negative) finite float; an input error naming ``name``."""
    try:
        x = float(v)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a number, got {v!r}") from None
    if not math.isfinite(x) or x < 0 or (x == 0 and not allow_zero):
        raise InputError(f"{name} must be a {'non-negative' if allow_zero else 'positive'} "
                         f"finite number, got {v!r}")
    return x


def output_times(t_final: Any, print_step: Any, times: Any) -> np.ndarray:
    """The output times: ``times`` as given (increasing, finite, at least two), or 0,
    print_step, ... up to and including t_final."""
    if times is not None:
        if t_final is not None or print_step is not None:
            raise InputError("give either times= or t_final (with print_step), not both")
        try:
            t = np.asarray(times, dtype=float)
        except (TypeError, ValueError):
            raise InputError(f"times must be numbers, got {times!r}") from None
        if t.ndim != 1:
            raise InputError(f"times must be one row of output times, got an array of shape "
                             f"{t.shape}")
        if t.size > MAX_OUTPUTS + 1:
            raise InputError(f"times: {t.size} output times are more than {MAX_OUTPUTS:g}; "
                             "give fewer")
        if t.size < 2 or not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
            raise InputError("times must be at least two finite, strictly increasing times "
                             "(the first is the start)")
        return t
    if t_final is None:
        raise InputError("give the final time (t_final) or the output times (times=)")
    tf = positive("t_final", t_final)
    dt = tf if print_step is None else positive("print_step", print_step)
    ratio = tf / dt
    if not ratio <= MAX_OUTPUTS:  # before floor(): an infinite ratio has no integer
        raise InputError(f"t_final {tf:g} s at print_step {dt:g} s makes {ratio:.3g} outputs, "
                         f"more than {MAX_OUTPUTS:g}: give a larger print_step (or fewer times)")
    n = math.floor(ratio * (1 + 1e-12))
    t = np.arange(n + 1) * dt
    if tf - t[-1] > 1e-9 * dt:
        t = np.append(t, tf)
    else:
        t[-1] = tf
    return t


class OutputBuffer:
    """The output rows: the buffers the compiled run writes (rows from k - base), kept
    whole (``keep``) or flushed to the stream chunk by chunk."""

    def __init__(self, system: System, tout: np.ndarray, keep: bool, stream: Any) -> None:
        nq = system.nq
        n = tout.size
        self.system = system
        self.tout = tout
        self.keep = keep
        self.cap = n if keep else min(n, CHUNK_ROWS)
        cap = self.cap
        self.rows_ = OutputRows(np.zeros(cap), np.zeros((cap, nq)), np.zeros((cap, nq)),
                                np.zeros((cap, nq)), np.zeros((cap, nq), np.bool_),
                                np.zeros(cap), np.zeros(cap), np.zeros((cap, 5)))
        self.k = np.zeros(1, np.int64)
        self.base = 0
        self.streamed = 0
        self.last: OutputRows | None = None
        self.first: OutputRows | None = None
        self.stream = CsvStream(system, stream) if stream is not None else None

    def view(self) -> Outputs:
        """What the compiled run takes: the times, the next output, the rows held."""
        return Outputs(self.tout, self.k, self.rows_, self.base, self.cap)

    @property
    def count(self) -> int:
        return int(self.k[0])

    def flush(self) -> None:
        """Stream the rows written since the last flush; without ``keep`` free the buffer."""
        upto = self.count - self.base
        if self.stream is not None:
            for r in range(self.streamed - self.base, upto):
                self.stream.write(self.rows_, r, self.system.length_scale ** 2)
            self.streamed = self.count
        if not self.keep and upto > 0:
            if self.first is None:
                self.first = OutputRows(*(a[:1].copy() for a in self.rows_))
            self.last = OutputRows(*(a[upto - 1:upto].copy() for a in self.rows_))
            self.base = self.count

    def rows(self) -> OutputRows:
        """The kept rows: all of them, or without ``keep`` the first and the last (the
        energy audit is against the start)."""
        if self.keep:
            return OutputRows(*(a[:self.count].copy() for a in self.rows_))
        if self.last is None or self.first is None:
            return OutputRows(*(a[:0].copy() for a in self.rows_))
        if self.count == 1:
            return self.first
        return OutputRows(*(np.concatenate((f, la))
                            for f, la in zip(self.first, self.last, strict=True)))


class CsvStream:
    """Output rows written to a CSV file as they come (``<path>.part`` while the run
    goes on, renamed to ``path`` when it ends, complete or not)."""

    def __init__(self, system: System, path: Any) -> None:
        try:
            self.path = os.fspath(path)
        except TypeError:
            raise InputError(f"stream must be the path of a .csv file, got {path!r}") from None
        if not isinstance(self.path, str):
            raise InputError(f"stream must be the path of a .csv file, got {path!r}")
        if not self.path.lower().endswith(".csv"):
            raise InputError(f"stream must name a .csv file, got {self.path!r}")
        d = os.path.dirname(os.path.abspath(self.path))
        if not os.path.isdir(d):
            raise InputError(f"stream: the folder {d!r} does not exist")
        self.part = self.path + ".part"
        self.scale = system.var_scale
        names = system.var_names
        head = (["time"] + list(names) + [n + "'" for n in names] + [n + "''" for n in names]
                + ["kinetic", "potential", "drive work", "load work", "dissipated", "closure",
                   "quality"])
        try:
            self.f: TextIO | None = open(self.part, "w", encoding="utf-8")
        except OSError as exc:
            raise InputError(f"stream: cannot write {self.part!r}: {exc.strerror}") from None
        self.f.write(",".join(head) + "\n")

    def write(self, ob: OutputRows, k: int, e2: float) -> None:
        assert self.f is not None
        sc = self.scale
        row = np.concatenate(([ob.t[k]], ob.q[k] * sc, ob.qd[k] * sc, ob.qdd[k] * sc,
                              ob.energy[k] * e2, [ob.closure[k], ob.quality[k]]))
        self.f.write(",".join(repr(float(x)) for x in row) + "\n")
        self.f.flush()

    def close(self) -> None:
        if self.f is not None:
            self.f.close()
            self.f = None
            os.replace(self.part, self.path)


class Progress:
    """A one-line bar on a terminal, or the user's ``progress(done, total)`` with done
    the time reached and total the final time."""

    def __init__(self, progress: Any, t0: float, tf: float) -> None:
        self.fn: Callable[[float, float], Any] | None = None
        self.bar = False
        self.t0, self.tf = t0, tf
        self.last = 0.0
        if callable(progress):
            self.fn = progress
        elif progress is None:
            self.bar = sys.stderr.isatty()
        elif progress is True:
            self.bar = True
        elif progress is not False:
            raise InputError("progress must be None, True, False or a callable(done, total)")

    def __call__(self, t: float, force: bool = False) -> None:
        if self.fn is not None:
            self.fn(t, self.tf)
            return
        if not self.bar:
            return
        now = _time.monotonic()
        if not force and now - self.last < 0.2:
            return
        self.last = now
        frac = (t - self.t0) / max(self.tf - self.t0, 1e-300)
        n = int(30 * frac)
        sys.stderr.write(f"\r  time response [{'#' * n}{'.' * (30 - n)}] t = {t:.4g} s "
                         f"of {self.tf:.4g}")
        sys.stderr.flush()

    def done(self) -> None:
        if self.bar:
            sys.stderr.write("\n")
            sys.stderr.flush()
