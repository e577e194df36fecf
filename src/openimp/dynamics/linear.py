"""Linearized equations of motion about a set point (book ch 11).

About a state (psi*, psi'*, psi''*, t) the equations of motion
M psi'' + c(psi, psi') = Q(psi, psi', t) of :mod:`~openimp.dynamics.eom`
become, for small changes x = psi - psi*, v = psi' - psi'* (11.1, 11.11),

    M v' + D v + K x = F,      M = M(psi*)                      (11.7)
    D = d(c - Q)/dpsi'                                          (11.8)
    K = d(M psi''* + c - Q)/dpsi                                (11.9)
    F = Q(psi*, psi'*, t) - c(psi*, psi'*)                      (11.10)

over every generalized coordinate; the FGC rows with the SGC terms as
inputs are (11.13), the SGC rows the drive they need (11.14).  How each
term is formed, in internal units (:mod:`openimp.system`), at one assembled
posture with the set-point elimination kept:

* the second geometric derivatives phi''_{h,jk} (8.27) and the body
  operators' derivatives A_{b,jk} = dW_{b,j}/dpsi_k (8.46) come from the
  velocity-product stage, which gives sum_jk phi''_jk u_j u_k and
  sum_jk A_bjk u_j u_k for rates u: run on u = e_j and u = e_j + e_k it
  yields the symmetric parts (polarisation, exact), and
  A_bjk - A_bkj = [W_bk, W_bj] (8.49) the rest (:func:`second_derivatives`);
* K of the loads at rest (gravity, springs, constant loads, geometric
  stiffness of every tension and follower direction; 11.9 term by term) is
  sum_b A_bil . Fext_b + W_bi . dFext_b/dpsi_l + sum_h phi''_hil fq_h +
  phi'_hi dfq_h/dpsi_l with the load rates of :func:`load_rates`: closed
  form, no differencing;
* D: c - Q is quadratic in psi' (gyroscopic and velocity-product terms,
  8.49 doubles them) plus linear (dampers), so the central difference
  over a rate step of any size is its derivative exactly (polarisation);
* the terms the book's K leaves out (11.9 holds at rest): the position
  derivatives of M psi''* + c and of the damper forces at psi'* need third
  geometric derivatives; they are differentiated along each coordinate over
  exactly closed postures (Richardson extrapolation of central differences,
  truncation O(h^4)), and only when the set point moves;
* load laws (callables) are frozen at the set point in the kernel; their
  own derivatives are added by :func:`~openimp.dynamics.laws.law_derivatives`.
"""

from __future__ import annotations

import numpy as np

from openimp._jit import njit
from openimp.dynamics.eom import generalized, generalized_forces
from openimp.dynamics.inertia import body_inertias, inertia_wrenches, mass_matrix
from openimp.dynamics.loads import COINCIDENT, applied_loads, point_motion, unit_between
from openimp.kinematics.posture import newton
from openimp.kinematics.rates import accelerations, velocity, velocity_product
from openimp.mat4 import screw_bracket
from openimp.system import (
    DAMPER,
    FORCE,
    SPRING,
    TORQUE,
    data_views,
    dyn_data_views,
    dyn_views,
    model_views,
)

#: coordinate step of the differenced motion terms (internal units: radians, L)
H_MOTION = 1e-3


@njit(nrt=False, inline="always")
def _set_rates(KP: tuple, DP: tuple, S: tuple, gen: np.ndarray | None, rank: int,
               G: np.ndarray, u: np.ndarray) -> None:
    """Joint rates S.qd = phi' u (7.16), body velocities, velocity-product joint and
    body accelerations (zero psi'') for generalized rates u (nf,)."""
    for a in range(S.q.shape[0]):
        s = 0.0
        for j in range(u.shape[0]):
            s += G[a, j] * u[j]
        S.qd[a] = s
    velocity(KP, DP, S)
    velocity_product(KP, DP, S, gen, rank)
    accelerations(KP, DP, S)


