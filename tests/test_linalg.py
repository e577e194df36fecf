"""The compiled dense linear algebra of :mod:`openimp.linalg` against numpy and scipy.

Each kernel is run on the leading block of larger buffers (as the dynamics kernels
call them) and compared with ``scipy.linalg.expm``, ``numpy.linalg.solve``,
``numpy.linalg.cholesky``, ``numpy.linalg.eigh`` and ``numpy.linalg.svd``.
Tolerances are relative to the largest entry of the reference (stated at each
check): 1e-12 where both algorithms are backward stable on a well-conditioned
problem; on ill-conditioned ones the forward difference is bounded by the
condition number times 1e-14 (both solutions are that far from the exact one),
and the backward error (the residual) is checked at 1e-14 instead.  The same
tests run uncompiled in CI (``OPENIMP_NOJIT=1``, ``.ci/run``).
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

from openimp.linalg import cholesky_solve, expm, full_pivot, sym_eigen

#: spare rows and columns of every buffer: the kernels must use the leading block only
PAD = 2


def rel(a: np.ndarray, ref: np.ndarray) -> float:
    """Largest difference relative to the largest entry of the reference."""
    return float(np.abs(a - ref).max() / max(np.abs(ref).max(), 1e-300))


def padded(A: np.ndarray, fill: float = 7.0) -> np.ndarray:
    """A in the leading block of a larger array whose other entries are ``fill``."""
    out = np.full(tuple(s + PAD for s in A.shape), fill)
    out[tuple(slice(0, s) for s in A.shape)] = A
    return out


def spd(rng: np.random.Generator, n: int, cond: float) -> np.ndarray:
    """A symmetric positive definite matrix with eigenvalues log-spaced over 1 .. 1/cond."""
    Q = np.linalg.qr(rng.standard_normal((n, n)))[0]
    A = (Q * np.logspace(0, -np.log10(cond), n)) @ Q.T
    return 0.5 * (A + A.T)


# ----------------------------------------------------------------------------- expm
@pytest.mark.parametrize("n", [1, 3, 8, 13])
@pytest.mark.parametrize("norm", [0.0, 0.1, 1.0, 10.0, 60.0])
def test_expm_against_scipy(n: int, norm: float):
    """exp(A) of random matrices of infinity norm 0 .. 60 (0, 3 and 7 squarings): within
    1e-12 of scipy's Pade expm relative to its largest entry (measured: 6e-14 at norm
    60); A kept, the buffers' spare entries untouched."""
    rng = np.random.default_rng(100 * n + int(norm))
    A = rng.standard_normal((n, n))
    A *= norm / np.abs(A).sum(axis=1).max()
    Ap = padded(A)
    E, X1, X2 = padded(np.zeros((n, n)), -3.0), padded(np.zeros((n, n))), padded(np.zeros((n, n)))
    expm(Ap, n, E, X1, X2)
    assert rel(E[:n, :n], scipy.linalg.expm(A)) < 1e-12
    assert np.array_equal(Ap, padded(A))
    assert (E[n:, :] == -3.0).all() and (E[:, n:] == -3.0).all()


def test_expm_of_the_augmented_matrix_integrates_a_forced_oscillator():
    """The book step's use (14.11-14.30): the exponential of [[-D/m, -K/m, f/m], [1, 0, 0],
    [0, 0, 0]] * tau applied to (v, x, 1) is the exact response of m x'' + D x' + K x = f
    from rest, written in closed form here (underdamped), to 1e-12 relative."""
    m, D, K, f, tau = 2.0, 0.3, 50.0, 4.0, 0.7
    A = np.array([[-D / m, -K / m, f / m], [1.0, 0.0, 0.0], [0.0, 0.0, 0.0]]) * tau
    E, X1, X2 = np.zeros((3, 3)), np.zeros((3, 3)), np.zeros((3, 3))
    expm(A, 3, E, X1, X2)
    zeta = D / (2.0 * np.sqrt(K * m))
    wn = np.sqrt(K / m)
    wd = wn * np.sqrt(1.0 - zeta**2)
    e = np.exp(-zeta * wn * tau)
    x = f / K * (1.0 - e * (np.cos(wd * tau) + zeta * wn / wd * np.sin(wd * tau)))
    v = f / K * e * (wn**2 / wd) * np.sin(wd * tau)
    got = E[:2, 2]
    assert rel(got, np.array([v, x])) < 1e-12


