"""Compiled chapter-3 mathematics: 4x4 transforms, rotations and screws inside kernels.

:mod:`openimp.spatial` is the numpy side of book chapter 3 (batched, checked,
for Python callers); this module is its only compiled counterpart, written as
small functions on preallocated arrays for the numba kernels of
:mod:`openimp.joints` and :mod:`openimp.kinematics`.  Stacks of 4x4 matrices
are addressed by index (``a[ia]``) where a kernel would otherwise make a view
in a hot loop.

Screws (book 6.41) are 6-vectors ``(v, w)``: the operator
``D = [[skew(w), v], [0, 0]]`` acting on homogeneous points.  The commutator
of two operators is the screw :func:`screw_bracket`.
"""

from __future__ import annotations

import math

import numpy as np

from openimp._jit import njit


@njit(nrt=False, forceinline=True)
def eye4(out: np.ndarray) -> None:
    """out = I (4x4)."""
    for i in range(4):
        for j in range(4):
            out[i, j] = 0.0
        out[i, i] = 1.0


@njit(nrt=False, forceinline=True)
def rotz4(out: np.ndarray, a: float) -> None:
    """out = Rz(a) as a 4x4 (no translation)."""
    ca = math.cos(a)
    sa = math.sin(a)
    eye4(out)
    out[0, 0] = ca
    out[0, 1] = -sa
    out[1, 0] = sa
    out[1, 1] = ca


@njit(nrt=False, forceinline=True)
def er_rotation(out: np.ndarray, e: np.ndarray, k: int) -> None:
    """Theta(e) of book (3.50) from the Euler-Rodrigues block e[k:k+4] into out[:3, :3]."""
    e1 = e[k]
    e2 = e[k + 1]
    e3 = e[k + 2]
    e4 = e[k + 3]
    out[0, 0] = e1 * e1 - e2 * e2 - e3 * e3 + e4 * e4
    out[0, 1] = 2.0 * (e1 * e2 - e3 * e4)
    out[0, 2] = 2.0 * (e1 * e3 + e2 * e4)
    out[1, 0] = 2.0 * (e1 * e2 + e3 * e4)
    out[1, 1] = -e1 * e1 + e2 * e2 - e3 * e3 + e4 * e4
    out[1, 2] = 2.0 * (e2 * e3 - e1 * e4)
    out[2, 0] = 2.0 * (e1 * e3 - e2 * e4)
    out[2, 1] = 2.0 * (e2 * e3 + e1 * e4)
    out[2, 2] = -e1 * e1 - e2 * e2 + e3 * e3 + e4 * e4


@njit(nrt=False, forceinline=True)
def er_norm2(x: np.ndarray, e0: int) -> float:
    """Sum of squares of the block of four Euler-Rodrigues entries of ``x`` at ``e0``.

    Of the parameters: the normalisation residual 1 - |e|^2 (6.43); of their
    rates: -2 |e'|^2, the acceleration right-hand side of that row.
    """
    return x[e0] * x[e0] + x[e0 + 1] * x[e0 + 1] + x[e0 + 2] * x[e0 + 2] + x[e0 + 3] * x[e0 + 3]


@njit(nrt=False, forceinline=True)
def elem_rot3(axis: int, a: float, order: int, out: np.ndarray) -> None:
    """3x3 rotation about z (axis 2) or x (axis 0) by ``a``, or its 1st/2nd derivative."""
    for i in range(3):
        for j in range(3):
            out[i, j] = 0.0
    ca = math.cos(a)
    sa = math.sin(a)
    # derivative of order k of (cos, sin) is (cos(a + k pi/2), sin(a + k pi/2))
    if order == 0:
        cc, ss, one = ca, sa, 1.0
    elif order == 1:
        cc, ss, one = -sa, ca, 0.0
    else:
        cc, ss, one = -ca, -sa, 0.0
    if axis == 2:
        out[0, 0] = cc
        out[0, 1] = -ss
        out[1, 0] = ss
        out[1, 1] = cc
        out[2, 2] = one
    else:
        out[0, 0] = one
        out[1, 1] = cc
        out[1, 2] = -ss
        out[2, 1] = ss
        out[2, 2] = cc


