"""Compiled dense linear algebra for the kernels: solve, exponential, eigenvalues.

The dynamics kernels need four small dense operations inside compiled code
(no allocation, no calls back into numpy or LAPACK, which ``nrt=False``
kernels cannot make): a Cholesky solve of the mass matrix (the time step), the
exponential of the book step's augmented matrix (14.11-14.30), the full-pivot
Gauss-Jordan elimination of the static search (12.6, with its neutral group)
and the eigen-decomposition of a symmetric stiffness (the stable-seeking
search).  They work on the leading ``n x n`` block of preallocated arrays, so
one set of buffers serves every size up to its own; every argument is written
only where the docstring says.  :mod:`openimp.mat4` is the compiled 4x4 and
screw mathematics beside them.

Each is tested against numpy and scipy in ``tests/test_linalg.py``.
"""

from __future__ import annotations

import math

import numpy as np

from openimp._jit import njit


@njit(nrt=False, inline="always")
def cholesky_solve(A: np.ndarray, n: int, b: np.ndarray, x: np.ndarray, tol: float,
                   floor: float) -> bool:
    """x[:n] = A^-1 b[:n] for the symmetric positive definite A[:n, :n], by the Cholesky
    factorization A = L L^T and two triangular solves.

    A (>= n, >= n): its lower triangle (diagonal included) is overwritten by L, the
    strict upper triangle is not read.  b (>= n,) is kept; x (>= n,) receives the
    solution.  Returns False, with A and x partly written, when a pivot (the square of
    L's diagonal before its root) falls to or below ``tol`` times the larger of A's
    largest diagonal entry and ``floor``, or when that larger value is not positive
    (n > 0): a singular or indefinite matrix (a singular mass matrix, IMP's ZERO
    (INERTIA)).  ``floor`` lets a caller judge against a scale known beforehand (the
    mass matrix's when the coordinates were chosen), so that a matrix that shrinks as a
    whole (a 1x1 m r^2 with r -> 0) is singular too; 0 for none.
    """
    big = floor
    for i in range(n):
        big = max(big, abs(A[i, i]))
    if n > 0 and big <= 0.0:
        return False
    for j in range(n):
        s = A[j, j]
        for k in range(j):
            s -= A[j, k] * A[j, k]
        if s <= tol * big:
            return False
        d = math.sqrt(s)
        A[j, j] = d
        for i in range(j + 1, n):
            s = A[i, j]
            for k in range(j):
                s -= A[i, k] * A[j, k]
            A[i, j] = s / d
    for i in range(n):
        s = b[i]
        for k in range(i):
            s -= A[i, k] * x[k]
        x[i] = s / A[i, i]
    for i in range(n - 1, -1, -1):
        s = x[i]
        for k in range(i + 1, n):
            s -= A[k, i] * x[k]
        x[i] = s / A[i, i]
    return True

@njit(nrt=False)
def expm(A: np.ndarray, n: int, E: np.ndarray, X1: np.ndarray, X2: np.ndarray) -> None:
    """E[:n, :n] = exp(A[:n, :n]), by scaling and squaring of the Taylor series.

    A is scaled by 2^-s to an infinity norm (largest row sum) <= 1/2, the Taylor
    polynomial of degree 16 is evaluated by Horner's rule (truncation below 1e-19
    relative) and squared s times.  A (>= n, >= n) is kept; E receives the
    exponential; X1, X2 (>= n, >= n) scratch.  The matrices of the book step are
    small (2 nF + 3) with moderate norms, where this agrees with scipy's Pade
    approximant to 1e-13 of the largest entry (measured up to norm 60).
    """
    norm = 0.0
    for i in range(n):
        s = 0.0
        for j in range(n):
            s += abs(A[i, j])
        norm = max(norm, s)
    sq = 0
    if norm > 0.5:
        sq = math.ceil(math.log2(norm / 0.5))
    sc = 0.5 ** sq
    for i in range(n):
        for j in range(n):
            X1[i, j] = A[i, j] * sc
            E[i, j] = 1.0 if i == j else 0.0
    for k in range(16, 0, -1):  # Horner: E = I + X1 E / k
        for i in range(n):
            for j in range(n):
                s = 0.0
                for m in range(n):
                    s += X1[i, m] * E[m, j]
                X2[i, j] = s / k
        for i in range(n):
            for j in range(n):
                E[i, j] = X2[i, j] + (1.0 if i == j else 0.0)
    for _ in range(sq):
        for i in range(n):
            for j in range(n):
                s = 0.0
                for m in range(n):
                    s += E[i, m] * E[m, j]
                X2[i, j] = s
        for i in range(n):
            for j in range(n):
                E[i, j] = X2[i, j]