# ----------------------------------------------------------------------------- cholesky
@pytest.mark.parametrize("n", [1, 4, 12])
def test_cholesky_solve_well_conditioned(n: int):
    """Condition number 100: x within 1e-12 of numpy.linalg.solve and the factor (A's
    lower triangle after the call) within 1e-12 of numpy.linalg.cholesky, both relative
    to their largest entry; b kept, A's strict upper triangle and spare entries kept."""
    rng = np.random.default_rng(n)
    A = spd(rng, n, 100.0) * 3.7
    b = rng.standard_normal(n)
    L, bp, x = padded(A), padded(b), padded(np.zeros(n), -1.0)
    assert cholesky_solve(L, n, bp, x, 1e-14, 0.0)
    assert rel(x[:n], np.linalg.solve(A, b)) < 1e-12
    assert rel(np.tril(L[:n, :n]), np.linalg.cholesky(A)) < 1e-12
    assert np.array_equal(np.triu(L[:n, :n], 1), np.triu(A, 1))
    assert np.array_equal(bp, padded(b)) and (x[n:] == -1.0).all()
    assert (L[n:] == 7.0).all() and (L[:, n:] == 7.0).all()


@pytest.mark.parametrize("cond", [1e6, 1e10])
def test_cholesky_solve_ill_conditioned(cond: float):
    """Condition number 1e6 and 1e10 (n = 10): the residual |A x - b| within 1e-14 of
    |A| |x| (backward stable, as numpy's LU), and x within cond * 1e-14 of numpy's
    (each is that far from the exact solution); the factor within sqrt(cond) * 1e-14
    of numpy's (the Cholesky factor's conditioning is the square root of A's)."""
    rng = np.random.default_rng(int(np.log10(cond)))
    n = 10
    A = spd(rng, n, cond)
    b = rng.standard_normal(n)
    L, x = A.copy(), np.zeros(n)
    assert cholesky_solve(L, n, b, x, 1e-16 / cond, 0.0)
    assert np.abs(A @ x - b).max() <= 1e-14 * np.abs(A).max() * np.abs(x).max()
    assert rel(x, np.linalg.solve(A, b)) < cond * 1e-14
    assert rel(np.tril(L), np.linalg.cholesky(A)) < np.sqrt(cond) * 1e-14


def test_cholesky_solve_refuses_singular_and_indefinite():
    """False for a rank-deficient, an indefinite and a zero matrix; a pivot exactly at
    tol times the scale is refused, just above accepted; ``floor`` raises the scale
    (a 1x1 matrix 1e-10 is singular against a floor of 1 at tol 1e-9, not without);
    n = 0 solves nothing and succeeds."""
    rng = np.random.default_rng(5)
    B = rng.standard_normal((4, 2))
    b = np.ones(4)
    x = np.zeros(4)
    assert not cholesky_solve(B @ B.T, 4, b, x, 1e-12, 0.0)  # rank 2
    assert not cholesky_solve(np.diag([2.0, -1.0, 3.0, 1.0]), 4, b, x, 1e-12, 0.0)
    assert not cholesky_solve(np.zeros((4, 4)), 4, b, x, 1e-12, 0.0)
    # second pivot of [[4, 2], [2, 1 + p]] is p: exactly 0.25 * 4 refused, above it accepted
    assert not cholesky_solve(np.array([[4.0, 2.0], [2.0, 2.0]]), 2, b, x, 0.25, 0.0)
    assert cholesky_solve(np.array([[4.0, 2.0], [2.0, 2.0 + 1e-9]]), 2, b, x, 0.25, 0.0)
    assert not cholesky_solve(np.array([[1e-10]]), 1, b, x, 1e-9, 1.0)
    assert cholesky_solve(np.array([[1e-10]]), 1, b, x, 1e-9, 0.0)
    assert x[0] == pytest.approx(1e10, rel=1e-15)
    assert cholesky_solve(np.zeros((0, 0)), 0, b, x, 1e-12, 0.0)


