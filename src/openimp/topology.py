"""Topology of a mechanism: incidence, tree and cut-set, loop and path matrices.

This implements Chapter 2 of Uicker, Ravani & Sheth.  A mechanism is a graph
whose vertices are bodies and whose arcs are joints.  Joint ``h`` is oriented
from its *first* body (``h-``) to its *second* body (``h+``).

* The incidence matrix Γ (``nbodies x njoints``) has -1 at ``(first[h], h)``
  and +1 at ``(second[h], h)``.
* Each connected assembly gets a *reference body*: the ground for the
  ground's assembly, the highest-index body for every other assembly (the
  book's rule).  A spanning tree is grown from each reference body by a
  breadth-first search (optionally steered by a per-joint preference); the
  remaining joints are the *chords* (cut-set), one independent loop each.
* The oriented-path matrix P has P(b, h) = +1 if tree joint h lies on the
  path reference -> b traversed along its orientation, -1 if against it.
* The oriented-loop matrix L has, for chord c from body b to body d,
  ``L(i, :) = P(d, :) - P(b, :) - e_c``, so ``L(i, c) = -1`` (the loop crosses
  its own chord against the chord's orientation) and Γ Lᵗ = 0.

Bodies and joints are 0-based here; the book's labels are 1-based.

:func:`book_reduction` reproduces the book's unimodular row reduction of
[Γ | I] exactly, so that the printed L and P of the book's examples can be
checked entry by entry.
"""

from __future__ import annotations

import heapq
import math
import operator
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from openimp.errors import InputError

__all__ = ["Topology", "analyze", "book_reduction"]


@dataclass(frozen=True, eq=False)
class Topology:
    """Topological description of a mechanism (result of :func:`analyze`).

    All arrays are read-only.  Bodies and joints are 0-based indices.

    Attributes:
        nbodies: number of bodies ℓ.
        njoints: number of joints n.
        ground: index of the fixed body.
        incidence: Γ, ``(nbodies, njoints)`` int8; -1 at the joint's first body
            (h-), +1 at its second body (h+).
        tree: int64 indices of the spanning-tree joints, ascending.
        chords: int64 indices of the cut-set joints, ascending; ``chords[i]``
            closes loop ``i``.
        loops: L, ``(nloops, njoints)`` int8 with ``L[i, chords[i]] == -1`` and
            ``incidence @ loops.T == 0``.
        paths: P, ``(nbodies, njoints)`` int8; row b is the oriented path from
            the reference body of b's assembly to b.
        order: int64 permutation of all bodies in which every body comes after
            its parent; the reference bodies come first (the ground's first),
            then the other bodies in breadth-first (tree) order.
        parent_joint: int64 ``(nbodies,)`` tree joint joining each body to its
            parent, -1 for reference bodies.
        parent_body: int64 ``(nbodies,)`` parent body, -1 for reference bodies.
        parent_sign: int8 ``(nbodies,)``; +1 if the body is the second (h+)
            body of its parent joint, -1 if it is the first (h-), 0 for
            reference bodies.  Equals ``paths[b, parent_joint[b]]``.
        reference: int64 ``(nbodies,)`` reference body of each body's assembly.
        assemblies: one ascending int64 body-index array per connected
            assembly; the ground's assembly first, the others ordered by their
            lowest body index.  An isolated body forms its own assembly.
    """

    nbodies: int
    njoints: int
    ground: int
    incidence: np.ndarray
    tree: np.ndarray
    chords: np.ndarray
    loops: np.ndarray
    paths: np.ndarray
    order: np.ndarray
    parent_joint: np.ndarray
    parent_body: np.ndarray
    parent_sign: np.ndarray
    reference: np.ndarray
    assemblies: tuple[np.ndarray, ...]

    @property
    def nloops(self) -> int:
        """Number of independent loops NL = n - ℓ + a."""
        return int(self.chords.shape[0])

    @property
    def nassemblies(self) -> int:
        """Number of connected assemblies a (rank Γ = ℓ - a)."""
        return len(self.assemblies)

    def degree(self) -> np.ndarray:
        """Degree of every body: the number of joint elements it carries (2.2)."""
        return np.abs(self.incidence).sum(axis=1).astype(np.int64)

    def first_body(self, h: int) -> int:
        """First body (h-) of joint ``h``."""
        return int(np.flatnonzero(self.incidence[:, h] == -1)[0])

    def second_body(self, h: int) -> int:
        """Second body (h+) of joint ``h``."""
        return int(np.flatnonzero(self.incidence[:, h] == 1)[0])

    def path_joints(self, b: int) -> list[tuple[int, int]]:
        """Joints on the tree path from the reference body to body ``b``, in order.

        Each item is ``(joint, sign)`` with ``sign == paths[b, joint]``: +1 if the
        joint is traversed from its first to its second body, -1 otherwise.
        The list is empty for a reference body.
        """
        if not 0 <= b < self.nbodies:
            raise InputError(f"body {b} out of range 0..{self.nbodies - 1}")
        out: list[tuple[int, int]] = []
        while self.parent_joint[b] >= 0:
            out.append((int(self.parent_joint[b]), int(self.parent_sign[b])))
            b = int(self.parent_body[b])
        out.reverse()
        return out

    def loop_bodies(self, i: int) -> list[tuple[int, int]]:
        """Joints of loop ``i`` in traversal order, as ``(joint, sign)`` pairs.

        For chord c from body b to body d the loop starts at b, follows the
        tree from b to d (up to the deepest common ancestor, then down), and
        returns to b across c against its orientation.  ``sign == loops[i,
        joint]``: +1 if the joint is traversed from its first to its second
        body, -1 otherwise.  The last item is ``(chords[i], -1)``.
        """
        if not 0 <= i < self.nloops:
            raise InputError(f"loop {i} out of range 0..{self.nloops - 1}")
        c = int(self.chords[i])
        b, d = self.first_body(c), self.second_body(c)
        up = self.path_joints(b)  # reference -> b
        down = self.path_joints(d)  # reference -> d
        k = 0
        while k < min(len(up), len(down)) and up[k] == down[k]:
            k += 1
        out = [(h, -s) for h, s in reversed(up[k:])]  # b -> common ancestor
        out.extend(down[k:])  # common ancestor -> d
        out.append((c, -1))  # d -> b across the chord, reversed
        return out


