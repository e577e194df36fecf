"""Sweeps (book 6.5-6.9, 7, 8): a mechanism moved through a sequence of driver values.

:func:`sweep_steps` solves every step in one compiled loop: a second-order
predictor from the last eliminations' by-products, Newton's correction, step
halving, the quality index, the mobility and the free coordinates per step,
and with rates the velocities and accelerations from the same final
elimination.  :func:`sweep` is the Python entry point; it returns a
:class:`~openimp.results.Trajectory`.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any, NamedTuple, Protocol

import numpy as np

from openimp._jit import njit
from openimp.errors import InputError, renamed
from openimp.kinematics import singular as sing
from openimp.kinematics.elimination import derivatives
from openimp.kinematics.inputs import names_of, start_state
from openimp.kinematics.posture import (
    BRANCH,
    DIVERGED,
    INTERRUPTED,
    MAXITER,
    OK,
    check_drivers,
    newton,
    normalise_er,
)
from openimp.kinematics.rates import velocity, velocity_product
from openimp.kinematics.singular import NEAR_SINGULAR
from openimp.kinematics.track import tracker
from openimp.limits import check_solver_options
from openimp.results import DriverSwitch, Singularity, Trajectory
from openimp.system import State, System, data_views, make_data, make_state

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
    iteration cap, the number of step halvings allowed, whether rates are wanted, and
    whether the step loop resumes where its last call stopped (the data keeps the
    last posture and the tangents: a long sweep is solved in chunks, between which
    progress is told and Ctrl-C heard, exactly as in one call), and the range of
    steps to solve."""

    tol: float
    ptol: float
    maxit: int
    maxhalve: int
    rates: bool
    resume: bool = False
    #: solve only the steps first..last-1 of the drive (last -1: to its end), for a
    #: caller that does more between steps (the force analysis of one pass)
    first: int = 0
    last: int = -1


class SweepOut(NamedTuple):
    """Per-step outputs of :func:`sweep_steps` (steps rows each): Q, QD, QDD (x nq;
    QD and QDD 0 rows without rates), quality, rank, fgc (x nq bool), iterations,
    consistency residual (0 rows without rates), and ``jump``: how far the step moved
    across the tangent-continuous prediction, relative to the predicted step (about 0
    on a smooth branch; see :data:`JUMP`)."""

    Q: np.ndarray
    QD: np.ndarray
    QDD: np.ndarray
    quality: np.ndarray
    rank: np.ndarray
    fgc: np.ndarray
    iters: np.ndarray
    cons: np.ndarray
    jump: np.ndarray


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


#: steps solved per call of the step loop when a sweep tells its progress
CHUNK = 2000

