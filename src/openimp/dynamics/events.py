"""Events of a time response: the switching functions of the load laws and the location
of their roots in time.

A law with a ``switch`` attribute (:class:`~openimp.dynamics.laws.BumpStop`,
:class:`~openimp.dynamics.laws.LiftOff`, :class:`~openimp.dynamics.laws.OneWayDamper`)
changes its form where its switching function crosses zero.  The compiled run
asks after every accepted step whether one changed sign over it
(:data:`~openimp.dynamics.hooks.Hook.SWITCH`); when one did, :func:`locate` finds
the first root by taking the step again from its start with other lengths
(regula falsi with the Illinois halving), each a compiled attempt.

Contact will plug in here: a gap function per watched pair of solids is a
switching function like these, and the impact (book 16.14) an instantaneous
change of the generalized rates applied at the located instant before the run
restarts.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from openimp.dynamics.laws import LoadState, law_coordinate
from openimp.errors import AnalysisError, InputError


class Switches:
    """The switching functions of a system's laws: a law's ``switch`` attribute, one
    function, or ``nswitch`` of them when the law says so (``switch`` then returns an
    array: the IFs of a deck's VALUE data)."""

    def __init__(self, system: Any) -> None:
        self.system = system
        self.funcs = [(slot, name, fn.switch, int(getattr(fn, "nswitch", 1)))
                      for slot, (_, name, fn, _c) in enumerate(system.laws)
                      if callable(getattr(fn, "switch", None))
                      and int(getattr(fn, "nswitch", 1)) > 0]
        #: the law's name of every switching function
        self.names = [str(name) for _s, name, _f, n in self.funcs for _ in range(n)]

    def __bool__(self) -> bool:
        return bool(self.names)

    def name(self, i: int) -> str:
        """The element of switching function i."""
        return self.names[i]

    def signs(self, tr: Any, t: float) -> np.ndarray:
        """The switching functions at step 0 of ``tr`` (an
        :class:`~openimp.dynamics.laws.Instant`) at time t, ``nswitch`` per law."""
        out = np.zeros(len(self.names))
        k = 0
        for slot, name, fn, n in self.funcs:
            x, xd = law_coordinate(self.system, tr, slot)
            try:
                out[k:k + n] = np.asarray(fn(LoadState(tr, 0, t, x, xd)), float).reshape(-1)[:n]
                k += n
            except InputError:
                raise
            except Exception as exc:  # the user's function: any failure is bad input
                raise InputError(f"{name}: its switching function failed at t = {t:.6g}: "
                                 f"{type(exc).__name__}: {exc}") from None
        return out


def crossed(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Where a switching function went from one side of zero to the other (> 0 is one
    side, <= 0 the other: reaching exactly zero from above counts)."""
    return (np.asarray(a) > 0) != (np.asarray(b) > 0)


def locate(take: Callable[[float], np.ndarray | None], g0: np.ndarray, g1: np.ndarray,
           h: float, t0: float) -> tuple[float, np.ndarray, np.ndarray]:
    """The first root in (0, h] of the switching functions that changed sign from g0 (at
    the step start t0) to g1 (at its end, step length h).  ``take(hm)`` takes the step
    of length hm from its start and gives the functions at its end (None when it
    cannot be taken).  Regula falsi on the step length with the Illinois halving,
    candidates only from the functions that change in the bracket, to 1e-12 of the
    time.  Returns the step length just past the root (the state is left there),
    the indices of the functions that changed and their values there."""
    changed = np.flatnonzero(crossed(g0, g1))
    lo, hi = 0.0, h
    glo, ghi = g0[changed].copy(), g1[changed].copy()
    tol = 1e-12 * max(1.0, abs(t0)) + 1e-13
    side = 0
    for _ in range(80):
        if hi - lo <= tol:
            break
        inside = crossed(glo, ghi)
        with np.errstate(divide="ignore", invalid="ignore"):
            cand = lo + (hi - lo) * glo[inside] / (glo[inside] - ghi[inside])
        cand = cand[np.isfinite(cand)]
        hm = float(np.min(cand)) if cand.size else 0.5 * (lo + hi)
        if not lo < hm < hi:
            hm = 0.5 * (lo + hi)
        gm = take(hm)
        if gm is None:
            hm = 0.5 * (lo + hi)
            gm = take(hm)
            if gm is None:
                break
        gm = gm[changed]
        if np.any(crossed(glo, gm)):
            hi, ghi = hm, gm
            if side == 1:  # Illinois: the kept end's values halved
                glo = 0.5 * glo
            side = 1
        else:
            lo, glo = hm, gm
            if side == -1:
                ghi = 0.5 * ghi
            side = -1
    g_end = take(hi)
    if g_end is None:  # keep the step as first taken
        g_end = take(h)
        hi = h
        if g_end is None:
            raise AnalysisError(f"t = {t0:.9g} s: the step could not be taken again to locate "
                             "a law's switching (a law that keeps a state?)")
    return hi, changed, g_end
