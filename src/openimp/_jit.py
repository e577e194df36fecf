"""Compilation switch for the kernels.

Every hot function of openimp is written once, in the subset of Python that
numba compiles in nopython mode, and decorated with :func:`njit`.  With numba
present the decorator compiles it (cached on disk, so later runs load the
machine code); with ``OPENIMP_NOJIT=1`` in the environment the very same
functions run as plain Python, which is slow but handy for debugging.  There is
no second implementation to keep in step.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from typing import Any, TypeVar

F = TypeVar("F", bound=Callable[..., Any])

JIT_ENABLED = os.environ.get("OPENIMP_NOJIT", "") in ("", "0")

try:  # numba is a declared dependency; the fallback only serves OPENIMP_NOJIT debugging
    import numba as _numba
except ImportError:  # pragma: no cover - exercised only on broken installs
    _numba = None
    JIT_ENABLED = False


def _source_digest() -> str:
    """Hash of every source file of the package.

    numba keys a cached function on its own file only, so a kernel in
    kinematics.py would keep stale machine code of joints.py after an upgrade
    or an edit; one cache directory per source version avoids that.
    """
    import hashlib
    from pathlib import Path

    h = hashlib.sha1()
    root = Path(__file__).resolve().parent
    for p in sorted(root.rglob("*.py")):
        h.update(p.relative_to(root).as_posix().encode())
        h.update(p.read_bytes())
    return h.hexdigest()[:16]


def _cache_dir() -> str:
    base = os.environ.get("OPENIMP_CACHE_DIR") or os.path.join(
        os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache"),
        "openimp",
    )
    return os.path.join(base, "numba-" + _source_digest())


if _numba is not None and JIT_ENABLED and not os.environ.get("NUMBA_CACHE_DIR"):
    _numba.config.CACHE_DIR = _cache_dir()


def njit(*args: Any, **kwargs: Any) -> Any:
    """Compile a function in nopython mode with an on-disk cache (or leave it as is).

    Usable bare (``@njit``) or with numba options (``@njit(parallel=True)``).
    ``nrt=False`` compiles without numba's reference counting: for kernels
    that allocate nothing, whose array arguments the caller keeps alive.  In
    the hot loops the atomic reference counts of every array view and
    argument otherwise cost more than the arithmetic.
    """
    # explicit either way: numba lets a callee without the option inherit
    # its caller's, and the joint functions that allocate must keep NRT even
    # when called from a kernel without it
    kwargs["_nrt"] = kwargs.pop("nrt", True)
    kwargs.setdefault("cache", True)
    kwargs.setdefault("nogil", True)

    def wrap(fn: F) -> F:
        if not JIT_ENABLED:
            return fn
        return _numba.njit(**kwargs)(fn)  # type: ignore[no-any-return]

    if len(args) == 1 and callable(args[0]) and not kwargs.get("_called", False):
        return wrap(args[0])
    return wrap


#: ``numba.prange`` when compiling (parallel loops), plain ``range`` otherwise.
prange = _numba.prange if JIT_ENABLED else range
