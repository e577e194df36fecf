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

from collections import namedtuple
from typing import NamedTuple

import numpy as np

from openimp._jit import JIT_ENABLED, njit, packed_views
from openimp.dynamics.linear import (
    Linearized,
    LinWork,
    forces_at_rates,
    load_stiffness,
    set_point,
)
from openimp.kinematics.posture import newton
from openimp.linalg import full_pivot, sym_eigen
from openimp.system import Field, allocate, data_views, dyn_data_views, layout_of, views


class Evaluation(NamedTuple):
    """The static residual and stiffness at one posture (internal units), over the nf
    generalized coordinates of its elimination (leading entries used)."""

    F: np.ndarray  #: (nq,) unbalanced generalized load (12.1)
    K: np.ndarray  #: (nq, nq) stiffness of the loads at rest (12.2)
    cols: np.ndarray  #: (nq,) int, the generalized coordinates (z.cols)


def make_evaluation(nq: int) -> Evaluation:
    """Zeroed :class:`Evaluation` for nq joint variables."""
    return Evaluation(F=np.zeros(nq), K=np.zeros((nq, nq)), cols=np.zeros(nq, np.int64))


@njit(nrt=False)
def static_point(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple,
                 gen: np.ndarray | None, ptol: float, want_k: bool, at: Evaluation,
                 lin: Linearized, work: LinWork) -> tuple[int, int, float, float]:
    """F (12.1) and, with ``want_k``, K (12.2) at the assembled posture S.q (internal
    units) over the generalized coordinates that the elimination with S.sgc leaves
    (z.cols, their phi' in z.Gf): at.F[:nf], at.K[:nf, :nf], at.cols[:nf].

    lin: its P2, A2 receive the second derivatives (scratch; nothing else of it is
    written); work: the scratch of :func:`~openimp.dynamics.linear.load_stiffness`
    and u, cv.  Returns (nf, rank, potential energy of gravity and linear springs,
    load scale): the scale is the sum of the magnitudes of every body's force, its
    moment about the body's centre of mass (frame origin when massless) and every
    joint load, the size against which a residual is judged balanced.
    """
    u, cv, F = work.u, work.cv, at.F
    z = dyn_data_views(ZP)
    d = data_views(DP)
    rank, nf = set_point(KP, DP, YP, ZP, S, gen, ptol)
    for j in range(nf):
        u[j] = 0.0
        at.cols[j] = z.cols[j]
    _, pe = forces_at_rates(KP, DP, YP, ZP, S, gen, rank, nf, u[:nf], cv, F)
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
        load_stiffness(KP, DP, YP, ZP, S, gen, rank, nf, at.K, lin, work)
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


class StepOptions(NamedTuple):
    """Options of :func:`search_step` (internal units unless said)."""

    pivot_tol: float  #: pivot tolerance of the elimination (ch 6)
    rtol: float  #: balanced: every |F_i| <= rtol x the largest load scale seen ...
    force_tol: float  #: ... or, when >= 0, <= force_tol in model units (force, moment)
    step_tol: float  #: when >= 0, balanced also needs the next step <= it (model units)
    limit: float  #: the increment limit (12.4), the whole step vector scaled
    neutral: float  #: a pivot or eigenvalue below neutral x the stiffness' size is zero
    stable: bool  #: seek a stable posture (the modified Newton step, the escape)
    numeric_k: bool  #: the caller fills K (load laws); the search evaluates F only
    close_tol: float  #: closure tolerance of the trial postures