#: a converged step that moved across the tangent-continuous prediction by more than this
#: fraction of the predicted step left the branch the motion came along (a branch change
#: at a change point or bifurcation): it is retried in smaller steps, where the prediction
#: error falls as the cube of the step and the branches part only linearly.  Along the
#: prediction (a driver near its end of travel) any change is accepted.
JUMP = 0.1


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

    Singular postures (book 6.9): the prediction always continues the
    tangent of the motion.  At a posture where the rank of the Jacobian drops
    (a change point, a bifurcation, a dead point), the geometric derivatives
    are not determined there (nor, within :data:`NEAR_SINGULAR`, near it):
    the step keeps those of the last regular posture, so the next prediction
    leaves the singular posture along the incoming tangent instead of a
    direction the rank deficiency made up.  A
    converged step that moved across the prediction by more than :data:`JUMP`
    of the step (another branch) is retried in halves.
    """
    d = data_views(DP)
    q = S.q
    nq = q.shape[0]
    cols = drive.cols
    nd = cols.shape[0]
    chord = not opt.rates
    if opt.resume:  # the last call left its posture, tangents and regular rank in the data
        rank_ref = d.loop[0]
        has_prev = d.loop[1] != 0
    else:
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
    kend = drive.values.shape[0] if opt.last < 0 else opt.last
    for k in range(opt.first, kend):
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
            for c in range(nq):
                d.qpred[c] = q[c]
            st, it, rank, det, rest = newton(KP, DP, S, gen, opt.tol, opt.ptol, opt.maxit,
                                             chord)
            total_it += it
            jump = 0.0
            if st == OK and has_prev:
                # the part of the step across the predicted direction, relative to the
                # predicted step: another branch leaves sideways; the end of travel of a
                # driver (a fold) only shortens or lengthens the step along it
                aa = 0.0
                ap = 0.0
                pp = 0.0
                for c in range(nq):
                    a = q[c] - d.qlast[c]
                    pr = d.qpred[c] - d.qlast[c]
                    aa += a * a
                    ap += a * pr
                    pp += pr * pr
                if pp > 0.0:
                    jump = math.sqrt(max(aa - ap * ap / pp, 0.0) / pp)
                if jump > JUMP and math.sqrt(jump * jump * pp) > 100.0 * opt.tol:
                    st = BRANCH  # another branch: retry the step in halves
            if st == OK:
                for j in range(nd):
                    d.dprev[j] = q[cols[j]] - d.qlast[cols[j]]
                for c in range(nq):
                    d.qlast[c] = q[c]
                if rank > rank_ref:
                    rank_ref = rank
                smallest = 1.0
                for t in range(rank):
                    smallest = min(smallest, abs(1.0 / d.pinv[t]))
                if rank == rank_ref and smallest > NEAR_SINGULAR:
                    # a singular posture keeps the incoming tangent
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
                    d.loop[0] = rank_ref
                    d.loop[1] = 1 if has_prev else 0
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
        out.jump[k] = jump
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
    d.loop[0] = rank_ref
    d.loop[1] = 1 if has_prev else 0
    return kend, OK


# =============================================================================
# Python side
# =============================================================================
def driver_columns(
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
    lookup = system.var_lookup
    for key, v in drivers.items():
        c = lookup.get(key) if isinstance(key, str) else None
        if c is None:
            c = system.var_index(key)
        if system.var_kinds[c] == "er":
            raise InputError(
                f"driver {key!r}: an Euler-Rodrigues parameter cannot be driven; "
                "drive a joint with angle or length variables"
            )
        if c in cols:
            raise InputError(f"driver {key!r} is given twice")
        try:
            a = np.asarray(v, dtype=float)
        except (TypeError, ValueError):
            raise InputError(
                f"driver {key!r}: its values must be numbers, got {v!r:.60}"
            ) from None
        if a.ndim == 0:
            a = a.reshape(1)
        if a.ndim != 1 or a.size == 0 or not np.isfinite(a).all():
            raise InputError(f"driver {key!r}: give a non-empty sequence of finite numbers")
        if nsteps is None:
            nsteps = a.size
        elif a.size != nsteps:
            raise InputError(
                f"driver {key!r} has {a.size} values but the other drivers have {nsteps}; "
                "give every driver the same number of steps"
            )
        cols.append(c)
        vals.append(a)
    out = np.empty((len(vals[0]), len(vals)))
    scale = system.var_scale
    for k, (c, a) in enumerate(zip(cols, vals, strict=True)):
        out[:, k] = a
        out[:, k] /= scale[c]
    return np.array(cols, np.int64), out


def _rate_values(
    system: System, dcols: np.ndarray, nsteps: int, given: Mapping[Any, Any] | None, what: str
) -> np.ndarray:
    """(steps x nd) driver rates or accelerations in internal units (0 where not given)."""
    out = np.zeros((nsteps, dcols.size))
    if not given:
        return out
    pos = {int(c): j for j, c in enumerate(dcols)}
    seen: set[int] = set()
    lookup = system.var_lookup
    for key, v in given.items():
        c = lookup.get(key) if isinstance(key, str) else None
        if c is None:
            c = system.var_index(key)
        if c in seen:
            raise InputError(f"{what} of {key!r} is given twice")
        seen.add(c)
        if c not in pos:
            raise InputError(f"{what} given for {key!r}, which is not one of the drivers")
        try:
            a = np.asarray(v, dtype=float)
        except (TypeError, ValueError):
            raise InputError(f"{what} of {key!r} must be numbers, got {v!r:.60}") from None
        if a.size == 1:
            a = a.reshape(1)
        if a.shape != (nsteps,) and a.shape != (1,):
            raise InputError(
                f"{what} of {key!r}: give one finite value or {nsteps} values (one per step)"
            )
        out[:, pos[c]] = a  # one value broadcasts to every step
    if not np.isfinite(out).all():  # one check for all: then find the culprit
        bad = int(np.flatnonzero(~np.isfinite(out).all(axis=0))[0])
        key = next(k for k in given if system.var_index(k) == int(dcols[bad]))
        raise InputError(
            f"{what} of {key!r}: give one finite value or {nsteps} values (one per step)"
        )
    out /= system.var_scale[dcols]
    return out


def failure_message(
    system: System, names: list[str], dvals: np.ndarray, k: int, status: int
) -> str:
    """Why step ``k`` of a sweep could not be solved, and the last good posture."""
    scale = np.array([system.var_scale[system.var_index(n)] for n in names])
    want = ", ".join(f"{n} = {v:.8g}" for n, v in zip(names, dvals[k] * scale))
    why = {MAXITER: "Newton did not converge", DIVERGED: "Newton diverged",
           BRANCH: "every solution Newton found left the branch of the motion"}.get(
        status, f"status {status}")
    last = f"step {k - 1}" if k > 0 else "the start posture"
    return (
        f"step {k}: posture not reachable ({want}): {why} even in steps of 1/4096; "
        f"the mechanism cannot be assembled there (limit of travel or singular posture). "
        f"The last good posture is {last}."
    )


class MotionInputs(NamedTuple):
    """The drivers of a motion as given to :func:`sweep`, checked: ``cols`` (nd,) their
    columns, ``values``, ``rates``, ``accels`` (steps x nd, internal units; rates
    0 where none are given), ``times`` (steps,) or None, ``with_rates``: whether
    rates or accelerations were given."""

    cols: np.ndarray
    values: np.ndarray
    rates: np.ndarray
    accels: np.ndarray
    times: np.ndarray | None
    with_rates: bool


def motion_inputs(
    system: System, drivers: Mapping[Any, Any] | None, rates: Mapping[Any, Any] | None,
    accels: Mapping[Any, Any] | None, motion: Mapping[Any, Any] | None,
    times: Sequence[float] | np.ndarray | None, steps: int | None,
) -> MotionInputs:
    """The drivers of :func:`sweep` (values, or motions of time at ``times``) checked and
    in internal units; input errors name the driver."""
    from openimp.motion import as_motion

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
    dcols, dvals = driver_columns(system, drivers, steps)
    nsteps = dvals.shape[0]
    rd = _rate_values(system, dcols, nsteps, rates, "rate")
    ad = _rate_values(system, dcols, nsteps, accels, "acceleration")
    return MotionInputs(dcols, dvals, rd, ad, tarr, rates is not None or accels is not None)


class StepKernel(Protocol):
    """A kernel that solves the steps of a sweep and does more at each of them (the force
    analysis of :mod:`openimp.dynamics` evaluates every step as it is solved):
    ``allocate(nsteps)`` before the sweep, then ``run(system, data, S, drive, opt,
    part, k0)`` in place of :func:`sweep_steps` for the steps from k0 on, with
    the same result."""

    def allocate(self, nsteps: int) -> None: ...

    def run(self, system: System, data: Any, S: Any, drive: Drive, opt: Solver,
            part: SweepOut, k0: int) -> tuple[int, int]: ...


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
    q: Any = None,
    state: State | None = None,
    specified: Any = (),
    steps: int | None = None,
    branch: str = "smooth",
    at_limit: str = "stop",
    progress: Callable[[float, float], None] | None = None,
    kernel: StepKernel | None = None,
    warn: bool = True,
    **deprecated_names: Any,
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

    Singular postures (book 6.9) are reported in
    :attr:`Trajectory.singularities` (:mod:`openimp.kinematics.singular`).
    At a change point, where branches of motion meet, the motion continues on
    the branch whose tangent continues the incoming motion
    (``branch="smooth"``, what a real mechanism with inertia does) or, with
    ``branch="other"``, on the other branch.  At a dead point of the driver (its
    limit of travel) the sweep stops with a message (``at_limit="stop"``) or,
    with ``at_limit="switch"``, drives the joint variable that moves most there
    and goes on for the remaining steps (IMP's automatic driver switching,
    reported in :attr:`Trajectory.switches`).

    ``q``: the start posture, model units (the nq joint variables, or a
    mapping of joint variables to values; default the modeling posture), or
    ``state``: a :class:`~openimp.system.State` (internal units) to start
    from.  ``specified``: joint variables (names or ``"joint.var"``) held at
    their start values besides the drivers.  ``start`` is the deprecated name
    of ``q``.

    ``progress(done, total)`` (steps solved, steps) is called as the steps
    are solved (in chunks of :data:`CHUNK`); Ctrl-C then ends the sweep with
    every step solved before (:attr:`Trajectory.interrupted`).

    ``kernel`` (:class:`StepKernel`), for analyses built on the sweep: solves
    the steps in place of :func:`sweep_steps` and does its own work at each
    (rates are then always computed: zero where none are given).

    A sweep that stops before its last step (a limit of travel, a posture that
    cannot be reached) returns the steps solved before it and, with ``warn``
    (default), logs why as a warning of the ``openimp`` logger, so that an
    incomplete result is never taken for a whole one in silence.
    """
    if deprecated_names:  # start=, the old name of q
        old = renamed("sweep", {"q": q, **deprecated_names} if q is not None
                      else deprecated_names, {"start": "q"})
        if old.keys() - {"q"}:
            raise InputError(f"sweep: unknown option(s) {', '.join(sorted(old.keys() - {'q'}))}")
        q = old["q"]
    S = make_state(system, start_state(system, q, state, "sweep").q)
    check_solver_options(tol, pivot_tol, maxit, maxhalve)
    if progress is not None and not callable(progress):
        raise InputError(f"sweep: progress must be a callable progress(done, total), got "
                         f"{progress!r}")
    if branch not in ("smooth", "other"):
        raise InputError(f"branch must be 'smooth' or 'other', got {branch!r}")
    if at_limit not in ("stop", "switch"):
        raise InputError(f"at_limit must be 'stop' or 'switch', got {at_limit!r}")
    inp = motion_inputs(system, drivers, rates, accels, motion, times, steps)
    dcols, dvals, rd, ad, tarr = inp.cols, inp.values, inp.rates, inp.accels, inp.times
    nq = system.nq
    nsteps = dvals.shape[0]
    want = inp.with_rates or kernel is not None
    S.sgc[dcols] = True
    S.sgc[[system.var_index(k) for k in names_of(specified, "sweep")]] = True
    # one scratch for the driver check and the sweep
    data = make_data(system, len(dcols))
    # the same drivers from the same start were checked before: a study's repeated sweeps
    key = ("drivers", dcols.tobytes(), S.sgc.tobytes(), S.q.tobytes(), float(pivot_tol),
           bool(hold_free))
    checked = system.memo.get(key)
    if checked is None:
        checked = system.memo[key] = check_drivers(system, S, dcols, pivot_tol, hold_free,
                                                   data)
        if len(system.memo) > 64:  # a bounded memory of starts
            system.memo.pop(next(iter(system.memo)))
    held, rank0, quality0 = checked
    # free coordinates that are held (hold_free, or passive) are specified at
    # their values, as IMP holds FGCs in kinematic mode; this keeps the
    # pivoting from trading one free coordinate for another between steps
    S.sgc[held] = True
    nr = nsteps if want else 0
    out = SweepOut(np.zeros((nsteps, nq)), np.zeros((nr, nq)), np.zeros((nr, nq)),
                   np.zeros(nsteps), np.zeros(nsteps, np.int64), np.zeros((nsteps, nq), np.bool_),
                   np.zeros(nsteps, np.int64), np.zeros(nr), np.zeros(nsteps))
    if kernel is not None:
        kernel.allocate(nsteps)
    run = _Run(system, data, S, dcols, np.ascontiguousarray(dvals), rd, ad, out,
               Solver(float(tol), float(pivot_tol), int(maxit), int(maxhalve), want),
               rank0, quality0, kernel)
    done, status = run.solve(branch, at_limit, progress)
    names = [system.var_names[c] for c in dcols]
    if run.interrupted:
        msg = f"step {done}: interrupted by the user (Ctrl-C); the {done} steps before it are kept"
    else:
        msg = "" if done == nsteps else failure_message(system, names, run.values, done, status)
    res = Trajectory(system, out.Q[:done], out.quality[:done], out.rank[:done], out.fgc[:done],
                     out.iters[:done], names, msg, tracker=tracker(system), sgc=S.sgc.copy())
    res.rank_ref, res.quality_ref = rank0, quality0
    res.interrupted = run.interrupted
    res.singularities = run.singularities(done)
    res.switches = run.switches
    if want:
        res.set_rates(out.QD[:done], out.QDD[:done], out.cons[:done])
    if tarr is not None:
        res.time = tarr[:done]
    if warn and msg and not run.interrupted:  # an incomplete result is said, not only kept
        logging.getLogger("openimp").warning(
            "sweep: %s (the result keeps the %d of %d steps solved before it: "
            "res.complete is False, res.message says why)", msg, done, nsteps)
    return res


