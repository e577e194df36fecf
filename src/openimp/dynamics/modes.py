"""Natural frequencies, damping and mode shapes of the linearized equations (book ch 13).

* :func:`modes`: eigenvalues of the first-order FGC system with every SGC
  locked (13.9, 14.11), natural frequencies, damping ratios, time
  constants, mode shapes;
* :func:`modes_along`: the frequencies at every posture of a motion in one
  compiled pass (a frequency-versus-posture map);
* :func:`mode_motion`: one period of a mode as closed postures, to animate;
* :func:`free_blocks`, :func:`first_order`: the FGC blocks (with the mass
  check) and the first-order matrix (14.11) that
  :mod:`~openimp.dynamics.frequency` builds on.
"""

from __future__ import annotations

import cmath
import math
from typing import Any

import numpy as np

from openimp.dynamics.eom import mass_floor, massless_message, null_motion, singular_masses
from openimp.dynamics.linear import H_MOTION, LinOptions, LinSteps, linearize_steps
from openimp.dynamics.linearize import (
    ASSEMBLED,
    CLOSE_TOL,
    kernel_buffers,
    linearize,
    motion_accelerations,
)
from openimp.errors import AnalysisError, InputError, deprecated
from openimp.kinematics import sweep
from openimp.kinematics.inputs import floats, named, names_of, per_step, positive
from openimp.limits import MAX_STEPS
from openimp.results import Linearization, ModeMap, Modes, Trajectory
from openimp.system import System, make_data, make_dyn_data, make_state


def free_blocks(lin: Linearization) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """M_FF, D_FF, K_FF, with M_FF checked (13.3 note: a singular M_FF is a modeling
    error naming the bodies that move without mass)."""
    if not lin.specified.any():
        MFF, DFF, KFF = lin.M, lin.D, lin.K
    else:
        F = lin.free
        MFF, DFF, KFF = (X[F][:, F] for X in (lin.M, lin.D, lin.K))
    check_mass(lin, MFF)
    return MFF, DFF, KFF


def check_mass(lin: Linearization, MFF: np.ndarray | None = None) -> None:
    """Raise InputError naming the free coordinates and the bodies that move without
    kinetic energy when M_FF of ``lin`` (or ``MFF``, its block) is singular (the one
    test and message of :mod:`~openimp.dynamics.eom`, as its :func:`mass_check`)."""
    if MFF is None:
        MFF = lin.M[np.ix_(lin.free, lin.free)]
    v = null_motion(MFF, mass_floor(lin.system))
    if v is not None:  # the names only on failure: modes() is called per posture
        F = lin.free
        raise InputError(massless_message([lin.coords[i] for i in F], lin.bodies[:, F],
                                          lin.system.bodies, v))


def _rate_scale(M: np.ndarray, D: np.ndarray, K: np.ndarray) -> np.ndarray:
    """The size of the system's rates, sqrt(|K| / |M|) + |D| / |M| (infinity norms) of
    M, D, K over every coordinate, SGCs included: a free block of round-off size is
    measured against the rest of the mechanism.  Batched over leading axes."""
    def norm(X: np.ndarray) -> np.ndarray:
        return np.abs(X).sum(axis=-1).max(axis=-1)

    m = np.maximum(norm(M), 1e-300)
    return np.sqrt(norm(K) / m) + norm(D) / m


def no_fgc(what: str, lin: Linearization) -> str:
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


def first_order(MFF: np.ndarray, DFF: np.ndarray, KFF: np.ndarray) -> np.ndarray:
    """S = [[-M^-1 D, -M^-1 K], [I, 0]] (14.11), state (v_F, x_F); batched over leading
    axes of (..., nf, nf) blocks."""
    nf = MFF.shape[-1]
    Sm = np.zeros((*MFF.shape[:-2], 2 * nf, 2 * nf))
    Sm[..., :nf, :] = -np.linalg.solve(MFF, np.concatenate([DFF, KFF], axis=-1))
    Sm[..., nf:, :nf] = np.eye(nf)
    return Sm


