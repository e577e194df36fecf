"""Posture, velocity and acceleration analysis (book ch 5-8).

The kernels here work on the flat arrays of :class:`~openimp.system.System`
(:data:`~openimp.system.KData`) and are compiled by numba (see
:mod:`openimp._jit`):

* :func:`postures` - T_0b of every body along the spanning tree (5.4, 5.5);
* :func:`loop_equations` - the loop residuals E_i with the false-solution
  guard (6.40, 6.48), the Euler-Rodrigues rows (6.43) and the Jacobian
  built from the screw coordinates of D_h = A_h Q_h A_h^-1 (6.14, 6.41, 6.45);
* :func:`gauss_jordan` - the restricted complete-pivoting Gauss-Jordan
  elimination of book 6.5.3 that never pivots on a specified coordinate and
  keeps its by-products (J11^-1, J11^-1 J12, J11^-1 J13) in the tableau;
* :func:`newton` - Newton-Raphson to the tolerance, with a divergence guard;
* :func:`sweep_kernel` - a whole sweep: first-order predictor from the
  by-products, step halving, quality index, mobility and FGCs per step.

:func:`sweep` is the Python entry point; it returns a :class:`SweepResult`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from openimp._jit import njit, prange
from openimp.errors import AnalysisError, InputError
from openimp.joints import (
    CYLINDER,
    MAXV,
    PRISMATIC,
    REVOLUTE,
    RIGID,
    SCREW,
    SPHERE,
    SPHERE_GROOVE,
    SPHERE_PLANE,
    joint_dQ,
    joint_phi,
    joint_Q,
)
from openimp.system import unpack

if TYPE_CHECKING:
    from openimp.system import System

# status codes of the kernels
OK = 0
MAXITER = 1
DIVERGED = 2
SGC_DETERMINED = 3


# =============================================================================
# 4x4 helpers
# =============================================================================
@njit(nrt=False, forceinline=True)
def inv4(a: np.ndarray, out: np.ndarray) -> None:
    """Rigid inverse of a homogeneous 4x4 whose rotation part is orthogonal."""
    for i in range(3):
        for j in range(3):
            out[i, j] = a[j, i]
    for i in range(3):
        out[i, 3] = -(a[0, i] * a[0, 3] + a[1, i] * a[1, 3] + a[2, i] * a[2, 3])
    out[3, 0] = 0.0
    out[3, 1] = 0.0
    out[3, 2] = 0.0
    out[3, 3] = 1.0


@njit(nrt=False, forceinline=True)
def gen_inv4(a: np.ndarray, out: np.ndarray) -> None:
    """Inverse of a homogeneous 4x4 whose 3x3 block need not be orthogonal.

    Joint matrices built from Euler-Rodrigues parameters off the unit sphere
    are scaled rotations; the exact inverse keeps Newton consistent there.
    """
    m = a
    det = (
        m[0, 0] * (m[1, 1] * m[2, 2] - m[1, 2] * m[2, 1])
        - m[0, 1] * (m[1, 0] * m[2, 2] - m[1, 2] * m[2, 0])
        + m[0, 2] * (m[1, 0] * m[2, 1] - m[1, 1] * m[2, 0])
    )
    inv = 1.0 / det
    out[0, 0] = (m[1, 1] * m[2, 2] - m[1, 2] * m[2, 1]) * inv
    out[0, 1] = (m[0, 2] * m[2, 1] - m[0, 1] * m[2, 2]) * inv
    out[0, 2] = (m[0, 1] * m[1, 2] - m[0, 2] * m[1, 1]) * inv
    out[1, 0] = (m[1, 2] * m[2, 0] - m[1, 0] * m[2, 2]) * inv
    out[1, 1] = (m[0, 0] * m[2, 2] - m[0, 2] * m[2, 0]) * inv
    out[1, 2] = (m[0, 2] * m[1, 0] - m[0, 0] * m[1, 2]) * inv
    out[2, 0] = (m[1, 0] * m[2, 1] - m[1, 1] * m[2, 0]) * inv
    out[2, 1] = (m[0, 1] * m[2, 0] - m[0, 0] * m[2, 1]) * inv
    out[2, 2] = (m[0, 0] * m[1, 1] - m[0, 1] * m[1, 0]) * inv
    for i in range(3):
        out[i, 3] = -(out[i, 0] * a[0, 3] + out[i, 1] * a[1, 3] + out[i, 2] * a[2, 3])
    out[3, 0] = 0.0
    out[3, 1] = 0.0
    out[3, 2] = 0.0
    out[3, 3] = 1.0


# =============================================================================
# Postures and loop equations
# =============================================================================
@njit(nrt=False, forceinline=True)
def mm4(a: np.ndarray, ia: int, b: np.ndarray, ib: int, out: np.ndarray, io: int) -> None:
    """out[io] = a[ia] @ b[ib] for stacks of homogeneous 4x4 matrices.

    Indices instead of views: a view made inside a loop that also calls
    other kernels costs a pair of atomic reference counts.  ``out`` may be
    ``a`` (same index: each row of a is read before it is written), not ``b``.
    """
    for i in range(3):
        x0 = a[ia, i, 0]
        x1 = a[ia, i, 1]
        x2 = a[ia, i, 2]
        x3 = a[ia, i, 3]
        for j in range(4):
            out[io, i, j] = x0 * b[ib, 0, j] + x1 * b[ib, 1, j] + x2 * b[ib, 2, j]
        out[io, i, 3] += x3
    out[io, 3, 0] = 0.0
    out[io, 3, 1] = 0.0
    out[io, 3, 2] = 0.0
    out[io, 3, 3] = 1.0


@njit(nrt=False, forceinline=True)
def er_norm2(x: np.ndarray, e0: int) -> float:
    """Sum of squares of the block of four Euler-Rodrigues entries of ``x`` at ``e0``.

    Of the parameters: the normalisation residual 1 - |e|^2 (6.43); of their
    rates: -2 |e'|^2, the acceleration right-hand side of that row.
    """
    return x[e0] * x[e0] + x[e0 + 1] * x[e0 + 1] + x[e0 + 2] * x[e0 + 2] + x[e0 + 3] * x[e0 + 3]


@njit(nrt=False, forceinline=True)
def right_phi(
    code: int, q: np.ndarray, a0: int, M: np.ndarray, im: int, W: np.ndarray, iw: int,
    inverse: bool, Phi: np.ndarray, h: int, scr: np.ndarray,
) -> None:
    """W[iw] = M[im] Phi_h(q) (or M[im] Phi_h^-1 with ``inverse``) for joint h of kind ``code``.

    Rigid, revolute, prismatic and cylindric joints touch only the columns
    their Phi moves (two columns for a rotation about z, the last for a slide
    along z); the other kinds use ``Phi[h]``, computed beforehand by
    :func:`general_phis` into ``Phi[h]``.  ``W`` and ``M`` must be different arrays.
    """
    if code == REVOLUTE or code == PRISMATIC or code == CYLINDER or code == RIGID:
        th = 0.0
        d = 0.0
        if code == PRISMATIC:
            d = q[a0]
        elif code != RIGID:
            th = q[a0]
            if code == CYLINDER:
                d = q[a0 + 1]
        if inverse:  # Rz(th) Tz(d) inverts to Rz(-th) Tz(-d): both act along z
            th = -th
            d = -d
        ca = math.cos(th)
        sa = math.sin(th)
        for i in range(3):
            m0 = M[im, i, 0]
            m1 = M[im, i, 1]
            m2 = M[im, i, 2]
            W[iw, i, 0] = ca * m0 + sa * m1
            W[iw, i, 1] = ca * m1 - sa * m0
            W[iw, i, 2] = m2
            W[iw, i, 3] = M[im, i, 3] + d * m2
        W[iw, 3, 0] = 0.0
        W[iw, 3, 1] = 0.0
        W[iw, 3, 2] = 0.0
        W[iw, 3, 3] = 1.0
    elif inverse:
        gen_inv4(Phi[h], scr[7])
        mm4(M, im, scr, 7, W, iw)
    else:
        mm4(M, im, Phi, h, W, iw)


@njit(nrt=False, inline="always")
def general_phis(KP: tuple, q: np.ndarray, scr: np.ndarray) -> None:
    """Phi_h of every joint of a general kind (K.gen) into scr[8 + h], through joint_phi.

    Computed before the tree loop, which then multiplies by the stored Phi_h.
    """
    K = unpack(KP)
    for k in range(K.gen.shape[0]):
        h = K.gen[k]
        a0 = K.jq0[h]
        joint_phi(K.jcode[h], q[a0:a0 + K.jnv[h]], K.const[K.jc0[h]:], scr[8 + h])


@njit(nrt=False)
def tree_pass(
    KP: tuple, q: np.ndarray, A: np.ndarray, T0: np.ndarray, E: np.ndarray, scr: np.ndarray
) -> float:
    """One pass along the tree and the chords: postures, A_h and the loop residuals.

    T_0b of every body (5.4, 5.5) follows its parent joint h:
    A_h = T_{0h-} S_{h-,h} and T_0b = A_h Phi_h S_{h+,h}^-1 (or, against the
    joint's direction, A_h = T_{0h+} S_{h+,h} Phi_h^-1 and T_0b = A_h
    S_{h-,h}^-1).  Loop i closes its chord c from body b to body d:
    F = T_0b S_{c-,c} Phi_c S_{c+,c}^-1 T_0d^-1 = I, and E holds F - I taken
    through the false-solution guard (6.48), then the Euler-Rodrigues rows
    (6.43).  Returns max |E|.  Scratch: scr[0..2] and scr[7]; Phi_h of the
    general kinds goes to scr[8 + h].
    """
    K = unpack(KP)
    if K.gen.shape[0] > 0:
        general_phis(KP, q, scr)
    for k in range(K.order.shape[0]):
        b = K.order[k]
        h = K.pj[b]
        if h < 0:
            for r in range(4):
                for c in range(4):
                    T0[b, r, c] = K.Tref[b, r, c]
        elif K.psign[b] > 0:
            mm4(T0, K.jb1[h], K.S1, h, A, h)
            right_phi(K.jcode[h], q, K.jq0[h], A, h, scr, 0, False, scr, 8 + h, scr)
            mm4(scr, 0, K.S2inv, h, T0, b)
        else:
            mm4(T0, K.jb2[h], K.S2, h, scr, 0)
            right_phi(K.jcode[h], q, K.jq0[h], scr, 0, A, h, True, scr, 8 + h, scr)
            mm4(A, h, K.S1inv, h, T0, b)
    err = 0.0
    for i in range(K.chord.shape[0]):
        ch = K.chord[i]
        d = K.jb2[ch]
        mm4(T0, K.jb1[ch], K.S1, ch, A, ch)
        right_phi(K.jcode[ch], q, K.jq0[ch], A, ch, scr, 0, False, scr, 8 + ch, scr)
        mm4(scr, 0, K.S2inv, ch, scr, 0)
        inv4(T0[d], scr[2])
        mm4(scr, 0, scr, 2, scr, 1)
        r0 = 6 * i
        E[r0 + 0] = scr[1, 0, 3]
        E[r0 + 1] = scr[1, 1, 3]
        E[r0 + 2] = scr[1, 2, 3]
        # (6.48): the diagonal terms (cos-1, second order near a true closure)
        # push the iteration away from a false solution with 180 deg errors.
        f00 = scr[1, 0, 0] - 1.0
        f11 = scr[1, 1, 1] - 1.0
        f22 = scr[1, 2, 2] - 1.0
        E[r0 + 3] = scr[1, 2, 1] + f11 + f22
        E[r0 + 4] = scr[1, 0, 2] + f00 + f22
        E[r0 + 5] = scr[1, 1, 0] + f11 + f00
        for k in range(6):
            if abs(E[r0 + k]) > err:
                err = abs(E[r0 + k])
    r = 6 * K.chord.shape[0]
    for k in range(K.er.shape[0]):
        E[r + k] = 1.0 - er_norm2(q, K.er[k])
        if abs(E[r + k]) > err:
            err = abs(E[r + k])
    return err


@njit(nrt=False, inline="always")
def screw_columns(
    KP: tuple, q: np.ndarray, A: np.ndarray, Dh: np.ndarray, Qb: np.ndarray, scr: np.ndarray
) -> None:
    """Screw coordinates (6.41) of D = A Q A^-1 for every joint variable, into Dh[nq, 6].

    Revolute, prismatic and cylindric columns in closed form: the unit
    rotation about w = R e3 through p has [p x w, w], the unit slide [w, 0].
    """
    K = unpack(KP)
    for h in range(K.jcode.shape[0]):
        nv = K.jnv[h]
        if nv == 0:
            continue
        a0 = K.jq0[h]
        code = K.jcode[h]
        if code == REVOLUTE or code == PRISMATIC or code == CYLINDER:
            wx = A[h, 0, 2]
            wy = A[h, 1, 2]
            wz = A[h, 2, 2]
            c = a0
            if code != PRISMATIC:
                px = A[h, 0, 3]
                py = A[h, 1, 3]
                pz = A[h, 2, 3]
                Dh[a0, 0] = py * wz - pz * wy
                Dh[a0, 1] = pz * wx - px * wz
                Dh[a0, 2] = px * wy - py * wx
                Dh[a0, 3] = wx
                Dh[a0, 4] = wy
                Dh[a0, 5] = wz
                c = a0 + 1
            if code != REVOLUTE:
                Dh[c, 0] = wx
                Dh[c, 1] = wy
                Dh[c, 2] = wz
                Dh[c, 3] = 0.0
                Dh[c, 4] = 0.0
                Dh[c, 5] = 0.0
    for k in range(K.gen.shape[0]):
        h = K.gen[k]
        _screw_general(K.jcode[h], q, K.jq0[h], K.jnv[h], K.const, K.jc0[h], A, h, Dh, Qb, scr)


@njit(nrt=False, inline="always")
def _screw_general(
    code: int, q: np.ndarray, a0: int, nv: int, const: np.ndarray, c0: int, A: np.ndarray,
    h: int, Dh: np.ndarray, Qb: np.ndarray, scr: np.ndarray,
) -> None:
    """Screw coordinates of A_h Q_g A_h^-1 for a joint of any kind (through joint_Q)."""
    RM = scr[4]
    Mp = scr[5]
    Ah = A[h]
    joint_Q(code, q[a0:a0 + nv], const[c0:], Qb)
    for g in range(nv):
        Qg = Qb[g]
        # M' = R M R^T (only the three skew entries are needed)
        for i in range(3):
            for j in range(3):
                RM[i, j] = Ah[i, 0] * Qg[0, j] + Ah[i, 1] * Qg[1, j] + Ah[i, 2] * Qg[2, j]
        for i in range(3):
            for j in range(3):
                Mp[i, j] = RM[i, 0] * Ah[j, 0] + RM[i, 1] * Ah[j, 1] + RM[i, 2] * Ah[j, 2]
        col = a0 + g
        for i in range(3):
            # column 4: R v - M' p
            Dh[col, i] = (
                Ah[i, 0] * Qg[0, 3] + Ah[i, 1] * Qg[1, 3] + Ah[i, 2] * Qg[2, 3]
                - (Mp[i, 0] * Ah[0, 3] + Mp[i, 1] * Ah[1, 3] + Mp[i, 2] * Ah[2, 3])
            )
        Dh[col, 3] = Mp[2, 1]
        Dh[col, 4] = Mp[0, 2]
        Dh[col, 5] = Mp[1, 0]


@njit(nrt=False, inline="always")
def loop_jacobian(
    KP: tuple, q: np.ndarray, A: np.ndarray, Dh: np.ndarray, J: np.ndarray, Qb: np.ndarray,
    scr: np.ndarray,
) -> None:
    """Jacobian of the loop equations (6.45): L(i,h) times the screws of D_h, ER rows.

    Writes only the entries the loops and ER blocks fill, the same ones at
    every call: ``J`` must start zeroed (:func:`work_arrays`).
    """
    K = unpack(KP)
    nl = K.L.shape[0]
    nj = K.jcode.shape[0]
    screw_columns(KP, q, A, Dh, Qb, scr)
    for i in range(nl):
        r0 = 6 * i
        for h in range(nj):
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
            J[r + k, e0 + t] = 2.0 * q[e0 + t]


@njit(nrt=False, inline="always")
def gauss_jordan(
    J: np.ndarray, E: np.ndarray, sgc: np.ndarray, tol: float, T: np.ndarray,
    prow: np.ndarray, pcol: np.ndarray, pinv: np.ndarray, mult: np.ndarray, used: np.ndarray,
) -> tuple[int, float, float]:
    """Restricted complete-pivoting Gauss-Jordan elimination (book 6.5.3).

    The tableau ``T`` (m x (n + 1)) receives [J | E] reduced in place: pivot
    row ``prow[k]`` holds, in the columns of J, a unit at ``pcol[k]`` and the
    by-products J11^-1 J12 (free columns) and J11^-1 J13 (specified columns);
    in the last column the solution.  Columns with ``sgc`` true are never
    pivoted.  The row operations are kept (``pinv[k]`` = 1 / pivot k,
    ``mult[k, r]`` = the multiple of pivot row k taken from row r), so
    :func:`replay` applies J11^-1 to any other right-hand side without a
    second elimination.  ``used`` is boolean scratch of length m + n.
    Returns the rank, the quality index |det J11| and the largest entry left
    unpivoted (below ``tol``; 0 when the elimination ran out of rows or
    columns).
    """
    m = J.shape[0]
    n = J.shape[1]
    for r in range(m):
        for c in range(n):
            T[r, c] = J[r, c]
        T[r, n] = E[r]
    rowused = used[:m]
    colused = used[m:m + n]
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
        pinv[k] = inv
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


@njit(nrt=False, inline="always")
def replay(
    prow: np.ndarray, pinv: np.ndarray, mult: np.ndarray, rank: int, e: np.ndarray
) -> None:
    """Apply the row operations of the last elimination to the right-hand side ``e``.

    Afterwards e[prow[k]] is component pcol[k] of J11^-1 e (the same as the
    augmented identity block of book 6.5.3 would give) and the other rows
    hold what the dependent equations leave unexplained (8.45).
    """
    m = e.shape[0]
    for k in range(rank):
        br = prow[k]
        v = e[br] * pinv[k]
        e[br] = v
        if v != 0.0:
            for r in range(m):
                e[r] -= mult[k, r] * v


@njit
def sgc_residual(T: np.ndarray, sgc: np.ndarray, prow: np.ndarray, rank: int, n: int) -> float:
    """Largest entry left in the specified columns of the unpivoted rows (6.5.3 e).

    Non-zero means a specified coordinate is determined by the constraints.
    """
    m = T.shape[0]
    used = np.zeros(m, np.bool_)
    for k in range(rank):
        used[prow[k]] = True
    worst = 0.0
    for r in range(m):
        if used[r]:
            continue
        for c in range(n):
            if sgc[c] and abs(T[r, c]) > worst:
                worst = abs(T[r, c])
    return worst


@njit(nrt=False, inline="always")
def normalise_er(KP: tuple, q: np.ndarray) -> None:
    """Put every Euler-Rodrigues block back on the unit sphere (digest 9.27)."""
    K = unpack(KP)
    for k in range(K.er.shape[0]):
        e0 = K.er[k]
        s = math.sqrt(er_norm2(q, e0))
        if s > 0.0:
            for t in range(4):
                q[e0 + t] /= s


def plain(fn: Any) -> Any:
    """The Python function behind a compiled one (itself without numba).

    The scratch allocators below are compiled for the kernels that allocate
    (the batch, the rates); Python callers run the same code uncompiled,
    where numpy allocates faster than a compiled function returns arrays.
    """
    return getattr(fn, "py_func", fn)


@njit
def work_arrays(K: Any, nq: int) -> tuple:
    """Scratch arrays of one solver, in the order the kernels take them.

    (T0, A, Dh, J, E, T, prow, pcol, pinv, mult, dq, Qb, scr, used); scr holds
    8 matrices of scratch and then Phi_h of every joint of a general kind.
    ``K``: the kernel arrays (:data:`~openimp.system.KData`).
    """
    nj = K.jcode.shape[0]
    nb = K.order.shape[0]
    m = 6 * K.L.shape[0] + K.er.shape[0]
    k = max(min(m, nq), 1)
    return (np.zeros((nb, 4, 4)), np.zeros((nj, 4, 4)), np.zeros((max(nq, 1), 6)),
            np.zeros((m, nq)), np.zeros(m), np.zeros((m, nq + 1)),
            np.zeros(k, np.int64), np.zeros(k, np.int64), np.zeros(k), np.zeros((k, m)),
            np.zeros(nq), np.zeros((MAXV, 4, 4)), np.zeros((8 + nj, 4, 4)),
            np.zeros(m + nq + 1, np.bool_))


class Work:
    """Scratch arrays of one solver (allocated once per sweep, reused every step)."""

    def __init__(self, K: Any, nq: int) -> None:
        self.arrays = plain(work_arrays)(K, nq)
        (self.T0, self.A, self.Dh, self.J, self.E, self.T, self.prow, self.pcol, self.pinv,
         self.mult, self.dq, self.Qb, self.scr, self.used) = self.arrays

    def eliminate(self, KP: tuple, q: np.ndarray, sgc: np.ndarray,
                  ptol: float) -> tuple[int, float, float]:
        """Evaluate and eliminate the loop equations at ``q`` (:func:`evaluate`).

        Returns (rank, quality index, largest unpivoted entry); the postures,
        screws, tableau and pivots stay in these arrays.  Runs as one
        iteration of the compiled :func:`newton` that accepts any correction
        (on a copy of ``q``): no compiled entry of its own, which would cost a
        cold start about a second.
        """
        _, _, rank, det, rest = newton(KP, q.copy(), sgc, np.inf, ptol, 1, False, *self.arrays)
        return rank, det, rest


@njit(nrt=False, inline="always")
def evaluate(
    KP: tuple, q: np.ndarray, sgc: np.ndarray, ptol: float,
    T0: np.ndarray, A: np.ndarray, Dh: np.ndarray, J: np.ndarray, E: np.ndarray,
    T: np.ndarray, prow: np.ndarray, pcol: np.ndarray, pinv: np.ndarray, mult: np.ndarray,
    Qb: np.ndarray, scr: np.ndarray, used: np.ndarray,
) -> tuple[float, int, float, float]:
    """Postures, loop equations and their elimination at ``q``.

    Returns (max|E|, rank, quality, largest unpivoted entry).
    """
    err = tree_pass(KP, q, A, T0, E, scr)
    loop_jacobian(KP, q, A, Dh, J, Qb, scr)
    rank, det, rest = gauss_jordan(J, E, sgc, ptol, T, prow, pcol, pinv, mult, used)
    return err, rank, det, rest


@njit(nrt=False)
def newton(
    KP: tuple, q: np.ndarray, sgc: np.ndarray, tol: float, ptol: float, maxit: int, chord: bool,
    T0: np.ndarray, A: np.ndarray, Dh: np.ndarray, J: np.ndarray, E: np.ndarray,
    T: np.ndarray, prow: np.ndarray, pcol: np.ndarray, pinv: np.ndarray, mult: np.ndarray,
    dq: np.ndarray, Qb: np.ndarray, scr: np.ndarray, used: np.ndarray,
) -> tuple[int, int, int, float, float]:
    """Newton-Raphson on the loop equations (book 6.5); q is updated in place.

    Converged when every |E| and every correction is below ``tol`` (internal
    units); the last correction is applied.  Returns (status, iterations,
    rank, quality, largest unpivoted entry).

    With ``chord``, a correction that is already small is followed by
    simplified-Newton steps that reuse the elimination (:func:`replay`: one
    pass along the tree, no Jacobian and no pivot search) for as long as
    they contract at least tenfold; the convergence test is the same, so the
    posture is as accurate.  The tableau in ``T`` then belongs to a posture
    one small correction away, which serves the predictor but not the
    derivatives: sweeps that want rates run without ``chord``, and their
    tableau belongs to the final posture.
    """
    nq = q.shape[0]
    prev = 1e300
    grow = 0
    rank = 0
    det = 0.0
    rest = 0.0
    for it in range(maxit):
        err, rank, det, rest = evaluate(KP, q, sgc, ptol, T0, A, Dh, J, E, T, prow, pcol, pinv,
                                        mult, Qb, scr, used)
        step = 0.0
        for c in range(nq):
            dq[c] = 0.0
        for k in range(rank):
            v = T[prow[k], nq]
            dq[pcol[k]] = v
            if abs(v) > step:
                step = abs(v)
        if err < tol and step < tol:
            for c in range(nq):
                q[c] += dq[c]
            return OK, it + 1, rank, det, rest
        if err > prev:
            grow += 1
            if grow >= 3 or err > 1e3 * prev:
                return DIVERGED, it + 1, rank, det, rest
        prev = err
        if step > 2.0:  # a correction beyond ~2 rad / 2 model sizes: not "nearby"
            return DIVERGED, it + 1, rank, det, rest
        for c in range(nq):
            q[c] += dq[c]
        normalise_er(KP, q)
        if not chord or step > 1e-3:
            continue
        for _ in range(4):
            err = tree_pass(KP, q, A, T0, E, scr)
            replay(prow, pinv, mult, rank, E)
            last = step
            step = 0.0
            for k in range(rank):
                v = E[prow[k]]
                if abs(v) > step:
                    step = abs(v)
            if err < tol and step < tol:
                for k in range(rank):
                    q[pcol[k]] += E[prow[k]]
                return OK, it + 1, rank, det, rest
            if step > 0.1 * last:
                break  # contracting too slowly: a fresh Jacobian
            for k in range(rank):
                q[pcol[k]] += E[prow[k]]
            normalise_er(KP, q)
    return MAXITER, maxit, rank, det, rest


@njit(nrt=False)
def derivative_matrix(
    T: np.ndarray, prow: np.ndarray, pcol: np.ndarray, rank: int, cols: np.ndarray,
    nq: int, G: np.ndarray,
) -> None:
    """First geometric derivatives dq/dpsi for the coordinates ``cols`` (7.14).

    G[:, j] = -J11^-1 J1j in the dependent rows, 1 at cols[j], 0 elsewhere.
    """
    for r in range(nq):
        for j in range(cols.shape[0]):
            G[r, j] = 0.0
    for j in range(cols.shape[0]):
        G[cols[j], j] = 1.0
        for k in range(rank):
            G[pcol[k], j] = -T[prow[k], cols[j]]


@njit
def step_arrays(nq: int, nd: int) -> tuple:
    """The step loop's own scratch: G, Gp (first derivatives now and one step
    back), qtry, isdriver, dprev and dnew (driver moves)."""
    return (np.zeros((nq, nd)), np.zeros((nq, nd)), np.zeros(nq), np.zeros(nq, np.bool_),
            np.zeros(nd), np.zeros(nd))


@njit
def sweep_arrays(K: Any, nq: int, nd: int, want_rates: bool) -> tuple:
    """Scratch arrays of :func:`_sweep_steps`, in the order it takes them.

    :func:`work_arrays`, :func:`rate_arrays` (empty without rates), then
    :func:`step_arrays`.  Compiled for :func:`sweep_kernel`; :func:`sweep`
    puts the same together from the three allocators run uncompiled (this
    function uncompiled would call the compiled ones and box their arrays).
    """
    return (work_arrays(K, nq) + rate_arrays(K, nq if want_rates else 0)
            + step_arrays(nq, nd))


@njit
def sweep_kernel(
    KP: tuple, q: np.ndarray, sgc: np.ndarray, dcols: np.ndarray, dvals: np.ndarray,
    tol: float, ptol: float, maxit: int, maxhalve: int,
    Qout: np.ndarray, quality: np.ndarray, rank_out: np.ndarray, fgc_out: np.ndarray,
    iters_out: np.ndarray, want_rates: bool, rd: np.ndarray, ad: np.ndarray,
    QDout: np.ndarray, QDDout: np.ndarray, cons_out: np.ndarray,
) -> tuple[int, int]:
    """Solve every posture of a sweep (book 6.5, 6.9).

    ``q`` holds a closed posture on entry.  For step k the specified columns
    ``dcols`` go to ``dvals[k]``: the dependent variables are predicted to
    second order from the last eliminations' by-products (-J11^-1 J13 dpsi),
    then corrected by Newton.  A step that fails is retried from the last
    good posture in halves, down to 2^-maxhalve of it.  With ``want_rates``
    the joint velocities and accelerations for the driver rates ``rd[k]`` and
    accelerations ``ad[k]`` come from the same final elimination
    (:func:`joint_rates`).  Returns (steps solved, status of the first failure
    or OK).

    This is :func:`_sweep_steps` on the scratch of :func:`sweep_arrays`, for
    compiled callers (the batch); :func:`sweep` makes the two calls itself,
    which spares a cold start the compilation of this wrapper.
    """
    return _sweep_steps(
        KP, q, sgc, dcols, dvals, tol, ptol, maxit, maxhalve, Qout, quality, rank_out, fgc_out,
        iters_out, want_rates, rd, ad, QDout, QDDout, cons_out,
        *sweep_arrays(unpack(KP), q.shape[0], dcols.shape[0], want_rates))


@njit(nrt=False)
def _sweep_steps(
    KP: tuple, q: np.ndarray, sgc: np.ndarray, dcols: np.ndarray, dvals: np.ndarray,
    tol: float, ptol: float, maxit: int, maxhalve: int,
    Qout: np.ndarray, quality: np.ndarray, rank_out: np.ndarray, fgc_out: np.ndarray,
    iters_out: np.ndarray, want_rates: bool, rd: np.ndarray, ad: np.ndarray,
    QDout: np.ndarray, QDDout: np.ndarray, cons_out: np.ndarray,
    T0: np.ndarray, A: np.ndarray, Dh: np.ndarray, J: np.ndarray, E: np.ndarray,
    T: np.ndarray, prow: np.ndarray, pcol: np.ndarray, pinv: np.ndarray, mult: np.ndarray,
    dq: np.ndarray, Qb: np.ndarray, scr: np.ndarray, used: np.ndarray,
    D4: np.ndarray, B4: np.ndarray, omega: np.ndarray, Kh: np.ndarray, dQb: np.ndarray,
    qd: np.ndarray, qdd: np.ndarray, rhs: np.ndarray,
    G: np.ndarray, Gp: np.ndarray, qtry: np.ndarray, isdriver: np.ndarray,
    dprev: np.ndarray, dnew: np.ndarray,
) -> tuple[int, int]:
    """The step loop of :func:`sweep_kernel` on preallocated arrays (no reference counting)."""
    nq = q.shape[0]
    nd = dcols.shape[0]
    nsteps = dvals.shape[0]
    chord = not want_rates
    # the elimination at the start posture provides the first predictor
    st, it, rank, det, rest = newton(KP, q, sgc, tol, ptol, maxit, False, T0, A, Dh, J, E,
                                     T, prow, pcol, pinv, mult, dq, Qb, scr, used)
    if st != OK:
        return 0, st
    rank_ref = rank
    for j in range(nd):
        isdriver[dcols[j]] = True
    derivative_matrix(T, prow, pcol, rank, dcols, nq, G)
    # second-order predictor: the change of G over the last step estimates
    # d2q/dpsi2 along the direction of motion (uniform sweeps keep that direction)
    has_prev = False
    for k in range(nsteps):
        frac = 1.0
        done = False
        total_it = 0
        while not done:
            # remaining move of the drivers from the current good posture
            for c in range(nq):
                qtry[c] = q[c]
            for j in range(nd):
                dnew[j] = (dvals[k, j] - q[dcols[j]]) * frac
                for r in range(nq):
                    qtry[r] += G[r, j] * dnew[j]
            if has_prev:
                num = 0.0
                den = 0.0
                for j in range(nd):
                    num += dnew[j] * dprev[j]
                    den += dprev[j] * dprev[j]
                ratio = num / den if den > 0.0 else 0.0
                off = 0.0
                nrm = 0.0
                for j in range(nd):
                    off += (dnew[j] - ratio * dprev[j]) ** 2
                    nrm += dnew[j] * dnew[j]
                if off <= 1e-18 * nrm:
                    for j in range(nd):
                        f = 0.5 * ratio * dnew[j]
                        for r in range(nq):
                            qtry[r] += f * (G[r, j] - Gp[r, j])
            normalise_er(KP, qtry)
            last = frac == 1.0
            if last:
                for j in range(nd):
                    qtry[dcols[j]] = dvals[k, j]
            st, it, rank, det, rest = newton(KP, qtry, sgc, tol, ptol, maxit, chord, T0, A,
                                             Dh, J, E, T, prow, pcol, pinv, mult, dq, Qb,
                                             scr, used)
            total_it += it
            if st == OK:
                for j in range(nd):
                    dprev[j] = qtry[dcols[j]] - q[dcols[j]]
                for c in range(nq):
                    q[c] = qtry[c]
                for r in range(nq):
                    for j in range(nd):
                        Gp[r, j] = G[r, j]
                derivative_matrix(T, prow, pcol, rank, dcols, nq, G)
                has_prev = True
                if last:
                    done = True
                else:
                    frac = min(1.0, 2.0 * frac)
            else:
                frac *= 0.5
                if frac < 0.5 ** maxhalve:
                    return k, st
        for c in range(nq):
            Qout[k, c] = q[c]
        # (6.53) |det J11| over the regular pivots; where the rank drops (a dead
        # centre) the missing pivots are the tiny entries left, so the index
        # collapses toward zero instead of jumping to a smaller J11's value
        if rank > rank_ref:
            rank_ref = rank
        for _ in range(rank_ref - rank):
            det *= rest
        quality[k] = det
        rank_out[k] = rank
        iters_out[k] = total_it
        if want_rates:
            cons_out[k] = joint_rates(KP, q, dcols, G, rd[k], ad[k], prow, pcol, pinv, mult,
                                      rank, A, D4, B4, omega, Kh, dQb, qd, qdd, rhs, Qb, scr,
                                      used)
            for c in range(nq):
                QDout[k, c] = qd[c]
                QDDout[k, c] = qdd[c]
        for c in range(nq):
            fgc_out[k, c] = not isdriver[c]
        for t in range(rank):
            fgc_out[k, pcol[t]] = False
    return nsteps, OK


# =============================================================================
# Velocities and accelerations (book ch 7, 8)
# =============================================================================
@njit(nrt=False)
def _similar(A: np.ndarray, M: np.ndarray, out: np.ndarray, scr: np.ndarray) -> None:
    """out = A M A^-1 for a rigid A and an operator M with zero last row (scr: 2 x 4x4)."""
    Ai = scr[0]
    tmp = scr[1]
    inv4(A, Ai)
    for i in range(3):
        for j in range(4):
            tmp[i, j] = A[i, 0] * M[0, j] + A[i, 1] * M[1, j] + A[i, 2] * M[2, j]
    for i in range(3):
        for j in range(4):
            out[i, j] = tmp[i, 0] * Ai[0, j] + tmp[i, 1] * Ai[1, j] + tmp[i, 2] * Ai[2, j]
        out[i, 3] += tmp[i, 3]
    for j in range(4):
        out[3, j] = 0.0


@njit(nrt=False)
def _commutator_add(X: np.ndarray, Y: np.ndarray, f: float, out: np.ndarray) -> None:
    """out += f (X Y - Y X) for 4x4 operators with zero last rows."""
    for i in range(3):
        for j in range(4):
            s = 0.0
            for k in range(3):
                s += X[i, k] * Y[k, j] - Y[i, k] * X[k, j]
            out[i, j] += f * s


@njit(nrt=False)
def _constant_Q(code: int) -> bool:
    """True for kinds whose Q does not depend on q (every Q_{g,i} is zero)."""
    return (code == RIGID or code == REVOLUTE or code == PRISMATIC or code == SCREW
            or code == CYLINDER)


@njit(nrt=False)
def operators(
    KP: tuple, q: np.ndarray, A: np.ndarray, D4: np.ndarray, B4: np.ndarray, Qb: np.ndarray,
    dQb: np.ndarray, scr: np.ndarray,
) -> None:
    """Global operators of every joint variable.

    D4[c] = A_h Q_h^g A_h^-1 (6.14) and B4[c, i] = A_h Q_h^{g,i} A_h^-1 (8.24)
    for the variables c = (h, g) and i over the same joint's variables; B4 is
    left alone for kinds whose Q is constant (:func:`drift_terms` skips them).
    Revolute and prismatic operators are written in closed form: the unit
    rotation about w = R e3 through p is [[skew(w), p x w], [0, 0]], the unit
    slide along w is [[0, w], [0, 0]].
    """
    K = unpack(KP)
    for h in range(K.jcode.shape[0]):
        nv = K.jnv[h]
        if nv == 0:
            continue
        a0 = K.jq0[h]
        code = K.jcode[h]
        Ah = A[h]
        if code == REVOLUTE or code == PRISMATIC:
            D = D4[a0]
            wx, wy, wz = Ah[0, 2], Ah[1, 2], Ah[2, 2]
            for i in range(4):
                for j in range(4):
                    D[i, j] = 0.0
            if code == PRISMATIC:
                D[0, 3] = wx
                D[1, 3] = wy
                D[2, 3] = wz
                continue
            px, py, pz = Ah[0, 3], Ah[1, 3], Ah[2, 3]
            D[0, 1] = -wz
            D[0, 2] = wy
            D[1, 0] = wz
            D[1, 2] = -wx
            D[2, 0] = -wy
            D[2, 1] = wx
            D[0, 3] = py * wz - pz * wy
            D[1, 3] = pz * wx - px * wz
            D[2, 3] = px * wy - py * wx
            continue
        qh = q[a0:a0 + nv]
        ch = K.const[K.jc0[h]:]
        joint_Q(code, qh, ch, Qb)
        for g in range(nv):
            _similar(Ah, Qb[g], D4[a0 + g], scr)
        if _constant_Q(code):
            continue
        joint_dQ(code, qh, ch, dQb)
        for g in range(nv):
            for i in range(nv):
                _similar(Ah, dQb[g, i], B4[a0 + g, i], scr)


@njit(nrt=False)
def tree_operators(
    KP: tuple, rate: np.ndarray, D4: np.ndarray, Kh: np.ndarray, with_drift: bool,
    out: np.ndarray,
) -> None:
    """Sum joint operators along the tree: out_b = sum_h P(b,h) (D_h rate_h [+ Kh_h]).

    With the joint velocities and no drift this is omega_b (7.22); with the
    joint accelerations and the drift terms Kh it is alpha_b (8.52).
    """
    K = unpack(KP)
    for k in range(K.order.shape[0]):
        b = K.order[k]
        h = K.pj[b]
        for i in range(4):
            for j in range(4):
                out[b, i, j] = 0.0
        if h < 0:
            continue
        pb = K.pb[b]
        sg = float(K.psign[b])
        a0 = K.jq0[h]
        for i in range(3):
            for j in range(4):
                s = Kh[h, i, j] if with_drift else 0.0
                for g in range(K.jnv[h]):
                    s += D4[a0 + g, i, j] * rate[a0 + g]
                out[b, i, j] = out[pb, i, j] + sg * s


@njit(nrt=False)
def drift_terms(
    KP: tuple, qd: np.ndarray, D4: np.ndarray, B4: np.ndarray, omega: np.ndarray, Kh: np.ndarray
) -> None:
    """Kh = sum_g ([omega_h-, D_h^g] + sum_i B_h^{g,i} qd_i) qd_g per joint (8.26, 8.39)."""
    K = unpack(KP)
    for h in range(K.jcode.shape[0]):
        for i in range(4):
            for j in range(4):
                Kh[h, i, j] = 0.0
        nv = K.jnv[h]
        a0 = K.jq0[h]
        wm = omega[K.jb1[h]]
        second = not _constant_Q(K.jcode[h])
        for g in range(nv):
            f = qd[a0 + g]
            if f == 0.0:
                continue
            _commutator_add(wm, D4[a0 + g], f, Kh[h])
            if not second:
                continue
            for t in range(nv):
                ft = f * qd[a0 + t]
                if ft == 0.0:
                    continue
                for i in range(3):
                    for j in range(4):
                        Kh[h, i, j] += ft * B4[a0 + g, t, i, j]


@njit
def rate_arrays(K: Any, nq: int) -> tuple:
    """Scratch arrays of :func:`joint_rates`: (D4, B4, omega, Kh, dQb, qd, qdd, rhs)."""
    nj = K.jcode.shape[0]
    nb = K.order.shape[0]
    m = 6 * K.L.shape[0] + K.er.shape[0]
    n = max(nq, 1)
    return (np.zeros((n, 4, 4)), np.zeros((n, MAXV, 4, 4)), np.zeros((nb, 4, 4)),
            np.zeros((nj, 4, 4)), np.zeros((MAXV, MAXV, 4, 4)), np.zeros(nq), np.zeros(nq),
            np.zeros(max(m, 1)))


@njit(nrt=False, inline="always")
def joint_rates(
    KP: tuple, q: np.ndarray, dcols: np.ndarray, G: np.ndarray, psid: np.ndarray,
    psidd: np.ndarray, prow: np.ndarray, pcol: np.ndarray, pinv: np.ndarray,
    mult: np.ndarray, rank: int, A: np.ndarray, D4: np.ndarray, B4: np.ndarray,
    omega: np.ndarray, Kh: np.ndarray, dQb: np.ndarray, qd: np.ndarray, qdd: np.ndarray,
    b: np.ndarray, Qb: np.ndarray, scr: np.ndarray, used: np.ndarray,
) -> float:
    """Joint velocities (7.19) and accelerations (8.44) at a converged posture.

    Uses the final elimination of the posture (no second inversion):
    qd = G psid with G the first geometric derivatives, and
    qdd_dep = J11^-1 C1 + G psidd with C the acceleration right-hand side
    (8.40) built from the drift terms of every joint, J11^-1 applied by
    :func:`replay`.  Free coordinates that are not driven keep zero rate.
    Returns the consistency residual (8.45): what the dependent rows leave
    of C.
    """
    K = unpack(KP)
    nq = q.shape[0]
    m = b.shape[0] if K.L.shape[0] + K.er.shape[0] > 0 else 0
    nd = dcols.shape[0]
    for c in range(nq):
        s = 0.0
        for j in range(nd):
            s += G[c, j] * psid[j]
        qd[c] = s
    operators(KP, q, A, D4, B4, Qb, dQb, scr)
    tree_operators(KP, qd, D4, Kh, False, omega)
    drift_terms(KP, qd, D4, B4, omega, Kh)
    for i in range(K.L.shape[0]):
        # C = -sum_h L(i,h) Kh_h; only its screw coordinates (6.41) enter
        r0 = 6 * i
        for k in range(6):
            b[r0 + k] = 0.0
        for h in range(K.jcode.shape[0]):
            lih = K.L[i, h]
            if lih == 0:
                continue
            Kc = Kh[h]
            b[r0 + 0] -= lih * Kc[0, 3]
            b[r0 + 1] -= lih * Kc[1, 3]
            b[r0 + 2] -= lih * Kc[2, 3]
            b[r0 + 3] -= lih * Kc[2, 1]
            b[r0 + 4] -= lih * Kc[0, 2]
            b[r0 + 5] -= lih * Kc[1, 0]
    r0 = 6 * K.L.shape[0]
    for k in range(K.er.shape[0]):
        b[r0 + k] = -2.0 * er_norm2(qd, K.er[k])
    replay(prow, pinv, mult, rank, b)
    for c in range(nq):
        s = 0.0
        for j in range(nd):
            s += G[c, j] * psidd[j]
        qdd[c] = s
    for r in range(m):
        used[r] = False
    for k in range(rank):
        used[prow[k]] = True
        qdd[pcol[k]] += b[prow[k]]
    worst = 0.0
    for r in range(m):
        if not used[r] and abs(b[r]) > worst:
            worst = abs(b[r])
    return worst


@njit
def tracks(
    KP: tuple, Qs: np.ndarray, QDs: np.ndarray, QDDs: np.ndarray, bodies: np.ndarray,
    points: np.ndarray, T_out: np.ndarray, p_out: np.ndarray, omega_out: np.ndarray,
    alpha_out: np.ndarray,
) -> None:
    """Postures of selected bodies, positions of selected points and, given rates, body rates.

    A forward pass along the tree per row of ``Qs``; only the selection is
    stored (T_out: steps x len(bodies) x 4 x 4, p_out: steps x len(points) x
    3), so a million-step sweep needs no array of every body's posture.
    With joint velocities ``QDs`` and accelerations ``QDDs`` (one row per
    step; none for postures only) the velocity and acceleration operators of
    every body (7.22, 8.52) go to omega_out and alpha_out (steps x nb x 4 x 4).
    One kernel for both, as each compiled entry costs a cold start seconds.
    """
    K = unpack(KP)
    nq = Qs.shape[1]
    w = work_arrays(K, nq)
    T0, A, E, Qb, scr = w[0], w[1], w[4], w[11], w[12]
    rates = QDs.shape[0] > 0
    r = rate_arrays(K, nq if rates else 0)
    D4, B4, Kh, dQb = r[0], r[1], r[3], r[4]
    for s in range(Qs.shape[0]):
        tree_pass(KP, Qs[s], A, T0, E, scr)
        for k in range(bodies.shape[0]):
            for i in range(4):
                for c in range(4):
                    T_out[s, k, i, c] = T0[bodies[k], i, c]
        for k in range(points.shape[0]):
            p = points[k]
            Tb = T0[K.ptbody[p]]
            x = K.ptlocal[p]
            for i in range(3):
                p_out[s, k, i] = Tb[i, 0] * x[0] + Tb[i, 1] * x[1] + Tb[i, 2] * x[2] + Tb[i, 3]
        if rates:
            operators(KP, Qs[s], A, D4, B4, Qb, dQb, scr)
            tree_operators(KP, QDs[s], D4, Kh, False, omega_out[s])
            drift_terms(KP, QDs[s], D4, B4, omega_out[s], Kh)
            tree_operators(KP, QDDs[s], D4, Kh, True, alpha_out[s])


# =============================================================================
# Python side
# =============================================================================
def _driver_columns(
    system: System, drivers: Mapping[Any, Sequence[float] | np.ndarray], steps: int | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Columns and (steps x nd) values (internal units) of the drivers.

    No drivers at all (a structure, or every freedom held) needs ``steps``.
    """
    if not drivers:
        if steps is None:
            raise InputError(
                "give at least one driver: a joint name mapped to its values "
                "(or drivers={} with steps=N for a structure or a held posture)"
            )
        if int(steps) < 1:
            raise InputError(f"steps must be a positive number of postures, got {steps!r}")
        return np.zeros(0, np.int64), np.zeros((int(steps), 0))
    cols: list[int] = []
    vals: list[np.ndarray] = []
    nsteps = None
    for key, v in drivers.items():
        c = system.var_index(key)
        if system.var_kinds[c] == "er":
            raise InputError(
                f"driver {key!r}: an Euler-Rodrigues parameter cannot be driven; "
                "drive a joint with angle or length variables"
            )
        if c in cols:
            raise InputError(f"driver {key!r} is given twice")
        try:
            a = np.atleast_1d(np.asarray(v, dtype=float))
        except (TypeError, ValueError):
            raise InputError(
                f"driver {key!r}: its values must be numbers, got {v!r:.60}"
            ) from None
        if a.ndim != 1 or a.size == 0 or not np.all(np.isfinite(a)):
            raise InputError(f"driver {key!r}: give a non-empty sequence of finite numbers")
        if nsteps is None:
            nsteps = a.size
        elif a.size != nsteps:
            raise InputError(
                f"driver {key!r} has {a.size} values but the other drivers have {nsteps}; "
                "give every driver the same number of steps"
            )
        cols.append(c)
        vals.append(a / system.var_scale[c])
    return np.array(cols, np.int64), np.stack(vals, axis=1)


