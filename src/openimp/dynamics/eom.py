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
linearisation, time response) call; :func:`equations` the Python entry, whose result is an
:class:`~openimp.results.EquationsOfMotion`.
Partitioned [F | S] (as the book partitions the linearized equations,
11.12-11.14), the F rows give the free accelerations for given SGC
accelerations and the S rows the drive forces (11.14).  :data:`SINGULAR_MASS`
and :func:`mass_check` are the one test of a singular mass matrix and its
message.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from openimp._jit import njit
from openimp.dynamics.inertia import body_inertias, inertia_wrenches, mass_matrix
from openimp.dynamics.laws import law_values_at
from openimp.dynamics.loads import applied_loads
from openimp.errors import AnalysisError, InputError
from openimp.kinematics.ballrates import spin_rates
from openimp.kinematics.elimination import derivatives, eliminate, free_columns, jacobian
from openimp.kinematics.inputs import (
    finite,
    given_state,
    names_of,
    per_coordinate,
    positive,
    posture_input,
)
from openimp.kinematics.position import position
from openimp.kinematics.rates import accelerations, body_operators, velocity, velocity_product
from openimp.results import EquationsOfMotion
from openimp.system import (
    State,
    System,
    data_views,
    dyn_data_views,
    make_scratch,
    make_state,
    model_views,
)
from openimp.workspace import WORKSPACES


@njit(nrt=False)
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


@njit(nrt=False)
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


@njit(nrt=False)
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


@njit(nrt=False)
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


# ----------------------------------------------------------------------------- mass
#: M_FF is singular when its smallest eigenvalue is at most SINGULAR_MASS times its scale:
#: the larger of its largest diagonal entry and the model's mass (:func:`mass_floor`).
#: The one test of every analysis that solves with M_FF (modes, transfer functions, the
#: frequency map, equations().free_accelerations, the time response's diagnosis).  The
#: time step's compiled Cholesky solve keeps its own guard, a pivot below ``mass_tol``
#: (IMP's ZERO (INERTIA), 1e-5 by default) times the same scale: every pivot is at least
#: the smallest eigenvalue, so that guard refuses only matrices whose smallest
#: eigenvalue is below 1e-5 of the scale (it is IMP's looser accuracy limit, a user
#: option), and a matrix singular by this test has a round-off pivot and stops there too;
#: simulate() then names what moves without mass by this test (:func:`massless`).
SINGULAR_MASS = 1e-14


def mass_floor(system: System) -> float:
    """The model's mass times min(1, L^2), model units: what an M_FF entry of round-off
    size is measured against (a 1 x 1 M_FF of round-off size is as singular as a zero
    one; the SGCs' block is not used, which a heavy carriage would make dwarf a light
    part that does move)."""
    return float(system.Y.Jb[:, 3, 3].sum()) * min(1.0, system.length_scale ** 2)


def singular_masses(MFF: np.ndarray, floor: float) -> np.ndarray:
    """Where M_FF (..., n, n; model units) is singular by the test of
    :data:`SINGULAR_MASS`: a bool (...,), every matrix at once."""
    low = np.linalg.eigvalsh(0.5 * (MFF + np.swapaxes(MFF, -1, -2)))[..., 0]
    top = np.abs(np.diagonal(MFF, axis1=-2, axis2=-1)).max(axis=-1, initial=0.0)
    return low <= SINGULAR_MASS * np.maximum(np.maximum(top, floor), 1e-300)


def null_motion(MFF: np.ndarray, floor: float) -> np.ndarray | None:
    """None when M_FF (n, n; model units) is regular by the test of
    :data:`SINGULAR_MASS`, else the eigenvector (n,) of its smallest eigenvalue: a
    motion of the free coordinates without kinetic energy.  A Cholesky factor whose
    smallest pivot is clear of the limit answers first (the eigen-solution costs more
    than the rest of a small modes() call)."""
    if MFF.size == 0:
        return None
    d = MFF.diagonal().tolist()
    limit = SINGULAR_MASS * max(max(abs(x) for x in d), floor, 1e-300)
    if len(d) == 1:
        if d[0] > limit:
            return None
    else:
        try:
            L = np.linalg.cholesky(MFF)
            if min(L.diagonal().tolist()) ** 2 > limit:
                return None
        except np.linalg.LinAlgError:
            pass
    lam, vec = np.linalg.eigh(0.5 * (MFF + MFF.T))
    if lam[0] > limit:
        return None
    return vec[:, 0]


def massless_message(coords: list[str], bodies: np.ndarray, body_names: Any,
                     v: np.ndarray) -> str:
    """The message of a singular M_FF: the free coordinates ``coords`` (n names) that
    move together in the massless motion ``v`` (n,) (:func:`null_motion`) and the bodies
    that move with them, whose twists sum_j W_{b,j} v_j are not zero (``bodies``
    (nb, n, 6) the screws of W per unit of each free coordinate, ``body_names`` (nb,))."""
    moving = [coords[i] for i in np.flatnonzero(np.abs(v) > 1e-6 * np.max(np.abs(v)))]
    tw = np.abs(np.einsum("bjk,j->bk", bodies, v)).max(axis=1, initial=0.0)
    top = float(tw.max()) if tw.size else 0.0
    names = [body_names[b] for b in np.flatnonzero(tw > 1e-9 * max(top, 1e-300))]
    return ("the mass matrix of the free coordinates is singular at this posture: moving "
            + ", ".join(moving) + " together moves "
            + (("bodies " + ", ".join(names)) if names else "no body") + " without "
            "kinetic energy (no mass or inertia there); give those bodies mass and inertia "
            "(Model.add_mass, DATA MASS / DATA INERTIA) or specify the coordinate")