@njit(nrt=False)
def second_derivatives(KP: tuple, DP: tuple, ZP: tuple, S: tuple, gen: np.ndarray | None,
                       rank: int, nf: int, P2: np.ndarray, A2: np.ndarray,
                       u: np.ndarray) -> None:
    """phi''_{a,jk} (8.27) into P2 (nq, nf, nf) and A_{b,jk} = dW_{b,j}/dpsi_k (8.46) into
    A2 (nb, nf, nf, 6), at the eliminated posture (z.Gf, z.W set).

    The velocity-product stage at rates u gives sum_jk X_jk u_j u_k (X = phi'' of
    every joint variable, or A_b as screws): u = e_j gives X_jj, u = e_j + e_k
    gives X_jk + X_kj.  phi'' is symmetric; A_bjk - A_bkj = [W_bk, W_bj] (8.49).
    ``u``: (nf,) scratch.  Leaves S.qd, S.qdd, d.V, d.Ab of the last pass.
    """
    d = data_views(DP)
    z = dyn_data_views(ZP)
    G = z.Gf[:, :nf]
    nq = S.q.shape[0]
    nb = A2.shape[0]
    for j in range(nf):
        for k in range(nf):
            u[k] = 0.0
        u[j] = 1.0
        _set_rates(KP, DP, S, gen, rank, G, u)
        for a in range(nq):
            P2[a, j, j] = S.qdd[a]
        for b in range(nb):
            for i in range(6):
                A2[b, j, j, i] = d.Ab[b, i]
    for j in range(nf):
        for k in range(j + 1, nf):
            for m in range(nf):
                u[m] = 0.0
            u[j] = 1.0
            u[k] = 1.0
            _set_rates(KP, DP, S, gen, rank, G, u)
            for a in range(nq):
                v = 0.5 * (S.qdd[a] - P2[a, j, j] - P2[a, k, k])
                P2[a, j, k] = v
                P2[a, k, j] = v
            for b in range(nb):
                for i in range(6):
                    v = 0.5 * (d.Ab[b, i] - A2[b, j, j, i] - A2[b, k, k, i])
                    A2[b, j, k, i] = v
                    A2[b, k, j, i] = v
                screw_bracket(z.W[b, k], z.W[b, j], 0.5, A2[b, j, k])
                screw_bracket(z.W[b, j], z.W[b, k], 0.5, A2[b, k, j])


@njit(nrt=False, inline="always")
def _direction_rate(r1: np.ndarray, r2: np.ndarray, v1: np.ndarray, v2: np.ndarray,
                    u: np.ndarray, du: np.ndarray) -> tuple[float, float]:
    """u = (r1 - r2)/l (:func:`~openimp.dynamics.loads.unit_between`), its rate
    du = (I - u u^T)(v1 - v2)/l (9.17, 11.9); returns (l, l') with l' = u.(v1 - v2)
    (10.11).  l below COINCIDENT: u, du are not set (the caller skips)."""
    ln = unit_between(r1, r2, u)
    if ln < COINCIDENT:
        return ln, 0.0
    lr = 0.0
    for k in range(3):
        lr += u[k] * (v1[k] - v2[k])
    for k in range(3):
        du[k] = (v1[k] - v2[k] - lr * u[k]) / ln
    return ln, lr


@njit(nrt=False, inline="always")
def _add_force_rate(dF: np.ndarray, f: float, u: np.ndarray, df: float, du: np.ndarray,
                    r: np.ndarray, v: np.ndarray) -> None:
    """dF += the rate of the wrench (f u, r x f u) of a force f u at a moving point r:
    (g', v x g + r x g') with g = f u, g' = df u + f du."""
    g0, g1, g2 = f * u[0], f * u[1], f * u[2]
    h0 = df * u[0] + f * du[0]
    h1 = df * u[1] + f * du[1]
    h2 = df * u[2] + f * du[2]
    dF[0] += h0
    dF[1] += h1
    dF[2] += h2
    dF[3] += v[1] * g2 - v[2] * g1 + r[1] * h2 - r[2] * h1
    dF[4] += v[2] * g0 - v[0] * g2 + r[2] * h0 - r[0] * h2
    dF[5] += v[0] * g1 - v[1] * g0 + r[0] * h1 - r[1] * h0