def _as_index_list(values: Sequence[int], name: str) -> list[int]:
    try:
        return [operator.index(v) for v in values]
    except TypeError as exc:
        raise InputError(f"{name} must be a sequence of integer body indices") from exc


def analyze(
    nbodies: int,
    first: Sequence[int],
    second: Sequence[int],
    ground: int,
    tree_preference: Sequence[float] | None = None,
) -> Topology:
    """Build the topology of a mechanism from its joint incidences.

    Args:
        nbodies: number of bodies ℓ (bodies are ``0 .. nbodies-1``).
        first: ``first[h]`` is the body joint h is oriented from (h-).
        second: ``second[h]`` is the body joint h is oriented to (h+).
        ground: index of the fixed body; it is the reference body of its
            assembly.  Every other assembly is referenced to its highest-index
            body.
        tree_preference: optional per-joint value; joints with a lower value
            enter the spanning tree first, so e.g. giving 'open' joints a high
            value pushes them into the cut-set whenever the graph allows.  The
            tree is grown from each reference body Prim-style on the key
            ``(preference, discovery sequence)``, which is a plain
            breadth-first search visiting joints in index order when all
            preferences are equal, and a minimum spanning tree of the
            preferences in general.

    Returns:
        The :class:`Topology`.

    Raises:
        InputError: mismatched lengths, body indices out of range, a self-loop
            joint (first == second), or a bad ``tree_preference``.
    """
    try:
        nb = operator.index(nbodies)
        g = operator.index(ground)
    except TypeError as exc:
        raise InputError("nbodies and ground must be integers") from exc
    if nb < 1:
        raise InputError(f"a mechanism needs at least one body (nbodies={nb})")
    if not 0 <= g < nb:
        raise InputError(f"ground body {g} out of range 0..{nb - 1}")
    f = _as_index_list(first, "first")
    s = _as_index_list(second, "second")
    if len(f) != len(s):
        raise InputError(
            f"first and second must have one entry per joint (got {len(f)} and {len(s)})"
        )
    nj = len(f)
    for h in range(nj):
        for which, body in (("first", f[h]), ("second", s[h])):
            if not 0 <= body < nb:
                raise InputError(f"joint {h}: {which} body {body} out of range 0..{nb - 1}")
        if f[h] == s[h]:
            raise InputError(
                f"joint {h} is a self-loop (both elements on body {f[h]}); it permits "
                "no motion, remove it"
            )
    if tree_preference is None:
        pref = [0.0] * nj
    else:
        try:
            pref = [float(v) for v in tree_preference]
        except (TypeError, ValueError) as exc:
            raise InputError("tree_preference must be a sequence of numbers") from exc
        if len(pref) != nj:
            raise InputError(
                f"tree_preference has {len(pref)} entries, expected one per joint ({nj})"
            )
        for h, v in enumerate(pref):
            if math.isnan(v):
                raise InputError(f"tree_preference of joint {h} is NaN")

    gamma = np.zeros((nb, nj), dtype=np.int8)
    for h in range(nj):
        gamma[f[h], h] = -1
        gamma[s[h], h] = 1

    # Incident joints of every body, in joint-index order.
    incident: list[list[int]] = [[] for _ in range(nb)]
    for h in range(nj):
        incident[f[h]].append(h)
        incident[s[h]].append(h)

    # Connected assemblies (iterative DFS), then reference bodies.
    comp = np.full(nb, -1, dtype=np.int64)
    members: list[list[int]] = []
    for start in [g, *range(nb)]:
        if comp[start] >= 0:
            continue
        k = len(members)
        comp[start] = k
        stack, mem = [start], [start]
        while stack:
            u = stack.pop()
            for h in incident[u]:
                v = s[h] if f[h] == u else f[h]
                if comp[v] < 0:
                    comp[v] = k
                    stack.append(v)
                    mem.append(v)
        members.append(sorted(mem))
    refs = [g] + [mem[-1] for mem in members[1:]]

    parent_joint = np.full(nb, -1, dtype=np.int64)
    parent_body = np.full(nb, -1, dtype=np.int64)
    parent_sign = np.zeros(nb, dtype=np.int8)
    reference = np.empty(nb, dtype=np.int64)
    paths = np.zeros((nb, nj), dtype=np.int8)
    in_tree = np.zeros(nj, dtype=bool)
    visited = np.zeros(nb, dtype=bool)
    tail: list[int] = []

    for k, r in enumerate(refs):
        reference[members[k]] = r
        visited[r] = True
        # Prim's search on the key (preference, discovery sequence): with equal
        # preferences it is a breadth-first search taking joints in index order.
        heap: list[tuple[float, int, int, int]] = []  # (pref, seq, joint, from)
        seq = 0
        frontier = [r]
        while frontier:
            for u in frontier:
                for h in incident[u]:
                    if not in_tree[h]:
                        heapq.heappush(heap, (pref[h], seq, h, u))
                        seq += 1
            frontier = []
            while heap and not frontier:
                _, _, h, u = heapq.heappop(heap)
                v = s[h] if f[h] == u else f[h]
                if visited[v]:
                    continue
                visited[v] = True
                in_tree[h] = True
                parent_joint[v] = h
                parent_body[v] = u
                parent_sign[v] = 1 if s[h] == v else -1
                paths[v] = paths[u]
                paths[v, h] = parent_sign[v]
                tail.append(v)
                frontier = [v]

    tree = np.flatnonzero(in_tree).astype(np.int64)
    chords = np.flatnonzero(~in_tree).astype(np.int64)
    loops = np.zeros((chords.shape[0], nj), dtype=np.int8)
    for i, c in enumerate(chords):
        row = paths[s[c]].astype(np.int16) - paths[f[c]].astype(np.int16)
        row[c] -= 1
        loops[i] = row

    order = np.array(refs + tail, dtype=np.int64)
    assemblies = tuple(np.array(m, dtype=np.int64) for m in members)
    arrays = [
        gamma,
        tree,
        chords,
        loops,
        paths,
        order,
        parent_joint,
        parent_body,
        parent_sign,
        reference,
        *assemblies,
    ]
    for a in arrays:
        a.setflags(write=False)
    return Topology(
        nbodies=nb,
        njoints=nj,
        ground=g,
        incidence=gamma,
        tree=tree,
        chords=chords,
        loops=loops,
        paths=paths,
        order=order,
        parent_joint=parent_joint,
        parent_body=parent_body,
        parent_sign=parent_sign,
        reference=reference,
        assemblies=assemblies,
    )


