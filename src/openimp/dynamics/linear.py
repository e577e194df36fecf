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

from typing import NamedTuple

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


class LinOptions(NamedTuple):
    """Options of :func:`linearize_kernel` (internal units)."""

    pivot_tol: float  #: pivot tolerance of the elimination (ch 6)
    close_tol: float  #: closure tolerance of the postures differenced for the motion terms
    h: float  #: coordinate step of those differences (:data:`H_MOTION`)
    motion: bool  #: differentiate the motion terms (the set point moves)
    keep: bool  #: close the differenced postures even at rest and keep them (load laws)


class Linearized(NamedTuple):
    """What :func:`linearize_kernel` writes, for nq joint variables, nb bodies, nlaw laws;
    the leading (nf, nf) blocks of M, D, K and nf entries of F are used."""

    M: np.ndarray  #: (nq, nq) mass matrix (11.7)
    D: np.ndarray  #: (nq, nq) damping (11.8)
    K: np.ndarray  #: (nq, nq) stiffness (11.9)
    F: np.ndarray  #: (nq,) unbalanced load at the set point (11.10)
    P2: np.ndarray  #: (nq, nq, nq) phi''_{a,jk} (:func:`second_derivatives`)
    A2: np.ndarray  #: (nb, nq, nq, 6) A_{b,jk} (:func:`second_derivatives`)
    Gl: np.ndarray  #: (nq, nlaw) generalized direction of every law (dQ/dlaw)
    qpl: np.ndarray  #: (nq, 4, nq) postures closed at psi* + (-2h, -h, h, 2h) e_l
    qdpl: np.ndarray  #: (nq, 4, nq) joint rates phi' psi'* there (motion terms only)


class LinWork(NamedTuple):
    """Scratch of :func:`linearize_kernel` (nq joint variables, nb bodies)."""

    u: np.ndarray  #: (nq,) generalized rates
    a: np.ndarray  #: (nq,) generalized accelerations
    zero: np.ndarray  #: (nq,) zero rates
    cv: np.ndarray  #: (nq,) c
    Qv: np.ndarray  #: (nq,) Q
    cp: np.ndarray  #: (nq,) c at perturbed rates
    Qp: np.ndarray  #: (nq,) Q at perturbed rates
    r: np.ndarray  #: (nq,) a residual
    dF: np.ndarray  #: (nb, 6) body wrench rates
    dfq: np.ndarray  #: (nq,) joint load rates
    q0: np.ndarray  #: (nq,) the set point's joint variables
    sgc0: np.ndarray  #: (nq,) bool, the set point's SGCs
    Mw: np.ndarray  #: (nq, nq) a mass matrix


class LinSteps(NamedTuple):
    """The set points of :func:`linearize_steps` and what it writes per step."""

    q: np.ndarray  #: (steps, nq) assembled postures, internal units
    psid: np.ndarray  #: (steps, nq) rates of the generalized coordinates
    psidd: np.ndarray  #: (steps, nq) their accelerations
    t: np.ndarray  #: (steps,) times
    mdk: np.ndarray  #: (steps, 3, nq, nq) out: M, D, K (leading (nf, nf))
    nf: np.ndarray  #: (steps,) int out: coordinate count, -1 where a closure failed
    cols: np.ndarray  #: (steps, nq) int out: the generalized coordinates
    res: np.ndarray  #: (steps,) out: the largest loop residual of the posture


def make_linearized(nq: int, nb: int, nlaw: int) -> Linearized:
    """Zeroed :class:`Linearized` for nq joint variables, nb bodies, nlaw load laws."""
    f = np.zeros
    return Linearized(M=f((nq, nq)), D=f((nq, nq)), K=f((nq, nq)), F=f(nq),
                      P2=f((nq, nq, nq)), A2=f((nb, nq, nq, 6)), Gl=f((nq, nlaw)),
                      qpl=f((nq, 4, nq)), qdpl=f((nq, 4, nq)))