@njit(nrt=False)
def load_rates(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple, dF: np.ndarray,
               dfq: np.ndarray) -> None:
    """Rates of the loads at rest as the mechanism moves with joint rates S.qd (body
    velocities d.V): dF (nb, 6) of the body wrenches z.Fext, dfq (nq,) of z.fq.

    The loads are those of :func:`~openimp.dynamics.loads.applied_loads` at zero
    rates with the law values z.law held: gravity m g at the moving centre;
    linear joint springs (-k qd); point springs k (l - l0) or a held tension,
    whose direction turns (9.17); forces and torques of a held magnitude along
    a fixed direction or one that turns with two points.  Dampers carry
    nothing at rest.  Needs z.Gb, d.T0, d.V.
    """
    K = model_views(KP)
    d = data_views(DP)
    y = dyn_views(YP)
    z = dyn_data_views(ZP)
    g = y.grav
    P = z.P6
    r1 = P[0]
    r2 = P[1]
    v1 = P[2]
    v2 = P[3]
    u = P[4]
    du = P[5]
    for b in range(K.order.shape[0]):
        for k in range(6):
            dF[b, k] = 0.0
        G = z.Gb[b]
        m = G[3, 3]
        if m == 0.0:
            continue
        V = d.V[b]
        # (m c)' = m v + w x (m c) with m c = G[0:3, 3]; moment m c x g
        h0 = m * V[0] + V[4] * G[2, 3] - V[5] * G[1, 3]
        h1 = m * V[1] + V[5] * G[0, 3] - V[3] * G[2, 3]
        h2 = m * V[2] + V[3] * G[1, 3] - V[4] * G[0, 3]
        dF[b, 3] = h1 * g[2] - h2 * g[1]
        dF[b, 4] = h2 * g[0] - h0 * g[2]
        dF[b, 5] = h0 * g[1] - h1 * g[0]
    for a in range(S.q.shape[0]):
        dfq[a] = -y.qk[a] * S.qd[a] if y.qlaw[a, 0] < 0 else 0.0
    for i in range(y.ekind.shape[0]):
        kind = y.ekind[i]
        if kind == SPRING or kind == DAMPER:
            b1 = point_motion(KP, DP, y.ept[i, 0], r1, v1)
            b2 = point_motion(KP, DP, y.ept[i, 1], r2, v2)
            ln, lr = _direction_rate(r1, r2, v1, v2, u, du)
            if ln < COINCIDENT:
                continue
            if y.elaw[i] >= 0:
                t = z.law[y.elaw[i]]
                dt = 0.0
            elif kind == SPRING:
                t = y.evalue[i] * (ln - y.efree[i])
                dt = y.evalue[i] * lr
            else:
                continue  # a linear damper carries nothing at rest
            _add_force_rate(dF[b1], -t, u, -dt, du, r1, v1)
            _add_force_rate(dF[b2], t, u, dt, du, r2, v2)
            continue
        mag = z.law[y.elaw[i]] if y.elaw[i] >= 0 else y.evalue[i]
        first = 1 if kind == FORCE else 0
        if y.ept[i, first] >= 0:
            point_motion(KP, DP, y.ept[i, first], r2, v2)
            point_motion(KP, DP, y.ept[i, first + 1], r1, v1)
            ln, _ = _direction_rate(r1, r2, v1, v2, u, du)
            if ln < COINCIDENT:
                continue
        else:
            for k in range(3):
                u[k] = y.edir[i, k]
                du[k] = 0.0
        b = y.ebody[i]
        if kind == FORCE:
            point_motion(KP, DP, y.ept[i, 0], r1, v1)
            _add_force_rate(dF[b], mag, u, 0.0, du, r1, v1)
        elif kind == TORQUE:
            for k in range(3):
                dF[b, 3 + k] += mag * du[k]


