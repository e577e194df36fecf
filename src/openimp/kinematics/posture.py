"""Posture solution (book 6.5-6.9): Newton-Raphson on the loop equations, and the
checks of the drivers of a motion (mobility, over-specification, passive freedoms).
"""

from __future__ import annotations

import math

import numpy as np

from openimp._jit import njit
from openimp.errors import InputError
from openimp.joints.codes import GIMBAL, SPHERE, SPHERE_GROOVE, SPHERE_PLANE
from openimp.kinematics.elimination import derivatives, eliminate, jacobian, replay
from openimp.kinematics.position import position
from openimp.kinematics.rates import body_operators
from openimp.mat4 import er_norm2
from openimp.system import Data, State, System, data_views, make_data, make_state, model_views

# status codes of the kernels
OK = 0
MAXITER = 1
DIVERGED = 2
#: a step converged on another branch than the one the motion came along
BRANCH = 3
#: the user pressed Ctrl-C (between chunks of a sweep)
INTERRUPTED = 4


@njit(nrt=False, inline="always")
def normalise_er(KP: tuple, q: np.ndarray) -> None:
    """Put every Euler-Rodrigues block of ``q`` back on the unit sphere (the book's Q of
    the spheric and open joints, 6.22 and 6.24, hold only where |e| = 1)."""
    K = model_views(KP)
    for k in range(K.er.shape[0]):
        e0 = K.er[k]
        s = math.sqrt(er_norm2(q, e0))
        if s > 0.0:
            for t in range(4):
                q[e0 + t] /= s


@njit(nrt=False)
def newton(
    KP: tuple, DP: tuple, S: tuple, gen: np.ndarray | None, tol: float, ptol: float,
    maxit: int, chord: bool,
) -> tuple[int, int, int, float, float]:
    """Newton-Raphson on the loop equations (book 6.5); S.q is updated in place.

    The specified coordinates S.sgc stay where they are.  Converged when
    every |E| and every correction is below ``tol`` (internal units); the
    last correction is applied.  ``ptol``: the pivot tolerance of the
    elimination.  Returns (status, iterations, rank, quality, largest
    unpivoted entry).

    With ``chord``, a correction that is already small is followed by
    simplified-Newton steps that reuse the elimination
    (:func:`~openimp.kinematics.elimination.replay`: one pass along the
    tree, no Jacobian and no pivot search) for as long as they contract at
    least tenfold; the convergence test is the same, so the posture is as
    accurate.  The tableau then belongs to a posture one small correction
    away, which serves the predictor but not the derivatives: sweeps that
    want rates run without ``chord``, and their tableau belongs to the final
    posture.
    """
    d = data_views(DP)
    q = S.q
    dq = d.dq
    nq = q.shape[0]
    prev = 1e300
    grow = 0
    rank = 0
    det = 0.0
    rest = 0.0
    for it in range(maxit):
        err = position(KP, DP, S, gen, 1)
        jacobian(KP, DP, S, gen)
        rank, det, rest = eliminate(DP, S.sgc, ptol)
        step = 0.0
        for c in range(nq):
            dq[c] = 0.0
        for k in range(rank):
            v = d.T[d.prow[k], nq]
            dq[d.pcol[k]] = v
            if abs(v) > step:
                step = abs(v)
        if err < tol and step < tol:
            for c in range(nq):
                q[c] += dq[c]
            return OK, it + 1, rank, det, rest
        if err > prev:
            grow += 1
            if grow >= 3 or err > 1e3 * prev:
                return DIVERGED, it + 1, rank, det, rest
        prev = err
        if step > 2.0:  # a correction beyond ~2 rad / 2 model sizes: not "nearby"
            return DIVERGED, it + 1, rank, det, rest
        for c in range(nq):
            q[c] += dq[c]
        normalise_er(KP, q)
        if not chord or step > 1e-3:
            continue
        E = d.E
        for _ in range(4):
            err = position(KP, DP, S, gen, 0)
            replay(DP, rank, E)
            last = step
            step = 0.0
            for k in range(rank):
                v = E[d.prow[k]]
                if abs(v) > step:
                    step = abs(v)
            if err < tol and step < tol:
                for k in range(rank):
                    q[d.pcol[k]] += E[d.prow[k]]
                return OK, it + 1, rank, det, rest
            if step > 0.1 * last:
                break  # contracting too slowly: a fresh Jacobian
            for k in range(rank):
                q[d.pcol[k]] += E[d.prow[k]]
            normalise_er(KP, q)
    return MAXITER, maxit, rank, det, rest


# =============================================================================
# Python side: eliminations at one posture, driver checks
# =============================================================================
def eliminate_at(system: System, data: Data, state: State, ptol: float) -> tuple[int, float, float]:
    """Evaluate and eliminate the loop equations at ``state.q`` (state unchanged).

    Returns (rank, quality index, largest unpivoted entry); the postures,
    screws, tableau and pivots stay in ``data``.  Runs as one iteration of
    the compiled :func:`newton` that accepts any correction, on a copy of the
    state: no compiled entry of its own, which would cost a cold start.
    """
    S = state.copy()
    _, _, rank, det, rest = newton(system.KP, data.DP, S, system.gen, math.inf, ptol, 1, False)
    return rank, det, rest


