"""The book's step of a ball joint in local rotation coordinates (book 14.11, 3.48-3.50).

A SPHERE joint's variables are Euler-Rodrigues parameters e = (e1, e2, e3, e4), three
of them free and one dependent through |e| = 1 (6.43).  They are a poor chart for the
book's linearized step: a steady rotation at rate w moves them as sin(w t / 2) and
cos(w t / 2), so the linear model frozen at the step start leaves a local error
of order (w h)^3 that no linear model in e removes (a top spinning at 50 rad/s on a
ball was 100 to 2500 times less accurate than the same top on three revolutes,
whose angle of spin is linear in time).

Here the step is taken in the rotation vector theta of the second body relative to
its place at the step start,

    e(theta) = e0 (x) q(theta),    q(theta) = (sin(|theta|/2) theta/|theta|, cos(|theta|/2)),

(x) the product of Euler-Rodrigues parameters (the composition of rotations
Theta(e0) Theta(q), 3.50), in which a steady rotation is a straight line in time.
The step's linear model in e (v' = P_v v + P_x x + f, :func:`~openimp.dynamics.
stepping.book_predict`) becomes the one in theta by the chain rule with the
derivatives of e(theta) at theta = 0 (exact, closed form):

    e_F = g(theta):  g' = L(e0)[:, :3] / 2,  g''[a, b] = L(e0)[:, 3] (-a.b / 4),
                     g'''[a, b, c] = -L(e0)[:, :3] (a.b c + a.c b + b.c a) / 24,

L(e0) the matrix of the left product by e0, rows of the free parameters.  With
theta'* = g'^-1 v_F* and theta''* = g'^-1 (f* - g''[theta'*, theta'*]):

    theta'' = g'^-1 (P_v g' - 2 G2') dtheta' + g'^-1 (P_v G2' + P_x g' - G2'' - G3) theta
              + g'^-1 (f - g''[theta'*, theta'*])

(G2' = g''[theta'*, .], G2'' = g''[theta''*, .], G3 = g'''[theta'*, theta'*, .]),
solved by the same exponential; the end is mapped back exactly through e(theta)
and its time derivatives.  Only a ball whose three free parameters are all FGCs of
the step (the fourth dependent) is treated so; any other coordinate keeps its row.
"""

from __future__ import annotations

import math

import numpy as np

from openimp._jit import njit
from openimp.joints.codes import OPEN, SPHERE
from openimp.system import model_views

#: below this |theta| the functions of the rotation vector are taken from their series
SERIES = 0.5
#: Taylor coefficients of sin(phi/2)/phi in p = phi^2: (-1)^k / (2^(2k+1) (2k+1)!)
S_COEF = np.array([(-1.0) ** k / (2.0 ** (2 * k + 1) * math.factorial(2 * k + 1))
                   for k in range(9)])


@njit(nrt=False)
def ball_blocks(KP: tuple, role: np.ndarray, fcols: np.ndarray, nF: int,
                blk: np.ndarray) -> int:
    """The ball joints stepped in local rotation coordinates (SPHERE, and the rotation of
    an OPEN joint): those with three of their four Euler-Rodrigues parameters free
    (role 1) and the fourth dependent (role 0).
    blk (nq, 4) int: per ball, the column of its e1 and the places (0 .. nF-1) of its
    three free parameters in fcols; the row after the last holds -1.  Returns their
    number."""
    K = model_views(KP)
    nb = 0
    for h in range(K.jcode.shape[0]):
        if K.jcode[h] == SPHERE:
            c0 = K.jq0[h]
        elif K.jcode[h] == OPEN:  # its rotation after its three translations
            c0 = K.jq0[h] + 3
        else:
            continue
        nfree = 0
        ndep = 0
        for m in range(4):
            if role[c0 + m] == 1:
                nfree += 1
            elif role[c0 + m] == 0:
                ndep += 1
        if nfree != 3 or ndep != 1:
            continue
        blk[nb, 0] = c0
        r = 1
        for j in range(nF):
            if c0 <= fcols[j] < c0 + 4:
                blk[nb, r] = j
                r += 1
        nb += 1
    if nb < blk.shape[0]:
        blk[nb, 0] = -1
    return nb


