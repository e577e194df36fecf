"""One integration of a time response: the compiled run (:mod:`~openimp.dynamics.stepping`)
set up, started and driven, and the Python side of its step.

:class:`Run` owns the run's arrays (:class:`~openimp.dynamics.stepping.Work`, the
scratch of the stages) and registers itself as the run's handler
(:mod:`~openimp.dynamics.hooks`): the compiled step asks it for the motions of
the specified coordinates at its stage times, the load laws' values at a stage,
their slopes for the book's linear model, and after every accepted step whether
a switching function changed sign; it answers from the same arrays.  There is
one orchestration of the step, the compiled one; Python only answers it and
locates the events (:mod:`~openimp.dynamics.events`) by calling its attempts.
"""

from __future__ import annotations

import math
import time as _time
from collections.abc import Mapping
from typing import Any

import numpy as np

from openimp.dynamics import hooks
from openimp.dynamics import stepping as stp
from openimp.dynamics.eom import massless
from openimp.dynamics.events import Switches, crossed, locate
from openimp.dynamics.laws import Instant, law_derivatives, law_values_now
from openimp.dynamics.outputs import OutputBuffer
from openimp.dynamics.stepping import RunEnd, Stage
from openimp.errors import AnalysisError, InputError
from openimp.kinematics.elimination import eliminate, free_columns, jacobian
from openimp.kinematics.position import position
from openimp.kinematics.posture import newton
from openimp.kinematics.track import tracker
from openimp.motion import as_motion
from openimp.results import Event, Trajectory
from openimp.system import System, make_data, make_dyn_data

#: the book's "large" displacement of one step (internal units: radians, or lengths with
#: the bounding-box diagonal 1); section 11.4 of the book: about 0.25
XMAX = 0.25
#: Newton iterations allowed to close the loops at a stage (book 6.9: never more than 6)
MAXIT = 12

#: what each stage code means, for the run's message
WHY = {
    Stage.NO_CLOSURE: "the loops cannot be closed (Newton did not converge): a limit of "
                      "travel, a singular posture or a motion too fast for the step",
    Stage.SINGULAR_MASS: "the mass matrix of the free coordinates is singular (IMP's ZERO "
                         "(INERTIA)): a massless part can move alone, or free coordinates "
                         "turn about one line (a gimbal lock); give it mass or inertia, or "
                         "use a SPHERE for the gimbal",
    Stage.LOST_COORDINATES: "the free coordinates no longer describe the mechanism (a "
                            "singular posture)",
    Stage.TOO_LARGE: "the book's step moves a coordinate more than its largest displacement "
                     "(a quarter radian or a quarter of the model's size) even at the smallest "
                     "step allowed: a rate far too high, or a motion that grows without bound",
    Stage.UNDERFLOW: "the error control asked for a step below 1e-14 of the time (the motion "
                     "is discontinuous there, or the tolerance is below roundoff)",
    Stage.NEAR_CHANGE: "a change point (the loops' Jacobian singular, branches of motion "
                       "meeting) could not be passed",
    Stage.NO_PROGRESS: f"{stp.MAX_REJECTS} attempts in a row were rejected: the step makes "
                       "no progress (loosen the tolerance, or lower the smallest step)",
    Stage.NOT_FINITE: "the accelerations, the loads or the motion came out infinite or "
                      "undefined (NaN): a spring rate, mass, force or rate too large for the "
                      "arithmetic, or a motion that grows without bound; check the sizes of "
                      "the data",
    Stage.TINY_STEP: "the error control asks for steps below {floor:.3g} s (1e-6 of the "
                     "output step): a spring or load far too stiff or with a pole, a motion "
                     "that grows without bound (a negative damper), or a rate far too high "
                     "for the outputs asked for; "
                     "give a smallest step (DATA TIME's second number, min_step) to go on "
                     "with steps of that length whatever their error",
}
#: wall seconds between returns of a compiled run to Python (progress, Ctrl-C)
TICK_SECONDS = 0.2
#: wall seconds of attempts between two questions to the clock (Hook.TICK); the count
#: grows at most twofold per question, so a run whose attempts turn slow waits a few of
#: these at worst before a Ctrl-C is seen
TICK_GAP = 0.02