class _Run:
    """A sweep in segments: the step loop, and the choices at singular postures between.

    One call of :func:`sweep_steps` does the whole motion unless the user
    asked for the other branch at a change point or a driver switch at a
    dead point; then each such posture ends a segment and the next starts
    from the chosen posture (:mod:`openimp.kinematics.singular`).
    """

    def __init__(self, system: System, data: Any, S: Any, dcols: np.ndarray,
                 values: np.ndarray, rd: np.ndarray, ad: np.ndarray, out: SweepOut,
                 opt: Solver, rank0: int, quality0: float, kernel: StepKernel | None = None
                 ) -> None:
        self.system, self.data, self.S, self.out, self.opt = system, data, S, out, opt
        self.kernel = kernel
        self.opt_resume = opt._replace(resume=True)
        self.isdriver = data.view("isdriver")
        # fresh arrays of motion_inputs, ours to change (a driver switch rewrites them)
        self.values, self.rd, self.ad = values, rd, ad
        self.rank0, self.quality0 = rank0, quality0
        #: (first step, driver columns, specified columns) of every segment
        self.segments: list[tuple[int, np.ndarray, np.ndarray]] = []
        self.cols = dcols
        self.branches: dict[int, str] = {}
        #: change points where the other branch was taken (found, segment start)
        self.crossed: list[tuple[int, bool, float, np.ndarray, float, int]] = []
        self.switches: list[DriverSwitch] = []
        self.handled = -1
        self.interrupted = False
        #: dead points where the sweep stopped or switched: (step, posture, what was done)
        self.limits: list[tuple[int, np.ndarray, str]] = []
        self.start = S.q.copy()
        self._full_ref: tuple[int, float] | None = None

    @property
    def full_ref(self) -> tuple[int, float]:
        """Rank and quality index of the whole Jacobian at the start posture (regular)."""
        if self._full_ref is None:
            self._full_ref = sing.full_quality(self.system, self.start, self.opt.ptol)
        return self._full_ref

    def _kernel(self, k0: int, k1: int, resume: bool) -> tuple[int, int]:
        """Solve steps k0..k1-1 from the state's posture (or, with ``resume``, where the
        last call stopped); (steps solved from k0, status)."""
        o = self.out
        if not resume:
            self.isdriver[:] = False
            self.segments.append((k0, self.cols.copy(), self.S.sgc.copy()))
        if k0 == 0 and k1 == self.values.shape[0]:  # the whole sweep in one call
            part, drive = o, Drive(self.cols, self.values, self.rd, self.ad)
        else:  # rows of C-ordered arrays: contiguous views
            sl = slice(k0, k1)
            rs = sl if o.QD.shape[0] else slice(0, 0)
            part = SweepOut(o.Q[sl], o.QD[rs], o.QDD[rs], o.quality[sl], o.rank[sl],
                            o.fgc[sl], o.iters[sl], o.cons[rs], o.jump[sl])
            drive = Drive(self.cols, self.values[sl], self.rd[sl], self.ad[sl])
        opt = self.opt_resume if resume else self.opt
        if self.kernel is not None:
            return self.kernel.run(self.system, self.data, self.S, drive, opt, part, k0)
        return sweep_steps(self.system.KP, self.data.DP, self.S, self.system.gen, drive, opt,
                           part)

    def solve(self, branch: str, at_limit: str,
              progress: Callable[[float, float], None] | None) -> tuple[int, int]:
        """Every step, with the user's choices; (steps solved, status).  With
        ``progress`` the steps are solved in chunks of :data:`CHUNK`, told after each;
        Ctrl-C between chunks ends the sweep with what was solved."""
        n = self.values.shape[0]
        k0, resume = 0, False
        try:
            while True:
                k1 = min(n, k0 + CHUNK) if progress is not None else n
                done, status = self._kernel(k0, k1, resume)
                k = k0 + done
                seg = self.segments[-1][0]
                if branch == "other":
                    nxt = self._other(seg, k)
                    if nxt is not None:
                        k0, resume = nxt, False
                        continue
                if status == OK and k < n:  # a chunk solved: on with the next
                    k0, resume = k, True
                    if progress is not None:
                        progress(float(k), float(n))
                    continue
                if k < n and at_limit == "switch" and self._switch(k):
                    k0, resume = k, False
                    continue
                if k < n:
                    self.limits.append((k, self.S.q.copy(), "the sweep stops there"))
                k0 = k
                if progress is not None:
                    progress(float(k), float(n))
                return k, status
        except KeyboardInterrupt:
            self.interrupted = True
            return k0, INTERRUPTED

    def _found(self, k0: int, k1: int) -> list[tuple[int, bool, float, np.ndarray, float]]:
        """Singular postures among the steps k0..k1-1 of the segment starting at k0."""
        if k1 - k0 < 1:
            return []
        o = self.out
        rank_ref = max(self.rank0, int(o.rank[:k1].max()))
        quality_ref = max(self.quality0, float(o.quality[:k1].max()))
        if sing.candidates(o.rank[k0:k1], o.quality[k0:k1], rank_ref, quality_ref)[0] is None:
            return []  # the ordinary sweep: nothing to search
        seg = [s for s in self.segments if s[0] <= k0][-1]
        S = self.S.copy()
        S.sgc[:] = seg[2]
        opt = sing.Solver(self.opt.tol, self.opt.ptol, self.opt.maxit, seg[1])
        Q = o.Q[k0:k1]
        return sing.find(self.system, S, opt, Q, Q[:, seg[1]], o.rank[k0:k1],
                         o.quality[k0:k1], rank_ref, quality_ref)

    def _other(self, k0: int, k: int) -> int | None:
        """After a segment: the first change point not yet handled; solve the first step
        after it on the other branch and return that step (None: nothing to do)."""
        o = self.out
        for step, landed, pos, q, _qual in self._found(k0, k):
            step += k0
            pos += k0
            if step <= self.handled:
                continue
            kind = sing.classify(self.system, q, self.S.sgc, self.opt.ptol, self.full_ref,
                                 self.system.nq - self.rank0)[0]
            if kind != sing.CHANGE_POINT:
                continue
            self.handled = step
            # the steps before and after it, far enough to tell the branches apart
            k1 = math.ceil(pos + 0.01)
            kb = math.floor(pos - 0.01)
            if k1 >= k or kb < 0:
                return None
            tangent = (q - o.Q[kb]) * (k1 - pos) / (pos - kb)
            opt = sing.Solver(self.opt.tol, self.opt.ptol, self.opt.maxit, self.cols)
            q2 = sing.other_branch(self.system, self.S, opt, q, tangent, self.values[k1])
            if isinstance(q2, str):
                self.branches[step] = f"the other branch was asked for, but {q2}"
                continue
            self.branches[step] = "other"
            # the segment ends before the step after it: remember the posture for the report
            self.crossed.append((step, landed, pos, q.copy(), _qual, k0))
            self.S.q[:] = q2
            return k1
        return None

    def _switch(self, k: int) -> bool:
        """At a dead point reached at step k: drive another variable from there on
        (True), or leave the failure (False)."""
        if self.cols.size != 1:
            return False
        S, o = self.S, self.out
        previous = o.Q[k - 1] if k >= 1 else S.q
        q = S.q.copy()
        kind = sing.classify(self.system, q, S.sgc, self.opt.ptol, self.full_ref,
                             self.system.nq - self.rank0)[0]
        if kind != sing.DEAD_POINT:
            return False
        old = int(self.cols[0])
        picked = sing.new_driver(self.system, S, self.opt.ptol, old, q, previous)
        if picked is None:
            return False
        c, step = picked
        if k >= 2:  # as far along the motion per step as the steps before took
            arcs = np.linalg.norm(np.diff(o.Q[:k], axis=0), axis=1)
            step *= float(np.median(arcs)) / max(float(np.linalg.norm(q - previous)), 1e-300)
        m = self.values.shape[0] - k
        self.values[k:, 0] = q[c] + step * np.arange(1, m + 1)
        rate = o.QD[k - 1, c] / self.system.var_scale[c] if o.QD.shape[0] and k >= 1 else 0.0
        self.rd[k:, 0] = rate
        self.ad[k:, 0] = 0.0
        S.sgc[old] = False
        S.sgc[c] = True
        self.cols = np.array([c], np.int64)
        names = self.system.var_names
        self.switches.append(DriverSwitch(k, names[old], names[c],
                                          float(self.values[k, 0] * self.system.var_scale[c])))
        self.limits.append((k, q, f"the input switched to {names[c]} there"))
        return True

    def singularities(self, done: int) -> list[Singularity]:
        """The singular postures of the solved steps, segment by segment."""
        out: list[Singularity] = []
        if len(self.segments) == 1 and not self.limits and not self.crossed:
            r, qu = self.out.rank[:done], self.out.quality[:done]
            if done == 0 or (r.min() >= max(self.rank0, r.max()) and qu.min()
                             >= sing.DIP * max(self.quality0, qu.max())):
                return out  # the ordinary sweep: no step low (as _found decides)
        bounds = [s[0] for s in self.segments] + [done]
        seen: set[int] = set()
        for (k0, cols, sgc), k1 in zip(self.segments, bounds[1:]):
            k1 = min(k1, done)
            found = [(st + k0, la, pos + k0, q, qu) for st, la, pos, q, qu
                     in self._found(k0, k1)]
            found += [c[:5] for c in self.crossed if c[5] == k0]
            found.sort(key=lambda f: f[2])
            found = [f for f in found if f[0] not in seen]
            if not found:
                continue
            seen.update(f[0] for f in found)
            names = [self.system.var_names[c] for c in cols]
            scale = np.array([self.system.var_scale[c] for c in cols])
            out += sing.report(self.system, found, self.out.Q[:, cols], names, scale, sgc,
                               self.opt.ptol, self.full_ref, self.system.nq - self.rank0,
                               self.branches)
        for k, q, what in self.limits:  # the postures nearest where the input gave out
            seg = ([s for s in self.segments if s[0] < k] or self.segments)[-1]
            kind, mob, free = sing.classify(self.system, q, seg[2], self.opt.ptol,
                                            self.full_ref, self.system.nq - self.rank0)
            if kind != sing.DEAD_POINT:
                continue
            drivers = {self.system.var_names[c]: float(q[c] * self.system.var_scale[c])
                       for c in seg[1]}
            out.append(Singularity(k, False, k - 0.5, drivers, kind, mob,
                                   self.system.nq - self.rank0, free, what, 0.0))
        out.sort(key=lambda r: r.position)
        return out
