"""Compile the rate kernels in a second process while a cold ``openimp run`` starts.

On a machine whose kernel cache is empty, most of the first run is numba
compiling (book method, many kernels; see docs/kinematics.md, "Speed").  The
kernels a run needs first (postures: the joint functions, the tree pass,
Newton) and the ones it needs later (velocities and accelerations: the joint
operators and their derivatives, the body rates) compile independently, so
:func:`start` lets a second process compile the later ones on the other
core and write them to the shared on-disk cache; when the run reaches them,
numba loads them from there instead of compiling them (or compiles them
itself if the helper is not done: the cache is only ever a shortcut).

The helper runs only on a cold cache, with two or more cores, and unless
``OPENIMP_NO_WARMUP=1``; it is stopped when the run ends.
"""

from __future__ import annotations

import atexit
import glob
import os
import subprocess
import sys
from typing import Any

from openimp._jit import JIT_ENABLED

#: A kernel the helper compiles last: its cache entry means the helper's work is done.
_LAST = "track.track-"


def _cache_dir() -> str | None:
    import numba

    return str(numba.config.CACHE_DIR) or None


def cache_is_cold() -> bool:
    """True when the on-disk kernel cache of this source version lacks the rate kernels."""
    d = _cache_dir()
    if not d:
        return False  # numba's default per-source caches: nothing to share reliably
    return not glob.glob(os.path.join(d, "**", _LAST + "*.nbi"), recursive=True)


def start() -> subprocess.Popen[bytes] | None:
    """Start the helper process when it can help (see the module docstring); None otherwise."""
    if not JIT_ENABLED or os.environ.get("OPENIMP_NO_WARMUP", "") not in ("", "0"):
        return None
    if (os.cpu_count() or 1) < 2 or not cache_is_cold():
        return None
    try:
        proc = subprocess.Popen(
            [sys.executable, "-m", "openimp._warm"], stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
        )
    except OSError:
        return None
    atexit.register(_stop, proc)
    return proc


def _stop(proc: subprocess.Popen[bytes]) -> None:
    if proc.poll() is None:
        proc.terminate()
        try:
            proc.wait(timeout=2)
        except subprocess.TimeoutExpired:
            proc.kill()


def rate_kernel_signatures() -> list[tuple[Any, tuple[Any, ...]]]:
    """The rate kernels and the argument types a run calls them with.

    The types come from a placeholder model packed from the field tables (the
    types do not depend on the model, only on whether it has joints of a
    general kind; a deck's run usually has none): the helper needs neither a
    model nor the joint checks of building one.
    """
    import numpy as np
    from numba import typeof

    from openimp.kinematics import rates, track
    from openimp.system import (
        DATA_FIELDS,
        MODEL_FIELDS,
        State,
        allocate,
        read_only,
    )

    ones = {k: 1 for f in MODEL_FIELDS + DATA_FIELDS for k in f.shape if isinstance(k, str)}
    KP = read_only(allocate(MODEL_FIELDS, ones))
    DP = allocate(DATA_FIELDS, ones)
    v = np.zeros(1)
    S = State(v, v, v, v, np.zeros(1, np.bool_), np.zeros(1, np.bool_), v)
    none = None
    Q = np.zeros((1, 1))
    sel = track.Selection(np.zeros(1, np.int64), np.zeros(1, np.int64))
    out = track.Tracked(np.zeros((1, 1, 4, 4)), np.zeros((1, 1, 3)), np.zeros((1, 1, 6)),
                        np.zeros((1, 1, 6)))

    def types(*args: Any) -> tuple[Any, ...]:
        return tuple(typeof(a) for a in args)

    return [
        (rates.velocity, types(KP, DP, S)),
        (rates.drift, types(KP, DP, S, none)),
        (rates.velocity_product, types(KP, DP, S, none, 0)),
        (rates.accelerations, types(KP, DP, S)),
        (track.track, types(KP, DP, S, none, track.Rows(Q, Q, Q), sel, out)),
    ]


def compile_rate_kernels() -> None:
    """Compile (and so cache) the rate kernels; nothing is run."""
    for kernel, types in rate_kernel_signatures():
        kernel.compile(types)


if __name__ == "__main__":
    compile_rate_kernels()