@njit(nrt=False, inline="always")
def left_product(e0: np.ndarray, c0: int, L: np.ndarray) -> None:
    """L (4, 4) with e0 (x) q = L q for the Euler-Rodrigues parameters e0[c0:c0+4]
    (vector part first, e4 the scalar): (e4 q_v + q4 e_v + e_v x q_v, e4 q4 - e_v.q_v)."""
    x, y, z, s = e0[c0], e0[c0 + 1], e0[c0 + 2], e0[c0 + 3]
    L[0, 0], L[0, 1], L[0, 2], L[0, 3] = s, -z, y, x
    L[1, 0], L[1, 1], L[1, 2], L[1, 3] = z, s, -x, y
    L[2, 0], L[2, 1], L[2, 2], L[2, 3] = -y, x, s, z
    L[3, 0], L[3, 1], L[3, 2], L[3, 3] = -x, -y, -z, s


@njit(nrt=False, inline="always")
def _m(blk: np.ndarray, b: int, r: int, fcols: np.ndarray) -> int:
    """The number (0..3) of the r-th free parameter of ball b."""
    return fcols[blk[b, 1 + r]] - blk[b, 0]


@njit(nrt=False, inline="always")
def chart(e0: np.ndarray, blk: np.ndarray, b: int, fcols: np.ndarray, L: np.ndarray,
          J: np.ndarray, Ji: np.ndarray) -> bool:
    """L(e0) (4, 4) of ball b (its parameters e0[blk[b, 0]:][:4]), J = g' (3, 3) (rows:
    its free parameters) and the inverse Ji; False when J is singular (never with a
    good choice of the dependent parameter: det J = e_dep / 8)."""
    left_product(e0, blk[b, 0], L)
    for r in range(3):
        for k in range(3):
            J[r, k] = 0.5 * L[_m(blk, b, r, fcols), k]
    d = (J[0, 0] * (J[1, 1] * J[2, 2] - J[1, 2] * J[2, 1])
         - J[0, 1] * (J[1, 0] * J[2, 2] - J[1, 2] * J[2, 0])
         + J[0, 2] * (J[1, 0] * J[2, 1] - J[1, 1] * J[2, 0]))
    if abs(d) < 1e-6:
        return False
    for r in range(3):
        for k in range(3):
            # the cofactor of J[k, r] over det
            a0, a1 = (k + 1) % 3, (k + 2) % 3
            b0, b1 = (r + 1) % 3, (r + 2) % 3
            Ji[r, k] = (J[a0, b0] * J[a1, b1] - J[a0, b1] * J[a1, b0]) / d
    return True