@njit(nrt=False, forceinline=True)
def mm3(A: np.ndarray, B: np.ndarray, out: np.ndarray) -> None:
    """out = A B for 3x3 blocks (out must differ from A and B)."""
    for i in range(3):
        for j in range(3):
            out[i, j] = A[i, 0] * B[0, j] + A[i, 1] * B[1, j] + A[i, 2] * B[2, j]


@njit(nrt=False, forceinline=True)
def mm4(a: np.ndarray, ia: int, b: np.ndarray, ib: int, out: np.ndarray, io: int) -> None:
    """out[io] = a[ia] @ b[ib] for stacks of homogeneous 4x4 matrices.

    ``out`` may be ``a`` (same index: each row of a is read before it is
    written), not ``b``.
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
def inv4(a: np.ndarray, out: np.ndarray) -> None:
    """Rigid inverse of a homogeneous 4x4 whose rotation part is orthogonal (3.27)."""
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
def gen_inv4(m: np.ndarray, out: np.ndarray) -> None:
    """Inverse of a homogeneous 4x4 whose 3x3 block need not be orthogonal.

    Joint matrices built from Euler-Rodrigues parameters off the unit sphere
    are scaled rotations; the exact inverse keeps Newton consistent there.
    """
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
        out[i, 3] = -(out[i, 0] * m[0, 3] + out[i, 1] * m[1, 3] + out[i, 2] * m[2, 3])
    out[3, 0] = 0.0
    out[3, 1] = 0.0
    out[3, 2] = 0.0
    out[3, 3] = 1.0


@njit(nrt=False, forceinline=True)
def similar_screw(A: np.ndarray, Q: np.ndarray, out: np.ndarray, io: int,
                  scr: np.ndarray) -> None:
    """out[io] = screw of A Q A^-1 (6.14, 6.41) for a rigid A and an operator Q.

    With A = [[R, p], [0, 1]] and Q = [[M, v], [0, 0]]: the 3x3 part is
    M' = R M R^T, of which only the skew part (w) is kept (an Euler-Rodrigues
    operator's symmetric part multiplies the normalisation and vanishes on
    the constraint manifold), and the 4th column is R v - M' p.  ``scr``:
    two 4x4 scratch matrices.
    """
    RM = scr[0]
    Mp = scr[1]
    for i in range(3):
        for j in range(3):
            RM[i, j] = A[i, 0] * Q[0, j] + A[i, 1] * Q[1, j] + A[i, 2] * Q[2, j]
    for i in range(3):
        for j in range(3):
            Mp[i, j] = RM[i, 0] * A[j, 0] + RM[i, 1] * A[j, 1] + RM[i, 2] * A[j, 2]
    for i in range(3):
        out[io, i] = (
            A[i, 0] * Q[0, 3] + A[i, 1] * Q[1, 3] + A[i, 2] * Q[2, 3]
            - (Mp[i, 0] * A[0, 3] + Mp[i, 1] * A[1, 3] + Mp[i, 2] * A[2, 3])
        )
    out[io, 3] = Mp[2, 1]
    out[io, 4] = Mp[0, 2]
    out[io, 5] = Mp[1, 0]


@njit(nrt=False, forceinline=True)
def screw_bracket(x: np.ndarray, y: np.ndarray, f: float, out: np.ndarray) -> None:
    """out += f [X, Y] for screws x = (v, w), y: the commutator X Y - Y X of the operators.

    [X, Y] = (w_x × v_y - w_y × v_x, w_x × w_y).
    """
    vx0, vx1, vx2, wx0, wx1, wx2 = x[0], x[1], x[2], x[3], x[4], x[5]
    vy0, vy1, vy2, wy0, wy1, wy2 = y[0], y[1], y[2], y[3], y[4], y[5]
    out[0] += f * ((wx1 * vy2 - wx2 * vy1) - (wy1 * vx2 - wy2 * vx1))
    out[1] += f * ((wx2 * vy0 - wx0 * vy2) - (wy2 * vx0 - wy0 * vx2))
    out[2] += f * ((wx0 * vy1 - wx1 * vy0) - (wy0 * vx1 - wy1 * vx0))
    out[3] += f * (wx1 * wy2 - wx2 * wy1)
    out[4] += f * (wx2 * wy0 - wx0 * wy2)
    out[5] += f * (wx0 * wy1 - wx1 * wy0)