def mass_check(system: System, MFF: np.ndarray, coords: list[str], bodies: np.ndarray
               ) -> str:
    """"" when M_FF (n, n; model units) of the free coordinates ``coords`` is regular,
    else the message that names what moves without mass (:func:`massless_message`;
    ``bodies`` (nb, n, 6): the screws of W per unit of each free coordinate)."""
    v = null_motion(MFF, mass_floor(system))
    return "" if v is None else massless_message(coords, bodies, system.bodies, v)


def massless(system: System, state: Any) -> str:
    """What moves without kinetic energy at the assembled ``state`` (a
    :class:`~openimp.system.State`, its SGCs locked), by the test of every analysis
    (:func:`mass_check`), or "" when M_FF is regular there."""
    try:
        return equations(system, state=state).singular
    except (InputError, AnalysisError):
        return ""


# ----------------------------------------------------------------------------- entry
def equations(system: System, q: Any = None, rates: Any = None, *, state: Any = None,
              specified: Any = (), t: float = 0.0, pivot_tol: float = 1e-10
              ) -> EquationsOfMotion:
    """The equations of motion M psi'' + c = Q (10.15) of ``system`` at one state.

    ``q``: joint variables (nq,) in model units or a mapping of joint or
    ``"joint.var"`` to values (default the modeling posture; an assembled
    posture); ``rates``: mapping coordinate -> rate (model units per second;
    default at rest; ``"joint.w"``: a ball joint's angular velocity, as in
    :func:`~openimp.dynamics.linearize.linearize`); ``specified``: the SGCs
    (joint names or ``"joint.var"``), the free coordinates are the ones the
    elimination leaves; ``t``: the time
    (load laws read it).  ``state``: a :class:`~openimp.system.State` instead
    of ``q``, ``rates`` and ``t`` (internal units: its posture, time, SGCs and
    the rates of its generalized coordinates).  Returns an
    :class:`~openimp.results.EquationsOfMotion` in model units; its
    ``singular`` says what moves without mass when M_FF is singular
    (:data:`SINGULAR_MASS`).
    """
    if not isinstance(system, System):
        raise InputError(f"equations takes a compiled System, got {type(system).__name__}")
    ptol = positive(pivot_tol, "equations: pivot_tol")
    given = given_state(system, q, state, "equations", rates)
    if given is not None:
        S = given.copy()
        psid = S.qd.copy()
        t = float(S.t[0])
    else:
        t = finite(t, "equations: t")
        S = make_state(system, posture_input(system, q), t)
        rates = spin_rates(system, rates, system.to_model(S.q), "equations: rates")[0]
        psid = per_coordinate(system, rates, "equations: rates")
    for key in names_of(specified, "equations"):
        S.sgc[system.var_index(key)] = True
    # the scratch kept per system: making its views costs a third of a small call
    with WORKSPACES.use(system, "equations", make_scratch) as scratch:
        return _equations(system, S, psid, t, ptol, scratch)


def _equations(system: System, S: State, psid: np.ndarray, t: float, ptol: float,
               scratch: tuple[Any, Any]) -> EquationsOfMotion:
    """:func:`equations` at the assembled state S with the rates psid (internal units)
    in ``scratch`` (Data, DynData)."""
    nq = system.nq
    data, dyn = scratch
    M, cv, Qv = np.zeros((nq, nq)), np.zeros(nq), np.zeros(nq)
    if system.laws:
        # the laws read the joint rates phi' psi', which the first evaluation sets
        eom(system.KP, data.DP, system.YP, dyn.ZP, S, system.gen, ptol, psid,
            (M, cv, Qv))
        dyn.v.law[:] = law_values_at(system, S.q[None, :], S.qd[None, :], t)[0]
    nf, _, ke, pe = eom(system.KP, data.DP, system.YP, dyn.ZP, S, system.gen,
                        ptol, psid, (M, cv, Qv))
    cols = dyn.v.cols[:nf].copy()
    # model units: generalized forces times gscale (L^2 for an angle, L for a length)
    gs = system.Y.gscale[cols]
    e2 = system.length_scale ** 2
    # M_ij psi''_j is a force of i: scale by gs_i gs_j / L^2 (rates of lengths are / L)
    Mm = M[:nf, :nf] * np.outer(gs, gs) / e2
    coords = [system.var_names[c] for c in cols]
    sgc = S.sgc[cols].copy()
    F = np.flatnonzero(~sgc)
    # the body screws per unit of each free coordinate, model units (v in lengths)
    W = dyn.v.W[:, :nf][:, F].copy()
    W[:, :, :3] *= system.length_scale
    W /= system.var_scale[cols[F]][None, :, None]
    why = mass_check(system, Mm[np.ix_(F, F)], [coords[i] for i in F], W)
    return EquationsOfMotion(coords, sgc, Mm, cv[:nf] * gs, Qv[:nf] * gs, ke * e2, pe * e2,
                             why)