def sgc_residual(data: Data, sgc: np.ndarray, rank: int) -> float:
    """Largest entry left in the specified columns of the unpivoted rows (6.5.3 e).

    Non-zero means a specified coordinate is determined by the constraints.
    """
    pivoted = set(data.view("prow")[:rank].tolist())
    cols = np.flatnonzero(sgc).tolist()
    worst = 0.0
    for r, row in enumerate(data.view("T").tolist()):  # a few rows: plain Python is quickest
        if r not in pivoted:
            for c in cols:
                worst = max(worst, abs(row[c]))
    return worst


def check_drivers(
    system: System, state: State, dcols: np.ndarray, pivot_tol: float, hold_free: bool,
    data: Data | None = None,
) -> tuple[np.ndarray, int, float]:
    """Check the drivers at ``state`` (whose ``sgc`` marks them): not determined by the
    constraints, enough of them.

    Returns the free coordinates to hold (all of them with ``hold_free``,
    otherwise only passive ones), the rank and the quality index there.
    Raises InputError naming the offending driver or the free coordinates
    that need drivers.  ``data``: scratch to use (a new one otherwise).
    """
    if data is None:
        data = make_data(system)
    sgc = state.sgc
    rank, det, _rest = eliminate_at(system, data, state, pivot_tol)
    nq = system.nq
    if sgc_residual(data, sgc, rank) > 1e-6:
        T = data.view("T")
        used = np.zeros(T.shape[0], bool)
        used[data.view("prow")[:rank]] = True
        bad = [system.var_names[c] for c in dcols if np.any(np.abs(T[~used, c]) > 1e-6)]
        raise InputError(
            f"over-specified motion: driver(s) {', '.join(bad)} are determined by the other "
            f"drivers and the loop constraints (mobility is {nq - rank_full(system, state)}); "
            "remove one of them or drive another joint"
        )
    piv = set(data.view("pcol")[:rank].tolist())
    free = [c for c in range(nq) if c not in piv and not sgc[c]]
    if free and not hold_free:
        passive = passive_freedoms(system, data, state, rank, free)
        active = [c for c in free if c not in passive]
        if active:
            f = nq - rank
            raise InputError(
                f"the mechanism has mobility {f} at its starting posture but only "
                f"{len(dcols)} driver(s) were given; add drivers for "
                f"{len(active)} of the free coordinates found: "
                f"{', '.join(system.var_names[c] for c in active)} "
                "(or pass hold_free=True to keep them at their values)"
            )
    return np.array(free, np.int64), int(rank), float(det)


def redundant_drivers(system: System, cols: np.ndarray, pivot_tol: float) -> list[int]:
    """Indices into ``cols`` (driver columns, in the order given) of the drivers that the
    earlier ones and the loop constraints determine at the modeling posture (6.5.3 e):
    dropping them leaves an independent set, the earliest kept.  Empty when the
    drivers are independent."""
    data = make_data(system)
    kept: list[int] = []
    out: list[int] = []
    for i, c in enumerate(np.asarray(cols, np.int64).tolist()):
        S = make_state(system)
        S.sgc[[*kept, c]] = True
        rank = eliminate_at(system, data, S, pivot_tol)[0]
        if sgc_residual(data, S.sgc, rank) > 1e-6:
            out.append(i)
        else:
            kept.append(c)
    return out


def rank_full(system: System, state: State) -> int:
    """Rank of the whole Jacobian at ``state.q`` (nothing specified)."""
    S = make_state(system, state.q)
    return int(eliminate_at(system, make_data(system), S, 1e-10)[0])


def free_coordinate(system: System, q: np.ndarray | None) -> int | None:
    """A free joint variable (not Euler-Rodrigues) at ``q`` (internal units; default the
    modeling posture) with nothing specified, or None for a structure."""
    data = make_data(system)
    S = make_state(system, q)
    rank = eliminate_at(system, data, S, 1e-10)[0]
    piv = set(data.view("pcol")[:rank].tolist())
    for c in range(system.nq):
        if c not in piv and system.var_kinds[c] != "er":
            return c
    return None


def passive_freedoms(system: System, data: Data, state: State, rank: int,
                     free: list[int]) -> set[int]:
    """Free coordinates that only spin one body between two ball-type joints.

    Such an idle freedom (the coupler of an RSSR turning about the line of its
    ball centres) moves no other body and no point of the mechanism off that
    line, so a kinematic sweep may hold it.  A free coordinate is passive when
    its body operators W_{b,j} (7.20) move exactly one body, that body carries
    exactly two joints, both ball-type (sphere, sphere_plane, sphere_groove),
    and it carries no points.  ``data`` holds the elimination at ``state``.
    """
    K = system.K
    cols = np.array(free, np.int64)
    G = np.zeros((system.nq, len(free)))
    derivatives(data.DP, rank, cols, G)
    W = np.zeros((len(system.bodies), len(free), 6))
    body_operators(system.KP, data.DP, G, W)
    out: set[int] = set()
    for j, c in enumerate(free):
        moving = np.flatnonzero(np.max(np.abs(W[:, j]), axis=1) > 1e-9)
        if len(moving) != 1:
            continue
        b = int(moving[0])
        incident = [h for h in range(len(system.joints)) if K.jb1[h] == b or K.jb2[h] == b]
        if (
            len(incident) == 2
            and all(K.jcode[h] in (SPHERE, SPHERE_PLANE, SPHERE_GROOVE, GIMBAL) for h in incident)
            and not np.any(K.ptbody == b)
        ):
            out.add(c)
    return out
