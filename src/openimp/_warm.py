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
_LAST = "kinematics.tracks-"


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

    The types come from the allocators of the kernels' scratch on a packed
    placeholder model (the types do not depend on the model): the helper
    needs neither a model nor the joint checks of building one.
    """
    import numpy as np
    from numba import typeof

    from openimp import kinematics as kin
    from openimp.system import KFIELDS, KData, pack

    one = {"i": np.zeros(1, np.int64), "l": np.zeros((1, 1), np.int64), "f": np.zeros(1),
           "m": np.zeros((1, 4, 4)), "v": np.zeros((1, 4))}
    KP, K = pack({name: one[kind] for name, kind in zip(KData._fields, KFIELDS, strict=True)})
    w: Any = kin.plain(kin.work_arrays)(K, 1)
    r: Any = kin.plain(kin.rate_arrays)(K, 1)
    A, Qb, scr = w[1], w[11], w[12]
    D4, B4, omega, Kh, dQb, qd = r[0], r[1], r[2], r[3], r[4], r[5]
    Qs = np.zeros((1, 1))
    body = np.zeros(1, np.int64)
    M4 = np.zeros((1, 1, 4, 4))

    def types(*args: Any) -> tuple[Any, ...]:
        return tuple(typeof(a) for a in args)

    return [
        (kin.operators, types(KP, qd, A, D4, B4, Qb, dQb, scr)),
        (kin.tree_operators, types(KP, qd, D4, Kh, False, omega)),
        (kin.drift_terms, types(KP, qd, D4, B4, omega, Kh)),
        (kin.tracks, types(KP, Qs, Qs, Qs, body, body, M4, np.zeros((1, 1, 3)), M4, M4)),
    ]


def compile_rate_kernels() -> None:
    """Compile (and so cache) the rate kernels; nothing is run."""
    for kernel, types in rate_kernel_signatures():
        kernel.compile(types)


if __name__ == "__main__":
    compile_rate_kernels()
