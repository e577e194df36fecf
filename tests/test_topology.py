"""Tests of openimp.topology against the book's Chapter 2 examples and invariants.

Book labels are 1-based (bodies 1..ℓ, joints A, B, ...); here everything is
0-based, so the helpers below translate.
"""

from __future__ import annotations

import dataclasses
from collections import deque

import numpy as np
import pytest

from openimp.errors import InputError
from openimp.topology import Topology, analyze, book_reduction

# ----------------------------------------------------------------------------
# helpers


def book(arcs: list[tuple[int, int]]) -> tuple[list[int], list[int]]:
    """1-based (from, to) pairs -> 0-based first/second lists."""
    return [a - 1 for a, _ in arcs], [b - 1 for _, b in arcs]


def arr(rows: list[list[int]]) -> np.ndarray:
    return np.array(rows, dtype=np.int64)


def rank(m: np.ndarray) -> int:
    if m.size == 0:
        return 0
    return int(np.linalg.matrix_rank(m.astype(float)))


def same_span(a: np.ndarray, b: np.ndarray) -> bool:
    ra, rb = rank(a), rank(b)
    return ra == rb == rank(np.vstack([a, b]))


def components(nb: int, first: list[int], second: list[int]) -> list[set[int]]:
    adj: list[list[int]] = [[] for _ in range(nb)]
    for u, v in zip(first, second):
        adj[u].append(v)
        adj[v].append(u)
    seen: set[int] = set()
    out = []
    for s in range(nb):
        if s in seen:
            continue
        comp = {s}
        stack = [s]
        while stack:
            u = stack.pop()
            for v in adj[u]:
                if v not in comp:
                    comp.add(v)
                    stack.append(v)
        seen |= comp
        out.append(comp)
    return out


