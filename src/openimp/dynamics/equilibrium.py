"""Static equilibrium (book ch 12): where a loaded mechanism comes to rest.

* :func:`equilibrium`: the equilibrium posture nearest a start posture, the
  SGCs held at given values; its residual, stability (the eigenvalues of the
  stiffness on the FGCs, the modes of instability), the holding forces of
  the SGCs and the force analysis there;
* :func:`equilibria`: a path of equilibria as SGCs or load laws (of t) step
  through values, each started from the last, with its turning points.

The search (:class:`_Search`) is the book's Newton-Raphson on the static
residual, K_FF dpsi_F = F_F (12.3, 12.4), with

* the energy test (12.6-12.9, with the sign corrected: F of 12.1 is -dV/dpsi,
  so the book's printed 12.7-12.9 would reject the Newton step at every stable
  posture; docs/statics.md, "Energy test"): a Newton step is taken only when
  the loads do positive work along it (F . dpsi > 0, the potential energy
  falls); otherwise the step follows the load (steepest descent, 12.9) over
  the length where the stiffness says the energy stops falling;
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
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from openimp.dynamics.laws import law_values_at
from openimp.dynamics.statics import (
    STEPPED,
    StepOptions,
    close_posture,
    make_history,
    make_search_buffers,
    make_search_state,
    search_loop,
    search_point,
    search_step,
)
from openimp.errors import AnalysisError, InputError, renamed
from openimp.kinematics.inputs import finite, names_of, positive, start_state
from openimp.kinematics.track import tracker
from openimp.limits import MAX_STEPS
from openimp.results import Equilibrium, EquilibriumPath, SearchStatus, StepKind, Trajectory
from openimp.system import DAMPER, State, System, make_scratch
from openimp.workspace import WORKSPACES

#: relative force tolerance (``force_rtol``): |F_i| <= RTOL x the size of the loads
RTOL = 1e-10
#: IMP's cap on search iterations (ZERO (EQUILIB) nsteps; ``max_iter``)
MAX_ITER = 25
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
@dataclass(frozen=True)
class SearchOptions:
    """The options of :func:`equilibrium` and :func:`equilibria`, validated by
    :func:`search_options` (model units where they have any).

    ``force_tol``: the largest generalized force left on an FGC, an absolute
    force (or moment for an angle), model units; by default ``force_rtol``
    times the size of the loads (the sum of the magnitudes of every body
    wrench and joint load, internal units); ``step_tol``: with it (radians or
    lengths, IMP's ZERO (EQUILIB)) the next Newton correction of every FGC
    must also be below it; ``max_iter``: the cap on search iterations (IMP's
    25); ``step_limit``: the largest step (12.4; radians or internal lengths,
    the whole vector scaled); ``neutral_tol``: a pivot of K_FF (or an
    eigenvalue) below this fraction of the largest stiffness and the loads'
    size is neutral (12.6); ``pivot_tol``: of the elimination; ``seek_stable``:
    leave unstable equilibria and saddles for a stable posture (otherwise the
    nearest equilibrium of any kind); ``forces``: run the force analysis at
    the equilibrium; ``progress``: :func:`equilibria` only, ``progress(done,
    total)`` (steps done, steps) after every step.
    """

    force_tol: float | None = None
    force_rtol: float = RTOL
    step_tol: float | None = None
    max_iter: int = MAX_ITER
    step_limit: float = STEP_LIMIT
    neutral_tol: float = NEUTRAL
    pivot_tol: float = 1e-10
    seek_stable: bool = True
    forces: bool = True
    progress: Callable[[float, float], None] | None = None


#: the deprecated names of the options (old -> new), kept for one release
RENAMED = {"rtol": "force_rtol", "max_steps": "max_iter"}


#: checked options by (where, path, items): a study repeats the same few (their checks
#: cost a tenth of a search)
_CHECKED: dict[tuple[Any, ...], SearchOptions] = {}


def search_options(where: str, options: dict[str, Any], path: bool = False) -> SearchOptions:
    """The :class:`SearchOptions` of the keyword arguments ``options`` of ``where``
    (``path``: :func:`equilibria`, which takes ``progress``), every value checked;
    deprecated names (:data:`RENAMED`) are accepted with a DeprecationWarning."""
    try:
        key: tuple[Any, ...] | None = (where, path, *((k, type(v), v) for k, v in
                                                      sorted(options.items())))
        hit = _CHECKED.get(key)  # type: ignore[arg-type]
    except TypeError:  # an unhashable value: checked below, not kept
        key = hit = None
    if hit is not None:
        return hit
    checked = _check_options(where, options, path)
    if key is not None and not (options.keys() & RENAMED.keys()):  # each use warns
        if len(_CHECKED) >= 64:
            _CHECKED.clear()
        _CHECKED[key] = checked
    return checked


def _check_options(where: str, options: dict[str, Any], path: bool) -> SearchOptions:
    """:func:`search_options`, uncached."""
    o = renamed(where, options, RENAMED)
    known = set(SearchOptions.__dataclass_fields__) - (set() if path else {"progress"})
    unknown = sorted(o.keys() - known)
    if unknown:
        raise InputError(f"{where}: unknown option(s) {', '.join(unknown)}; the options are "
                         f"{', '.join(sorted(known))}")

    def pos(what: str, none: bool = False) -> Any:
        x = o.get(what, getattr(SearchOptions, what))
        if x is None and none:
            return None
        return positive(x, f"{where}: {what}")

    def flag(what: str) -> bool:
        x = o.get(what, getattr(SearchOptions, what))
        if not isinstance(x, bool | np.bool_):
            raise InputError(f"{where}: {what} must be True or False, got {x!r}")
        return bool(x)

    cap = o.get("max_iter", MAX_ITER)
    if isinstance(cap, bool) or not isinstance(cap, int | np.integer) or cap < 1:
        raise InputError(f"{where}: max_iter must be a positive whole number, got {cap!r}")
    progress = o.get("progress")
    if progress is not None and not callable(progress):
        raise InputError(f"{where}: progress must be a callable progress(done, total), got "
                         f"{progress!r}")
    return SearchOptions(pos("force_tol", True), pos("force_rtol"), pos("step_tol", True),
                         int(cap), pos("step_limit"), pos("neutral_tol"), pos("pivot_tol"),
                         flag("seek_stable"), flag("forces"), progress)


# ----------------------------------------------------------------------------- the search
#: the word of each step kind of the history, by code
_KIND = {int(k): str(k) for k in StepKind}


def _sym_eig(K: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues (ascending) and vectors of the symmetric part of K."""
    if K.size == 0:
        return np.zeros(0), np.zeros((0, 0))
    if K.shape[0] == 1:
        return K[0].copy(), np.ones((1, 1))
    return np.linalg.eigh(0.5 * (K + K.T))


class _Scratch:
    """The arrays of one search (from :data:`~openimp.workspace.WORKSPACES`, kind
    ``"equilibrium"``: allocating them costs more than a search step)."""

    def __init__(self, system: System) -> None:
        nq, nb = system.nq, len(system.bodies)
        self.data, self.dyn = make_scratch(system)
        self.z_cols = self.dyn.view("cols")
        self.z_G = self.dyn.view("Gf")
        self.z_law = self.dyn.view("law")
        self.E = self.data.view("E")
        vs = system.var_scale.astype(float)
        gs = system.Y.gscale.copy()
        # SP: the packed buffers the kernels take; b: their views, for Python
        self.SP, self.b = make_search_buffers(nq, nb, vs, gs)
        self.F, self.K, self.cols = self.b.F, self.b.K, self.b.cols
        self.loaded = _loaded(system)
        self.laws = bool(system.laws)
        # the StepOptions of the last search's SearchOptions (a study repeats them)
        self.options: tuple[SearchOptions | None, StepOptions | None] = (None, None)

    def step_options(self, opts: SearchOptions) -> StepOptions:
        """The kernels' :class:`~openimp.dynamics.statics.StepOptions` of ``opts``."""
        last, step = self.options
        if last is opts and step is not None:
            return step
        step = StepOptions(
            pivot_tol=float(opts.pivot_tol), rtol=float(opts.force_rtol),
            force_tol=-1.0 if opts.force_tol is None else float(opts.force_tol),
            step_tol=-1.0 if opts.step_tol is None else float(opts.step_tol),
            limit=float(opts.step_limit), neutral=float(opts.neutral_tol),
            stable=bool(opts.seek_stable), numeric_k=self.laws,
            close_tol=CLOSE_TOL)
        self.options = (opts, step)
        return step


class _Search:
    """One equilibrium search of a system (internal units): the compiled
    :func:`~openimp.dynamics.statics.search_step` in a loop, with the step cap, the
    escapes from unstable equilibria and, for load laws, their values refreshed and
    the stiffness differenced at every step."""

    def __init__(self, system: System, opts: SearchOptions) -> None:
        self.system = system
        self.o = opts
        sc = WORKSPACES.take(system, "equilibrium", _Scratch)
        self.sc = sc
        self.data, self.dyn, self.E = sc.data, sc.dyn, sc.E
        self.t = 0.0
        self.iterations = 0
        self.opts = sc.step_options(opts)
        # the search's record (statics.SEARCH_STATE): the kernels take the (1,) array,
        # Python reads and writes its one record by field
        self.record = make_search_state()
        self.state = self.record[0]

    def release(self) -> None:
        """Give the scratch back to the system's pool."""
        WORKSPACES.give(self.system, "equilibrium", self.sc)

    @property
    def evaluations(self) -> int:
        return int(self.state["evals"])

    # one posture -------------------------------------------------------------
    def _laws(self, S: State) -> None:
        if self.system.laws:
            self.sc.z_law[:] = law_values_at(self.system, S.q[None, :],
                                             np.zeros((1, S.q.size)), self.t)[0]

    def _point(self, S: State) -> tuple[int, int, float, float]:
        """:func:`~openimp.dynamics.statics.search_point` at S.q with the laws' values
        there, without the stiffness, counted: (nf, rank, potential, load scale)."""
        sy, sc = self.system, self.sc
        self._laws(S)
        self.state["evals"] += 1
        return search_point(sy.KP, sc.data.DP, sy.YP, sc.dyn.ZP, S, sy.gen, self.o.pivot_tol,
                            sc.SP)

    def evaluate(self, S: State) -> tuple[np.ndarray, np.ndarray]:
        """(cols, F) at the posture S.q (assembled or not), without the stiffness."""
        nf, _, _, _ = self._point(S)
        self.state["have"] = False
        return self.sc.z_cols[:nf].copy(), self.sc.F[:nf].copy()

    def _numeric_k(self, S: State) -> None:
        """F and K = -dF/dpsi at S.q into the scratch, K by central differences over
        closed postures (load laws, whose own derivatives are not known in closed form);
        the posture S is restored."""
        sy, sc = self.system, self.sc
        cols, _ = self.evaluate(S)
        nf = cols.size
        G = sc.z_G[:, :nf].copy()
        K = np.zeros((nf, nf))
        q0 = S.q.copy()
        for j in range(nf):
            Fs = []
            for h in (H_LAW, -H_LAW):
                S.q[:] = q0 + h * G[:, j]
                status, _, _ = close_posture(sy.KP, sc.data.DP, S, sy.gen, cols, CLOSE_TOL,
                                             self.o.pivot_tol, 30, sc.b.keep)
                if status != 0:
                    S.q[:] = q0
                    raise AnalysisError("equilibrium: the loops do not close within "
                                        f"{H_LAW:g} of the posture along "
                                        f"{sy.var_names[cols[j]]}")
                c2, F2 = self.evaluate(S)
                if not np.array_equal(c2, cols):
                    S.q[:] = q0
                    raise AnalysisError("equilibrium: the generalized coordinates change "
                                        "within a differencing step (a singular posture)")
                Fs.append(F2)
            K[:, j] = -(Fs[0] - Fs[1]) / (2 * H_LAW)
        S.q[:] = q0
        nf, rank, pe, scale = self._point(S)
        self.state["kevals"] += 1
        sc.cols[:nf] = cols
        sc.K[:nf, :nf] = K
        st = self.state
        st["nf"], st["rank"], st["pe"], st["scale"] = nf, rank, pe, scale
        st["have"] = True

    def close(self, S: State, cols: np.ndarray) -> bool:
        """Close the loops holding ``cols`` (and the SGCs); False when they do not close."""
        sc = self.sc
        status, self.iterations, q = close_posture(self.system.KP, sc.data.DP, S,
                                                   self.system.gen, cols, CLOSE_TOL,
                                                   self.o.pivot_tol, 30, sc.b.keep)
        self.state["have"] = False
        if status == 0:
            self.state["quality"], self.state["closed"] = q, True
            self.state["iter"] = self.iterations
        return status == 0

    # the search ---------------------------------------------------------------
    def run(self, S: State) -> dict[str, Any]:
        """Search from the assembled posture S (SGCs in S.sgc held); S.q ends at the last
        posture reached.  Returns the raw outcome (internal units)."""
        sy, sc, o = self.system, self.sc, self.o
        st, opts, rec = self.state, self.opts, self.record
        st["seen"] = 0.0
        history: list[tuple[str, float, float]] = []
        counts = {"neutral": 0, "escape": 0}
        steps = 0
        if not sy.laws:  # the whole search in one compiled call
            hist = make_history(o.max_iter)
            code = search_loop(sy.KP, sc.data.DP, sy.YP, sc.dyn.ZP, S, sy.gen, opts, rec,
                               sc.SP, hist)
            steps = int(st["steps"])
            counts["escape"], counts["neutral"] = int(st["escapes"]), int(st["neutral_steps"])
            h = hist.view(type=np.ndarray)[:steps]  # by column: one read per field
            history = [(_KIND[k], f, m) for k, f, m in zip(
                h["kind"].tolist(), h["fmax"].tolist(), h["stepmax"].tolist(), strict=True)]
        else:  # load laws: their values and the stiffness refreshed at every step
            while True:
                self._numeric_k(S)
                st["may_step"] = steps < o.max_iter
                st["may_escape"] = counts["escape"] < 4 and steps < o.max_iter
                code = search_step(sy.KP, sc.data.DP, sy.YP, sc.dyn.ZP, S, sy.gen, opts, rec,
                                   sc.SP)
                if code != STEPPED:
                    break
                steps += 1
                kind = _KIND[int(st["kind"])]
                if kind in counts:
                    counts[kind] += 1
                history.append((kind, float(st["fmax"]), float(st["stepmax"])))
        status = str(SearchStatus(code))
        if not st["have"]:  # a failed step left a trial's evaluation in the scratch
            if sy.laws:
                self._numeric_k(S)
            else:
                st["may_step"] = st["may_escape"] = False
                search_step(sy.KP, sc.data.DP, sy.YP, sc.dyn.ZP, S, sy.gen, opts, rec,
                            sc.SP)
        nf = int(st["nf"])
        cols = sc.cols[:nf].copy()
        scale = max(float(st["seen"]), float(st["scale"]))
        message = ("the loops cannot be closed (or the loads do work against every step) "
                   "near this posture along the search direction; the search stopped at "
                   "the last closed posture") if status == "failed" else ""
        return dict(cols=cols, F=sc.F[:nf].copy(), K=sc.K[:nf, :nf].copy(),
                    pe=float(st["pe"]), scale=scale, rank=int(st["rank"]), status=status,
                    steps=steps, history=history, neutral_steps=counts["neutral"],
                    escapes=counts["escape"], message=message,
                    ftol=self.tolerance(cols, scale))

    def tolerance(self, cols: np.ndarray, scale: float) -> np.ndarray:
        """Force tolerance per coordinate (internal units)."""
        o = self.o
        if o.force_tol is not None:
            return o.force_tol / self.sc.b.gs[cols]
        return np.full(cols.size, o.force_rtol * max(scale, 1e-300))


# ----------------------------------------------------------------------------- entries
def _start(system: System, q: Any, state: Any, specified: Any, t: Any, where: str) -> State:
    """The start of a search: ``q`` (model units) or ``state`` (a State: its SGCs held
    too, its rates ignored), the ``specified`` coordinates held, at time ``t`` (default
    0, or the State's)."""
    if not isinstance(system, System):
        raise InputError(f"{where} takes a compiled System, got {type(system).__name__}")
    names = names_of(specified, where)
    tf = None
    if t is not None:
        tf = finite(t, f"{where}: t")
    S = start_state(system, q, state, where, 0.0 if tf is None else tf)
    S.qd[:] = 0.0
    S.qdd[:] = 0.0
    if tf is not None:
        S.t[0] = tf
    for key in names:
        S.sgc[system.var_index(key)] = True
    return S


def equilibrium(system: System, q: Any = None, *, state: State | None = None,
                specified: Any = (), t: float | None = None, **options: Any) -> Equilibrium:
    """The static equilibrium of ``system`` nearest the posture ``q`` (book ch 12).

    ``q``: the start posture in model units (the nq joint variables, or a
    mapping of joint variables to values; default the modeling posture), or
    ``state``: a :class:`~openimp.system.State` (internal units; its SGCs
    ``sgc`` are held too, its rates are ignored); the posture is closed first
    with the generalized coordinates held.  ``specified``: SGCs (joint names
    or ``"joint.var"``) held at their start values; the other generalized
    coordinates (FGCs) move until the loads balance.  ``t``: the time that
    load laws read (default 0, or the State's).

    ``options`` (:class:`SearchOptions`, checked by :func:`search_options`):
    ``force_tol`` (an absolute force, model units) or ``force_rtol`` (relative
    to the loads' size) for convergence, ``step_tol``, ``max_iter`` (IMP's 25),
    ``step_limit``, ``neutral_tol``, ``pivot_tol``, ``seek_stable``, ``forces``
    (run the force analysis at the equilibrium: joint reactions, element
    forces, holding forces).  ``rtol`` and ``max_steps`` are the deprecated
    names of ``force_rtol`` and ``max_iter``.

    The search stops without an error: :attr:`Equilibrium.converged` and
    :attr:`~Equilibrium.status` say how it ended (``"balanced"``, ``"step
    cap"``, ``"no free coordinate"``, ``"failed"``; :attr:`~Equilibrium.code`
    the same as a :class:`~openimp.results.SearchStatus`) and the messages
    why.  An unassembled start posture is an :class:`InputError`.
    """
    opts = search_options("equilibrium", options)
    S = _start(system, q, state, specified, t, "equilibrium")
    search = _Search(system, opts)
    try:
        search.t = S.time
        _assemble(search, S)
        raw = search.run(S)
        return _result(system, search, S, raw, opts.forces, opts)
    finally:
        search.release()


def _assemble(search: _Search, S: State) -> None:
    """Close the start posture holding the generalized coordinates; InputError when it
    cannot be assembled."""
    from openimp.kinematics.posture import newton

    sy = search.system
    st = search.state
    st["evals"] = st["kevals"] = 0
    st["closed"] = False
    cols, _ = search.evaluate(S)
    if float(np.abs(search.E).max(initial=0.0)) <= CLOSE_TOL:
        return
    q0 = S.q.copy()
    if not search.close(S, cols):
        S.q[:] = q0  # the FGCs free too: the nearest assembly
        st = newton(sy.KP, search.data.DP, S, sy.gen, CLOSE_TOL, search.o.pivot_tol, 50,
                    False)[0]
        if st != 0:
            raise InputError("equilibrium: the mechanism cannot be assembled at the start "
                             f"posture (the loops miss closing by "
                             f"{float(np.abs(search.E).max()):.3g} and Newton does not close "
                             "them: a limit of travel or a singular posture of the inputs, "
                             "or a start too far from an assembly); give input values the "
                             "mechanism can reach, or a start posture nearer an assembly")


def _result(system: System, search: _Search, S: State, raw: dict[str, Any], want_forces: bool,
            opts: SearchOptions) -> Equilibrium:
    """The :class:`~openimp.results.Equilibrium` of a finished search (model units)."""
    cols = raw["cols"]
    sc = search.sc
    vs = sc.b.vs[cols]
    gs = sc.b.gs[cols]
    Ls = system.length_scale
    names = [system.var_names[c] for c in cols]
    spec = S.sgc[cols].copy()
    free = ~spec
    F = raw["F"] * gs
    K = raw["K"] * np.outer(gs, 1.0 / vs)
    ftol = raw["ftol"] * gs
    status = raw["status"]
    messages: list[str] = []
    KFF = K if not spec.any() else K[np.ix_(free, free)]
    # stability is judged in internal units (every coordinate a radian or an internal
    # length, the search's own test); the eigenvalues are reported in model units
    Ki = raw["K"] if not spec.any() else raw["K"][np.ix_(free, free)]
    kmax = max(float(np.abs(Ki).max(initial=0.0)), 1e-300)
    thr = opts.neutral_tol * max(kmax, raw["scale"])
    symmetric = float(np.abs(Ki - Ki.T).max(initial=0.0)) <= 1e-8 * kmax
    if symmetric:
        lam, vec = _sym_eig(KFF)
        li, vi = _sym_eig(Ki)
    else:  # follower loads: divergence is a real eigenvalue of K_FF through zero
        lam, vec = _eig(KFF)
        li, vi = _eig(Ki)
    vi = vi * vs[free][:, None] if vi.size else vi  # internal shapes to model units
    low = li.real if li.size else li
    if free.sum() == 0:
        stability = "none"
    elif np.any((low < -thr) & (np.abs(li.imag) <= thr)) if not symmetric else low[0] < -thr:
        stability = "unstable"
    elif np.any(np.abs(li) <= thr):
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
        zero = [i for i in range(len(li)) if abs(li[i]) <= thr]
        modes = ", ".join(_mode_text(fnames, vi[:, i].real) for i in zero)
        moved = sorted({fnames[int(np.argmax(np.abs(vi[:, i])))] for i in zero})
        messages.append(f"neutral equilibrium: no stiffness along {modes} (the mechanism "
                        f"balances as well when {', '.join(moved)} moves that way)"
                        if converged else
                        f"neutral freedom: no stiffness along {modes}; an unbalanced load "
                        "there has no posture of balance")
    elif stability == "unstable":
        modes = ", ".join(_mode_text(fnames, vi[:, i].real) for i in range(len(li))
                          if li[i].real < -thr and abs(li[i].imag) <= thr)
        messages.append((f"unstable equilibrium: the potential energy falls along {modes}"
                         if symmetric else f"unstable equilibrium (divergence) along {modes}")
                        if converged else
                        f"the posture reached is not an equilibrium, and the stiffness "
                        f"there is negative along {modes}")
    if not symmetric and free.any():
        messages.append("the stiffness is not symmetric (follower loads, no potential): the "
                        "search is plain Newton (no energy test), and stability is the "
                        "static test (divergence: a real eigenvalue of K_FF through zero); "
                        "see openimp.modes for flutter")
    over = _over_specified(search, S, cols, spec)
    if over:
        messages.append(over)
    if not sc.loaded:
        messages.append("no load acts (no gravity on a mass, no spring, no applied load): "
                        "every posture is an equilibrium; the start posture is returned")
    holding = {n: -float(F[i]) for i, n in enumerate(names) if spec[i]}
    q_int = S.q.copy()
    quality = _quality(search, S)
    iterations = int(search.state["iter"]) if search.state["closed"] else 0
    fgc = np.zeros((1, system.nq), bool)
    fgc[0, cols[free]] = True
    tr = Trajectory(system, q_int[None, :].copy(), np.array([quality]),
                    np.array([raw["rank"]], np.int64), fgc,
                    np.array([iterations], np.int64), [n for n, s in zip(names, spec,
                                                                           strict=True) if s],
                    tracker=tracker(system), sgc=S.sgc.copy())
    tr.rank_ref, tr.quality_ref = raw["rank"], 1.0
    tr.set_rates(np.zeros((1, system.nq)), np.zeros((1, system.nq)), np.zeros(1))
    tr.time = np.array([S.time])
    eq = Equilibrium(
        system=system, q=q_int * sc.b.vs, coords=names, specified=spec,
        converged=converged, status=status, steps=raw["steps"],
        evaluations=search.evaluations, residual=F, force_tol=ftol, stiffness=K,
        eigenvalues=lam, eigenvectors=vec, stability=stability, holding=holding,
        potential=raw["pe"] * Ls * Ls, history=raw["history"], trajectory=tr,
        messages=messages, t=S.time)
    if want_forces:
        from openimp.dynamics.analysis import forces_of

        eq.forces = forces_of(tr, pivot_tol=opts.pivot_tol)
    return eq


def _eig(K: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues (sorted by real part) and vectors of an unsymmetric K."""
    if K.size == 0:
        return np.zeros(0), np.zeros((0, 0))
    lam, vec = np.linalg.eig(K)
    order = np.argsort(lam.real)
    lam, vec = lam[order], vec[:, order]
    if np.all(np.abs(lam.imag) <= 1e-12 * max(np.abs(lam).max(), 1e-300)):
        return lam.real.copy(), vec.real.copy()
    return lam, vec


def _over_specified(search: _Search, S: State, cols: np.ndarray, spec: np.ndarray) -> str:
    """A message when the SGCs over-specify the mechanism (their holding forces then
    split a load between them arbitrarily), else ""."""
    from openimp.kinematics.posture import eliminate_at, sgc_residual

    if not spec.any():
        return ""
    rank = eliminate_at(search.system, search.data, S, search.o.pivot_tol)[0]
    if sgc_residual(search.data, S.sgc, rank) <= 1e-8:
        return ""
    names = [search.system.var_names[c] for c, s in zip(cols, spec, strict=True) if s]
    return (f"the SGCs {', '.join(names)} over-specify the mechanism (they are not "
            "independent): their holding forces share a load in a way the rigid model "
            "cannot determine")


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
    """The quality index of the elimination at S.q with its generalized coordinates held
    (6.5.3): the last closure's, else a fresh elimination."""
    from openimp.kinematics.posture import eliminate_at

    if search.state["closed"]:
        return float(search.state["quality"])
    return float(eliminate_at(search.system, search.data, S, search.o.pivot_tol)[1])


def _mode_text(names: list[str], v: np.ndarray) -> str:
    """A mode shape in words: its largest components."""
    k = np.argsort(-np.abs(v))
    big = [i for i in k if abs(v[i]) >= 0.2 * abs(v[k[0]])][:3]
    return "(" + ", ".join(f"{v[i]:+.3g} {names[i]}" for i in big) + ")"


# ----------------------------------------------------------------------------- paths
def equilibria(system: System, path: Any = None, *, times: Any = None, q: Any = None,
               state: State | None = None, specified: Any = (), **options: Any
               ) -> EquilibriumPath:
    """A path of equilibria, each searched from the last (the book's W(psi) curve, 12.1).

    ``path``: a mapping SGC name -> values (model units, one per step; the
    named coordinates are held there, with any ``specified`` ones at their
    start values); ``times``: (steps,) the time of every step, which the
    load laws read (a load stepped through values is a law of t).  At least
    one of the two sets the number of steps.  ``q`` or ``state``: the start,
    as in :func:`equilibrium`.  ``options``: those of :func:`equilibrium`
    (``forces`` runs one force analysis of the whole path), and
    ``progress(done, total)``: called after every step with the steps done
    and the steps of the path.  Ctrl-C ends the path with the steps done
    (``message`` says so).

    Every step's :class:`~openimp.results.Equilibrium` is kept; a step that is
    not balanced ends the path there with its message (the steps before it are
    kept).  Turning points are reported in :attr:`EquilibriumPath.turning_points`:
    where the stability changes (the smallest stiffness eigenvalue changes
    sign: a limit point or a bifurcation), where a step jumps far from the
    path, and, on an SGC path, where a holding force passes an extremum (the
    limit load under which a dead load would snap the mechanism over).
    """
    opts = search_options("equilibria", options, path=True)
    path = {} if path is None else path
    if not hasattr(path, "items"):
        raise InputError("equilibria: path must map SGC names to arrays of values")
    names = list(path)
    cols = [system.var_index(k) for k in names] if isinstance(system, System) else []
    S = _start(system, q, state, list(names_of(specified, "equilibria")) + names, 0.0,
               "equilibria")
    vals = [_steps(path[k], f"path[{k!r}]") / system.var_scale[c]
            for k, c in zip(names, cols, strict=True)]
    tt = None if times is None else _steps(times, "times")
    sizes = {a.size for a in vals} | ({tt.size} if tt is not None else set())
    if len(sizes) > 1:
        given = [f"{k}: {a.size}" for k, a in zip(names, vals, strict=True)]
        given += [f"times: {tt.size}"] if tt is not None else []
        raise InputError(f"equilibria: the path and times have different numbers of values "
                         f"({', '.join(given)})")
    if not sizes:
        raise InputError("equilibria: give a path of SGC values or the times of load laws")
    search = _Search(system, opts)
    try:
        steps, message, interrupted = _walk(system, search, S, sizes.pop(), tt, cols, vals,
                                            opts)
    finally:
        search.release()
    return _path_result(system, steps, message, interrupted, names, cols, vals, tt, opts)


def _steps(values: Any, what: str) -> np.ndarray:
    """(steps,) finite numbers of a path or of its times."""
    try:
        arr = np.atleast_1d(np.asarray(values, float))
    except (TypeError, ValueError):
        raise InputError(f"equilibria: {what} must be numbers, one per step, got "
                         f"{values!r}") from None
    if arr.ndim != 1 or not np.all(np.isfinite(arr)) or arr.size == 0:
        raise InputError(f"equilibria: {what} must be finite values, one per step")
    if arr.size > MAX_STEPS:
        raise InputError(f"equilibria: {arr.size} steps are more than {MAX_STEPS} (limit "
                         "MAX_STEPS); take fewer, larger steps")
    return arr


def _walk(system: System, search: _Search, S: State, n: int, tt: np.ndarray | None,
          cols: list[int], vals: list[np.ndarray], opts: SearchOptions
          ) -> tuple[list[Equilibrium], str, bool]:
    """The steps of a path, each from the last: (equilibria, why it stopped early or "",
    interrupted)."""
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
        if opts.progress is not None:
            opts.progress(float(k + 1), float(n))
        if not eq.converged:
            message = f"step {k}: " + "; ".join(m for m in eq.messages
                                                 if not m.startswith("Equilibrium found"))
            break
        prev_tangent = _tangent(system, eq, cols) if cols else None
    return steps, message, interrupted


def _path_result(system: System, steps: list[Equilibrium], message: str, interrupted: bool,
                 names: list[str], cols: list[int], vals: list[np.ndarray],
                 tt: np.ndarray | None, opts: SearchOptions) -> EquilibriumPath:
    """The :class:`~openimp.results.EquilibriumPath` of the steps reached."""
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
    res.turning_points = turning_points(res)
    res.interrupted = interrupted
    if opts.forces and traj is not None:
        from openimp.dynamics.analysis import forces_of

        res.forces = forces_of(traj, pivot_tol=opts.pivot_tol)
    return res


def _path_step(system: System, search: _Search, S: State, k: int, tt: np.ndarray | None,
               cols: list[int], vals: list[np.ndarray], tangent: np.ndarray | None,
               opts: SearchOptions) -> Equilibrium:
    """The equilibrium of path step ``k``, searched from S (the last equilibrium) with the
    SGCs moved to their values there and the FGCs predicted along ``tangent``."""
    search.t = float(tt[k]) if tt is not None else 0.0
    S.t[0] = search.t
    if cols:
        _move_sgcs(search, S, cols, np.array([v[k] for v in vals]),
                   tangent if k > 0 else None)
    _assemble(search, S)
    raw = search.run(S)
    return _result(system, search, S, raw, False, opts)


#: largest change of a stepped SGC per sub-step of its move (internal units: radians or
#: internal lengths), so that the closure follows the branch (as a sweep does)
SUBSTEP = 0.05
#: most sub-steps of one move (1000 radians or internal lengths): a larger move is an
#: input error, not a path to follow
MAX_SUBSTEPS = 20000


def _move_sgcs(search: _Search, S: State, pcols: list[int], targets: np.ndarray,
               tangent: np.ndarray | None) -> None:
    """Move the SGCs ``pcols`` of S to ``targets`` (internal units) along the assembly
    branch of S: sub-steps of at most SUBSTEP, each a first-order predictor of every
    joint variable (phi' of the generalized coordinates at the posture before it; the
    FGCs along ``tangent`` (nq, len(pcols)) of :func:`_tangent`, else held) and the
    loops closed with the generalized coordinates held.  A start that is not
    assembled gets the values set directly (closed by :func:`_assemble`).  InputError
    when a sub-step cannot be closed: the inputs are beyond the mechanism's reach."""
    sy = search.system
    pc = np.asarray(pcols, np.int64)
    start = S.q[pc].copy()
    delta = targets - start
    big = float(np.abs(delta).max(initial=0.0))
    cols, _ = search.evaluate(S)
    if big == 0.0 or float(np.abs(search.E).max(initial=0.0)) > 1e-8:
        S.q[pc] = targets
        return
    if big > MAX_SUBSTEPS * SUBSTEP:
        vs = sy.var_scale[pc]

        def at(x: np.ndarray) -> str:
            return ", ".join(f"{sy.var_names[c]} = {v:.10g}" for c, v
                             in zip(pc, x * vs, strict=True))

        raise InputError(f"the specified coordinates move too far in one step, from "
                         f"{at(start)} to {at(targets)}: more than "
                         f"{MAX_SUBSTEPS * SUBSTEP:g} radians or internal lengths; give "
                         "values within reach of the last step")
    n = max(1, math.ceil(big / SUBSTEP))
    for i in range(1, n + 1):
        if i > 1:
            cols, _ = search.evaluate(S)
        where = {int(c): j for j, c in enumerate(cols)}
        G = search.sc.z_G[:, :cols.size]
        d = delta / n
        dq = np.zeros(sy.nq)
        for j, c in enumerate(pc):
            if int(c) in where:
                dq += G[:, where[int(c)]] * d[j]
        if tangent is not None:
            for c in np.flatnonzero(np.abs(tangent).sum(axis=1)):
                if int(c) in where and not S.sgc[c]:
                    dq += G[:, where[int(c)]] * float(tangent[c] @ d)
        S.q[:] += dq
        S.q[pc] = start + delta * (i / n)
        if not search.close(S, cols):
            vs = sy.var_scale[pc]
            asked = ", ".join(f"{sy.var_names[c]} = {v:.10g}" for c, v
                              in zip(pc, targets * vs, strict=True))
            reached = ", ".join(f"{sy.var_names[c]} = {v:.10g}" for c, v
                                in zip(pc, (start + delta * ((i - 1) / n)) * vs, strict=True))
            raise InputError(f"the mechanism cannot be assembled with {asked} (a limit of "
                             f"travel or a singular posture; it closes up to {reached})")


def _tangent(system: System, eq: Equilibrium, cols: list[int]) -> np.ndarray | None:
    """(nq, len(cols)) the first-order change of the equilibrium posture per unit change
    of the path's SGCs (internal units): dpsi_F = -K_FF^-1 K_FS dpsi_S, through phi'."""
    sp = eq.specified
    if sp.all() or not sp.any():
        return None
    free = ~sp
    at = [system.var_index(n) for n in eq.coords]
    vs = system.var_scale[at]
    gs = system.Y.gscale[at]
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


def turning_points(res: EquilibriumPath, label: str | None = None,
                    show: Any = None, names: Any = None) -> list[str]:
    """Messages for the turning points of a path.  ``label``: the parameter's name
    (default ``res.parameter``), ``show``: value -> text (default ``{:.6g}``, model
    units), ``names``: coordinate name -> the name to print (a listing's names)."""
    out: list[str] = []
    st = res.steps
    par = res.parameter if label is None else label

    def val(k: int) -> str:
        v = float(res.values[k])
        return f"{v:.6g}" if show is None else show(v)
    sy = res.system
    vs = np.asarray(sy.var_scale) if st else None
    fixed = {c for e in st for c, sp in zip(e.coords, e.specified, strict=True) if sp}
    moving = np.array([n not in fixed for n in sy.var_names], bool)
    # the path's parameter in internal units (an SGC's, or the time)
    p_int = np.asarray(res.values, float)
    if res.parameter != "t" and st:
        p_int = p_int / vs[sy.var_index(res.parameter)]

    def change(k: int) -> float:
        """Largest change of the free variables from step k-1 to k per unit change of
        the parameter (internal units)."""
        d = float(np.abs((st[k].q - st[k - 1].q)[moving] / vs[moving]).max(initial=0.0))
        dp = abs(p_int[k] - p_int[k - 1]) if k < p_int.size else 0.0
        return d / dp if dp > 0 else d

    for k in range(1, len(st)):
        a, b = st[k - 1], st[k]
        la = a.eigenvalues[0] if a.eigenvalues.size else None
        lb = b.eigenvalues[0] if b.eigenvalues.size else None
        if {a.stability, b.stability} == {"stable", "unstable"}:
            out.append(f"between steps {k - 1} and {k} ({par} {val(k - 1)}"
                       f" to {val(k)}) the smallest stiffness eigenvalue changes "
                       f"sign ({la:.4g} to {lb:.4g}): the path passes a limit point or a "
                       "bifurcation and the stability changes")
        if k >= 2 and a.coords == b.coords:
            d, prev = change(k), change(k - 1)
            jump = float(np.abs((b.q - a.q)[moving] / vs[moving]).max(initial=0.0))
            if prev > 0 and d > 10 * prev and jump > 0.05:
                first = st[0].eigenvalues[0] if st[0].eigenvalues.size else None
                fold = (la is not None and first is not None and first > 0
                        and 0 <= la < 0.5 * first)
                out.append(f"between steps {k - 1} and {k} ({par} {val(k - 1)} to "
                           f"{val(k)}) the equilibrium jumps ({d / prev:.3g} times the "
                           "change of the step before, per unit of the parameter): the "
                           "path snapped to another branch" + (
                               f"; the smallest stiffness eigenvalue had fallen from "
                               f"{first:.4g} to {la:.4g}: a limit point (snap-through)"
                               if fold else ""))
    single = res.parameter != "t" and len(st[0].holding if st else {}) >= 1
    if single:
        key = sy.var_names[sy.var_index(res.parameter)]
        names_h = [key] if key in st[0].holding else []
        for name in names_h:
            w = np.array([e.holding.get(name, np.nan) for e in st])
            dw = np.diff(w)
            tol = 1e-8 * max(float(np.nanmax(np.abs(w), initial=0.0)), 1e-300)
            sig = np.where(np.abs(dw) > tol, np.sign(dw), 0.0)
            last = 0.0
            for k in range(dw.size):
                if sig[k] == 0.0:
                    continue
                if last != 0.0 and sig[k] != last:
                    kind = "maximum" if last > 0 else "minimum"
                    shown = name if names is None else names(name)
                    out.append(f"the holding force of {shown} passes a {kind} of about "
                               f"{w[k]:.6g} at step {k} ({par} {val(k)}): under a dead "
                               "load of that size the mechanism would snap over (a limit "
                               "load)")
                last = sig[k]
    return out
