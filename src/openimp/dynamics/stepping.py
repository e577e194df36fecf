"""Time stepping of the equations of motion (book ch 14), compiled.

The state between steps is the whole mechanism at one instant: every joint
variable S.q on the closed loops, every joint rate and acceleration, the
free generalized coordinates (FGCs) chosen there and the works done since the
start.  A step integrates the FGCs of its start (positions x_F, rates v_F)
with the loops closed at every stage by the posture solver (ch 6, Newton,
holding the FGCs and the SGCs); the dependent variables never drift.  At the
end of an accepted step the FGCs are chosen again (:func:`choose`) and the
rates carried across a change of coordinates through the joint rates
(qd = phi' psi', 7.16): the state is coordinate-free, so is the first stage
of the next step (full joint accelerations).

Two integrators share the stage (:func:`close_stage`, :func:`evaluate`):

* ``rk``: Dormand-Prince 5(4) (embedded pair, error estimate of order 4,
  FSAL), error per step controlled on x_F and v_F against ``atol + rtol |y|``;
* ``book``: the book's locally linearized exact-exponential step (14.11-14.30,
  section 4.4 of the digest): M, D, K of ch 11 frozen at the step start, the
  SGC motion over the step as a quadratic in time, the linear system solved
  exactly by the exponential of the augmented matrix (Van Loan; no Jordan
  form), the loops closed at the end, and the step controlled by the force
  error eps = M_FF (psi''_F - v'_F) of section 14.5 (IMP's ZERO (FORCE)).

Works are integrated with the motion: of the drives (SGC forces times SGC
rates), of the loads that have no potential, and the energy the dampers take
out; with the kinetic and potential energies they make the energy audit.

Everything here is in internal units (:mod:`openimp.system`); the scalars of
a run live in ``w.st`` / ``w.it`` at the indices below.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from openimp._jit import njit
from openimp.dynamics.eom import eom
from openimp.dynamics.linear import (
    H_MOTION,
    Linearized,
    LinOptions,
    LinWork,
    linearize_kernel,
    make_lin_work,
    make_linearized,
)
from openimp.kinematics.elimination import eliminate, jacobian
from openimp.kinematics.position import position
from openimp.kinematics.posture import newton
from openimp.linalg import cholesky_solve, expm
from openimp.system import DAMPER, SPRING, data_views, dyn_data_views, dyn_views, model_views

# ------------------------------------------------------------------ codes
#: what a stage or an attempt found
OK, NO_CLOSURE, SINGULAR_MASS, LOST_COORDINATES, TOO_LARGE, UNDERFLOW = 0, 1, 2, 3, 4, 5
#: what an attempt decided
ACCEPTED, REJECTED, FAILED = 0, 1, 2
#: what a run returned
REACHED, SWITCHED, STOPPED, CAPPED, FULL = 0, 1, 2, 3, 4

#: float scalars of w.st
(T, H, HNEXT, RTOL, ATOL, HMIN, HMAX, PTOL, CTOL, MTOL, FABS, FPCT, FSCALE, KE, PE,
 CLOSURE, QUALITY, SMALLEST, LARGEST, ERR, XMAX, QREF, TPREV, CLOS0, QUAL0, LSCALE,
 MSCALE, TFAIL, HPROP, NST) = range(30)
#: integer scalars of w.it (LAWS: the run has load laws, whose derivatives need the
#: closed postures of the book step's linearization)
(NF, NS, STEPS, REJECTS, EVALS, CLOSES, MAXIT, HAVE_LIN, WHY, FORCED, LAW_OK, LAWS,
 NIT) = range(13)

# Dormand-Prince 5(4): nodes, stage weights (row 6 = the 5th-order weights, FSAL) and the
# error weights b - b^ (b^ the 4th-order weights)
RK_C = np.array([0.0, 0.2, 0.3, 0.8, 8.0 / 9.0, 1.0, 1.0])
RK_A = np.array([
    [0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [0.2, 0.0, 0.0, 0.0, 0.0, 0.0],
    [3.0 / 40.0, 9.0 / 40.0, 0.0, 0.0, 0.0, 0.0],
    [44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0, 0.0, 0.0, 0.0],
    [19372.0 / 6561.0, -25360.0 / 2187.0, 64448.0 / 6561.0, -212.0 / 729.0, 0.0, 0.0],
    [9017.0 / 3168.0, -355.0 / 33.0, 46732.0 / 5247.0, 49.0 / 176.0, -5103.0 / 18656.0, 0.0],
    [35.0 / 384.0, 0.0, 500.0 / 1113.0, 125.0 / 192.0, -2187.0 / 6784.0, 11.0 / 84.0],
])
RK_E = np.array([35.0 / 384.0 - 5179.0 / 57600.0, 0.0, 500.0 / 1113.0 - 7571.0 / 16695.0,
                 125.0 / 192.0 - 393.0 / 640.0, -2187.0 / 6784.0 + 92097.0 / 339200.0,
                 11.0 / 84.0 - 187.0 / 2100.0, -1.0 / 40.0])
NSTAGE = 7
#: 3-point Gauss-Legendre nodes on [0, 1] and weights (exact to degree 5)
GL_X = np.array([0.5 - math.sqrt(15.0) / 10.0, 0.5, 0.5 + math.sqrt(15.0) / 10.0])
GL_W = np.array([5.0 / 18.0, 8.0 / 18.0, 5.0 / 18.0])


class Work(NamedTuple):
    """The arrays of one integration (internal units; nq joint variables, nS SGCs).

    st, it: scalars (indices above).  gscale (nq,): model units of a generalized
    force per internal unit (L for lengths, L^2 for angles).  role (nq,): 0
    dependent, 1 FGC, 2 SGC.  fcols (nq,): the FGC columns, ascending, nF used;
    scols (nS,): the SGC columns, ascending.  q0, qd0, qdd0 (nq,): the step
    start.  x0, v0 (nq,): its FGC positions and rates; w0 (3,): works (drive,
    loads without potential, dissipated).  ms (7, nS, 3): SGC position, rate,
    acceleration at each stage time (the last row also the step end).  kx,
    kv (7, nq), kw (7, 3): stage derivatives; ke_pe (7, 2): stage energies.
    xs, vs (nq,), ws (3,): a stage's state; xe, ve (nq,): the step's error (rk), the
    predicted end (book, :func:`book_mid`).
    psid, aF, rhs (nq,); M, c, Q, Lc (mass, velocity products, forces,
    Cholesky scratch); pw (3,) stage powers; ag (nq,) generalized
    accelerations; keep (nq,) bool scratch.  Book step: lin
    (:class:`~openimp.dynamics.linear.Linearized`) and lwork
    (:class:`~openimp.dynamics.linear.LinWork`) of
    :func:`~openimp.dynamics.linear.linearize_kernel`; Ab (n, n), Eb, X1, X2, X3 with
    n = 2 nq + 3: the augmented matrix, its exponential and scratch; ap (nq,)
    predicted accelerations; lcols (nq,) its column order; iF, iS (nq,)
    the places of the FGCs and SGCs in it; gF (3, nq) the forcing terms;
    Minv (nq, nq) M_FF^-1.  xprev, vprev, aprev (nq,), wprev, pprev (3,): the FGC
    positions, rates, accelerations, the works and powers at the start of the
    step just taken (w.st[TPREV]), for the outputs inside it.  wq (3,): the powers
    summed over the Gauss nodes of :func:`dense_works`.
    """

    st: np.ndarray
    it: np.ndarray
    gscale: np.ndarray
    role: np.ndarray
    fcols: np.ndarray
    scols: np.ndarray
    q0: np.ndarray
    qd0: np.ndarray
    qdd0: np.ndarray
    x0: np.ndarray
    v0: np.ndarray
    w0: np.ndarray
    ms: np.ndarray
    kx: np.ndarray
    kv: np.ndarray
    kw: np.ndarray
    ke_pe: np.ndarray
    xs: np.ndarray
    vs: np.ndarray
    ws: np.ndarray
    xe: np.ndarray
    ve: np.ndarray
    psid: np.ndarray
    aF: np.ndarray
    rhs: np.ndarray
    M: np.ndarray
    c: np.ndarray
    Q: np.ndarray
    Lc: np.ndarray
    pw: np.ndarray
    ag: np.ndarray
    keep: np.ndarray
    lin: Linearized
    lwork: LinWork
    Ab: np.ndarray
    Eb: np.ndarray
    X1: np.ndarray
    X2: np.ndarray
    X3: np.ndarray
    ap: np.ndarray
    lcols: np.ndarray
    iF: np.ndarray
    iS: np.ndarray
    gF: np.ndarray
    Minv: np.ndarray
    xprev: np.ndarray
    vprev: np.ndarray
    aprev: np.ndarray
    wprev: np.ndarray
    pprev: np.ndarray
    wq: np.ndarray


def make_work(nq: int, ns: int, nb: int, nlaw: int) -> Work:
    """Zeroed arrays of :class:`Work` for nq joint variables, ns SGCs, nb bodies."""
    f = np.zeros
    n = 2 * nq + 3
    lin = make_linearized(nq, nb, max(nlaw, 1))
    lwork = make_lin_work(nq, nb)
    w = Work(f(NST), np.zeros(NIT, np.int64), f(nq), np.zeros(nq, np.int64),
             np.zeros(nq, np.int64), np.zeros(ns, np.int64), f(nq), f(nq), f(nq), f(nq),
             f(nq), f(3), f((NSTAGE, ns, 3)), f((NSTAGE, nq)), f((NSTAGE, nq)),
             f((NSTAGE, 3)), f((NSTAGE, 2)), f(nq), f(nq), f(3), f(nq), f(nq), f(nq), f(nq),
             f(nq), f((nq, nq)), f(nq), f(nq), f((nq, nq)), f(3), f(nq),
             np.zeros(nq, np.bool_), lin, lwork, f((n, n)), f((n, n)), f((n, n)),
             f((n, n)), f((n, n)), f(nq), np.zeros(nq, np.int64),
             np.zeros(nq, np.int64), np.zeros(nq, np.int64), f((3, nq)), f((nq, nq)),
             f(nq), f(nq), f(nq), f(3), f(3), f(3))
    w.it[LAWS] = 1 if nlaw else 0
    return w


# ------------------------------------------------------------------ the stage
@njit(nrt=False)
def close_stage(KP: tuple, DP: tuple, S: tuple, gen: np.ndarray | None, w: Work,
                dt: float, srow: int) -> int:
    """Close the loops at the stage state: every joint variable predicted from the step
    start over dt (second-order Taylor), the FGCs at w.xs, the SGCs at w.ms[srow];
    Newton holding both.  Returns OK or NO_CLOSURE."""
    for a in range(S.q.shape[0]):
        S.q[a] = w.q0[a] + dt * w.qd0[a] + 0.5 * dt * dt * w.qdd0[a]
    return _close(KP, DP, S, gen, w, srow)


@njit(nrt=False)
def close_near(KP: tuple, DP: tuple, S: tuple, gen: np.ndarray | None, w: Work,
               dt: float, srow: int) -> int:
    """:func:`close_stage` predicted from the posture last evaluated in S (its q, qd,
    qdd) over dt: a point near it, not near the step start."""
    for a in range(S.q.shape[0]):
        S.q[a] += dt * S.qd[a] + 0.5 * dt * dt * S.qdd[a]
    return _close(KP, DP, S, gen, w, srow)


@njit(nrt=False, inline="always")
def _close(KP: tuple, DP: tuple, S: tuple, gen: np.ndarray | None, w: Work,
           srow: int) -> int:
    """Newton from the predicted S.q holding the FGCs at w.xs and the SGCs at
    w.ms[srow]; the quality index into w.st[QUALITY].  OK or NO_CLOSURE."""
    nq = S.q.shape[0]
    nF = w.it[NF]
    for a in range(nq):
        w.keep[a] = S.sgc[a]
    for j in range(nF):
        S.q[w.fcols[j]] = w.xs[j]
        S.sgc[w.fcols[j]] = True
    for s in range(w.scols.shape[0]):
        S.q[w.scols[s]] = w.ms[srow, s, 0]
    res = newton(KP, DP, S, gen, w.st[CTOL], w.st[PTOL], w.it[MAXIT], False)
    for a in range(nq):
        S.sgc[a] = w.keep[a]
    w.it[CLOSES] += 1
    if res[0] != 0:
        return NO_CLOSURE
    w.st[QUALITY] = res[3]
    return OK


@njit(nrt=False, inline="always")
def _powers(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple, nf: int,
            cols: np.ndarray, w: Work) -> None:
    """w.pw = (drive power, power of the loads without potential, dissipation rate)
    at the evaluated stage; w.ag holds the generalized accelerations (cols order)."""
    K = model_views(KP)
    d = data_views(DP)
    y = dyn_views(YP)
    z = dyn_data_views(ZP)
    M, c, Q = w.M, w.c, w.Q
    drive = 0.0
    applied = 0.0
    for k in range(nf):
        applied += Q[k] * w.psid[cols[k]]
        if w.role[cols[k]] == 2:
            f = c[k] - Q[k]
            for m in range(nf):
                f += M[k, m] * w.ag[m]
            drive += f * w.psid[cols[k]]
    # the power of the loads with a potential: gravity and linear springs (-dV/dt)
    g = y.grav
    cons = 0.0
    for b in range(K.order.shape[0]):
        G = z.Gb[b]
        V = d.V[b]
        m = G[3, 3]
        if m == 0.0:
            continue
        vx = m * V[0] + V[4] * G[2, 3] - V[5] * G[1, 3]
        vy = m * V[1] + V[5] * G[0, 3] - V[3] * G[2, 3]
        vz = m * V[2] + V[3] * G[1, 3] - V[4] * G[0, 3]
        cons += g[0] * vx + g[1] * vy + g[2] * vz
    damp = 0.0
    for a in range(S.q.shape[0]):
        sl = y.qlaw[a]
        if sl[0] < 0:
            cons -= y.qk[a] * (S.q[a] - y.qfree[a]) * S.qd[a]
        dv = z.law[sl[1]] if sl[1] >= 0 else y.qc[a] * S.qd[a]
        damp -= dv * S.qd[a]
    for i in range(y.ekind.shape[0]):
        if y.ekind[i] == SPRING and y.elaw[i] < 0:
            cons += z.epower[i]
        elif y.ekind[i] == DAMPER:
            damp += z.epower[i]
    w.pw[0] = drive
    w.pw[1] = applied - cons - damp
    w.pw[2] = -damp


@njit(nrt=False)
def evaluate(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple, gen: np.ndarray | None,
             w: Work, srow: int) -> int:
    """The equations of motion at the closed stage posture S.q with FGC rates w.vs and
    the SGC motion w.ms[srow]: w.aF (nF,) from M_FF psi''_F = Q_F - c_F - M_FS psi''_S
    (10.15), S.qd and the full joint accelerations S.qdd, the powers w.pw, and
    w.st[KE], w.st[PE].  Returns OK, SINGULAR_MASS or LOST_COORDINATES (the
    elimination no longer leaves exactly the FGCs and SGCs)."""
    z = dyn_data_views(ZP)
    nq = S.q.shape[0]
    nF = w.it[NF]
    nS = w.scols.shape[0]
    for a in range(nq):
        w.psid[a] = 0.0
        w.keep[a] = S.sgc[a]
    for j in range(nF):
        w.psid[w.fcols[j]] = w.vs[j]
        S.sgc[w.fcols[j]] = True
    for s in range(nS):
        w.psid[w.scols[s]] = w.ms[srow, s, 1]
    nf, _, ke, pe = eom(KP, DP, YP, ZP, S, gen, w.st[PTOL], w.psid, (w.M, w.c, w.Q))
    for a in range(nq):
        S.sgc[a] = w.keep[a]
    w.it[EVALS] += 1
    if nf != nF + nS:
        return LOST_COORDINATES
    cols = z.cols[:nf]
    # M_FF into Lc, the right-hand side into rhs (FGC order = column order)
    i = 0
    for k in range(nf):
        if w.role[cols[k]] != 1:
            continue
        r = w.Q[k] - w.c[k]
        s = 0
        jj = 0
        for m in range(nf):
            if w.role[cols[m]] == 1:
                w.Lc[i, jj] = w.M[k, m]
                jj += 1
            else:
                r -= w.M[k, m] * w.ms[srow, s, 2]
                s += 1
        w.rhs[i] = r
        i += 1
    if w.st[MSCALE] <= 0.0:  # the first evaluation with these coordinates
        for i in range(nF):
            w.st[MSCALE] = max(w.st[MSCALE], w.Lc[i, i])
    if not cholesky_solve(w.Lc, nF, w.rhs, w.aF, w.st[MTOL], w.st[MSCALE]):
        return SINGULAR_MASS
    i = 0
    s = 0
    for k in range(nf):
        if w.role[cols[k]] == 1:
            w.ag[k] = w.aF[i]
            i += 1
        else:
            w.ag[k] = w.ms[srow, s, 2]
            s += 1
    G = z.Gf
    for a in range(nq):
        acc = S.qdd[a]
        for k in range(nf):
            acc += G[a, k] * w.ag[k]
        S.qdd[a] = acc
    _powers(KP, DP, YP, ZP, S, nf, cols, w)
    # the scale of the generalized loads term by term (the net force vanishes at rest)
    big = 0.0
    for k in range(nf):
        if w.role[cols[k]] != 1:
            continue
        sc = 0.0
        for b in range(z.Fext.shape[0]):
            p = 0.0
            for i6 in range(6):
                p += z.W[b, k, i6] * z.Fext[b, i6]
            sc += abs(p)
        for a in range(nq):
            sc += abs(G[a, k] * z.fq[a])
        big = max(big, sc * w.gscale[cols[k]])
    w.st[LSCALE] = big
    w.st[KE] = ke
    w.st[PE] = pe
    d = data_views(DP)
    res = 0.0
    for r in range(d.E.shape[0]):
        res = max(res, abs(d.E[r]))
    w.st[CLOSURE] = res
    return OK


@njit(nrt=False)
def start_state(S: tuple, w: Work) -> None:
    """Take the evaluated posture S (q, qd, qdd) as the step start and its derivatives
    as the first stage (the FGCs' rates and accelerations, coordinate-free)."""
    nq = S.q.shape[0]
    for a in range(nq):
        w.q0[a] = S.q[a]
        w.qd0[a] = S.qd[a]
        w.qdd0[a] = S.qdd[a]
    for j in range(w.it[NF]):
        c = w.fcols[j]
        w.x0[j] = S.q[c]
        w.v0[j] = S.qd[c]
        w.kx[0, j] = S.qd[c]
        w.kv[0, j] = S.qdd[c]
    for k in range(3):
        w.kw[0, k] = w.pw[k]
    w.ke_pe[0, 0] = w.st[KE]
    w.ke_pe[0, 1] = w.st[PE]
    w.st[CLOS0] = w.st[CLOSURE]
    w.st[QUAL0] = w.st[QUALITY]
    w.it[HAVE_LIN] = 0


@njit(nrt=False)
def choose(KP: tuple, DP: tuple, S: tuple, gen: np.ndarray | None, w: Work) -> bool:
    """Choose the FGCs again at the step start (the posture S.q = w.q0): the columns the
    elimination leaves free with only the SGCs specified, unless the current set is
    still good (its quality index at least half the best: no switching back and
    forth between equally good coordinates).  The runs call it when the quality
    index of the current set (w.st[QUALITY], from the last closure) has fallen
    below half its value at the last choice (w.st[QREF]).  On a change the FGC state is
    re-read from the joint rates and accelerations (w.q0, w.qd0, w.qdd0).
    Returns True when the set changed."""
    d = data_views(DP)
    nq = S.q.shape[0]
    for a in range(nq):
        S.q[a] = w.q0[a]
    position(KP, DP, S, gen, 1)
    jacobian(KP, DP, S, gen)
    rank, quality, _ = eliminate(DP, S.sgc, w.st[PTOL])
    for a in range(nq):
        w.keep[a] = False
    for k in range(rank):
        w.keep[d.pcol[k]] = True
    nF = 0
    same = True
    for a in range(nq):
        if not (S.sgc[a] or w.keep[a]):
            if w.role[a] != 1:
                same = False
            nF += 1
    if same and nF == w.it[NF]:
        w.st[QREF] = quality
        return False
    # the current set held: still regular?
    for j in range(w.it[NF]):
        S.sgc[w.fcols[j]] = True
    rank_c, quality_c, _ = eliminate(DP, S.sgc, w.st[PTOL])
    for j in range(w.it[NF]):
        S.sgc[w.fcols[j]] = False
    if rank_c == rank and nF == w.it[NF] and quality_c >= 0.5 * quality:
        w.st[QREF] = quality_c
        return False
    w.st[QREF] = quality
    # the new set: FGCs are the columns neither specified nor pivoted
    eliminate(DP, S.sgc, w.st[PTOL])
    for a in range(nq):
        w.keep[a] = False
    for k in range(rank):
        w.keep[d.pcol[k]] = True
    nF = 0
    for a in range(nq):
        if w.role[a] == 1:
            w.role[a] = 0
        if not (S.sgc[a] or w.keep[a]):
            w.role[a] = 1
            w.fcols[nF] = a
            nF += 1
    w.it[NF] = nF
    w.st[MSCALE] = 0.0  # the scale of the new M_FF, at its first evaluation
    for j in range(nF):
        c = w.fcols[j]
        w.x0[j] = w.q0[c]
        w.v0[j] = w.qd0[c]
        w.kx[0, j] = w.qd0[c]
        w.kv[0, j] = w.qdd0[c]
    w.it[HAVE_LIN] = 0
    return True


# ------------------------------------------------------------------ Dormand-Prince 5(4)
@njit(nrt=False)
def rk_stage_state(w: Work, i: int) -> float:
    """w.xs, w.vs, w.ws = the state of stage i of a step of length w.st[H]; returns its
    time offset."""
    h = w.st[H]
    for j in range(w.it[NF]):
        sx = w.x0[j]
        sv = w.v0[j]
        for m in range(i):
            a = RK_A[i, m]
            if a != 0.0:
                sx += h * a * w.kx[m, j]
                sv += h * a * w.kv[m, j]
        w.xs[j] = sx
        w.vs[j] = sv
    for k in range(3):
        s = w.w0[k]
        for m in range(i):
            s += h * RK_A[i, m] * w.kw[m, k]
        w.ws[k] = s
    return RK_C[i] * h


@njit(nrt=False)
def keep_stage(S: tuple, w: Work, i: int) -> None:
    """Store the derivatives of the evaluated stage i (rates, accelerations, powers)."""
    for j in range(w.it[NF]):
        w.kx[i, j] = w.vs[j]
        w.kv[i, j] = w.aF[j]
    for k in range(3):
        w.kw[i, k] = w.pw[k]
    w.ke_pe[i, 0] = w.st[KE]
    w.ke_pe[i, 1] = w.st[PE]


@njit(nrt=False)
def rk_stage(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple, gen: np.ndarray | None,
             w: Work, i: int) -> int:
    """Stage i of the step: its state, the loops closed, the equations evaluated."""
    dt = rk_stage_state(w, i)
    S.t[0] = w.st[T] + dt
    st = close_stage(KP, DP, S, gen, w, dt, i)
    if st != OK:
        return st
    st = evaluate(KP, DP, YP, ZP, S, gen, w, i)
    if st == OK:
        keep_stage(S, w, i)
    return st


@njit(nrt=False)
def rk_finish(S: tuple, w: Work) -> int:
    """The error of the step just evaluated (all 7 stages; S at its end): accept it (the
    end becomes the next start) or reject it; propose the next step.  Returns
    ACCEPTED or REJECTED."""
    h = w.st[H]
    err = 0.0
    nF = w.it[NF]
    for j in range(nF):
        ex = 0.0
        ev = 0.0
        for m in range(NSTAGE):
            ex += RK_E[m] * w.kx[m, j]
            ev += RK_E[m] * w.kv[m, j]
        sx = w.st[ATOL] + w.st[RTOL] * max(abs(w.x0[j]), abs(w.xs[j]))
        sv = w.st[ATOL] + w.st[RTOL] * max(abs(w.v0[j]), abs(w.vs[j]))
        err += (h * ex / sx) ** 2 + (h * ev / sv) ** 2
    err = math.sqrt(err / max(2 * nF, 1))
    w.st[ERR] = err
    if err <= 1.0 or h <= w.st[HMIN] * (1.0 + 1e-12):
        if err > 1.0:
            w.it[FORCED] += 1
        fac = 5.0 if err == 0.0 else min(5.0, max(0.2, 0.9 * err ** -0.2))
        w.st[HNEXT] = h * fac
        _accept(S, w, h)
        return ACCEPTED
    w.st[HNEXT] = h * max(0.2, 0.9 * err ** -0.2)
    w.it[REJECTS] += 1
    return REJECTED


@njit(nrt=False, inline="always")
def _accept(S: tuple, w: Work, h: float) -> None:
    """The step of length h is taken: S (evaluated at its end, works w.ws) is the next
    start; the old start is kept for the outputs inside the step."""
    w.st[TPREV] = w.st[T]
    for j in range(w.it[NF]):
        w.xprev[j] = w.x0[j]
        w.vprev[j] = w.v0[j]
        w.aprev[j] = w.kv[0, j]
    for k in range(3):
        w.wprev[k] = w.w0[k]
        w.pprev[k] = w.kw[0, k]
        w.w0[k] = w.ws[k]
    w.st[T] += h
    w.it[STEPS] += 1
    w.st[SMALLEST] = min(w.st[SMALLEST], h)
    w.st[LARGEST] = max(w.st[LARGEST], h)
    start_state(S, w)


@njit(nrt=False)
def rk_attempt(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple, gen: np.ndarray | None,
               w: Work) -> int:
    """One attempt of a step of length w.st[H] from the start in w (the SGC motion at the
    stage times in w.ms): ACCEPTED, REJECTED (error, or a stage could not be closed or
    evaluated; w.it[WHY] says which) with w.st[HNEXT] proposed."""
    w.it[WHY] = OK
    for i in range(1, NSTAGE):
        st = rk_stage(KP, DP, YP, ZP, S, gen, w, i)
        if st != OK:
            w.it[WHY] = st
            w.st[HNEXT] = 0.5 * w.st[H]
            w.it[REJECTS] += 1
            return REJECTED
    return rk_finish(S, w)


# ------------------------------------------------------------------ the book's step
@njit(nrt=False)
def book_linearize(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple,
                   gen: np.ndarray | None, w: Work) -> int:
    """M, D, K, F of ch 11 (11.7-11.10) at the step start, the FGCs and SGCs held, into
    w.lin (rows and columns in the column order w.lcols of the FGCs and SGCs), the
    places of both in w.iF, w.iS and M_FF^-1 in w.Minv.  With w.it[LAWS] set the
    closed postures are kept in w.lin for the derivatives of the load laws,
    which the caller adds to D and K (laws are Python) when w.it[LAW_OK].  Returns OK,
    LOST_COORDINATES or SINGULAR_MASS."""
    z = dyn_data_views(ZP)
    nq = S.q.shape[0]
    nF = w.it[NF]
    nS = w.scols.shape[0]
    for a in range(nq):
        S.q[a] = w.q0[a]
        w.psid[a] = 0.0
        w.rhs[a] = 0.0
        w.keep[a] = S.sgc[a]
    for j in range(nF):
        w.psid[w.fcols[j]] = w.v0[j]
        w.rhs[w.fcols[j]] = w.kv[0, j]
        S.sgc[w.fcols[j]] = True
    for s in range(nS):
        w.psid[w.scols[s]] = w.ms[0, s, 1]
        w.rhs[w.scols[s]] = w.ms[0, s, 2]
    # the book's K (11.9) holds at rest; in motion its position derivatives of the
    # inertia and damper terms are added (differences over closed postures), which
    # makes the step second order
    moving = False
    for j in range(nF):
        if w.v0[j] != 0.0 or w.kv[0, j] != 0.0:
            moving = True
    for s in range(nS):
        if w.ms[0, s, 1] != 0.0 or w.ms[0, s, 2] != 0.0:
            moving = True
    # keep the closed postures for the laws' derivatives (the caller adds them)
    o = LinOptions(w.st[PTOL], w.st[CTOL], H_MOTION, moving, w.it[LAWS] != 0)
    nf, _, status = linearize_kernel(KP, DP, YP, ZP, S, gen, o, w.psid, w.rhs, w.lin,
                                     w.lwork)
    # the closed postures (and their rates) are whole only when every closure converged
    w.it[LAW_OK] = 1 if status == 0 else 0
    if status != 0:  # a closure of the motion terms failed: the book's K at rest
        for a in range(nq):
            S.q[a] = w.q0[a]
        o = LinOptions(o.pivot_tol, o.close_tol, o.h, False, o.keep)
        nf, _, _ = linearize_kernel(KP, DP, YP, ZP, S, gen, o, w.psid, w.rhs, w.lin, w.lwork)
    if not o.motion:  # at rest the joint rates at the closed postures are zero (not written)
        qdpl = w.lin.qdpl
        for i in range(qdpl.shape[0]):
            for p in range(qdpl.shape[1]):
                for a in range(qdpl.shape[2]):
                    qdpl[i, p, a] = 0.0
    for a in range(nq):
        S.sgc[a] = w.keep[a]
    w.it[EVALS] += 1 + 2 * nf
    if nf != nF + nS:
        return LOST_COORDINATES
    a = 0
    b = 0
    for k in range(nf):
        c = z.cols[k]
        w.lcols[k] = c
        if w.role[c] == 1:
            w.iF[a] = k
            a += 1
        else:
            w.iS[b] = k
            b += 1
    M = w.lin.M
    for j in range(nF):  # M_FF^-1 column by column
        for i in range(nF):
            for m in range(nF):
                w.Lc[i, m] = M[w.iF[i], w.iF[m]]
            w.rhs[i] = 1.0 if i == j else 0.0
        if not cholesky_solve(w.Lc, nF, w.rhs, w.aF, w.st[MTOL], w.st[MSCALE]):
            return SINGULAR_MASS
        for i in range(nF):
            w.Minv[i, j] = w.aF[i]
    w.it[HAVE_LIN] = 1
    return OK


@njit(nrt=False)
def book_predict(w: Work) -> int:
    """The linear solution over the step tau = w.st[H] (14.11-14.30, by the exponential
    of the augmented matrix): the FGC state at the step end into w.xs, w.vs, the
    predicted accelerations v'_F there into w.ap.  The forcing is (11.13) with
    the SGC motion over the step as a quadratic in time (rate, acceleration and
    the jerk between the step's ends, w.ms[0] and w.ms[6]): exact for a linear
    system under such an input, where the book freezes it.  Returns OK or
    TOO_LARGE (a displacement above w.st[XMAX], the book's step 7)."""
    M, D, K, F = w.lin.M, w.lin.D, w.lin.K, w.lin.F
    nF = w.it[NF]
    nS = w.scols.shape[0]
    tau = w.st[H]
    iF, iS, Minv, g = w.iF, w.iS, w.Minv, w.gF
    # forcing of the FGC rows: G(s) = G0 + G1 s + G2 s^2 / 2 (11.13 over the step)
    for i in range(nF):
        r = iF[i]
        g0 = F[r]
        g1 = 0.0
        g2 = 0.0
        for s in range(nS):
            col = iS[s]
            v_s = w.ms[0, s, 1]
            a_s = w.ms[0, s, 2]
            j_s = (w.ms[NSTAGE - 1, s, 2] - a_s) / tau
            g0 -= M[r, col] * a_s
            g1 -= M[r, col] * j_s + D[r, col] * a_s + K[r, col] * v_s
            g2 -= D[r, col] * j_s + K[r, col] * a_s
        g[0, i] = g0
        g[1, i] = g1
        g[2, i] = g2
    # y = (v, x) and the clock (1, s, s^2/2), all times tau:
    #   v' = -Minv D v - Minv K x + Minv G(s),  x' = v + psi'_F*   (14.11)
    n = 2 * nF + 3
    A = w.Ab
    for i in range(n):
        for j in range(n):
            A[i, j] = 0.0
    for i in range(nF):
        for j in range(nF):
            sd = 0.0
            sk = 0.0
            for m in range(nF):
                sd += Minv[i, m] * D[iF[m], iF[j]]
                sk += Minv[i, m] * K[iF[m], iF[j]]
            A[i, j] = -sd * tau
            A[i, nF + j] = -sk * tau
        A[nF + i, i] = tau
        for p in range(3):
            s = 0.0
            for m in range(nF):
                s += Minv[i, m] * g[p, m]
            A[i, 2 * nF + p] = s * tau
        A[nF + i, 2 * nF] = w.v0[i] * tau
    A[2 * nF + 1, 2 * nF] = tau
    A[2 * nF + 2, 2 * nF + 1] = tau
    expm(A, n, w.Eb, w.X2, w.X3)
    E = w.Eb
    big = 0.0
    for i in range(nF):
        w.X1[0, i] = E[i, 2 * nF]  # v(tau)
        w.X1[1, i] = E[nF + i, 2 * nF]  # x(tau)
        w.vs[i] = w.v0[i] + w.X1[0, i]
        w.xs[i] = w.x0[i] + w.X1[1, i]
        big = max(big, abs(w.X1[1, i]))
    # the accelerations the linear model predicts at the end (14.28)
    for i in range(nF):
        acc = 0.0
        for j in range(nF):
            acc += (A[i, j] * w.X1[0, j] + A[i, nF + j] * w.X1[1, j]) / tau
        for m in range(nF):
            acc += Minv[i, m] * (g[0, m] + g[1, m] * tau + 0.5 * g[2, m] * tau * tau)
        w.ap[i] = acc
    if big > w.st[XMAX]:
        return TOO_LARGE
    return OK


@njit(nrt=False)
def book_mid(w: Work) -> None:
    """After :func:`book_predict`: the linear solution at the step's middle into w.xs,
    w.vs (the exponential of half the augmented matrix, w.Ab scaled in place), the
    end's kept in w.xe, w.ve for :func:`book_end`."""
    nF = w.it[NF]
    n = 2 * nF + 3
    for i in range(nF):
        w.xe[i] = w.xs[i]
        w.ve[i] = w.vs[i]
    for i in range(n):
        for j in range(n):
            w.Ab[i, j] *= 0.5
    expm(w.Ab, n, w.Eb, w.X2, w.X3)
    for i in range(nF):
        w.vs[i] = w.v0[i] + w.Eb[i, 2 * nF]
        w.xs[i] = w.x0[i] + w.Eb[nF + i, 2 * nF]


@njit(nrt=False)
def book_end(w: Work) -> None:
    """The powers evaluated at the step's middle into w.wq (for Simpson's rule in
    :func:`book_finish`); the end's predicted state back into w.xs, w.vs."""
    for k in range(3):
        w.wq[k] = w.pw[k]
    for i in range(w.it[NF]):
        w.xs[i] = w.xe[i]
        w.vs[i] = w.ve[i]


@njit(nrt=False)
def book_finish(S: tuple, w: Work) -> int:
    """The force error of the step just taken (S evaluated at its end, section 14.5):
    eps = M_FF (psi''_F - v'_F) in model units against IMP's ZERO (FORCE) =
    (force, percent of the largest generalized force met so far): above twice the
    limit the step is repeated with half the length; above the limit it is kept
    and the next one halved; below 1/8 of it the next one doubles (up to the
    largest step).  Returns ACCEPTED or REJECTED."""
    nF = w.it[NF]
    h = w.st[H]
    M = w.lin.M
    err = 0.0
    fmax = 0.0
    for i in range(nF):
        e = 0.0
        f = 0.0
        for j in range(nF):
            mij = M[w.iF[i], w.iF[j]]
            e += mij * (w.aF[j] - w.ap[j])
            f += mij * w.aF[j]
        gs = w.gscale[w.fcols[i]]
        err = max(err, abs(e) * gs)
        fmax = max(fmax, abs(f) * gs, abs(w.lin.F[w.iF[i]]) * gs)
    w.st[FSCALE] = max(w.st[FSCALE], fmax, w.st[LSCALE])
    tol = w.st[FABS]
    pct = 0.01 * w.st[FPCT] * w.st[FSCALE]
    if pct > 0.0:
        tol = min(tol, pct)
    if err != err:  # NaN: the step is unusable
        err = math.inf
    w.st[ERR] = err / tol
    if err > 2.0 * tol and h > w.st[HMIN] * (1.0 + 1e-12):
        w.st[HNEXT] = 0.5 * h
        w.it[REJECTS] += 1
        return REJECTED
    if err > 2.0 * tol:
        w.it[FORCED] += 1
    if err > tol:
        w.st[HNEXT] = 0.5 * h
    elif err < 0.125 * tol:
        w.st[HNEXT] = 2.0 * h
    else:
        w.st[HNEXT] = h
    if err <= tol:  # a step cut to land on an output: back to the proposal before the cut
        w.st[HNEXT] = max(w.st[HNEXT], w.st[HPROP])
    # works over the step by Simpson's rule: the powers at its ends and its middle
    # (w.wq, :func:`book_end`), the motion there the linear model's
    for k in range(3):
        w.ws[k] = w.w0[k] + h / 6.0 * (w.kw[0, k] + 4.0 * w.wq[k] + w.pw[k])
    _accept(S, w, h)
    return ACCEPTED


@njit(nrt=False)
def book_attempt(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple,
                 gen: np.ndarray | None, w: Work) -> int:
    """One attempt of the book's step of length w.st[H] (section 14.4, steps 4-15): the
    linearization at the start (once per start), the exponential solution, the
    loops closed at the middle (for the works) and the end, the equations there,
    the force error.  ACCEPTED or
    REJECTED (w.it[WHY]: TOO_LARGE, NO_CLOSURE, ... or OK for the error test)."""
    w.it[WHY] = OK
    if w.it[HAVE_LIN] == 0:
        st = book_linearize(KP, DP, YP, ZP, S, gen, w)
        if st != OK:
            w.it[WHY] = st
            return FAILED
    h = w.st[H]
    st = book_predict(w)
    if st == OK:  # the middle, for the works
        book_mid(w)
        S.t[0] = w.st[T] + 0.5 * h
        st = close_stage(KP, DP, S, gen, w, 0.5 * h, 1)
    if st == OK:
        st = evaluate(KP, DP, YP, ZP, S, gen, w, 1)
    if st == OK:
        book_end(w)
        S.t[0] = w.st[T] + h
        st = close_stage(KP, DP, S, gen, w, h, NSTAGE - 1)
    if st == OK:
        st = evaluate(KP, DP, YP, ZP, S, gen, w, NSTAGE - 1)
    if st != OK:
        w.it[WHY] = st
        w.st[HNEXT] = 0.5 * w.st[H]
        w.it[REJECTS] += 1
        return REJECTED
    return book_finish(S, w)


# ------------------------------------------------------------------ runs
@njit(nrt=False)
def begin_step(w: Work, t_end: float) -> float:
    """The length of the next attempt toward t_end (the proposal, at most the largest
    step, stretched by up to 10% to land on t_end, never below the smallest step
    unless t_end is nearer); into w.st[H]."""
    t = w.st[T]
    h = min(w.st[HNEXT], w.st[HMAX])
    h = max(h, w.st[HMIN])
    if t + 1.1 * h >= t_end:
        h = t_end - t
    w.st[H] = h
    return h


# ------------------------------------------------------------------ outputs
@njit(nrt=False)
def dense_point(w: Work, tk: float) -> float:
    """The FGC state at tk inside the step just taken, into w.xs, w.vs: the quintic
    Hermite interpolant of the positions through the positions, rates and
    accelerations of both ends (error O(h^6), below the step's own), its
    derivative for the rates; the works into w.ws by the cubic Hermite
    interpolant of works and powers.  Returns tk minus the step's end."""
    t0 = w.st[TPREV]
    h = w.st[T] - t0
    th = (tk - t0) / h
    t2 = th * th
    t3 = t2 * th
    t4 = t3 * th
    t5 = t4 * th
    h0 = 1.0 - 10.0 * t3 + 15.0 * t4 - 6.0 * t5
    h1 = th - 6.0 * t3 + 8.0 * t4 - 3.0 * t5
    h2 = 0.5 * t2 - 1.5 * t3 + 1.5 * t4 - 0.5 * t5
    h3 = 10.0 * t3 - 15.0 * t4 + 6.0 * t5
    h4 = -4.0 * t3 + 7.0 * t4 - 3.0 * t5
    h5 = 0.5 * t3 - t4 + 0.5 * t5
    d0 = -30.0 * t2 + 60.0 * t3 - 30.0 * t4
    d1 = 1.0 - 18.0 * t2 + 32.0 * t3 - 15.0 * t4
    d2 = th - 4.5 * t2 + 6.0 * t3 - 2.5 * t4
    d3 = 30.0 * t2 - 60.0 * t3 + 30.0 * t4
    d4 = -12.0 * t2 + 28.0 * t3 - 15.0 * t4
    d5 = 1.5 * t2 - 4.0 * t3 + 2.5 * t4
    for j in range(w.it[NF]):
        p0, v0, a0 = w.xprev[j], w.vprev[j], w.aprev[j]
        p1, v1, a1 = w.x0[j], w.v0[j], w.kv[0, j]
        w.xs[j] = h0 * p0 + h1 * h * v0 + h2 * h * h * a0 + h3 * p1 + h4 * h * v1 \
            + h5 * h * h * a1
        w.vs[j] = (d0 * p0 + d1 * h * v0 + d2 * h * h * a0 + d3 * p1 + d4 * h * v1
                   + d5 * h * h * a1) / h
    c0 = 1.0 - 3.0 * t2 + 2.0 * t3
    c1 = th - 2.0 * t2 + t3
    c2 = 3.0 * t2 - 2.0 * t3
    c3 = -t2 + t3
    for k in range(3):
        w.ws[k] = c0 * w.wprev[k] + c1 * h * w.pprev[k] + c2 * w.w0[k] + c3 * h * w.kw[0, k]
    return tk - w.st[T]


@njit(nrt=False)
def works_change(w: Work) -> bool:
    """The works changed over the step just taken by more than round-off (its end and
    stage powers, its work increments against the energies and works): else an
    output inside it needs no quadrature (a conservative system)."""
    h = w.st[T] - w.st[TPREV]
    scale = abs(w.ke_pe[0, 0]) + abs(w.ke_pe[0, 1])
    big = 0.0
    for k in range(3):
        scale += abs(w.w0[k])
        big = max(big, abs(w.w0[k] - w.wprev[k]), h * abs(w.pprev[k]))
        for m in range(NSTAGE):
            big = max(big, h * abs(w.kw[m, k]))
    return big > 1e-13 * scale


@njit(nrt=False)
def works_node(w: Work, tk: float, i: int) -> float:
    """Gauss node i of [w.st[TPREV], tk]: the FGC state there (:func:`dense_point`);
    returns its time."""
    tn = w.st[TPREV] + GL_X[i] * (tk - w.st[TPREV])
    dense_point(w, tn)
    return tn


@njit(nrt=False)
def works_add(w: Work, i: int) -> None:
    """Add the powers w.pw evaluated at Gauss node i to w.wq."""
    for k in range(3):
        w.wq[k] += GL_W[i] * w.pw[k]


@njit(nrt=False)
def works_at(w: Work, tk: float, ob: tuple, row: int) -> None:
    """The works of output row ``row`` at tk: the step start's plus the Gauss rule of
    the powers over [w.st[TPREV], tk] (w.wq; error O(h^7), as the interpolated
    motion's)."""
    OEN = ob[7]
    for k in range(3):
        OEN[row, 2 + k] = w.wprev[k] + (tk - w.st[TPREV]) * w.wq[k]


@njit(nrt=False)
def dense_works(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple,
                gen: np.ndarray | None, w: Work, tk: float) -> int:
    """The powers at the 3 Gauss nodes of [w.st[TPREV], tk] along the interpolated
    motion (loops closed, equations evaluated there; SGCs at w.ms[0]) summed into
    w.wq for :func:`works_at`: the works at an output inside a step, as accurate
    as its motion (the cubic Hermite of the ends' works and powers in
    :func:`dense_point` is O(h^4)).  S is evaluated at tk on entry; the nodes are
    taken back from there, each closed from the last (the step's end may be near
    a limit of travel).  Returns OK or the failure code."""
    for k in range(3):
        w.wq[k] = 0.0
    t_last = tk
    for i in range(2, -1, -1):
        tn = works_node(w, tk, i)
        S.t[0] = tn
        st = close_near(KP, DP, S, gen, w, tn - t_last, 0)
        if st == OK:
            st = evaluate(KP, DP, YP, ZP, S, gen, w, 0)
        if st != OK:
            return st
        works_add(w, i)
        t_last = tn
    return OK


@njit(nrt=False)
def record(S: tuple, w: Work, ob: tuple, row: int, tk: float, end: bool) -> None:
    """Output row ``row`` of ob = (t, q, qd, qdd, fgc, quality, closure, energy (5:
    kinetic, potential, drive work, load work, dissipated)) at tk: the step's end
    (``end``: the start state in w) or the evaluated S with the works w.ws."""
    OT, OQ, OQD, OQDD, OF, OQUAL, OCLOS, OEN = ob
    OT[row] = tk
    nq = S.q.shape[0]
    for a in range(nq):
        OQ[row, a] = w.q0[a] if end else S.q[a]
        OQD[row, a] = w.qd0[a] if end else S.qd[a]
        OQDD[row, a] = w.qdd0[a] if end else S.qdd[a]
        OF[row, a] = w.role[a] == 1
    OCLOS[row] = w.st[CLOS0] if end else w.st[CLOSURE]
    OQUAL[row] = w.st[QUAL0] if end else w.st[QUALITY]
    OEN[row, 0] = w.ke_pe[0, 0] if end else w.st[KE]
    OEN[row, 1] = w.ke_pe[0, 1] if end else w.st[PE]
    for k in range(3):
        OEN[row, 2 + k] = w.w0[k] if end else w.ws[k]


@njit(nrt=False)
def dense_output(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple,
                 gen: np.ndarray | None, w: Work, tk: float, ob: tuple, row: int) -> int:
    """The output at tk inside the step just taken (SGCs at w.ms[0]): the interpolated
    FGCs, the loops closed there, the equations evaluated, the row recorded; its
    works by :func:`dense_works` when they change (kept from the cubic of
    :func:`dense_point` where a node cannot be closed).  Returns OK or the
    failure code of the output."""
    dt = dense_point(w, tk)
    S.t[0] = tk
    st = close_stage(KP, DP, S, gen, w, dt, 0)
    if st == OK:
        st = evaluate(KP, DP, YP, ZP, S, gen, w, 0)
    if st == OK:
        record(S, w, ob, row, tk, False)
        if works_change(w) and dense_works(KP, DP, YP, ZP, S, gen, w, tk) == OK:
            works_at(w, tk, ob, row)
    return st


@njit(nrt=False)
def outputs(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple, gen: np.ndarray | None,
            w: Work, tout: np.ndarray, kout: np.ndarray, ob: tuple, base: int) -> int:
    """Record the outputs tout[kout[0]:] that the step just taken reached (rows from
    kout[0] - base); returns OK or the failure code of an interpolated one.  The end
    of the step is recorded from the start state."""
    t1 = w.st[T]
    n = tout.shape[0]
    while kout[0] < n:
        tk = tout[kout[0]]
        end = abs(tk - t1) <= 1e-12 * max(1.0, abs(t1))
        if not _reached(tk, t1):
            break
        if end:
            record(S, w, ob, kout[0] - base, tk, True)
        else:
            st = dense_output(KP, DP, YP, ZP, S, gen, w, tk, ob, kout[0] - base)
            if st != OK:
                w.it[WHY] = st
                w.st[TFAIL] = tk
                return st
        kout[0] += 1
    return OK


@njit(nrt=False, inline="always")
def _reached(tk: float, t1: float) -> bool:
    """Output time tk is reached by a step ending at t1 (the test of :func:`outputs`)."""
    return tk <= t1 + 1e-12 * max(1.0, abs(t1))


@njit(nrt=False)
def land(w: Work, tout: np.ndarray, kout: np.ndarray) -> None:
    """The book's steps end on the output times: the time to the next output is cut
    into equal steps of at most 1.1 times the proposed one (no short remainder
    step, whose length would set the next proposal; never below the smallest step
    unless the gap is; the cut proposal kept in w.st[HPROP] for :func:`book_finish`).
    Its outputs are then step ends, never interpolated (an interpolant through the
    ends' accelerations carries the stiff modes its step damps)."""
    w.st[HPROP] = 0.0
    if kout[0] < tout.shape[0]:
        gap = tout[kout[0]] - w.st[T]
        h = w.st[H]
        if gap > 0.0 and h > 0.0:
            n = max(1.0, math.ceil(gap / (1.1 * h)))
            if w.st[HMIN] > 0.0 and gap / n < w.st[HMIN]:  # never below the smallest step
                n = max(1.0, math.floor(gap / w.st[HMIN]))
            w.st[H] = gap / n
            if w.st[H] < h:  # cut to land: the next step may go back to the proposal
                w.st[HPROP] = h


@njit(nrt=False)
def fit(w: Work, tout: np.ndarray, kout: np.ndarray, base: int, cap: int) -> bool:
    """True when the output rows left hold every output the next step (w.st[H]) may
    reach; with the rows all free the step is shortened to fit them; False when they
    must be flushed first."""
    t1 = w.st[T] + w.st[H]
    k = kout[0]
    while k < tout.shape[0] and _reached(tout[k], t1):
        k += 1
    if k - base <= cap:
        return True
    if kout[0] > base:
        return False
    w.st[H] = tout[base + cap - 1] - w.st[T]
    return True


@njit(nrt=False, inline="always")
def _after(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple, gen: np.ndarray | None,
           w: Work, code: int, h: float, last: bool, t_end: float, tout: np.ndarray,
           kout: np.ndarray, ob: tuple, base: int) -> int:
    """What the run loop does after an attempt: -1 to go on, else its return code."""
    if code == FAILED:
        return STOPPED
    if code == REJECTED:
        if h <= w.st[HMIN] * (1.0 + 1e-12) or h <= 1e-14 * max(1.0, abs(w.st[T])):
            if w.it[WHY] == OK:
                w.it[WHY] = UNDERFLOW
            return STOPPED
        return -1
    if last:
        w.st[T] = t_end
    if outputs(KP, DP, YP, ZP, S, gen, w, tout, kout, ob, base) != OK:
        return STOPPED
    if w.st[QUAL0] < 0.5 * w.st[QREF] and choose(KP, DP, S, gen, w):
        return SWITCHED
    return -1


@njit(nrt=False)
def run_rk(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple, gen: np.ndarray | None,
           w: Work, tout: np.ndarray, kout: np.ndarray, ob: tuple, base: int, cap: int,
           max_steps: int) -> int:
    """Dormand-Prince steps toward the last output time (hit exactly) with the SGCs held
    (w.ms the same at every stage), recording the outputs tout[kout[0]:] the steps
    pass (interpolated, the loops closed there: :func:`outputs`) into the rows of
    ob from kout[0] - base (at most cap rows).  Returns REACHED (every output
    done); SWITCHED when the FGCs changed at w.st[T] (the caller records it and
    calls again); STOPPED when a step could not be taken even at the smallest
    length (w.it[WHY] says why); CAPPED after max_steps steps; FULL when the next
    step's outputs would not fit."""
    s0 = w.it[STEPS]
    t_end = tout[tout.shape[0] - 1]
    while kout[0] < tout.shape[0]:
        begin_step(w, t_end)
        if not fit(w, tout, kout, base, cap):
            return FULL
        h = w.st[H]
        last = w.st[T] + h >= t_end
        code = _after(KP, DP, YP, ZP, S, gen, w, rk_attempt(KP, DP, YP, ZP, S, gen, w), h,
                      last, t_end, tout, kout, ob, base)
        if code >= 0:
            return code
        if w.it[STEPS] - s0 >= max_steps:
            return CAPPED
    return REACHED


@njit(nrt=False)
def run_book(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple, gen: np.ndarray | None,
             w: Work, tout: np.ndarray, kout: np.ndarray, ob: tuple, base: int, cap: int,
             max_steps: int) -> int:
    """:func:`run_rk` with the book's steps (compiled apart: a run of one method never
    compiles the other)."""
    s0 = w.it[STEPS]
    t_end = tout[tout.shape[0] - 1]
    while kout[0] < tout.shape[0]:
        begin_step(w, t_end)
        land(w, tout, kout)
        if not fit(w, tout, kout, base, cap):
            return FULL
        h = w.st[H]
        last = w.st[T] + h >= t_end
        code = _after(KP, DP, YP, ZP, S, gen, w, book_attempt(KP, DP, YP, ZP, S, gen, w), h,
                      last, t_end, tout, kout, ob, base)
        if code >= 0:
            return code
        if w.it[STEPS] - s0 >= max_steps:
            return CAPPED
    return REACHED