def modes(lin: Linearization, **kwargs: Any) -> Modes:
    """Natural frequencies, damping ratios, time constants and mode shapes (13.9-13.13).

    ``lin``: the :class:`Linearization` of :func:`linearize` (of a System:
    ``modes(openimp.linearize(system, q, ...))``; a System with the arguments
    of :func:`linearize` still works, with a DeprecationWarning).  Every SGC
    is locked (x_S = 0); the eigenvalues are those of the first-order system
    y' = S y, y = (v_F, x_F) (14.11), a general (not symmetric) matrix, so
    gyroscopic and follower-load terms are kept.  Each neutral freedom is one
    mode, of frequency 0.  Raises :class:`InputError` when M_FF is singular
    and :class:`AnalysisError` when there are no FGCs.
    """
    if isinstance(lin, System):
        deprecated("modes", "modes(system, ...)", "modes(openimp.linearize(system, ...))")
        lin = linearize(lin, **kwargs)
    elif not isinstance(lin, Linearization):
        raise InputError(f"modes takes a Linearization (of openimp.linearize), got "
                         f"{type(lin).__name__}")
    elif kwargs:
        raise InputError("modes takes one Linearization and no other argument; the set "
                         "point's arguments are linearize's")
    free = lin.free
    nf = free.size
    if nf == 0:
        raise AnalysisError(no_fgc("modes", lin))
    MFF, DFF, KFF = free_blocks(lin)
    Sm = first_order(MFF, DFF, KFF)
    lam, eta = _eigen(Sm)
    # per eigenvalue in plain Python: a few of them, where numpy's per-call cost dominates
    lams = lam.tolist()
    # |lambda| of round-off size against the system's own rates is zero (neutral): a K_FF
    # of 1e-14 instead of 0 must not make an unstable or a 1e-7 rad/s mode
    rate = float(_rate_scale(lin.M, lin.D, lin.K))
    tol = 1e-9 * max(max(abs(z) for z in lams), rate, 1e-300)
    zero = 1e-6 * rate
    # one entry per mode: a real eigenvalue, or the upper member of a pair; slowest first
    keep = sorted((k for k, z in enumerate(lams)
                   if abs(z.imag) <= tol or z.imag > 0 or abs(z) <= zero),
                  key=lambda k: abs(lams[k]))
    keep = _one_per_freedom(keep, lams, eta[nf:], tol, zero)
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
            freq[r] = 0.0
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
            freq[r] = 0.0 if neutral else math.nan
            kinds.append("neutral" if neutral else "overdamped")
    unstable = (mlam.real > tol) & (np.abs(mlam) > zero)
    joint = lin.phi[:, free] @ shapes
    return Modes(lin, [lin.coords[i] for i in free], lam[np.argsort(np.abs(lam),
                 kind="stable")], mlam, np.array(freq), np.array(damp), np.array(damped),
                 np.array(tau), kinds, unstable, shapes, joint, Sm)


def _one_per_freedom(keep: list[int], lams: list[complex], X: np.ndarray, tol: float,
                     zero: float) -> list[int]:
    """``keep`` with each neutral freedom once.  A freedom with no stiffness and no
    damping (x'' = 0: a free rotor) is a double zero eigenvalue with one eigenvector
    (a Jordan pair), a damped one a single zero: the neutral freedoms are as many as
    the independent FGC parts ``X`` (nf, 2 nf) of the zero eigenvalues' eigenvectors
    (the null space of K_FF), the first of them in order of |lambda| kept."""
    zeros = [k for k in keep if abs(lams[k]) <= zero
             or (abs(lams[k].imag) <= tol and abs(lams[k].real) <= tol)]
    if len(zeros) < 2:
        return keep
    chosen: list[int] = []
    basis = np.zeros((X.shape[0], 0), complex)
    for k in zeros:
        x = X[:, k] / max(float(np.linalg.norm(X[:, k])), 1e-300)
        # independent of those chosen: a part of it outside their span (a nearly
        # defective pair's vectors differ by ~sqrt(round-off), far below 1e-6)
        rest = x - basis @ (basis.conj().T @ x)
        if np.linalg.norm(rest) > 1e-6:
            chosen.append(k)
            basis = np.column_stack([basis, rest / np.linalg.norm(rest)])
    drop = set(zeros) - set(chosen)
    return [k for k in keep if k not in drop]


