"""Singular postures of a motion (book 6.9): found, located, classified, and the choices
they offer (the other branch at a change point, another driver at a dead point).

The step loop (:func:`openimp.kinematics.sweep.sweep_steps`) keeps the motion
on the branch whose tangent continues the incoming one; this module looks at
what it solved:

* a step whose rank is below the regular one *is* a singular posture;
* a step whose quality index dips far below its neighbours may straddle one:
  the posture between them with the smallest quality index is searched
  (golden section along the steps, every posture solved by Newton) and is
  singular when the index vanishes there;
* a singular posture is a *change point* when the whole Jacobian loses rank
  there (the mechanism gains a freedom for an instant and branches of motion
  meet: the parallelogram folding into the anti-parallelogram, a kite, a
  Bennett loop at its bifurcation), and a *dead point* when only the drivers
  lose control of it (a limit of travel or toggle of a driver);
* :func:`other_branch` finds the posture on the second branch through a change
  point: its tangent t2 = t1 + beta n differs from the incoming t1 by a null
  vector n of the Jacobian, and beta follows from the second-order condition
  of the loop equations on the extra left null vector (the velocity-product
  terms of :func:`~openimp.kinematics.rates.velocity_product`, which are the
  loop equations' second derivative along a direction);
* :func:`new_driver` picks the joint variable that moves most along the
  motion at a dead point of the driver (IMP's automatic driver switching).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from openimp.kinematics.elimination import derivatives
from openimp.kinematics.posture import OK, eliminate_at, newton
from openimp.kinematics.rates import velocity, velocity_product
from openimp.results import Singularity
from openimp.system import Data, State, System, make_data, make_state

CHANGE_POINT = "change point"
DEAD_POINT = "dead point"

#: a step whose quality index is a local minimum below this fraction of the regular
#: value, and at most half its larger neighbour's (a V, as |det J11| is near a simple
#: singular posture, not the flat bottom of a smooth minimum), may straddle a singular
#: posture: it is searched
DIP = 0.2
#: pivot tolerance at a located singular posture: a pivot this small (the Jacobian's
#: entries are of order 1 in internal units) is the rank the posture loses
NEAR = 1e-6
#: a singular posture is a change point when the whole Jacobian's quality index falls
#: below this fraction of its regular value there (a dead point leaves it regular)
CHANGE = 1e-4
#: the searched posture is singular when its quality index falls below this fraction
#: of the regular one (Newton's postures next to a singular one are accurate only to
#: about the square root of its tolerance, and the index with them)
VANISH = 1e-5
#: a posture whose smallest pivot (the Jacobian's entries are of order 1 in internal units)
#: is below this is singular or so near it that its geometric derivatives are noise: the
#: sweep keeps the tangent of the last regular posture, the time step steps over it
#: (:func:`openimp.dynamics.stepping.pass_change`)
NEAR_SINGULAR = 1e-4
_GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0


@dataclass
class Solver:
    """The Newton options of the sweep (internal units) and its drivers."""

    tol: float
    ptol: float
    maxit: int
    dcols: np.ndarray


def quality_of(rank: int, det: float, rest: float, rank_ref: int) -> float:
    """The quality index (6.53) with the missing pivots of a rank drop as factors."""
    for _ in range(rank_ref - rank):
        det *= rest
    return det


def solve_at(system: System, data: Data, state: State, guess: np.ndarray,
             opt: Solver, psi: np.ndarray) -> tuple[bool, np.ndarray, int, float, float]:
    """The posture with the drivers at ``psi`` (internal units) by Newton from ``guess``.

    ``state`` gives the specified columns; returns (converged, q, rank, det,
    largest unpivoted entry).
    """
    S = state.copy()
    S.q[:] = guess
    S.q[opt.dcols] = psi
    st, _, rank, det, rest = newton(system.KP, data.DP, S, system.gen, opt.tol, opt.ptol,
                                    opt.maxit, False)
    return st == OK, S.q.copy(), int(rank), float(det), float(rest)


def _interpolate(Q: np.ndarray, s: float) -> np.ndarray:
    """Rows of Q (three, at s = 0, 1, 2) interpolated quadratically at s."""
    l0 = (s - 1.0) * (s - 2.0) / 2.0
    l1 = -s * (s - 2.0)
    l2 = s * (s - 1.0) / 2.0
    return l0 * Q[0] + l1 * Q[1] + l2 * Q[2]


def locate(system: System, data: Data, state: State, opt: Solver, Q: np.ndarray,
           psi: np.ndarray, rank_ref: int) -> tuple[float, np.ndarray, float, int] | None:
    """The posture of least quality index between the three postures ``Q`` (rows at the
    driver values ``psi``, one row each): (position in [0, 2], q, quality, rank), or
    None when Newton solves none of the postures tried.

    Golden-section search along the piecewise-linear path of the driver
    values; each posture is solved from the quadratic interpolation of ``Q``.
    Right at a singular posture Newton converges only linearly and may stop
    short: such a posture counts as singular (index 0), and the posture
    returned is the solved one nearest the minimum.
    """
    solved: list[tuple[float, np.ndarray, float, int]] = []

    def at(s: float) -> float:
        i = 0 if s <= 1.0 else 1
        p = psi[i] + (s - i) * (psi[i + 1] - psi[i])
        ok, q, rank, det, rest = solve_at(system, data, state, _interpolate(Q, s), opt, p)
        if not ok:
            return 0.0
        qual = quality_of(rank, det, rest, rank_ref)
        solved.append((s, q, qual, rank))
        return qual

    a, b = 0.0, 2.0
    c = b - _GOLDEN * (b - a)
    e = a + _GOLDEN * (b - a)
    fc, fe = at(c), at(e)
    for _ in range(60):
        if fc < fe:
            b, e, fe = e, c, fc
            c = b - _GOLDEN * (b - a)
            fc = at(c)
        else:
            a, c, fc = c, e, fe
            e = a + _GOLDEN * (b - a)
            fe = at(e)
        if b - a < 1e-13:
            break
    s = 0.5 * (a + b)
    if not solved:
        return None
    _, q, qual, rank = min(solved, key=lambda x: abs(x[0] - s))
    return s, q, min(fc, fe, qual), rank


def full_quality(system: System, q: np.ndarray, ptol: float, rank_ref: int = 0
                 ) -> tuple[int, float]:
    """Rank and quality index of the whole Jacobian at ``q`` (nothing specified); the
    missing pivots of a rank below ``rank_ref`` count as factors."""
    rank, det, rest = eliminate_at(system, make_data(system), make_state(system, q), ptol)
    return int(rank), quality_of(int(rank), det, rest, rank_ref)


def gained(system: System, q: np.ndarray, sgc: np.ndarray, ptol: float) -> list[str]:
    """At ``q`` with ``sgc`` specified: the names of the free coordinates beyond the
    specified ones (Euler-Rodrigues parameters excepted), pivots below :data:`NEAR`
    counting as lost."""
    data = make_data(system)
    S = make_state(system, q)
    S.sgc[:] = sgc
    rank = int(eliminate_at(system, data, S, max(ptol, NEAR))[0])
    piv = set(data.view("pcol")[:rank].tolist())
    return [system.var_names[c] for c in range(system.nq)
            if c not in piv and not sgc[c] and system.var_kinds[c] != "er"]


def classify(system: System, q: np.ndarray, sgc: np.ndarray, ptol: float,
             full_ref: tuple[int, float], free_ref: int) -> tuple[str, int, list[str]]:
    """(kind, mobility there, freedoms gained) of a singular posture ``q``.

    A change point when the whole Jacobian degenerates there as well (its rank
    below the regular one of ``full_ref`` = (rank, quality), or its quality
    index below :data:`CHANGE` of the regular one: the mechanism gains
    freedoms), a dead point when only the specified coordinates lose control.
    ``free_ref``: the regular mobility.
    """
    rf, qf = full_quality(system, q, ptol, full_ref[0])
    free = gained(system, q, sgc, ptol)
    if rf < full_ref[0] or qf < CHANGE * full_ref[1]:
        return CHANGE_POINT, free_ref + max(full_ref[0] - rf, 1), free
    return DEAD_POINT, free_ref, free


def candidates(rank: np.ndarray, quality: np.ndarray, rank_ref: int, quality_ref: float
               ) -> tuple[np.ndarray | None, np.ndarray]:
    """The steps that are singular (rank below ``rank_ref``) and the steps whose quality
    index dips as :data:`DIP` says, as two masks; (None, ...) when there are none.

    Written for the ordinary sweep, which has none: one comparison over the
    steps decides that, the rest is done for the few low steps only.
    """
    n = quality.shape[0]
    if n and rank.min() >= rank_ref and quality.min() >= DIP * quality_ref:
        return None, np.zeros(0, bool)  # the ordinary sweep
    low = rank < rank_ref
    dip = np.zeros(n, bool)
    small = np.flatnonzero(quality[1:-1] < DIP * quality_ref) + 1 if n >= 3 else []
    for k in small:
        qk, ql, qr = quality[k], quality[k - 1], quality[k + 1]
        dip[k] = (qk <= ql and qk <= qr and 2.0 * qk <= max(ql, qr)
                  and not (low[k - 1] or low[k] or low[k + 1]))
    if not (low.any() or dip.any()):
        return None, dip
    return low, dip


def find(system: System, state: State, opt: Solver, Q: np.ndarray, D: np.ndarray,
         rank: np.ndarray, quality: np.ndarray, rank_ref: int, quality_ref: float
         ) -> list[tuple[int, bool, float, np.ndarray, float]]:
    """The singular postures along solved steps: (step, landed, position, q, quality).

    Q: (steps x nq) postures, D: (steps x nd) driver values (internal units),
    rank and quality per step, with the regular rank and quality index.
    Steps whose rank dropped are singular postures (one per run of such
    steps); a step whose index dips as :data:`DIP` says is searched between its
    neighbours (:func:`locate`).
    """
    out: list[tuple[int, bool, float, np.ndarray, float]] = []
    n = Q.shape[0]
    low, dip = candidates(rank, quality, rank_ref, quality_ref)
    if low is None:
        return out
    data = make_data(system)
    k = 0
    while k < n:
        if low[k]:
            # a run of rank-deficient steps: the one with the least index stands for it
            e = k
            while e + 1 < n and low[e + 1]:
                e += 1
            m = k + int(np.argmin(quality[k:e + 1]))
            out.append((m, True, float(m), Q[m].copy(), float(quality[m])))
            k = e + 1
            continue
        if dip[k]:
            found = locate(system, data, state, opt, Q[k - 1:k + 2], D[k - 1:k + 2], rank_ref)
            if found is not None and found[2] < VANISH * quality_ref:
                s, q, qual, _ = found
                pos = k - 1 + s
                step = math.ceil(pos - 1e-4)
                out.append((step, abs(pos - round(pos)) < 1e-4, pos, q, qual))
        k += 1
    return out


def _second_order(system: System, data: Data, state: State, rank: int, t: np.ndarray
                  ) -> np.ndarray:
    """The loop equations' second derivative along the direction ``t`` (nq,), as the
    elimination at ``state`` leaves it: the replayed velocity-product right-hand side
    (its unpivoted rows are the components on the left null space)."""
    S = state.copy()
    S.qd[:] = t
    velocity(system.KP, data.DP, S)
    velocity_product(system.KP, data.DP, S, system.gen, rank)
    return data.view("rhs").copy()


def other_branch(system: System, state: State, opt: Solver, qstar: np.ndarray,
                 tangent: np.ndarray, psi: np.ndarray) -> np.ndarray | str:
    """The posture at the driver values ``psi`` on the other branch through the change
    point ``qstar``, or why there is none to take (a sentence).

    ``tangent``: the incoming tangent dq/dpsi times the driver move (nq,),
    so that qstar + tangent is the smooth prediction at ``psi``.  The other
    branch's tangent is tangent + beta n, n the null vector of the restricted
    Jacobian at ``qstar`` (a freedom gained there); beta solves the
    second-order condition y^T Phi''[t, t] = 0 on the extra left null vector y,
    whose t-term vanishes on the smooth branch:
    beta = -2 y^T Phi''[t, n] / y^T Phi''[n, n].  When y^T Phi''[n, n]
    vanishes the other branch leaves along n itself: the drivers stand still
    on it, and it cannot be followed by moving them.
    """
    data = make_data(system)
    S = state.copy()
    S.q[:] = qstar
    rank, _, _ = eliminate_at(system, data, S, max(opt.ptol, NEAR))
    piv = set(data.view("pcol")[:rank].tolist())
    free = [c for c in range(system.nq)
            if c not in piv and not S.sgc[c] and system.var_kinds[c] != "er"]
    if not free:
        return "no freedom is gained there"
    G = np.zeros((system.nq, 1))
    derivatives(data.DP, rank, np.array([free[0]], np.int64), G)
    nvec = G[:, 0] * max(float(np.max(np.abs(tangent))), 1e-12)
    used = np.zeros(data.view("rhs").shape[0], bool)
    used[data.view("prow")[:rank]] = True
    Qt = _second_order(system, data, S, rank, tangent)[~used]
    Qn = _second_order(system, data, S, rank, nvec)[~used]
    Qtn = _second_order(system, data, S, rank, tangent + nvec)[~used]
    if not Qn.size or float(np.max(np.abs(Qn))) < 1e-9 * max(1e-300, float(
            np.max(np.abs(Qtn)))):
        return "the other branch does not move the drivers"
    r = int(np.argmax(np.abs(Qn)))
    cross = 0.5 * (Qtn[r] - Qt[r] - Qn[r])
    beta = -2.0 * cross / Qn[r]
    guess = qstar + tangent + beta * nvec
    ok, q, _, _, _ = solve_at(system, data, S, guess, opt, psi)
    if not ok:
        return "Newton found no posture on the other branch"
    smooth_ok, qs, _, _, _ = solve_at(system, data, S, qstar + tangent, opt, psi)
    step = float(np.max(np.abs(tangent)))
    if smooth_ok and float(np.max(np.abs(q - qs))) < 1e-3 * step:
        return "the two branches are the same to first order there"
    return q


def new_driver(system: System, state: State, ptol: float, old: int, q: np.ndarray,
               previous: np.ndarray) -> tuple[int, float] | None:
    """At a dead point of the driver column ``old``: the variable that moves most along
    the motion, and its move per step (the last step's, in the direction of motion).

    ``q``: the posture reached nearest the dead point; ``previous``: the solved
    posture a step before.  The tangent of the motion is the null vector of the
    Jacobian with the old driver released.  None when no variable can take over.
    """
    data = make_data(system)
    S = state.copy()
    S.q[:] = q
    S.sgc[old] = False
    rank, _, _ = eliminate_at(system, data, S, max(ptol, NEAR))
    piv = set(data.view("pcol")[:rank].tolist())
    free = [c for c in range(system.nq) if c not in piv and not S.sgc[c]]
    if not free:
        return None
    G = np.zeros((system.nq, 1))
    derivatives(data.DP, rank, np.array([free[0]], np.int64), G)
    t = G[:, 0]
    move = q - previous
    if float(t @ move) < 0.0:
        t = -t
    cands = [c for c in range(system.nq)
             if c != old and not S.sgc[c] and system.var_kinds[c] != "er"]
    if not cands:
        return None
    c = max(cands, key=lambda c: abs(t[c]))
    scale = float(np.linalg.norm(move)) / max(float(np.linalg.norm(t)), 1e-300)
    step = t[c] * scale
    if step == 0.0:
        return None
    return c, step


def report(system: System, found: list[tuple[int, bool, float, np.ndarray, float]],
           D: np.ndarray, dnames: list[str], dscale: np.ndarray, sgc: np.ndarray,
           ptol: float, full_ref: tuple[int, float], free_ref: int,
           branches: dict[int, str]
           ) -> list[Singularity]:
    """The :class:`~openimp.results.Singularity` records of :func:`find`'s postures.

    D: driver values per step (internal units); ``branches``: the branch
    taken at a change point (default "smooth"; "other", or why the other could
    not be taken).
    """
    out = []
    for step, landed, pos, q, qual in found:
        kind, mob, free = classify(system, q, sgc, ptol, full_ref, free_ref)
        k0 = min(math.floor(pos), D.shape[0] - 1)
        k1 = min(k0 + 1, D.shape[0] - 1)
        w = pos - k0
        dv = (1.0 - w) * D[k0] + w * D[k1]
        drivers = {n: float(v * s) for n, v, s in zip(dnames, dv, dscale)}
        branch = ""
        if kind == CHANGE_POINT:
            which = branches.get(step, "smooth")
            if which == "other":
                branch = "continued on the other branch (as asked)"
            else:
                branch = "continued on the branch whose tangent continues the motion"
                if which != "smooth":
                    branch += f" ({which})"
        out.append(Singularity(step, landed, pos, drivers, kind, mob, free_ref, free, branch,
                               qual))
    return out