#: The record of a search, kept between steps (one line per field: name, type, meaning).
SEARCH_STATE = np.dtype([
    ("seen", np.float64),  # the largest load scale met so far
    ("have", np.bool_),  # the scratch's evaluation (``now``) is the one at S.q
    ("nf", np.int64),  # generalized coordinates of that evaluation
    ("rank", np.int64),  # rank of the loop Jacobian there
    ("pe", np.float64),  # potential energy of gravity and linear springs there
    ("scale", np.float64),  # the load scale there (:func:`static_point`)
    ("kind", np.int64),  # the kind of the last step taken (NEWTON ...)
    ("fmax", np.float64),  # its largest generalized force at the start, model units
    ("stepmax", np.float64),  # its largest coordinate change, model units
    ("iter", np.int64),  # Newton iterations of the last closure
    ("quality", np.float64),  # quality index of the last closure's elimination
    ("closed", np.bool_),  # a closure was made (iter and quality are set)
    ("evals", np.int64),  # evaluations of F
    ("kevals", np.int64),  # evaluations of K
    ("may_step", np.bool_),  # a step may be taken (the step cap not reached)
    ("may_escape", np.bool_),  # an unstable equilibrium may be left
    ("steps", np.int64),  # steps taken by :func:`search_loop`
    ("escapes", np.int64),  # of them, escapes from an unstable equilibrium
    ("neutral_steps", np.int64),  # of them, steps of a neutral group
])


def _records(a: np.ndarray) -> np.ndarray:
    """A structured array as the kernels take it: plain when compiled (a kernel call
    unboxes it in half the time of a record array), a record array when they run as
    Python (OPENIMP_NOJIT: they read and write fields as attributes, ``st.nf``)."""
    return a if JIT_ENABLED else a.view(np.recarray)


def make_search_state() -> np.ndarray:
    """A zeroed :data:`SEARCH_STATE` record, as a (1,) structured array: ``rec[0]["nf"]``."""
    return _records(np.zeros(1, SEARCH_STATE))


#: One step of a search's history (:func:`search_loop`).
STEP_RECORD = np.dtype([
    ("kind", np.int64),  # the kind of step (NEWTON ...)
    ("fmax", np.float64),  # the largest generalized force at its start, model units
    ("stepmax", np.float64),  # its largest coordinate change, model units
])


def make_history(max_steps: int) -> np.ndarray:
    """A zeroed (max_steps,) :data:`STEP_RECORD` structured array."""
    return _records(np.zeros(max_steps, STEP_RECORD))


