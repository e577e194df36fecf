"""The book's step of a ball joint in local angles (book 14.11, 3.48-3.50).

A SPHERE joint's variables are Euler-Rodrigues parameters e = (e1, e2, e3, e4), three
of them free and one dependent through |e| = 1 (6.43).  They are a poor chart for the
book's linearized step: a steady rotation at rate w moves them as sin(w t / 2) and
cos(w t / 2), so the linear model frozen at the step start leaves a local error
of order (w h)^3 that no linear model in e removes.

Here the step is taken in three angles theta of the second body relative to its place
at the step start, about three orthonormal axes m0, m1, m2 of its joint frame there
(a gimbal that is at theta = 0, far from its lock, at every step start):

    e(theta) = e0 (x) E(theta),   E = Q(theta_0 m0) (x) Q(theta_1 m1) (x) Q(theta_2 m2),
    Q(phi m) = (sin(phi/2) m, cos(phi/2)),

(x) the product of Euler-Rodrigues parameters (the composition of rotations, 3.50).
The axes (:func:`ball_axes`) make a symmetric rotor's spin one angle that its
equations do not contain, as it is on three revolutes whose last is the rotor's
axis: the symmetry axis of the second body's inertia as the last factor (of the
first body's, when the second has no mass, as the first factor: a turn of that body
about its own axis is a factor on the left of e0); for a body without such an axis
its principal axis nearest the joint's angular velocity; else that velocity.  In one
rotation vector (the chart before) a top spinning at 50 rad/s on a ball was 98 times
less accurate than on three revolutes: its large angle of spin entered the products
of the small ones.

The step's linear model in e (v' = P_v v + P_x x + f, :func:`~openimp.dynamics.
stepping.book_predict`) becomes the one in theta by the chain rule with the
derivatives of e(theta) at theta = 0, exact, products of those of the factors
(Q^(k)(0) = 1, m/2, -1/4, -m/8 for k = 0 .. 3, :func:`dpart`):

    e_F = g(theta):  g' = L(e0) dE,  g''[a, b] = L(e0) d2E[a, b],  g'''[a, b, c] likewise,

L(e0) the matrix of the left product by e0, rows of the free parameters.  With
theta'* = g'^-1 v_F* and theta''* = g'^-1 (f* - g''[theta'*, theta'*]):

    theta'' = g'^-1 (P_v g' - 2 G2') dtheta' + g'^-1 (P_v G2' + P_x g' - G2'' - G3) theta
              + g'^-1 (f - g''[theta'*, theta'*])

(G2' = g''[theta'*, .], G2'' = g''[theta''*, .], G3 = g'''[theta'*, theta'*, .]),
solved by the same exponential; the end is mapped back exactly through e(theta)
and its time derivatives.  Only a ball whose three free parameters are all FGCs of
the step (the fourth dependent) is treated so; any other coordinate keeps its row.

Every function here takes the balls as blk (:func:`ball_blocks`), their axes ax
(nq, 3, 3: per ball the rows m0, m1, m2) and a scratch X (12, 12) whose X[0:4, 0:4]
holds L(e0) and X[4:7, 0:6] g' and its inverse.
"""

from __future__ import annotations

import math

import numpy as np

from openimp._jit import njit
from openimp.joints.codes import OPEN, SPHERE
from openimp.linalg import sym_eigen
from openimp.system import dyn_views, model_views

#: eigenvalues of a body's second moments closer than this (relative to the largest)
#: are equal: the body is symmetric about the third principal axis
SYMMETRIC = 1e-9


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
def qmul(a0: float, a1: float, a2: float, a3: float,
         b0: float, b1: float, b2: float, b3: float) -> tuple[float, float, float, float]:
    """The product a (x) b of Euler-Rodrigues parameters (vector part first):
    (a4 b_v + b4 a_v + a_v x b_v, a4 b4 - a_v . b_v), Theta(a b) = Theta(a) Theta(b)."""
    return (a3 * b0 + b3 * a0 + a1 * b2 - a2 * b1,
            a3 * b1 + b3 * a1 + a2 * b0 - a0 * b2,
            a3 * b2 + b3 * a2 + a0 * b1 - a1 * b0,
            a3 * b3 - a0 * b0 - a1 * b1 - a2 * b2)


@njit(nrt=False, inline="always")
def _q0(m: np.ndarray, k: int) -> tuple[float, float, float, float]:
    """The k-th derivative (k = 0 .. 3) of Q(phi m) in phi at phi = 0."""
    if k == 0:
        return (0.0, 0.0, 0.0, 1.0)
    if k == 1:
        return (0.5 * m[0], 0.5 * m[1], 0.5 * m[2], 0.0)
    if k == 2:
        return (0.0, 0.0, 0.0, -0.25)
    return (-0.125 * m[0], -0.125 * m[1], -0.125 * m[2], 0.0)


