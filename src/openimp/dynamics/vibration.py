"""Linearized vibration: the Python entries of chapters 11 and 13.

* :func:`linearize`: M, D, K, F about a set point (11.7-11.10) with the
  FGC/SGC partition (11.12-11.14), from the compiled kernel of
  :mod:`~openimp.dynamics.linear` plus the derivatives of load laws;
* :func:`modes`: eigenvalues of the first-order FGC system with every SGC
  locked (13.9, 14.11), natural frequencies, damping ratios, time
  constants, mode shapes;
* :func:`modes_along`: the frequencies at every posture of a motion in one
  compiled pass (a frequency-versus-posture map);
* :func:`mode_motion`: one period of a mode as closed postures, to animate;
* :func:`transfer_function`, :func:`frequency_response`,
  :func:`state_space`: from a force element, a load on a joint variable or
  an SGC motion to positions, velocities or accelerations of joint variables
  and point components (13.18-13.21).

Inputs are ``("force", element)`` (a force or torque element of the model,
per unit of its magnitude), ``("load", "joint[.var]")`` (a force or moment
on a joint variable, positive tending to increase it) or
``("motion", "joint[.var]")`` (an SGC moved by x_S).  Outputs are
``("position" | "velocity" | "accel", name)`` with name a joint variable
(``"J"``, ``"J.var"``) or a point component (``"P.x"``, ``"P.y"``,
``"P.z"``).  Everything is in model units (radians for angles).
"""

from __future__ import annotations

import cmath
import math
from typing import Any

import numpy as np
import scipy.linalg

from openimp.dynamics.laws import law_values_at
from openimp.dynamics.linear import (
    H_MOTION,
    Linearized,
    LinOptions,
    LinSteps,
    LinWork,
    linearize_kernel,
    linearize_steps,
    make_lin_work,
    make_linearized,
)
from openimp.errors import AnalysisError, InputError
from openimp.kinematics import sweep
from openimp.kinematics.posture import newton, sgc_residual
from openimp.results import (
    FrequencyResponse,
    Linearization,
    ModeMap,
    Modes,
    StateSpace,
    Trajectory,
    TransferFunction,
)
from openimp.system import FORCE, TORQUE, State, System, make_data, make_dyn_data, make_state
from openimp.workspace import WORKSPACES

#: closure tolerance of the postures the motion terms are differenced over
CLOSE_TOL = 1e-13
#: relative size of M_FF's smallest eigenvalue below which it is singular
SINGULAR_M = 1e-14
#: largest loop residual (internal units) of a posture accepted as assembled
ASSEMBLED = 1e-6

OUTPUT_KINDS = ("position", "velocity", "accel")
INPUT_KINDS = ("force", "load", "motion")


# ----------------------------------------------------------------------------- linearize
def linearize(system: System, q: Any = None, rates: Any = None, accels: Any = None, *,
              specified: Any = (), t: float = 0.0, pivot_tol: float = 1e-10,
              motion_terms: bool = True, close: bool = False) -> Linearization:
    """The linearized equations of motion of ``system`` about one set point (11.11).

    ``q``: joint variables (nq,), model units, an assembled posture (default
    the modeling posture), or a :class:`~openimp.system.State` (internal
    units: its posture, time, specified coordinates ``sgc`` and the rates and
    accelerations of its joint variables, which for the generalized
    coordinates are theirs); ``specified``: the SGCs (joint names or
    ``"joint.var"``), the other generalized coordinates are the FGCs the
    elimination leaves; ``rates``, ``accels``: mappings coordinate -> rate,
    acceleration at the set point (default at rest).  ``motion_terms``: add the
    position derivatives of the velocity and acceleration terms that the
    book's K (11.9) leaves out (default; they vanish at rest).  ``close``:
    first close the loops of ``q`` to 1e-13 holding the generalized
    coordinates (a posture solved to a looser tolerance); otherwise a posture
    that misses closing by more than 1e-6 is refused.

    Rates and accelerations are those of the generalized coordinates: one given
    for a variable that the elimination makes dependent is an input error
    (specify it, or give the rate of a generalized coordinate).
    """
    if not isinstance(system, System):
        raise InputError(f"linearize takes a compiled System, got {type(system).__name__}")
    nq = system.nq
    pivot_tol = _positive(pivot_tol, "pivot_tol")
    specified = _names(specified)
    given = not isinstance(q, State)
    if isinstance(q, State):
        vs = system.var_scale
        st, q, t = q, system.to_model(q.q), q.time
        specified = list(specified) + [system.var_names[c] for c in np.flatnonzero(st.sgc)]
        rates = {system.var_names[c]: st.qd[c] * vs[c] for c in range(nq) if st.qd[c]}
        accels = {system.var_names[c]: st.qdd[c] * vs[c] for c in range(nq) if st.qdd[c]}
    qm = system.modeling_q if q is None else _floats(q, "q")
    if qm.shape != (nq,) or not np.all(np.isfinite(qm)):
        raise InputError(f"q must hold the {nq} joint variables as finite numbers, got "
                         f"shape {qm.shape}")
    t = float(_floats(t, "t"))
    S = make_state(system, system.to_internal(qm), t)
    for key in specified:
        S.sgc[system.var_index(key)] = True
    vs = system.var_scale
    psid = _per_coordinate(system, rates, "rates")
    psidd = _per_coordinate(system, accels, "accels")
    scratch = WORKSPACES.take(system, "linearize", _scratch)  # given back when done
    data, dyn, out, work = scratch
    out.qdpl[:] = 0.0  # the joint rates at the closed postures: written only when moving
    nlaw = len(system.laws)
    moving = motion_terms and bool(np.any(psid) or np.any(psidd))
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
    Ls = system.length_scale
    gs = np.where(vs[cols] == 1.0, Ls * Ls, Ls)
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


def _positive(x: Any, what: str) -> float:
    try:
        v = float(x)
    except (TypeError, ValueError):
        raise InputError(f"{what} must be a positive number, got {x!r}") from None
    if not (math.isfinite(v) and v > 0):
        raise InputError(f"{what} must be a positive number, got {x!r}")
    return v