@njit(nrt=False)
def full_pivot(A: np.ndarray, n: int, eps: float, rleft: np.ndarray, cleft: np.ndarray,
               prow: np.ndarray, pcol: np.ndarray) -> int:
    """Gauss-Jordan elimination of the augmented A[:n, :n+1] = [K | F] with full pivoting
    (book 12.6), in place.

    Pivots are taken, each the largest magnitude of the rows and columns not yet used
    (the Schur complement), while it exceeds ``eps``.  prow, pcol (>= n,) int receive the
    pivots' rows and columns in order; rleft, cleft (>= n,) bool mark the rows and
    columns left unpivoted (the neutral group: K's numerical null space at ``eps``).
    Returns the number of pivots r (K's rank at ``eps``).  After it, with x the
    solution of K x = F over the pivoted columns,
    x[pcol[k]] = A[prow[k], n] - sum over the neutral columns j of A[prow[k], j] x[j]
    (the neutral x[j] free: zero for the particular solution), and A[i, n] of a row i
    left is its reduced load (zero when F is in K's range).
    """
    for i in range(n):
        rleft[i] = True
        cleft[i] = True
    npiv = 0
    for _ in range(n):
        best = -1.0
        r = -1
        c = -1
        for i in range(n):
            if not rleft[i]:
                continue
            for j in range(n):
                if cleft[j] and abs(A[i, j]) > best:
                    best = abs(A[i, j])
                    r = i
                    c = j
        if r < 0 or best <= eps:
            break
        p = A[r, c]
        for j in range(n + 1):
            A[r, j] /= p
        for i in range(n):
            if i != r and A[i, c] != 0.0:
                f = A[i, c]
                for j in range(n + 1):
                    A[i, j] -= f * A[r, j]
        rleft[r] = False
        cleft[c] = False
        prow[npiv] = r
        pcol[npiv] = c
        npiv += 1
    return npiv

@njit(nrt=False, inline="always")
def _rotate(A: np.ndarray, n: int, p: int, q: int, c: float, s: float) -> None:
    """Columns p and q of A[:n] turned by the plane rotation (c, s): A <- A R."""
    for k in range(n):
        a = A[k, p]
        b = A[k, q]
        A[k, p] = c * a - s * b
        A[k, q] = s * a + c * b


@njit(nrt=False)
def sym_eigen(K: np.ndarray, n: int, W: np.ndarray, V: np.ndarray, lam: np.ndarray) -> None:
    """Eigenvalues lam[:n] in ascending order and eigenvectors V[:n, :n] (columns,
    orthonormal) of the symmetric part (K + K^T) / 2 of K[:n, :n], by the cyclic Jacobi
    method: rotations annihilate every off-diagonal entry in turn, sweep after sweep,
    until the off-diagonal sum of squares is at or below 1e-30 of the diagonal's (or
    zero), at most 60 sweeps (Jacobi converges quadratically; a handful suffice).

    K (>= n, >= n) is kept; W (>= n, >= n) scratch (the rotated matrix); repeated
    eigenvalues are exact in Jacobi (no deflation), their vectors any orthonormal basis
    of the eigenspace.
    """
    for i in range(n):
        for j in range(n):
            W[i, j] = 0.5 * (K[i, j] + K[j, i])
            V[i, j] = 1.0 if i == j else 0.0
    for _sweep in range(60):
        off = 0.0
        diag = 0.0
        for i in range(n):
            diag += W[i, i] * W[i, i]
            for j in range(i + 1, n):
                off += W[i, j] * W[i, j]
        if off <= 1e-30 * diag or off == 0.0:
            break
        for p in range(n):
            for q in range(p + 1, n):
                if W[p, q] == 0.0:
                    continue
                theta = (W[q, q] - W[p, p]) / (2.0 * W[p, q])
                t = (1.0 if theta >= 0 else -1.0) / (abs(theta) + np.sqrt(theta * theta + 1.0))
                c = 1.0 / np.sqrt(t * t + 1.0)
                s = t * c
                _rotate(W, n, p, q, c, s)  # W <- W R, then R^T W: its rows as columns
                _rotate(W.T, n, p, q, c, s)
                _rotate(V, n, p, q, c, s)
    for i in range(n):
        lam[i] = W[i, i]
    for i in range(n):  # selection sort, columns of V along
        m = i
        for j in range(i + 1, n):
            if lam[j] < lam[m]:
                m = j
        if m != i:
            x = lam[i]
            lam[i] = lam[m]
            lam[m] = x
            for k in range(n):
                x = V[k, i]
                V[k, i] = V[k, m]
                V[k, m] = x