@njit(nrt=False)
def load_stiffness(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple,
                   gen: np.ndarray | None, rank: int, nf: int, P2: np.ndarray,
                   A2: np.ndarray, cp: np.ndarray, Qp: np.ndarray, dF: np.ndarray,
                   dfq: np.ndarray, K: np.ndarray) -> None:
    """K (11.9, 12.2) of the loads at rest into K[:nf, :nf], closed form: -dQ/dpsi =
    -(sum_b A_bil . Fext_b + W_bi . dFext_b/dpsi_l + sum_h phi''_hil fq_h + phi'_hi
    dfq_h/dpsi_l), at the eliminated posture (:func:`_setup` done).  P2, A2 receive
    the second derivatives (:func:`second_derivatives`); cp, Qp (nq,), dF (nb, 6), dfq
    (nq,) scratch.  Leaves z.Fext, z.fq at rest and S.qd at the last unit rate."""
    z = dyn_data_views(ZP)
    nq = S.q.shape[0]
    nb = A2.shape[0]
    second_derivatives(KP, DP, ZP, S, gen, rank, nf, P2, A2, cp[:nf])
    for m in range(nf):
        cp[m] = 0.0
    _rate_forces(KP, DP, YP, ZP, S, gen, rank, nf, cp[:nf], Qp, dfq)  # Fext, fq at rest
    G = z.Gf
    W = z.W
    for l in range(nf):
        for m in range(nf):
            cp[m] = 0.0
        cp[l] = 1.0
        _set_rates(KP, DP, S, gen, rank, G[:, :nf], cp[:nf])
        load_rates(KP, DP, YP, ZP, S, dF, dfq)
        for i in range(nf):
            s = 0.0
            for b in range(nb):
                for k in range(6):
                    s += A2[b, i, l, k] * z.Fext[b, k] + W[b, i, k] * dF[b, k]
            for c in range(nq):
                s += P2[c, i, l] * z.fq[c] + G[c, i] * dfq[c]
            K[i, l] = -s


@njit(nrt=False)
def _setup(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple, gen: np.ndarray | None,
           ptol: float) -> tuple[int, int]:
    """:func:`~openimp.dynamics.eom.generalized` and the global pseudo-inertias at S.q (one
    compiled call: the stages are inlined once, not at every caller)."""
    rank, nf = generalized(KP, DP, ZP, S, gen, ptol)
    body_inertias(KP, DP, YP, ZP)
    return rank, nf


@njit(nrt=False)
def _rate_forces(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple,
                 gen: np.ndarray | None, rank: int, nf: int, u: np.ndarray,
                 cv: np.ndarray, Qv: np.ndarray) -> tuple[float, float]:
    """c and Q (nf each) at generalized rates u (nf,), the posture eliminated and z.Gb set;
    returns the kinetic and potential energies."""
    z = dyn_data_views(ZP)
    _set_rates(KP, DP, S, gen, rank, z.Gf[:, :nf], u)
    ke = inertia_wrenches(KP, DP, ZP)
    pe = applied_loads(KP, DP, YP, ZP, S)[0]
    generalized_forces(KP, ZP, nf, cv, Qv)
    return ke, pe


@njit(nrt=False)
def _motion_terms(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple,
                  gen: np.ndarray | None, ptol: float, nf: int, u: np.ndarray,
                  a: np.ndarray, zero: np.ndarray, Mw: np.ndarray, cv: np.ndarray,
                  Qv: np.ndarray, r: np.ndarray, qd: np.ndarray) -> int:
    """r = M psi''* + c(psi, u) - Q(psi, u) + Q(psi, 0) (nf,) at the posture S.q, closed
    beforehand, with the coordinates of z.cols held: the velocity-dependent part of
    the residual, whose psi-derivative is what the book's K leaves out; qd (nq,) the
    joint rates phi' u there.  Returns the rank, -1 when the coordinates are not
    the same."""
    rank, nf2 = _setup(KP, DP, YP, ZP, S, gen, ptol)
    if nf2 != nf:
        return -1
    mass_matrix(KP, ZP, Mw)
    _rate_forces(KP, DP, YP, ZP, S, gen, rank, nf, u, cv, Qv)
    for c in range(qd.shape[0]):
        qd[c] = S.qd[c]
    for i in range(nf):
        s = cv[i] - Qv[i]
        for j in range(nf):
            s += Mw[i, j] * a[j]
        r[i] = s
    _rate_forces(KP, DP, YP, ZP, S, gen, rank, nf, zero, cv, Qv)
    for i in range(nf):
        r[i] += Qv[i] - cv[i]  # c(psi, 0) = 0: kept for symmetry of the two passes
    return rank


