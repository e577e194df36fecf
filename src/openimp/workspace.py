"""Workspaces: the scratch of one analysis call, kept per system and reused.

Allocating an analysis's scratch (its ``Data``, ``DynData`` and buffers) costs
about as much as a step of the analysis, so a study that calls an analysis
thousands of times on one system should allocate it once.  :data:`WORKSPACES`
is the one per-system cache every analysis takes its scratch from:

* :meth:`Workspaces.take` hands out a scratch of one kind (the analysis's
  name) that no other call holds: an idle one of the system's pool, else a
  new one from ``make(system)``; :meth:`Workspaces.give` returns it when the
  call is done (:meth:`Workspaces.use` does both around a ``with`` block);
* two calls at once never share a scratch: two threads on the same system, or
  an analysis called from a progress callback of another (re-entry), each
  hold their own, so they give the same results as the calls one after the
  other; a scratch taken and never given back (an exception) is simply
  dropped;
* the pool of a system goes with the system (a ``weakref.finalize`` on it),
  and keeps at most :data:`IDLE` idle scratches of each kind.

An analysis must not rely on what a scratch held before: every call writes
what it reads.
"""

from __future__ import annotations

import threading
import weakref
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

#: idle scratches kept per system and kind (one per concurrent call beyond is made anew)
IDLE = 4


class Workspaces:
    """Pools of scratch per system (by ``id``, dropped with the system) and kind."""

    def __init__(self) -> None:
        # an RLock: a finalizer (a system collected) may run inside a locked block
        self._lock = threading.RLock()
        self._pools: dict[int, dict[str, list[Any]]] = {}

    def take(self, system: Any, kind: str, make: Callable[[Any], Any]) -> Any:
        """A scratch of ``kind`` for ``system`` that no other call holds (an idle one, or
        ``make(system)``); hand it back with :meth:`give`."""
        key = id(system)
        with self._lock:
            pools = self._pools.get(key)
            if pools is None:
                pools = self._pools[key] = {}
                weakref.finalize(system, self._drop, key)
            idle = pools.get(kind)
            if idle:
                return idle.pop()
        return make(system)

    def give(self, system: Any, kind: str, scratch: Any) -> None:
        """Return a scratch taken with :meth:`take` for ``system``: the next call reuses it."""
        with self._lock:
            pools = self._pools.get(id(system))
            if pools is None:
                return
            idle = pools.get(kind)
            if idle is None:
                idle = pools[kind] = []
            if len(idle) < IDLE:
                for s in idle:  # (a loop: a generator cost a tenth of a statics search)
                    if s is scratch:
                        return
                idle.append(scratch)

    @contextmanager
    def use(self, system: Any, kind: str, make: Callable[[Any], Any]) -> Iterator[Any]:
        """``with WORKSPACES.use(system, kind, make) as scratch:`` take, then give back."""
        scratch = self.take(system, kind, make)
        try:
            yield scratch
        finally:
            self.give(system, kind, scratch)

    def idle(self, system: Any, kind: str) -> int:
        """The number of idle scratches of ``kind`` kept for ``system``."""
        with self._lock:
            return len(self._pools.get(id(system), {}).get(kind, ()))

    def __len__(self) -> int:
        """The number of systems with a pool (alive, or not yet finalized)."""
        with self._lock:
            return len(self._pools)

    def _drop(self, key: int) -> None:
        with self._lock:
            self._pools.pop(key, None)


#: the one per-system cache of scratch of every analysis
WORKSPACES = Workspaces()
