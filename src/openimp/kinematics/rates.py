"""Rate stages: body operators, velocities and accelerations (book ch 7, 8).

Operators with zero last row are kept as screws ``(v, w)``
(:mod:`openimp.mat4`): the velocity operator of a body
omega_b = [[skew(w), v], [0, 0]] is the twist of the body, v the velocity of
the body point at the global origin.

* :func:`body_operators`: W_{b,j} = sum_h P(b,h) D_h phi'_{h,j} (7.20), the
  operator that moves body b for a unit rate of coordinate j (dynamics builds
  its mass matrix on them);
* :func:`velocity`: omega_b = sum_h P(b,h) D_h qd_h (7.22);
* :func:`drift`: the joint drift screws K_h = sum_g ([omega_{h-}, D_h^g] +
  sum_i B_h^{g,i} qd_i) qd_g (8.24, 8.26, 8.39);
* :func:`velocity_product`: the joint accelerations with zero input
  acceleration: qdd = J11^-1 C from the drift terms (8.40, 8.44), with the
  consistency residual (8.45);
* :func:`accelerations`: alpha_b = sum_h P(b,h) (D_h qdd_h + K_h) (8.52).

The velocity-product acceleration is the acceleration stage with the input
accelerations switched off, not a second formula: a sweep adds
phi' psi'' to it.
"""

from __future__ import annotations

import numpy as np

from openimp._jit import njit
from openimp.joints.calc import joint_calc
from openimp.joints.codes import constant_Q
from openimp.kinematics.elimination import replay
from openimp.mat4 import er_norm2, screw_bracket, similar_screw
from openimp.system import data_views, model_views


@njit(nrt=False, inline="always")
def _tree_sum(KP: tuple, DP: tuple, rate: np.ndarray, drift: bool, out: np.ndarray) -> None:
    """out[b] = sum_h P(b,h) (sum_g D_h^g rate[a0 + g] [+ K_h]) for every body, along the tree.

    ``rate``: (nq,) joint rates; ``out``: (nb, 6) screws.  The path sum is
    built parent first: out_b = out_parent + psign_b (D_h rate_h [+ K_h]).
    """
    K = model_views(KP)
    d = data_views(DP)
    Dh = d.Dh
    for k in range(K.order.shape[0]):
        b = K.order[k]
        h = K.pj[b]
        if h < 0:
            for i in range(6):
                out[b, i] = 0.0
            continue
        pb = K.pb[b]
        sg = float(K.psign[b])
        a0 = K.jq0[h]
        for i in range(6):
            s = d.Kh[h, i] if drift else 0.0
            for g in range(K.jnv[h]):
                s += Dh[a0 + g, i] * rate[a0 + g]
            out[b, i] = out[pb, i] + sg * s


@njit(nrt=False)
def body_operators(KP: tuple, DP: tuple, G: np.ndarray, W: np.ndarray) -> None:
    """W_{b,j} = sum_h P(b,h) sum_g D_h^g phi'^g_{h,j} (7.20) for every body and column of G.

    G: (nq, ncols) geometric derivatives (:func:`~openimp.kinematics.elimination.
    derivatives`); W: (nb, ncols, 6) screws, so that dT_0b/dpsi_j = W_{b,j} T_0b
    (7.21).  Needs the screws of the posture (d.Dh).
    """
    for j in range(G.shape[1]):
        _tree_sum(KP, DP, G[:, j], False, W[:, j])


@njit(nrt=False)
def velocity(KP: tuple, DP: tuple, S: tuple) -> None:
    """omega_b of every body (7.22) from the joint rates S.qd, into d.V (nb x 6)."""
    _tree_sum(KP, DP, S.qd, False, data_views(DP).V)