@njit(nrt=False, inline="always")
def dpart(axb: np.ndarray, k0: int, k1: int, k2: int) -> tuple[float, float, float, float]:
    """The partial derivative of E(theta) k0 times in theta_0, k1 in theta_1, k2 in
    theta_2 at theta = 0: the product of the factors' derivatives, in their order.
    axb (3, 3): the ball's axes (rows)."""
    a = _q0(axb[0], k0)
    b = _q0(axb[1], k1)
    c = _q0(axb[2], k2)
    p = qmul(a[0], a[1], a[2], a[3], b[0], b[1], b[2], b[3])
    return qmul(p[0], p[1], p[2], p[3], c[0], c[1], c[2], c[3])


@njit(nrt=False)
def t2(axb: np.ndarray, a: np.ndarray, b: np.ndarray, out: np.ndarray) -> None:
    """out (4) = d2E[a, b] = sum_ij a_i b_j d2E/dtheta_i dtheta_j at theta = 0."""
    for c in range(4):
        out[c] = 0.0
    for i in range(3):
        for j in range(3):
            w = a[i] * b[j]
            if w == 0.0:
                continue
            d = dpart(axb, (i == 0) + (j == 0), (i == 1) + (j == 1), (i == 2) + (j == 2))
            for c in range(4):
                out[c] += w * d[c]


@njit(nrt=False)
def t3(axb: np.ndarray, a: np.ndarray, b: np.ndarray, g: np.ndarray,
       out: np.ndarray) -> None:
    """out (4) = d3E[a, b, g], the third derivatives at theta = 0 likewise."""
    for c in range(4):
        out[c] = 0.0
    for i in range(3):
        for j in range(3):
            for k in range(3):
                w = a[i] * b[j] * g[k]
                if w == 0.0:
                    continue
                d = dpart(axb, (i == 0) + (j == 0) + (k == 0), (i == 1) + (j == 1) + (k == 1),
                          (i == 2) + (j == 2) + (k == 2))
                for c in range(4):
                    out[c] += w * d[c]


@njit(nrt=False, inline="always")
def _rows(L: np.ndarray, blk: np.ndarray, b: int, fcols: np.ndarray, qv: np.ndarray,
          out: np.ndarray) -> None:
    """out (3) = the free parameters' rows of L(e0) qv."""
    for r in range(3):
        mr = _m(blk, b, r, fcols)
        out[r] = L[mr, 0] * qv[0] + L[mr, 1] * qv[1] + L[mr, 2] * qv[2] + L[mr, 3] * qv[3]


