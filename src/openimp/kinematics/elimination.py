"""Elimination stage: the Jacobian of the loop equations and its restricted pivoting
(book 6.5.3), the replay of its row operations and the first geometric derivatives.

The Jacobian is the only matrix ever inverted for derivatives
(docs/architecture.md, Conventions): the by-products of its elimination
(J11^-1 J12, J11^-1 J13 and the row operations) serve the Newton step, the
predictor of the next posture, the velocities (7.14), the accelerations (8.44)
and, later, the forces (ch 17).

* :func:`jacobian`: J = [L(i,h) screws of D_h | ER rows] (6.45);
* :func:`eliminate`: restricted complete-pivoting Gauss-Jordan on [J | E];
* :func:`replay`: J11^-1 applied to any right-hand side, from the kept row operations;
* :func:`derivatives`: phi' = dq/dpsi for chosen coordinates (7.14).
"""

from __future__ import annotations

import numpy as np

from openimp._jit import njit
from openimp.kinematics.position import screws
from openimp.system import data_views, model_views


@njit(nrt=False, inline="always")
def jacobian(KP: tuple, DP: tuple, S: tuple, gen: np.ndarray | None) -> None:
    """Jacobian of the loop equations (6.45): L(i,h) times the screws of D_h, ER rows.

    Computes the screws (:func:`~openimp.kinematics.position.screws`, after
    :func:`~openimp.kinematics.position.position` with ``order`` 1) and fills
    d.J (m x nq).  Writes only the entries the loops and ER blocks fill, the
    same ones at every call: d.J starts zeroed (:func:`openimp.system.make_data`).
    """
    K = model_views(KP)
    d = data_views(DP)
    J = d.J
    Dh = d.Dh
    screws(KP, DP, gen)
    nl = K.L.shape[0]
    for i in range(nl):
        r0 = 6 * i
        for h in range(K.jcode.shape[0]):
            lih = K.L[i, h]
            if lih == 0:
                continue
            a0 = K.jq0[h]
            for g in range(K.jnv[h]):
                for k in range(6):
                    J[r0 + k, a0 + g] = lih * Dh[a0 + g, k]
    r = 6 * nl
    for k in range(K.er.shape[0]):
        e0 = K.er[k]
        for t in range(4):
            J[r + k, e0 + t] = 2.0 * S.q[e0 + t]


@njit(nrt=False)
def free_columns(DP: tuple, sgc: np.ndarray, rank: int, free: np.ndarray) -> int:
    """The free generalized coordinates (FGCs) an elimination leaves (6.5.3, 7.14):
    free[a] (nq,) true where column a is neither specified (``sgc``) nor among the
    first ``rank`` pivot columns of the last :func:`eliminate`.  Returns their number.
    The one choice of the FGCs: every analysis takes them from here."""
    d = data_views(DP)
    nq = free.shape[0]
    for a in range(nq):
        free[a] = not sgc[a]
    for k in range(rank):
        free[d.pcol[k]] = False
    n = 0
    for a in range(nq):
        if free[a]:
            n += 1
    return n


@njit(nrt=False, inline="always")
def eliminate(DP: tuple, sgc: np.ndarray, tol: float) -> tuple[int, float, float]:
    """Restricted complete-pivoting Gauss-Jordan elimination of [J | E] (book 6.5.3).

    The tableau d.T (m x (nq + 1)) receives [J | E] reduced in place: pivot
    row ``prow[k]`` holds, in the columns of J, a unit at ``pcol[k]`` and the
    by-products J11^-1 J12 (free columns) and J11^-1 J13 (specified columns);
    in the last column the solution.  Columns with ``sgc`` (nq,) true are
    never pivoted.  The row operations are kept (``pinv[k]`` = 1 / pivot k,
    ``mult[k, r]`` = the multiple of pivot row k taken from row r), so
    :func:`replay` applies J11^-1 to any other right-hand side without a
    second elimination.  Returns the rank, the quality index |det J11| (6.53)
    and the largest entry left unpivoted (below ``tol``; 0 when the
    elimination ran out of rows or columns).
    """
    d = data_views(DP)
    J = d.J
    T = d.T
    prow = d.prow
    pcol = d.pcol
    mult = d.mult
    m = J.shape[0]
    n = J.shape[1]
    for r in range(m):
        for c in range(n):
            T[r, c] = J[r, c]
        T[r, n] = d.E[r]
    rowused = d.used[:m]
    colused = d.used[m:m + n]
    for r in range(m):
        rowused[r] = False
    for c in range(n):
        colused[c] = False
    det = 1.0
    rank = 0
    rest = 0.0
    for k in range(min(m, n)):
        best = 0.0
        br = -1
        bc = -1
        for r in range(m):
            if rowused[r]:
                continue
            for c in range(n):
                if colused[c] or sgc[c]:
                    continue
                v = abs(T[r, c])
                if v > best:
                    best = v
                    br = r
                    bc = c
        if best <= tol:
            rest = best
            break
        rowused[br] = True
        colused[bc] = True
        prow[k] = br
        pcol[k] = bc
        rank += 1
        inv = 1.0 / T[br, bc]
        d.pinv[k] = inv
        det *= best
        for c in range(n + 1):
            T[br, c] *= inv
        T[br, bc] = 1.0
        for r in range(m):
            if r == br:
                mult[k, r] = 0.0
                continue
            f = T[r, bc]
            mult[k, r] = f
            if f != 0.0:
                for c in range(n + 1):
                    T[r, c] -= f * T[br, c]
                T[r, bc] = 0.0
    return rank, det, rest


@njit(nrt=False, forceinline=True)
def replay(DP: tuple, rank: int, e: np.ndarray) -> None:
    """Apply the row operations of the last elimination to the right-hand side ``e`` (m,).

    Afterwards e[prow[k]] is component pcol[k] of J11^-1 e (the same as the
    augmented identity block of book 6.5.3 would give) and the other rows
    hold what the dependent equations leave unexplained (8.45).
    """
    d = data_views(DP)
    prow = d.prow
    mult = d.mult
    m = e.shape[0]
    for k in range(rank):
        br = prow[k]
        v = e[br] * d.pinv[k]
        e[br] = v
        if v != 0.0:
            for r in range(m):
                e[r] -= mult[k, r] * v


@njit(nrt=False)
def derivatives(DP: tuple, rank: int, cols: np.ndarray, G: np.ndarray) -> None:
    """First geometric derivatives phi' = dq/dpsi for the coordinates ``cols`` (7.14).

    G (nq x len(cols)): -J11^-1 J1j in the dependent rows, 1 at cols[j], 0
    elsewhere, from the tableau of the last elimination.
    """
    d = data_views(DP)
    T = d.T
    for r in range(G.shape[0]):
        for j in range(cols.shape[0]):
            G[r, j] = 0.0
    for j in range(cols.shape[0]):
        G[cols[j], j] = 1.0
        for k in range(rank):
            G[d.pcol[k], j] = -T[d.prow[k], cols[j]]