def check_invariants(t: Topology, first: list[int], second: list[int]) -> None:
    """All structural properties a Topology must have."""
    nb, nj = t.nbodies, t.njoints
    assert nb == t.incidence.shape[0] and nj == len(first) == t.incidence.shape[1]
    G = t.incidence.astype(np.int64)
    L = t.loops.astype(np.int64)
    P = t.paths.astype(np.int64)

    # dtypes and shapes
    assert t.incidence.dtype == np.int8 and t.loops.dtype == np.int8
    assert t.paths.dtype == np.int8 and t.parent_sign.dtype == np.int8
    for a in (t.tree, t.chords, t.order, t.parent_joint, t.parent_body, t.reference):
        assert a.dtype == np.int64
    assert t.loops.shape == (t.nloops, nj) and t.paths.shape == (nb, nj)

    # incidence (2.1)
    for h in range(nj):
        col = np.zeros(nb, dtype=np.int64)
        col[first[h]] -= 1
        col[second[h]] += 1
        assert np.array_equal(G[:, h], col)
        assert t.first_body(h) == first[h] and t.second_body(h) == second[h]
    deg = t.degree()
    assert np.array_equal(deg, np.diag(G @ G.T))
    assert deg.sum() == 2 * nj

    # assemblies, rank Γ = ℓ - a (Theorem 2.1), NL = n - ℓ + a (2.13)
    comps = components(nb, first, second)
    a = len(comps)
    assert t.nassemblies == a
    assert sorted(map(tuple, map(sorted, comps))) == sorted(tuple(x.tolist()) for x in t.assemblies)
    assert t.ground in t.assemblies[0]
    assert sorted(np.concatenate(t.assemblies).tolist()) == list(range(nb))
    assert rank(G) == nb - a
    assert t.nloops == nj - nb + a
    assert len(t.tree) == nb - a
    assert sorted(t.tree.tolist() + t.chords.tolist()) == list(range(nj))
    assert np.all(np.diff(t.tree) > 0) and np.all(np.diff(t.chords) > 0)

    # reference bodies: ground, else highest index of the assembly
    for k, asm in enumerate(t.assemblies):
        ref = t.ground if k == 0 else int(asm.max())
        assert np.all(t.reference[asm] == ref)
        assert t.parent_joint[ref] == -1 and t.parent_body[ref] == -1
        assert t.parent_sign[ref] == 0
        assert not P[ref].any()

    # loops: Γ Lᵗ = 0 (2.9), -1 at own chord, full rank, -I block on chords
    assert not (G @ L.T).any()
    assert rank(L) == t.nloops
    if t.nloops:
        assert np.array_equal(L[:, t.chords], -np.eye(t.nloops, dtype=np.int64))
    # tree joints carry no loop of their own: only chords are in the -I block

    # each loop row is a simple closed loop, traversed in order by loop_bodies
    for i in range(t.nloops):
        c = int(t.chords[i])
        seq = t.loop_bodies(i)
        assert seq[-1] == (c, -1)
        assert sorted(h for h, _ in seq) == sorted(np.flatnonzero(L[i]).tolist())
        body = first[c]
        visited = [body]
        for h, sgn in seq:
            assert sgn == L[i, h]
            if sgn == 1:
                assert first[h] == body
                body = second[h]
            else:
                assert second[h] == body
                body = first[h]
            visited.append(body)
        assert visited[-1] == visited[0]
        assert len(set(visited[:-1])) == len(seq)  # simple loop: no body twice
        # independent check: every body of the loop has degree 2 in it
        sup = np.flatnonzero(L[i])
        ldeg = np.abs(G[:, sup]).sum(axis=1)
        assert set(ldeg.tolist()) <= {0, 2}

    # paths: consistent with the parent chain and with Γ
    for b in range(nb):
        ref = int(t.reference[b])
        e = np.zeros(nb, dtype=np.int64)
        e[b] += 1
        e[ref] -= 1
        assert np.array_equal(G @ P[b], e)
        assert not P[b, t.chords].any()
        pj = int(t.parent_joint[b])
        if b != ref:
            pb = int(t.parent_body[b])
            assert pj in t.tree
            assert {first[pj], second[pj]} == {b, pb}
            assert t.parent_sign[b] == (1 if second[pj] == b else -1)
            assert P[b, pj] == t.parent_sign[b]
            expect = P[pb].copy()
            expect[pj] = t.parent_sign[b]
            assert np.array_equal(P[b], expect)
            assert t.reference[pb] == ref
        seq = t.path_joints(b)
        body = ref
        for h, sgn in seq:
            assert sgn == P[b, h]
            assert (first[h] if sgn == 1 else second[h]) == body
            body = second[h] if sgn == 1 else first[h]
        assert body == b
        assert sorted(h for h, _ in seq) == np.flatnonzero(P[b]).tolist()

    # loop closed form of the digest: L(c) = P(d) - P(b) - e_c
    for i, c in enumerate(t.chords):
        row = P[second[c]] - P[first[c]]
        row[c] -= 1
        assert np.array_equal(L[i], row)

    # order: permutation, references first (ground first), parents before children
    assert sorted(t.order.tolist()) == list(range(nb))
    refs = [t.ground] + [int(asm.max()) for asm in t.assemblies[1:]]
    assert t.order[: len(refs)].tolist() == refs
    pos = np.empty(nb, dtype=np.int64)
    pos[t.order] = np.arange(nb)
    for b in range(nb):
        if t.parent_body[b] >= 0:
            assert pos[t.parent_body[b]] < pos[b]

    # the loop space is the null space of Γ: same span as the book's reduction
    Lb, _, cb, rb = book_reduction(t.incidence)
    assert len(cb) == t.nloops
    if t.nloops:
        assert same_span(L, Lb.astype(np.int64))
    assert not (G @ Lb.astype(np.int64).T).any()
    # the book's reference rows are the highest body of every assembly
    assert sorted(rb.tolist()) == sorted(int(asm.max()) for asm in t.assemblies)


def bfs_depths(nb: int, first: list[int], second: list[int], src: int) -> dict[int, int]:
    adj: list[list[int]] = [[] for _ in range(nb)]
    for u, v in zip(first, second):
        adj[u].append(v)
        adj[v].append(u)
    depth = {src: 0}
    q = deque([src])
    while q:
        u = q.popleft()
        for v in adj[u]:
            if v not in depth:
                depth[v] = depth[u] + 1
                q.append(v)
    return depth


def random_graph(
    rng: np.random.Generator, nb: int, extra: int, connected: bool = True
) -> tuple[list[int], list[int]]:
    """Random oriented multigraph without self-loops, shuffled joint order."""
    arcs: list[tuple[int, int]] = []
    perm = rng.permutation(nb)
    for k in range(1, nb):
        if connected or rng.random() < 0.7:
            u = int(perm[k])
            v = int(perm[rng.integers(0, k)])
            arcs.append((u, v))
    for _ in range(extra):
        u, v = (int(x) for x in rng.choice(nb, size=2, replace=False))
        if not connected:
            # keep the assemblies: only join bodies already connected
            comps = components(nb, [a for a, _ in arcs], [b for _, b in arcs])
            comp = next(c for c in comps if u in c)
            if len(comp) < 2:
                continue
            v = int(rng.choice(sorted(comp - {u})))
        arcs.append((u, v))
    order = rng.permutation(len(arcs))
    arcs = [arcs[i] if rng.random() < 0.5 else arcs[i][::-1] for i in order]
    return [a for a, _ in arcs], [b for _, b in arcs]


