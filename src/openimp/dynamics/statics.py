"""The static stages of an equilibrium search (book ch 12), compiled.

At rest (every rate and acceleration zero) the unbalanced generalized load of
(12.1) is F = Q(psi) (the loads of :func:`~openimp.dynamics.loads.applied_loads`
on every generalized coordinate: gravity, springs, joint and applied loads;
dampers carry nothing at rest) and its Jacobian is -K, the stiffness of the
loads at rest (12.2, the K of :func:`~openimp.dynamics.linear.load_stiffness`
without velocity terms).  :func:`static_point` evaluates both at one assembled
posture; :func:`close_posture` re-solves the loop closure after a change of the
generalized coordinates (12.5, ch 6).  The search itself (step choice, energy
test, increment limit, neutral freedoms) is :mod:`~openimp.dynamics.equilibrium`.
"""

from __future__ import annotations

import numpy as np

from openimp._jit import njit
from openimp.dynamics.linear import _rate_forces, _setup, load_stiffness
from openimp.kinematics.posture import newton
from openimp.linalg import full_pivot, sym_eigen
from openimp.system import data_views, dyn_data_views


@njit(nrt=False)
def static_point(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple,
                 gen: np.ndarray | None, ptol: float, want_k: bool, F: np.ndarray,
                 K: np.ndarray, P2: np.ndarray, A2: np.ndarray, work: tuple
                 ) -> tuple[int, int, float, float]:
    """F (12.1) and, with ``want_k``, K (12.2) at the assembled posture S.q (internal
    units) over the generalized coordinates that the elimination with S.sgc leaves
    (z.cols, their phi' in z.Gf): F[:nf], K[:nf, :nf].

    P2 (nq, nq, nq), A2 (nb, nq, nq, 6): second derivatives (scratch);
    work = (u, cv, cp, Qp, dF (nb, 6), dfq).  Returns (nf, rank, potential energy
    of gravity and linear springs, load scale): the scale is the sum of the
    magnitudes of every body's force, its moment about the body's centre of mass
    (frame origin when massless) and every joint load, the size against which a
    residual is judged balanced.
    """
    u, cv, cp, Qp, dF, dfq = work
    z = dyn_data_views(ZP)
    d = data_views(DP)
    rank, nf = _setup(KP, DP, YP, ZP, S, gen, ptol)
    for j in range(nf):
        u[j] = 0.0
    pe = _rate_forces(KP, DP, YP, ZP, S, gen, rank, nf, u[:nf], cv, F)[1]
    scale = 0.0
    for b in range(z.Fext.shape[0]):
        # force, and moment about the body's centre of mass (or its frame's origin when
        # massless), not the global origin, so that the scale does not grow with the
        # model's distance from it
        f = z.Fext[b]
        G = z.Gb[b]
        if G[3, 3] > 0.0:
            ox, oy, oz = G[0, 3] / G[3, 3], G[1, 3] / G[3, 3], G[2, 3] / G[3, 3]
        else:
            ox, oy, oz = d.T0[b, 0, 3], d.T0[b, 1, 3], d.T0[b, 2, 3]
        mx = f[3] - (oy * f[2] - oz * f[1])
        my = f[4] - (oz * f[0] - ox * f[2])
        mz = f[5] - (ox * f[1] - oy * f[0])
        scale += abs(f[0]) + abs(f[1]) + abs(f[2]) + abs(mx) + abs(my) + abs(mz)
    for a in range(z.fq.shape[0]):
        scale += abs(z.fq[a])
    for j in range(nf):
        F[j] -= cv[j]  # zero at rest; kept so that F is (11.10) at psi' = 0
    if want_k:
        load_stiffness(KP, DP, YP, ZP, S, gen, rank, nf, P2, A2, cp, Qp, dF, dfq, K)
        for a in range(S.qd.shape[0]):
            S.qd[a] = 0.0
    return nf, rank, pe, scale


@njit(nrt=False)
def close_posture(KP: tuple, DP: tuple, S: tuple, gen: np.ndarray | None, cols: np.ndarray,
                  tol: float, ptol: float, maxit: int, keep: np.ndarray
                  ) -> tuple[int, int, float]:
    """Close the loops at S.q holding the generalized coordinates ``cols`` (and S.sgc)
    where they are (Newton, ch 6); returns the status of
    :func:`~openimp.kinematics.posture.newton` (0: closed), its iterations and the
    quality index of the last elimination.  ``keep`` (nq,) bool scratch."""
    nq = S.q.shape[0]
    for c in range(nq):
        keep[c] = S.sgc[c]
    for c in cols:
        S.sgc[c] = True
    res = newton(KP, DP, S, gen, tol, ptol, maxit, False)
    for c in range(nq):
        S.sgc[c] = keep[c]
    return res[0], res[1], res[3]