#: The arrays of a search of a system (internal units), packed (:func:`make_search_buffers`)
#: and unpacked in a kernel by :func:`search_views`: one argument instead of 47 arrays
#: (a call's argument unboxing cost more than a search step).  Sizes: nq joint
#: variables, nq1 = nq + 1, nb bodies.  ``F``, ``K``, ``cols`` are the evaluation at
#: S.q (valid when the record's ``have``), ``F1``, ``K1``, ``cols1`` a trial's; ``l*`` the
#: :class:`~openimp.dynamics.linear.Linearized` and ``w*`` the
#: :class:`~openimp.dynamics.linear.LinWork` that :func:`static_point` writes in.
SEARCH_FIELDS: tuple[Field, ...] = (
    Field("F", "f", ("nq",), "unbalanced generalized load at S.q (12.1), leading nf"),
    Field("K", "f", ("nq", "nq"), "its stiffness of the loads at rest (12.2)"),
    Field("cols", "i", ("nq",), "its generalized coordinates"),
    Field("F1", "f", ("nq",), "F at a trial posture"),
    Field("K1", "f", ("nq", "nq"), "K at a trial posture"),
    Field("cols1", "i", ("nq",), "the generalized coordinates at a trial posture"),
    Field("vs", "f", ("nq",), "model units of a coordinate per internal unit"),
    Field("gs", "f", ("nq",), "model units of a generalized force per internal unit"),
    Field("Gw", "f", ("nq", "nq"), "phi' of the FGCs"),
    Field("q0", "f", ("nq",), "the posture at the step's start"),
    Field("fidx", "i", ("nq",), "places of the FGCs among the coordinates"),
    Field("FF", "f", ("nq",), "F on the FGCs"),
    Field("KFF", "f", ("nq", "nq"), "K on the FGCs"),
    Field("A", "f", ("nq", "nq1"), "[K_FF | F_F], eliminated (12.6)"),
    Field("step", "f", ("nq",), "the step on the FGCs"),
    Field("lam", "f", ("nq",), "eigenvalues of K_FF's symmetric part"),
    Field("V", "f", ("nq", "nq"), "its eigenvectors"),
    Field("W", "f", ("nq", "nq"), "scratch of the eigen-solver"),
    Field("x0", "f", ("nq",), "the Newton step"),
    Field("red", "f", ("nq",), "the neutral group's reduced load"),
    Field("rleft", "b", ("nq",), "rows left by the full pivoting"),
    Field("cleft", "b", ("nq",), "columns left (the neutral group)"),
    Field("prow", "i", ("nq",), "pivot rows"),
    Field("pcol", "i", ("nq",), "pivot columns"),
    Field("keep", "b", ("nq",), "scratch of close_posture"),
    Field("lM", "f", ("nq", "nq"), "Linearized.M (not written by static_point)"),
    Field("lD", "f", ("nq", "nq"), "Linearized.D (not written)"),
    Field("lK", "f", ("nq", "nq"), "Linearized.K (not written)"),
    Field("lF", "f", ("nq",), "Linearized.F (not written)"),
    Field("lP2", "f", ("nq", "nq", "nq"), "Linearized.P2: phi''_{a,jk}"),
    Field("lA2", "f", ("nb", "nq", "nq", 6), "Linearized.A2: A_{b,jk}"),
    Field("lGl", "f", ("nq", 0), "Linearized.Gl (no load laws in a compiled search)"),
    Field("lqpl", "f", ("nq", 4, "nq"), "Linearized.qpl (not written)"),
    Field("lqdpl", "f", ("nq", 4, "nq"), "Linearized.qdpl (not written)"),
    Field("wu", "f", ("nq",), "LinWork.u"),
    Field("wa", "f", ("nq",), "LinWork.a"),
    Field("wzero", "f", ("nq",), "LinWork.zero"),
    Field("wcv", "f", ("nq",), "LinWork.cv"),
    Field("wQv", "f", ("nq",), "LinWork.Qv"),
    Field("wcp", "f", ("nq",), "LinWork.cp"),
    Field("wQp", "f", ("nq",), "LinWork.Qp"),
    Field("wr", "f", ("nq",), "LinWork.r"),
    Field("wdF", "f", ("nb", 6), "LinWork.dF"),
    Field("wdfq", "f", ("nq",), "LinWork.dfq"),
    Field("wq0", "f", ("nq",), "LinWork.q0"),
    Field("wsgc0", "b", ("nq",), "LinWork.sgc0"),
    Field("wMw", "f", ("nq", "nq"), "LinWork.Mw"),
)

SearchBuffers = namedtuple("SearchBuffers", [f.name for f in SEARCH_FIELDS])  # type: ignore[misc]

#: ``search_views(SP)``: the :data:`SEARCH_FIELDS` of packed search buffers as named
#: views (a :class:`SearchBuffers`), inside a kernel
search_views = packed_views(layout_of(SEARCH_FIELDS), SearchBuffers)


def make_search_buffers(nq: int, nb: int, vs: np.ndarray, gs: np.ndarray
                        ) -> tuple[tuple[np.ndarray, np.ndarray, np.ndarray], SearchBuffers]:
    """Zeroed packed :data:`SEARCH_FIELDS` for nq joint variables and nb bodies, with the
    coordinate and force scales vs, gs (nq,): (SP, its views on the Python side)."""
    SP = allocate(SEARCH_FIELDS, {"nq": nq, "nq1": nq + 1, "nb": nb})
    b = SearchBuffers(*views(SEARCH_FIELDS, SP))
    b.vs[:] = vs
    b.gs[:] = gs
    return SP, b


@njit(nrt=False)
def _evaluation(b: SearchBuffers, trial: bool) -> Evaluation:
    """The evaluation at S.q (``now``) or at a trial posture, as an :class:`Evaluation`."""
    if trial:
        return Evaluation(b.F1, b.K1, b.cols1)
    return Evaluation(b.F, b.K, b.cols)


@njit(nrt=False)
def _lin(b: SearchBuffers) -> Linearized:
    return Linearized(b.lM, b.lD, b.lK, b.lF, b.lP2, b.lA2, b.lGl, b.lqpl, b.lqdpl)


