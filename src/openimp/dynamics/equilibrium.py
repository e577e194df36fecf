"""Static equilibrium (book ch 12): where a loaded mechanism comes to rest.

* :func:`equilibrium`: the equilibrium posture nearest a start posture, the
  SGCs held at given values; its residual, stability (the eigenvalues of the
  stiffness on the FGCs, the modes of instability), the holding forces of
  the SGCs and the force analysis there;
* :func:`equilibria`: a path of equilibria as SGCs or load laws (of t) step
  through values, each started from the last, with its turning points.

The search (:class:`_Search`) is the book's Newton-Raphson on the static
residual, K_FF dpsi_F = F_F (12.3, 12.4), with

* the energy test (12.6-12.9, with the sign of digest §2.5): a Newton step
  is taken only when the loads do positive work along it (F . dpsi > 0, the
  potential energy falls); otherwise the step follows the load (steepest
  descent, 12.9) over the length where the stiffness says the energy stops
  falling;
* where K_FF is indefinite (a saddle or a maximum nearby) and a stable
  posture is sought, the Newton step with every eigenvalue of K_FF taken by
  its magnitude: a step that always lowers the energy and is Newton's near a
  minimum (beyond the book, whose energy test alone lets a several-freedom
  search settle on a saddle);
* the increment limit |dpsi| <= 1 (12.4, the whole vector scaled);
* neutral freedoms (12.6): K_FF eliminated with full pivoting until the
  Schur complement is below a tolerance; the neutral group moves only by a
  gradient step on its reduced load, counted against the step cap, so a
  neutral freedom never loops;
* the loops re-closed at every trial posture (12.5, ch 6), the step halved
  when they do not close or when the loads did negative work over it;
* convergence on the residual: every generalized force on the FGCs below
  the force tolerance (relative to the loads' size, or stated), and, when a
  step tolerance is given (IMP's ZERO (EQUILIB)), the next correction below it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from openimp.dynamics.laws import law_values_at
from openimp.dynamics.statics import close_posture, static_point
from openimp.errors import AnalysisError, InputError
from openimp.kinematics.track import tracker
from openimp.results import Equilibrium, EquilibriumPath, Trajectory
from openimp.system import DAMPER, State, System, make_data, make_dyn_data, make_state

#: relative force tolerance: |F_i| <= RTOL x the size of the loads
RTOL = 1e-10
#: IMP's step cap (ZERO (EQUILIB) nsteps)
MAX_STEPS = 25
#: the increment limit of 12.4 (radians or internal lengths), the whole vector scaled
STEP_LIMIT = 1.0
#: relative size (of the largest stiffness and the loads' size) below which a pivot of
#: K_FF or an eigenvalue is neutral (12.6)
NEUTRAL = 1e-8
#: closure tolerance of the trial postures (internal units)
CLOSE_TOL = 1e-12
#: step of the numeric stiffness of load laws (internal units)
H_LAW = 1e-5


# ----------------------------------------------------------------------------- options
@dataclass
class Options:
    """Search options, internal units where they apply (see :func:`equilibrium`)."""

    force_tol: float | None = None
    rtol: float = RTOL
    step_tol: float | None = None
    max_steps: int = MAX_STEPS
    step_limit: float = STEP_LIMIT
    neutral_tol: float = NEUTRAL
    pivot_tol: float = 1e-10
    seek_stable: bool = True


def _options(force_tol: Any, rtol: Any, step_tol: Any, max_steps: Any, step_limit: Any,
             neutral_tol: Any, pivot_tol: Any, seek_stable: Any) -> Options:
    def pos(x: Any, what: str, none: bool = False) -> float | None:
        if x is None and none:
            return None
        try:
            v = float(x)
        except (TypeError, ValueError):
            raise InputError(f"{what} must be a positive number, got {x!r}") from None
        if not (v > 0 and math.isfinite(v)):
            raise InputError(f"{what} must be a positive number, got {x!r}")
        return v

    if isinstance(max_steps, bool) or not isinstance(max_steps, int | np.integer) \
            or max_steps < 1:
        raise InputError(f"max_steps must be a positive whole number, got {max_steps!r}")
    return Options(pos(force_tol, "force_tol", True), pos(rtol, "rtol"),  # type: ignore[arg-type]
                   pos(step_tol, "step_tol", True), int(max_steps),
                   pos(step_limit, "step_limit"), pos(neutral_tol, "neutral_tol"),  # type: ignore[arg-type]
                   pos(pivot_tol, "pivot_tol"), bool(seek_stable))  # type: ignore[arg-type]


# ----------------------------------------------------------------------------- linear algebra
def full_pivot_solve(K: np.ndarray, F: np.ndarray, eps: float
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Solve K x = F by Gauss-Jordan elimination with full pivoting (book 12.6).

    Pivots are taken while the largest entry of the Schur complement
    K22 - K21 K11^-1 K12 exceeds ``eps``.  Returns (x0, neutral, reduced, C): the
    neutral group (the columns left unpivoted, ascending), the reduced load
    F2 - K21 K11^-1 F1 of the rows left (ascending; paired with the neutral
    columns in that order), and C (n, m) such that x = x0 - C x2 for any change
    x2 of the neutral group (x0 is the book's option (a), x2 = 0).
    """
    n = K.shape[0]
    A = np.hstack([K.astype(float), F.astype(float)[:, None]])
    rows = list(range(n))
    cols = list(range(n))
    piv: list[tuple[int, int]] = []
    for _ in range(n):
        sub = np.abs(A[np.ix_(rows, cols)])
        if sub.size == 0 or sub.max() <= eps:
            break
        i, j = np.unravel_index(int(np.argmax(sub)), sub.shape)
        r, c = rows[i], cols[j]
        A[r] /= A[r, c]
        for rr in range(n):
            if rr != r and A[rr, c] != 0.0:
                A[rr] -= A[rr, c] * A[r]
        piv.append((r, c))
        rows.remove(r)
        cols.remove(c)
    neutral = np.array(sorted(cols), np.int64)
    x0 = np.zeros(n)
    C = np.zeros((n, neutral.size))
    for r, c in piv:
        x0[c] = A[r, n]
        C[c] = A[r, neutral]
    reduced = np.array([A[r, n] for r in sorted(rows)])
    return x0, neutral, reduced, C