def make_lin_work(nq: int, nb: int) -> LinWork:
    """Zeroed :class:`LinWork` for nq joint variables and nb bodies."""
    f = np.zeros
    return LinWork(u=f(nq), a=f(nq), zero=f(nq), cv=f(nq), Qv=f(nq), cp=f(nq), Qp=f(nq),
                   r=f(nq), dF=f((nb, 6)), dfq=f(nq), q0=f(nq), sgc0=np.zeros(nq, np.bool_),
                   Mw=f((nq, nq)))


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
                   gen: np.ndarray | None, rank: int, nf: int, K: np.ndarray,
                   out: Linearized, work: LinWork) -> None:
    """K (11.9, 12.2) of the loads at rest into K[:nf, :nf], closed form: -dQ/dpsi =
    -(sum_b A_bil . Fext_b + W_bi . dFext_b/dpsi_l + sum_h phi''_hil fq_h + phi'_hi
    dfq_h/dpsi_l), at the eliminated posture (:func:`set_point` done).  out.P2, out.A2
    receive the second derivatives (:func:`second_derivatives`; nothing else of ``out``
    is written); work.cp, work.Qp, work.dF, work.dfq scratch.  Leaves z.Fext, z.fq at
    rest and S.qd at the last unit rate."""
    P2, A2 = out.P2, out.A2
    cp, Qp, dF, dfq = work.cp, work.Qp, work.dF, work.dfq
    z = dyn_data_views(ZP)
    nq = S.q.shape[0]
    nb = A2.shape[0]
    second_derivatives(KP, DP, ZP, S, gen, rank, nf, P2, A2, cp[:nf])
    for m in range(nf):
        cp[m] = 0.0
    forces_at_rates(KP, DP, YP, ZP, S, gen, rank, nf, cp[:nf], Qp, dfq)  # Fext, fq at rest
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
def set_point(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple, gen: np.ndarray | None,
              ptol: float) -> tuple[int, int]:
    """The set-point stage of the linearization and the statics at the assembled posture
    S.q: the elimination with the SGCs S.sgc held (:func:`~openimp.dynamics.eom.
    generalized`: the generalized coordinates z.cols, their phi' z.Gf (7.14), the body
    operators z.W (7.20)) and the global pseudo-inertias z.Gb (9.7).  ``ptol`` the pivot
    tolerance.  Returns (rank of the loop Jacobian, nf the number of generalized
    coordinates).  One compiled call: the stages are inlined once here, not at every
    caller."""
    rank, nf = generalized(KP, DP, ZP, S, gen, ptol)
    body_inertias(KP, DP, YP, ZP)
    return rank, nf


@njit(nrt=False)
def forces_at_rates(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple,
                    gen: np.ndarray | None, rank: int, nf: int, u: np.ndarray,
                    cv: np.ndarray, Qv: np.ndarray) -> tuple[float, float]:
    """c and Q of (10.15) into cv, Qv (nf each) at generalized rates u (nf,): joint rates
    phi' u (7.16), velocity-product accelerations, inertia wrenches (10.8) and the
    applied loads (9.5-9.11) with the law values z.law held, projected on the
    generalized coordinates.  Needs :func:`set_point` at the posture (rank, nf its
    returns).  Returns the kinetic and potential energies."""
    z = dyn_data_views(ZP)
    _set_rates(KP, DP, S, gen, rank, z.Gf[:, :nf], u)
    ke = inertia_wrenches(KP, DP, ZP)
    pe = applied_loads(KP, DP, YP, ZP, S)[0]
    generalized_forces(KP, ZP, nf, cv, Qv)
    return ke, pe


@njit(nrt=False)
def _motion_terms(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple,
                  gen: np.ndarray | None, ptol: float, nf: int, work: LinWork,
                  qd: np.ndarray) -> int:
    """r = M psi''* + c(psi, u) - Q(psi, u) + Q(psi, 0) into work.r[:nf] at the posture
    S.q, closed beforehand, with the coordinates of z.cols held, for the generalized
    rates u = work.u[:nf] and accelerations a = work.a[:nf]: the velocity-dependent
    part of the residual, whose psi-derivative is what the book's K leaves out; qd
    (nq,) the joint rates phi' u there.  work.Mw, work.cv, work.Qv scratch.  Returns
    the rank, -1 when the coordinates are not the same."""
    u, a, zero, Mw = work.u[:nf], work.a[:nf], work.zero[:nf], work.Mw[:nf, :nf]
    cv, Qv, r = work.cv, work.Qv, work.r
    rank, nf2 = set_point(KP, DP, YP, ZP, S, gen, ptol)
    if nf2 != nf:
        return -1
    mass_matrix(KP, ZP, Mw)
    forces_at_rates(KP, DP, YP, ZP, S, gen, rank, nf, u, cv, Qv)
    for c in range(qd.shape[0]):
        qd[c] = S.qd[c]
    for i in range(nf):
        s = cv[i] - Qv[i]
        for j in range(nf):
            s += Mw[i, j] * a[j]
        r[i] = s
    forces_at_rates(KP, DP, YP, ZP, S, gen, rank, nf, zero, cv, Qv)
    for i in range(nf):
        r[i] += Qv[i] - cv[i]  # c(psi, 0) = 0: kept for symmetry of the two passes
    return rank