def why(code: int, floor: float = 0.0) -> str:
    """The message of a stage code (named by its :class:`Stage` member); ``floor``: the
    run's step floor (s), which TINY_STEP names."""
    try:
        st = Stage(int(code))
    except ValueError:
        return f"the step failed (code {code})"
    return WHY.get(st, f"the step failed ({st.name})").replace("{floor:.3g}", f"{floor:.3g}")


class Held:
    """A coordinate held at a value: position, zero rate and acceleration."""

    def __init__(self, value: float) -> None:
        self.value = float(value)

    def __call__(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        t = np.asarray(t, dtype=float)
        return np.full_like(t, self.value), np.zeros_like(t), np.zeros_like(t)


def motions(system: System, motion: Any, key: str = "motion") -> tuple[np.ndarray, list[Any]]:
    """The SGC columns (ascending) and their motions (model units) of a mapping
    coordinate -> motion of time (or number: held)."""
    if motion is None:
        return np.zeros(0, np.int64), []
    if not isinstance(motion, Mapping):
        raise InputError(f"{key} must map joint variables to motions of time (or numbers)")
    rows: dict[int, Any] = {}
    for name, mo in motion.items():
        c = column(system, name, key)
        if c in rows:
            raise InputError(f"{key}: {name!r} is given twice")
        if isinstance(mo, int | float) and not isinstance(mo, bool):
            rows[c] = Held(mo)
        else:
            rows[c] = as_motion(mo)
    cols = np.array(sorted(rows), np.int64)
    return cols, [rows[int(c)] for c in cols]


def column(system: System, key: Any, what: str) -> int:
    """The column of joint variable ``key``; an input error naming ``what`` else."""
    try:
        return system.var_index(key)
    except (KeyError, ValueError, InputError, TypeError, IndexError):
        raise InputError(f"{what}: {key!r} is not a joint variable of the model (give "
                         f"'joint' or 'joint.var': {', '.join(system.var_names)})") from None


class Drive:
    """The SGC motions evaluated at times, internal units: (times, nS, 3)."""

    def __init__(self, system: System, cols: np.ndarray, motions: list[Any]) -> None:
        self.cols = cols
        self.motions = motions
        self.scale = system.var_scale[cols] if cols.size else np.zeros(0)
        self.names = [system.var_names[c] for c in cols]
        #: some motion is a function of time (held coordinates need no call)
        self.timed = any(not isinstance(m, Held) for m in motions)

    def at(self, t: np.ndarray, out: np.ndarray) -> None:
        for s, mo in enumerate(self.motions):
            try:
                p, v, a = mo(t)
            except InputError:
                raise
            except Exception as exc:  # the user's function: any failure is bad input
                raise InputError(f"motion of {self.names[s]}: it failed at t = "
                                 f"{float(np.max(t)):.6g}: {type(exc).__name__}: {exc}") from None
            out[:, s, 0] = np.asarray(p, float) / self.scale[s]
            out[:, s, 1] = np.asarray(v, float) / self.scale[s]
            out[:, s, 2] = np.asarray(a, float) / self.scale[s]
        if not np.all(np.isfinite(out)):
            raise InputError(f"a motion gave a value that is not finite near t = "
                             f"{float(np.max(t)):.6g}")


#: evaluations of the start at most, while the laws that watch accepted states settle
START_PASSES = 50


class Run:
    """One integration: the compiled work arrays, the handler of the step's hooks and
    the loop of compiled runs around them."""

    def __init__(self, system: System, method: str, drive: Drive, opts: Any,
                 events: bool) -> None:
        self.system = system
        self.book = method == "book"
        self.method = method
        nq = system.nq
        self.data = make_data(system, nq)
        self.dyn = make_dyn_data(system, nq)
        self.drive = drive
        self.W = stp.make_work(nq, drive.cols.size, len(system.bodies), len(system.laws))
        w = self.w = stp.work_arrays(self.W)
        w.gscale[:] = system.Y.gscale
        w.scols[:] = drive.cols
        w.role[drive.cols] = 2
        w.rtol[0], w.atol[0] = opts.rtol, opts.atol
        w.hmin[0], w.hmax[0], w.hfloor[0] = opts.min_step, opts.max_step, opts.floor
        w.hcap[0] = math.inf  # set by the book step while switches are watched
        w.ptol[0], w.ctol[0], w.mtol[0] = opts.pivot_tol, opts.tol, opts.mass_tol
        w.fabs[0], w.fpct[0] = opts.force_error
        w.xmax[0] = XMAX
        w.smallest[0], w.largest[0] = math.inf, 0.0
        w.hnext[0] = opts.first_step
        w.tfail[0] = math.nan  # the time of an output that failed (else the step's)
        w.maxit[0] = MAXIT
        self.switch_fns = Switches(system)
        w.driven[0] = drive.timed
        w.laws[0] = bool(system.laws)
        w.events[0] = events and bool(self.switch_fns)
        #: the laws' ``accepted`` callables (each once): told of every accepted state
        self.watchers: list[Any] = []
        for _what, _name, fn, _col in system.laws:
            f = getattr(fn, "accepted", None)
            if callable(f) and f not in self.watchers:
                self.watchers.append(f)
        w.watch[0] = bool(self.watchers)
        self.instant = Instant(system, None, self.data)
        self.law = self.dyn.v.law
        self.switches: list[tuple[int, float, tuple[str, ...], tuple[str, ...]]] = []
        #: change points passed: (time, posture, the whole Jacobian's smallest pivot there)
        self.crossings: list[tuple[float, np.ndarray, float]] = []
        self.g_start = np.zeros(0)
        self.g_end = np.zeros(0)
        self.snap: list[np.ndarray] = []
        self.locating = False
        self.events: list[Event] = []
        self.error: BaseException | None = None
        #: set by a Ctrl-C the caller defers (:func:`openimp._interrupt.deferred_interrupt`)
        self.interrupt = [False]
        self.S: Any = None
        self.k = (system.KP, self.data.DP, system.YP, self.dyn.ZP)
        self.attempt = stp.book_attempt if self.book else stp.rk_attempt
        self.run = stp.run_book if self.book else stp.run_rk
        self.names_before: tuple[str, ...] = ()
        self.ident = hooks.register(self.handle)
        self.tick0 = self.tick_last = _time.perf_counter()
        w.hook[0] = self.ident
        w.tick[0] = stp.TICK_EVERY

    def tick(self) -> int:
        """The clock (Hook.TICK): 1 when TICK_SECONDS have passed since the run left
        Python; sets the attempts to the next question to about TICK_GAP seconds' worth
        at the pace since the last (at most twice as many as before)."""
        now = _time.perf_counter()
        n = int(self.w.tick[0])
        pace = (now - self.tick_last) / max(n, 1)
        self.tick_last = now
        self.w.tick[0] = max(stp.TICK_EVERY, min(2 * n, int(TICK_GAP / max(pace, 1e-9))))
        return int(now - self.tick0 > TICK_SECONDS)

    def close(self) -> None:
        """The run is over: its handler is forgotten."""
        hooks.unregister(self.ident)

    # ---- the step's hooks
    def handle(self, what: int) -> int:
        """Answer the compiled step (:class:`~openimp.dynamics.hooks.Hook`); an exception
        is kept for the caller and the step told it failed.  A Ctrl-C deferred by the
        caller (:attr:`interrupt`) ends the step here: the clock asks for Python, any
        other hook fails with KeyboardInterrupt, raised by the caller."""
        if self.interrupt[0]:
            if what == hooks.Hook.TICK:
                return 1
            self.error = KeyboardInterrupt()
            return hooks.FAILED
        try:
            if what == hooks.Hook.MOTION:
                n = int(self.w.nmt[0])
                self.drive.at(self.w.mt[:n], self.w.ms[:n])
            elif what == hooks.Hook.LAWS:
                law_values_now(self.system, self.instant, float(self.S.t[0]), self.law)
            elif what == hooks.Hook.LAW_TERMS:
                self.law_terms()
            elif what == hooks.Hook.SNAP:
                if not self.locating:
                    self.snap = [a.copy() for a in self.W.P] + [self.law.copy()]
            elif what == hooks.Hook.TICK:
                return self.tick()
            elif what == hooks.Hook.SWITCH:
                if self.w.events[0]:
                    self.g_end = self.switch_fns.signs(self.instant, float(self.w.t[0]))
                    if np.any(crossed(self.g_start, self.g_end)):
                        return hooks.CROSSED  # told once the event is located
                    self.g_start = self.g_end
                if self.watchers:
                    self.tell()
                    return hooks.TOLD
        except Exception as exc:  # kept and raised by the caller, out of compiled code
            self.error = exc
            return hooks.FAILED
        return hooks.DONE

    def tell(self) -> None:
        """Tell the watching laws (:attr:`watchers`) of the state just accepted, the step
        start w.q0, w.qd0, w.qdd0 at w.t[0]: a trajectory of one step with its
        accelerations, its FGCs free and its SGCs specified."""
        if not self.watchers:
            return
        w, system = self.w, self.system
        nq = system.nq
        free = np.zeros((1, nq), bool)
        free[0, w.fcols[:int(w.nF[0])]] = True
        spec = np.zeros(nq, bool)
        spec[w.scols] = True
        tr = Trajectory(system, w.q0[None, :].copy(), w.quality[:1].copy(),
                        np.zeros(1, np.int64), free, np.zeros(1, np.int64),
                        [system.var_names[int(c)] for c in w.scols], tracker=tracker(system),
                        sgc=spec)
        tr.set_rates(w.qd0[None, :].copy(), w.qdd0[None, :].copy(), np.zeros(1))
        tr.time = np.array([float(w.t[0])])
        longest = math.inf
        for f in self.watchers:
            want = f(tr)
            if want is not None:
                longest = min(longest, float(want))
        if longest < w.hnext[0]:  # a watcher that reads the motion a step behind
            w.hnext[0] = max(longest, float(w.hfloor[0]))

    def law_terms(self) -> None:
        """The load laws' stiffness and damping added to the book's D and K at the step
        start: a law is then part of the step's linear model, not a force held over
        the step (whose step would be first order in contact with a stop)."""
        w = self.w
        nF = int(w.nF[0])
        nf = nF + w.scols.size
        lin = self.W.lin
        D, K = lin.D, lin.K
        Gl, qpl, qdpl = lin.Gl, lin.qpl, lin.qdpl
        cols = w.lcols[:nf]
        # the directions of the coordinates' motion and of their rates' (the side of a
        # law's kink the step goes to)
        acc = np.zeros(self.system.nq)
        acc[w.fcols[:nF]] = w.kv[0, :nF]
        acc[w.scols] = w.ms[0, :, 2]
        rate = w.psid[cols]
        go = np.where(rate != 0.0, rate, acc[cols])  # at rest, where it starts to move
        law_derivatives(self.system, w.q0, self.dyn.v.Gf[:, :nf], cols, qpl[:nf],
                        qdpl[:nf], Gl[:nf], w.psid, float(w.t[0]), D[:nf, :nf], K[:nf, :nf],
                        [], (go, acc[cols]))

    def failed(self, code: int) -> None:
        """Raise what a Python callable raised inside the step (code PYTHON)."""
        if int(code) == Stage.PYTHON and self.error is not None:
            err, self.error = self.error, None
            raise err

    # ---- the state at the start
    def start(self, S: Any, t0: float, q_given: dict[int, float], qd_given: dict[int, float],
              qd_all: np.ndarray | None) -> None:
        """Assemble the start (the SGCs at their motion's start, the given positions held),
        choose the FGCs (those with given rates first), set their rates (``qd_given``
        by column, or ``qd_all`` of every joint variable, internal units) and evaluate
        the start."""
        system, w = self.system, self.w
        pivot_tol, tol = float(w.ptol[0]), float(w.ctol[0])
        KP, DP = self.system.KP, self.data.DP
        self.S = self.instant.S = S
        if self.drive.cols.size:
            self.drive.at(np.array([t0]), w.ms[:1])
        w.ms[:] = w.ms[0]
        for s, c in enumerate(w.scols):
            S.q[c] = w.ms[0, s, 0]
        for c, v in q_given.items():
            S.q[c] = v
        S.sgc[:] = False
        S.sgc[w.scols] = True
        S.sgc[list(q_given)] = True
        S.t[0] = t0
        res = newton(KP, DP, S, system.gen, tol, pivot_tol, 50, False)
        S.sgc[:] = False
        S.sgc[w.scols] = True
        if res[0] != 0:
            given = ", ".join(system.var_names[c] for c in sorted(set(q_given) | set(w.scols)))
            raise InputError(f"the mechanism cannot be assembled at the start (t = {t0:g} s) "
                             f"with {given or 'the modeling posture'} as given: change the "
                             "initial positions")
        # the FGCs: the coordinates with given rates first, then what the elimination leaves
        w.role[:] = 0
        w.role[w.scols] = 2
        self.choose_start(S, qd_given, pivot_tol)
        w.t[0] = t0
        nF = int(w.nF[0])
        for j in range(nF):
            c = int(w.fcols[j])
            w.x0[j] = S.q[c]
            w.v0[j] = qd_given.get(c, 0.0) if qd_all is None else float(qd_all[c])
        w.q0[:] = S.q
        w.qd0[:] = 0.0
        w.qdd0[:] = 0.0
        code = stp.restart(*self.k, S, system.gen, self.W)
        if code != Stage.OK:
            self.failed(code)
            named = massless(system, S) if code == Stage.SINGULAR_MASS else ""
            if code == Stage.NOT_FINITE:  # from the data: nothing was integrated yet
                raise InputError(f"at the start (t = {t0:g} s): {why(code)}")
            raise AnalysisError(f"t = {t0:g} s: {named or why(code)}")
        w.qref[0] = w.quality[0]
        for _ in range(START_PASSES if self.watchers else 0):
            # the laws' view of the start, then the start's derivatives again, until they
            # settle (values read a step behind that feed back, an acceleration)
            before = w.qdd0.copy()
            self.tell()
            code = stp.restart(*self.k, S, system.gen, self.W)
            if code != Stage.OK:
                self.failed(code)
                raise AnalysisError(f"t = {t0:g} s: {why(code)}")
            if np.allclose(w.qdd0, before, rtol=1e-12, atol=1e-300):
                break
        if w.events[0]:
            self.g_start = self.switch_fns.signs(self.instant, t0)

    def choose_start(self, S: Any, qd_given: dict[int, float], pivot_tol: float) -> None:
        system, w = self.system, self.w
        DP = self.data.DP
        position(system.KP, DP, S, system.gen, 1)
        jacobian(system.KP, DP, S, system.gen)
        base = S.sgc.copy()
        if any(c in set(w.scols.tolist()) for c in qd_given):
            raise InputError("initial rates are given for a driven coordinate: its motion "
                             "sets its rate")
        rank = eliminate(DP, S.sgc, pivot_tol)[0]
        if qd_given:
            S.sgc[list(qd_given)] = True
            rank1 = eliminate(DP, S.sgc, pivot_tol)[0]
            if rank1 < rank:
                S.sgc[:] = base
                names = ", ".join(system.var_names[c] for c in sorted(qd_given))
                raise InputError(f"the initial rates of {names} are not independent (the loops "
                                 "tie them together): give rates of independent coordinates, "
                                 "at most as many as the mobility")
            rank = rank1
        free = np.zeros(system.nq, np.bool_)  # the given-rate columns free (never pivoted)
        free_columns(DP, base, rank, free)
        S.sgc[:] = base
        cols = np.flatnonzero(free)
        w.fcols[:cols.size] = cols
        w.nF[0] = cols.size
        w.role[cols] = 1

    # ---- events
    def restore(self) -> None:
        """Back to the step start kept by the last :data:`Hook.SNAP`."""
        for dst, src in zip((*self.W.P, self.law), self.snap, strict=True):
            dst[...] = src

    def take(self, h: float) -> np.ndarray | None:
        """The step of length h from the kept start, accepted whatever its error; the
        switching functions at its end (None when it could not be taken)."""
        self.restore()
        w = self.w
        hmin = float(w.hmin[0])
        w.hmin[0] = h  # accepted whatever its error
        w.h[0] = h
        code = self.attempt(*self.k, self.S, self.system.gen, self.W)
        w.hmin[0] = hmin
        if code != stp.ACCEPTED:
            self.failed(int(w.why[0]))
            return None
        return self.switch_fns.signs(self.instant, float(w.t[0]))

    def event(self, O: stp.Outputs) -> int:
        """A switching function changed sign over the step just accepted: take the step
        again up to its first root (:func:`~openimp.dynamics.events.locate`), record
        the event, evaluate the start again with the law switched, and finish the
        step (:func:`~openimp.dynamics.stepping.after_step`).  -1 to go on, else the
        run's code."""
        w = self.w
        h = float(w.h[0])
        t0 = float(w.tprev[0])
        hnext = float(w.hnext[0])
        t_end = float(O.times[-1])
        last = t0 + h >= t_end
        g0 = self.g_start
        self.locating = True
        try:
            hi, changed, g_end = locate(self.take, g0, self.g_end, h, t0)
        finally:
            self.locating = False
        t_ev = t0 + hi
        for i in changed:  # a function leaving exactly 0 (at rest at the start) is no event
            if crossed(g0[i:i + 1], g_end[i:i + 1])[0] and g0[i] != 0.0:
                self.events.append(Event(t_ev, self.switch_fns.name(int(i)),
                                         1 if g0[i] <= 0 else -1))
        w.hnext[0] = hnext
        self.tell()  # the watching laws' values at the event, used from here on
        # the law switched: the derivatives of the start are those after the switch
        code = stp.restart(*self.k, self.S, self.system.gen, self.W)
        if code != Stage.OK:
            self.failed(code)
            raise AnalysisError(f"t = {t_ev:.9g} s: {why(code)}")
        self.g_start = self.switch_fns.signs(self.instant, float(w.t[0]))
        return int(stp.after_step(*self.k, self.S, self.system.gen, self.W, O,
                                  last and hi >= h))

    # ---- drive the whole run
    def advance(self, out: OutputBuffer, max_steps: int) -> int:
        """Integrate on, recording outputs, until every output is done (REACHED), the
        buffer is full (FULL), max_steps were taken (CAPPED) or the run cannot go on
        (STOPPED); changes of coordinates and events are recorded on the way."""
        w, S = self.w, self.S
        s0 = int(w.steps[0])
        while True:
            O = out.view()
            left = max_steps - (int(w.steps[0]) - s0)
            if left <= 0:
                return RunEnd.CAPPED
            self.tick0 = self.tick_last = _time.perf_counter()
            code = int(self.run(*self.k, S, self.system.gen, self.W, O, left))
            if code == RunEnd.PAUSED:
                return code
            if code == RunEnd.EVENT:
                code = self.event(O)
                if code < 0:
                    continue
            if code == RunEnd.STOPPED:
                self.failed(int(w.why[0]))
            tc = float(w.tcross[0])
            if code in (RunEnd.SWITCHED, RunEnd.CROSSED) and not math.isnan(tc) and not (
                    self.crossings and abs(tc - self.crossings[-1][0]) <= 1e-9 * max(1.0, tc)):
                self.crossings.append((tc, w.qcross.copy(), float(w.pcross[0])))
            if code == RunEnd.CROSSED:
                continue
            if code != RunEnd.SWITCHED:
                return code
            new = self.fgc_names()
            self.switches.append((out.count, float(w.t[0]), self.names_before, new))
            self.names_before = new
            if w.laws[0]:  # law values at the start, for the next first stage
                code = int(stp.restart(*self.k, S, self.system.gen, self.W))
                if code != Stage.OK:
                    self.failed(code)
                    w.why[0] = code
                    return RunEnd.STOPPED

    def fgc_names(self) -> tuple[str, ...]:
        w = self.w
        return tuple(self.system.var_names[int(c)] for c in w.fcols[:int(w.nF[0])])

