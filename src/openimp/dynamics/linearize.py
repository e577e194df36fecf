"""The linearized equations of motion about one set point: :func:`linearize` (book ch 11).

M, D, K, F (11.7-11.10) over the generalized coordinates with the FGC/SGC
partition (11.12-11.14), from the compiled kernel of
:mod:`~openimp.dynamics.linear` plus the derivatives of load laws
(:func:`~openimp.dynamics.laws.law_derivatives`), converted to model units,
with the first-order derivatives of every point and the generalized
direction of every force element (what :mod:`~openimp.dynamics.frequency`
reads as inputs and outputs).  The scratch of the kernel is made once per
System and reused (:func:`kernel_buffers`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from openimp.dynamics.eom import equations
from openimp.dynamics.laws import law_derivatives, law_values_at
from openimp.dynamics.linear import (
    H_MOTION,
    Linearized,
    LinOptions,
    LinWork,
    linearize_kernel,
    make_lin_work,
    make_linearized,
)
from openimp.errors import AnalysisError, InputError
from openimp.kinematics.ballrates import spin_rates
from openimp.kinematics.inputs import (
    finite,
    given_state,
    named,
    names_of,
    per_coordinate,
    positive,
    posture_input,
)
from openimp.kinematics.posture import newton, sgc_residual
from openimp.results import Linearization
from openimp.system import (
    FORCE,
    TORQUE,
    State,
    System,
    make_scratch,
    make_state,
)
from openimp.workspace import WORKSPACES

#: closure tolerance of the postures the motion terms are differenced over
CLOSE_TOL = 1e-13
#: largest loop residual (internal units) of a posture accepted as assembled
ASSEMBLED = 1e-6


def linearize(system: System, q: Any = None, rates: Any = None, accels: Any = None, *,
              state: State | None = None, specified: Any = (), t: float = 0.0,
              pivot_tol: float = 1e-10, motion_terms: bool = True,
              close: bool = False) -> Linearization:
    """The linearized equations of motion of ``system`` about one set point (11.11).

    ``q``: the posture in model units: all nq joint variables, or a mapping of
    joint or ``"joint.var"`` to values (the others at the modeling posture);
    default the modeling posture; an assembled posture.  ``rates``,
    ``accels``: mappings coordinate -> rate, acceleration of the generalized
    coordinates at the set point (model units; default at rest);
    ``"joint.w": (wx, wy, wz)`` in ``rates`` gives a ball joint's (SPHERE, OPEN)
    angular velocity, its second body's relative to its first in the first
    body's joint frame u v w, as in :func:`~openimp.dynamics.response.simulate`
    (:func:`~openimp.kinematics.ballrates.spin_rates`: the rates of the three
    parameters other than the largest, at ``q``).
    ``specified``: the SGCs (joint names or ``"joint.var"``), the other
    generalized coordinates are the FGCs the elimination leaves.  ``t``: the
    time (load laws read it).  ``state``: a :class:`~openimp.system.State`
    instead of ``q``, ``rates``, ``t`` (internal units: its posture, time,
    SGCs ``sgc`` and joint rates; its non-zero accelerations count as given).
    A State passed as ``q`` works as ``state=`` with a DeprecationWarning.

    The accelerations of the set point: the SGCs' as given (default 0).  Those
    of the FGCs, when none of them is given and the set point moves, are the
    ones the equations of motion give there, M_FF psi''_F = Q_F - c_F -
    M_FS psi''_S (10.15), so that K holds the position derivative of
    M psi''* of the actual motion; at rest they are 0 unless given (K is then
    the book's stiffness at rest, 11.9, the frequencies of the posture held
    still, whether or not it is an equilibrium).

    ``motion_terms``: add the position derivatives of the velocity and
    acceleration terms that the book's K (11.9) leaves out (default; they
    vanish at rest).  ``close``: first close the loops of ``q`` to 1e-13
    holding the generalized coordinates (a posture solved to a looser
    tolerance); otherwise a posture that misses closing by more than 1e-6 is
    refused.  Rates and accelerations are those of the generalized
    coordinates: one given for a variable that the elimination makes
    dependent is an input error (specify it, or give the rate of a
    generalized coordinate).
    """
    if not isinstance(system, System):
        raise InputError(f"linearize takes a compiled System, got {type(system).__name__}")
    nq = system.nq
    pivot_tol = positive(pivot_tol, "linearize: pivot_tol")
    specified = names_of(specified, "linearize")
    state = given_state(system, q, state, "linearize", rates)
    given = state is None
    if state is not None:
        vs = system.var_scale
        qi, t = state.q.copy(), state.time
        specified = list(specified) + [system.var_names[c] for c in np.flatnonzero(state.sgc)]
        rates = {system.var_names[c]: state.qd[c] * vs[c] for c in range(nq) if state.qd[c]}
        if accels is None:
            accels = {system.var_names[c]: state.qdd[c] * vs[c] for c in range(nq)
                      if state.qdd[c]}
    else:
        qi = posture_input(system, q)
        t = finite(t, "linearize: t")
    qm = system.to_model(qi)
    rates, balls = spin_rates(system, rates, qm, "linearize: rates")
    S = make_state(system, qi, t)
    for key in specified:
        S.sgc[system.var_index(key)] = True
    vs = system.var_scale
    psid = per_coordinate(system, rates, "linearize: rates")
    psidd = per_coordinate(system, accels, "linearize: accels")
    if psid.any():
        motion_accelerations(system, S, psid, psidd, named(system, accels), pivot_tol)
    scratch = WORKSPACES.take(system, "linearize", _scratch)  # given back when done
    data, dyn, out, work = scratch
    out.qdpl[:] = 0.0  # the joint rates at the closed postures: written only when moving
    nlaw = len(system.laws)
    moving = motion_terms and bool(psid.any() or psidd.any())
    opts = LinOptions(pivot_tol, CLOSE_TOL, H_MOTION, moving, nlaw > 0)
    if nlaw:
        # the laws at the set point's joint rates phi' psi': phi' from a first pass
        # without the differenced terms, which need the laws' values
        first = LinOptions(pivot_tol, CLOSE_TOL, H_MOTION, False, False)
        nf = _kernel(system, data, dyn, S, first, psid, psidd, out, work)[0]
        qd = dyn.views("Gf")[:, :nf] @ psid[dyn.views("cols")[:nf]]
        dyn.views("law")[:] = law_values_at(system, S.q[None, :], qd[None, :], t)[0]
    nf, rank, status = _kernel(system, data, dyn, S, opts, psid, psidd, out, work)
    residual = float(np.abs(data.views("E")).max(initial=0.0))
    if close and residual > CLOSE_TOL:
        sgc0 = S.sgc.copy()
        S.sgc[dyn.views("cols")[:nf]] = True
        newton(system.KP, data.DP, S, system.gen, CLOSE_TOL, pivot_tol, 30, False)
        S.sgc[:] = sgc0
        qm = system.to_model(S.q)
        for joint, (bcols, e) in balls.items():
            if not np.allclose(qm[bcols], e, rtol=0.0, atol=1e-9):
                raise InputError(f"linearize: rates: the angular velocity of {joint!r} was "
                                 "given at a posture that closing the loops changes: close "
                                 "the posture first (or give the rates of its parameters)")
        nf, rank, status = _kernel(system, data, dyn, S, opts, psid, psidd, out, work)
        residual = float(np.abs(data.views("E")).max(initial=0.0))
    if residual > ASSEMBLED:
        raise InputError(f"linearize: q is not an assembled posture (the loops miss closing "
                         f"by {residual:.3g}); close it first, e.g. with openimp.sweep(system, "
                         "{driver: [value]}).q[0]")
    if status:
        name = system.var_names[int(dyn.views("cols")[status - 1])]
        raise AnalysisError(f"linearize: the loops do not close when {name} moves by "
                            f"{H_MOTION:g} from the set point: the posture is at or near a "
                            "singular position; move the set point away from it")
    M, D, K, F, Gl, qpl, qdpl = out.M, out.D, out.K, out.F, out.Gl, out.qpl, out.qdpl
    cols = dyn.views("cols")[:nf].copy()
    _check_coordinates(system, data, cols, rank, S.sgc, psid, psidd, given)
    G = dyn.views("Gf")[:, :nf].copy()
    M, D, K, F = M[:nf, :nf].copy(), D[:nf, :nf].copy(), K[:nf, :nf].copy(), F[:nf].copy()
    messages: list[str] = [f"element {system.elements[i]} left out: its two points "
                           "coincide at this posture (no direction, so no force or stiffness)"
                           for i in np.flatnonzero(dyn.views("eskip"))]
    if nlaw:
        law_derivatives(system, S.q, G, cols, qpl[:nf], qdpl[:nf], Gl[:nf], psid, t, D, K,
                         messages)
    # internal -> model units: rows are generalized forces (x gs), columns per unit
    # of coordinate (/ vs): X_model = gs_i X_int / vs_j
    gs = system.Y.gscale[cols]
    sc = np.outer(gs, 1.0 / vs[cols])
    phi = G * vs[:, None] / vs[cols][None, :]
    lin = Linearization(
        system, [system.var_names[c] for c in cols], S.sgc[cols].copy(), M * sc, D * sc,
        K * sc, F * gs, phi, qm.copy(), psid[cols] * vs[cols], psidd[cols] * vs[cols],
        float(t), _point_derivatives(system, data, dyn, nf, cols),
        _element_directions(system, data, dyn, nf, cols), _body_screws(system, dyn, nf, cols),
        int(rank), messages)
    WORKSPACES.give(system, "linearize", scratch)  # (dropped on an error: never shared)
    return lin


def motion_accelerations(system: System, S: State, psid: np.ndarray, psidd: np.ndarray,
                        given: np.ndarray, pivot_tol: float) -> None:
    """The FGC accelerations of a moving set point from the equations of motion, into
    ``psidd`` (nq,; internal units, in place): M_FF psi''_F = Q_F - c_F - M_FS psi''_S
    (10.15) at S.q, S.sgc, S.t with the generalized rates ``psid`` (nq,) and the SGC
    accelerations of ``psidd``.  Nothing is changed when the acceleration of a coordinate
    that is not specified is given (``given`` (nq,) bool: named by the caller, or
    non-zero in ``psidd``; of a dependent one it is refused later) or M_FF is singular
    (the analysis that solves with it says so)."""
    if np.any((given | (psidd != 0.0)) & ~S.sgc):
        return
    St = S.copy()
    St.qd[:] = psid
    e = equations(system, state=St, pivot_tol=pivot_tol)
    cols = np.array([system.var_index(n) for n in e.coords], np.int64)
    F, Sg = cols[~e.specified], cols[e.specified]
    if F.size == 0 or e.singular:
        return
    vs = system.var_scale
    psidd[F] = e.free_accelerations(psidd[Sg] * vs[Sg]) / vs[F]


def _check_coordinates(system: System, data: Any, cols: np.ndarray, rank: int,
                       sgc: np.ndarray, psid: np.ndarray, psidd: np.ndarray, given: bool
                       ) -> None:
    """Specified coordinates must be independent, and given rates those of generalized
    coordinates (a dependent variable's rate follows from them: phi' psi')."""
    names = [system.var_names[c] for c in cols]
    if sgc.any() and sgc_residual(data, sgc, rank) > 1e-8:
        spec = [system.var_names[c] for c in np.flatnonzero(sgc)]
        raise InputError(f"specified: {', '.join(spec)} are not independent at this posture "
                         "(one of them follows from the others); specify fewer")
    if not given or not (psid.any() or psidd.any()):
        return
    known = set(cols.tolist())
    for what, v in (("rates", psid), ("accels", psidd)):
        bad = [system.var_names[c] for c in np.flatnonzero(v) if c not in known]
        if bad:
            raise InputError(f"{what}: {', '.join(bad)} is not a generalized coordinate at "
                             f"this posture (they are {', '.join(names) or 'none'}); "
                             "specify it, or give the value of a generalized coordinate")


def _kernel(system: System, data: Any, dyn: Any, S: Any, opts: LinOptions, psid: np.ndarray,
            psidd: np.ndarray, out: Linearized, work: LinWork) -> tuple[int, int, int]:
    q0 = S.q.copy()
    res = linearize_kernel(system.KP, data.DP, system.YP, dyn.ZP, S, system.gen, opts,
                           psid, psidd, out, work)
    S.q[:] = q0
    return res


def _body_screws(system: System, dyn: Any, nf: int, cols: np.ndarray) -> np.ndarray:
    """W_{b,j} (nb, nf, 6) per model unit of coordinate j: v in lengths, w in radians."""
    W = dyn.views("W")[:, :nf].copy()
    vs = system.var_scale[cols]
    W[:, :, :3] *= system.length_scale
    return W / vs[None, :, None]


def _point_derivatives(system: System, data: Any, dyn: Any, nf: int, cols: np.ndarray
                       ) -> dict[str, np.ndarray]:
    """dR/dpsi (3, nf) of every point, model units: R'_j = v_bj + w_bj x R (7.25)."""
    if not system.points:
        return {}
    body = system.K.ptbody
    R = np.einsum("pij,pj->pi", data.views("T0")[body, :3], system.K.ptlocal)  # (np, 3)
    W = dyn.views("W")[body, :nf]  # (np, nf, 6)
    Rp = W[:, :, :3] + np.cross(W[:, :, 3:], R[:, None, :])
    Rp *= (system.length_scale / system.var_scale[cols])[None, :, None]
    return dict(zip(system.points, Rp.transpose(0, 2, 1), strict=True))


def _element_directions(system: System, data: Any, dyn: Any, nf: int, cols: np.ndarray
                        ) -> dict[str, np.ndarray]:
    """The generalized force (f,) of a unit force or torque element (9.32, 9.34), model
    units: u . R'_j at the point of a force, u . w_bj for a torque."""
    T0 = data.views("T0")
    W = dyn.views("W")[:, :nf]
    Ls, vs = system.length_scale, system.var_scale[cols]
    Y = system.Y
    out = {}

    def pos(p: int) -> np.ndarray:
        b = int(system.K.ptbody[p])
        return (T0[b] @ system.K.ptlocal[p])[:3]

    for i, name in enumerate(system.elements):
        kind = int(Y.ekind[i])
        if kind not in (FORCE, TORQUE):
            continue
        first = 1 if kind == FORCE else 0
        if Y.ept[i, first] >= 0:
            d = pos(int(Y.ept[i, first + 1])) - pos(int(Y.ept[i, first]))
            n = np.linalg.norm(d)
            u = d / n if n > 0 else np.zeros(3)
        else:
            u = np.asarray(Y.edir[i], float)
        b = int(Y.ebody[i])
        if kind == FORCE:
            R = pos(int(Y.ept[i, 0]))
            Rp = W[b, :, :3] + np.cross(W[b, :, 3:], R)  # (nf, 3) internal
            out[name] = Rp @ u * Ls / vs
        else:
            out[name] = W[b, :, 3:] @ u / vs
    return out


class _Views:
    """Named numpy views of one Data and DynData, each made once (a view costs ~3 us)."""

    def __init__(self, data: Any, dyn: Any) -> None:
        self.data, self.dyn = data, dyn
        self.cache: dict[str, np.ndarray] = {}

    def __call__(self, name: str) -> np.ndarray:
        v = self.cache.get(name)
        if v is None:
            src = self.dyn if name in ("law", "cols", "Gf", "W", "eskip") else self.data
            v = self.cache[name] = src.view(name)
        return v


def _scratch(system: System) -> tuple[Any, Any, Linearized, LinWork]:
    """(Data, DynData, out, work) of one :func:`linearize` call, kept per system by
    :data:`~openimp.workspace.WORKSPACES` (allocating them costs as much as the
    compiled kernel; the results never alias them); the Data and DynData carry
    ``views`` (:class:`_Views`)."""
    data, dyn = make_scratch(system)
    data.views = dyn.views = _Views(data, dyn)  # type: ignore[attr-defined]
    return (data, dyn, *kernel_buffers(system))


def kernel_buffers(system: System) -> tuple[Linearized, LinWork]:
    """The out and work of :func:`~openimp.dynamics.linear.linearize_kernel`."""
    nq, nb = system.nq, len(system.bodies)
    return make_linearized(nq, nb, len(system.laws)), make_lin_work(nq, nb)
