"""Force analysis of a prescribed motion (book 11.14, ch 17): the Python entry.

:func:`forces` solves a motion of a System (the arguments of
:func:`openimp.sweep`) and :func:`forces_of` takes one already solved (a
:class:`~openimp.results.Trajectory` from :func:`openimp.sweep`, with or
without rates); both return a :class:`~openimp.results.Forces`: the driving
force of every generalized coordinate, the reaction in every joint, the force
in every element, the energies and the power of every load at every step.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from openimp.dynamics.inverse import (
    ForceOptions,
    ForceOut,
    StepRows,
    forces_steps,
    open_chain_steps,
    sweep_forces,
)
from openimp.dynamics.laws import law_values
from openimp.errors import InputError, Named, deprecated
from openimp.kinematics.inputs import positive
from openimp.kinematics.sweep import (
    Drive,
    Solver,
    SweepOut,
    motion_inputs,
    sweep,
)
from openimp.kinematics.track import tracker
from openimp.results import Forces, Trajectory
from openimp.system import (
    ELEMENT_KINDS,
    State,
    System,
    make_dyn_data,
    make_scratch,
    make_state,
)
from openimp.workspace import WORKSPACES

#: IMP's ZERO (INDETERM): the largest incompatibility (17.18) of a determinate component
INDETERMINATE = 1e-4


def forces(system: System, drivers: Any = None, rates: Any = None, accels: Any = None, *,
           q: Any = None, state: State | None = None, specified: Any = (),
           reactions: bool = True, indeterminate: float = INDETERMINATE,
           pivot_tol: float = 1e-10, **sweep_options: Any) -> Forces:
    """Driving forces, joint reactions, element forces, energies and powers along a
    motion in which every freedom is specified (the drivers, and the free
    coordinates held as IMP holds them in kinematic mode), solved here.

    The arguments are those of :func:`openimp.sweep` (``drivers``, ``rates``,
    ``accels`` or ``motion=``/``times=``; ``q`` or ``state=`` the start;
    ``specified`` held coordinates; and its options): the sweep is solved and
    every step's forces are evaluated as it is solved, from the same
    elimination (one pass; rates 0 where none are given), and the trajectory
    is ``result.trajectory``.  ``indeterminate``: the compatibility tolerance
    (17.18) above which a reaction component is statically indeterminate
    (IMP's ZERO (INDETERM)).  The forces of a motion already solved:
    :func:`forces_of`.  ``forces(trajectory)`` is the deprecated form of
    ``forces_of(trajectory)``.
    """
    if isinstance(system, Trajectory):  # the overloaded form of the last release
        if drivers is not None or rates is not None or accels is not None or sweep_options \
                or q is not None or state is not None or specified:
            raise InputError("forces(trajectory) takes no drivers or sweep options: they "
                             "belong to the sweep that solved the trajectory")
        deprecated("forces", "forces(trajectory)", "forces_of(trajectory)")
        return forces_of(system, reactions=reactions, indeterminate=indeterminate,
                         pivot_tol=pivot_tol)
    if not isinstance(system, System):
        raise InputError(f"forces() takes a compiled System and the motion (or "
                         f"forces_of(trajectory) a solved one), got {type(system).__name__}")
    opt = _options(reactions, indeterminate, pivot_tol)
    start = dict(q=q, state=state, specified=specified)
    if system.laws:  # laws read the solved motion: solve it first, then evaluate
        tr = sweep(system, drivers, rates, accels, pivot_tol=pivot_tol, **start,
                   **sweep_options)
        return forces_of(tr, reactions=reactions, indeterminate=indeterminate,
                         pivot_tol=pivot_tol)
    direct = _open_chain(system, drivers, rates, accels, sweep_options, opt)
    if direct is not None:
        return direct
    kernel = _SweepForces(system, opt)
    tr = sweep(system, drivers, rates, accels, pivot_tol=pivot_tol, kernel=kernel, **start,
               **sweep_options)
    assert kernel.out is not None
    return _result(system, tr, ForceOut(*(a[:tr.nsteps] for a in kernel.out)), reactions)


def forces_of(trajectory: Trajectory, *, reactions: bool = True,
              indeterminate: float = INDETERMINATE, pivot_tol: float = 1e-10) -> Forces:
    """The :class:`~openimp.results.Forces` of :func:`forces` along a solved motion: a
    :class:`~openimp.results.Trajectory` of a sweep, with or without rates (without,
    the motion is quasi-static, as IMP's kinematic mode without DATA VELOCITY), or
    of an equilibrium path."""
    if not isinstance(trajectory, Trajectory):
        raise InputError(f"forces_of() takes the Trajectory of a sweep, got "
                         f"{type(trajectory).__name__}; forces() solves a System's motion")
    opt = _options(reactions, indeterminate, pivot_tol)
    system: System = trajectory.system
    Q, QD, QDD = trajectory.internal()
    n, nq = Q.shape
    if QD is None or QDD is None:
        QD = QDD = np.zeros((n, nq))
    times = trajectory.time if trajectory.time is not None else np.arange(n, dtype=float)
    laws = law_values(system, trajectory, times)
    generalized = trajectory.free | trajectory.specified[None, :]
    rows = StepRows(np.ascontiguousarray(Q), np.ascontiguousarray(QD),
                    np.ascontiguousarray(QDD), np.ascontiguousarray(generalized), laws)
    out = _allocate(system, n)
    S = make_state(system)
    S.sgc[:] = trajectory.specified
    with WORKSPACES.use(system, "forces", make_scratch) as (data, dyn):
        forces_steps(system.KP, data.DP, system.YP, dyn.ZP, S, system.gen, rows, opt, out)
    return _result(system, trajectory, out, reactions)


def _options(reactions: Any, indeterminate: Any, pivot_tol: Any) -> ForceOptions:
    """The checked options of a force analysis."""
    return ForceOptions(positive(pivot_tol, "forces: pivot_tol"),
                        positive(indeterminate, "forces: indeterminate"), bool(reactions))


def _open_chain(system: System, drivers: Any, rates: Any, accels: Any,
                sweep_options: dict[str, Any], opt: ForceOptions) -> Forces | None:
    """A model without loops (nor Euler-Rodrigues rows) with every joint variable driven
    has nothing to solve: every posture is given.  Its forces then come straight
    from the given motion (the inverse dynamics of a robot arm, book 10.17-10.18),
    without the sweep's predictor and Newton.  None when that does not apply."""
    if system.nrows or not drivers or sweep_options.keys() - {"motion", "times"}:
        return None
    inp = motion_inputs(system, drivers, rates, accels, sweep_options.get("motion"),
                        sweep_options.get("times"), None)
    nq = system.nq
    if inp.cols.size != nq:
        return None
    n = inp.values.shape[0]
    Q, QD, QDD = np.empty((n, nq)), np.empty((n, nq)), np.empty((n, nq))
    Q[:, inp.cols] = inp.values
    QD[:, inp.cols] = inp.rates
    QDD[:, inp.cols] = inp.accels
    tr = Trajectory(system, Q, np.ones(n), np.zeros(n, np.int64), np.zeros((n, nq), bool),
                    np.zeros(n, np.int64), [system.var_names[c] for c in inp.cols],
                    tracker=tracker(system), sgc=np.ones(nq, bool))
    tr.rank_ref, tr.quality_ref = 0, 1.0
    tr.set_rates(QD, QDD, np.zeros(n))
    tr.time = inp.times
    rows = StepRows(Q, QD, QDD, np.ones((n, nq), bool), np.zeros((n, 1)))
    out = _allocate(system, n)
    S = make_state(system)
    S.sgc[:] = True
    with WORKSPACES.use(system, "forces", make_scratch) as (data, dyn):
        open_chain_steps(system.KP, data.DP, system.YP, dyn.ZP, S, system.gen, rows, opt,
                         out)
    return _result(system, tr, out, opt.reactions)


def _allocate(system: System, n: int) -> ForceOut:
    """The outputs of ``n`` steps (:class:`~openimp.dynamics.inverse.ForceOut`)."""
    nq, nj, ne = system.nq, len(system.joints), len(system.elements)
    return ForceOut(np.zeros((n, nq)), np.zeros((n, nj, 6)), np.zeros((n, 2)), np.zeros(n),
                    np.zeros(n), np.zeros((n, nq)), np.zeros((n, ne)), np.zeros((n, ne)),
                    np.zeros((n, ne)), np.zeros((n, ne)), np.zeros((n, ne), np.bool_),
                    np.zeros(n, np.int64))


class _SweepForces:
    """The step kernel of a sweep that evaluates the forces of every step as it is
    solved (:class:`~openimp.kinematics.sweep.StepKernel`)."""

    def __init__(self, system: System, opt: ForceOptions) -> None:
        self.system = system
        self.opt = opt
        self.dyn = make_dyn_data(system, system.nq)
        self.out: ForceOut | None = None

    def allocate(self, nsteps: int) -> None:
        self.out = _allocate(self.system, nsteps)

    def run(self, system: System, data: Any, S: Any, drive: Drive, opt: Solver,
            part: SweepOut, k0: int) -> tuple[int, int]:
        assert self.out is not None
        n = drive.values.shape[0]
        rows = ForceOut(*(a[k0:k0 + n] for a in self.out))
        return sweep_forces(system.KP, data.DP, S, system.gen, drive, opt, part,
                            (system.YP, self.dyn.ZP, self.opt, rows))


def _loaded_joints(system: System) -> list[tuple[str, int, int]]:
    """(joint, first variable, number of variables) of the joints with a spring, damper
    or load on a variable (kept on the System)."""
    hit = system.memo.get("loaded joints")
    if hit is None:
        Y, K = system.Y, system.K
        on = (Y.qk != 0) | (Y.qc != 0) | (Y.qf != 0) | np.any(Y.qlaw >= 0, axis=1)
        hit = system.memo["loaded joints"] = [
            (j, int(K.jq0[h]), int(K.jnv[h])) for h, j in enumerate(system.joints)
            if on[int(K.jq0[h]):int(K.jq0[h] + K.jnv[h])].any()]
    return hit


def _result(system: System, trajectory: Trajectory, out: ForceOut, reactions: bool) -> Forces:
    """The result object of the outputs (already in model units)."""
    drive = {system.var_names[c]: out.drive[:, c]
             for c in np.flatnonzero(np.isfinite(out.drive).any(axis=0))}
    power = {"gravity": out.gpower}
    for i, name in enumerate(system.elements):
        power[name] = out.epower[:, i]
    for j, a0, nv in _loaded_joints(system):
        power[f"joint {j}"] = out.qpower[:, a0:a0 + nv].sum(axis=1)
    power["drive"] = out.dpower
    kinds = system.Y.ekind
    messages = []
    for i in (np.flatnonzero(out.eskip.any(axis=0)) if out.eskip.size else ()):
        name = system.elements[i]
        skipped = np.flatnonzero(out.eskip[:, i])
        if skipped.size:
            kind = ELEMENT_KINDS[int(kinds[i])]
            messages.append(f"{kind} {name}: its two points coincide at {skipped.size} "
                            f"step(s) (first at step {int(skipped[0])}); it is skipped there")

    Ls = system.length_scale

    def frames(h: int) -> tuple[np.ndarray, np.ndarray]:
        b1, b2 = system.bodies[int(system.K.jb1[h])], system.bodies[int(system.K.jb2[h])]
        S1 = system.K.S1[h].copy()
        S2 = system.K.S2[h].copy()
        S1[:3, 3] *= Ls
        S2[:3, 3] *= Ls
        return trajectory.posture(b1) @ S1, trajectory.posture(b2) @ S2

    return Forces(trajectory, Named("drive", drive), out.R, frames, out.eforce, out.eskip,
                  out.energy[:, 0], out.energy[:, 1], Named("power", power), messages,
                  reactions)