@njit(nrt=False)
def linearize_kernel(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple,
                     gen: np.ndarray | None, opts: LinOptions, psid: np.ndarray,
                     psidd: np.ndarray, out: Linearized, work: LinWork) -> tuple[int, int, int]:
    """M, D, K, F of (11.7)-(11.10) at the assembled posture S.q (internal units).

    opts: :class:`LinOptions`.  psid, psidd: (nq,) rates and accelerations of the
    generalized coordinates (others ignored).  out: :class:`Linearized` (M, D, K, F
    over the leading nf coordinates; P2, A2 of :func:`second_derivatives`; the laws'
    directions Gl; with ``opts.motion`` or ``opts.keep`` the closed postures qpl and,
    with the motion terms only, their joint rates qdpl).  work: :class:`LinWork`
    scratch.  Returns (nf, rank, status): status 0, or l + 1 when the closure at
    coordinate l failed.
    """
    M, D, K, F, P2 = out.M, out.D, out.K, out.F, out.P2
    Gl, qpl, qdpl = out.Gl, out.qpl, out.qdpl
    u, a, zero, cv, Qv = work.u, work.a, work.zero, work.cv, work.Qv
    cp, Qp, r, q0, sgc0 = work.cp, work.Qp, work.r, work.q0, work.sgc0
    z = dyn_data_views(ZP)
    ptol = opts.pivot_tol
    nq = S.q.shape[0]
    rank, nf = set_point(KP, DP, YP, ZP, S, gen, ptol)
    cols = z.cols
    for j in range(nf):
        u[j] = psid[cols[j]]
        a[j] = psidd[cols[j]]
        zero[j] = 0.0
    mass_matrix(KP, ZP, M[:nf, :nf])
    # F (11.10) at the set point
    forces_at_rates(KP, DP, YP, ZP, S, gen, rank, nf, u[:nf], cv, Qv)
    for i in range(nf):
        F[i] = Qv[i] - cv[i]
    # generalized direction of every law: Q is affine in each law value
    for e in range(Gl.shape[1]):
        if e >= z.law.shape[0] or Gl.shape[0] == 0:
            break
        z.law[e] += 1.0
        forces_at_rates(KP, DP, YP, ZP, S, gen, rank, nf, u[:nf], cp, Qp)
        z.law[e] -= 1.0
        for i in range(nf):
            Gl[i, e] = Qp[i] - Qv[i]
    # D (11.8): c - Q is quadratic in the rates, so this difference is exact
    step = 1.0
    for j in range(nf):
        step = max(step, abs(u[j]))
    for k in range(nf):
        u[k] += step
        forces_at_rates(KP, DP, YP, ZP, S, gen, rank, nf, u[:nf], cp, Qp)
        for i in range(nf):
            r[i] = cp[i] - Qp[i]
        u[k] -= 2.0 * step
        forces_at_rates(KP, DP, YP, ZP, S, gen, rank, nf, u[:nf], cp, Qp)
        u[k] += step
        for i in range(nf):
            D[i, k] = (r[i] - (cp[i] - Qp[i])) / (2.0 * step)
    # K (11.9) of the loads at rest, closed form
    load_stiffness(KP, DP, YP, ZP, S, gen, rank, nf, K, out, work)
    G = z.Gf
    status = 0
    moving = opts.motion
    if not (moving or opts.keep):
        return nf, rank, status
    # the motion terms: central differences over closed postures, Richardson
    h = opts.h
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
            st = newton(KP, DP, S, gen, opts.close_tol, ptol, 30, False)[0]
            if st != 0:
                status = l + 1
                break
            for c in range(nq):
                qpl[l, p, c] = S.q[c]
            if moving:
                if _motion_terms(KP, DP, YP, ZP, S, gen, ptol, nf, work, qdpl[l, p]) < 0:
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
    set_point(KP, DP, YP, ZP, S, gen, ptol)
    forces_at_rates(KP, DP, YP, ZP, S, gen, rank, nf, u[:nf], cv, Qv)
    return nf, rank, status


@njit(nrt=False)
def linearize_steps(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple,
                    gen: np.ndarray | None, opts: LinOptions, steps: LinSteps,
                    out: Linearized, work: LinWork) -> None:
    """:func:`linearize_kernel` at every set point of ``steps`` (:class:`LinSteps`: the
    assembled postures, internal units, with their rates, accelerations and times), the
    SGCs S.sgc throughout, writing its M, D, K, coordinate counts, coordinates and
    loop residuals.  ``opts.motion`` (the motion terms) applies where a step moves."""
    z = dyn_data_views(ZP)
    d = data_views(DP)
    M, D, K = out.M, out.D, out.K
    Q = steps.q
    for k in range(Q.shape[0]):
        for c in range(Q.shape[1]):
            S.q[c] = Q[k, c]
        S.t[0] = steps.t[k]
        still = True
        for c in range(Q.shape[1]):
            if steps.psid[k, c] != 0.0 or steps.psidd[k, c] != 0.0:
                still = False
        o = LinOptions(opts.pivot_tol, opts.close_tol, opts.h, opts.motion and not still,
                       opts.keep)
        nf, _, status = linearize_kernel(KP, DP, YP, ZP, S, gen, o, steps.psid[k],
                                         steps.psidd[k], out, work)
        steps.nf[k] = nf if status == 0 else -1
        res = 0.0
        for r in range(d.E.shape[0]):
            res = max(res, abs(d.E[r]))
        steps.res[k] = res
        for i in range(nf):
            steps.cols[k, i] = z.cols[i]
            for j in range(nf):
                steps.mdk[k, 0, i, j] = M[i, j]
                steps.mdk[k, 1, i, j] = D[i, j]
                steps.mdk[k, 2, i, j] = K[i, j]
