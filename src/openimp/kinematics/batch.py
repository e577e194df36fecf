"""Batches of variants: one mechanism with other dimensions or inputs, swept in parallel.

The variants share the topology and joint kinds (the int and bool buffers of
the packed model) and differ in the float buffer (constants, shape matrices,
reference postures, points), their starting variables and their driver
values.  :func:`batch_kernel` runs :func:`~openimp.kinematics.sweep.sweep_steps`
for every variant over the cores, each with its own data and state.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from openimp._jit import njit, prange
from openimp.errors import InputError
from openimp.kinematics.posture import check_drivers
from openimp.kinematics.sweep import (
    Drive,
    Solver,
    SweepOut,
    driver_columns,
    failure_message,
    sweep_steps,
)
from openimp.kinematics.track import tracker
from openimp.limits import check_solver_options
from openimp.results import Trajectory
from openimp.system import State, System, make_data, make_state, read_only


@njit
def _variant(KI: np.ndarray, KFs: np.ndarray, KB: np.ndarray, DP0: tuple, S0: tuple,
             gen: np.ndarray | None, drive: tuple, opt: tuple, out: tuple, v: int) -> None:
    """The sweep of variant v of :func:`batch_kernel`, on data and a state of its own."""
    Qs, quality, rank, fgc, iters, jump, done, status = out
    DP = (DP0[0].copy(), np.zeros_like(DP0[1]), np.zeros_like(DP0[2]))
    S = State(S0.t.copy(), S0.q[v].copy(), S0.qd.copy(), S0.qdd.copy(), S0.sgc.copy(),
              S0.fgc.copy(), S0.load_sign.copy())
    dv = Drive(drive.cols, drive.values[v], drive.rates, drive.accels)
    o = SweepOut(Qs[v], Qs[v, :0], Qs[v, :0], quality[v], rank[v], fgc[v], iters[v],
                 quality[v, :0], jump[v])
    n, st = sweep_steps((KI, KFs[v], KB), DP, S, gen, dv, opt, o)
    done[v] = n
    status[v] = st


@njit(parallel=True)
def batch_kernel(KI: np.ndarray, KFs: np.ndarray, KB: np.ndarray, DP0: tuple, S0: tuple,
                 gen: np.ndarray | None, drive: tuple, opt: tuple, out: tuple) -> None:
    """Run :func:`~openimp.kinematics.sweep.sweep_steps` for every variant v in parallel.

    KI, KB: the shared int and bool buffers of the packed models; KFs
    (variants x nf): their float buffers.  DP0: packed data of one variant
    (its header is copied, its arrays allocated per variant); S0: the state
    template, whose ``q`` is (variants x nq) start postures.  drive: the
    driver columns, values (variants x steps x nd) and two unused rate arrays;
    out: (Q, quality, rank, fgc, iterations, jump) with a leading variant axis, then
    ``done`` and ``status`` per variant.  The loop body is a function of its
    own: numba 0.68 loses writes made in a parallel loop through the arrays
    of a tuple argument.
    """
    for v in prange(KFs.shape[0]):
        _variant(KI, KFs, KB, DP0, S0, gen, drive, opt, out, v)


class BatchResult:
    """Sweeps of many variants: one :class:`~openimp.results.Trajectory` per variant,
    on demand.

    ``q`` holds every variant's joint variables (variants x steps x nq, model
    units); ``solved[v]`` is the number of steps variant v reached.
    """

    def __init__(self, systems: Sequence[System], Q: np.ndarray, quality: np.ndarray,
                 rank: np.ndarray, fgc: np.ndarray, iters: np.ndarray, solved: np.ndarray,
                 messages: list[str], drivers: list[str], sgc: np.ndarray) -> None:
        self.systems = list(systems)
        self._Q = Q
        self.quality = quality
        self.rank = rank
        self._fgc = fgc
        self.iterations = iters
        self.solved = solved
        self.messages = messages
        self.drivers = drivers
        self._sgc = sgc

    def __len__(self) -> int:
        return len(self.systems)

    @property
    def q(self) -> np.ndarray:
        """Joint variables (variants x steps x nq), model units (NaN past a failure)."""
        out = self._Q * np.stack([s.var_scale for s in self.systems])[:, None, :]
        for v, n in enumerate(self.solved):
            out[v, n:] = np.nan
        return out

    def __getitem__(self, v: int) -> Trajectory:
        n = int(self.solved[v])
        s = self.systems[v]
        return Trajectory(s, self._Q[v, :n], self.quality[v, :n], self.rank[v, :n],
                          self._fgc[v, :n], self.iterations[v, :n], self.drivers,
                          self.messages[v], tracker=tracker(s), sgc=self._sgc)


def sweep_batch(
    systems: Sequence[System],
    drivers: Mapping[Any, Sequence[float] | np.ndarray],
    *,
    tol: float = 1e-10,
    pivot_tol: float = 1e-10,
    maxit: int = 25,
    maxhalve: int = 12,
    hold_free: bool = False,
) -> BatchResult:
    """Sweep many variants of one mechanism in one compiled, parallel call.

    ``systems`` are compiled models of the same topology and joint kinds
    (built, for example, from one model-building function with other
    dimensions).  ``drivers`` maps joint keys to arrays of shape (steps,)
    (the same for every variant) or (variants, steps).  Every variant is
    checked like :func:`~openimp.kinematics.sweep.sweep` and solved
    independently, in parallel over the cores.
    """
    if not systems:
        raise InputError("sweep_batch needs at least one compiled system")
    check_solver_options(tol, pivot_tol, maxit, maxhalve)
    s0 = systems[0]
    KI, KB = s0.KP[0], s0.KP[2]
    for i, s in enumerate(systems[1:], start=1):
        # same joints, loops, tree and points: the same int parts (the header also
        # fixes the shapes of the float parts)
        same = (s.var_names == s0.var_names and s.bodies == s0.bodies
                and np.array_equal(s.KP[0], KI) and np.array_equal(s.KP[2], KB))
        if not same:
            raise InputError(
                f"variant {i} ({s.name!r}) does not have the topology and joints of variant 0 "
                f"({s0.name!r}); a batch needs one mechanism with other dimensions"
            )
    nv = len(systems)
    vals = []
    for key, v in drivers.items():
        a = np.asarray(v, dtype=float)
        if a.ndim == 1:
            a = np.broadcast_to(a, (nv, a.size))
        if a.ndim != 2 or a.shape[0] != nv:
            raise InputError(f"driver {key!r}: give (steps,) or ({nv}, steps) values")
        vals.append(a)
    cols = None
    per_variant = []
    for v, s in enumerate(systems):
        c, dv = driver_columns(s, {key: vals[k][v] for k, key in enumerate(drivers)})
        cols = c if cols is None else cols
        per_variant.append(dv)
    assert cols is not None
    dvals = np.ascontiguousarray(np.stack(per_variant))
    nq = s0.nq
    S0 = make_state(s0)
    S0.sgc[cols] = True
    held, _, _ = check_drivers(s0, S0, cols, pivot_tol, hold_free)
    S0.sgc[held] = True
    nsteps = dvals.shape[1]
    out = (np.zeros((nv, nsteps, nq)), np.zeros((nv, nsteps)), np.zeros((nv, nsteps), np.int64),
           np.zeros((nv, nsteps, nq), np.bool_), np.zeros((nv, nsteps), np.int64),
           np.zeros((nv, nsteps)), np.zeros(nv, np.int64), np.zeros(nv, np.int64))
    S0 = S0._replace(q=np.stack([s.q0 for s in systems]))
    KFs = read_only((np.stack([s.KP[1] for s in systems]),))[0]
    none = np.zeros((nsteps, len(cols)))
    batch_kernel(KI, KFs, KB, make_data(s0, len(cols)).DP, S0, s0.gen,
                 Drive(cols, dvals, none, none),
                 Solver(float(tol), float(pivot_tol), int(maxit), int(maxhalve), False), out)
    Q, quality, rank, fgc, iters, _, done, status = out
    names = [s0.var_names[c] for c in cols]
    msgs = ["" if done[v] == nsteps else
            failure_message(systems[v], names, dvals[v], int(done[v]), int(status[v]))
            for v in range(nv)]
    return BatchResult(systems, Q, quality, rank, fgc, iters, done, msgs, names, S0.sgc.copy())