# ----------------------------------------------------------------------------
# T1: clamp (Table 2.1)

CLAMP = [(6, 3), (3, 5), (3, 4), (1, 4), (2, 5), (6, 1), (2, 6)]  # A..G
CLAMP_GAMMA = arr(
    [
        [0, 0, 0, -1, 0, 1, 0],
        [0, 0, 0, 0, -1, 0, -1],
        [1, -1, -1, 0, 0, 0, 0],
        [0, 0, 1, 1, 0, 0, 0],
        [0, 1, 0, 0, 1, 0, 0],
        [-1, 0, 0, 0, 0, -1, 1],
    ]
)
CLAMP_L = arr([[1, 0, 1, -1, 0, -1, 0], [-1, -1, 0, 0, 1, 0, -1]])
CLAMP_P = arr(
    [
        [1, 0, 1, -1, 0, 0, 0],
        [1, 1, 0, 0, -1, 0, 0],
        [1, 0, 0, 0, 0, 0, 0],
        [1, 0, 1, 0, 0, 0, 0],
        [1, 1, 0, 0, 0, 0, 0],
        [0, 0, 0, 0, 0, 0, 0],
    ]
)


def test_clamp_incidence_degrees_rank() -> None:
    f, s = book(CLAMP)
    t = analyze(6, f, s, ground=5)
    assert np.array_equal(t.incidence, CLAMP_GAMMA)
    assert t.degree().tolist() == [2, 2, 3, 2, 2, 3]
    assert rank(CLAMP_GAMMA) == 5
    assert t.nassemblies == 1 and t.nloops == 2
    check_invariants(t, f, s)


def test_clamp_book_reduction_exact() -> None:
    L, P, chords, refs = book_reduction(CLAMP_GAMMA)
    assert chords.tolist() == [5, 6]  # cut-set {F, G}
    assert refs.tolist() == [5]  # body 6
    assert np.array_equal(L, CLAMP_L)
    assert np.array_equal(P, CLAMP_P)
    assert L.dtype == np.int8 and P.dtype == np.int8


def test_clamp_gamma11_inverse_and_l1() -> None:
    g11 = CLAMP_GAMMA[:5, :5].astype(float)
    g12 = CLAMP_GAMMA[:5, 5:].astype(float)
    inv = arr(
        [[1, 1, 1, 1, 1], [0, 1, 0, 0, 1], [1, 0, 0, 1, 0], [-1, 0, 0, 0, 0], [0, -1, 0, 0, 0]]
    )
    assert np.allclose(np.linalg.inv(g11), inv)
    l1t = inv @ g12
    assert np.array_equal(l1t, arr([[1, -1], [0, -1], [1, 0], [-1, 0], [0, 1]]))
    assert np.array_equal(CLAMP_L[:, :5], l1t.T)
    # P = [[(Γ11^-1)^t, 0], [0, 0]] (2.15)
    assert np.array_equal(CLAMP_P[:5, :5], inv.T)


def test_clamp_all_six_loops_in_span() -> None:
    f, s = book(CLAMP)
    t = analyze(6, f, s, ground=5)
    six = arr([[1, 0, 1, -1, 0, -1, 0], [-1, -1, 0, 0, 1, 0, -1], [0, -1, 1, -1, 1, -1, -1]])
    six = np.vstack([six, -six])
    assert not (CLAMP_GAMMA @ six.T).any()
    assert rank(np.vstack([t.loops, six])) == 2
    assert same_span(t.loops, CLAMP_L)


def test_clamp_bfs_tree() -> None:
    # BFS from body 6 over joints in index order: A, F, G from 6; B, C from 3.
    f, s = book(CLAMP)
    t = analyze(6, f, s, ground=5)
    assert t.tree.tolist() == [0, 1, 2, 5, 6]
    assert t.chords.tolist() == [3, 4]  # D, E
    assert t.order.tolist() == [5, 2, 0, 1, 4, 3]
    # loop of chord D (1->4): from 1 back over F to 6, A to 3, C to 4, D reversed
    assert t.loop_bodies(0) == [(5, -1), (0, 1), (2, 1), (3, -1)]
    assert t.path_joints(1) == [(6, -1)]  # body 2: G against its orientation
    assert t.path_joints(3) == [(0, 1), (2, 1)]


