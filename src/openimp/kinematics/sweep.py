"""Sweeps (book 6.5-6.9, 7, 8): a mechanism moved through a sequence of driver values.

:func:`sweep_steps` solves every step in one compiled loop: a second-order
predictor from the last eliminations' by-products, Newton's correction, step
halving, the quality index, the mobility and the free coordinates per step,
and with rates the velocities and accelerations from the same final
elimination.  :func:`sweep` is the Python entry point; it returns a
:class:`~openimp.results.Trajectory`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, NamedTuple

import numpy as np

from openimp._jit import njit
from openimp.errors import InputError
from openimp.kinematics.elimination import derivatives
from openimp.kinematics.posture import (
    DIVERGED,
    MAXITER,
    OK,
    check_drivers,
    newton,
    normalise_er,
)
from openimp.kinematics.rates import velocity, velocity_product
from openimp.kinematics.track import tracker
from openimp.limits import check_solver_options
from openimp.results import Trajectory
from openimp.system import System, data_views, make_data, make_state

#: the former name of the trajectory of a sweep
SweepResult = Trajectory


class Drive(NamedTuple):
    """The drivers of a sweep (internal units): ``cols`` (nd,) their columns in q,
    ``values``, ``rates``, ``accels`` (steps x nd) (rates and accelerations 0 rows
    when no rates are wanted)."""

    cols: np.ndarray
    values: np.ndarray
    rates: np.ndarray
    accels: np.ndarray


class Solver(NamedTuple):
    """Options of a sweep: Newton tolerance and pivot tolerance (internal units), the
    iteration cap, the number of step halvings allowed, and whether rates are wanted."""

    tol: float
    ptol: float
    maxit: int
    maxhalve: int
    rates: bool


class SweepOut(NamedTuple):
    """Per-step outputs of :func:`sweep_steps` (steps rows each): Q, QD, QDD (x nq;
    QD and QDD 0 rows without rates), quality, rank, fgc (x nq bool), iterations,
    consistency residual (0 rows without rates)."""

    Q: np.ndarray
    QD: np.ndarray
    QDD: np.ndarray
    quality: np.ndarray
    rank: np.ndarray
    fgc: np.ndarray
    iters: np.ndarray
    cons: np.ndarray


@njit(nrt=False, inline="always")
def joint_rates(KP: tuple, DP: tuple, S: tuple, gen: np.ndarray | None, psid: np.ndarray,
                psidd: np.ndarray, rank: int) -> float:
    """Joint velocities (7.19) and accelerations (8.44) at a converged posture.

    From the final elimination of the posture (no second inversion):
    S.qd = G psid with G the first geometric derivatives (d.G), and
    S.qdd = (velocity-product acceleration) + G psidd.  Free coordinates that
    are not driven keep zero rate.  Returns the consistency residual (8.45).
    """
    d = data_views(DP)
    G = d.G
    nq = S.q.shape[0]
    nd = psid.shape[0]
    for c in range(nq):
        s = 0.0
        for j in range(nd):
            s += G[c, j] * psid[j]
        S.qd[c] = s
    velocity(KP, DP, S)
    worst = velocity_product(KP, DP, S, gen, rank)
    for c in range(nq):
        s = 0.0
        for j in range(nd):
            s += G[c, j] * psidd[j]
        S.qdd[c] += s
    return worst


@njit(nrt=False, inline="always")
def _predict(DP: tuple, S: tuple, drive: tuple, k: int, frac: float, has_prev: bool) -> None:
    """S.q = the predicted posture of step k at the fraction ``frac`` of its driver move.

    First order from the last eliminations' by-products (G = -J11^-1 J13);
    the change of G over the last step estimates d2q/dpsi2 along the
    direction of motion (uniform sweeps keep that direction): second order.
    """
    d = data_views(DP)
    nq = S.q.shape[0]
    cols = drive.cols
    nd = cols.shape[0]
    for c in range(nq):
        S.q[c] = d.qlast[c]
    for j in range(nd):
        d.dnew[j] = (drive.values[k, j] - d.qlast[cols[j]]) * frac
        for r in range(nq):
            S.q[r] += d.G[r, j] * d.dnew[j]
    if not has_prev:
        return
    num = 0.0
    den = 0.0
    for j in range(nd):
        num += d.dnew[j] * d.dprev[j]
        den += d.dprev[j] * d.dprev[j]
    ratio = num / den if den > 0.0 else 0.0
    off = 0.0
    nrm = 0.0
    for j in range(nd):
        off += (d.dnew[j] - ratio * d.dprev[j]) ** 2
        nrm += d.dnew[j] * d.dnew[j]
    if off <= 1e-18 * nrm:
        for j in range(nd):
            f = 0.5 * ratio * d.dnew[j]
            for r in range(nq):
                S.q[r] += f * (d.G[r, j] - d.Gp[r, j])


@njit(nrt=False)
def sweep_steps(KP: tuple, DP: tuple, S: tuple, gen: np.ndarray | None, drive: tuple,
                opt: tuple, out: tuple) -> tuple[int, int]:
    """Solve every posture of a sweep (book 6.5, 6.9) into ``out`` (:class:`SweepOut`).

    ``S.q`` holds a closed posture on entry (or one Newton can close) and
    S.sgc the specified columns.  For step k the driver columns go to
    ``drive.values[k]`` (:class:`Drive`): the dependent variables are
    predicted to second order (:func:`_predict`), then corrected by Newton.
    A step that fails is retried from the last good posture in halves, down
    to 2^-maxhalve of it.  With ``opt.rates`` (:class:`Solver`) the joint
    velocities and accelerations for the driver rates and accelerations come
    from the same final elimination (:func:`joint_rates`).  Returns (steps
    solved, status of the first failure or OK); S.q ends at the last solved
    posture.
    """
    d = data_views(DP)
    q = S.q
    nq = q.shape[0]
    cols = drive.cols
    nd = cols.shape[0]
    chord = not opt.rates
    # the elimination at the start posture provides the first predictor
    st, it, rank, det, rest = newton(KP, DP, S, gen, opt.tol, opt.ptol, opt.maxit, False)
    if st != OK:
        return 0, st
    rank_ref = rank
    for j in range(nd):
        d.isdriver[cols[j]] = True
    derivatives(DP, rank, cols, d.G)
    for c in range(nq):
        d.qlast[c] = q[c]
    has_prev = False
    for k in range(drive.values.shape[0]):
        frac = 1.0
        done = False
        total_it = 0
        while not done:
            _predict(DP, S, drive, k, frac, has_prev)
            normalise_er(KP, q)
            last = frac == 1.0
            if last:
                for j in range(nd):
                    q[cols[j]] = drive.values[k, j]
            st, it, rank, det, rest = newton(KP, DP, S, gen, opt.tol, opt.ptol, opt.maxit,
                                             chord)
            total_it += it
            if st == OK:
                for j in range(nd):
                    d.dprev[j] = q[cols[j]] - d.qlast[cols[j]]
                for c in range(nq):
                    d.qlast[c] = q[c]
                for r in range(nq):
                    for j in range(nd):
                        d.Gp[r, j] = d.G[r, j]
                derivatives(DP, rank, cols, d.G)
                has_prev = True
                if last:
                    done = True
                else:
                    frac = min(1.0, 2.0 * frac)
            else:
                frac *= 0.5
                if frac < 0.5 ** opt.maxhalve:
                    for c in range(nq):
                        q[c] = d.qlast[c]
                    return k, st
        for c in range(nq):
            out.Q[k, c] = q[c]
        # (6.53) |det J11| over the regular pivots; where the rank drops (a dead
        # centre) the missing pivots are the tiny entries left, so the index
        # collapses toward zero instead of jumping to a smaller J11's value
        if rank > rank_ref:
            rank_ref = rank
        for _ in range(rank_ref - rank):
            det *= rest
        out.quality[k] = det
        out.rank[k] = rank
        out.iters[k] = total_it
        if opt.rates:
            out.cons[k] = joint_rates(KP, DP, S, gen, drive.rates[k], drive.accels[k], rank)
            for c in range(nq):
                out.QD[k, c] = S.qd[c]
                out.QDD[k, c] = S.qdd[c]
        for c in range(nq):
            S.fgc[c] = not d.isdriver[c]
        for t in range(rank):
            S.fgc[d.pcol[t]] = False
        for c in range(nq):
            out.fgc[k, c] = S.fgc[c]
    return drive.values.shape[0], OK


# =============================================================================
# Python side
# =============================================================================
def _driver_columns(
    system: System, drivers: Mapping[Any, Sequence[float] | np.ndarray], steps: int | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Columns and (steps x nd) values (internal units) of the drivers.

    No drivers at all (a structure, or every freedom held) needs ``steps``.
    """
    if not drivers:
        if steps is None:
            raise InputError(
                "give at least one driver: a joint name mapped to its values "
                "(or drivers={} with steps=N for a structure or a held posture)"
            )
        if isinstance(steps, bool) or not isinstance(steps, (int, np.integer)) or steps < 1:
            raise InputError(f"steps must be a positive whole number of postures, got {steps!r}")
        return np.zeros(0, np.int64), np.zeros((int(steps), 0))
    cols: list[int] = []
    vals: list[np.ndarray] = []
    nsteps = None
    for key, v in drivers.items():
        c = system.var_index(key)
        if system.var_kinds[c] == "er":
            raise InputError(
                f"driver {key!r}: an Euler-Rodrigues parameter cannot be driven; "
                "drive a joint with angle or length variables"
            )
        if c in cols:
            raise InputError(f"driver {key!r} is given twice")
        try:
            a = np.atleast_1d(np.asarray(v, dtype=float))
        except (TypeError, ValueError):
            raise InputError(
                f"driver {key!r}: its values must be numbers, got {v!r:.60}"
            ) from None
        if a.ndim != 1 or a.size == 0 or not np.all(np.isfinite(a)):
            raise InputError(f"driver {key!r}: give a non-empty sequence of finite numbers")
        if nsteps is None:
            nsteps = a.size
        elif a.size != nsteps:
            raise InputError(
                f"driver {key!r} has {a.size} values but the other drivers have {nsteps}; "
                "give every driver the same number of steps"
            )
        cols.append(c)
        vals.append(a / system.var_scale[c])
    return np.array(cols, np.int64), np.stack(vals, axis=1)