@njit(nrt=False)
def linearize_kernel(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple,
                     gen: np.ndarray | None, opts: np.ndarray, psid: np.ndarray,
                     psidd: np.ndarray, out: tuple, work: tuple) -> tuple[int, int, int]:
    """M, D, K, F of (11.7)-(11.10) at the assembled posture S.q (internal units).

    opts = (pivot tolerance, closure tolerance, motion step h, differentiate
    motion terms 0/1, keep the closed postures 0/1).  psid, psidd: (nq,) rates
    and accelerations of the generalized coordinates (others ignored).
    out = (M, D, K, F, P2, A2, Gl, qpl, qdpl): M, D, K (nq, nq) and F (nq,), their
    leading (nf, nf) used; P2, A2 of :func:`second_derivatives`; Gl (nq, nlaw)
    the generalized direction of every law (dQ/dlaw); qpl (nq, 4, nq) the
    postures closed at psi* + (-2h, -h, h, 2h) e_l, qdpl the joint rates there
    (phi' psi'*; with the motion terms only, else 0).  work = (u, a, zero, cv,
    Qv, cp, Qp, r, dF, dfq, q0, sgc0, Mw) scratch.  Returns (nf, rank, status):
    status 0, or l + 1 when the closure at coordinate l failed.
    """
    M, D, K, F, P2, A2, Gl, qpl, qdpl = out
    u, a, zero, cv, Qv, cp, Qp, r, dF, dfq, q0, sgc0, Mw = work
    z = dyn_data_views(ZP)
    ptol = opts[0]
    nq = S.q.shape[0]
    rank, nf = _setup(KP, DP, YP, ZP, S, gen, ptol)
    cols = z.cols
    for j in range(nf):
        u[j] = psid[cols[j]]
        a[j] = psidd[cols[j]]
        zero[j] = 0.0
    mass_matrix(KP, ZP, M[:nf, :nf])
    # F (11.10) at the set point
    _rate_forces(KP, DP, YP, ZP, S, gen, rank, nf, u[:nf], cv, Qv)
    for i in range(nf):
        F[i] = Qv[i] - cv[i]
    # generalized direction of every law: Q is affine in each law value
    for e in range(Gl.shape[1]):
        if e >= z.law.shape[0] or Gl.shape[0] == 0:
            break
        z.law[e] += 1.0
        _rate_forces(KP, DP, YP, ZP, S, gen, rank, nf, u[:nf], cp, Qp)
        z.law[e] -= 1.0
        for i in range(nf):
            Gl[i, e] = Qp[i] - Qv[i]
    # D (11.8): c - Q is quadratic in the rates, so this difference is exact
    step = 1.0
    for j in range(nf):
        step = max(step, abs(u[j]))
    for k in range(nf):
        u[k] += step
        _rate_forces(KP, DP, YP, ZP, S, gen, rank, nf, u[:nf], cp, Qp)
        for i in range(nf):
            r[i] = cp[i] - Qp[i]
        u[k] -= 2.0 * step
        _rate_forces(KP, DP, YP, ZP, S, gen, rank, nf, u[:nf], cp, Qp)
        u[k] += step
        for i in range(nf):
            D[i, k] = (r[i] - (cp[i] - Qp[i])) / (2.0 * step)
    # K (11.9) of the loads at rest, closed form
    load_stiffness(KP, DP, YP, ZP, S, gen, rank, nf, P2, A2, cp, Qp, dF, dfq, K)
    G = z.Gf
    status = 0
    moving = opts[3] != 0.0
    keep = opts[4] != 0.0
    if not (moving or keep):
        return nf, rank, status
    # the motion terms: central differences over closed postures, Richardson
    h = opts[2]
    for c in range(nq):
        q0[c] = S.q[c]
        sgc0[c] = S.sgc[c]
    for j in range(nf):
        S.sgc[cols[j]] = True
    offsets = (-2.0, -1.0, 1.0, 2.0)
    weights = (1.0, -8.0, 8.0, -1.0)
    for l in range(nf):
        for i in range(nf):
            Qp[i] = 0.0
        for p in range(4):
            s = offsets[p] * h
            for c in range(nq):
                S.q[c] = q0[c] + s * G[c, l] + 0.5 * s * s * P2[c, l, l]
            st = newton(KP, DP, S, gen, opts[1], ptol, 30, False)[0]
            if st != 0:
                status = l + 1
                break
            for c in range(nq):
                qpl[l, p, c] = S.q[c]
            if moving:
                if _motion_terms(KP, DP, YP, ZP, S, gen, ptol, nf, u[:nf], a[:nf],
                                 zero[:nf], Mw[:nf, :nf], cv, Qv, r, qdpl[l, p]) < 0:
                    status = l + 1
                    break
                for i in range(nf):
                    Qp[i] += weights[p] * r[i]
        if status != 0:
            break
        if moving:
            for i in range(nf):
                K[i, l] += Qp[i] / (12.0 * h)
    # back to the set point: its elimination, operators and loads
    for c in range(nq):
        S.q[c] = q0[c]
        S.sgc[c] = sgc0[c]
    _setup(KP, DP, YP, ZP, S, gen, ptol)
    _rate_forces(KP, DP, YP, ZP, S, gen, rank, nf, u[:nf], cv, Qv)
    return nf, rank, status