class SweepResult:
    """Postures of a mechanism along a sweep.

    Joint variables are stored for every solved step; body postures and point
    positions are recomputed from them on demand (cheap, and it keeps a
    million-step sweep small).  All results are in model units (radians for
    angles).
    """

    def __init__(
        self, system: System, q: np.ndarray, quality: np.ndarray, rank: np.ndarray,
        fgc: np.ndarray, iterations: np.ndarray, drivers: list[str], message: str = "",
    ) -> None:
        self.system = system
        self._q = q  # internal units
        self.quality = quality
        self.rank = rank
        self._fgc = fgc
        self.iterations = iterations
        self.drivers = drivers
        #: empty when every step was solved; otherwise why the sweep stopped
        self.message = message
        #: times of the steps when the sweep was driven by motions of time
        self.time: np.ndarray | None = None
        #: rank and quality index at the start posture (the regular values)
        self.rank_ref = 0
        self.quality_ref = 0.0
        self._T0: np.ndarray | None = None
        self._qd: np.ndarray | None = None
        self._qdd: np.ndarray | None = None
        self._omega: np.ndarray | None = None
        self._alpha: np.ndarray | None = None
        self.consistency: np.ndarray | None = None

    # ----------------------------------------------------------------- rates
    def _set_rates(self, qd: np.ndarray, qdd: np.ndarray, cons: np.ndarray) -> None:
        self._qd = qd
        self._qdd = qdd
        self.consistency = cons

    @property
    def has_rates(self) -> bool:
        """True when the sweep was given driver rates or accelerations."""
        return self._qd is not None

    def _need_rates(self) -> None:
        if self._qd is None:
            raise InputError(
                "this sweep has no velocities: call sweep(drivers, rates=..., accels=...) "
                "or sweep(motion=..., times=...)"
            )

    @property
    def singular(self) -> np.ndarray:
        """Steps at a singular posture, where rates are not determined by the drivers.

        A step is singular when the rank of the Jacobian is below the regular
        rank (the largest seen at the start posture or along the sweep: an
        extra instantaneous freedom appears, as at a dead centre), when the
        quality index has fallen below ``1e-6`` of its regular value (rates
        there are amplified a million-fold: a near-locking posture), or when
        the acceleration equations are inconsistent there (8.45).  Rates at a
        flagged step are not determined by the drivers: they may be huge (the
        true rates diverge at a locking posture) or leave the extra freedom at
        rest (a change point).
        """
        if self.nsteps == 0:
            return np.zeros(0, bool)
        rank_ref = max(self.rank_ref, int(self.rank.max()))
        q_ref = max(self.quality_ref, float(self.quality.max()))
        sing = (self.rank < rank_ref) | (self.quality < 1e-6 * q_ref)
        if self.consistency is not None:
            sing |= self.consistency > 1e-6
        return sing

    @property
    def qd(self) -> np.ndarray:
        """All joint velocities (steps x nq), model units per second."""
        self._need_rates()
        assert self._qd is not None
        return self._qd * self.system.var_scale

    @property
    def qdd(self) -> np.ndarray:
        """All joint accelerations (steps x nq), model units per second squared."""
        self._need_rates()
        assert self._qdd is not None
        return self._qdd * self.system.var_scale

    def joint_velocity(self, name: str) -> np.ndarray:
        """Velocities of one joint's variables (steps x nvar)."""
        return self.qd[:, self.system.joint_vars(name)]

    def joint_acceleration(self, name: str) -> np.ndarray:
        """Accelerations of one joint's variables (steps x nvar)."""
        return self.qdd[:, self.system.joint_vars(name)]

    def _body_rates(self) -> tuple[np.ndarray, np.ndarray]:
        self._need_rates()
        if self._omega is None:
            nb = len(self.system.bodies)
            om = np.zeros((self.nsteps, nb, 4, 4))
            al = np.zeros((self.nsteps, nb, 4, 4))
            T0 = np.zeros((self.nsteps, nb, 4, 4))
            tracks(self.system.KP, np.ascontiguousarray(self._q), self._qd, self._qdd,
                   np.arange(nb), np.zeros(0, np.int64), T0, np.zeros((self.nsteps, 0, 3)),
                   om, al)
            Ls = self.system.length_scale
            om[..., :3, 3] *= Ls
            al[..., :3, 3] *= Ls
            T0[..., :3, 3] *= Ls
            self._omega, self._alpha, self._T0 = om, al, T0
        assert self._alpha is not None
        return self._omega, self._alpha

    @staticmethod
    def _axial(M: np.ndarray) -> np.ndarray:
        return np.stack([M[..., 2, 1], M[..., 0, 2], M[..., 1, 0]], axis=-1)

    def angular_velocity(self, body: str) -> np.ndarray:
        """Angular velocity vector of a body, global components (steps x 3), rad/s."""
        om, _ = self._body_rates()
        return self._axial(om[:, self.system.body_index(body)])

    def angular_acceleration(self, body: str) -> np.ndarray:
        """Angular acceleration vector of a body, global (steps x 3), rad/s^2."""
        _, al = self._body_rates()
        return self._axial(al[:, self.system.body_index(body)])

    def velocity_operator(self, body: str) -> np.ndarray:
        """The 4x4 velocity operator omega_b of book (7.22) (steps x 4 x 4)."""
        om, _ = self._body_rates()
        return om[:, self.system.body_index(body)].copy()

    def acceleration_operator(self, body: str) -> np.ndarray:
        """The 4x4 operator alpha_b of book (8.52) (steps x 4 x 4)."""
        _, al = self._body_rates()
        return al[:, self.system.body_index(body)].copy()

    def _point_rates(self, R: np.ndarray, b: int) -> tuple[np.ndarray, np.ndarray]:
        om, al = self._body_rates()
        Rh = np.concatenate([R, np.ones((R.shape[0], 1))], axis=1)
        W = om[:, b]
        v = np.einsum("sij,sj->si", W, Rh)
        a = np.einsum("sij,sj->si", al[:, b] + W @ W, Rh)
        return v[:, :3], a[:, :3]

    def origin_velocity(self, body: str) -> np.ndarray:
        """Velocity of the origin of a body's frame (steps x 3), global."""
        b = self.system.body_index(body)
        return self._point_rates(self.posture(body)[:, :3, 3], b)[0]

    def origin_acceleration(self, body: str) -> np.ndarray:
        """Acceleration of the origin of a body's frame (steps x 3), global."""
        b = self.system.body_index(body)
        return self._point_rates(self.posture(body)[:, :3, 3], b)[1]

    def point_velocity(self, name: str) -> np.ndarray:
        """Velocity of a point (steps x 3), global, model units per second (7.27)."""
        b = int(self.system.K.ptbody[self.system.point_index(name)])
        return self._point_rates(self.point(name), b)[0]

    def point_acceleration(self, name: str) -> np.ndarray:
        """Acceleration of a point (steps x 3), global (8.56)."""
        b = int(self.system.K.ptbody[self.system.point_index(name)])
        return self._point_rates(self.point(name), b)[1]

    @property
    def nsteps(self) -> int:
        """Number of solved steps."""
        return int(self._q.shape[0])

    @property
    def complete(self) -> bool:
        """True when every requested step was solved."""
        return not self.message

    @property
    def q(self) -> np.ndarray:
        """All joint variables (steps x nq), model units."""
        return self._q * self.system.var_scale

    @property
    def mobility(self) -> np.ndarray:
        """Mobility f = n - rank(J) at every step (6.52)."""
        return self.system.nq - self.rank

    @property
    def fgc(self) -> list[list[str]]:
        """Names of the free generalized coordinates chosen at every step."""
        names = self.system.var_names
        return [[names[c] for c in np.flatnonzero(row)] for row in self._fgc]

    def joint(self, name: str) -> np.ndarray:
        """Variables of one joint (steps x nvar), model units."""
        sl = self.system.joint_vars(name)
        return self.q[:, sl]

    def variable(self, key: Any) -> np.ndarray:
        """One joint variable over the steps (key as in System.var_index)."""
        c = self.system.var_index(key)
        return self.q[:, c]

    def _track(self, bodies: list[int], points: list[int]) -> tuple[np.ndarray, np.ndarray]:
        T = np.zeros((self.nsteps, len(bodies), 4, 4))
        p = np.zeros((self.nsteps, len(points), 3))
        none = np.zeros((0, self.system.nq))
        tracks(self.system.KP, np.ascontiguousarray(self._q), none, none,
               np.array(bodies, np.int64), np.array(points, np.int64), T, p,
               np.zeros((0, 0, 4, 4)), np.zeros((0, 0, 4, 4)))
        Ls = self.system.length_scale
        T[..., :3, 3] *= Ls
        return T, p * Ls

    def posture(self, body: str) -> np.ndarray:
        """Global posture T_0b of a body (steps x 4 x 4), model units."""
        b = self.system.body_index(body)
        if self._T0 is not None:  # computed with the rates
            return self._T0[:, b].copy()
        return self._track([b], [])[0][:, 0]

    def point(self, name: str) -> np.ndarray:
        """Global position of a point (steps x 3), model units."""
        return self._track([], [self.system.point_index(name)])[1][:, 0]

    def to_table(self) -> dict[str, Any]:
        """Columns: step (and time), joint variables (and their rates), quality, mobility."""
        cols: dict[str, Any] = {"step": np.arange(self.nsteps)}
        if self.time is not None:
            cols["time"] = self.time
        q = self.q
        for c, n in enumerate(self.system.var_names):
            cols[n] = q[:, c]
        if self.has_rates:
            qd, qdd = self.qd, self.qdd
            for c, n in enumerate(self.system.var_names):
                cols[n + "'"] = qd[:, c]
                cols[n + "''"] = qdd[:, c]
        cols["quality"] = self.quality
        cols["mobility"] = self.mobility
        return cols

    def __repr__(self) -> str:
        state = "complete" if self.complete else f"stopped: {self.message}"
        return f"SweepResult({self.nsteps} steps, {state})"