@njit(nrt=False)
def _work(b: SearchBuffers) -> LinWork:
    return LinWork(b.wu, b.wa, b.wzero, b.wcv, b.wQv, b.wcp, b.wQp, b.wr, b.wdF, b.wdfq,
                   b.wq0, b.wsgc0, b.wMw)


@njit(nrt=False)
def search_point(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple,
                 gen: np.ndarray | None, ptol: float, SP: tuple
                 ) -> tuple[int, int, float, float]:
    """:func:`static_point` at S.q without the stiffness, into the evaluation ``F``,
    ``cols`` of the packed search buffers SP (:data:`SEARCH_FIELDS`)."""
    b = search_views(SP)
    return static_point(KP, DP, YP, ZP, S, gen, ptol, False, _evaluation(b, False), _lin(b),
                        _work(b))


@njit(nrt=False)
def _evaluate(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple, gen: np.ndarray | None,
              opts: StepOptions, state: np.ndarray, b: SearchBuffers, trial: bool) -> int:
    """:func:`static_point` at S.q into the evaluation ``now`` of b (or, ``trial``, a
    trial's; K only without numeric_k); counts in the record state[0]."""
    st = state[0]
    want_k = not opts.numeric_k
    nf, rank, pe, scale = static_point(KP, DP, YP, ZP, S, gen, opts.pivot_tol, want_k,
                                       _evaluation(b, trial), _lin(b), _work(b))
    st.nf = nf
    st.rank = rank
    st.pe = pe
    st.scale = scale
    st.evals += 1
    if want_k:
        st.kevals += 1
    return nf


@njit(nrt=False)
def search_step(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple, gen: np.ndarray | None,
                opts: StepOptions, state: np.ndarray, SP: tuple) -> int:
    """One step of the equilibrium search (book 12.2-12.6) from the assembled S.q.

    opts: :class:`StepOptions`; state: a (1,) :data:`SEARCH_STATE` record array
    (:func:`make_search_state`), kept between steps; SP: the packed
    :data:`SEARCH_FIELDS`: F, K, cols the evaluation at S.q (valid when state[0].have;
    with opts.numeric_k the caller fills its K), F1, K1, cols1 a trial's, vs, gs the
    coordinate and force scales (model = internal x scale), the rest scratch.  Returns
    STEPPED (S.q moved to the accepted trial, whose evaluation is now in F, K, cols),
    BALANCED, NO_FREE, CAPPED (not balanced, no step allowed: state[0].may_step false)
    or FAILED (no trial closed
    and lowered the energy; S.q unchanged).  The record's kind, fmax, stepmax: the step
    taken, and the largest generalized force and coordinate change over it, model units.
    """
    bufs = search_views(SP)
    F, K, cols = bufs.F, bufs.K, bufs.cols
    F1, K1, cols1 = bufs.F1, bufs.K1, bufs.cols1
    vs, gs, Gw, q0, fidx = bufs.vs, bufs.gs, bufs.Gw, bufs.q0, bufs.fidx
    FF, KFF, A, step, x0 = bufs.FF, bufs.KFF, bufs.A, bufs.step, bufs.x0
    lam, V, W = bufs.lam, bufs.V, bufs.W
    rleft, cleft, prow, pcol = bufs.rleft, bufs.cleft, bufs.prow, bufs.pcol
    st = state[0]
    z = dyn_data_views(ZP)
    nq = S.q.shape[0]
    if not st.have:
        _evaluate(KP, DP, YP, ZP, S, gen, opts, state, bufs, False)
        st.have = True
    nf = st.nf
    seen = max(st.seen, st.scale)
    st.seen = seen
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
    eps = opts.neutral * max(kmax, seen, 1e-300)
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
        tol = opts.force_tol / gs[cols[fidx[a]]] if opts.force_tol >= 0.0 else \
            opts.rtol * max(seen, 1e-300)
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
    if opts.step_tol >= 0.0:
        for a in range(nF):
            if abs(x0[a] * vs[cols[fidx[a]]]) > opts.step_tol:
                small = False
    sym_eigen(KFF, nF, W, V, lam)
    seek = opts.stable and conservative
    kind = NEWTON
    if balanced and small:
        if not (seek and lam[0] < -eps and st.may_escape):
            return BALANCED
        # an unstable equilibrium: leave it along its mode (the energy falls both ways
        # to second order), then search on
        kind = ESCAPE
        for a in range(nF):
            step[a] = 0.1 * opts.limit * V[a, 0]
    else:
        if not st.may_step:
            return CAPPED
        kind = _choose(nF, npiv, bufs, eps, ftol_max, opts.limit, seek)
    # the increment limit (12.4): the whole vector scaled
    size = 0.0
    for a in range(nF):
        size += step[a] * step[a]
    size = np.sqrt(size)
    if size > opts.limit:
        for a in range(nF):
            step[a] *= opts.limit / size
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
        code, it, det = close_posture(KP, DP, S, gen, cols[:nf], opts.close_tol,
                                      opts.pivot_tol, 30, bufs.keep)
        if code == 0:
            st.iter = it
            st.quality = det
            st.closed = True
            nf1 = _evaluate(KP, DP, YP, ZP, S, gen, opts, state, bufs, True)
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
                st.nf = nf1
                st.kind = kind
                st.fmax = frec
                st.stepmax = smax
                st.have = True
                return STEPPED
        for a in range(nF):
            step[a] *= 0.5
    for c in range(nq):
        S.q[c] = q0[c]
    st.have = False  # the scratch holds a trial's evaluation
    return FAILED