@njit(nrt=False)
def to_local(A: np.ndarray, nF: int, tau: float, blk: np.ndarray, fcols: np.ndarray,
             q0: np.ndarray, v0: np.ndarray, X: np.ndarray) -> None:
    """The step's augmented matrix A (2 nF + 3, scaled by tau; rows v then x then the
    clock, as :func:`~openimp.dynamics.stepping.book_predict` builds it in e) turned
    into the one of the balls' rotation vectors (module docstring), in place.
    q0 (nq,): the step start; v0 (nF,): the FGC rates there; X (at least 11 x 11)
    scratch."""
    L, J, Ji, G2 = X[0:4, 0:4], X[4:7, 0:3], X[4:7, 3:6], X[7:10, 0:3]
    td, tdd, old, tmp = X[0, 4:7], X[1, 4:7], X[2, 4:10], X[3, 4:7]
    n = 2 * nF + 3
    b = 0
    while b < blk.shape[0] and blk[b, 0] >= 0:
        ok = chart(q0, blk, b, fcols, L, J, Ji)
        b += 1
        if not ok:
            continue
        bb = b - 1
        # theta'* = g'^-1 v*, h2 = g''[theta'*, theta'*], theta''* = g'^-1 (f* - h2)
        for r in range(3):
            s = 0.0
            for k in range(3):
                s += Ji[r, k] * v0[blk[bb, 1 + k]]
            td[r] = s
        tt = td[0] * td[0] + td[1] * td[1] + td[2] * td[2]
        for r in range(3):
            s = 0.0
            for k in range(3):
                s += Ji[r, k] * (A[blk[bb, 1 + k], 2 * nF] / tau
                                 + 0.25 * L[_m(blk, bb, k, fcols), 3] * tt)
            tdd[r] = s
        # columns: P_v g' into the v columns, P_x g' + P_v G2' into the x columns
        for r in range(3):
            for k in range(3):
                G2[r, k] = -0.25 * L[_m(blk, bb, r, fcols), 3] * td[k]
        for i in range(nF):
            for r in range(3):
                old[r] = A[i, blk[bb, 1 + r]]
                old[3 + r] = A[i, nF + blk[bb, 1 + r]]
            for k in range(3):
                sv = 0.0
                sx = 0.0
                for r in range(3):
                    sv += old[r] * J[r, k]
                    sx += old[3 + r] * J[r, k] + old[r] * G2[r, k]
                A[i, blk[bb, 1 + k]] = sv
                A[i, nF + blk[bb, 1 + k]] = sx
        # the ball's rows: -2 G2', -(G2'' + G3), -h2, then g'^-1 on the left
        for r in range(3):
            jr = blk[bb, 1 + r]
            mr = _m(blk, bb, r, fcols)
            lv = L[mr, 0] * td[0] + L[mr, 1] * td[1] + L[mr, 2] * td[2]
            for k in range(3):
                jk = blk[bb, 1 + k]
                g3 = -(tt * L[mr, k] + 2.0 * lv * td[k]) / 24.0
                g2b = -0.25 * L[mr, 3] * tdd[k]
                A[jr, jk] -= 2.0 * G2[r, k] * tau
                A[jr, nF + jk] -= (g2b + g3) * tau
            A[jr, 2 * nF] += 0.25 * L[mr, 3] * tt * tau
        for col in range(n):
            for r in range(3):
                tmp[r] = A[blk[bb, 1 + r], col]
            for r in range(3):
                s = 0.0
                for k in range(3):
                    s += Ji[r, k] * tmp[k]
                A[blk[bb, 1 + r], col] = s
        # the positions' clock: theta' = theta'* + dtheta'
        for r in range(3):
            A[nF + blk[bb, 1 + r], 2 * nF] = td[r] * tau


@njit(nrt=False, inline="always")
def rotation_functions(p: float, out: np.ndarray) -> None:
    """out = (S, S_p, S_pp): S(p) = sin(phi/2)/phi of p = phi^2 and its first two
    derivatives in p (series below |phi| = SERIES, else closed form)."""
    phi = math.sqrt(p)
    if phi < SERIES:
        s = 0.0
        s1 = 0.0
        s2 = 0.0
        pk = 1.0
        for k in range(S_COEF.shape[0]):
            s += S_COEF[k] * pk
            if k + 1 < S_COEF.shape[0]:
                s1 += (k + 1) * S_COEF[k + 1] * pk
            if k + 2 < S_COEF.shape[0]:
                s2 += (k + 2) * (k + 1) * S_COEF[k + 2] * pk
            pk *= p
        out[0], out[1], out[2] = s, s1, s2
        return
    sn = math.sin(0.5 * phi)
    cs = math.cos(0.5 * phi)
    out[0] = sn / phi
    out[1] = (0.5 * phi * cs - sn) / (2.0 * phi ** 3)
    out[2] = (6.0 * sn - 3.0 * phi * cs - 0.5 * phi * phi * sn) / (8.0 * phi ** 5)