def _rate_values(
    system: System, dcols: np.ndarray, nsteps: int, given: Mapping[Any, Any] | None, what: str
) -> np.ndarray:
    """(steps x nd) driver rates or accelerations in internal units (0 where not given)."""
    out = np.zeros((nsteps, dcols.size))
    if not given:
        return out
    pos = {int(c): j for j, c in enumerate(dcols)}
    seen: set[int] = set()
    for key, v in given.items():
        c = system.var_index(key)
        if c in seen:
            raise InputError(f"{what} of {key!r} is given twice")
        seen.add(c)
        if c not in pos:
            raise InputError(f"{what} given for {key!r}, which is not one of the drivers")
        try:
            a = np.atleast_1d(np.asarray(v, dtype=float))
        except (TypeError, ValueError):
            raise InputError(f"{what} of {key!r} must be numbers, got {v!r:.60}") from None
        if a.size == 1:
            a = np.full(nsteps, float(a[0]))
        if a.shape != (nsteps,) or not np.all(np.isfinite(a)):
            raise InputError(
                f"{what} of {key!r}: give one finite value or {nsteps} values (one per step)"
            )
        out[:, pos[c]] = a / system.var_scale[c]
    return out


def sweep(
    system: System,
    drivers: Mapping[Any, Sequence[float] | np.ndarray] | None = None,
    rates: Mapping[Any, Sequence[float] | np.ndarray] | None = None,
    accels: Mapping[Any, Sequence[float] | np.ndarray] | None = None,
    *,
    motion: Mapping[Any, Any] | None = None,
    times: Sequence[float] | np.ndarray | None = None,
    tol: float = 1e-10,
    pivot_tol: float = 1e-10,
    maxit: int = 25,
    maxhalve: int = 12,
    hold_free: bool = False,
    start: np.ndarray | None = None,
    steps: int | None = None,
) -> SweepResult:
    """Move ``system`` through the driver values and solve every posture.

    ``drivers`` maps joints (or ``"joint.var"``) to sequences of values of that
    variable (radians or lengths), all of equal length.  ``rates`` and
    ``accels`` map the same keys to their first and second time derivatives
    (one value per step, or one value for all); given either, the result
    carries velocities and accelerations.  Instead of ``drivers``,
    ``motion`` maps keys to functions of time (:mod:`openimp.motion`)
    evaluated at ``times``.  ``drivers={}`` with ``steps=N`` solves a
    structure (mobility 0), or a posture with every freedom held, N times.

    Every posture is solved by Newton-Raphson to ``tol`` internal units (book
    6.7).  A model whose mobility exceeds the number of drivers is an input
    error unless ``hold_free`` keeps the free coordinates at their values
    (passive freedoms, such as the spin of an RSSR coupler, are held anyway).
    An unreachable posture ends the sweep with :attr:`SweepResult.message`
    set; every posture solved before is kept.
    """
    from openimp.motion import as_motion

    tarr = None
    if motion is not None:
        if drivers is not None or rates is not None or accels is not None:
            raise InputError("give either motion= (with times=) or drivers/rates/accels, not both")
        if times is None:
            raise InputError("motion= needs times=: the instants at which to solve")
        tarr = np.asarray(times, dtype=float)
        drivers, rates, accels = {}, {}, {}
        for key, mo in motion.items():
            p, v, a = as_motion(mo)(tarr)
            drivers[key], rates[key], accels[key] = p, v, a
    if drivers is None:
        raise InputError("give drivers (joint -> values) or motion= with times=")
    KP = system.KP
    dcols, dvals = _driver_columns(system, drivers, steps)
    nq = system.nq
    nsteps = dvals.shape[0]
    want = rates is not None or accels is not None
    rd = _rate_values(system, dcols, nsteps, rates, "rate")
    ad = _rate_values(system, dcols, nsteps, accels, "acceleration")
    sgc = np.zeros(nq, np.bool_)
    sgc[dcols] = True
    q = _start_posture(system, start)
    # one scratch for the driver check and the sweep (what sweep_arrays gives)
    w = Work(system.K, nq)
    arrays = (w.arrays + plain(rate_arrays)(system.K, nq if want else 0)
              + plain(step_arrays)(nq, len(dcols)))
    held, rank0, quality0 = check_drivers(system, q, sgc, dcols, pivot_tol, hold_free, w)
    # free coordinates that are held (hold_free, or passive) are specified at
    # their values, as IMP holds FGCs in kinematic mode; this keeps the
    # pivoting from trading one free coordinate for another between steps
    sgc[held] = True
    Qout = np.zeros((nsteps, nq))
    quality = np.zeros(nsteps)
    rank = np.zeros(nsteps, np.int64)
    fgc = np.zeros((nsteps, nq), np.bool_)
    iters = np.zeros(nsteps, np.int64)
    shape_r = (nsteps, nq) if want else (1, 1)
    QD = np.zeros(shape_r)
    QDD = np.zeros(shape_r)
    cons = np.zeros(nsteps if want else 1)
    # sweep_kernel's two steps, from Python: one compiled function less
    done, status = _sweep_steps(
        KP, q, sgc, dcols, np.ascontiguousarray(dvals), tol, pivot_tol, maxit, maxhalve,
        Qout, quality, rank, fgc, iters, want, rd, ad, QD, QDD, cons,
        *arrays)
    names = [system.var_names[c] for c in dcols]
    msg = ""
    if done < nsteps:
        msg = _failure_message(system, names, dvals, done, status)
    res = SweepResult(system, Qout[:done], quality[:done], rank[:done], fgc[:done],
                      iters[:done], names, msg)
    res.rank_ref, res.quality_ref = rank0, quality0
    if want:
        res._set_rates(QD[:done], QDD[:done], cons[:done])
    if tarr is not None:
        res.time = tarr[:done]
    return res