def test_clamp_other_ground() -> None:
    f, s = book(CLAMP)
    for g in range(6):
        t = analyze(6, f, s, ground=g)
        assert t.order[0] == g and np.all(t.reference == g)
        check_invariants(t, f, s)


# ----------------------------------------------------------------------------
# T2: two assemblies (Fig. 2.8)

TWO = [(1, 2), (3, 1), (3, 2), (4, 5), (6, 5), (7, 4), (7, 6)]  # A..G
TWO_GAMMA = arr(
    [
        [-1, 1, 0, 0, 0, 0, 0],
        [1, 0, 1, 0, 0, 0, 0],
        [0, -1, -1, 0, 0, 0, 0],
        [0, 0, 0, -1, 0, 1, 0],
        [0, 0, 0, 1, 1, 0, 0],
        [0, 0, 0, 0, -1, 0, 1],
        [0, 0, 0, 0, 0, -1, -1],
    ]
)
TWO_L = arr([[0, 0, 0, 1, -1, 1, -1], [1, 1, -1, 0, 0, 0, 0]])
TWO_P = arr(
    [
        [0, 1, 0, 0, 0, 0, 0],
        [1, 1, 0, 0, 0, 0, 0],
        [0, 0, 0, 0, 0, 0, 0],
        [0, 0, 0, 0, 0, 1, 0],
        [0, 0, 0, 1, 0, 1, 0],
        [0, 0, 0, 1, -1, 1, 0],
        [0, 0, 0, 0, 0, 0, 0],
    ]
)


def test_two_assemblies_book_reduction_exact() -> None:
    L, P, chords, refs = book_reduction(TWO_GAMMA)
    assert rank(TWO_GAMMA) == 5
    assert chords.tolist() == [2, 6]  # cut-set {C, G}
    assert refs.tolist() == [2, 6]  # bodies 3 and 7
    # the book prints the G loop first; rows here follow ascending chords
    assert np.array_equal(L, TWO_L[::-1])
    assert np.array_equal(P, TWO_P)


def test_two_assemblies_analyze_ground_7() -> None:
    f, s = book(TWO)
    t = analyze(7, f, s, ground=6)
    assert np.array_equal(t.incidence, TWO_GAMMA)
    assert t.nassemblies == 2 and t.nloops == 2
    assert [x.tolist() for x in t.assemblies] == [[3, 4, 5, 6], [0, 1, 2]]
    assert t.reference.tolist() == [2, 2, 2, 6, 6, 6, 6]
    assert t.order[:2].tolist() == [6, 2]
    assert same_span(t.loops, TWO_L)
    check_invariants(t, f, s)


def test_two_assemblies_analyze_ground_1() -> None:
    f, s = book(TWO)
    t = analyze(7, f, s, ground=0)
    assert [x.tolist() for x in t.assemblies] == [[0, 1, 2], [3, 4, 5, 6]]
    assert t.reference.tolist() == [0, 0, 0, 6, 6, 6, 6]
    check_invariants(t, f, s)


# ----------------------------------------------------------------------------
# T3-T6: single-loop and small examples of Chapters 4-5


def test_ferguson_with_tree_preference() -> None:
    # T3: A 1->2, B 5->1, C 3->2, D 5->3, E 4->2, F 5->4, G 5->2; book tree A,B,D,F
    f, s = book([(1, 2), (5, 1), (3, 2), (5, 3), (4, 2), (5, 4), (5, 2)])
    pref = [0, 0, 1, 0, 1, 0, 1]
    t = analyze(5, f, s, ground=4, tree_preference=pref)
    assert t.chords.tolist() == [2, 4, 6]
    book_l = arr([[1, 1, 0, 0, 0, 0, -1], [1, 1, 0, 0, -1, -1, 0], [1, 1, -1, -1, 0, 0, 0]])
    assert np.array_equal(t.loops, book_l[::-1])  # book order G, E, C
    book_p = arr(
        [
            [0, 1, 0, 0, 0, 0, 0],
            [1, 1, 0, 0, 0, 0, 0],
            [0, 0, 0, 1, 0, 0, 0],
            [0, 0, 0, 0, 0, 1, 0],
            [0, 0, 0, 0, 0, 0, 0],
        ]
    )
    assert np.array_equal(t.paths, book_p)
    check_invariants(t, f, s)
    # plain BFS from 5 takes B, D, F, G and cuts A, C, E
    t0 = analyze(5, f, s, ground=4)
    assert t0.chords.tolist() == [0, 2, 4]
    assert same_span(t0.loops, book_l)
    check_invariants(t0, f, s)


