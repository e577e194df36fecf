"""Inertia stages (book 9.2-9.3, 10.3-10.4): global pseudo-inertias, inertia wrenches,
the mass matrix and the kinetic energy, over (System, Data, DynData).

Everything the book writes as a trace over 4x4 operators,
``trace(W_{b,i} T J T^T Lambda^T)`` (10.7, 10.8), is evaluated as the power of
the screw ``W_{b,i}`` on a wrench: with G = T_0b J_b T_0b^T and an operator
Lambda = [[L3, l], [0, 0]] the wrench of :func:`pseudo_wrench` is the
coefficient vector of that trace.  With Lambda = alpha_b + omega_b omega_b
(the acceleration operator of the body's points, 8.52) it is the inertia
force of the body (f = m a_c, n = moment about the global origin); with
Lambda = W_{b,j} it is the momentum the column j of the mass matrix pairs
with.  Screws are (v, w) and wrenches (f, n about the global origin); the
power of a screw on a wrench is v.f + w.n.
"""

from __future__ import annotations

import numpy as np

from openimp._jit import njit
from openimp.system import data_views, dyn_data_views, dyn_views, model_views


@njit(nrt=False)
def pseudo_wrench(G: np.ndarray, L: np.ndarray, out: np.ndarray) -> None:
    """The wrench w with screw . w = trace(S G L^T) for every screw S (the trace form 10.7).

    G: (4, 4) pseudo-inertia in global axes; L: (3, 4) top rows of an operator;
    out: (6,) (f, n about the origin).  X = G L^T; f_j = X[3, j];
    n = (X[1,2] - X[2,1], X[2,0] - X[0,2], X[0,1] - X[1,0]).
    """
    x01 = 0.0
    x02 = 0.0
    x10 = 0.0
    x12 = 0.0
    x20 = 0.0
    x21 = 0.0
    for k in range(4):
        x01 += G[0, k] * L[1, k]
        x02 += G[0, k] * L[2, k]
        x10 += G[1, k] * L[0, k]
        x12 += G[1, k] * L[2, k]
        x20 += G[2, k] * L[0, k]
        x21 += G[2, k] * L[1, k]
    for j in range(3):
        f = 0.0
        for k in range(4):
            f += G[3, k] * L[j, k]
        out[j] = f
    out[3] = x12 - x21
    out[4] = x20 - x02
    out[5] = x01 - x10


@njit(nrt=False)
def massless(J: np.ndarray) -> bool:
    """A pseudo-inertia (4 x 4, any axes) of no mass and no inertia: its diagonal, which
    is never negative, is all zero."""
    return J[3, 3] == 0.0 and J[0, 0] == 0.0 and J[1, 1] == 0.0 and J[2, 2] == 0.0


@njit(nrt=False)
def screw_rows(s: np.ndarray, L: np.ndarray) -> None:
    """The top rows (3, 4) of the operator [[skew(w), v], [0, 0]] of screw s = (v, w)."""
    L[0, 0] = 0.0
    L[0, 1] = -s[5]
    L[0, 2] = s[4]
    L[1, 0] = s[5]
    L[1, 1] = 0.0
    L[1, 2] = -s[3]
    L[2, 0] = -s[4]
    L[2, 1] = s[3]
    L[2, 2] = 0.0
    L[0, 3] = s[0]
    L[1, 3] = s[1]
    L[2, 3] = s[2]


@njit(nrt=False)
def acceleration_rows(V: np.ndarray, A: np.ndarray, L: np.ndarray) -> None:
    """Top rows of alpha + omega omega (8.52 with 8.49): the operator that gives the
    acceleration of every point of the body, R'' = (alpha + omega omega) R.

    V, A: (6,) screws of omega_b and alpha_b; L: (3, 4).
    """
    wx, wy, wz = V[3], V[4], V[5]
    # skew(w) skew(w) = w w^T - |w|^2 E
    ww = wx * wx + wy * wy + wz * wz
    L[0, 0] = wx * wx - ww
    L[0, 1] = wx * wy - A[5]
    L[0, 2] = wx * wz + A[4]
    L[1, 0] = wy * wx + A[5]
    L[1, 1] = wy * wy - ww
    L[1, 2] = wy * wz - A[3]
    L[2, 0] = wz * wx - A[4]
    L[2, 1] = wz * wy + A[3]
    L[2, 2] = wz * wz - ww
    # a + w x v
    L[0, 3] = A[0] + wy * V[2] - wz * V[1]
    L[1, 3] = A[1] + wz * V[0] - wx * V[2]
    L[2, 3] = A[2] + wx * V[1] - wy * V[0]