def _start_posture(system: System, start: Any) -> np.ndarray:
    """The starting joint variables (internal units): the modeling posture or ``start``."""
    if start is None:
        return system.q0.copy()
    try:
        q = np.asarray(start, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise InputError(f"start must be {system.nq} numbers (all joint variables)") from None
    if q.shape != (system.nq,) or not np.all(np.isfinite(q)):
        raise InputError(
            f"start must hold {system.nq} finite numbers, one per joint variable "
            f"({', '.join(system.var_names)}); got {q.size}"
        )
    return system.to_internal(q).copy()


def _failure_message(
    system: System, names: list[str], dvals: np.ndarray, k: int, status: int
) -> str:
    scale = np.array([system.var_scale[system.var_index(n)] for n in names])
    want = ", ".join(f"{n} = {v:.8g}" for n, v in zip(names, dvals[k] * scale))
    why = {MAXITER: "Newton did not converge", DIVERGED: "Newton diverged"}.get(
        status, f"status {status}")
    last = f"step {k - 1}" if k > 0 else "the start posture"
    return (
        f"step {k}: posture not reachable ({want}): {why} even in steps of 1/4096; "
        f"the mechanism cannot be assembled there (limit of travel or singular posture). "
        f"The last good posture is {last}."
    )


def check_drivers(
    system: System, q: np.ndarray, sgc: np.ndarray, dcols: np.ndarray, pivot_tol: float,
    hold_free: bool, w: Work | None = None,
) -> tuple[np.ndarray, int, float]:
    """Check the drivers at posture ``q``: not determined by the constraints, enough of them.

    Returns the free coordinates to hold (all of them with ``hold_free``,
    otherwise only passive ones), the rank and the quality index there.
    Raises InputError naming the offending driver or the free coordinates
    that need drivers.  ``w``: scratch to use (a new one otherwise).
    """
    if w is None:
        w = Work(system.K, system.nq)
    rank, det, _rest = w.eliminate(system.KP, q, sgc, pivot_tol)
    nq = system.nq
    if sgc_residual(w.T, sgc, w.prow, rank, nq) > 1e-6:
        # find which driver is determined: the ones with a residual in an unpivoted row
        used = np.zeros(w.T.shape[0], bool)
        used[w.prow[:rank]] = True
        bad = [system.var_names[c] for c in dcols if np.any(np.abs(w.T[~used, c]) > 1e-6)]
        raise InputError(
            f"over-specified motion: driver(s) {', '.join(bad)} are determined by the other "
            f"drivers and the loop constraints (mobility is {nq - rank_full(system, q)}); "
            "remove one of them or drive another joint"
        )
    piv = set(int(c) for c in w.pcol[:rank])
    free = [c for c in range(nq) if c not in piv and not sgc[c]]
    if free and not hold_free:
        passive = passive_freedoms(system, q, w, rank, free)
        active = [c for c in free if c not in passive]
        if active:
            f = nq - rank
            raise InputError(
                f"the mechanism has mobility {f} at its starting posture but only "
                f"{len(dcols)} driver(s) were given; add drivers for "
                f"{len(active)} of the free coordinates found: "
                f"{', '.join(system.var_names[c] for c in active)} "
                "(or pass hold_free=True to keep them at their values)"
            )
    return np.array(free, np.int64), int(rank), float(det)


def rank_full(system: System, q: np.ndarray) -> int:
    """Rank of the whole Jacobian at ``q`` (nothing specified)."""
    w = Work(system.K, system.nq)
    sgc = np.zeros(system.nq, np.bool_)
    rank = w.eliminate(system.KP, q, sgc, 1e-10)[0]
    return int(rank)


def passive_freedoms(system: System, q: np.ndarray, w: Work, rank: int, free: list[int]) -> set:
    """Free coordinates that only spin one body between two ball-type joints.

    Such an idle freedom (the coupler of an RSSR turning about the line of its
    ball centres) moves no other body and no point of the mechanism off that
    line, so a kinematic sweep may hold it.  A free coordinate is passive when
    its first geometric derivative moves exactly one body, that body carries
    exactly two joints, both ball-type (sphere, sphere_plane, sphere_groove),
    and it carries no points.
    """
    K = system.K
    nq = system.nq
    cols = np.array(free, np.int64)
    G = np.zeros((nq, len(free)))
    derivative_matrix(w.T, w.prow, w.pcol, rank, cols, nq, G)
    out: set[int] = set()
    for j, c in enumerate(free):
        moving = []
        for b in range(len(system.bodies)):
            # body twist: sum over its path of P(b,h) D_h dq_h
            tw = np.zeros(6)
            for h in np.flatnonzero(K.P[b]):
                a0 = K.jq0[h]
                for g in range(K.jnv[h]):
                    tw += K.P[b, h] * w.Dh[a0 + g] * G[a0 + g, j]
            if np.max(np.abs(tw)) > 1e-9:
                moving.append(b)
        if len(moving) != 1:
            continue
        b = moving[0]
        incident = [h for h in range(len(system.joints)) if K.jb1[h] == b or K.jb2[h] == b]
        if (
            len(incident) == 2
            and all(K.jcode[h] in (SPHERE, SPHERE_PLANE, SPHERE_GROOVE) for h in incident)
            and not np.any(K.ptbody == b)
        ):
            out.add(c)
    return out


def require_complete(result: SweepResult) -> SweepResult:
    """Raise AnalysisError (carrying the partial result) if the sweep stopped early."""
    if not result.complete:
        raise AnalysisError(result.message, partial=result)
    return result


# =============================================================================
# Batches of variants (same topology, other dimensions or inputs)
# =============================================================================
@njit(parallel=True)
def batch_kernel(
    KI: np.ndarray, KL: np.ndarray, KFs: np.ndarray, KMs: np.ndarray, KVs: np.ndarray,
    q0s: np.ndarray, sgc: np.ndarray, dcols: np.ndarray,
    dvals: np.ndarray, tol: float, ptol: float, maxit: int, maxhalve: int,
    Qout: np.ndarray, quality: np.ndarray, rank_out: np.ndarray, fgc_out: np.ndarray,
    iters_out: np.ndarray, done_out: np.ndarray, status_out: np.ndarray,
) -> None:
    """Run :func:`sweep_kernel` for every variant v in parallel.

    The variants share the topology and joint kinds (the int parts ``KI``
    and ``KL`` of the packed kernel arrays, :func:`openimp.system.pack`) and
    differ in their float parts (constants ``KFs[v]``, shape matrices and
    reference postures ``KMs[v]``, points ``KVs[v]``), their starting
    variables and their driver values (``dvals[v]``).
    """
    nv = q0s.shape[0]
    for v in prange(nv):
        q = q0s[v].copy()
        dummy2 = np.zeros((1, 1))
        dummy1 = np.zeros(1)
        rd = np.zeros((1, dcols.shape[0]))
        done, st = sweep_kernel(
            (KI, KL, KFs[v], KMs[v], KVs[v]), q, sgc, dcols, dvals[v], tol, ptol, maxit,
            maxhalve, Qout[v], quality[v], rank_out[v], fgc_out[v], iters_out[v], False, rd, rd,
            dummy2, dummy2, dummy1)
        done_out[v] = done
        status_out[v] = st


class BatchResult:
    """Sweeps of many variants: one :class:`SweepResult` per variant, on demand.

    ``q`` holds every variant's joint variables (variants x steps x nq, model
    units); ``solved[v]`` is the number of steps variant v reached.
    """

    def __init__(self, systems: Sequence[System], Q: np.ndarray, quality: np.ndarray,
                 rank: np.ndarray, fgc: np.ndarray, iters: np.ndarray, solved: np.ndarray,
                 messages: list[str], drivers: list[str]) -> None:
        self.systems = list(systems)
        self._Q = Q
        self.quality = quality
        self.rank = rank
        self._fgc = fgc
        self.iterations = iters
        self.solved = solved
        self.messages = messages
        self.drivers = drivers

    def __len__(self) -> int:
        return len(self.systems)

    @property
    def q(self) -> np.ndarray:
        """Joint variables (variants x steps x nq), model units (NaN past a failure)."""
        out = self._Q * np.stack([s.var_scale for s in self.systems])[:, None, :]
        for v, n in enumerate(self.solved):
            out[v, n:] = np.nan
        return out

    def __getitem__(self, v: int) -> SweepResult:
        n = int(self.solved[v])
        return SweepResult(self.systems[v], self._Q[v, :n], self.quality[v, :n],
                           self.rank[v, :n], self._fgc[v, :n], self.iterations[v, :n],
                           self.drivers, self.messages[v])


def sweep_batch(
    systems: Sequence[System],
    drivers: Mapping[Any, Sequence[float] | np.ndarray],
    *,
    tol: float = 1e-10,
    pivot_tol: float = 1e-10,
    maxit: int = 25,
    maxhalve: int = 12,
    hold_free: bool = False,
) -> BatchResult:
    """Sweep many variants of one mechanism in one compiled, parallel call.

    ``systems`` are compiled models of the same topology and joint kinds
    (built, for example, from one model-building function with other
    dimensions).  ``drivers`` maps joint keys to arrays of shape (steps,)
    (the same for every variant) or (variants, steps).  Every variant is
    checked like :func:`sweep` and solved independently, in parallel over
    the cores.
    """
    if not systems:
        raise InputError("sweep_batch needs at least one compiled system")
    s0 = systems[0]
    KI, KL = s0.KP[0], s0.KP[1]
    for i, s in enumerate(systems[1:], start=1):
        # same joints, loops, tree and points: the same int parts (KI's header also
        # fixes the shapes of the float parts)
        same = (s.var_names == s0.var_names and s.bodies == s0.bodies
                and np.array_equal(s.KP[0], KI) and np.array_equal(s.KP[1], KL))
        if not same:
            raise InputError(
                f"variant {i} ({s.name!r}) does not have the topology and joints of variant 0 "
                f"({s0.name!r}); a batch needs one mechanism with other dimensions"
            )
    nv = len(systems)
    cols = None
    vals = []
    for key, v in drivers.items():
        a = np.asarray(v, dtype=float)
        if a.ndim == 1:
            a = np.broadcast_to(a, (nv, a.size))
        if a.ndim != 2 or a.shape[0] != nv:
            raise InputError(f"driver {key!r}: give (steps,) or ({nv}, steps) values")
        vals.append(a)
    per_variant = []
    for v, s in enumerate(systems):
        dmap = {key: vals[k][v] for k, key in enumerate(drivers)}
        c, dv = _driver_columns(s, dmap)
        if cols is None:
            cols = c
        per_variant.append(dv)
    assert cols is not None
    dvals = np.ascontiguousarray(np.stack(per_variant))
    nq = s0.nq
    sgc = np.zeros(nq, np.bool_)
    sgc[cols] = True
    held, _, _ = check_drivers(s0, s0.q0.copy(), sgc.copy(), cols, pivot_tol, hold_free)
    sgc[held] = True
    nsteps = dvals.shape[1]
    Q = np.zeros((nv, nsteps, nq))
    quality = np.zeros((nv, nsteps))
    rank = np.zeros((nv, nsteps), np.int64)
    fgc = np.zeros((nv, nsteps, nq), np.bool_)
    iters = np.zeros((nv, nsteps), np.int64)
    done = np.zeros(nv, np.int64)
    status = np.zeros(nv, np.int64)
    batch_kernel(
        KI, KL, *(np.stack([s.KP[k] for s in systems]) for k in (2, 3, 4)),
        np.stack([s.q0 for s in systems]), sgc, cols,
        dvals, tol, pivot_tol, maxit, maxhalve, Q, quality, rank, fgc, iters, done, status)
    names = [s0.var_names[c] for c in cols]
    msgs = ["" if done[v] == nsteps else
            _failure_message(systems[v], names, dvals[v], int(done[v]), int(status[v]))
            for v in range(nv)]
    return BatchResult(systems, Q, quality, rank, fgc, iters, done, msgs, names)
