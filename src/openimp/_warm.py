"""A cold first run: tell the user it compiles, and compile the rate kernels on the other core.

On a machine whose kernel cache is empty (a new installation, a new version of
openimp), most of the first run is numba compiling the kernels its analysis
uses (a kinematic run compiles only the kinematic ones).  Two things make that
first run bearable:

* :class:`~openimp._announce.Announcer` says so once, with the expected time, when the first
  kernel starts compiling, and on a terminal shows which kernel it is at;
  it says nothing when the kernels load from the cache.
* :func:`start` lets a second process compile the kernels a run needs later
  (velocities and accelerations, the body rates of the results) on the other
  core while the run compiles the posture kernels, and write them to the
  shared on-disk cache; when the run reaches them, numba loads them from there
  (or compiles them itself if the helper is not done: the cache is only ever
  a shortcut).  The helper runs only on a cold cache, with a core to spare
  (load average below ``cores - 1.5``: on a loaded machine it would slow the
  run down), and unless ``OPENIMP_NO_WARMUP=1``; it is stopped when the run
  ends.

The kernels come in two flavours: for models whose joints all have a closed
form (rigid, revolute, prismatic, cylindric) and for models with general
joints (:attr:`openimp.system.System.gen`).  :func:`deck_flavours` reads the
deck's joint keywords to compile the likely one first.
"""

from __future__ import annotations

import atexit
import glob
import os
import subprocess
import sys
from collections.abc import Sequence
from typing import Any

from openimp._jit import JIT_ENABLED

#: A kernel the helper compiles last: its cache entry means the helper's work is done.
_LAST = "track.track-"

LOWER = "closed-form"
GENERAL = "general"


def _cache_dir() -> str | None:
    import numba

    return str(numba.config.CACHE_DIR) or None


def cache_is_cold() -> bool:
    """True when the on-disk kernel cache of this source version lacks the rate kernels."""
    d = _cache_dir()
    if not d:
        return False  # numba's default per-source caches: nothing to share reliably
    return not glob.glob(os.path.join(d, "**", _LAST + "*.nbi"), recursive=True)


def machine_busy() -> bool:
    """True when no core is left for a helper beside the run itself (load average)."""
    try:
        load = os.getloadavg()[0]
    except OSError:  # pragma: no cover - platforms without a load average
        return True
    return load > (os.cpu_count() or 1) - 1.5


def deck_flavours(path: str | os.PathLike[str]) -> list[str]:
    """The kernel flavours a deck most likely needs, likeliest first.

    A deck that names a joint keyword of a general kind (GEAR, SPHERE, CAM ...)
    in its first megabyte needs the general flavour first.
    """
    from openimp.imp.jointmap import IMP_JOINTS
    from openimp.joints.catalogue import joint_type
    from openimp.joints.codes import CLOSED_FORM

    try:
        with open(path, "rb") as f:
            words = set(f.read(1 << 20).decode("latin-1").upper().replace(",", " ").split())
    except OSError:
        return [LOWER, GENERAL]
    general = {k for k, ij in IMP_JOINTS.items()
               if ij.available and joint_type(ij.kind).code not in CLOSED_FORM}
    return [GENERAL, LOWER] if words & general else [LOWER, GENERAL]


def start(flavours: Sequence[str] = (LOWER, GENERAL)) -> subprocess.Popen[bytes] | None:
    """Start the helper when it can help (see the module docstring); None otherwise.

    ``flavours``: the order in which the helper compiles the two flavours.
    """
    if not JIT_ENABLED or os.environ.get("OPENIMP_NO_WARMUP", "") not in ("", "0"):
        return None
    if (os.cpu_count() or 1) < 2 or not cache_is_cold() or machine_busy():
        return None
    try:
        proc = subprocess.Popen(
            [sys.executable, "-m", "openimp._warm", *flavours], stdin=subprocess.DEVNULL,
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


def rate_kernel_signatures(flavour: str = LOWER) -> list[tuple[Any, tuple[Any, ...]]]:
    """The rate kernels and the argument types a run calls them with.

    The types come from a placeholder model packed from the field tables (the
    types do not depend on the model, only on its flavour: ``gen`` None or an
    int array): the helper needs neither a model nor the joint checks of
    building one.
    """
    import numpy as np
    from numba import typeof

    from openimp.kinematics import rates, track
    from openimp.system import DATA_FIELDS, MODEL_FIELDS, State, allocate, read_only

    ones = {k: 1 for f in MODEL_FIELDS + DATA_FIELDS for k in f.shape if isinstance(k, str)}
    KP = read_only(allocate(MODEL_FIELDS, ones))
    DP = allocate(DATA_FIELDS, ones)
    v = np.zeros(1)
    S = State(v, v, v, v, np.zeros(1, np.bool_), np.zeros(1, np.bool_), v)
    gen = None if flavour == LOWER else KP[0][:1]
    Q = np.zeros((1, 1))
    sel = track.Selection(np.zeros(1, np.int64), np.zeros(1, np.int64))
    out = track.Tracked(np.zeros((1, 1, 4, 4)), np.zeros((1, 1, 3)), np.zeros((1, 1, 6)),
                        np.zeros((1, 1, 6)))

    def types(*args: Any) -> tuple[Any, ...]:
        return tuple(typeof(a) for a in args)

    return [
        (rates.velocity, types(KP, DP, S)),
        (rates.drift, types(KP, DP, S, gen)),
        (rates.velocity_product, types(KP, DP, S, gen, 0)),
        (rates.accelerations, types(KP, DP, S)),
        (track.track, types(KP, DP, S, gen, track.Rows(Q, Q, Q), sel, out)),
    ]


def compile_rate_kernels(flavours: Sequence[str] = (LOWER,)) -> None:
    """Compile (and so cache) the rate kernels of each flavour in turn; nothing is run."""
    for flavour in flavours:
        for kernel, types in rate_kernel_signatures(flavour):
            kernel.compile(types)


def _flavours(argv: Sequence[str]) -> list[str]:
    known = [a for a in argv if a in (LOWER, GENERAL)]
    return known or [LOWER, GENERAL]


if __name__ == "__main__":
    compile_rate_kernels(_flavours(sys.argv[1:]))