# ----------------------------------------------------------------------------- the search step
#: what :func:`search_step` did
STEPPED, BALANCED, NO_FREE, CAPPED, FAILED = 0, 1, 2, 3, 4
#: kinds of search step (history)
NEWTON, DESCENT, MODIFIED, NEUTRAL_STEP, ESCAPE = 0, 1, 2, 3, 4
#: opts of :func:`search_step`
(O_PTOL, O_RTOL, O_FTOL, O_STEPTOL, O_LIMIT, O_NEUTRAL, O_STABLE, O_MAY_STEP, O_MAY_ESCAPE,
 O_NUMERIC_K, O_CLOSE) = range(11)
#: state of :func:`search_step` (kept between steps)
(S_SEEN, S_HAVE, S_NF, S_RANK, S_PE, S_SCALE, S_KIND, S_FMAX, S_STEPMAX, S_ITER, S_QUALITY,
 S_EVALS, S_KEVALS, S_CLOSED) = range(14)


@njit(nrt=False)
def _evaluate(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple, gen: np.ndarray | None,
              opts: np.ndarray, state: np.ndarray, F: np.ndarray, K: np.ndarray,
              cols: np.ndarray, P2: np.ndarray, A2: np.ndarray, work: tuple) -> int:
    """:func:`static_point` at S.q into F, K (K only without numeric_k) and cols; counts."""
    z = dyn_data_views(ZP)
    want_k = opts[O_NUMERIC_K] == 0.0
    nf, rank, pe, scale = static_point(KP, DP, YP, ZP, S, gen, opts[O_PTOL], want_k, F, K,
                                       P2, A2, work)
    for i in range(nf):
        cols[i] = z.cols[i]
    state[S_NF] = nf
    state[S_RANK] = rank
    state[S_PE] = pe
    state[S_SCALE] = scale
    state[S_EVALS] += 1.0
    if want_k:
        state[S_KEVALS] += 1.0
    return nf