@njit(nrt=False, inline="always")
def chart(e0: np.ndarray, blk: np.ndarray, b: int, ax: np.ndarray, fcols: np.ndarray,
          L: np.ndarray, J: np.ndarray, Ji: np.ndarray) -> bool:
    """L(e0) (4, 4) of ball b (its parameters e0[blk[b, 0]:][:4]), J = g' (3, 3) (rows:
    its free parameters; column k = L(e0) (m_k / 2, 0)) and the inverse Ji; False when
    J is singular (never with a good choice of the dependent parameter: det J =
    e_dep / 8 for orthonormal axes)."""
    left_product(e0, blk[b, 0], L)
    for r in range(3):
        mr = _m(blk, b, r, fcols)
        for k in range(3):
            J[r, k] = 0.5 * (L[mr, 0] * ax[b, k, 0] + L[mr, 1] * ax[b, k, 1]
                             + L[mr, 2] * ax[b, k, 2])
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
def ball_axes(KP: tuple, YP: tuple, q0: np.ndarray, v0: np.ndarray, blk: np.ndarray,
              ax: np.ndarray, fcols: np.ndarray, X: np.ndarray) -> None:
    """The axes ax[b] (rows m0, m1, m2, orthonormal, right-handed, in the primed joint
    frame at the step start) of every ball b of blk, at the posture q0 (nq,) with the
    FGC rates v0 (nF,) (module docstring): the spin axis is the last (of the second
    body) or the first (of the first body) row."""
    K = model_views(KP)
    y = dyn_views(YP)
    Sig, Wk, V, lam = X[0:3, 0:3], X[3:6, 0:3], X[6:9, 0:3], X[9, 0:3]
    ed, w, a, u = X[10, 0:4], X[10, 4:7], X[11, 0:3], X[11, 3:6]
    b = 0
    while b < blk.shape[0] and blk[b, 0] >= 0:
        c0 = blk[b, 0]
        h = K.vjoint[c0]
        # the relative angular velocity in the primed frame, w = 2 vec(e* (x) e')
        dep = 0
        for m in range(4):
            ed[m] = 0.0
        for r in range(3):
            ed[_m(blk, b, r, fcols)] = v0[blk[b, 1 + r]]
        s = 0.0
        for m in range(4):
            if (m != _m(blk, b, 0, fcols) and m != _m(blk, b, 1, fcols)
                    and m != _m(blk, b, 2, fcols)):
                dep = m
        for m in range(4):
            if m != dep:
                s += q0[c0 + m] * ed[m]
        ed[dep] = -s / q0[c0 + dep]
        p = qmul(-q0[c0], -q0[c0 + 1], -q0[c0 + 2], q0[c0 + 3], ed[0], ed[1], ed[2], ed[3])
        w[0], w[1], w[2] = 2.0 * p[0], 2.0 * p[1], 2.0 * p[2]
        wn = math.sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2])
        # the body whose inertia names the spin axis: the second, else the first
        side = 2
        body = K.jb2[h]
        if y.Jb[body, 3, 3] <= 0.0:
            side = 1
            body = K.jb1[h]
            if y.Jb[body, 3, 3] <= 0.0:
                side = 0
        pick = -1  # the column of V, -2: the angular velocity, -3: the frame's z
        if side > 0:
            # second moments about the joint's origin in its frame: S^-1 J S^-T (9.6)
            Si = K.S2inv[h] if side == 2 else K.S1inv[h]
            for i in range(3):
                for j in range(3):
                    t = 0.0
                    for k in range(4):
                        for m in range(4):
                            t += Si[i, k] * y.Jb[body, k, m] * Si[j, m]
                    Sig[i, j] = t
            sym_eigen(Sig, 3, Wk, V, lam)
            big = max(abs(lam[0]), abs(lam[2]))
            lo = lam[1] - lam[0] <= SYMMETRIC * big
            hi = lam[2] - lam[1] <= SYMMETRIC * big
            if lo and not hi:
                pick = 2
            elif hi and not lo:
                pick = 0
            elif not lo and wn > 0.0:  # no symmetry: the principal axis nearest w
                best = -1.0
                for k in range(3):
                    for i in range(3):
                        u[i] = V[i, k]
                    if side == 1:  # into the primed frame: Theta(e0)^T u
                        _turn_back(q0, c0, u)
                    d = abs(u[0] * w[0] + u[1] * w[1] + u[2] * w[2])
                    if d > best:
                        best = d
                        pick = k
            else:
                pick = -2
        else:
            pick = -2
        if pick == -2 and wn == 0.0:
            pick = -3
        if pick >= 0:
            for i in range(3):
                a[i] = V[i, pick]
            if side == 1:
                _turn_back(q0, c0, a)
        elif pick == -2:
            for i in range(3):
                a[i] = w[i] / wn
        else:
            a[0], a[1], a[2] = 0.0, 0.0, 1.0
        # two more axes: o1 _|_ a, o2 = a x o1
        u[0], u[1], u[2] = (0.0, 1.0, 0.0) if abs(a[0]) > 0.9 else (1.0, 0.0, 0.0)
        d = u[0] * a[0] + u[1] * a[1] + u[2] * a[2]
        for i in range(3):
            u[i] -= d * a[i]
        n = math.sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2])
        for i in range(3):
            u[i] /= n
        o2 = (a[1] * u[2] - a[2] * u[1], a[2] * u[0] - a[0] * u[2], a[0] * u[1] - a[1] * u[0])
        first = 0 if side == 1 else 2
        for i in range(3):
            ax[b, first, i] = a[i]
            ax[b, (first + 1) % 3, i] = u[i]
            ax[b, (first + 2) % 3, i] = o2[i]
        b += 1


@njit(nrt=False, inline="always")
def _turn_back(q0: np.ndarray, c0: int, u: np.ndarray) -> None:
    """u <- Theta(e)^T u = vec(e* (x) (u, 0) (x) e), e = q0[c0:c0+4]: a vector of the
    unprimed joint frame in the primed one."""
    e0, e1, e2, e3 = q0[c0], q0[c0 + 1], q0[c0 + 2], q0[c0 + 3]
    p = qmul(-e0, -e1, -e2, e3, u[0], u[1], u[2], 0.0)
    r = qmul(p[0], p[1], p[2], p[3], e0, e1, e2, e3)
    u[0], u[1], u[2] = r[0], r[1], r[2]


