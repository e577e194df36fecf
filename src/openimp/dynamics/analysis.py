"""Force analysis of a prescribed motion (book 11.14, ch 17): the Python entry.

:func:`forces` takes a solved motion (a :class:`~openimp.results.Trajectory`
from :func:`openimp.sweep`, with or without rates) and returns a
:class:`~openimp.results.Forces`: the driving force of every generalized
coordinate, the reaction in every joint, the force in every element, the
energies and the power of every load at every step.
"""

from __future__ import annotations

import numpy as np

from openimp.dynamics.inverse import ForceOptions, ForceOut, StepRows, forces_steps
from openimp.dynamics.laws import law_values
from openimp.errors import InputError
from openimp.results import Forces, Trajectory
from openimp.system import ELEMENT_KINDS, System, make_data, make_dyn_data, make_state

#: IMP's ZERO (INDETERM): the largest incompatibility (17.18) of a determinate component
INDETERMINATE = 1e-4


def forces(trajectory: Trajectory, *, reactions: bool = True,
           indeterminate: float = INDETERMINATE, pivot_tol: float = 1e-10) -> Forces:
    """Driving forces, joint reactions, element forces, energies and powers along a
    solved motion (every freedom specified: the drivers, and the free coordinates
    held as IMP holds them in kinematic mode).

    Inertia loads come from the trajectory's rates (a sweep given ``rates=`` or
    ``accels=``, or a motion of time); without rates the motion is taken as
    quasi-static (IMP's kinematic mode without DATA VELOCITY). ``indeterminate``:
    the compatibility tolerance (17.18) above which a reaction component is
    statically indeterminate (IMP's ZERO (INDETERM)).
    """
    if not isinstance(trajectory, Trajectory):
        raise InputError(f"forces() takes the Trajectory of a sweep, got {type(trajectory)!r}")
    if not (indeterminate > 0 and np.isfinite(indeterminate)):
        raise InputError(f"indeterminate must be a positive tolerance, got {indeterminate!r}")
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
    nj, ne = len(system.joints), len(system.elements)
    out = ForceOut(np.zeros((n, nq)), np.zeros((n, nj, 6)), np.zeros((n, 2)), np.zeros(n),
                   np.zeros((n, nq)), np.zeros((n, ne)), np.zeros((n, ne)), np.zeros((n, ne)),
                   np.zeros((n, ne)), np.zeros((n, ne), np.bool_), np.zeros(n, np.int64))
    S = make_state(system)
    S.sgc[:] = trajectory.specified
    data = make_data(system, nq)
    dyn = make_dyn_data(system, nq)
    opt = ForceOptions(float(pivot_tol), float(indeterminate), bool(reactions))
    forces_steps(system.KP, data.DP, system.YP, dyn.ZP, S, system.gen, rows, opt, out)
    return _result(system, trajectory, out, reactions)


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
    """Model units (lengths times L, forces times L, moments and energies times L^2 with
    L the length scale) and the result object."""
    Ls = system.length_scale
    e2 = Ls * Ls
    gen_scale = np.where(np.array(system.var_kinds) == "angle", e2, Ls)
    drive = {}
    for c in np.flatnonzero(np.any(np.isfinite(out.drive), axis=0)):
        drive[system.var_names[c]] = out.drive[:, c] * gen_scale[c]
    R = out.R.copy()
    R[..., :3] *= Ls
    R[..., 3:] *= e2
    kinds = system.Y.ekind
    escale = np.where(kinds == ELEMENT_KINDS.index("torque"), e2, Ls)
    power = {"gravity": out.gpower * e2}
    for i, name in enumerate(system.elements):
        power[name] = out.epower[:, i] * e2
    for j, a0, nv in _loaded_joints(system):
        power[f"joint {j}"] = out.qpower[:, a0:a0 + nv].sum(axis=1) * e2
    QD = trajectory.internal()[1]
    if QD is not None:
        dr = np.nan_to_num(out.drive) * QD
        power["drive"] = dr.sum(axis=1) * e2
    else:
        power["drive"] = np.zeros(out.rank.shape[0])
    messages = []
    for i in (np.flatnonzero(out.eskip.any(axis=0)) if out.eskip.size else ()):
        name = system.elements[i]
        skipped = np.flatnonzero(out.eskip[:, i])
        if skipped.size:
            kind = ELEMENT_KINDS[int(kinds[i])]
            messages.append(f"{kind} {name}: its two points coincide at {skipped.size} "
                            f"step(s) (first at step {int(skipped[0])}); it is skipped there")

    def frames(h: int) -> tuple[np.ndarray, np.ndarray]:
        b1, b2 = system.bodies[int(system.K.jb1[h])], system.bodies[int(system.K.jb2[h])]
        S1 = system.K.S1[h].copy()
        S2 = system.K.S2[h].copy()
        S1[:3, 3] *= Ls
        S2[:3, 3] *= Ls
        return trajectory.posture(b1) @ S1, trajectory.posture(b2) @ S2

    return Forces(trajectory, drive, R, frames, out.eforce * escale[None, :],
                  out.eskip.copy(), out.energy[:, 0] * e2, out.energy[:, 1] * e2, power,
                  messages, reactions)