@njit(nrt=False)
def drift(KP: tuple, DP: tuple, S: tuple, gen: np.ndarray | None) -> None:
    """Drift screw of every joint (8.26, 8.39) into d.Kh (nj x 6).

    K_h = sum_g ([omega_{h-}, D_h^g] + sum_i B_h^{g,i} qd_i) qd_g, with
    B_h^{g,i} = A_h Q_h^{g,i} A_h^-1 (8.24) of the kinds whose Q depends on q
    (evaluated here, into d.Bh).  Needs the screws (d.Dh) and the
    velocities (d.V, :func:`velocity`) at S.qd.
    """
    K = model_views(KP)
    d = data_views(DP)
    qd = S.qd
    if gen is not None:
        for k in range(gen.shape[0]):
            h = gen[k]
            if constant_Q(K.jcode[h]):
                continue
            a0 = K.jq0[h]
            nv = K.jnv[h]
            joint_calc(K.jcode[h], S.q[a0:a0 + nv], K.const[K.jc0[h]:], S.load_sign[h],
                       d.Phi[h], d.Qj[a0:a0 + nv], d.dQj, 2)
            for g in range(nv):
                for i in range(nv):
                    similar_screw(d.A[h], d.dQj[g, i], d.Bh[a0 + g], i, d.M4)
    for h in range(K.jcode.shape[0]):
        for i in range(6):
            d.Kh[h, i] = 0.0
        nv = K.jnv[h]
        a0 = K.jq0[h]
        wm = d.V[K.jb1[h]]
        second = not constant_Q(K.jcode[h])
        for g in range(nv):
            f = qd[a0 + g]
            if f == 0.0:
                continue
            screw_bracket(wm, d.Dh[a0 + g], f, d.Kh[h])
            if not second:
                continue
            for t in range(nv):
                ft = f * qd[a0 + t]
                if ft != 0.0:
                    for i in range(6):
                        d.Kh[h, i] += ft * d.Bh[a0 + g, t, i]


@njit(nrt=False)
def velocity_product(KP: tuple, DP: tuple, S: tuple, gen: np.ndarray | None,
                     rank: int) -> float:
    """Joint accelerations for zero input acceleration (8.40, 8.44) into S.qdd.

    From the drift terms of every joint (:func:`drift`, needs d.V at S.qd)
    the acceleration right-hand side C = -sum_h L(i,h) K_h (its screw
    coordinates) and -2 |e'|^2 for the Euler-Rodrigues rows goes through the
    last elimination (:func:`~openimp.kinematics.elimination.replay`):
    qdd_dep = J11^-1 C, every other variable 0.  Returns the consistency
    residual (8.45): what the dependent rows leave of C.
    """
    K = model_views(KP)
    d = data_views(DP)
    drift(KP, DP, S, gen)
    b = d.rhs
    nl = K.L.shape[0]
    for i in range(nl):
        r0 = 6 * i
        for k in range(6):
            b[r0 + k] = 0.0
        for h in range(K.jcode.shape[0]):
            lih = K.L[i, h]
            if lih == 0:
                continue
            for k in range(6):
                b[r0 + k] -= lih * d.Kh[h, k]
    r0 = 6 * nl
    for k in range(K.er.shape[0]):
        b[r0 + k] = -2.0 * er_norm2(S.qd, K.er[k])
    replay(DP, rank, b)
    m = b.shape[0]
    used = d.used
    for r in range(m):
        used[r] = False
    for c in range(S.qdd.shape[0]):
        S.qdd[c] = 0.0
    for k in range(rank):
        used[d.prow[k]] = True
        S.qdd[d.pcol[k]] = b[d.prow[k]]
    worst = 0.0
    for r in range(m):
        if not used[r] and abs(b[r]) > worst:
            worst = abs(b[r])
    return worst


@njit(nrt=False)
def accelerations(KP: tuple, DP: tuple, S: tuple) -> None:
    """alpha_b of every body (8.52) from S.qdd and the drift screws, into d.Ab (nb x 6).

    Needs d.Kh (:func:`drift`) at the same rates.
    """
    _tree_sum(KP, DP, S.qdd, True, data_views(DP).Ab)