@njit(nrt=False)
def to_local(A: np.ndarray, nF: int, tau: float, blk: np.ndarray, ax: np.ndarray,
             fcols: np.ndarray, q0: np.ndarray, v0: np.ndarray, X: np.ndarray) -> None:
    """The step's augmented matrix A (2 nF + 3, scaled by tau; rows v then x then the
    clock, as :func:`~openimp.dynamics.stepping.book_predict` builds it in e) turned
    into the one of the balls' angles (module docstring), in place.
    q0 (nq,): the step start; v0 (nF,): the FGC rates there."""
    L, J, Ji = X[0:4, 0:4], X[4:7, 0:3], X[4:7, 3:6]
    G2, G2b, G3 = X[7:10, 0:3], X[7:10, 3:6], X[7:10, 6:9]
    td, tdd, old = X[10, 0:3], X[10, 3:6], X[10, 6:12]
    qv, tmp, h2, ek = X[11, 0:4], X[11, 4:7], X[11, 8:11], X[0:3, 9:12]
    n = 2 * nF + 3
    for r in range(3):
        for k in range(3):
            ek[r, k] = 1.0 if r == k else 0.0
    b = 0
    while b < blk.shape[0] and blk[b, 0] >= 0:
        ok = chart(q0, blk, b, ax, fcols, L, J, Ji)
        b += 1
        if not ok:
            continue
        bb = b - 1
        axb = ax[bb]
        # theta'* = g'^-1 v*, h2 = g''[theta'*, theta'*], theta''* = g'^-1 (f* - h2)
        for r in range(3):
            s = 0.0
            for k in range(3):
                s += Ji[r, k] * v0[blk[bb, 1 + k]]
            td[r] = s
        t2(axb, td, td, qv)
        _rows(L, blk, bb, fcols, qv, h2)
        for r in range(3):
            s = 0.0
            for k in range(3):
                s += Ji[r, k] * (A[blk[bb, 1 + k], 2 * nF] / tau - h2[k])
            tdd[r] = s
        # G2' = g''[theta'*, .], G2'' = g''[theta''*, .], G3 = g'''[theta'*, theta'*, .]
        for k in range(3):
            t2(axb, td, ek[k], qv)
            _rows(L, blk, bb, fcols, qv, tmp)
            for r in range(3):
                G2[r, k] = tmp[r]
            t2(axb, tdd, ek[k], qv)
            _rows(L, blk, bb, fcols, qv, tmp)
            for r in range(3):
                G2b[r, k] = tmp[r]
            t3(axb, td, td, ek[k], qv)
            _rows(L, blk, bb, fcols, qv, tmp)
            for r in range(3):
                G3[r, k] = tmp[r]
        # columns: P_v g' into the v columns, P_x g' + P_v G2' into the x columns
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
            for k in range(3):
                jk = blk[bb, 1 + k]
                A[jr, jk] -= 2.0 * G2[r, k] * tau
                A[jr, nF + jk] -= (G2b[r, k] + G3[r, k]) * tau
            A[jr, 2 * nF] -= h2[r] * tau
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
def _factors(axb: np.ndarray, th: np.ndarray, td: np.ndarray, tdd: np.ndarray,
             F: np.ndarray) -> None:
    """F[3 k + d] (4) = the d-th time derivative (d = 0, 1, 2) of the factor
    Q(theta_k m_k) along theta with rates td and accelerations tdd (3,)."""
    for k in range(3):
        s = math.sin(0.5 * th[k])
        c = math.cos(0.5 * th[k])
        r1 = 0.5 * td[k]
        r2 = 0.5 * tdd[k]
        r3 = 0.25 * td[k] * td[k]
        for i in range(3):
            m = axb[k, i]
            F[3 * k, i] = s * m
            F[3 * k + 1, i] = r1 * c * m
            F[3 * k + 2, i] = r2 * c * m - r3 * s * m
        F[3 * k, 3] = c
        F[3 * k + 1, 3] = -r1 * s
        F[3 * k + 2, 3] = -r2 * s - r3 * c


@njit(nrt=False, inline="always")
def _p3(F: np.ndarray, i: int, j: int, k: int) -> tuple[float, float, float, float]:
    """The product of the factors' derivatives F[i] (x) F[3 + j] (x) F[6 + k]."""
    a, b, c = F[i], F[3 + j], F[6 + k]
    p = qmul(a[0], a[1], a[2], a[3], b[0], b[1], b[2], b[3])
    return qmul(p[0], p[1], p[2], p[3], c[0], c[1], c[2], c[3])