def test_oldham() -> None:
    # T4: A 4->1, B 1->2, C 3->2, D 4->3
    f, s = book([(4, 1), (1, 2), (3, 2), (4, 3)])
    book_l = arr([[1, 1, -1, -1]])
    book_p = arr([[1, 0, 0, 0], [1, 1, 0, 0], [1, 1, -1, 0], [0, 0, 0, 0]])
    L, P, chords, refs = book_reduction(analyze(4, f, s, 3).incidence)
    assert np.array_equal(L, book_l) and np.array_equal(P, book_p)
    assert chords.tolist() == [3] and refs.tolist() == [3]
    t = analyze(4, f, s, ground=3, tree_preference=[0, 0, 0, 1])
    assert np.array_equal(t.loops, book_l) and np.array_equal(t.paths, book_p)
    assert t.path_joints(2) == [(0, 1), (1, 1), (2, -1)]
    check_invariants(t, f, s)
    t0 = analyze(4, f, s, ground=3)
    assert t0.chords.tolist() == [2]
    assert np.array_equal(t0.loops, book_l)  # the same loop, now closed by C
    check_invariants(t0, f, s)


def test_cardan_single_loop() -> None:
    # T5: A 4->1, B 1->2, C 2->3, D 3->4; book L = [1,1,1,1] up to orientation
    f, s = book([(4, 1), (1, 2), (2, 3), (3, 4)])
    t = analyze(4, f, s, ground=3)
    assert t.nloops == 1
    assert np.array_equal(np.abs(t.loops), [[1, 1, 1, 1]])
    assert len(set(t.loops[0].tolist())) == 1  # all joints the same sense
    check_invariants(t, f, s)


def test_disk_cam() -> None:
    # T6: A 3->1, B 1->2, C 3->2; L = [1, 1, -1]
    f, s = book([(3, 1), (1, 2), (3, 2)])
    t = analyze(3, f, s, ground=2, tree_preference=[0, 0, 1])
    assert np.array_equal(t.loops, [[1, 1, -1]])
    assert np.array_equal(book_reduction(t.incidence)[0], [[1, 1, -1]])
    check_invariants(t, f, s)


# ----------------------------------------------------------------------------
# P2.1, P2.2


P21 = [(1, 2), (2, 3), (2, 4), (3, 5), (4, 5), (5, 6), (5, 7), (6, 8), (7, 8), (8, 1)]


def test_p21() -> None:
    f, s = book(P21)
    t = analyze(8, f, s, ground=7)
    assert t.nloops == 3 and t.nassemblies == 1
    check_invariants(t, f, s)
    L, P, chords, refs = book_reduction(t.incidence)
    assert chords.tolist() == [4, 8, 9]  # {E, J, K}
    assert refs.tolist() == [7]
    assert np.array_equal(
        L,
        arr(
            [
                [0, 1, -1, 1, -1, 0, 0, 0, 0, 0],
                [0, 0, 0, 0, 0, 1, -1, 1, -1, 0],
                [-1, -1, 0, -1, 0, -1, 0, -1, 0, -1],
            ]
        ),
    )
    assert np.array_equal(
        P,
        arr(
            [
                [-1, -1, 0, -1, 0, -1, 0, -1, 0, 0],
                [0, -1, 0, -1, 0, -1, 0, -1, 0, 0],
                [0, 0, 0, -1, 0, -1, 0, -1, 0, 0],
                [0, -1, 1, -1, 0, -1, 0, -1, 0, 0],
                [0, 0, 0, 0, 0, -1, 0, -1, 0, 0],
                [0, 0, 0, 0, 0, 0, 0, -1, 0, 0],
                [0, 0, 0, 0, 0, -1, 1, -1, 0, 0],
                [0, 0, 0, 0, 0, 0, 0, 0, 0, 0],
            ]
        ),
    )
    assert same_span(t.loops, L)