@njit(nrt=False)
def linearize_steps(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple,
                    gen: np.ndarray | None, opts: np.ndarray, Q: np.ndarray,
                    PSID: np.ndarray, PSIDD: np.ndarray, T: np.ndarray, MDK: np.ndarray,
                    NF: np.ndarray, COLS: np.ndarray, RES: np.ndarray, out: tuple,
                    work: tuple) -> None:
    """:func:`linearize_kernel` at every row of Q (steps, nq; internal units, assembled
    postures) with the rates PSID, accelerations PSIDD (steps, nq) and times T
    (steps,), the SGCs S.sgc throughout: M, D, K into MDK (steps, 3, nq, nq), the
    coordinate count (or -1 where a closure failed) into NF and the coordinates
    into COLS (steps, nq), the largest loop residual of the posture into RES (steps,).
    ``opts[3]`` (motion terms) applies where a step moves."""
    z = dyn_data_views(ZP)
    d = data_views(DP)
    M, D, K = out[0], out[1], out[2]
    moving = opts[3]
    for k in range(Q.shape[0]):
        for c in range(Q.shape[1]):
            S.q[c] = Q[k, c]
        S.t[0] = T[k]
        still = True
        for c in range(Q.shape[1]):
            if PSID[k, c] != 0.0 or PSIDD[k, c] != 0.0:
                still = False
        opts[3] = 0.0 if still else moving
        nf, _, status = linearize_kernel(KP, DP, YP, ZP, S, gen, opts, PSID[k], PSIDD[k],
                                         out, work)
        opts[3] = moving
        NF[k] = nf if status == 0 else -1
        res = 0.0
        for r in range(d.E.shape[0]):
            res = max(res, abs(d.E[r]))
        RES[k] = res
        for i in range(nf):
            COLS[k, i] = z.cols[i]
            for j in range(nf):
                MDK[k, 0, i, j] = M[i, j]
                MDK[k, 1, i, j] = D[i, j]
                MDK[k, 2, i, j] = K[i, j]