@njit(nrt=False)
def search_step(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple, gen: np.ndarray | None,
                opts: np.ndarray, state: np.ndarray, bufs: tuple, work: tuple) -> int:
    """One step of the equilibrium search (book 12.2-12.6) from the assembled S.q.

    bufs = (F, K, cols, F1, K1, cols1, P2, A2, Gw, q0, vs, gs, fidx, FF, KFF, A, step, lam,
    V, W, x0, red, rleft, cleft, prow, pcol, keep): F (nq,), K (nq, nq), cols (nq,) int
    the evaluation at S.q (valid when state[S_HAVE]; with opts[O_NUMERIC_K] the caller
    fills K); F1, K1, cols1 the trial's; vs, gs (nq,) the coordinate and force scales
    (model = internal x scale); the rest scratch.  opts and state: the O_* and S_*
    entries.  Returns STEPPED (S.q moved to the accepted trial, whose evaluation is now
    in F, K, cols), BALANCED, NO_FREE, CAPPED (not balanced, no step allowed) or FAILED
    (no trial closed and lowered the energy; S.q unchanged).  state[S_KIND],
    state[S_FMAX], state[S_STEPMAX]: the step taken, and the largest generalized force
    and coordinate change over it, model units.
    """
    (F, K, cols, F1, K1, cols1, P2, A2, Gw, q0, vs, gs, fidx, FF, KFF, A, step, lam, V, W,
     x0, red, rleft, cleft, prow, pcol, keep) = bufs
    z = dyn_data_views(ZP)
    nq = S.q.shape[0]
    if state[S_HAVE] == 0.0:
        _evaluate(KP, DP, YP, ZP, S, gen, opts, state, F, K, cols, P2, A2, work)
        state[S_HAVE] = 1.0
    nf = int(state[S_NF])
    seen = max(state[S_SEEN], state[S_SCALE])
    state[S_SEEN] = seen
    nF = 0
    for i in range(nf):
        if not S.sgc[cols[i]]:
            fidx[nF] = i
            nF += 1
    if nF == 0:
        return NO_FREE
    kmax = 0.0
    fmax = 0.0
    for a in range(nF):
        FF[a] = F[fidx[a]]
        fmax = max(fmax, abs(FF[a]))
        for b in range(nF):
            KFF[a, b] = K[fidx[a], fidx[b]]
            kmax = max(kmax, abs(KFF[a, b]))
    eps = opts[O_NEUTRAL] * max(kmax, seen, 1e-300)
    # follower loads make K_FF unsymmetric: no potential, so no energy test, no
    # stable-seeking (its symmetric part says nothing about divergence)
    asym = 0.0
    for a in range(nF):
        for b in range(a + 1, nF):
            asym = max(asym, abs(KFF[a, b] - KFF[b, a]))
    conservative = asym <= 1e-8 * max(kmax, 1e-300)
    balanced = True
    ftol_max = 0.0
    for a in range(nF):
        tol = opts[O_FTOL] / gs[cols[fidx[a]]] if opts[O_FTOL] >= 0.0 else \
            opts[O_RTOL] * max(seen, 1e-300)
        ftol_max = max(ftol_max, tol)
        if abs(FF[a]) > tol:
            balanced = False
    # 12.6: full pivoting; the neutral group left
    for a in range(nF):
        for b in range(nF):
            A[a, b] = KFF[a, b]
        A[a, nF] = FF[a]
    npiv = full_pivot(A[:nF, :nF + 1], nF, eps, rleft, cleft, prow, pcol)
    for a in range(nF):
        x0[a] = 0.0
    for k in range(npiv):
        x0[pcol[k]] = A[prow[k], nF]
    small = True
    if opts[O_STEPTOL] >= 0.0:
        for a in range(nF):
            if abs(x0[a] * vs[cols[fidx[a]]]) > opts[O_STEPTOL]:
                small = False
    sym_eigen(KFF, nF, W, V, lam)
    seek = opts[O_STABLE] != 0.0 and conservative
    kind = NEWTON
    if balanced and small:
        if not (seek and lam[0] < -eps and opts[O_MAY_ESCAPE] != 0.0):
            return BALANCED
        # an unstable equilibrium: leave it along its mode (the energy falls both ways
        # to second order), then search on
        kind = ESCAPE
        for a in range(nF):
            step[a] = 0.1 * opts[O_LIMIT] * V[a, 0]
    else:
        if opts[O_MAY_STEP] == 0.0:
            return CAPPED
        kind = _choose(nF, FF, KFF, x0, A, npiv, prow, pcol, rleft, cleft, red, lam, V,
                       step, eps, ftol_max, opts[O_LIMIT], seek)
    # the increment limit (12.4): the whole vector scaled
    size = 0.0
    for a in range(nF):
        size += step[a] * step[a]
    size = np.sqrt(size)
    if size > opts[O_LIMIT]:
        for a in range(nF):
            step[a] *= opts[O_LIMIT] / size
    # trial postures: the loops closed with the coordinates held; halved on failure
    for c in range(nq):
        q0[c] = S.q[c]
        for a in range(nF):
            Gw[c, a] = z.Gf[c, fidx[a]]
    work0 = 0.0
    for a in range(nF):
        work0 += FF[a] * step[a]
    frec = 0.0  # the record, model units
    for a in range(nF):
        frec = max(frec, abs(FF[a]) * gs[cols[fidx[a]]])
    for _half in range(12):
        for c in range(nq):
            s = q0[c]
            for a in range(nF):
                s += Gw[c, a] * step[a]
            S.q[c] = s
        st, it, det = close_posture(KP, DP, S, gen, cols[:nf], opts[O_CLOSE], opts[O_PTOL],
                                    30, keep)
        if st == 0:
            state[S_ITER] = it
            state[S_QUALITY] = det
            state[S_CLOSED] = 1.0
            nf1 = _evaluate(KP, DP, YP, ZP, S, gen, opts, state, F1, K1, cols1, P2, A2,
                            work)
            ok = kind == ESCAPE or (kind == NEWTON and not seek)
            if not ok:
                # the loads did non-negative work over the step (trapezoid rule, each end
                # in its own coordinates), or the residual fell
                w1 = 0.0
                after = 0.0
                for i in range(nf1):
                    if not S.sgc[cols1[i]]:
                        w1 += F1[i] * (S.q[cols1[i]] - q0[cols1[i]])
                        after = max(after, abs(F1[i]))
                ok = 0.5 * (work0 + w1) >= 0.0 or after < fmax or fmax <= ftol_max
            if ok:
                smax = 0.0
                for a in range(nF):
                    smax = max(smax, abs(step[a]) * vs[cols[fidx[a]]])
                for i in range(nf1):
                    F[i] = F1[i]
                    cols[i] = cols1[i]
                    for j in range(nf1):
                        K[i, j] = K1[i, j]
                state[S_NF] = nf1
                state[S_KIND] = kind
                state[S_FMAX] = frec
                state[S_STEPMAX] = smax
                state[S_HAVE] = 1.0
                return STEPPED
        for a in range(nF):
            step[a] *= 0.5
    for c in range(nq):
        S.q[c] = q0[c]
    state[S_HAVE] = 0.0  # the scratch holds a trial's evaluation
    return FAILED