@njit(nrt=False)
def from_local(blk: np.ndarray, ax: np.ndarray, fcols: np.ndarray, q0: np.ndarray,
               v0: np.ndarray, x: np.ndarray, dv: np.ndarray, acc: np.ndarray, out: tuple,
               with_acc: bool, X: np.ndarray) -> None:
    """The balls' free parameters, rates and (``with_acc``) accelerations at the angles
    x, their rates' changes dv and their accelerations acc (nF, theta space) into
    out = (xs, vs, ap) (nF): e = e0 (x) E(theta) and its time derivatives, exactly.
    The other FGCs are left as they are."""
    xs, vs, ap = out
    L, J, Ji, F = X[0:4, 0:4], X[4:7, 0:3], X[4:7, 3:6], X[0:9, 6:10]
    th, td, a = X[9, 0:3], X[9, 3:6], X[9, 6:9]
    E0, E1, E2 = X[10, 0:4], X[10, 4:8], X[11, 0:4]
    ev = X[11, 4:7]
    b = 0
    while b < blk.shape[0] and blk[b, 0] >= 0:
        ok = chart(q0, blk, b, ax, fcols, L, J, Ji)
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
            a[r] = acc[blk[bb, 1 + r]] if with_acc else 0.0
        _factors(ax[bb], th, td, a, F)
        p0 = _p3(F, 0, 0, 0)
        pa, pb, pc = _p3(F, 1, 0, 0), _p3(F, 0, 1, 0), _p3(F, 0, 0, 1)
        for c in range(4):
            E0[c] = p0[c]
            E1[c] = pa[c] + pb[c] + pc[c]
        if with_acc:
            qa, qb, qc = _p3(F, 2, 0, 0), _p3(F, 0, 2, 0), _p3(F, 0, 0, 2)
            ra, rb, rc = _p3(F, 1, 1, 0), _p3(F, 1, 0, 1), _p3(F, 0, 1, 1)
            for c in range(4):
                E2[c] = qa[c] + qb[c] + qc[c] + 2.0 * (ra[c] + rb[c] + rc[c])
        _rows(L, blk, bb, fcols, E0, ev)
        for r in range(3):
            xs[blk[bb, 1 + r]] = ev[r]
        _rows(L, blk, bb, fcols, E1, ev)
        for r in range(3):
            vs[blk[bb, 1 + r]] = ev[r]
        if with_acc:
            _rows(L, blk, bb, fcols, E2, ev)
            for r in range(3):
                ap[blk[bb, 1 + r]] = ev[r]


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
def ball_moments(blk: np.ndarray, ax: np.ndarray, fcols: np.ndarray, q0: np.ndarray,
                 x: np.ndarray, V: np.ndarray, X: np.ndarray) -> None:
    """Generalized forces of the FGCs (rows V[0] and V[1], nF) turned, for the balls, into
    those of their angles x (nF, theta space) at the step's end:
    f_theta = (de_F/dtheta)^T f_e, de/dtheta = L(e0) dE/dtheta, column k the product
    with the k-th factor differentiated (the moments about the axes at theta = 0)."""
    L, J, Ji, F = X[0:4, 0:4], X[4:7, 0:3], X[4:7, 3:6], X[0:9, 6:10]
    Jt, th, one, zero = X[7:10, 0:3], X[9, 0:3], X[9, 3:6], X[9, 6:9]
    ev, tmp = X[11, 4:7], X[11, 8:11]
    b = 0
    while b < blk.shape[0] and blk[b, 0] >= 0:
        ok = chart(q0, blk, b, ax, fcols, L, J, Ji)
        b += 1
        if not ok:
            continue
        bb = b - 1
        for r in range(3):
            th[r] = x[blk[bb, 1 + r]]
            one[r] = 1.0
            zero[r] = 0.0
        _factors(ax[bb], th, one, zero, F)  # F[3 k + 1] = dQ_k / dtheta_k
        for k in range(3):
            d = _p3(F, 1 if k == 0 else 0, 1 if k == 1 else 0, 1 if k == 2 else 0)
            X[10, 0], X[10, 1], X[10, 2], X[10, 3] = d[0], d[1], d[2], d[3]
            _rows(L, blk, bb, fcols, X[10, 0:4], ev)
            for r in range(3):
                Jt[r, k] = ev[r]
        for row in range(2):
            for r in range(3):
                tmp[r] = V[row, blk[bb, 1 + r]]
            for k in range(3):
                s = 0.0
                for r in range(3):
                    s += Jt[r, k] * tmp[r]
                V[row, blk[bb, 1 + k]] = s