def stewart() -> tuple[list[int], list[int]]:
    # bodies: 0 platform, 2k-1 CYLk, 2k PISTONk (k = 1..6), 13 base
    # joints: 3(k-1) Sk platform->CYLk, +1 Pk CYLk->PISTONk, +2 Uk PISTONk->base
    f: list[int] = []
    s: list[int] = []
    for k in range(1, 7):
        f += [0, 2 * k - 1, 2 * k]
        s += [2 * k - 1, 2 * k, 13]
    return f, s


def test_p22_stewart() -> None:
    f, s = stewart()
    t = analyze(14, f, s, ground=13)
    G = t.incidence
    assert G.shape == (14, 18) and rank(G) == 13
    assert np.all(G[0, 0::3] == -1) and np.all(G[13, 2::3] == 1)
    assert t.nloops == 5
    check_invariants(t, f, s)
    L, _, chords, refs = book_reduction(G)
    assert chords.tolist() == [5, 8, 11, 14, 17]  # U2..U6
    assert refs.tolist() == [13]
    for i, k in enumerate(range(2, 7)):
        row = np.zeros(18, dtype=np.int64)
        row[[0, 1, 2]] = 1
        row[[3 * (k - 1), 3 * (k - 1) + 1, 3 * (k - 1) + 2]] = -1
        assert np.array_equal(L[i], row)
    assert same_span(t.loops, L)
    # BFS from the base reaches the platform through leg 1 and cuts S2..S6
    assert t.chords.tolist() == [3, 6, 9, 12, 15]
    assert t.path_joints(0) == [(2, -1), (1, -1), (0, -1)]


# ----------------------------------------------------------------------------
# random graphs


@pytest.mark.parametrize("seed", range(40))
def test_random_connected(seed: int) -> None:
    rng = np.random.default_rng(1000 + seed)
    nb = int(rng.integers(1, 16))
    extra = int(rng.integers(0, 10)) if nb > 1 else 0
    f, s = random_graph(rng, nb, extra)
    g = int(rng.integers(0, nb))
    t = analyze(nb, f, s, ground=g)
    assert t.nassemblies == 1
    check_invariants(t, f, s)
    # a BFS tree gives shortest paths from the reference body
    depth = bfs_depths(nb, f, s, g)
    for b in range(nb):
        assert len(t.path_joints(b)) == depth[b]
    # with the ground as highest body the reference agrees with the book's rule
    perm = list(range(nb))
    perm[g], perm[nb - 1] = perm[nb - 1], perm[g]
    f2, s2 = [perm[x] for x in f], [perm[x] for x in s]
    t2 = analyze(nb, f2, s2, ground=nb - 1)
    assert book_reduction(t2.incidence)[3].tolist() == [nb - 1]
    check_invariants(t2, f2, s2)


@pytest.mark.parametrize("seed", range(20))
def test_random_multi_assembly(seed: int) -> None:
    rng = np.random.default_rng(2000 + seed)
    nb = int(rng.integers(2, 16))
    f, s = random_graph(rng, nb, int(rng.integers(0, 8)), connected=False)
    g = int(rng.integers(0, nb))
    t = analyze(nb, f, s, ground=g)
    assert t.nassemblies == len(components(nb, f, s))
    check_invariants(t, f, s)
    # non-ground assemblies are ordered by their lowest body
    mins = [int(x.min()) for x in t.assemblies[1:]]
    assert mins == sorted(mins)


def kruskal_weight(nb: int, f: list[int], s: list[int], w: list[float]) -> float:
    parent = list(range(nb))

    def find(x: int) -> int:
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    total = 0.0
    for h in sorted(range(len(f)), key=lambda h: w[h]):
        a, b = find(f[h]), find(s[h])
        if a != b:
            parent[a] = b
            total += w[h]
    return total


@pytest.mark.parametrize("seed", range(20))
def test_random_tree_preference_is_minimal(seed: int) -> None:
    rng = np.random.default_rng(3000 + seed)
    nb = int(rng.integers(2, 14))
    f, s = random_graph(rng, nb, int(rng.integers(0, 10)), connected=bool(seed % 2))
    pref = [float(x) for x in rng.integers(0, 4, size=len(f))]
    g = int(rng.integers(0, nb))
    t = analyze(nb, f, s, ground=g, tree_preference=pref)
    check_invariants(t, f, s)
    assert sum(pref[h] for h in t.tree) == kruskal_weight(nb, f, s, pref)