@njit(nrt=False)
def body_inertias(KP: tuple, DP: tuple, YP: tuple, ZP: tuple) -> None:
    """G_b = T_0b J_b T_0b^T for every body (the pseudo-inertia in global axes, 9.7).

    With T = [[R, p], [0, 1]] and J = [[Sigma, h], [h^T, m]] (second moments,
    first moments h = m c, mass): G = [[R Sigma R^T + Rh p^T + p (Rh)^T +
    m p p^T, Rh + m p], [., m]], symmetric.  Needs the postures d.T0
    (:func:`~openimp.kinematics.position.position`); writes z.Gb (nb x 4 x 4).
    Massless bodies are skipped (their G stays 0).
    """
    d = data_views(DP)
    y = dyn_views(YP)
    z = dyn_data_views(ZP)
    K = model_views(KP)
    RS = z.L3  # R Sigma (its first three columns)
    for b in range(K.order.shape[0]):
        J = y.Jb[b]
        if massless(J):
            continue
        m = J[3, 3]
        T = d.T0[b]
        G = z.Gb[b]
        for i in range(3):
            for j in range(3):
                RS[i, j] = T[i, 0] * J[0, j] + T[i, 1] * J[1, j] + T[i, 2] * J[2, j]
        for i in range(3):
            rh = T[i, 0] * J[0, 3] + T[i, 1] * J[1, 3] + T[i, 2] * J[2, 3]
            G[i, 3] = rh + m * T[i, 3]
            G[3, i] = G[i, 3]
        for i in range(3):
            pi = T[i, 3]
            for j in range(i, 3):
                pj = T[j, 3]
                v = RS[i, 0] * T[j, 0] + RS[i, 1] * T[j, 1] + RS[i, 2] * T[j, 2]
                # Rh p^T + p Rh^T + m p p^T = g p^T + p g^T - m p p^T with g = Rh + m p
                v += G[i, 3] * pj + pi * G[j, 3] - m * pi * pj
                G[i, j] = v
                G[j, i] = v
        G[3, 3] = m


@njit(nrt=False)
def inertia_wrenches(KP: tuple, DP: tuple, ZP: tuple) -> float:
    """Inertia wrench of every body, trace(W G (alpha + omega omega)^T) (10.8), into z.Fin,
    and the kinetic energy 1/2 sum_b trace(omega_b G_b omega_b^T) (9.7), returned.

    Needs z.Gb (:func:`body_inertias`), the velocity screws d.V and the
    acceleration screws d.Ab (:mod:`openimp.kinematics.rates`).
    """
    d = data_views(DP)
    z = dyn_data_views(ZP)
    K = model_views(KP)
    L = z.L3
    ke = 0.0
    for b in range(K.order.shape[0]):
        G = z.Gb[b]
        if massless(G):
            for i in range(6):
                z.Fin[b, i] = 0.0
            continue  # massless: no inertia
        V = d.V[b]
        acceleration_rows(V, d.Ab[b], L)
        pseudo_wrench(G, L, z.Fin[b])
        # 1/2 integral |w x r + v|^2 dm with G = [[Sigma, h], [h^T, m]]:
        # 1/2 m |v|^2 + v . (w x h) + 1/2 (|w|^2 tr Sigma - w^T Sigma w)
        vx, vy, vz, wx, wy, wz = V[0], V[1], V[2], V[3], V[4], V[5]
        hx, hy, hz = G[0, 3], G[1, 3], G[2, 3]
        wSw = (wx * (G[0, 0] * wx + G[0, 1] * wy + G[0, 2] * wz)
               + wy * (G[1, 0] * wx + G[1, 1] * wy + G[1, 2] * wz)
               + wz * (G[2, 0] * wx + G[2, 1] * wy + G[2, 2] * wz))
        ke += (0.5 * G[3, 3] * (vx * vx + vy * vy + vz * vz)
               + vx * (wy * hz - wz * hy) + vy * (wz * hx - wx * hz) + vz * (wx * hy - wy * hx)
               + 0.5 * ((wx * wx + wy * wy + wz * wz) * (G[0, 0] + G[1, 1] + G[2, 2]) - wSw))
    return ke


@njit(nrt=False)
def mass_matrix(KP: tuple, ZP: tuple, M: np.ndarray) -> None:
    """M_ij = sum_b trace(W_{b,i} G_b W_{b,j}^T) (10.15, 11.7) over the columns of z.W.

    Needs z.Gb and z.W (:func:`~openimp.kinematics.rates.body_operators`).
    M: (nf, nf).  Symmetric by construction: only the upper triangle is summed,
    the lower copied.
    """
    z = dyn_data_views(ZP)
    K = model_views(KP)
    L = z.L3
    h = z.h6
    nf = M.shape[0]
    for i in range(nf):
        for j in range(nf):
            M[i, j] = 0.0
    for b in range(K.order.shape[0]):
        if massless(z.Gb[b]):
            continue
        for j in range(nf):
            screw_rows(z.W[b, j], L)
            pseudo_wrench(z.Gb[b], L, h)
            for i in range(j + 1):
                s = 0.0
                for k in range(6):
                    s += z.W[b, i, k] * h[k]
                M[i, j] += s
    for j in range(nf):
        for i in range(j + 1, nf):
            M[i, j] = M[j, i]