def _rate_values(
    system: System, dcols: np.ndarray, nsteps: int, given: Mapping[Any, Any] | None, what: str
) -> np.ndarray:
    """(steps x nd) driver rates or accelerations in internal units (0 where not given)."""
    out = np.zeros((nsteps, dcols.size))
    if not given:
        return out
    pos = {int(c): j for j, c in enumerate(dcols)}
    seen: set[int] = set()
    for key, v in given.items():
        c = system.var_index(key)
        if c in seen:
            raise InputError(f"{what} of {key!r} is given twice")
        seen.add(c)
        if c not in pos:
            raise InputError(f"{what} given for {key!r}, which is not one of the drivers")
        try:
            a = np.atleast_1d(np.asarray(v, dtype=float))
        except (TypeError, ValueError):
            raise InputError(f"{what} of {key!r} must be numbers, got {v!r:.60}") from None
        if a.size == 1:
            a = np.full(nsteps, float(a[0]))
        if a.shape != (nsteps,) or not np.all(np.isfinite(a)):
            raise InputError(
                f"{what} of {key!r}: give one finite value or {nsteps} values (one per step)"
            )
        out[:, pos[c]] = a / system.var_scale[c]
    return out


def start_posture(system: System, start: Any) -> np.ndarray:
    """The starting joint variables (internal units): the modeling posture or ``start``
    (model units, all nq variables)."""
    if start is None:
        return system.q0.copy()
    try:
        q = np.asarray(start, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise InputError(f"start must be {system.nq} numbers (all joint variables)") from None
    if q.shape != (system.nq,) or not np.all(np.isfinite(q)):
        raise InputError(
            f"start must hold {system.nq} finite numbers, one per joint variable "
            f"({', '.join(system.var_names)}); got {q.size}"
        )
    return system.to_internal(q).copy()


def failure_message(
    system: System, names: list[str], dvals: np.ndarray, k: int, status: int
) -> str:
    """Why step ``k`` of a sweep could not be solved, and the last good posture."""
    scale = np.array([system.var_scale[system.var_index(n)] for n in names])
    want = ", ".join(f"{n} = {v:.8g}" for n, v in zip(names, dvals[k] * scale))
    why = {MAXITER: "Newton did not converge", DIVERGED: "Newton diverged"}.get(
        status, f"status {status}")
    last = f"step {k - 1}" if k > 0 else "the start posture"
    return (
        f"step {k}: posture not reachable ({want}): {why} even in steps of 1/4096; "
        f"the mechanism cannot be assembled there (limit of travel or singular posture). "
        f"The last good posture is {last}."
    )


def sweep(
    system: System,
    drivers: Mapping[Any, Sequence[float] | np.ndarray] | None = None,
    rates: Mapping[Any, Sequence[float] | np.ndarray] | None = None,
    accels: Mapping[Any, Sequence[float] | np.ndarray] | None = None,
    *,
    motion: Mapping[Any, Any] | None = None,
    times: Sequence[float] | np.ndarray | None = None,
    tol: float = 1e-10,
    pivot_tol: float = 1e-10,
    maxit: int = 25,
    maxhalve: int = 12,
    hold_free: bool = False,
    start: np.ndarray | None = None,
    steps: int | None = None,
) -> Trajectory:
    """Move ``system`` through the driver values and solve every posture.

    ``drivers`` maps joints (or ``"joint.var"``) to sequences of values of that
    variable (radians or lengths), all of equal length.  ``rates`` and
    ``accels`` map the same keys to their first and second time derivatives
    (one value per step, or one value for all); given either, the result
    carries velocities and accelerations.  Instead of ``drivers``,
    ``motion`` maps keys to functions of time (:mod:`openimp.motion`)
    evaluated at ``times``.  ``drivers={}`` with ``steps=N`` solves a
    structure (mobility 0), or a posture with every freedom held, N times.

    Every posture is solved by Newton-Raphson to ``tol`` internal units (book
    6.7).  A model whose mobility exceeds the number of drivers is an input
    error unless ``hold_free`` keeps the free coordinates at their values
    (passive freedoms, such as the spin of an RSSR coupler, are held anyway).
    An unreachable posture ends the sweep with :attr:`Trajectory.message`
    set; every posture solved before is kept.
    """
    from openimp.motion import as_motion

    check_solver_options(tol, pivot_tol, maxit, maxhalve)
    tarr = None
    if motion is not None:
        if drivers is not None or rates is not None or accels is not None:
            raise InputError("give either motion= (with times=) or drivers/rates/accels, not both")
        if times is None:
            raise InputError("motion= needs times=: the instants at which to solve")
        tarr = np.asarray(times, dtype=float)
        drivers, rates, accels = {}, {}, {}
        for key, mo in motion.items():
            p, v, a = as_motion(mo)(tarr)
            drivers[key], rates[key], accels[key] = p, v, a
    if drivers is None:
        raise InputError("give drivers (joint -> values) or motion= with times=")
    dcols, dvals = _driver_columns(system, drivers, steps)
    nq = system.nq
    nsteps = dvals.shape[0]
    want = rates is not None or accels is not None
    rd = _rate_values(system, dcols, nsteps, rates, "rate")
    ad = _rate_values(system, dcols, nsteps, accels, "acceleration")
    S = make_state(system, start_posture(system, start))
    S.sgc[dcols] = True
    # one scratch for the driver check and the sweep
    data = make_data(system, len(dcols))
    held, rank0, quality0 = check_drivers(system, S, dcols, pivot_tol, hold_free, data)
    # free coordinates that are held (hold_free, or passive) are specified at
    # their values, as IMP holds FGCs in kinematic mode; this keeps the
    # pivoting from trading one free coordinate for another between steps
    S.sgc[held] = True
    nr = nsteps if want else 0
    out = SweepOut(np.zeros((nsteps, nq)), np.zeros((nr, nq)), np.zeros((nr, nq)),
                   np.zeros(nsteps), np.zeros(nsteps, np.int64), np.zeros((nsteps, nq), np.bool_),
                   np.zeros(nsteps, np.int64), np.zeros(nr))
    drive = Drive(dcols, np.ascontiguousarray(dvals), rd, ad)
    done, status = sweep_steps(system.KP, data.DP, S, system.gen, drive,
                               Solver(float(tol), float(pivot_tol), int(maxit), int(maxhalve),
                                      want), out)
    names = [system.var_names[c] for c in dcols]
    msg = "" if done == nsteps else failure_message(system, names, dvals, done, status)
    res = Trajectory(system, out.Q[:done], out.quality[:done], out.rank[:done], out.fgc[:done],
                     out.iters[:done], names, msg, tracker=tracker(system), sgc=S.sgc.copy())
    res.rank_ref, res.quality_ref = rank0, quality0
    if want:
        res.set_rates(out.QD[:done], out.QDD[:done], out.cons[:done])
    if tarr is not None:
        res.time = tarr[:done]
    return res