# ----------------------------------------------------------------------------- full pivot
def pivot(K: np.ndarray, F: np.ndarray, eps: float
          ) -> tuple[int, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """full_pivot on [K | F] in padded buffers: (rank, A, prow, pcol, rleft, cleft)."""
    n = K.shape[0]
    A = padded(np.column_stack([K, F]))
    rleft, cleft = np.zeros(n + PAD, np.bool_), np.zeros(n + PAD, np.bool_)
    prow, pcol = np.full(n + PAD, -1, np.int64), np.full(n + PAD, -1, np.int64)
    r = full_pivot(A, n, eps, rleft, cleft, prow, pcol)
    assert (A[n:] == 7.0).all() and (A[:, n + 1:] == 7.0).all()
    return r, A[:n, :n + 1], prow, pcol, rleft[:n], cleft[:n]


def particular(A: np.ndarray, r: int, prow: np.ndarray, pcol: np.ndarray) -> np.ndarray:
    """The solution with the neutral coordinates zero (the docstring's formula)."""
    n = A.shape[0]
    x = np.zeros(n)
    for k in range(r):
        x[pcol[k]] = A[prow[k], n]
    return x


@pytest.mark.parametrize("cond", [10.0, 1e8])
def test_full_pivot_solves_a_regular_system(cond: float):
    """Nonsymmetric K (n = 9) of condition 10 and 1e8: rank n, no neutral group, prow and
    pcol permutations, and x within 1e-12 (cond 10) or cond * 1e-14 of
    numpy.linalg.solve relative to its largest entry."""
    rng = np.random.default_rng(int(cond))
    n = 9
    U = np.linalg.qr(rng.standard_normal((n, n)))[0]
    V = np.linalg.qr(rng.standard_normal((n, n)))[0]
    K = (U * np.logspace(0, -np.log10(cond), n)) @ V.T
    F = rng.standard_normal(n)
    r, A, prow, pcol, rleft, cleft = pivot(K, F, 1e-14)
    assert r == n and not rleft.any() and not cleft.any()
    assert sorted(prow[:n]) == list(range(n)) and sorted(pcol[:n]) == list(range(n))
    assert rel(particular(A, r, prow, pcol), np.linalg.solve(K, F)) < max(1e-12, cond * 1e-14)


@pytest.mark.parametrize(("n", "rank"), [(5, 3), (8, 1), (6, 5), (4, 0)])
def test_full_pivot_rank_deficient(n: int, rank: int):
    """K = U S V^T of rank r < n (singular values 1 .. 0.1, the rest exactly 0 up to
    rounding): r pivots at eps 1e-10 (numpy.linalg.matrix_rank agrees), n - r rows and
    columns left; every neutral column j gives a null vector z (z_j = 1,
    z[pcol_k] = -A[prow_k, j]) with |K z| within 1e-12 of |K| |z|, spanning numpy's
    SVD null space; a load in K's range leaves reduced loads below 1e-12 |F| and the
    particular solution solves K x = F to 1e-12; a load with a part F_perp outside the
    range has reduced loads equal to those of F_perp alone (linear, zero on the range)
    and not zero."""
    rng = np.random.default_rng(10 * n + rank)
    U = np.linalg.qr(rng.standard_normal((n, n)))[0]
    V = np.linalg.qr(rng.standard_normal((n, n)))[0]
    s = np.zeros(n)
    s[:rank] = np.linspace(1.0, 0.1, rank)
    K = (U * s) @ V.T
    assert np.linalg.matrix_rank(K, tol=1e-10) == rank
    F = K @ rng.standard_normal(n)  # in the range
    r, A, prow, pcol, rleft, cleft = pivot(K, F, 1e-10)
    assert r == rank and rleft.sum() == n - rank and cleft.sum() == n - rank
    assert set(pcol[:r]).isdisjoint(np.flatnonzero(cleft))
    assert set(prow[:r]).isdisjoint(np.flatnonzero(rleft))
    Z = []
    for j in np.flatnonzero(cleft):
        z = np.zeros(n)
        z[j] = 1.0
        for k in range(r):
            z[pcol[k]] = -A[prow[k], j]
        assert np.abs(K @ z).max() <= 1e-12 * np.abs(K).max() * np.abs(z).max()
        Z.append(z)
    if Z:  # the null vectors span the SVD's null space (the last n - r right vectors)
        Zn = np.linalg.qr(np.array(Z).T)[0]
        N = V[:, rank:]
        assert rel(Zn @ Zn.T, N @ N.T) < 1e-12
    scale = max(np.abs(F).max(), 1e-300)
    assert np.abs(A[rleft, n]).max(initial=0.0) <= 1e-12 * max(scale, 1.0)
    if rank:
        x = particular(A, r, prow, pcol)
        assert np.abs(K @ x - F).max() <= 1e-12 * scale
    # a load with a part outside the range: left null vectors U[:, rank:]
    Fp = U[:, rank:] @ rng.standard_normal(n - rank)
    red = pivot(K, F + Fp, 1e-10)[1][rleft, n]
    red_perp = pivot(K, Fp, 1e-10)[1][rleft, n]
    assert rel(red, red_perp) < 1e-12 and np.abs(red).max() > 1e-3 * np.abs(Fp).max()


def test_full_pivot_order_and_threshold():
    """Pivots largest first; an entry at or below eps is never a pivot: diag(3, 1e-8, -5, 2)
    at eps 1e-6 pivots columns 2, 0, 3 (rows likewise) and leaves coordinate 1 neutral with
    its load as reduced load; at eps 1e-8 exactly, the same (<= eps refused); below it, all
    four."""
    K = np.diag([3.0, 1e-8, -5.0, 2.0])
    F = np.array([1.0, 2.0, 3.0, 4.0])
    for eps in (1e-6, 1e-8):
        r, A, prow, pcol, rleft, cleft = pivot(K, F, eps)
        assert r == 3 and list(pcol[:3]) == [2, 0, 3] and list(prow[:3]) == [2, 0, 3]
        assert list(cleft) == [False, True, False, False] and list(rleft) == list(cleft)
        assert A[1, 4] == 2.0
        np.testing.assert_allclose(particular(A, r, prow, pcol), [1 / 3, 0.0, -0.6, 2.0],
                                   rtol=1e-15)
    assert pivot(K, F, 0.99e-8)[0] == 4


# ----------------------------------------------------------------------------- Jacobi
def eigen(K: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """sym_eigen in padded buffers: (lam, V)."""
    n = K.shape[0]
    Kp = padded(K)
    W, V, lam = padded(np.zeros((n, n))), padded(np.zeros((n, n)), 5.0), padded(np.zeros(n), 5.0)
    sym_eigen(Kp, n, W, V, lam)
    assert np.array_equal(Kp, padded(K))
    assert (V[n:] == 5.0).all() and (V[:, n:] == 5.0).all() and (lam[n:] == 5.0).all()
    return lam[:n], V[:n, :n]


def check_eigen(S: np.ndarray, lam: np.ndarray, V: np.ndarray) -> None:
    """Against numpy.linalg.eigh of the symmetric S: eigenvalues ascending within 1e-12 of
    |S|; V orthonormal and S V = V diag(lam) to 1e-12 |S|; the projector on each cluster
    of equal eigenvalues (gap below 1e-9 |S|) equal to numpy's to 1e-12 (the vectors of
    a repeated eigenvalue are any basis of its eigenspace)."""
    n = S.shape[0]
    top = max(np.abs(S).max(), 1e-300)
    ref, R = np.linalg.eigh(S)
    assert (np.diff(lam) >= 0).all()
    assert np.abs(lam - ref).max() <= 1e-12 * top
    assert np.abs(V.T @ V - np.eye(n)).max() <= 1e-12
    assert np.abs(S @ V - V * lam).max() <= 1e-12 * top
    start = 0
    for i in range(1, n + 1):
        if i == n or ref[i] - ref[i - 1] > 1e-9 * top:
            P = V[:, start:i] @ V[:, start:i].T
            Pr = R[:, start:i] @ R[:, start:i].T
            assert np.abs(P - Pr).max() <= 1e-12
            start = i


@pytest.mark.parametrize("n", [1, 2, 5, 11])
def test_sym_eigen_random(n: int):
    """Random symmetric matrices with eigenvalues of both signs (checks of check_eigen)."""
    rng = np.random.default_rng(n)
    B = rng.standard_normal((n, n))
    S = B + B.T
    check_eigen(S, *eigen(S))


def test_sym_eigen_takes_the_symmetric_part():
    """An unsymmetric K (follower loads): the result is eigh((K + K^T) / 2)."""
    rng = np.random.default_rng(3)
    K = rng.standard_normal((6, 6))
    check_eigen(0.5 * (K + K.T), *eigen(K))


@pytest.mark.parametrize("values", [[1.0, 1.0, 1.0, 2.0, 5.0, 5.0], [0.0, 0.0, 3.0, -2.0],
                                    [4.0, 4.0, 4.0, 4.0], [-1.0, 1e-9, -1.0, 7.0, 7.0]])
def test_sym_eigen_repeated_eigenvalues(values: list[float]):
    """Q diag(values) Q^T with repeated (and zero) eigenvalues: each exact to 1e-12 and
    each eigenspace's projector equal to numpy's to 1e-12."""
    rng = np.random.default_rng(len(values))
    n = len(values)
    Q = np.linalg.qr(rng.standard_normal((n, n)))[0]
    S = (Q * np.array(values)) @ Q.T
    S = 0.5 * (S + S.T)
    lam, V = eigen(S)
    assert np.abs(lam - np.sort(values)).max() <= 1e-12 * np.abs(values).max()
    check_eigen(S, lam, V)


def test_sym_eigen_diagonal_and_zero():
    """Already diagonal (no rotation): the diagonal sorted, V the matching permutation,
    exactly; the zero matrix: zeros and the identity."""
    lam, V = eigen(np.diag([3.0, -1.0, 2.0]))
    assert list(lam) == [-1.0, 2.0, 3.0]
    assert np.array_equal(V, np.eye(3)[:, [1, 2, 0]])
    lam, V = eigen(np.zeros((3, 3)))
    assert not lam.any() and np.array_equal(V, np.eye(3))