def _floats(x: Any, what: str) -> np.ndarray:
    try:
        return np.asarray(x, float)
    except (TypeError, ValueError):
        raise InputError(f"{what} must be numbers, got {x!r}") from None


def _names(specified: Any) -> list[str]:
    """The specified coordinates as a list of names (a single name allowed)."""
    if specified is None:
        return []
    if isinstance(specified, str):
        return [specified]
    try:
        return list(specified)
    except TypeError:
        raise InputError(f"specified must be names of joints or 'joint.var', got "
                         f"{specified!r}") from None


def _kernel(system: System, data: Any, dyn: Any, S: Any, opts: LinOptions, psid: np.ndarray,
            psidd: np.ndarray, out: Linearized, work: LinWork) -> tuple[int, int, int]:
    q0 = S.q.copy()
    res = linearize_kernel(system.KP, data.DP, system.YP, dyn.ZP, S, system.gen, opts,
                           psid, psidd, out, work)
    S.q[:] = q0
    return res


def _per_coordinate(system: System, values: Any, what: str) -> np.ndarray:
    """A mapping coordinate -> value (model units) as an (nq,) internal array."""
    out = np.zeros(system.nq)
    if values is None:
        return out
    if not hasattr(values, "items"):
        raise InputError(f"{what} must map coordinate names to numbers, e.g. "
                         "{'crank': 10.0}")
    for key, v in values.items():
        c = system.var_index(key)
        try:
            x = float(v)
        except (TypeError, ValueError):
            raise InputError(f"{what}[{key!r}] must be a number, got {v!r}") from None
        if not math.isfinite(x):
            raise InputError(f"{what}[{key!r}] must be finite, got {x}")
        out[c] = x / system.var_scale[c]
    return out


def law_derivatives(system: System, q: np.ndarray, G: np.ndarray, cols: np.ndarray,
                    qpl: np.ndarray, qdpl: np.ndarray, Gl: np.ndarray, psid: np.ndarray,
                    t: float, D: np.ndarray, K: np.ndarray, messages: list[str],
                    sides: tuple[np.ndarray, np.ndarray] | None = None) -> None:
    """Add g_e dlaw_e/dpsi to K and g_e dlaw_e/dpsi' to D (internal units, in place):
    the laws are black boxes, differentiated by Richardson-extrapolated central
    differences over the closed postures of the kernel (positions) and over the
    joint rates phi' (psi' + s e_k) (rates), at the generalized rates of the set point.
    q (nq,): the set point's joint variables; G (nq, nf) its first-order
    coefficients, cols (nf,) its coordinates; qpl, qdpl (nf, 4, nq), Gl (nf, nlaw)
    and D, K (nf, nf) of :func:`~openimp.dynamics.linear.linearize_kernel`.
    ``sides`` (the time response): the directions (nf,) in which each coordinate
    and each rate is moving; where a law has a kink inside the stencil (a stop's
    contact, a one-way damper at rest) its slope is then taken on one side
    (:func:`_kinked_slopes`), not averaged across the kink."""
    nf = G.shape[1]
    u = psid[cols]
    qd0 = G @ u
    h = H_MOTION
    rows_q, rows_qd = [], []
    for lcol in range(nf):
        for p in range(4):
            rows_q.append(qpl[lcol, p])
            rows_qd.append(qdpl[lcol, p])  # phi'(psi) psi'*: 0 at rest
    s = 1e-4 * max(1.0, float(np.max(np.abs(u))) if nf else 1.0)
    for k in range(nf):
        for off in (-2.0, -1.0, 1.0, 2.0):
            rows_q.append(q.copy())
            rows_qd.append(qd0 + off * s * G[:, k])
    if sides is not None:  # the laws at the set point itself, for one-sided slopes
        rows_q.append(q.copy())
        rows_qd.append(qd0)
    vals = law_values_at(system, np.array(rows_q), np.array(rows_qd), t)
    w = np.array([1.0, -8.0, 8.0, -1.0])
    nl = Gl.shape[1]
    Pq = vals[:4 * nf].reshape(nf, 4, -1)
    Pr = vals[4 * nf:8 * nf].reshape(nf, 4, -1)
    dpos = (w @ Pq) / (12.0 * h)  # (nf, nlaw)
    drat = (w @ Pr) / (12.0 * s)
    if sides is not None:
        dpos = _kinked_slopes(Pq, vals[8 * nf], h, sides[0], dpos)
        drat = _kinked_slopes(Pr, vals[8 * nf], s, sides[1], drat)
    K -= Gl[:, :nl] @ dpos[:, :nl].T
    D -= Gl[:, :nl] @ drat[:, :nl].T
    messages.append("load laws differentiated numerically (central differences, "
                    "Richardson extrapolation)")


