"""Tracking: postures, points and body rates of selected bodies along stored joint variables.

Results store joint variables only and recompute what is asked (cheap, and it
keeps a million-step sweep small): :func:`track` runs the position stage, and
with rates the velocity and acceleration stages, for every stored row.
:func:`tracker` binds it to a system, in model units, for the trajectory
results of :mod:`openimp.results`.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from openimp._jit import njit
from openimp.kinematics.position import position, screws
from openimp.kinematics.rates import accelerations, drift, velocity
from openimp.system import System, data_views, make_data, make_state, model_views


class Rows(NamedTuple):
    """Stored joint variables (steps x nq each; QD and QDD with 0 rows for postures only)."""

    Q: np.ndarray
    QD: np.ndarray
    QDD: np.ndarray


class Selection(NamedTuple):
    """Indices of the bodies and points to track."""

    bodies: np.ndarray
    points: np.ndarray


class Tracked(NamedTuple):
    """Outputs: T (steps x nbsel x 4 x 4), p (steps x npsel x 3), V and A (steps x nbsel x 6,
    screws of omega_b and alpha_b; 0 steps for postures only)."""

    T: np.ndarray
    p: np.ndarray
    V: np.ndarray
    A: np.ndarray


@njit(nrt=False)
def track(KP: tuple, DP: tuple, S: tuple, gen: np.ndarray | None, rows: tuple,
          sel: tuple, out: tuple) -> None:
    """For every stored row: postures of the selected bodies, positions of the selected
    points and, given rates, the body velocity and acceleration screws (7.22, 8.52).

    ``rows``: :class:`Rows`; ``sel``: :class:`Selection`; ``out``: :class:`Tracked`.
    The state ``S`` is scratch (its q, qd and qdd are overwritten).
    """
    K = model_views(KP)
    d = data_views(DP)
    rates = rows.QD.shape[0] > 0
    nq = rows.Q.shape[1]
    for s in range(rows.Q.shape[0]):
        for c in range(nq):
            S.q[c] = rows.Q[s, c]
        position(KP, DP, S, gen, 1 if rates else 0)
        for k in range(sel.bodies.shape[0]):
            for i in range(4):
                for c in range(4):
                    out.T[s, k, i, c] = d.T0[sel.bodies[k], i, c]
        for k in range(sel.points.shape[0]):
            p = sel.points[k]
            Tb = d.T0[K.ptbody[p]]
            x = K.ptlocal[p]
            for i in range(3):
                out.p[s, k, i] = Tb[i, 0] * x[0] + Tb[i, 1] * x[1] + Tb[i, 2] * x[2] + Tb[i, 3]
        if rates:
            for c in range(nq):
                S.qd[c] = rows.QD[s, c]
                S.qdd[c] = rows.QDD[s, c]
            screws(KP, DP, gen)
            velocity(KP, DP, S)
            drift(KP, DP, S, gen)
            accelerations(KP, DP, S)
            for k in range(sel.bodies.shape[0]):
                for i in range(6):
                    out.V[s, k, i] = d.V[sel.bodies[k], i]
                    out.A[s, k, i] = d.Ab[sel.bodies[k], i]


def tracker(system: System) -> Callable[..., Tracked]:
    """A function ``(Q, QD, QDD, bodies, points) -> Tracked`` in model units for ``system``.

    Q, QD, QDD: (steps x nq) internal units (QD, QDD None for postures only);
    bodies, points: index sequences.  Lengths and the translational parts of
    the screws come back in model units.
    """

    def run(Q: np.ndarray, QD: np.ndarray | None, QDD: np.ndarray | None,
            bodies: list[int], points: list[int]) -> Tracked:
        n = Q.shape[0]
        nb, npt = len(bodies), len(points)
        rates = QD is not None and QDD is not None
        none = np.zeros((0, system.nq))
        out = Tracked(np.zeros((n, nb, 4, 4)), np.zeros((n, npt, 3)),
                      np.zeros((n if rates else 0, nb, 6)), np.zeros((n if rates else 0, nb, 6)))
        rows = Rows(np.ascontiguousarray(Q, dtype=float),
                    np.ascontiguousarray(QD if rates else none, dtype=float),
                    np.ascontiguousarray(QDD if rates else none, dtype=float))
        track(system.KP, make_data(system).DP, make_state(system), system.gen, rows,
              Selection(np.asarray(bodies, np.int64), np.asarray(points, np.int64)), out)
        Ls = system.length_scale
        out.T[..., :3, 3] *= Ls
        out.p[...] *= Ls
        out.V[..., :3] *= Ls
        out.A[..., :3] *= Ls
        return out

    return run