def modes_along(system: System, q: Any, rates: Any = None, accels: Any = None, *,
                specified: Any = None, t: Any = 0.0, pivot_tol: float = 1e-10) -> ModeMap:
    """Natural frequencies and damping ratios at every posture of ``q`` (13.9).

    ``q``: (steps, nq) assembled postures (model units) or a :class:`Trajectory`
    (its postures, its specified coordinates unless ``specified`` is given, its
    rates and times); ``rates``, ``accels``: mappings coordinate -> value or
    array (steps,); ``t``: time or times.  The same result as :func:`modes` of
    :func:`linearize` at every step (at a moving step the FGC accelerations
    of the equations of motion, when none is given), linearized in one
    compiled pass and the eigenvalues found together (load laws, being
    Python, take the step-by-step route).
    """
    if not isinstance(system, System):
        raise InputError(f"modes_along takes a compiled System, got {type(system).__name__}")
    nq = system.nq
    pivot_tol = positive(pivot_tol, "modes_along: pivot_tol")
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
        qm = floats(q, "modes_along: q")
    specified = names_of(specified, "modes_along")
    if qm.ndim != 2 or qm.shape[1] != nq or not np.all(np.isfinite(qm)):
        raise InputError(f"modes_along: q must be (steps, {nq}) finite joint variables, got "
                         f"shape {np.shape(qm)}")
    n = qm.shape[0]
    tv = floats(t, "modes_along: t")
    if tv.ndim > 1 or (tv.ndim == 1 and tv.size != n) or not np.all(np.isfinite(tv)):
        raise InputError(f"modes_along: t must be one time or {n} of them")
    T = np.broadcast_to(tv, (n,)).copy()
    if n == 0:
        return _mode_map(system, qm, [])
    psid = per_step(system, rates, n, "modes_along: rates")
    psidd = per_step(system, accels, n, "modes_along: accels")
    given = named(system, accels)
    sgc = np.zeros(nq, bool)
    for key in specified:
        sgc[system.var_index(key)] = True
    if system.laws:
        blocks, why = [], []
        for k in range(n):
            r = {system.var_names[c]: psid[k, c] * system.var_scale[c] for c in range(nq)
                 if psid[k, c]}
            a = {system.var_names[c]: psidd[k, c] * system.var_scale[c] for c in range(nq)
                 if psidd[k, c] or given[c]}
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
    for k in np.flatnonzero(psid.any(axis=1)):  # moving: the FGC accelerations, as linearize
        Sk = make_state(system, system.to_internal(qm[k]), float(T[k]))
        Sk.sgc[:] = sgc
        try:
            motion_accelerations(system, Sk, psid[k], psidd[k], given, pivot_tol)
        except (InputError, AnalysisError):
            pass  # not assembled or singular there: the compiled pass says so for the step
    S = make_state(system, system.to_internal(qm[0]), float(T[0]))
    S.sgc[:] = sgc
    data = make_data(system, nq)
    dyn = make_dyn_data(system, nq)
    out, work = kernel_buffers(system)
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
        sc = np.outer(system.Y.gscale[cols], 1.0 / vs[cols])
        blocks.append((idx, MDK[idx, :, :nf, :nf] * sc, [system.var_names[c] for c in cols],
                       sgc[cols], 0))
    return _mode_map(system, qm, blocks)


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
        # a singular M_FF: the test of every analysis, every step at once; its steps get
        # a unit mass so that the others solve together
        ok = ~singular_masses(XF[:, 0], mass_floor(system))
        for r in np.flatnonzero(~ok):
            messages.append(f"step {idx[r]}: the mass matrix of the free coordinates is "
                            "singular (a massless part can move alone); no modes")
        XF = np.where(ok[:, None, None, None], XF, np.eye(nf))
        Sm = first_order(XF[:, 0], XF[:, 1], XF[:, 2])
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
    if isinstance(steps, bool) or not (isinstance(steps, (int, np.integer))
                                       and 2 <= steps <= MAX_STEPS):
        raise InputError(f"mode_motion: steps must be an integer in 2 ... {MAX_STEPS} (limit "
                         f"MAX_STEPS), got {steps!r}")
    amp = positive(amplitude, "mode_motion: amplitude")
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
