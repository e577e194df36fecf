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
from openimp.system import dyn_data_views


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
    magnitudes of every body wrench and joint load, the size against which a
    residual is judged balanced.
    """
    u, cv, cp, Qp, dF, dfq = work
    z = dyn_data_views(ZP)
    rank, nf = _setup(KP, DP, YP, ZP, S, gen, ptol)
    for j in range(nf):
        u[j] = 0.0
    pe = _rate_forces(KP, DP, YP, ZP, S, gen, rank, nf, u[:nf], cv, F)[1]
    scale = 0.0
    for b in range(z.Fext.shape[0]):
        for k in range(6):
            scale += abs(z.Fext[b, k])
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
                  tol: float, ptol: float, maxit: int, keep: np.ndarray) -> tuple[int, int]:
    """Close the loops at S.q holding the generalized coordinates ``cols`` (and S.sgc)
    where they are (Newton, ch 6); returns the status of
    :func:`~openimp.kinematics.posture.newton` (0: closed) and its iterations.
    ``keep`` (nq,) bool scratch."""
    nq = S.q.shape[0]
    for c in range(nq):
        keep[c] = S.sgc[c]
    for c in cols:
        S.sgc[c] = True
    res = newton(KP, DP, S, gen, tol, ptol, maxit, False)
    for c in range(nq):
        S.sgc[c] = keep[c]
    return res[0], res[1]