@njit(nrt=False)
def _choose(nF: int, FF: np.ndarray, KFF: np.ndarray, x0: np.ndarray, A: np.ndarray,
            npiv: int, prow: np.ndarray, pcol: np.ndarray, rleft: np.ndarray,
            cleft: np.ndarray, red: np.ndarray, lam: np.ndarray, V: np.ndarray,
            step: np.ndarray, eps: float, ftol: float, limit: float, seek: bool) -> int:
    """The search step on the FGCs into ``step`` (nF,); returns its kind.

    * a neutral group with an unbalanced reduced load: the book's 12.6 (b), a unit
      step of the group along its reduced load, the determinate group following
      through K11^-1 K12;
    * K_FF indefinite and a stable posture sought: Newton with every eigenvalue taken
      by its magnitude (always lowers the energy; Newton near a minimum);
    * otherwise Newton when the energy test passes (12.8: the loads do positive work
      along the step), else steepest descent (12.9) over the length where the
      stiffness says the energy stops falling."""
    # the neutral group's reduced load (the augmented column nF of the rows left), paired
    # in order with the columns left
    m = 0
    rn = 0.0
    for i in range(nF):
        if rleft[i]:
            red[m] = A[i, nF]
            rn += red[m] * red[m]
            m += 1
    unbalanced = False
    for i in range(m):
        if abs(red[i]) > ftol:
            unbalanced = True
    if m > 0 and unbalanced:
        rn = np.sqrt(rn)
        for a in range(nF):
            step[a] = x0[a]
        j = 0
        for c in range(nF):
            if not cleft[c]:
                continue
            d2 = limit * red[j] / rn
            step[c] += d2
            for k in range(npiv):
                step[pcol[k]] -= A[prow[k], c] * d2
            j += 1
        return NEUTRAL_STEP
    if seek and nF > 0 and lam[0] < -eps:
        for a in range(nF):
            step[a] = 0.0
        for i in range(nF):
            p = 0.0
            for a in range(nF):
                p += V[a, i] * FF[a]
            p /= max(abs(lam[i]), eps)
            for a in range(nF):
                step[a] += V[a, i] * p
        return MODIFIED
    e = 0.0
    for a in range(nF):
        e += FF[a] * x0[a]
    if not seek or m > 0 or e > 0.0:
        for a in range(nF):
            step[a] = x0[a]
        return NEWTON
    curv = 0.0
    nrm = 0.0
    for a in range(nF):
        nrm += FF[a] * FF[a]
        for b in range(nF):
            curv += FF[a] * KFF[a, b] * FF[b]
    mu = nrm / curv if curv > 0.0 else limit / max(np.sqrt(nrm), 1e-300)
    for a in range(nF):
        step[a] = mu * FF[a]
    return DESCENT


@njit(nrt=False)
def search_loop(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple, gen: np.ndarray | None,
                opts: np.ndarray, state: np.ndarray, bufs: tuple, work: tuple,
                max_steps: int, hist: np.ndarray, counts: np.ndarray) -> int:
    """:func:`search_step` until the search ends (a model without load laws: one compiled
    call per search).  At most ``max_steps`` steps; at most 4 of them leave an unstable
    equilibrium.  hist (max_steps, 3) receives (kind, largest generalized force, largest
    change) per step, counts (3,) the steps, escapes and neutral steps.  Returns the
    code of the last :func:`search_step` (not STEPPED)."""
    steps = 0
    escapes = 0
    neutral = 0
    while True:
        opts[O_MAY_STEP] = 1.0 if steps < max_steps else 0.0
        opts[O_MAY_ESCAPE] = 1.0 if escapes < 4 and steps < max_steps else 0.0
        code = search_step(KP, DP, YP, ZP, S, gen, opts, state, bufs, work)
        if code != STEPPED or steps >= hist.shape[0]:  # (the second: never, by the cap)
            counts[0] = steps
            counts[1] = escapes
            counts[2] = neutral
            return code if code != STEPPED else CAPPED
        kind = int(state[S_KIND])
        hist[steps, 0] = kind
        hist[steps, 1] = state[S_FMAX]
        hist[steps, 2] = state[S_STEPMAX]
        steps += 1
        if kind == ESCAPE:
            escapes += 1
        elif kind == NEUTRAL_STEP:
            neutral += 1