def _sym_eig(K: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues (ascending) and vectors of the symmetric part of K."""
    if K.size == 0:
        return np.zeros(0), np.zeros((0, 0))
    return np.linalg.eigh(0.5 * (K + K.T))


# ----------------------------------------------------------------------------- the search
class _Search:
    """Scratch and stages of one system's equilibrium search (internal units)."""

    def __init__(self, system: System, opts: Options) -> None:
        self.system = system
        self.opts = opts
        nq, nb = system.nq, len(system.bodies)
        self.data = make_data(system, nq)
        self.dyn = make_dyn_data(system, nq)
        self.z_cols = self.dyn.view("cols")
        self.z_G = self.dyn.view("Gf")
        self.z_law = self.dyn.view("law")
        self.E = self.data.view("E")
        self.F = np.zeros(nq)
        self.K = np.zeros((nq, nq))
        self.P2 = np.zeros((nq, nq, nq))
        self.A2 = np.zeros((nb, nq, nq, 6))
        self.work = (np.zeros(nq), np.zeros(nq), np.zeros(nq), np.zeros(nq),
                     np.zeros((nb, 6)), np.zeros(nq))
        self.keep = np.zeros(nq, np.bool_)
        self.evaluations = 0
        self.stiffness_evaluations = 0
        self.iterations = 0  # of the last closure
        self.t = 0.0

    # one posture -------------------------------------------------------------
    def _laws(self, S: State) -> None:
        if self.system.laws:
            self.z_law[:] = law_values_at(self.system, S.q[None, :], np.zeros((1, S.q.size)),
                                          self.t)[0]

    def evaluate(self, S: State, want_k: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                          float, float, int]:
        """(cols, F (nf,), K (nf, nf) or empty, potential energy, load scale, rank) at the
        assembled posture S.q, over every generalized coordinate."""
        sy = self.system
        self._laws(S)
        analytic_k = want_k and not sy.laws
        nf, rank, pe, scale = static_point(sy.KP, self.data.DP, sy.YP, self.dyn.ZP, S,
                                           sy.gen, self.opts.pivot_tol, analytic_k, self.F,
                                           self.K, self.P2, self.A2, self.work)
        self.evaluations += 1
        cols = self.z_cols[:nf].copy()
        F = self.F[:nf].copy()
        K = self.K[:nf, :nf].copy() if analytic_k else np.zeros((nf, nf))
        if want_k:
            self.stiffness_evaluations += 1
            if sy.laws:
                K = self._numeric_k(S, cols, self.z_G[:, :nf].copy())
        return cols, F, K, float(pe), float(scale), int(rank)

    def _numeric_k(self, S: State, cols: np.ndarray, G: np.ndarray) -> np.ndarray:
        """K = -dF/dpsi by central differences over closed postures (load laws, whose own
        derivatives are not known in closed form); the posture S is restored."""
        nf = cols.size
        K = np.zeros((nf, nf))
        q0 = S.q.copy()
        for j in range(nf):
            Fs = []
            for s in (H_LAW, -H_LAW):
                S.q[:] = q0 + s * G[:, j]
                if close_posture(self.system.KP, self.data.DP, S, self.system.gen, cols,
                                 CLOSE_TOL, self.opts.pivot_tol, 30, self.keep)[0] != 0:
                    S.q[:] = q0
                    raise AnalysisError("equilibrium: the loops do not close within "
                                        f"{H_LAW:g} of the posture along "
                                        f"{self.system.var_names[cols[j]]}")
                self._laws(S)
                nf2, _, _, _ = static_point(self.system.KP, self.data.DP, self.system.YP,
                                            self.dyn.ZP, S, self.system.gen,
                                            self.opts.pivot_tol, False, self.F, self.K,
                                            self.P2, self.A2, self.work)
                self.evaluations += 1
                if nf2 != nf or not np.array_equal(self.z_cols[:nf], cols):
                    S.q[:] = q0
                    raise AnalysisError("equilibrium: the generalized coordinates change "
                                        "within a differencing step (a singular posture)")
                Fs.append(self.F[:nf].copy())
            K[:, j] = -(Fs[0] - Fs[1]) / (2 * H_LAW)
        S.q[:] = q0
        self._laws(S)
        static_point(self.system.KP, self.data.DP, self.system.YP, self.dyn.ZP, S,
                     self.system.gen, self.opts.pivot_tol, False, self.F, self.K, self.P2,
                     self.A2, self.work)
        return K

    def close(self, S: State, cols: np.ndarray) -> bool:
        """Close the loops holding ``cols`` (and the SGCs); False when they do not close."""
        status, self.iterations = close_posture(self.system.KP, self.data.DP, S,
                                                self.system.gen, cols, CLOSE_TOL,
                                                self.opts.pivot_tol, 30, self.keep)
        return status == 0

    # the search ---------------------------------------------------------------
    def tolerance(self, cols: np.ndarray, scale: float) -> np.ndarray:
        """Force tolerance per coordinate (internal units)."""
        o = self.opts
        if o.force_tol is not None:
            Ls = self.system.length_scale
            vs = self.system.var_scale[cols]
            gs = np.where(vs == 1.0, Ls * Ls, Ls)
            return o.force_tol / gs
        return np.full(cols.size, o.rtol * max(scale, 1e-300))

    def run(self, S: State) -> dict[str, Any]:
        """Search from the assembled posture S (SGCs in S.sgc held); S.q ends at the last
        posture reached.  Returns the raw outcome (internal units)."""
        o = self.opts
        history: list[tuple[str, float, float]] = []
        neutral_steps = 0
        escapes = 0
        status = "step cap"
        message = ""
        steps = 0
        seen = 0.0  # the largest load size met: the scale of the force tolerance
        while True:
            cols, F, K, pe, scale, rank = self.evaluate(S, True)
            seen = scale = max(seen, scale)
            free = ~S.sgc[cols]
            FF, KFF = F[free], K[np.ix_(free, free)]
            ftol = self.tolerance(cols, scale)[free]
            nF = int(free.sum())
            if nF == 0:
                status = "no free coordinate"
                break
            kmax = float(np.abs(KFF).max(initial=0.0))
            eps = o.neutral_tol * max(kmax, scale, 1e-300)
            dpsi, neutral, reduced, C = full_pivot_solve(KFF, FF, eps)
            balanced = bool(np.all(np.abs(FF) <= ftol))
            small = o.step_tol is None or bool(
                np.all(np.abs(dpsi * self.system.var_scale[cols[free]]) <= o.step_tol))
            if balanced and small:
                lam, vec = _sym_eig(KFF)
                if o.seek_stable and lam[0] < -eps and escapes < 4 and steps < o.max_steps:
                    # an unstable equilibrium: leave it along its mode (energy falls
                    # both ways to second order), then search on
                    escapes += 1
                    step = 0.1 * o.step_limit * vec[:, 0]
                    kind = "escape"
                else:
                    status = "balanced"
                    break
            else:
                if steps >= o.max_steps:
                    break
                step, kind = self._step(FF, KFF, dpsi, neutral, reduced, C, ftol, eps)
                if kind == "neutral":
                    neutral_steps += 1
            # increment limit (12.4)
            size = float(np.linalg.norm(step))
            if size > o.step_limit:
                step *= o.step_limit / size
            q0 = S.q.copy()
            G = self.z_G[:, :cols.size].copy()
            Gfree = G[:, free]
            ok = False
            for _half in range(12):
                S.q[:] = q0 + Gfree @ step
                if self.close(S, cols):
                    if (kind in ("escape", "newton") and not o.seek_stable) or kind == "escape" \
                            or self._work_ok(S, q0, cols, free, FF, step, ftol):
                        ok = True
                        break
                step = 0.5 * step
            if not ok:
                S.q[:] = q0
                status = "failed"
                message = ("the loops cannot be closed (or the loads do work against every "
                           "step) near this posture along the search direction; the search "
                           "stopped at the last closed posture")
                break
            steps += 1
            history.append((kind, float(np.abs(FF).max()), float(np.abs(step).max())))
        # the last evaluation is at S.q (a failed step restored the posture it started
        # from, whose F and K these are)
        return dict(cols=cols, F=F, K=K, pe=pe, scale=scale, rank=rank, status=status,
                    steps=steps, history=history, neutral_steps=neutral_steps,
                    escapes=escapes, message=message,
                    ftol=self.tolerance(cols, scale))

    def _step(self, FF: np.ndarray, KFF: np.ndarray, dpsi: np.ndarray, neutral: np.ndarray,
              reduced: np.ndarray, C: np.ndarray, ftol: np.ndarray, eps: float
              ) -> tuple[np.ndarray, str]:
        """The search step on the FGCs and its kind."""
        o = self.opts
        if neutral.size and np.any(np.abs(reduced) > ftol[neutral]):
            # 12.6 (b): the neutral group follows its reduced load (a unit step, counted
            # against the cap); the determinate group follows it through K11^-1 K12
            d2 = o.step_limit * reduced / max(float(np.linalg.norm(reduced)), 1e-300)
            step = dpsi - C @ d2
            step[neutral] += d2
            return step, "neutral"
        lam, vec = _sym_eig(KFF)
        if o.seek_stable and lam.size and lam[0] < -eps:
            # indefinite: Newton with |eigenvalues| (descent; Newton near a minimum)
            proj = vec.T @ FF
            mag = np.maximum(np.abs(lam), eps)
            return vec @ (proj / mag), "modified"
        if not o.seek_stable or neutral.size or float(FF @ dpsi) > 0.0:
            # the energy test (12.8): the loads do positive work along the step (without
            # seek_stable, plain Newton: the nearest equilibrium of any kind)
            return dpsi, "newton"
        # steepest descent (12.9) over the length where the energy stops falling
        curv = float(FF @ KFF @ FF)
        nrm = float(np.linalg.norm(FF))
        mu = float(FF @ FF) / curv if curv > 0 else o.step_limit / max(nrm, 1e-300)
        return mu * FF, "descent"

    def _work_ok(self, S: State, q0: np.ndarray, cols: np.ndarray, free: np.ndarray,
                 F0: np.ndarray, step: np.ndarray, ftol: np.ndarray) -> bool:
        """The loads did non-negative work over the trial step (trapezoid rule on the
        generalized forces of both ends, each in its own coordinates), or the residual
        fell; a step within the force tolerance is always accepted."""
        cols1, F1, _, _, _, _ = self.evaluate(S, False)
        free1 = ~S.sgc[cols1]
        d1 = (S.q - q0)[cols1[free1]]
        work = 0.5 * (float(F0 @ step) + float(F1[free1] @ d1))
        if work >= 0.0:
            return True
        before = float(np.abs(F0).max())
        after = float(np.abs(F1[free1]).max(initial=0.0))
        return after < before or before <= float(ftol.max())


# ----------------------------------------------------------------------------- entries
def _start(system: System, q: Any, specified: Any, t: Any) -> State:
    from openimp.dynamics.vibration import _floats, _names

    if not isinstance(system, System):
        raise InputError(f"equilibrium takes a compiled System, got {type(system).__name__}")
    names = _names(specified)
    if isinstance(q, State):
        S = q.copy()
        S.qd[:] = 0.0
        S.qdd[:] = 0.0
        for key in names:
            S.sgc[system.var_index(key)] = True
        return S
    qm = system.modeling_q if q is None else _floats(q, "q")
    if qm.shape != (system.nq,) or not np.all(np.isfinite(qm)):
        raise InputError(f"q must hold the {system.nq} joint variables as finite numbers, "
                         f"got shape {qm.shape}")
    tf = float(_floats(t, "t"))
    if not math.isfinite(tf):
        raise InputError(f"t must be a finite time, got {t!r}")
    S = make_state(system, system.to_internal(qm), tf)
    for key in names:
        S.sgc[system.var_index(key)] = True
    return S


def equilibrium(system: System, q: Any = None, *, specified: Any = (), t: float = 0.0,
                force_tol: float | None = None, rtol: float = RTOL,
                step_tol: float | None = None, max_steps: int = MAX_STEPS,
                step_limit: float = STEP_LIMIT, neutral_tol: float = NEUTRAL,
                pivot_tol: float = 1e-10, seek_stable: bool = True,
                forces: bool = True) -> Equilibrium:
    """The static equilibrium of ``system`` nearest the posture ``q`` (book ch 12).

    ``q``: joint variables (nq,), model units (default the modeling posture),
    or a :class:`~openimp.system.State`; the posture is closed first with the
    generalized coordinates held.  ``specified``: SGCs (joint names or
    ``"joint.var"``) held at their values in ``q``; the other generalized
    coordinates (FGCs) move until the loads balance.  ``t``: the time that
    load laws read.

    Convergence: every generalized force left on the FGCs is at most
    ``force_tol`` (model units: force, or moment for an angle), by default
    ``rtol`` times the size of the loads (the sum of the magnitudes of every
    body wrench and joint load, internal units); with ``step_tol`` (model
    units: radians or lengths; IMP's ZERO (EQUILIB)) the next Newton
    correction of every FGC must also be below it.  ``max_steps``: the cap
    on search steps (IMP's 25);
    ``step_limit``: the largest step (12.4; radians or internal lengths, the
    whole vector scaled); ``neutral_tol``: a pivot of K_FF (or an eigenvalue)
    below this fraction of the largest stiffness and the loads' size is
    neutral (12.6); ``seek_stable``: leave unstable equilibria and saddles
    for a stable posture (otherwise the nearest equilibrium of any kind);
    ``forces``: run the force analysis at the equilibrium (joint reactions,
    element forces, holding forces).

    The search stops without an error: :attr:`Equilibrium.converged` and
    :attr:`~Equilibrium.status` say how it ended (``"balanced"``, ``"step
    cap"``, ``"no free coordinate"``, ``"failed"``) and the messages why.
    An unassembled start posture is an :class:`InputError`.
    """
    opts = _options(force_tol, rtol, step_tol, max_steps, step_limit, neutral_tol, pivot_tol,
                    seek_stable)
    S = _start(system, q, specified, t)
    search = _searcher(system, opts)
    search.t = S.time
    _assemble(search, S)
    raw = search.run(S)
    return _result(system, search, S, raw, forces, opts)


def _searcher(system: System, opts: Options) -> _Search:
    return _Search(system, opts)


def _assemble(search: _Search, S: State) -> None:
    """Close the start posture holding the generalized coordinates; InputError when it
    cannot be assembled."""
    from openimp.kinematics.posture import newton

    sy = search.system
    cols, *_ = search.evaluate(S, False)
    if float(np.abs(search.E).max(initial=0.0)) <= CLOSE_TOL:
        return
    q0 = S.q.copy()
    if not search.close(S, cols):
        S.q[:] = q0  # the FGCs free too: the nearest assembly
        st = newton(sy.KP, search.data.DP, S, sy.gen, CLOSE_TOL, search.opts.pivot_tol, 50,
                    False)[0]
        if st != 0:
            raise InputError("equilibrium: the start posture cannot be assembled (the loops "
                             f"miss closing by {float(np.abs(search.E).max()):.3g} and "
                             "Newton does not close them); start nearer an assembly, e.g. "
                             "from openimp.sweep(system, {driver: [value]}).q[0]")


def _result(system: System, search: _Search, S: State, raw: dict[str, Any], want_forces: bool,
            opts: Options) -> Equilibrium:
    """The :class:`~openimp.results.Equilibrium` of a finished search (model units)."""
    cols = raw["cols"]
    vs = system.var_scale[cols]
    Ls = system.length_scale
    gs = np.where(vs == 1.0, Ls * Ls, Ls)
    names = [system.var_names[c] for c in cols]
    spec = S.sgc[cols].copy()
    free = ~spec
    F = raw["F"] * gs
    K = raw["K"] * np.outer(gs, 1.0 / vs)
    ftol = raw["ftol"] * gs
    status = raw["status"]
    messages: list[str] = []
    KFF = K[np.ix_(free, free)]
    lam, vec = _sym_eig(KFF)
    scale_k = max(float(np.abs(KFF).max(initial=0.0)), raw["scale"] * Ls * Ls, 1e-300)
    thr = opts.neutral_tol * scale_k
    if free.sum() == 0:
        stability = "none"
    elif lam[0] < -thr:
        stability = "unstable"
    elif lam[0] <= thr:
        stability = "neutral"
    else:
        stability = "stable"
    resid = float(np.abs(F[free]).max(initial=0.0))
    converged = status in ("balanced", "no free coordinate")
    fnames = [n for n, s in zip(names, spec, strict=True) if not s]
    if status == "balanced":
        messages.append(f"Equilibrium found after {raw['steps']} search steps.")
    elif status == "no free coordinate":
        messages.append("no free generalized coordinate: every freedom is specified, so the "
                        "posture is set by the SGCs; only the holding forces are computed")
    elif status == "step cap":
        worst = fnames[int(np.argmax(np.abs(F[free])))] if fnames else ""
        messages.append(f"equilibrium not found in {raw['steps']} search steps (the step cap): "
                        f"the largest unbalanced generalized force is {resid:.6g} on {worst} "
                        f"(tolerance {float(ftol[free].max()):.3g})")
    else:
        messages.append(f"equilibrium not found: {raw['message']}")
    if raw["neutral_steps"]:
        messages.append(f"{raw['neutral_steps']} step(s) moved a neutral freedom (no "
                        "stiffness) along its unbalanced load (12.6)")
    if raw["escapes"]:
        messages.append(f"{raw['escapes']} unstable equilibrium(s) left along the mode of "
                        "instability, to find a stable one")
    if stability == "neutral":
        zero = [i for i in range(len(lam)) if abs(lam[i]) <= thr]
        modes = ", ".join(_mode_text(fnames, vec[:, i]) for i in zero)
        moved = sorted({fnames[int(np.argmax(np.abs(vec[:, i])))] for i in zero})
        messages.append(f"neutral equilibrium: no stiffness along {modes} (the mechanism "
                        f"balances as well when {', '.join(moved)} moves that way)"
                        if converged else
                        f"neutral freedom: no stiffness along {modes}; an unbalanced load "
                        "there has no posture of balance")
    elif stability == "unstable":
        modes = ", ".join(_mode_text(fnames, vec[:, i]) for i in range(len(lam))
                          if lam[i] < -thr)
        messages.append(f"unstable equilibrium: the potential energy falls along {modes}")
    nonsym = float(np.abs(KFF - KFF.T).max(initial=0.0)) > 1e-8 * scale_k
    if nonsym:
        messages.append("the stiffness is not symmetric (follower loads, no potential): "
                        "stability judged on its symmetric part, which covers divergence "
                        "only; see openimp.modes for flutter")
    if not _loaded(system):
        messages.append("no load acts (no gravity on a mass, no spring, no applied load): "
                        "every posture is an equilibrium; the start posture is returned")
    holding = {n: -float(F[i]) for i, n in enumerate(names) if spec[i]}
    q_int = S.q.copy()
    quality = _quality(search, S)
    tr = Trajectory(system, q_int[None, :].copy(), np.array([quality]),
                    np.array([raw["rank"]], np.int64),
                    np.isin(np.arange(system.nq), cols[free])[None, :],
                    np.array([search.iterations], np.int64), [n for n, s in zip(names, spec,
                                                                           strict=True) if s],
                    tracker=tracker(system), sgc=S.sgc.copy())
    tr.rank_ref, tr.quality_ref = raw["rank"], 1.0
    tr.set_rates(np.zeros((1, system.nq)), np.zeros((1, system.nq)), np.zeros(1))
    tr.time = np.array([S.time])
    eq = Equilibrium(
        system=system, q=system.to_model(q_int), coords=names, specified=spec,
        converged=converged, status=status, steps=raw["steps"],
        evaluations=search.evaluations, residual=F, force_tol=ftol, stiffness=K,
        eigenvalues=lam, eigenvectors=vec, stability=stability, holding=holding,
        potential=raw["pe"] * Ls * Ls, history=raw["history"], trajectory=tr,
        messages=messages, t=S.time)
    if want_forces:
        from openimp.dynamics.analysis import forces as _forces

        eq.forces = _forces(tr, pivot_tol=opts.pivot_tol)
    return eq


def _loaded(system: System) -> bool:
    """True when some load can act: gravity on a mass, a joint spring or load, an
    element (spring, force or torque), or a load law."""
    Y = system.Y
    if np.any(Y.grav != 0.0) and any(float(J[3, 3]) != 0.0 for J in Y.Jb):
        return True
    if np.any(Y.qk != 0.0) or np.any(Y.qf != 0.0) or len(system.laws):
        return True
    return bool(np.any((Y.ekind != DAMPER) & (Y.evalue != 0.0)))


def _quality(search: _Search, S: State) -> float:
    """The quality index of the elimination at S.q with its SGCs (6.5.3)."""
    from openimp.kinematics.posture import eliminate_at

    return float(eliminate_at(search.system, search.data, S, search.opts.pivot_tol)[1])


def _mode_text(names: list[str], v: np.ndarray) -> str:
    """A mode shape in words: its largest components."""
    k = np.argsort(-np.abs(v))
    big = [i for i in k if abs(v[i]) >= 0.2 * abs(v[k[0]])][:3]
    return "(" + ", ".join(f"{v[i]:+.3g} {names[i]}" for i in big) + ")"


# ----------------------------------------------------------------------------- paths
def equilibria(system: System, path: Any = None, *, times: Any = None, q: Any = None,
               specified: Any = (), **options: Any) -> EquilibriumPath:
    """A path of equilibria, each searched from the last (the book's W(psi) curve, 12.1).

    ``path``: a mapping SGC name -> values (model units, one per step; the
    named coordinates are held there, with any ``specified`` ones at their
    values in ``q``); ``times``: (steps,) the time of every step, which the
    load laws read (a load stepped through values is a law of t).  At least
    one of the two sets the number of steps.  ``options``: those of
    :func:`equilibrium` (``forces`` runs one force analysis of the whole path),
    and ``progress``: a callable (steps done, steps) called after every step.
    Ctrl-C ends the path with the steps done (``message`` says so).

    Every step's :class:`~openimp.results.Equilibrium` is kept; a step that is
    not balanced ends the path there with its message (the steps before it are
    kept).  Turning points are reported in :attr:`EquilibriumPath.turning_points`:
    where the stability changes (the smallest stiffness eigenvalue changes
    sign: a limit point or a bifurcation), where a step jumps far from the
    path, and, on an SGC path, where a holding force passes an extremum (the
    limit load under which a dead load would snap the mechanism over).
    """
    want_forces = bool(options.pop("forces", True))
    progress = options.pop("progress", None)
    opts = _options(options.pop("force_tol", None), options.pop("rtol", RTOL),
                    options.pop("step_tol", None), options.pop("max_steps", MAX_STEPS),
                    options.pop("step_limit", STEP_LIMIT), options.pop("neutral_tol", NEUTRAL),
                    options.pop("pivot_tol", 1e-10), options.pop("seek_stable", True))
    if options:
        raise InputError(f"equilibria: unknown option(s) {', '.join(sorted(options))}")
    path = {} if path is None else path
    if not hasattr(path, "items"):
        raise InputError("equilibria: path must map SGC names to arrays of values")
    names = list(path)
    cols = [system.var_index(k) for k in names] if isinstance(system, System) else []
    S = _start(system, q, list(specified) + names, 0.0)
    n = None
    vals = []
    for k, c in zip(names, cols, strict=True):
        try:
            arr = np.atleast_1d(np.asarray(path[k], float))
        except (TypeError, ValueError):
            raise InputError(f"equilibria: path[{k!r}] must be numbers, one per step, got "
                             f"{path[k]!r}") from None
        if arr.ndim != 1 or not np.all(np.isfinite(arr)) or arr.size == 0:
            raise InputError(f"equilibria: path[{k!r}] must be finite values, one per step")
        if n is not None and arr.size != n:
            raise InputError(f"equilibria: path[{k!r}] has {arr.size} values, the other "
                             f"inputs {n}")
        n = arr.size
        vals.append(arr / system.var_scale[c])
    if times is not None:
        try:
            tt = np.atleast_1d(np.asarray(times, float))
        except (TypeError, ValueError):
            raise InputError(f"equilibria: times must be numbers, got {times!r}") from None
        if tt.ndim != 1 or not np.all(np.isfinite(tt)) or tt.size == 0:
            raise InputError("equilibria: times must be finite values, one per step")
        if n is not None and tt.size != n:
            raise InputError(f"equilibria: times has {tt.size} values, the path {n}")
        n = tt.size
    else:
        tt = None
    if n is None:
        raise InputError("equilibria: give a path of SGC values or the times of load laws")
    search = _Search(system, opts)
    steps: list[Equilibrium] = []
    message = ""
    prev_tangent = None
    interrupted = False
    for k in range(n):
        try:
            eq = _path_step(system, search, S, k, tt, cols, vals, prev_tangent, opts)
        except InputError as exc:
            message = f"step {k}: {exc}"
            break
        except KeyboardInterrupt:
            message = f"step {k}: interrupted by the user (Ctrl-C)"
            interrupted = True
            break
        steps.append(eq)
        if progress is not None:
            progress(k + 1, n)
        if not eq.converged:
            message = f"step {k}: " + "; ".join(m for m in eq.messages
                                                 if not m.startswith("Equilibrium found"))
            break
        prev_tangent = _tangent(system, eq, cols) if cols else None
    traj = None
    good = [e for e in steps if e.converged]
    if good:
        traj = Trajectory.concatenate([e.trajectory for e in good])
        traj.time = np.array([e.t for e in good])
    res = EquilibriumPath(system=system, steps=steps, trajectory=traj, message=message,
                          parameter=names[0] if names else "t",
                          values=(vals[0][:len(steps)] * system.var_scale[cols[0]]
                                  if names else tt[:len(steps)] if tt is not None
                                  else np.zeros(0)))
    res.turning_points = _turning_points(res)
    res.interrupted = interrupted
    if want_forces and traj is not None:
        from openimp.dynamics.analysis import forces as _forces

        res.forces = _forces(traj, pivot_tol=opts.pivot_tol)
    return res


def _path_step(system: System, search: _Search, S: State, k: int, tt: np.ndarray | None,
               cols: list[int], vals: list[np.ndarray], tangent: np.ndarray | None,
               opts: Options) -> Equilibrium:
    """The equilibrium of path step ``k``, searched from S (the last equilibrium) with the
    SGCs moved to their values there and the FGCs predicted along ``tangent``."""
    search.t = float(tt[k]) if tt is not None else 0.0
    S.t[0] = search.t
    if tangent is not None and k > 0:
        S.q[:] += tangent @ np.array([v[k] - v[k - 1] for v in vals])
    for c, v in zip(cols, vals, strict=True):
        S.q[c] = v[k]
    _assemble(search, S)
    raw = search.run(S)
    return _result(system, search, S, raw, False, opts)


def _tangent(system: System, eq: Equilibrium, cols: list[int]) -> np.ndarray | None:
    """(nq, len(cols)) the first-order change of the equilibrium posture per unit change
    of the path's SGCs (internal units): dpsi_F = -K_FF^-1 K_FS dpsi_S, through phi'."""
    sp = eq.specified
    if sp.all() or not sp.any():
        return None
    free = ~sp
    vs = np.array([system.var_scale[system.var_index(n)] for n in eq.coords])
    Ls = system.length_scale
    gs = np.where(vs == 1.0, Ls * Ls, Ls)
    Kint = eq.stiffness / np.outer(gs, 1.0 / vs)
    try:
        KFF = Kint[np.ix_(free, free)]
        idx = [eq.coords.index(system.var_names[c]) for c in cols]
        KFS = Kint[np.ix_(free, idx)]
        dF = -np.linalg.solve(KFF, KFS)
    except (np.linalg.LinAlgError, ValueError):
        return None
    if not np.all(np.isfinite(dF)) or np.abs(dF).max() > 1e3:
        return None
    fcols = [system.var_index(n) for n, s in zip(eq.coords, sp, strict=True) if not s]
    T = np.zeros((system.nq, len(cols)))
    T[fcols, :] = dF
    return T


def _turning_points(res: EquilibriumPath) -> list[str]:
    out: list[str] = []
    st = res.steps
    for k in range(1, len(st)):
        a, b = st[k - 1], st[k]
        la = a.eigenvalues[0] if a.eigenvalues.size else None
        lb = b.eigenvalues[0] if b.eigenvalues.size else None
        if la is not None and lb is not None and (la > 0) != (lb > 0):
            out.append(f"between steps {k - 1} and {k} ({res.parameter} {res.values[k - 1]:.6g}"
                       f" to {res.values[k]:.6g}) the smallest stiffness eigenvalue changes "
                       f"sign ({la:.4g} to {lb:.4g}): the path passes a limit point or a "
                       "bifurcation and the stability changes")
        if a.coords == b.coords:
            fr = ~a.specified
            d = np.abs(b.q - a.q).max()
            prev = np.abs(a.q - st[k - 2].q).max() if k >= 2 else None
            if prev is not None and prev > 0 and d > 10 * prev and d > 0.05:
                first = st[0].eigenvalues[0] if st[0].eigenvalues.size else None
                fold = (la is not None and first is not None and first > 0
                        and 0 <= la < 0.5 * first)
                out.append(f"between steps {k - 1} and {k} the equilibrium jumps (a change of "
                           f"{d:.4g} against {prev:.4g} the step before): the path snapped "
                           "to another branch" + (
                               f"; the smallest stiffness eigenvalue had fallen from "
                               f"{first:.4g} to {la:.4g}: a limit point (snap-through)"
                               if fold else ""))
            del fr
    if res.parameter != "t":
        for name in (st[0].holding if st else {}):
            w = np.array([e.holding.get(name, np.nan) for e in st])
            dw = np.diff(w)
            for k in range(1, dw.size):
                if dw[k - 1] * dw[k] < 0:
                    kind = "maximum" if dw[k - 1] > 0 else "minimum"
                    out.append(f"the holding force of {name} passes a {kind} of about "
                               f"{w[k]:.6g} at step {k} ({res.parameter} "
                               f"{res.values[k]:.6g}): under a dead load of that size the "
                               "mechanism would snap over (a limit load)")
    return out
