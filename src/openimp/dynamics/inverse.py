"""Driving forces and joint reactions of a prescribed motion (book 11.14, ch 17).

Along a motion in which every freedom is specified (a kinematic sweep, or a
time motion of the SGCs), each step is evaluated from its stored joint
variables and rates:

* :func:`evaluate`: the posture stages (tree pass, Jacobian and its
  elimination, velocities, drift, accelerations; ch 5-8), the inertia wrench
  of every body (10.8) and the applied loads (ch 9), z.Fb = inertia - applied;
* :func:`transmitted`: the wrench every joint transmits to the bodies beyond
  it, and the generalized force of every joint variable alone;
* :func:`drive_forces`: the force or torque each generalized coordinate
  needs, tau_j = sum_b W_{b,j} . Fb_b - sum_h phi'_{h,j} fq_h (10.15 solved for
  the SGC rows, 11.14), regrouped by joint;
* :func:`reactions`: the six components of the load of the first body of
  every joint on its second by fictitious displacements (17.1-17.20), each
  column C'_Delta (17.12) replayed through the kept elimination (17.17) and
  tested for compatibility (17.18): an incompatible component is statically
  indeterminate and is returned as NaN, never as a number;
* :func:`forces_steps`: the step loop, compiled.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from openimp._jit import njit
from openimp.dynamics.inertia import body_inertias, inertia_wrenches
from openimp.dynamics.loads import applied_loads
from openimp.kinematics.elimination import derivatives, eliminate, jacobian, replay
from openimp.kinematics.position import position, screws
from openimp.kinematics.rates import accelerations, drift, velocity
from openimp.kinematics.sweep import Solver, sweep_steps
from openimp.system import data_views, dyn_data_views, dyn_views, model_views


class StepRows(NamedTuple):
    """The stored motion: Q, QD, QDD (steps x nq, internal units), generalized
    (steps x nq bool: the columns that are generalized coordinates at each step),
    laws (steps x nlaw: the load-law values)."""

    Q: np.ndarray
    QD: np.ndarray
    QDD: np.ndarray
    generalized: np.ndarray
    laws: np.ndarray


class ForceOptions(NamedTuple):
    """ptol: pivot tolerance of the elimination; itol: largest remainder (17.18) of a
    determinate reaction component; reactions: whether to compute them."""

    ptol: float
    itol: float
    reactions: bool


class ForceOut(NamedTuple):
    """Per step, in MODEL units: drive (nq: the force of every generalized coordinate,
    NaN elsewhere), R (nj x 6: u v w forces, u v w moments of the first body on the
    second, in the joint frame on the first body, about its origin; NaN where
    indeterminate), energy (2: kinetic, potential), gpower (power of gravity),
    dpower (power of the drives), qpower (nq: power of the joint loads), the
    element arrays (ne each: length, rate, tension or magnitude, power, skipped)
    and rank."""

    drive: np.ndarray
    R: np.ndarray
    energy: np.ndarray
    gpower: np.ndarray
    dpower: np.ndarray
    qpower: np.ndarray
    elen: np.ndarray
    erate: np.ndarray
    eforce: np.ndarray
    epower: np.ndarray
    eskip: np.ndarray
    rank: np.ndarray


@njit(nrt=False)
def evaluate(KP: tuple, DP: tuple, S: tuple, gen: np.ndarray | None, ptol: float) -> int:
    """The kinematic stages of one state S (q, qd, qdd of every joint variable; sgc):
    postures, screws, the elimination, velocities and drift (ch 5-8).

    Returns the rank of the elimination.  S.q is not changed (no Newton step:
    the posture is the solved one).  A sweep has all of these at the end of
    each step, and calls :func:`force_step` directly.
    """
    position(KP, DP, S, gen, 1)
    jacobian(KP, DP, S, gen)
    rank = eliminate(DP, S.sgc, ptol)[0]
    velocity(KP, DP, S)
    drift(KP, DP, S, gen)
    return rank


@njit(nrt=False)
def body_wrenches(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple
                  ) -> tuple[float, float, float]:
    """Body accelerations (8.52), the inertia wrench (10.8) and applied wrench of every
    body and z.Fb = inertia - applied.  Needs the kinematic stages at S
    (:func:`evaluate`, or the end of a sweep step).  Returns (kinetic energy,
    potential energy, power of gravity).
    """
    z = dyn_data_views(ZP)
    K = model_views(KP)
    accelerations(KP, DP, S)
    body_inertias(KP, DP, YP, ZP)
    ke = inertia_wrenches(KP, DP, ZP)
    pe, gp = applied_loads(KP, DP, YP, ZP, S)
    for b in range(K.order.shape[0]):
        for i in range(6):
            z.Fb[b, i] = z.Fin[b, i] - z.Fext[b, i]
    return ke, pe, gp


@njit(nrt=False)
def transmitted(KP: tuple, DP: tuple, ZP: tuple) -> None:
    """Wsum_h = sum_b P(b,h) Fb_b for every joint (zero for the chords, on no path) and
    gvar_a = D_a . Wsum_h(a) - fq_a for every joint variable.

    The power of W_{b,j} = sum_h P(b,h) sum_g D_h^g phi'_{h,j} (7.20) on the body
    wrenches regroups by joint: sum_b W_{b,j} . Fb_b - sum_a phi'_{a,j} fq_a =
    sum_a phi'_{a,j} gvar_a, so the driving forces and every fictitious
    column need only phi', never W.  One pass against the tree order sums the
    wrenches of every subtree (P(b,h) is the same for the whole subtree beyond
    a tree joint h: the sign of the body it carries).  Needs :func:`evaluate`.
    """
    K = model_views(KP)
    d = data_views(DP)
    z = dyn_data_views(ZP)
    nb = K.order.shape[0]
    for b in range(nb):
        for i in range(6):
            z.sub[b, i] = z.Fb[b, i]
    for h in range(K.jcode.shape[0]):
        for i in range(6):
            z.Wsum[h, i] = 0.0
    for kb in range(nb - 1, -1, -1):
        b = K.order[kb]
        h = K.pj[b]
        if h < 0:
            continue
        pb = K.pb[b]
        sg = float(K.psign[b])
        for i in range(6):
            z.sub[pb, i] += z.sub[b, i]
            z.Wsum[h, i] = sg * z.sub[b, i]
    for h in range(K.jcode.shape[0]):
        a0 = K.jq0[h]
        for g in range(K.jnv[h]):
            a = a0 + g
            s = -z.fq[a]
            for i in range(6):
                s += d.Dh[a, i] * z.Wsum[h, i]
            z.gvar[a] = s


@njit(nrt=False)
def drive_forces(DP: tuple, ZP: tuple, rank: int, nf: int, out: np.ndarray) -> None:
    """tau_j = sum_b W_{b,j} . Fb_b - sum_h phi'_{h,j} fq_h = sum_a phi'_{a,j} gvar_a for the
    first nf columns of z.cols (11.14), into out[z.cols[j]] (out: (nq,)).

    Needs :func:`transmitted`; computes phi' (7.14) into z.Gf (d.G is a sweep's
    predictor).
    """
    z = dyn_data_views(ZP)
    cols = z.cols[:nf]
    G = z.Gf[:, :nf]
    derivatives(DP, rank, cols, G)
    for j in range(nf):
        t = 0.0
        for a in range(G.shape[0]):
            t += G[a, j] * z.gvar[a]
        out[cols[j]] = t


@njit(nrt=False)
def reactions(KP: tuple, DP: tuple, ZP: tuple, rank: int, itol: float, R: np.ndarray
              ) -> None:
    """The load of the first body of every joint on its second (17.20), R: (nj, 6).

    Component k of joint Delta: a fictitious displacement D_Delta (17.2-17.7,
    17.9) along (k < 3) or about (k >= 3) axis u, v, w of the joint frame on
    the first body A_Delta = T_{0,Delta-} S_{Delta-,Delta}, about its origin.
    C'_Delta = -L(i, Delta) D_Delta (17.12, zero on the Euler-Rodrigues rows)
    goes through the kept elimination (17.17); what the dependent rows leave
    (17.18) above ``itol`` makes the component statically indeterminate: NaN.
    Otherwise, with W_{b,Delta} = P(b,Delta) D_Delta + sum_h P(b,h) D_h
    phi'_{h,Delta} (17.21 with the direct term P(b,Delta) D_Delta, which the
    book's printed 17.21 does not show: without it an open chain would carry no
    reaction), (17.20) regroups as
    F = sum_a phi'_{a,Delta} gvar_a + D_Delta . Wsum_Delta (:func:`transmitted`).

    The replay is linear in C': it is done once per step for the 6 unit rows
    of every loop (z.Xr, z.Yr), and each component combines them with the
    screw of its D_Delta: F = D . (Wsum_Delta - sum_i L(i,Delta) Yr_i),
    remainders -sum_i L(i,Delta) sum_r D_r Xr_(i,r).  The six D_Delta of a
    joint are the unit screws of its frame, so the six components of a joint
    come from one wrench (:func:`_components`).
    """
    K = model_views(KP)
    d = data_views(DP)
    z = dyn_data_views(ZP)
    m = z.Xr.shape[1]  # the rows of the loop equations
    used = d.used
    for r in range(m):
        used[r] = False
    for k in range(rank):
        used[d.prow[k]] = True
    nl = K.L.shape[0]
    for r6 in range(6 * nl):
        X = z.Xr[r6]
        for r in range(m):
            X[r] = 0.0
        X[r6] = 1.0
        replay(DP, rank, X)
        y = 0.0
        for k in range(rank):
            y += X[d.prow[k]] * z.gvar[d.pcol[k]]
        z.Yr[r6] = y
    W = z.h6  # the wrench each component pairs with, per joint
    for h in range(K.jcode.shape[0]):
        A = d.A[h]
        ox, oy, oz = A[0, 3], A[1, 3], A[2, 3]
        # the six D_Delta of joint h are (a_k, 0) and (o x a_k, a_k) with a_k the axes
        # (columns of A): a component is a_k . W_v, or a_k . (W_w + W_v x o), with
        # W = Wsum_h - sum_i L(i,h) Yr_i
        for r in range(6):
            W[r] = z.Wsum[h, r]
        inloop = False
        for i in range(nl):
            lih = K.L[i, h]
            if lih != 0:
                inloop = True
                for r in range(6):
                    W[r] -= lih * z.Yr[6 * i + r]
        _components(A, ox, oy, oz, W, R[h])
        if not inloop:
            continue
        # the remainders (17.18) of the six components, row by unused row
        X, Xc, worst = z.s6[0], z.s6[1], z.s6[2]
        for k in range(6):
            worst[k] = 0.0
        for u in range(m):
            if used[u]:
                continue
            for r in range(6):
                X[r] = 0.0
            for i in range(nl):
                lih = K.L[i, h]
                if lih == 0:
                    continue
                for r in range(6):
                    X[r] += lih * z.Xr[6 * i + r, u]
            _components(A, ox, oy, oz, X, Xc)
            for k in range(6):
                if abs(Xc[k]) > worst[k]:
                    worst[k] = abs(Xc[k])
        for k in range(6):
            if worst[k] > itol:
                R[h, k] = np.nan


@njit(nrt=False)
def _components(A: np.ndarray, ox: float, oy: float, oz: float, W: np.ndarray,
                out: np.ndarray) -> None:
    """The power of the six unit fictitious screws of a joint frame A (origin o) on the
    wrench W = (W_v, W_w): out[k] = a_k . W_v, out[3 + k] = a_k . (W_w + W_v x o)."""
    mx = W[3] + W[1] * oz - W[2] * oy
    my = W[4] + W[2] * ox - W[0] * oz
    mz = W[5] + W[0] * oy - W[1] * ox
    for k in range(3):
        out[k] = A[0, k] * W[0] + A[1, k] * W[1] + A[2, k] * W[2]
        out[3 + k] = A[0, k] * mx + A[1, k] * my + A[2, k] * mz


@njit(nrt=False)
def force_step(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple, rank: int, opt: tuple,
               out: tuple, s: int) -> None:
    """Every force output of row ``s`` of ``out`` (:class:`ForceOut`) at the state S, whose
    kinematic stages are done (:func:`evaluate`) and whose generalized coordinates
    are S.sgc | S.fgc.  ``opt``: :class:`ForceOptions`.
    """
    z = dyn_data_views(ZP)
    y = dyn_views(YP)
    nq = S.q.shape[0]
    L1 = y.lscale[0]
    L2 = L1 * L1
    ke, pe, gp = body_wrenches(KP, DP, YP, ZP, S)
    out.rank[s] = rank
    out.energy[s, 0] = ke * L2
    out.energy[s, 1] = pe * L2
    out.gpower[s] = gp * L2
    nf = 0
    for c in range(nq):
        out.drive[s, c] = np.nan
        out.qpower[s, c] = z.fq[c] * S.qd[c] * L2
        if S.sgc[c] or S.fgc[c]:
            z.cols[nf] = c
            nf += 1
    transmitted(KP, DP, ZP)
    drive_forces(DP, ZP, rank, nf, out.drive[s])
    dp = 0.0
    for j in range(nf):
        c = z.cols[j]
        dp += out.drive[s, c] * S.qd[c]
        out.drive[s, c] *= y.gscale[c]
    out.dpower[s] = dp * L2
    if opt.reactions:
        R = out.R[s]
        reactions(KP, DP, ZP, rank, opt.itol, R)
        for h in range(R.shape[0]):
            for k in range(3):
                R[h, k] *= L1
                R[h, 3 + k] *= L2
    for i in range(z.eforce.shape[0]):
        out.elen[s, i] = z.elen[i] * L1
        out.erate[s, i] = z.erate[i] * L1
        out.eforce[s, i] = z.eforce[i] * y.escale[i]
        out.epower[s, i] = z.epower[i] * L2
        out.eskip[s, i] = z.eskip[i]


@njit(nrt=False)
def _load_row(ZP: tuple, S: tuple, rows: tuple, s: int) -> None:
    """Row s of the stored motion into the state and its law values into the scratch."""
    z = dyn_data_views(ZP)
    for c in range(S.q.shape[0]):
        S.q[c] = rows.Q[s, c]
        S.qd[c] = rows.QD[s, c]
        S.qdd[c] = rows.QDD[s, c]
    for k in range(rows.laws.shape[1]):
        z.law[k] = rows.laws[s, k]


@njit(nrt=False)
def forces_steps(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple,
                 gen: np.ndarray | None, rows: tuple, opt: tuple, out: tuple) -> None:
    """Driving forces, reactions, element forces and energies at every stored step.

    ``rows``: :class:`StepRows`; ``opt``: :class:`ForceOptions`; ``out``:
    :class:`ForceOut`; S: scratch state whose sgc marks the specified
    coordinates of the motion.
    """
    for s in range(rows.Q.shape[0]):
        _load_row(ZP, S, rows, s)
        for c in range(S.q.shape[0]):
            S.fgc[c] = rows.generalized[s, c]
        rank = evaluate(KP, DP, S, gen, opt.ptol)
        force_step(KP, DP, YP, ZP, S, rank, opt, out, s)


@njit(nrt=False)
def open_chain_steps(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple,
                     gen: np.ndarray | None, rows: tuple, opt: tuple, out: tuple) -> None:
    """:func:`forces_steps` for a model without loops whose every variable is given (a
    robot arm): no loop equations, so no Jacobian and no elimination; phi' is the
    identity (rank 0, every variable a generalized coordinate, S.sgc all set).
    The kinematic stages are compiled in (inline) since they run once per step.
    """
    for s in range(rows.Q.shape[0]):
        _load_row(ZP, S, rows, s)
        position(KP, DP, S, gen, 1)
        screws(KP, DP, gen)
        velocity(KP, DP, S)
        drift(KP, DP, S, gen)
        force_step(KP, DP, YP, ZP, S, 0, opt, out, s)


@njit(nrt=False)
def sweep_forces(KP: tuple, DP: tuple, S: tuple, gen: np.ndarray | None, drive: tuple,
                 opt: tuple, part: tuple, dyn: tuple) -> tuple[int, int]:
    """A sweep (:func:`~openimp.kinematics.sweep.sweep_steps`, same arguments and result)
    that evaluates the forces of every step as it is solved, from the same final
    elimination and rates: no second pass over the kinematics.

    ``dyn`` = (YP, ZP, :class:`ForceOptions`, :class:`ForceOut` rows of these
    steps).  ``opt.rates`` must be on (zero driver rates: quasi-static).
    """
    YP, ZP, fopt, fout = dyn
    n = drive.values.shape[0]
    resume = opt.resume
    for k in range(n):
        o = Solver(opt.tol, opt.ptol, opt.maxit, opt.maxhalve, opt.rates, resume, k, k + 1)
        done, st = sweep_steps(KP, DP, S, gen, drive, o, part)
        if done == k:
            return k, st
        resume = True
        # the step left its posture, screws, elimination, velocities and drift in DP
        force_step(KP, DP, YP, ZP, S, part.rank[k], fopt, fout, k)
    return n, 0