def book_reduction(
    incidence: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The book's unimodular row reduction of [Γ | I] (chapter 2: L, 2.8-2.13; P, 2.14-2.15).

    The Γ columns are scanned left to right; in each column the pivot is the
    lowest-index not-yet-used row with a nonzero entry.  That row is made +1 at
    the pivot and the column is eliminated from every other row (including the
    augmented identity part).  Columns without a pivot are the chords; the
    rows never used are the reference bodies (the highest-index body of every
    assembly).  This is Kruskal's tree in joint-index order, and it reproduces
    the book's printed L and P.

    Args:
        incidence: Γ, ``(nbodies, njoints)`` with entries in {-1, 0, 1}.

    Returns:
        ``(L, P, chords, reference_rows)``: L ``(nloops, njoints)`` int8 with
        one row per chord in ascending chord order and -1 at the chord; P
        ``(nbodies, njoints)`` int8; ``chords`` and ``reference_rows`` as
        ascending int64 arrays.
    """
    gamma = np.asarray(incidence)
    if gamma.ndim != 2:
        raise InputError("incidence must be a 2-D matrix")
    nb, nj = gamma.shape
    a = np.concatenate([gamma.astype(np.int64), np.eye(nb, dtype=np.int64)], axis=1)
    used = np.zeros(nb, dtype=bool)
    pivot_row = np.full(nj, -1, dtype=np.int64)
    for k in range(nj):
        rows = np.flatnonzero((a[:, k] != 0) & ~used)
        if rows.size == 0:
            continue
        p = int(rows[0])
        if a[p, k] < 0:
            a[p] = -a[p]
        for r in np.flatnonzero(a[:, k]):
            if r != p:
                a[r] -= a[r, k] * a[p]
        used[p] = True
        pivot_row[k] = p
    if np.abs(a).max(initial=0) > 1:  # pragma: no cover - Γ is totally unimodular
        raise InputError("incidence is not a valid incidence matrix (not unimodular)")
    chords = np.flatnonzero(pivot_row < 0).astype(np.int64)
    tree = np.flatnonzero(pivot_row >= 0)
    paths = np.zeros((nb, nj), dtype=np.int8)
    for k in tree:
        paths[:, k] = a[pivot_row[k], nj:]
    loops = np.zeros((chords.shape[0], nj), dtype=np.int8)
    for i, c in enumerate(chords):
        loops[i, c] = -1
        for k in tree:
            loops[i, k] = a[pivot_row[k], c]
    reference_rows = np.flatnonzero(~used).astype(np.int64)
    return loops, paths, chords, reference_rows


def one_edit(a: str, b: str) -> bool:
    """True when ``b`` is ``a`` with one character inserted, deleted or replaced by a
    letter (case-insensitive); names of three characters or fewer, and names that differ
    in a digit (``LINK1``, ``LINK2``), never count: those are numbered on purpose."""
    a, b = a.upper(), b.upper()
    if a == b or min(len(a), len(b)) < 3 or abs(len(a) - len(b)) > 1:
        return False
    if len(a) == len(b):
        diff = [(x, y) for x, y in zip(a, b, strict=True) if x != y]
        return len(diff) == 1 and not (diff[0][0].isdigit() or diff[0][1].isdigit())
    short, long_ = (a, b) if len(a) < len(b) else (b, a)
    for i, ch in enumerate(long_):
        if long_[:i] + long_[i + 1:] == short:
            return not ch.isdigit()
    return False


def misspelt_bodies(joints: Sequence[tuple[str, str, str]], ground: str
                    ) -> list[tuple[str, str, str, list[str]]]:
    """Bodies that look like a misspelling of another: a body (not ``ground``) named in
    one joint only whose name is :func:`one_edit` from another body's.  ``joints``: (name,
    body1, body2) each.  Returns (body, its joint, the other body, the other's joints)
    for each, in the order of the joints."""
    where: dict[str, list[str]] = {}
    for name, b1, b2 in joints:
        for b in (b1, b2):
            where.setdefault(b, [])
            if name not in where[b]:
                where[b].append(name)
    out: list[tuple[str, str, str, list[str]]] = []
    for b, js in where.items():
        if b == ground or len(js) != 1:
            continue
        for o, ojs in where.items():
            if o != b and one_edit(b, o) and not any(x[0] == o and x[2] == b for x in out):
                out.append((b, js[0], o, ojs))
                break
    return out