def _kinked_slopes(P: np.ndarray, f0: np.ndarray, h: float, direction: np.ndarray,
                   central: np.ndarray) -> np.ndarray:
    """The slopes of laws with a kink in their stencil taken on one side.  P (nf, 4,
    nlaw): the values at offsets (-2h, -h, h, 2h) of each coordinate; f0 (nlaw,) at
    the point; direction (nf,): the sign of the motion; central (nf, nlaw): the
    Richardson slopes, kept for a smooth law.  Where the one-sided slopes jump far
    more than either side bends (the point on the kink: a located switch) the side
    the motion goes to is taken (the central slope at rest); where they differ and
    only one side is straight, that one (the kink lies within h on the other);
    with the kink between h and 2h the inner central difference."""
    fwd1 = (P[:, 2] - f0) / h
    fwd2 = (P[:, 3] - f0) / (2.0 * h)
    bwd1 = (f0 - P[:, 1]) / h
    bwd2 = (f0 - P[:, 0]) / (2.0 * h)
    tiny = 1e-9 * max(float(np.abs(P).max(initial=0.0)) / h, 1e-300)

    def same(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        return np.abs(a - b) <= 1e-3 * np.maximum(np.abs(a), np.abs(b)) + tiny

    differ = ~same(fwd1, bwd1)
    f_ok, b_ok = same(fwd1, fwd2), same(bwd1, bwd2)
    # on the kink (within 1e-3 h of it): the sides jump far more than either bends (a
    # smooth law's one-sided slopes differ by its curvature, as much as each side bends;
    # a point at d h from a kink bends by d / 2 of the jump on that side)
    jump = np.abs(fwd1 - bwd1)
    bend = np.abs(fwd2 - fwd1) + np.abs(bwd1 - bwd2)
    at0 = differ & (jump > 1000.0 * bend + tiny)
    go = np.broadcast_to(np.sign(direction)[:, None], differ.shape)
    use_f = (at0 & (go > 0)) | (differ & ~at0 & f_ok & ~b_ok)
    use_b = (at0 & (go < 0)) | (differ & ~at0 & b_ok & ~f_ok)
    # a kink between h and 2h: the inner points agree, the outer ones are off it
    inner = 0.5 * (fwd1 + bwd1)
    out = np.where(~differ & ~same(central, inner), inner, central)
    return np.where(use_f, fwd1, np.where(use_b, bwd1, out))


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


# ----------------------------------------------------------------------------- modes
def _free_blocks(lin: Linearization) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """M_FF, D_FF, K_FF, with M_FF checked (13.3 note: a singular M_FF is a modeling
    error naming the bodies that move without mass)."""
    if not lin.specified.any():
        MFF, DFF, KFF = lin.M, lin.D, lin.K
    else:
        F = lin.free
        MFF, DFF, KFF = (X[F][:, F] for X in (lin.M, lin.D, lin.K))
    _check_mass(lin, MFF)
    return MFF, DFF, KFF


def check_mass(lin: Linearization) -> None:
    """Raise InputError naming the free coordinates and the bodies that move without
    kinetic energy when M_FF of ``lin`` is singular (the time response's diagnosis
    of a singular mass matrix at its start)."""
    _free_blocks(lin)


def _check_mass(lin: Linearization, MFF: np.ndarray) -> None:
    """A Cholesky factor's smallest pivot bounds M_FF's smallest eigenvalue from above:
    only a small one is looked at closer (eigh) and reported."""
    if MFF.size == 0:
        return
    d = MFF.diagonal().tolist()
    # the scale M_FF is measured against: its own diagonal and the model's mass (a 1 x 1
    # M_FF of round-off size is as singular as a zero one); not the SGCs' block, which a
    # heavy carriage would make dwarf a light part that does move
    top = max(max(abs(x) for x in d), _mass_scale(lin.system), 1e-300)
    if len(d) == 1:
        if d[0] > SINGULAR_M * top:
            return
    else:
        try:
            L = np.linalg.cholesky(MFF)
            if min(L.diagonal().tolist()) ** 2 > SINGULAR_M * top:
                return
        except np.linalg.LinAlgError:
            pass
    lam, vec = np.linalg.eigh(0.5 * (MFF + MFF.T))
    bad = np.flatnonzero(lam <= SINGULAR_M * top)
    if bad.size == 0:
        return
    free = [lin.coords[i] for i in lin.free]
    v = vec[:, bad[0]]
    moving = [free[i] for i in np.flatnonzero(np.abs(v) > 1e-6 * np.max(np.abs(v)))]
    bodies = _moving_bodies(lin, v)
    raise InputError(
        "the mass matrix of the free coordinates is singular at this posture: moving "
        + ", ".join(moving) + " together moves "
        + (("bodies " + ", ".join(bodies)) if bodies else "no body") + " without "
        "kinetic energy (no mass or inertia there); give those bodies mass and inertia "
        "(Model.add_mass, DATA MASS / DATA INERTIA) or specify the coordinate")


def _rate_scale(M: np.ndarray, D: np.ndarray, K: np.ndarray) -> np.ndarray:
    """The size of the system's rates, sqrt(|K| / |M|) + |D| / |M| (infinity norms) of
    M, D, K over every coordinate, SGCs included: a free block of round-off size is
    measured against the rest of the mechanism.  Batched over leading axes."""
    def norm(X: np.ndarray) -> np.ndarray:
        return np.abs(X).sum(axis=-1).max(axis=-1)

    m = np.maximum(norm(M), 1e-300)
    return np.sqrt(norm(K) / m) + norm(D) / m


def _no_fgc(what: str, lin: Linearization) -> str:
    """Why nothing vibrates: every coordinate specified, or none at all (a structure)."""
    if not lin.coords:
        return (f"{what}: the mechanism has no generalized coordinates at this posture (it "
                "is a structure: mobility 0), so nothing can vibrate")
    return (f"{what}: there are no free generalized coordinates (every coordinate is "
            "specified), so nothing can vibrate")


def _eigen(Sm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues and eigenvectors of the first-order matrix (14.11).  One FGC: the
    roots of s^2 - S00 s - S01 = 0 (m s^2 + d s + k) with eigenvectors (lambda, 1),
    in closed form (numpy's general solver costs more than the rest of a call)."""
    if Sm.shape[0] != 2:
        return np.linalg.eig(Sm)
    b, c = -float(Sm[0, 0]), -float(Sm[0, 1])  # s^2 + b s + c
    disc = cmath.sqrt(b * b - 4.0 * c)
    # the larger root without cancellation, the other from the product c
    r1 = (-b - disc) / 2.0 if b >= 0 else (-b + disc) / 2.0
    r2 = c / r1 if r1 != 0 else (-b - r1)
    lam = np.array([r1, r2], complex)
    eta = np.array([[r1, r2], [1.0, 1.0]], complex)
    return lam, eta / np.sqrt(np.abs(lam) ** 2 + 1.0)


def _first_order(MFF: np.ndarray, DFF: np.ndarray, KFF: np.ndarray) -> np.ndarray:
    """S = [[-M^-1 D, -M^-1 K], [I, 0]] (14.11), state (v_F, x_F); batched over leading
    axes of (..., nf, nf) blocks."""
    nf = MFF.shape[-1]
    Sm = np.zeros((*MFF.shape[:-2], 2 * nf, 2 * nf))
    Sm[..., :nf, :] = -np.linalg.solve(MFF, np.concatenate([DFF, KFF], axis=-1))
    Sm[..., nf:, :nf] = np.eye(nf)
    return Sm


def _mass_scale(system: System) -> float:
    """The model's mass times min(1, L^2), model units: what a M_FF entry of round-off
    size is measured against (:func:`_check_mass`)."""
    return float(system.Y.Jb[:, 3, 3].sum()) * min(1.0, system.length_scale ** 2)


def _moving_bodies(lin: Linearization, vF: np.ndarray) -> list[str]:
    """Bodies whose twist sum_j W_{b,j} vF_j is not zero when the FGCs move by vF."""
    W = lin.bodies[:, lin.free]
    tw = np.abs(np.einsum("bjk,j->bk", W, vF)).max(axis=1)
    top = float(tw.max()) if tw.size else 0.0
    return [lin.system.bodies[b] for b in np.flatnonzero(tw > 1e-9 * max(top, 1e-300))]


def modes(lin: Linearization | System, **kwargs: Any) -> Modes:
    """Natural frequencies, damping ratios, time constants and mode shapes (13.9-13.13).

    ``lin``: a :class:`Linearization`, or a System with the arguments of
    :func:`linearize`.  Every SGC is locked (x_S = 0); the eigenvalues are
    those of the first-order system y' = S y, y = (v_F, x_F) (14.11), a general
    (not symmetric) matrix, so gyroscopic and follower-load terms are kept.
    Raises :class:`InputError` when M_FF is singular and
    :class:`AnalysisError` when there are no FGCs.
    """
    if isinstance(lin, System):
        lin = linearize(lin, **kwargs)
    elif not isinstance(lin, Linearization):
        raise InputError(f"modes takes a Linearization or a System, got {type(lin).__name__}")
    elif kwargs:
        raise InputError("modes: arguments besides a Linearization are for a System")
    free = lin.free
    nf = free.size
    if nf == 0:
        raise AnalysisError(_no_fgc("modes", lin))
    MFF, DFF, KFF = _free_blocks(lin)
    Sm = _first_order(MFF, DFF, KFF)
    lam, eta = _eigen(Sm)
    # per eigenvalue in plain Python: a few of them, where numpy's per-call cost dominates
    lams = lam.tolist()
    # |lambda| of round-off size against the system's own rates is zero (neutral): a K_FF
    # of 1e-14 instead of 0 must not make an unstable or a 1e-7 rad/s mode
    rate = float(_rate_scale(lin.M, lin.D, lin.K))
    tol = 1e-9 * max(max(abs(z) for z in lams), rate, 1e-300)
    zero = 1e-6 * rate
    # one entry per mode: a real eigenvalue, or the upper member of a pair; slowest first
    # (a neutral pair of round-off size counts twice, as the double zero it is)
    keep = sorted((k for k, z in enumerate(lams)
                   if abs(z.imag) <= tol or z.imag > 0 or abs(z) <= zero),
                  key=lambda k: abs(lams[k]))
    m = len(keep)
    mlam = lam[keep]
    shapes = eta[nf:, keep]
    freq, damp, damped, tau = [math.nan] * m, [math.nan] * m, [0.0] * m, [math.nan] * m
    kinds = []
    for r, k in enumerate(keep):
        z = lams[k]
        col = shapes[:, r]
        i = int(np.argmax(np.abs(col)))
        if col[i] != 0:
            shapes[:, r] = col / col[i]
        if abs(z) <= zero:
            shapes[:, r] = shapes[:, r].real
            tau[r] = math.inf
            kinds.append("neutral")
        elif abs(z.imag) > tol:
            freq[r] = abs(z)
            damp[r] = -z.real / abs(z) + 0.0
            damped[r] = z.imag
            kinds.append("oscillatory")
        else:
            shapes[:, r] = shapes[:, r].real
            neutral = abs(z.real) <= tol
            tau[r] = math.inf if neutral else -1.0 / z.real
            kinds.append("neutral" if neutral else "overdamped")
    unstable = (mlam.real > tol) & (np.abs(mlam) > zero)
    joint = lin.phi[:, free] @ shapes
    return Modes(lin, [lin.coords[i] for i in free], lam[np.argsort(np.abs(lam),
                 kind="stable")], mlam, np.array(freq), np.array(damp), np.array(damped),
                 np.array(tau), kinds, unstable, shapes, joint, Sm)


def modes_along(system: System, q: Any, rates: Any = None, accels: Any = None, *,
                specified: Any = None, t: Any = 0.0, pivot_tol: float = 1e-10) -> ModeMap:
    """Natural frequencies and damping ratios at every posture of ``q`` (13.9).

    ``q``: (steps, nq) assembled postures (model units) or a :class:`Trajectory`
    (its postures, its specified coordinates unless ``specified`` is given, its
    rates and times); ``rates``, ``accels``: mappings coordinate -> value or
    array (steps,); ``t``: time or times.  The same result as :func:`modes` of
    :func:`linearize` at every step, linearized in one compiled pass and the
    eigenvalues found together (load laws, being Python, take the step-by-step
    route).
    """
    if not isinstance(system, System):
        raise InputError(f"modes_along takes a compiled System, got {type(system).__name__}")
    nq = system.nq
    pivot_tol = _positive(pivot_tol, "pivot_tol")
    if isinstance(q, Trajectory):
        tr = q
        qm = tr.q
        if specified is None:
            specified = list(tr.sgc)
        if rates is None and tr.has_rates:
            rates = {n: tr.qd[:, system.var_index(n)] for n in specified}
            accels = {n: tr.qdd[:, system.var_index(n)] for n in specified}
        if tr.time is not None and np.isscalar(t) and t == 0.0:
            t = tr.time
    else:
        qm = _floats(q, "modes_along: q")
    specified = _names(specified)
    if qm.ndim != 2 or qm.shape[1] != nq or not np.all(np.isfinite(qm)):
        raise InputError(f"modes_along: q must be (steps, {nq}) finite joint variables, got "
                         f"shape {np.shape(qm)}")
    n = qm.shape[0]
    tv = _floats(t, "modes_along: t")
    if tv.ndim > 1 or (tv.ndim == 1 and tv.size != n) or not np.all(np.isfinite(tv)):
        raise InputError(f"modes_along: t must be one time or {n} of them")
    T = np.broadcast_to(tv, (n,)).copy()
    if n == 0:
        return _mode_map(system, qm, [])
    psid = _per_step(system, rates, n, "rates")
    psidd = _per_step(system, accels, n, "accels")
    sgc = np.zeros(nq, bool)
    for key in specified:
        sgc[system.var_index(key)] = True
    if system.laws:
        blocks, why = [], []
        for k in range(n):
            r = {system.var_names[c]: psid[k, c] * system.var_scale[c] for c in range(nq)
                 if psid[k, c]}
            a = {system.var_names[c]: psidd[k, c] * system.var_scale[c] for c in range(nq)
                 if psidd[k, c]}
            try:
                lin = linearize(system, qm[k], r, a, specified=specified, t=float(T[k]),
                                pivot_tol=pivot_tol)
            except (InputError, AnalysisError) as exc:  # this step only
                blocks.append(([k], None, [], np.zeros(0, bool), -3))
                why.append(f"step {k}: {exc}")
                continue
            blocks.append(([k], np.stack([lin.M, lin.D, lin.K])[None], lin.coords,
                           lin.specified, 0))
        mm = _mode_map(system, qm, blocks)
        mm.messages[:0] = why
        return mm
    S = make_state(system, system.to_internal(qm[0]), float(T[0]))
    S.sgc[:] = sgc
    data = make_data(system, nq)
    dyn = make_dyn_data(system, nq)
    out, work = _buffers(system)
    opts = LinOptions(pivot_tol, CLOSE_TOL, H_MOTION, True, False)
    steps = LinSteps(q=system.to_internal(qm), psid=psid, psidd=psidd, t=T,
                     mdk=np.zeros((n, 3, nq, nq)), nf=np.zeros(n, np.int64),
                     cols=np.zeros((n, nq), np.int64), res=np.zeros(n))
    linearize_steps(system.KP, data.DP, system.YP, dyn.ZP, S, system.gen, opts, steps, out,
                    work)
    MDK, NF, COLS, RES = steps.mdk, steps.nf, steps.cols, steps.res
    loose = np.flatnonzero(RES > ASSEMBLED)
    NF[loose] = -2
    vs = system.var_scale
    Ls = system.length_scale
    groups: dict[tuple[int, ...], list[int]] = {}
    for k in range(n):
        key = tuple(COLS[k, :NF[k]]) if NF[k] >= 0 else (int(NF[k]),)
        groups.setdefault(key, []).append(k)
    blocks = []
    for key, idx in groups.items():
        if key and key[0] < 0:
            blocks.append((idx, None, [], np.zeros(0, bool), key[0]))
            continue
        cols = np.array(key, np.int64)
        nf = cols.size
        sc = np.outer(np.where(vs[cols] == 1.0, Ls * Ls, Ls), 1.0 / vs[cols])
        blocks.append((idx, MDK[idx, :, :nf, :nf] * sc, [system.var_names[c] for c in cols],
                       sgc[cols], 0))
    return _mode_map(system, qm, blocks)


def _per_step(system: System, values: Any, n: int, what: str) -> np.ndarray:
    """A mapping coordinate -> value or (steps,) values, model units, as (steps, nq)
    internal values."""
    out = np.zeros((n, system.nq))
    if values is None:
        return out
    if not hasattr(values, "items"):
        raise InputError(f"{what} must map coordinate names to numbers or arrays")
    for key, v in values.items():
        c = system.var_index(key)
        arr = np.asarray(v, float)
        if arr.ndim > 1 or (arr.ndim == 1 and arr.size != n) or not np.all(np.isfinite(arr)):
            raise InputError(f"{what}[{key!r}] must be a finite number or {n} of them")
        out[:, c] = arr / system.var_scale[c]
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
    data, dyn = make_data(system, system.nq), make_dyn_data(system, system.nq)
    data.views = dyn.views = _Views(data, dyn)  # type: ignore[attr-defined]
    return (data, dyn, *_buffers(system))


def _buffers(system: System) -> tuple[Linearized, LinWork]:
    """The out and work of :func:`~openimp.dynamics.linear.linearize_kernel`."""
    nq, nb = system.nq, len(system.bodies)
    return make_linearized(nq, nb, len(system.laws)), make_lin_work(nq, nb)


def _mode_map(system: System, qm: np.ndarray, blocks: list) -> ModeMap:
    """Eigenvalues of every step's FGC system, solved together for the steps of one set of
    coordinates; frequencies sorted per step.  ``blocks``: (steps, MDK (steps, 3, f,
    f) model units or None, coordinate names, specified mask, why None: -1 the loops
    do not close near the posture, -2 it is not assembled, -3 said by the caller)."""
    n = qm.shape[0]
    sizes = [-1] * n
    for idx, X, _, spec, fail in blocks:
        for k in idx:
            sizes[k] = fail if X is None else int((~spec).sum())
    width = max([s for s in sizes if s > 0], default=0)
    lam = np.full((n, 2 * width), np.nan + 0j)
    coords: list[list[str]] = [[] for _ in range(n)]
    messages: list[str] = []
    rate = np.full(n, np.nan)
    for idx, X, names, spec, _ in blocks:
        F = np.flatnonzero(~spec)
        nf = F.size
        if X is None or nf == 0:
            continue
        XF = X[:, :, F][:, :, :, F]  # (steps, 3, nf, nf)
        # a nearly singular M_FF: the test of modes (_check_mass), every step at once; its
        # steps get a unit mass so that the others solve together
        low = np.linalg.eigvalsh(0.5 * (XF[:, 0] + XF[:, 0].transpose(0, 2, 1)))[:, 0]
        top = np.maximum(np.abs(np.diagonal(XF[:, 0], axis1=1, axis2=2)).max(axis=1),
                         _mass_scale(system))
        ok = low > SINGULAR_M * np.maximum(top, 1e-300)
        for r in np.flatnonzero(~ok):
            messages.append(f"step {idx[r]}: the mass matrix of the free coordinates is "
                            "singular (a massless part can move alone); no modes")
        XF = np.where(ok[:, None, None, None], XF, np.eye(nf))
        Sm = _first_order(XF[:, 0], XF[:, 1], XF[:, 2])
        rows = [idx[r] for r in range(len(idx)) if ok[r]]
        for k in rows:
            coords[k] = [names[i] for i in F]
        if not rows:
            continue
        ev = np.linalg.eigvals(Sm[ok])
        order = np.argsort(np.abs(ev), axis=1, kind="stable")
        lam[rows, :2 * nf] = np.take_along_axis(ev, order, axis=1)
        rate[rows] = _rate_scale(X[ok, 0], X[ok, 1], X[ok, 2])
    for k, sz in enumerate(sizes):
        if sz == -3:
            continue  # said by the step-by-step route
        if sz == -2:
            messages.append(f"step {k}: not an assembled posture (the loops miss closing by "
                            "more than 1e-6); no modes")
        elif sz < 0:
            messages.append(f"step {k}: the loops do not close near this posture (singular)")
        elif sz == 0:
            messages.append(f"step {k}: no free generalized coordinates")
    # the tolerances of modes: round-off against the step's own rates (_rate_scale)
    with np.errstate(invalid="ignore", divide="ignore"):
        mag = np.abs(lam)
        big = np.fmax(np.nanmax(np.where(np.isnan(mag), -np.inf, mag), axis=1,
                                initial=0.0), np.nan_to_num(rate))[:, None]
        tol = 1e-9 * np.maximum(big, 1e-300)
        zero = 1e-6 * np.nan_to_num(rate)[:, None]
        valid = ~np.isnan(lam)
        neutral = valid & (mag <= zero)
        osc = valid & ~neutral & (lam.imag > tol)
        real = valid & ~neutral & (np.abs(lam.imag) <= tol)
        freq = np.where(osc, mag, np.nan)
        damp = np.where(osc, -lam.real / mag, np.nan)
        tau = np.where(real, -1.0 / lam.real, np.where(neutral, np.inf, np.nan))
    # oscillatory modes first in order of frequency, NaN padding last
    fo = np.argsort(np.where(np.isnan(freq), np.inf, freq), axis=1, kind="stable")[:, :width]
    frequency = np.take_along_axis(freq, fo, axis=1)
    damping = np.take_along_axis(damp, fo, axis=1)
    unstable = np.any(valid & ~neutral & (lam.real > tol), axis=1)
    return ModeMap(system, qm.copy(), coords, lam, frequency, damping, tau, unstable,
                   messages)


# ----------------------------------------------------------------------------- transfer
def _input_vector(lin: Linearization, inp: Any) -> tuple[tuple[str, str], np.ndarray, int]:
    """(label, generalized direction over coords (f,), SGC index or -1)."""
    kind, name = _pair(inp, INPUT_KINDS, "input")
    system = lin.system
    if kind == "force":
        if name not in lin.inputs:
            known = ", ".join(lin.inputs) or "none"
            raise InputError(f"input ('force', {name!r}): not a force or torque element of "
                             f"the model (known: {known})")
        g = lin.inputs[name]
        if not np.any(g):
            raise InputError(f"input ('force', {name!r}): the element has no direction at "
                             "this posture (its two direction points coincide) or does no "
                             "work on any free coordinate")
        return (kind, name), g, -1
    c = system.var_index(name)
    vname = system.var_names[c]
    if kind == "load":
        g = lin.phi[c].copy()
        if not np.any(g[lin.free]):
            raise InputError(f"input ('load', {name!r}): {vname} is locked (a specified "
                             "coordinate, or moved by none of the free ones), so a load on it "
                             "moves nothing; use ('motion', ...) for a specified coordinate")
        return (kind, vname), g, -1
    if vname not in lin.coords or not lin.specified[lin.coords.index(vname)]:
        raise InputError(f"input ('motion', {name!r}): {vname} is not a specified "
                         "generalized coordinate (SGC) of this linearization; pass it in "
                         "specified=")
    return (kind, vname), np.zeros(len(lin.coords)), lin.coords.index(vname)


def _output_vector(lin: Linearization, out: Any) -> tuple[tuple[str, str], np.ndarray]:
    """(label, d output / d psi over coords (f,)) of a position-level output."""
    kind, name = _pair(out, OUTPUT_KINDS, "output")
    system = lin.system
    if "." in name:
        head, _, axis = name.rpartition(".")
        if head in lin.points and axis.lower() in ("x", "y", "z"):
            return (kind, f"{head}.{axis.lower()}"), lin.points[head]["xyz".index(
                axis.lower())].copy()
    if name in lin.points:
        raise InputError(f"output ({kind!r}, {name!r}): name a component of the point, "
                         f"e.g. {name}.x")
    c = system.var_index(name)
    return (kind, system.var_names[c]), lin.phi[c].copy()


def _listed(x: Any, what: str) -> list:
    """One (kind, name) pair or a non-empty list of them."""
    if isinstance(x, tuple) and len(x) == 2 and isinstance(x[0], str):
        return [x]
    try:
        out = list(x)
    except TypeError:
        raise InputError(f"{what} must be a (kind, name) pair or a list of them, got "
                         f"{x!r}") from None
    if not out:
        raise InputError(f"{what}: give at least one (kind, name) pair")
    return out


def _pair(x: Any, kinds: tuple[str, ...], what: str) -> tuple[str, str]:
    if (not isinstance(x, (tuple, list)) or len(x) != 2 or not isinstance(x[0], str)
            or not isinstance(x[1], str)):
        raise InputError(f"{what} must be a pair (kind, name) with kind one of "
                         f"{', '.join(kinds)}; got {x!r}")
    k = x[0].lower()
    if k == "acceleration":
        k = "accel"
    if k not in kinds:
        raise InputError(f"{what} kind {x[0]!r}: expected one of {', '.join(kinds)}")
    return k, x[1]


def _realization(lin: Linearization, b: np.ndarray, p: int, c: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A, B, C, D of the position output c . psi for one input, state (v, x) (13.6).

    Force or load b: M x'' + D x' + K x = b_F u.  SGC motion p (x_p = u):
    M x'' + D x' + K x = -(M_Fp u'' + D_Fp u' + K_Fp u), realized with the state
    x' = x + P u, v'' = x'' ... shifted so that no derivative of u remains:
    P = M^-1 M_Fp, R = M^-1 (D P - D_Fp); x'^. = v'' + R u,
    v''^. = M^-1 (-K x' - D v'' + (K P - K_Fp - D R) u), y = c_F x' + (c_p - c_F P) u.
    """
    MFF, DFF, KFF = _free_blocks(lin)
    F = lin.free
    nf = F.size
    Minv = np.linalg.inv(MFF)
    A = _first_order(MFF, DFF, KFF)
    cF = c[F]
    C = np.concatenate([np.zeros(nf), cF])[None, :]
    if p < 0:
        B = np.concatenate([Minv @ b[F], np.zeros(nf)])[:, None]
        return A, B, C, np.zeros((1, 1))
    Mp, Dp, Kp = lin.M[F, p], lin.D[F, p], lin.K[F, p]
    P = Minv @ Mp
    R = Minv @ (DFF @ P - Dp)
    B = np.concatenate([Minv @ (KFF @ P - Kp - DFF @ R), R])[:, None]
    return A, B, C, np.array([[c[p] - cF @ P]])


def transfer_function(lin: Linearization, input: Any, output: Any) -> TransferFunction:
    """H(s) from ``input`` to ``output`` as a rational function of s (13.18-13.21), every
    SGC but a motion input locked.  Velocity and acceleration outputs are s and s^2
    times the position's."""
    (ilab, b, p), (olab, c) = _input_vector(lin, input), _output_vector(lin, output)
    if lin.free.size == 0:
        raise AnalysisError(_no_fgc("transfer_function", lin))
    A, B, C, D = _realization(lin, b, p, c)
    num, den = _ss2tf(A, B, C, D)
    extra = OUTPUT_KINDS.index(olab[0])
    num = np.concatenate([num, np.zeros(extra)])
    return TransferFunction(ilab, olab, _trim(num), den)


def _ss2tf(A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray
           ) -> tuple[np.ndarray, np.ndarray]:
    """num, den of H(s) = C (sI - A)^-1 B + D (one input, one output), from roots.

    den = det(sI - A) from the eigenvalues of A (monic); num = g prod (s - z_i)
    with the zeros z_i the finite generalized eigenvalues of the Rosenbrock
    pencil ([[A, B], [C, D]], [[I, 0], [0, 0]]) (QZ: backward stable) and the
    gain g from H at the sample of largest |H| among points on the circle of
    the eigenvalues' geometric-mean size (turned off the axes, where poles of
    real and undamped modes sit).  Subtracting polynomials instead loses every
    digit on a stiff system.  Terms below 1e-12 of the largest at that size are
    round-off and set to zero.
    """
    lam = np.linalg.eigvals(A)
    n = lam.size
    mags = np.abs(lam[np.abs(lam) > 0])
    w0 = float(np.exp(np.mean(np.log(mags)))) if mags.size else 1.0
    den = _clean(np.real(np.poly(lam)), w0)
    P = np.block([[A, B], [C, D]])
    Q = np.zeros_like(P)
    Q[:n, :n] = np.eye(n)
    with np.errstate(all="ignore"):
        z = scipy.linalg.eigvals(P, Q)
    z = z[np.isfinite(z) & (np.abs(z) < 1e10 * max(w0, 1.0))]
    sk = w0 * np.exp(2j * np.pi * (np.arange(n + 1) + 0.3) / (n + 1))
    H = np.array([(C @ np.linalg.solve(sv * np.eye(n) - A, B))[0, 0] + D[0, 0] for sv in sk])
    k = int(np.argmax(np.abs(H)))
    if abs(H[k]) == 0.0:
        return np.zeros(1), den
    g = H[k] * np.polyval(den, sk[k]) / np.prod(sk[k] - z)
    num = np.real(g * np.poly(z)) if z.size else np.array([g.real])
    return _trim(_clean(num, w0)), den


def _clean(c: np.ndarray, w0: float) -> np.ndarray:
    """Zero the coefficients (highest power first) whose terms at |s| = w0 are below
    1e-12 of the largest: round-off of a cancelled or absent power."""
    terms = np.abs(c) * w0 ** np.arange(c.size - 1, -1, -1)
    big = float(terms.max()) if terms.size else 0.0
    out = c.copy()
    out[terms <= 1e-12 * big] = 0.0
    return out


def _trim(num: np.ndarray) -> np.ndarray:
    """Drop leading zero coefficients (a numerator of lower degree)."""
    k = 0
    while k < num.size - 1 and num[k] == 0.0:
        k += 1
    return num[k:]


def frequency_response(lin: Linearization, input: Any, outputs: Any, w: Any
                       ) -> FrequencyResponse:
    """H(j w) (13.20, 13.21) of one input to each output at frequencies ``w`` (rad/s),
    solved at each w from (s^2 M_FF + s D_FF + K_FF) x_F = rhs, not from polynomials."""
    ilab, b, p = _input_vector(lin, input)
    outs = [_output_vector(lin, o) for o in _listed(outputs, "outputs")]
    wv = np.atleast_1d(_floats(w, "frequency_response: w"))
    if wv.ndim != 1 or not np.all(np.isfinite(wv)) or np.any(wv < 0) or wv.size == 0:
        raise InputError("frequency_response: w must be finite frequencies >= 0 (rad/s)")
    if lin.free.size == 0:
        raise AnalysisError(_no_fgc("frequency_response", lin))
    MFF, DFF, KFF = _free_blocks(lin)
    F = lin.free
    H = np.zeros((wv.size, len(outs)), complex)
    for k, om in enumerate(wv):
        s = 1j * om
        Z = s * s * MFF + s * DFF + KFF
        if p < 0:
            rhs, xs = b[F].astype(complex), 0.0
        else:
            rhs = -(s * s * lin.M[F, p] + s * lin.D[F, p] + lin.K[F, p])
            xs = 1.0
        try:
            xF = np.linalg.solve(Z, rhs)
        except np.linalg.LinAlgError:
            raise AnalysisError(f"frequency_response: w = {om:g} rad/s is a pole of the "
                                "response (a rigid-body mode at 0, or an undamped mode at "
                                "that frequency); leave it out of w") from None
        with np.errstate(all="ignore"):  # an extreme w overflows to inf, said by the value
            for o, ((kind, _), c) in enumerate(outs):
                y = c[F] @ xF + (c[p] * xs if p >= 0 else 0.0)
                H[k, o] = y * s ** OUTPUT_KINDS.index(kind)
    return FrequencyResponse(wv, H, ilab, [lab for lab, _ in outs])


def state_space(lin: Linearization, inputs: Any, outputs: Any) -> StateSpace:
    """A, B, C, D of the FGC equations (14.11) for ``inputs`` and ``outputs``, state
    (v_F, x_F) (13.6).  A motion input shifts the state (see :func:`transfer_function`);
    it then allows only position outputs (a velocity or acceleration output would
    need derivatives of the input) and no other input."""
    if isinstance(inputs, tuple) and len(inputs) == 2 and isinstance(inputs[0], str):
        inputs = [inputs]
    if isinstance(outputs, tuple) and len(outputs) == 2 and isinstance(outputs[0], str):
        outputs = [outputs]
    ins = [_input_vector(lin, i) for i in inputs]
    outs = [_output_vector(lin, o) for o in outputs]
    if not ins or not outs:
        raise InputError("state_space needs at least one input and one output")
    if lin.free.size == 0:
        raise AnalysisError(_no_fgc("state_space", lin))
    motion = [lab for lab, _, p in ins if p >= 0]
    if motion and len(ins) > 1:
        raise InputError("state_space: an SGC motion input shifts the state, so it must be "
                         "the only input; build one model per motion input")
    F = lin.free
    nf = F.size
    MFF, DFF, KFF = _free_blocks(lin)
    Minv = np.linalg.inv(MFF)
    rows_C, rows_D = [], []
    if motion:
        _, b, p = ins[0]
        for (kind, name), c in outs:
            if kind != "position":
                raise InputError(f"state_space: output ({kind!r}, {name!r}) of a motion "
                                 "input is improper (it needs derivatives of the motion); "
                                 "use a position output or transfer_function")
            A, B, C, D = _realization(lin, b, p, c)
            rows_C.append(C[0])
            rows_D.append(D[0])
    else:
        A = _first_order(MFF, DFF, KFF)
        B = np.column_stack([np.concatenate([Minv @ b[F], np.zeros(nf)])
                             for _, b, _ in ins])
        bF = np.column_stack([b[F] for _, b, _ in ins])
        for (kind, _), c in outs:
            cF = c[F]
            if kind == "position":
                rows_C.append(np.concatenate([np.zeros(nf), cF]))
                rows_D.append(np.zeros(len(ins)))
            elif kind == "velocity":
                rows_C.append(np.concatenate([cF, np.zeros(nf)]))
                rows_D.append(np.zeros(len(ins)))
            else:
                rows_C.append(cF @ A[:nf])
                rows_D.append(cF @ Minv @ bF)
    free = [lin.coords[i] for i in F]
    states = [f"{n}'" for n in free] + list(free)
    return StateSpace(A, B, np.array(rows_C), np.array(rows_D), states,
                      [lab for lab, _, _ in ins], [lab for lab, _ in outs])


# ----------------------------------------------------------------------------- animation
def mode_motion(modes: Modes, mode: int = 0, amplitude: float = 0.1, steps: int = 48
                ) -> Trajectory:
    """One period of mode ``mode`` (0-based index into ``modes``) as exactly closed
    postures, to draw or animate like any sweep (:mod:`openimp.viz`).

    The FGCs move by amplitude * Re(shape e^{i theta}) about the set point
    (theta over one turn, ``steps`` frames; the largest FGC moves by
    ``amplitude``, model units: radians or lengths) and the loops are closed at
    every frame; the SGCs stay locked.  The trajectory's ``time`` is theta /
    (2 pi) times the mode's period (1 s for a mode that does not oscillate).
    """
    if not isinstance(modes, Modes):
        raise InputError(f"mode_motion takes the Modes of openimp.modes, got "
                         f"{type(modes).__name__}")
    if isinstance(mode, bool) or not (isinstance(mode, (int, np.integer))
                                      and 0 <= mode < modes.count):
        raise InputError(f"mode_motion: mode must be an index 0..{modes.count - 1}, got "
                         f"{mode!r}")
    if isinstance(steps, bool) or not (isinstance(steps, (int, np.integer)) and steps >= 2):
        raise InputError(f"mode_motion: steps must be an integer >= 2, got {steps!r}")
    amp = _positive(amplitude, "mode_motion: amplitude")
    lin = modes.linearization
    system = lin.system
    theta = np.linspace(0.0, 2 * math.pi, int(steps) + 1)
    shape = modes.shapes[:, mode]
    drivers = {}
    for k, i in enumerate(lin.free):
        name = lin.coords[i]
        c = system.var_index(name)
        drivers[name] = lin.q[c] + amp * np.real(shape[k] * np.exp(1j * theta))
    for i in lin.sgc:
        name = lin.coords[i]
        drivers[name] = np.full(theta.size, lin.q[system.var_index(name)])
    tr = sweep(system, drivers, q=lin.q)
    w = modes.damped[mode] if modes.kind[mode] == "oscillatory" else 2 * math.pi
    tr.time = theta[:tr.nsteps] / w
    return tr