@njit(nrt=False)
def _choose(nF: int, npiv: int, bufs: SearchBuffers, eps: float, ftol: float, limit: float,
            seek: bool) -> int:
    """The search step on the FGCs into bufs.step (nF,) from F_F, K_FF, the Newton step
    x0, the full pivoting's A (npiv pivots, prow, pcol, rleft, cleft) and K_FF's
    eigenvalues lam and vectors V; returns its kind.

    * a neutral group with an unbalanced reduced load: the book's 12.6 (b), a unit
      step of the group along its reduced load, the determinate group following
      through K11^-1 K12;
    * K_FF indefinite and a stable posture sought: Newton with every eigenvalue taken
      by its magnitude (always lowers the energy; Newton near a minimum);
    * otherwise Newton when the energy test passes (12.8: the loads do positive work
      along the step), else steepest descent (12.9) over the length where the
      stiffness says the energy stops falling."""
    FF, KFF, x0, A, step = bufs.FF, bufs.KFF, bufs.x0, bufs.A, bufs.step
    prow, pcol, rleft, cleft = bufs.prow, bufs.pcol, bufs.rleft, bufs.cleft
    red, lam, V = bufs.red, bufs.lam, bufs.V
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
                opts: StepOptions, state: np.ndarray, SP: tuple, hist: np.ndarray) -> int:
    """:func:`search_step` until the search ends (a model without load laws: one compiled
    call per search).  At most hist.shape[0] steps (the step cap); at most 4 of them
    leave an unstable equilibrium.  hist (max_steps,) :data:`STEP_RECORD` receives the
    kind, largest generalized force and largest change of every step; the record
    state[0] the steps, escapes and neutral steps.  Returns the code of the last
    :func:`search_step` (not STEPPED)."""
    st = state[0]
    max_steps = hist.shape[0]
    steps = 0
    escapes = 0
    neutral = 0
    while True:
        st.may_step = steps < max_steps
        st.may_escape = escapes < 4 and steps < max_steps
        code = search_step(KP, DP, YP, ZP, S, gen, opts, state, SP)
        if code != STEPPED or steps >= max_steps:  # (the second: never, by the cap)
            st.steps = steps
            st.escapes = escapes
            st.neutral_steps = neutral
            return code if code != STEPPED else CAPPED
        kind = st.kind
        h = hist[steps]
        h.kind = kind
        h.fmax = st.fmax
        h.stepmax = st.stepmax
        steps += 1
        if kind == ESCAPE:
            escapes += 1
        elif kind == NEUTRAL_STEP:
            neutral += 1