@njit(nrt=False)
def from_local(nF: int, blk: np.ndarray, fcols: np.ndarray, q0: np.ndarray, v0: np.ndarray,
               x: np.ndarray, dv: np.ndarray, acc: np.ndarray, out: tuple, with_acc: bool,
               X: np.ndarray) -> None:
    """The balls' free parameters, rates and (``with_acc``) accelerations at the rotation
    vectors x, their rates' changes dv and their accelerations acc (nF, theta space)
    into out = (xs, vs, ap) (nF): e = e0 (x) q(theta) and its time derivatives,
    exactly.  The other FGCs are left as they are.  X (at least 11 x 11) scratch."""
    xs, vs, ap = out
    L, J, Ji, q = X[0:4, 0:4], X[4:7, 0:3], X[4:7, 3:6], X[4:7, 6:10]
    th, td, f = X[7, 3:6], X[8, 3:6], X[9, 3:6]
    b = 0
    while b < blk.shape[0] and blk[b, 0] >= 0:
        ok = chart(q0, blk, b, fcols, L, J, Ji)
        b += 1
        if not ok:
            continue
        bb = b - 1
        for r in range(3):
            s = 0.0
            for k in range(3):
                s += Ji[r, k] * v0[blk[bb, 1 + k]]
            th[r] = x[blk[bb, 1 + r]]
            td[r] = s + dv[blk[bb, 1 + r]]
        p = th[0] * th[0] + th[1] * th[1] + th[2] * th[2]
        pd = 2.0 * (th[0] * td[0] + th[1] * td[1] + th[2] * td[2])
        pdd = 2.0 * (td[0] * td[0] + td[1] * td[1] + td[2] * td[2])
        if with_acc:
            for r in range(3):
                pdd += 2.0 * th[r] * acc[blk[bb, 1 + r]]
        rotation_functions(p, f)
        S, Sp, Spp = f[0], f[1], f[2]
        for k in range(3):
            a = acc[blk[bb, 1 + k]] if with_acc else 0.0
            q[0, k] = S * th[k]
            q[1, k] = Sp * pd * th[k] + S * td[k]
            q[2, k] = (Spp * pd * pd + Sp * pdd) * th[k] + 2.0 * Sp * pd * td[k] + S * a
        q[0, 3] = math.cos(0.5 * math.sqrt(p))
        q[1, 3] = -0.25 * S * pd
        q[2, 3] = -0.25 * (Sp * pd * pd + S * pdd)
        for r in range(3):
            mr = _m(blk, bb, r, fcols)
            e = 0.0
            ed = 0.0
            edd = 0.0
            for k in range(4):
                e += L[mr, k] * q[0, k]
                ed += L[mr, k] * q[1, k]
                edd += L[mr, k] * q[2, k]
            xs[blk[bb, 1 + r]] = e
            vs[blk[bb, 1 + r]] = ed
            if with_acc:
                ap[blk[bb, 1 + r]] = edd


@njit(nrt=False)
def ball_marks(blk: np.ndarray, mark: np.ndarray) -> None:
    """mark[j] = True for the FGCs j (0 .. nF-1) that are free parameters of a ball of
    blk."""
    b = 0
    while b < blk.shape[0] and blk[b, 0] >= 0:
        for r in range(3):
            mark[blk[b, 1 + r]] = True
        b += 1


@njit(nrt=False)
def ball_moments(nF: int, blk: np.ndarray, fcols: np.ndarray, q0: np.ndarray, x: np.ndarray,
                 V: np.ndarray, X: np.ndarray) -> None:
    """Generalized forces of the FGCs (rows V[0] and V[1], nF) turned, for the balls, into
    those of their rotation vectors x (nF, theta space) at the step's end:
    f_theta = (de_F/dtheta)^T f_e, de/dtheta = L(e0) dq/dtheta with
    dq_v/dtheta = S I + 2 S_p theta theta^T, dq_4/dtheta = -S theta^T / 2 (the
    moments about the rotation vector, the physical ones at theta = 0).  X (at least
    11 x 11) scratch."""
    L, J, Ji, Jt = X[0:4, 0:4], X[4:7, 0:3], X[4:7, 3:6], X[7:10, 0:3]
    th, f, tmp = X[7, 3:6], X[8, 3:6], X[9, 3:6]
    dq = X[4:8, 6:9]
    b = 0
    while b < blk.shape[0] and blk[b, 0] >= 0:
        ok = chart(q0, blk, b, fcols, L, J, Ji)
        b += 1
        if not ok:
            continue
        bb = b - 1
        for r in range(3):
            th[r] = x[blk[bb, 1 + r]]
        rotation_functions(th[0] * th[0] + th[1] * th[1] + th[2] * th[2], f)
        for c in range(3):
            for k in range(3):
                dq[c, k] = 2.0 * f[1] * th[c] * th[k] + (f[0] if c == k else 0.0)
        for k in range(3):
            dq[3, k] = -0.5 * f[0] * th[k]
        for r in range(3):
            mr = _m(blk, bb, r, fcols)
            for k in range(3):
                s = 0.0
                for c in range(4):
                    s += L[mr, c] * dq[c, k]
                Jt[r, k] = s
        for row in range(2):
            for r in range(3):
                tmp[r] = V[row, blk[bb, 1 + r]]
            for k in range(3):
                s = 0.0
                for r in range(3):
                    s += Jt[r, k] * tmp[r]
                V[row, blk[bb, 1 + k]] = s
