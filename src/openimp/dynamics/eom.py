"""The equations of motion at one state (book ch 10), in IMP's generalized coordinates:

    M(psi) psi'' + c(psi, psi') = Q(psi, psi', t)                    (10.15)

over every generalized coordinate (the specified ones, SGC, and the free
ones, FGC, that the elimination leaves), with

* M_ij = sum_b trace(W_{b,i} G_b W_{b,j}^T), the mass matrix (11.7);
* c_i = sum_b trace(W_{b,i} G_b (alpha0_b + omega_b omega_b)^T), the
  velocity-product terms, alpha0 the body accelerations with zero input
  acceleration (the velocity-product stage of the kinematics, 8.40-8.52);
* Q_i = sum_b W_{b,i} . Fext_b + sum_h phi'_{h,i} fq_h: gravity, springs,
  dampers and applied loads (10.12 with its sign turned, 10.13).

:func:`eom` is the compiled stage the later analyses (equilibrium,
linearisation, time response) call; :func:`equations` the Python entry.
Partitioned [F | S] (section 5.6 of the digest), the F rows give the free
accelerations for given SGC accelerations and the S rows the drive forces
(11.14): :meth:`EquationsOfMotion.free_accelerations`, :meth:`~EquationsOfMotion.drive`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from openimp._jit import njit
from openimp.dynamics.inertia import body_inertias, inertia_wrenches, mass_matrix
from openimp.dynamics.laws import law_values_at
from openimp.dynamics.loads import applied_loads
from openimp.errors import AnalysisError, InputError
from openimp.kinematics.elimination import derivatives, eliminate, free_columns, jacobian
from openimp.kinematics.position import position
from openimp.kinematics.rates import accelerations, body_operators, velocity, velocity_product
from openimp.system import (
    System,
    data_views,
    dyn_data_views,
    make_data,
    make_dyn_data,
    make_state,
    model_views,
)


@njit(nrt=False, inline="always")
def generalized(KP: tuple, DP: tuple, ZP: tuple, S: tuple, gen: np.ndarray | None,
                ptol: float) -> tuple[int, int]:
    """Evaluate and eliminate the loop equations at S.q (assembled) and set up the
    generalized coordinates: S.sgc and the columns the elimination leaves free, in
    column order, into z.cols; phi' of them into z.Gf (7.14) and the body operators
    W_{b,j} into z.W (7.20).  Returns (rank, nf)."""
    d = data_views(DP)
    z = dyn_data_views(ZP)
    nq = S.q.shape[0]
    position(KP, DP, S, gen, 1)
    jacobian(KP, DP, S, gen)
    rank = eliminate(DP, S.sgc, ptol)[0]
    free = d.used[:nq]
    free_columns(DP, S.sgc, rank, free)
    nf = 0
    for a in range(nq):
        if S.sgc[a] or free[a]:
            z.cols[nf] = a
            nf += 1
    G = z.Gf[:, :nf]
    derivatives(DP, rank, z.cols[:nf], G)
    body_operators(KP, DP, G, z.W[:, :nf])
    return rank, nf


@njit(nrt=False, inline="always")
def generalized_forces(KP: tuple, ZP: tuple, nf: int, c: np.ndarray, Q: np.ndarray) -> None:
    """c_j = sum_b W_{b,j} . Fin_b and Q_j = sum_b W_{b,j} . Fext_b + sum_a phi'_{a,j} fq_a
    (10.12, 10.13) for the nf coordinates of z.W, z.Gf."""
    K = model_views(KP)
    z = dyn_data_views(ZP)
    W = z.W
    G = z.Gf
    for j in range(nf):
        cj = 0.0
        qj = 0.0
        for b in range(K.order.shape[0]):
            for i in range(6):
                cj += W[b, j, i] * z.Fin[b, i]
                qj += W[b, j, i] * z.Fext[b, i]
        for a in range(G.shape[0]):
            qj += G[a, j] * z.fq[a]
        c[j] = cj
        Q[j] = qj


@njit(nrt=False, inline="always")
def eom_rates(KP: tuple, DP: tuple, ZP: tuple, S: tuple, gen: np.ndarray | None,
              ptol: float, psid: np.ndarray) -> tuple[int, int]:
    """The kinematic half of :func:`eom`: the generalized coordinates at S.q
    (:func:`generalized`), the joint rates S.qd = phi' psid (7.16), the body rates and the
    velocity-product accelerations S.qdd (8.44).  Load laws may read the state from here
    on (:func:`eom_loads` then takes their values).  Returns (rank, nf)."""
    z = dyn_data_views(ZP)
    rank, nf = generalized(KP, DP, ZP, S, gen, ptol)
    cols = z.cols[:nf]
    G = z.Gf[:, :nf]
    for a in range(S.q.shape[0]):
        s = 0.0
        for j in range(nf):
            s += G[a, j] * psid[cols[j]]
        S.qd[a] = s
    velocity(KP, DP, S)
    velocity_product(KP, DP, S, gen, rank)
    accelerations(KP, DP, S)
    return rank, nf


@njit(nrt=False, inline="always")
def eom_loads(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple, nf: int,
              out: tuple) -> tuple[float, float, float]:
    """The dynamic half of :func:`eom` after :func:`eom_rates`: M, c, Q into ``out`` =
    (M, c, Q) with the law values in z.law.  Returns (kinetic energy, potential
    energy, power of gravity)."""
    M, c, Q = out
    body_inertias(KP, DP, YP, ZP)
    ke = inertia_wrenches(KP, DP, ZP)
    pe, gp = applied_loads(KP, DP, YP, ZP, S)
    mass_matrix(KP, ZP, M[:nf, :nf])
    generalized_forces(KP, ZP, nf, c, Q)
    return ke, pe, gp


@njit(nrt=False)
def eom(KP: tuple, DP: tuple, YP: tuple, ZP: tuple, S: tuple, gen: np.ndarray | None,
        ptol: float, psid: np.ndarray, out: tuple) -> tuple[int, int, float, float]:
    """M, c and Q of (10.15) at S.q with generalized rates ``psid``, into ``out`` =
    (M, c, Q).

    The generalized coordinates are S.sgc and the columns the elimination
    leaves free (:func:`generalized`; count nf).  ``psid``
    (nq,): the rates of the generalized coordinates (others ignored); the
    joint rates S.qd = phi' psid (7.16) and S.qdd (velocity-product, 8.44) are
    written.  M: (nq, nq), c, Q: (nq,), the leading nf used.  Returns (nf,
    rank, kinetic energy, potential energy).
    """
    rank, nf = eom_rates(KP, DP, ZP, S, gen, ptol, psid)
    ke, pe, _ = eom_loads(KP, DP, YP, ZP, S, nf, out)
    return nf, rank, ke, pe


@dataclass
class EquationsOfMotion:
    """M psi'' + c = Q at one state (model units: forces, moments per radian, masses as
    given), over the generalized coordinates ``coords`` (names; ``specified`` marks
    the SGCs, the rest are FGCs).  ``kinetic``, ``potential``: the energies."""

    coords: list[str]
    specified: np.ndarray
    M: np.ndarray
    c: np.ndarray
    Q: np.ndarray
    kinetic: float
    potential: float

    def free_accelerations(self, specified_accels: np.ndarray | None = None) -> np.ndarray:
        """psi''_F from M_FF psi''_F = Q_F - c_F - M_FS psi''_S (10.15, 11.13)."""
        F, Sg = ~self.specified, self.specified
        a_s = np.zeros(int(Sg.sum())) if specified_accels is None else np.asarray(
            specified_accels, float)
        rhs = self.Q[F] - self.c[F] - self.M[np.ix_(F, Sg)] @ a_s
        MFF = self.M[np.ix_(F, F)]
        if MFF.size and np.linalg.cond(MFF) > 1e12:
            raise AnalysisError("the mass matrix of the free coordinates is singular: a "
                                "massless part can move alone")
        return np.linalg.solve(MFF, rhs) if MFF.size else np.zeros(0)

    def drive(self, accels: np.ndarray) -> np.ndarray:
        """Generalized forces the coordinates need for accelerations ``accels`` (all
        coordinates): M psi'' + c - Q (11.14)."""
        return self.M @ np.asarray(accels, float) + self.c - self.Q


def equations(system: System, q: Any = None, rates: Any = None, *,
              specified: Any = (), t: float = 0.0, pivot_tol: float = 1e-10
              ) -> EquationsOfMotion:
    """The equations of motion of ``system`` at joint variables ``q`` (model units,
    default the modeling posture; an assembled posture) with generalized rates.

    ``specified``: the SGCs (joint names or ``"joint.var"``); the free
    coordinates are the ones the elimination leaves.  ``rates``: mapping
    coordinate -> rate (model units per second; default at rest).
    """
    nq = system.nq
    qm = system.modeling_q if q is None else np.asarray(q, float)
    if qm.shape != (nq,):
        raise InputError(f"q must hold the {nq} joint variables, got shape {qm.shape}")
    S = make_state(system, system.to_internal(qm), t)
    for key in specified:
        S.sgc[system.var_index(key)] = True
    psid = np.zeros(nq)
    for key, v in dict(rates or {}).items():
        c = system.var_index(key)
        psid[c] = float(v) / system.var_scale[c]
    data = make_data(system, nq)
    dyn = make_dyn_data(system, nq)
    M, cv, Qv = np.zeros((nq, nq)), np.zeros(nq), np.zeros(nq)
    if system.laws:
        # the laws read the joint rates phi' psi', which the first evaluation sets
        eom(system.KP, data.DP, system.YP, dyn.ZP, S, system.gen, float(pivot_tol), psid,
            (M, cv, Qv))
        dyn.v.law[:] = law_values_at(system, S.q[None, :], S.qd[None, :], t)[0]
    nf, _, ke, pe = eom(system.KP, data.DP, system.YP, dyn.ZP, S, system.gen,
                        float(pivot_tol), psid, (M, cv, Qv))
    cols = dyn.v.cols[:nf].copy()
    # model units: generalized forces of angles times L^2, of lengths times L
    Ls = system.length_scale
    gs = np.where(np.array([system.var_kinds[c] for c in cols]) == "length", Ls, Ls * Ls)
    e2 = Ls * Ls
    # M_ij psi''_j is a force of i: scale by gs_i gs_j / L^2 (rates of lengths are / L)
    Mm = M[:nf, :nf] * np.outer(gs, gs) / e2
    return EquationsOfMotion([system.var_names[c] for c in cols], S.sgc[cols].copy(), Mm,
                             cv[:nf] * gs, Qv[:nf] * gs, ke * e2, pe * e2)