# ----------------------------------------------------------------------------
# tree preference, special cases, errors


def test_preference_pushes_open_joint_to_cutset() -> None:
    # four-bar 0-1-2-3-0 (ground 0); joint 0 is 'open'
    f, s = [0, 1, 2, 3], [1, 2, 3, 0]
    t = analyze(4, f, s, ground=0)
    assert t.chords.tolist() == [2]
    t = analyze(4, f, s, ground=0, tree_preference=[1.0, 0, 0, 0])
    assert t.chords.tolist() == [0]
    check_invariants(t, f, s)


def test_preference_cannot_cut_a_bridge() -> None:
    # triangle 0-1-2 plus a pendant body 3 hanging on a preferred-out joint
    f, s = [0, 1, 2, 2], [1, 2, 0, 3]
    t = analyze(4, f, s, ground=0, tree_preference=[0, 0, 0, 5])
    assert 3 in t.tree.tolist() and t.nloops == 1
    check_invariants(t, f, s)


def test_parallel_joints() -> None:
    f, s = [0, 1, 0], [1, 0, 1]
    t = analyze(2, f, s, ground=0)
    assert t.tree.tolist() == [0] and t.chords.tolist() == [1, 2]
    assert np.array_equal(t.loops, [[-1, -1, 0], [1, 0, -1]])
    check_invariants(t, f, s)


def test_no_joints() -> None:
    t = analyze(1, [], [], ground=0)
    assert t.nloops == 0 and t.nassemblies == 1 and t.loops.shape == (0, 0)
    assert t.order.tolist() == [0] and t.path_joints(0) == []
    t = analyze(3, [], [], ground=1)
    assert [x.tolist() for x in t.assemblies] == [[1], [0], [2]]
    assert t.reference.tolist() == [0, 1, 2]
    assert t.order.tolist() == [1, 0, 2]
    check_invariants(t, [], [])


def test_isolated_body_is_own_assembly() -> None:
    f, s = [0, 1], [1, 2]
    t = analyze(5, f, s, ground=2)
    assert [x.tolist() for x in t.assemblies] == [[0, 1, 2], [3], [4]]
    assert t.reference.tolist() == [2, 2, 2, 3, 4]
    check_invariants(t, f, s)


def test_numpy_inputs_accepted() -> None:
    f, s = book(CLAMP)
    t = analyze(np.int64(6), np.array(f), np.array(s, dtype=np.int32), np.int8(5))
    assert np.array_equal(t.incidence, CLAMP_GAMMA)


def test_self_loop_names_joint() -> None:
    with pytest.raises(InputError, match=r"joint 2 .*self-loop"):
        analyze(3, [0, 1, 2], [1, 2, 2], ground=0)


@pytest.mark.parametrize(
    ("nb", "f", "s", "g", "pref", "pattern"),
    [
        (3, [0, 1], [1, 3], 0, None, r"joint 1: second body 3 out of range"),
        (3, [-1], [1], 0, None, r"joint 0: first body -1 out of range"),
        (3, [0, 1], [1], 0, None, r"one entry per joint"),
        (3, [0], [1], 3, None, r"ground body 3 out of range"),
        (0, [], [], 0, None, r"at least one body"),
        (3, [0], [1], 0, [0.0, 1.0], r"tree_preference has 2 entries"),
        (3, [0], [1], 0, [float("nan")], r"joint 0 is NaN"),
        (3, [0.5], [1], 0, None, r"integer body indices"),
    ],
)
def test_input_errors(
    nb: int, f: list, s: list, g: int, pref: list[float] | None, pattern: str
) -> None:
    with pytest.raises(InputError, match=pattern):
        analyze(nb, f, s, ground=g, tree_preference=pref)


def test_accessor_range_errors() -> None:
    f, s = book(CLAMP)
    t = analyze(6, f, s, ground=5)
    with pytest.raises(InputError):
        t.loop_bodies(2)
    with pytest.raises(InputError):
        t.path_joints(6)


def test_frozen_and_read_only() -> None:
    f, s = book(CLAMP)
    t = analyze(6, f, s, ground=5)
    with pytest.raises(dataclasses.FrozenInstanceError):
        t.ground = 0  # type: ignore[misc]
    with pytest.raises(ValueError):
        t.loops[0, 0] = 0
    with pytest.raises(ValueError):
        t.paths[0, 0] = 0
    assert t == t and hash(t) == hash(t)
