"""Time response (book ch 14): :func:`simulate`, the Python entry.

The mechanism is released from initial conditions, its specified coordinates
(SGCs) driven as functions of time, and the equations of motion integrated in
its free generalized coordinates (FGCs) with the loops closed at every stage
(:mod:`~openimp.dynamics.stepping`, compiled).  Outputs come at the requested
times, hit exactly, with the energy audit, the loop-closure residual and the
quality index at each; a failure keeps every output before it.

Two integrators (``method``):

* ``"rk"`` (default): adaptive Dormand-Prince 5(4), error per step against
  ``atol + rtol |y|`` on the FGC positions and rates: the accurate one for
  smooth problems;
* ``"book"``: the book's locally linearized exact-exponential step (ch 14),
  controlled by the force error of IMP's ZERO (FORCE): the one for stiff
  problems (springs far stiffer than the motion needs), whose high
  frequencies do not set its step.

Without SGC motions of time and load laws the run is compiled calls of up to
:data:`CHUNK_STEPS` steps each (outputs interpolated and recorded inside);
otherwise Python drives the same compiled stages step by step (the motions and
laws are Python callables).  The works of the energy audit are integrated with
the motion but not error-controlled: with drives or loads, a smaller
``max_step`` tightens them.
"""

from __future__ import annotations

import contextlib
import math
import os
import sys
import time as _time
from collections.abc import Callable, Iterator, Mapping, Sequence
from typing import Any, TextIO

import numpy as np

from openimp.dynamics import stepping as stp
from openimp.dynamics.laws import LoadState, law_values_at
from openimp.dynamics.vibration import check_mass, law_derivatives, linearize
from openimp.errors import AnalysisError, InputError
from openimp.kinematics.posture import newton
from openimp.kinematics.track import tracker
from openimp.motion import as_motion
from openimp.results import (
    CoordinateSwitch,
    EnergyAudit,
    Event,
    IntegrationStats,
    Trajectory,
)
from openimp.system import System, make_data, make_dyn_data, make_state

#: methods of :func:`simulate`
METHODS = ("rk", "book")
#: the book's "large" displacement of one step (internal units: radians, or lengths with
#: the bounding-box diagonal 1); section 11.4 of the book: about 0.25
XMAX = 0.25
#: Newton iterations allowed to close the loops at a stage (book 6.9: never more than 6)
MAXIT = 12
#: steps per compiled call between progress reports (and chances for Ctrl-C)
CHUNK_STEPS = 2000
#: output rows held at once when they are streamed and not kept
CHUNK_ROWS = 1024


class _Held:
    """A coordinate held at a value: position, zero rate and acceleration."""

    def __init__(self, value: float) -> None:
        self.value = float(value)

    def __call__(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        t = np.asarray(t, dtype=float)
        return np.full_like(t, self.value), np.zeros_like(t), np.zeros_like(t)


# ------------------------------------------------------------------ inputs
def _positive(name: str, v: Any, allow_zero: bool = False) -> float:
    try:
        x = float(v)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a number, got {v!r}") from None
    if not math.isfinite(x) or x < 0 or (x == 0 and not allow_zero):
        raise InputError(f"{name} must be a {'non-negative' if allow_zero else 'positive'} "
                         f"finite number, got {v!r}")
    return x


#: most output times of a run (their times alone take 80 MB)
MAX_OUTPUTS = 10_000_000


def output_times(t_final: Any, print_step: Any, times: Any) -> np.ndarray:
    """The output times: ``times`` as given (increasing, finite, at least two), or 0,
    print_step, ... up to and including t_final."""
    if times is not None:
        if t_final is not None or print_step is not None:
            raise InputError("give either times= or t_final (with print_step), not both")
        try:
            t = np.asarray(times, dtype=float).reshape(-1)
        except (TypeError, ValueError):
            raise InputError(f"times must be numbers, got {times!r}") from None
        if t.size < 2 or not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
            raise InputError("times must be at least two finite, strictly increasing times "
                             "(the first is the start)")
        return t
    if t_final is None:
        raise InputError("give the final time (t_final) or the output times (times=)")
    tf = _positive("t_final", t_final)
    dt = tf if print_step is None else _positive("print_step", print_step)
    ratio = tf / dt
    if not ratio <= MAX_OUTPUTS:  # before floor(): an infinite ratio has no integer
        raise InputError(f"t_final {tf:g} s at print_step {dt:g} s makes {ratio:.3g} outputs, "
                         f"more than {MAX_OUTPUTS:g}: give a larger print_step (or fewer times)")
    n = math.floor(ratio * (1 + 1e-12))
    t = np.arange(n + 1) * dt
    if tf - t[-1] > 1e-9 * dt:
        t = np.append(t, tf)
    else:
        t[-1] = tf
    return t


def _column(system: System, key: Any, what: str) -> int:
    try:
        return system.var_index(key)
    except (KeyError, ValueError, InputError, TypeError, IndexError):
        raise InputError(f"{what}: {key!r} is not a joint variable of the model (give "
                         f"'joint' or 'joint.var': {', '.join(system.var_names)})") from None


def _mapping(system: System, values: Any, what: str) -> dict[int, float]:
    """A mapping key -> number as {column: internal value}."""
    if values is None:
        return {}
    if not isinstance(values, Mapping):
        raise InputError(f"{what} must map joint variables to numbers, e.g. {{'A': 0.5}}")
    out: dict[int, float] = {}
    for key, v in values.items():
        c = _column(system, key, what)
        try:
            x = float(v)
        except (TypeError, ValueError):
            raise InputError(f"{what}: the value of {key!r} must be a number, got {v!r}") from None
        if not math.isfinite(x):
            raise InputError(f"{what}: the value of {key!r} must be finite, got {v!r}")
        out[c] = x / system.var_scale[c]
    return out


def _motions(system: System, motion: Any) -> tuple[np.ndarray, list[Any]]:
    """The SGC columns (ascending) and their motions (model units)."""
    if motion is None:
        return np.zeros(0, np.int64), []
    if not isinstance(motion, Mapping):
        raise InputError("motion must map joint variables to motions of time (or numbers)")
    rows: dict[int, Any] = {}
    for key, mo in motion.items():
        c = _column(system, key, "motion")
        if c in rows:
            raise InputError(f"motion: {key!r} is given twice")
        if isinstance(mo, int | float) and not isinstance(mo, bool):
            rows[c] = _Held(mo)
        else:
            rows[c] = as_motion(mo)
    cols = np.array(sorted(rows), np.int64)
    return cols, [rows[int(c)] for c in cols]


class _Drive:
    """The SGC motions evaluated at times, internal units: (times, nS, 3)."""

    def __init__(self, system: System, cols: np.ndarray, motions: list[Any]) -> None:
        self.cols = cols
        self.motions = motions
        self.scale = system.var_scale[cols] if cols.size else np.zeros(0)
        self.names = [system.var_names[c] for c in cols]

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


# ------------------------------------------------------------------ the run
class _Outputs:
    """The output rows: the buffers the compiled run writes (ob, rows from kout[0] -
    base), kept whole (``keep``) or flushed to the stream chunk by chunk."""

    def __init__(self, system: System, tout: np.ndarray, keep: bool, stream: Any) -> None:
        nq = system.nq
        n = tout.size
        self.system = system
        self.tout = tout
        self.keep = keep
        self.cap = n if keep else min(n, CHUNK_ROWS)
        cap = self.cap
        self.ob = (np.zeros(cap), np.zeros((cap, nq)), np.zeros((cap, nq)), np.zeros((cap, nq)),
                   np.zeros((cap, nq), np.bool_), np.zeros(cap), np.zeros(cap), np.zeros((cap, 5)))
        self.kout = np.zeros(1, np.int64)
        self.base = 0
        self.streamed = 0
        self.last: tuple[np.ndarray, ...] | None = None
        self.first: tuple[np.ndarray, ...] | None = None
        self.stream = _Stream(system, stream) if stream is not None else None

    @property
    def count(self) -> int:
        return int(self.kout[0])

    def flush(self) -> None:
        """Stream the rows written since the last flush; without ``keep`` free the buffer."""
        upto = self.count - self.base
        if self.stream is not None:
            for r in range(self.streamed - self.base, upto):
                self.stream.write(self.ob, r, self.system.length_scale ** 2)
            self.streamed = self.count
        if not self.keep and upto > 0:
            if self.first is None:
                self.first = tuple(a[:1].copy() for a in self.ob)
            self.last = tuple(a[upto - 1:upto].copy() for a in self.ob)
            self.base = self.count

    def rows(self) -> tuple[np.ndarray, ...]:
        """The kept rows: all of them, or without ``keep`` the first and the last (the
        energy audit is against the start)."""
        if self.keep:
            return tuple(a[:self.count].copy() for a in self.ob)
        if self.last is None or self.first is None:
            return tuple(a[:0].copy() for a in self.ob)
        if self.count == 1:
            return self.first
        return tuple(np.concatenate((f, la)) for f, la in zip(self.first, self.last, strict=True))


class _Stream:
    """Output rows written to a CSV file as they come (``<path>.part`` while the run
    goes on, renamed to ``path`` when it ends, complete or not)."""

    def __init__(self, system: System, path: Any) -> None:
        try:
            self.path = os.fspath(path)
        except TypeError:
            raise InputError(f"stream must be the path of a .csv file, got {path!r}") from None
        if not isinstance(self.path, str):
            raise InputError(f"stream must be the path of a .csv file, got {path!r}")
        if not self.path.lower().endswith(".csv"):
            raise InputError(f"stream must name a .csv file, got {self.path!r}")
        d = os.path.dirname(os.path.abspath(self.path))
        if not os.path.isdir(d):
            raise InputError(f"stream: the folder {d!r} does not exist")
        self.part = self.path + ".part"
        self.scale = system.var_scale
        names = system.var_names
        head = (["time"] + list(names) + [n + "'" for n in names] + [n + "''" for n in names]
                + ["kinetic", "potential", "drive work", "load work", "dissipated", "closure",
                   "quality"])
        try:
            self.f: TextIO | None = open(self.part, "w", encoding="utf-8")
        except OSError as exc:
            raise InputError(f"stream: cannot write {self.part!r}: {exc.strerror}") from None
        self.f.write(",".join(head) + "\n")

    def write(self, ob: tuple[np.ndarray, ...], k: int, e2: float) -> None:
        assert self.f is not None
        sc = self.scale
        t, q, qd, qdd, _fgc, qual, clos, en = ob
        row = np.concatenate(([t[k]], q[k] * sc, qd[k] * sc, qdd[k] * sc, en[k] * e2,
                              [clos[k], qual[k]]))
        self.f.write(",".join(repr(float(x)) for x in row) + "\n")
        self.f.flush()

    def close(self) -> None:
        if self.f is not None:
            self.f.close()
            self.f = None
            os.replace(self.part, self.path)


class _Progress:
    """A one-line bar on a terminal (or the user's callable(t, t_final))."""

    def __init__(self, progress: Any, t0: float, tf: float) -> None:
        self.fn: Callable[[float, float], Any] | None = None
        self.bar = False
        self.t0, self.tf = t0, tf
        self.last = 0.0
        if callable(progress):
            self.fn = progress
        elif progress is None:
            self.bar = sys.stderr.isatty()
        elif progress is True:
            self.bar = True
        elif progress is not False:
            raise InputError("progress must be None, True, False or a callable(t, t_final)")

    def __call__(self, t: float, force: bool = False) -> None:
        if self.fn is not None:
            self.fn(t, self.tf)
            return
        if not self.bar:
            return
        now = _time.monotonic()
        if not force and now - self.last < 0.2:
            return
        self.last = now
        frac = (t - self.t0) / max(self.tf - self.t0, 1e-300)
        n = int(30 * frac)
        sys.stderr.write(f"\r  time response [{'#' * n}{'.' * (30 - n)}] t = {t:.4g} s "
                         f"of {self.tf:.4g}")
        sys.stderr.flush()

    def done(self) -> None:
        if self.bar:
            sys.stderr.write("\n")
            sys.stderr.flush()


class _Laws:
    """The load laws of a system evaluated at the stage state (Python callables) and
    their switching functions (a law's ``switch`` attribute)."""

    def __init__(self, system: System, dyn: Any) -> None:
        self.system = system
        self.dyn = dyn
        self.switches = [(slot, name, fn.switch)
                         for slot, (_, name, fn, _c) in enumerate(system.laws)
                         if callable(getattr(fn, "switch", None))]

    def set(self, S: Any, t: float) -> None:
        self.dyn.v.law[:] = law_values_at(self.system, S.q[None, :], S.qd[None, :], t)[0]

    def signs(self, S: Any, t: float) -> np.ndarray:
        """The switching functions at the state S (model units), one per switching law."""
        if not self.switches:
            return np.zeros(0)
        tr = _state_trajectory(self.system, S)
        out = np.zeros(len(self.switches))
        for i, (slot, name, fn) in enumerate(self.switches):
            x, xd = _law_coordinate(self.system, tr, slot)
            try:
                out[i] = float(fn(LoadState(tr, 0, t, x, xd)))
            except InputError:
                raise
            except Exception as exc:
                raise InputError(f"{name}: its switching function failed at t = {t:.6g}: "
                                 f"{type(exc).__name__}: {exc}") from None
        return out


def _state_trajectory(system: System, S: Any) -> Trajectory:
    n = 1
    tr = Trajectory(system, S.q[None, :].copy(), np.ones(n), np.zeros(n, np.int64),
                    np.zeros((n, system.nq), bool), np.zeros(n, np.int64), [],
                    tracker=tracker(system))
    tr.set_rates(S.qd[None, :].copy(), S.qdd[None, :].copy(), np.zeros(n))
    return tr


def _law_coordinate(system: System, tr: Trajectory, slot: int) -> tuple[float, float]:
    what, name, _fn, col = system.laws[slot]
    if col >= 0:
        return float(tr.q[0, col]), float(tr.qd[0, col])
    if what in ("spring", "damper"):
        i = system.elements.index(name)
        p1, p2 = (system.points[int(p)] for p in system.Y.ept[i, :2])
        dvec = tr.point(p1)[0] - tr.point(p2)[0]
        ln = float(np.linalg.norm(dvec))
        dv = tr.point_velocity(p1)[0] - tr.point_velocity(p2)[0]
        return ln, float(dvec @ dv / ln) if ln > 0 else 0.0
    return 0.0, 0.0


class _Run:
    """One integration: the compiled work arrays and the loop around them."""

    def __init__(self, system: System, method: str, drive: _Drive, opts: dict[str, float],
                 events: bool) -> None:
        self.system = system
        self.book = method == "book"
        self.method = method
        nq = system.nq
        self.data = make_data(system, nq)
        self.dyn = make_dyn_data(system, nq)
        self.drive = drive
        self.w = stp.make_work(nq, drive.cols.size, len(system.bodies), len(system.laws))
        w = self.w
        L = system.length_scale
        w.gscale[:] = [L if k == "length" else L * L for k in system.var_kinds]
        w.scols[:] = drive.cols
        w.role[drive.cols] = 2
        st, it = w.st, w.it
        st[stp.RTOL], st[stp.ATOL] = opts["rtol"], opts["atol"]
        st[stp.HMIN], st[stp.HMAX] = opts["min_step"], opts["max_step"]
        st[stp.PTOL], st[stp.CTOL], st[stp.MTOL] = opts["pivot_tol"], opts["tol"], opts["mass_tol"]
        st[stp.FABS], st[stp.FPCT] = opts["force_abs"], opts["force_pct"]
        st[stp.XMAX] = XMAX
        st[stp.SMALLEST], st[stp.LARGEST] = math.inf, 0.0
        st[stp.HNEXT] = opts["first_step"]
        st[stp.TFAIL] = math.nan  # the time of an output that failed (else the step's)
        it[stp.MAXIT] = MAXIT
        # Python callables (motions, laws) need the stage loop in Python; held
        # coordinates do not
        self.python = any(not isinstance(m, _Held) for m in drive.motions) or bool(system.laws)
        self.laws = _Laws(system, self.dyn) if system.laws else None
        self.events_on = events and self.laws is not None and bool(self.laws.switches)
        self.switches: list[tuple[int, float, tuple[str, ...], tuple[str, ...]]] = []
        self.g_start: np.ndarray | None = None
        self.mo: np.ndarray | None = None
        self.events: list[Event] = []
        self.k = (system.KP, self.data.DP, system.YP, self.dyn.ZP)

    # ---- the state at the start
    def start(self, S: Any, t0: float, q_given: dict[int, float], qd_given: dict[int, float],
              pivot_tol: float, tol: float) -> None:
        system, w = self.system, self.w
        KP, DP = self.k[0], self.k[1]
        self._motion_rows(np.array([t0]))
        w.ms[:] = w.ms[0]
        for s, c in enumerate(w.scols):
            S.q[c] = w.ms[0, s, 0]
        for c, v in q_given.items():
            S.q[c] = v
        S.sgc[:] = False
        S.sgc[w.scols] = True
        held = S.sgc.copy()
        held[list(q_given)] = True
        S.sgc[:] = held
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
        self._choose_start(S, qd_given, pivot_tol)
        w.st[stp.T] = t0
        nF = int(w.it[stp.NF])
        for j in range(nF):
            c = int(w.fcols[j])
            w.x0[j] = S.q[c]
            w.xs[j] = S.q[c]
            w.vs[j] = qd_given.get(c, 0.0)
            w.v0[j] = w.vs[j]
        w.q0[:] = S.q
        w.qd0[:] = 0.0
        w.qdd0[:] = 0.0
        code = self._evaluate_start(S)
        if code != stp.OK:
            why = _massless(system, S) if code == stp.SINGULAR_MASS else ""
            raise AnalysisError(f"t = {t0:g} s: {why or self._why(code)}")
        w.st[stp.QREF] = w.st[stp.QUALITY]

    def _choose_start(self, S: Any, qd_given: dict[int, float], pivot_tol: float) -> None:
        from openimp.kinematics.elimination import eliminate, jacobian
        from openimp.kinematics.position import position

        system, w = self.system, self.w
        DP = self.data.DP
        position(system.KP, DP, S, system.gen, 1)
        jacobian(system.KP, DP, S, system.gen)
        base = S.sgc.copy()
        if any(c in set(w.scols.tolist()) for c in qd_given):
            raise InputError("initial rates are given for a driven coordinate: its motion "
                             "sets its rate")
        rank0 = eliminate(DP, S.sgc, pivot_tol)[0]
        if qd_given:
            S.sgc[list(qd_given)] = True
            rank1 = eliminate(DP, S.sgc, pivot_tol)[0]
            if rank1 < rank0:
                S.sgc[:] = base
                names = ", ".join(system.var_names[c] for c in sorted(qd_given))
                raise InputError(f"the initial rates of {names} are not independent (the loops "
                                 "tie them together): give rates of independent coordinates, "
                                 "at most as many as the mobility")
        used = np.zeros(system.nq, bool)
        used[_pivot_columns(self.data, rank0 if not qd_given else rank1)] = True
        free = ~(base | used)
        S.sgc[:] = base
        cols = np.flatnonzero(free)
        w.fcols[:cols.size] = cols
        w.it[stp.NF] = cols.size
        w.role[cols] = 1

    def _evaluate_start(self, S: Any) -> int:
        """Evaluate the start state again (at the start, after a change of coordinates or
        a law's switch): the FGCs at w.x0, w.v0, the SGCs' motion at T, the loops closed,
        the equations (with the law values there), the start taken from it."""
        KP, DP, YP, ZP = self.k
        w, gen = self.w, self.system.gen
        t = float(w.st[stp.T])
        nF = int(w.it[stp.NF])
        w.xs[:nF] = w.x0[:nF]
        w.vs[:nF] = w.v0[:nF]
        self._motion_rows(np.array([t]))
        st = stp.close_stage(KP, DP, S, gen, w, 0.0, 0)
        if st != stp.OK:
            return st
        if self.laws is not None:
            st = stp.evaluate(KP, DP, YP, ZP, S, gen, w, 0)  # sets the joint rates
            if st != stp.OK:
                return st
            self.laws.set(S, t)
        st = stp.evaluate(KP, DP, YP, ZP, S, gen, w, 0)
        if st == stp.OK:
            stp.start_state(S, w)
        return st

    def _motion_rows(self, times: np.ndarray) -> None:
        if self.drive.cols.size:
            self.drive.at(times, self.w.ms[:times.size])

    def _why(self, code: int) -> str:
        return {
            stp.NO_CLOSURE: "the loops cannot be closed (Newton did not converge): a limit of "
                            "travel, a singular posture or a motion too fast for the step",
            stp.SINGULAR_MASS: "the mass matrix of the free coordinates is singular (IMP's ZERO "
                               "(INERTIA)): a massless part can move alone; give it mass or "
                               "inertia",
            stp.LOST_COORDINATES: "the free coordinates no longer describe the mechanism (a "
                                  "singular posture)",
            stp.TOO_LARGE: "the step stays too large even at the smallest step",
            stp.UNDERFLOW: "the error control asked for a step below 1e-14 of the time (the "
                           "motion is discontinuous there, or the tolerance is below roundoff)",
        }.get(code, f"the step failed (code {code})")

    # ---- one step driven from Python (motions or laws)
    def _python_attempt(self, S: Any) -> int:
        KP, DP, YP, ZP = self.k
        w, gen = self.w, self.system.gen
        h = float(w.st[stp.H])
        t = float(w.st[stp.T])
        if self.book:  # rows: 0 the start, 1 the middle, the last the end
            self._motion_rows(t + np.array([0.0, 0.5 * h] + [0.0] * (stp.NSTAGE - 3) + [h]))
            w.it[stp.WHY] = stp.OK
            if w.it[stp.HAVE_LIN] == 0:
                st = stp.book_linearize(KP, DP, YP, ZP, S, gen, w)
                if st != stp.OK:
                    w.it[stp.WHY] = st
                    return stp.FAILED
                if self.laws is not None and w.it[stp.LAW_OK]:
                    self._law_terms(t)
            st = stp.book_predict(w)
            if st == stp.OK:  # the middle, for the works
                stp.book_mid(w)
                S.t[0] = t + 0.5 * h
                st = stp.close_stage(KP, DP, S, gen, w, 0.5 * h, 1)
            if st == stp.OK:
                st = self._evaluate(S, t + 0.5 * h, 1)
            if st == stp.OK:
                stp.book_end(w)
                S.t[0] = t + h
                st = stp.close_stage(KP, DP, S, gen, w, h, stp.NSTAGE - 1)
            if st == stp.OK:
                st = self._evaluate(S, t + h, stp.NSTAGE - 1)
            if st != stp.OK:
                return self._reject(st, h)
            return stp.book_finish(S, w)
        self._motion_rows(t + stp.RK_C * h)
        w.it[stp.WHY] = stp.OK
        for i in range(1, stp.NSTAGE):
            dt = stp.rk_stage_state(w, i)
            S.t[0] = t + dt
            st = stp.close_stage(KP, DP, S, gen, w, dt, i)
            if st == stp.OK:
                st = self._evaluate(S, t + dt, i)
            if st != stp.OK:
                return self._reject(st, h)
            stp.keep_stage(S, w, i)
        return stp.rk_finish(S, w)

    def _law_terms(self, t: float) -> None:
        """The load laws' stiffness and damping added to the book's D and K at the step
        start (t): a law is then part of the step's linear model, not a force held
        over the step (whose step would be first order in contact with a stop)."""
        w = self.w
        nf = int(w.it[stp.NF]) + w.scols.size
        _, D, K, _, _, _, Gl, qpl, qdpl = w.lin
        cols = w.lcols[:nf]
        # the directions of the coordinates' motion and of their rates' (the side of a
        # law's kink the step goes to)
        acc = np.zeros(self.system.nq)
        acc[w.fcols[:w.it[stp.NF]]] = w.kv[0, :w.it[stp.NF]]
        acc[w.scols] = w.ms[0, :, 2]
        rate = w.psid[cols]
        go = np.where(rate != 0.0, rate, acc[cols])  # at rest, where it starts to move
        law_derivatives(self.system, w.q0, self.dyn.v.Gf[:, :nf], cols, qpl[:nf],
                        qdpl[:nf], Gl[:nf], w.psid, t, D[:nf, :nf], K[:nf, :nf], [],
                        (go, acc[cols]))

    def _reject(self, st: int, h: float) -> int:
        w = self.w
        w.it[stp.WHY] = st
        w.st[stp.HNEXT] = 0.5 * h
        w.it[stp.REJECTS] += 1
        return stp.REJECTED

    def _evaluate(self, S: Any, t: float, row: int) -> int:
        KP, DP, YP, ZP = self.k
        w, gen = self.w, self.system.gen
        if self.laws is not None:
            st = stp.evaluate(KP, DP, YP, ZP, S, gen, w, row)
            if st != stp.OK:
                return st
            self.laws.set(S, t)
        return stp.evaluate(KP, DP, YP, ZP, S, gen, w, row)

    def _python_run(self, S: Any, out: _Outputs, max_steps: int) -> int:
        """:func:`~openimp.dynamics.stepping.run_rk` / ``run_book`` with the stages driven
        from here (motions at the stage times, law values at every stage, events)."""
        KP, DP = self.k[0], self.k[1]
        w, tout, kout = self.w, out.tout, out.kout
        t_end = float(tout[-1])
        s0 = int(w.it[stp.STEPS])
        if self.events_on and self.g_start is None:
            assert self.laws is not None
            self.g_start = self.laws.signs(S, float(w.st[stp.T]))
        while kout[0] < tout.size:
            stp.begin_step(w, t_end)
            if self.book:
                stp.land(w, tout, kout)
            if not stp.fit(w, tout, kout, out.base, out.cap):
                return stp.FULL
            h = float(w.st[stp.H])
            last = w.st[stp.T] + h >= t_end
            snap = self._snapshot() if self.events_on else None
            code = self._python_attempt(S)
            if code == stp.FAILED:
                return stp.STOPPED
            if code == stp.REJECTED:
                if h <= w.st[stp.HMIN] * (1 + 1e-12) or h <= 1e-14 * max(1.0, abs(w.st[stp.T])):
                    if w.it[stp.WHY] == stp.OK:
                        w.it[stp.WHY] = stp.UNDERFLOW
                    return stp.STOPPED
                continue
            shortened = False
            if self.events_on:
                assert snap is not None
                shortened = self._locate(S, snap, h)
            if last and not shortened:
                w.st[stp.T] = t_end
            if self._outputs(S, out) != stp.OK:
                return stp.STOPPED
            if w.st[stp.QUAL0] < 0.5 * w.st[stp.QREF] and stp.choose(KP, DP, S,
                                                                      self.system.gen, w):
                return stp.SWITCHED
            if w.it[stp.STEPS] - s0 >= max_steps:
                return stp.CAPPED
        return stp.REACHED

    def _outputs(self, S: Any, out: _Outputs) -> int:
        """:func:`~openimp.dynamics.stepping.outputs` with the motions and laws here."""
        t1 = float(self.w.st[stp.T])
        laws = self.dyn.v.law.copy()  # the values of the step's end, for the next step
        try:
            return self._outputs_from(S, out, t1)
        finally:
            self.dyn.v.law[:] = laws

    def _outputs_from(self, S: Any, out: _Outputs, t1: float) -> int:
        w, tout, kout = self.w, out.tout, out.kout
        while kout[0] < tout.size:
            tk = float(tout[kout[0]])
            end = abs(tk - t1) <= 1e-12 * max(1.0, abs(t1))
            if tk > t1 and not end:
                break
            row = int(kout[0]) - out.base
            if end:
                stp.record(S, w, out.ob, row, tk, True)
            else:
                st = self._dense_output(S, tk, int(kout[0]))
                if st != stp.OK:
                    w.it[stp.WHY] = st
                    w.st[stp.TFAIL] = tk
                    return st
                stp.record(S, w, out.ob, row, tk, False)
                if stp.works_change(w) and self._dense_works(S, tk) == stp.OK:
                    stp.works_at(w, tk, out.ob, row)
            kout[0] += 1
        return stp.OK

    def _dense_output(self, S: Any, tk: float, k: int) -> int:
        """:func:`~openimp.dynamics.stepping.dense_output` with the motions and laws here
        (output k at tk inside the step just taken), short of recording the row."""
        w, gen = self.w, self.system.gen
        dt = stp.dense_point(w, tk)
        if self.mo is not None:
            w.ms[0] = self.mo[k]
        S.t[0] = tk
        st = stp.close_stage(self.k[0], self.k[1], S, gen, w, dt, 0)
        if st == stp.OK:
            st = self._evaluate(S, tk, 0)
        return st

    def _dense_works(self, S: Any, tk: float) -> int:
        """:func:`~openimp.dynamics.stepping.dense_works` with the motions and laws here
        (S evaluated at the output tk)."""
        w, gen = self.w, self.system.gen
        w.wq[:] = 0.0
        t_last = tk
        for i in range(stp.GL_X.size - 1, -1, -1):
            tn = stp.works_node(w, tk, i)
            self._motion_rows(np.array([tn]))
            S.t[0] = tn
            st = stp.close_near(self.k[0], self.k[1], S, gen, w, tn - t_last, 0)
            if st == stp.OK:
                st = self._evaluate(S, tn, 0)
            if st != stp.OK:
                return st
            stp.works_add(w, i)
            t_last = tn
        return stp.OK

    # ---- events: a law's switching function changed sign over the step
    def _snapshot(self) -> list[np.ndarray]:
        return [a.copy() for a in self._saved()]

    def _saved(self) -> tuple[np.ndarray, ...]:
        w = self.w
        return (w.st, w.it, w.role, w.fcols, w.q0, w.qd0, w.qdd0, w.x0, w.v0, w.w0, w.kx, w.kv,
                w.kw, w.ke_pe, w.xprev, w.vprev, w.aprev, w.wprev, w.pprev, self.dyn.v.law)

    def _restore(self, snap: list[np.ndarray]) -> None:
        for dst, src in zip(self._saved(), snap, strict=True):
            dst[...] = src

    def _take(self, S: Any, snap: list[np.ndarray], h: float) -> np.ndarray | None:
        """The step of length h from the snapshot, accepted whatever its error; the
        switching functions at its end (None when it could not be taken)."""
        self._restore(snap)
        w = self.w
        hmin = w.st[stp.HMIN]
        w.st[stp.HMIN] = h  # accepted whatever its error
        w.st[stp.H] = h
        code = self._python_attempt(S)
        w.st[stp.HMIN] = hmin
        if code != stp.ACCEPTED:
            return None
        assert self.laws is not None
        return self.laws.signs(S, float(w.st[stp.T]))

    def _locate(self, S: Any, snap: list[np.ndarray], h: float) -> bool:
        """Where a switching function changed sign over the step just taken (of length h
        from the snapshot), take the step again up to the first root (Illinois iterations
        on the step length, each a step from the snapshot) and record the event; the
        state is then just past the root.  Returns True when the step was shortened."""
        assert self.laws is not None and self.g_start is not None
        w = self.w
        g0 = self.g_start
        t0 = float(snap[0][stp.T])
        g1 = self.laws.signs(S, float(w.st[stp.T]))
        changed = np.flatnonzero(_crossed(g0, g1))
        if changed.size == 0:
            self.g_start = g1
            return False
        hnext = float(w.st[stp.HNEXT])
        # the earliest root of the changed functions: regula falsi on the step length with
        # the Illinois halving, candidates only from functions that change in the bracket
        lo, hi = 0.0, h
        glo, ghi = g0[changed].copy(), g1[changed].copy()
        tol = 1e-12 * max(1.0, abs(t0)) + 1e-13
        side = 0
        for _ in range(80):
            if hi - lo <= tol:
                break
            inside = _crossed(glo, ghi)
            with np.errstate(divide="ignore", invalid="ignore"):
                cand = lo + (hi - lo) * glo[inside] / (glo[inside] - ghi[inside])
            cand = cand[np.isfinite(cand)]
            hm = float(np.min(cand)) if cand.size else 0.5 * (lo + hi)
            if not lo < hm < hi:
                hm = 0.5 * (lo + hi)
            gm = self._take(S, snap, hm)
            if gm is None:
                hm = 0.5 * (lo + hi)
                gm = self._take(S, snap, hm)
                if gm is None:
                    break
            gm = gm[changed]
            if np.any(_crossed(glo, gm)):
                hi, ghi = hm, gm
                if side == 1:  # Illinois: the kept end's values halved
                    glo = 0.5 * glo
                side = 1
            else:
                lo, glo = hm, gm
                if side == -1:
                    ghi = 0.5 * ghi
                side = -1
        g_end = self._take(S, snap, hi)
        if g_end is None:  # keep the step as first taken
            g_end = self._take(S, snap, h)
            hi = h
            if g_end is None:
                raise AnalysisError(f"t = {t0:.9g} s: the step could not be taken again to "
                                    "locate a law's switching (a law that keeps a state?)")
        t_ev = t0 + hi
        for i in changed:
            if _crossed(g0[i:i + 1], g_end[i:i + 1])[0]:
                name = self.laws.switches[i][1]
                self.events.append(Event(t_ev, name, 1 if g0[i] <= 0 else -1))
        w.st[stp.HNEXT] = hnext
        # the law switched: the derivatives of the start are those after the switch
        code = self._evaluate_start(S)
        if code != stp.OK:
            raise AnalysisError(f"t = {t_ev:.9g} s: {self._why(code)}")
        self.g_start = self.laws.signs(S, float(w.st[stp.T]))
        return hi < h

    # ---- drive the whole run
    def advance(self, S: Any, out: _Outputs, max_steps: int) -> int:
        """Integrate on, recording outputs, until every output is done (REACHED), the
        buffer is full (FULL), max_steps were taken (CAPPED) or the run cannot go on
        (STOPPED); changes of coordinates are recorded on the way."""
        KP, DP, YP, ZP = self.k
        w = self.w
        while True:
            if self.python:
                code = self._python_run(S, out, max_steps)
            else:
                fn = stp.run_book if self.book else stp.run_rk
                code = fn(KP, DP, YP, ZP, S, self.system.gen, w, out.tout, out.kout, out.ob,
                          out.base, out.cap, max_steps)
            if code != stp.SWITCHED:
                return code
            new = self.fgc_names()
            self.switches.append((out.count, float(w.st[stp.T]), self._names_before, new))
            self._names_before = new
            if self.laws is not None:  # law values at the start, for the next first stage
                code = self._evaluate_start(S)
                if code != stp.OK:
                    w.it[stp.WHY] = code
                    return stp.STOPPED

    def fgc_names(self) -> tuple[str, ...]:
        w = self.w
        return tuple(self.system.var_names[int(c)] for c in w.fcols[:int(w.it[stp.NF])])


def _massless(system: System, S: Any) -> str:
    """What moves without kinetic energy at the assembled start S (the vibration
    analysis's diagnosis: the coordinates and the bodies), or "" when that finds M_FF
    regular.  The linearization compiles only on this failure."""
    try:
        check_mass(linearize(system, S, motion_terms=False))
    except (InputError, AnalysisError) as exc:
        return str(exc) if "singular" in str(exc) else ""
    return ""


def _crossed(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Where a switching function went from one side of zero to the other (> 0 is one
    side, <= 0 the other: reaching exactly zero from above counts)."""
    return (np.asarray(a) > 0) != (np.asarray(b) > 0)


def _pivot_columns(data: Any, rank: int) -> np.ndarray:
    return np.asarray(data.view("pcol")[:rank], np.int64)


@contextlib.contextmanager
def _interruptible() -> Iterator[list[bool]]:
    flag = [False]
    try:
        yield flag
    except KeyboardInterrupt:
        flag[0] = True


def simulate(
    system: System,
    t_final: float | None = None,
    *,
    print_step: float | None = None,
    times: Sequence[float] | np.ndarray | None = None,
    q0: Any = None,
    rates: Mapping[Any, float] | None = None,
    motion: Mapping[Any, Any] | None = None,
    method: str = "rk",
    rtol: float = 1e-8,
    atol: float | None = None,
    force_tol: tuple[float, float] = (0.1, 1.0),
    min_step: float = 0.0,
    max_step: float | None = None,
    first_step: float | None = None,
    tol: float = 1e-10,
    pivot_tol: float = 1e-10,
    mass_tol: float = 1e-5,
    events: bool = True,
    progress: Any = None,
    stream: Any = None,
    keep: bool = True,
    max_steps: int = 10_000_000,
) -> Trajectory:
    """The time response of ``system`` (book ch 14): released from its initial
    conditions, its specified coordinates driven by ``motion``, integrated to the
    output times with the loops closed at every stage.

    Output times: ``t_final`` with ``print_step`` (0, print_step, ..., t_final), or
    ``times`` (increasing; the first is the start).  Initial conditions: ``q0``
    maps joint variables (``"joint"`` or ``"joint.var"``) to positions (model
    units, radians for angles; the others from the modeling posture, the loops
    closed with the given ones held) or gives all nq variables; ``rates`` maps
    coordinates to initial rates: they become free coordinates, the other free
    coordinates start at rest (IMP's DATA IC).  ``motion`` maps the specified
    coordinates (SGCs) to motions of time (:mod:`openimp.motion`, a callable
    ``t -> (position, velocity, acceleration)``, or a number: held).

    ``method``: ``"rk"`` (Dormand-Prince 5(4), ``rtol``/``atol`` per step on the
    free coordinates' positions and rates, internal units, atol = rtol by
    default) or ``"book"`` (the book's linearized exponential step with the force
    error ``force_tol`` = (force in model units, percent), IMP's ZERO (FORCE)).
    Steps are never longer than ``max_step`` (default: the whole run for ``rk``,
    whose outputs are interpolated inside its steps and closed there; the output
    spacing for ``book``, the book's rule) nor shorter than ``min_step`` (IMP's
    DATA TIME minimum). ``tol``: loop closure;
    ``mass_tol``: the singularity test of the mass matrix (IMP's ZERO (INERTIA)).
    Load laws with a ``switch`` function are switched at the located instant
    (``events``).  ``progress``: a bar on a terminal (None: when stderr is one),
    False, or a callable(t, t_final).  ``stream``: a .csv path receiving every
    output as it is computed; with ``keep=False`` only the first and the last
    outputs stay in memory.

    Returns a :class:`~openimp.results.Trajectory` at the output times with rates,
    ``energy`` (:class:`~openimp.results.EnergyAudit`), ``closure``, ``quality``,
    ``coordinate_switches``, ``events`` and ``integration``.  When the run cannot go
    on, ``message`` says when and why and every output before is kept.
    """
    if not isinstance(system, System):
        raise InputError(f"simulate takes a compiled System, got {type(system).__name__}")
    if method not in METHODS:
        raise InputError(f"method must be one of {', '.join(METHODS)}, got {method!r}")
    tout = output_times(t_final, print_step, times)
    rt = _positive("rtol", rtol)
    at = rt if atol is None else _positive("atol", atol)
    try:
        fa, fp = (float(x) for x in force_tol)
    except (TypeError, ValueError):
        raise InputError(f"force_tol must be (force, percent), got {force_tol!r}") from None
    if not (fa > 0 and fp > 0 and math.isfinite(fa) and math.isfinite(fp)):
        raise InputError(f"force_tol: both the force and the percent must be > 0, got "
                         f"{force_tol!r} (IMP's ZERO (FORCE))")
    hmin = _positive("min_step", min_step, allow_zero=True)
    spacing = float(np.min(np.diff(tout)))
    span = float(tout[-1] - tout[0])
    # the book's step is at most the output interval (section 14.5); Dormand-Prince steps
    # over outputs (they are interpolated and closed there)
    hmax = (spacing if method == "book" else span) if max_step is None else \
        _positive("max_step", max_step)
    if hmin <= hmax * (1 + 1e-9):  # an output spacing a rounding under min_step
        hmin = min(hmin, hmax)
    if hmin > hmax:
        raise InputError(f"min_step {hmin:g} s exceeds the largest step {hmax:g} s (the output "
                         "spacing or max_step)")
    h1 = (min(hmax, 1e-3 * span) if method == "rk" else hmax) \
        if first_step is None else _positive("first_step", first_step)
    for name, v in (("tol", tol), ("pivot_tol", pivot_tol), ("mass_tol", mass_tol)):
        _positive(name, v)
    if isinstance(max_steps, np.integer):
        max_steps = int(max_steps)
    if not isinstance(max_steps, int) or isinstance(max_steps, bool) or max_steps < 1:
        raise InputError(f"max_steps must be a positive integer, got {max_steps!r}")
    if stream is None and not keep:
        raise InputError("keep=False needs stream= (the outputs must go somewhere)")
    scols, motions = _motions(system, motion)
    drive = _Drive(system, scols, motions)
    q_given = _mapping(system, q0, "q0") if not _is_array(q0) else {}
    qd_given = _mapping(system, rates, "rates")
    for c in q_given:
        if c in set(scols.tolist()):
            raise InputError(f"q0: {system.var_names[c]} is driven by its motion; its position "
                             "comes from there")
    S = make_state(system, _start_q(system, q0), float(tout[0]))
    opts = {"rtol": rt, "atol": at, "min_step": hmin, "max_step": hmax, "pivot_tol": pivot_tol,
            "tol": tol, "mass_tol": mass_tol, "force_abs": fa, "force_pct": fp,
            "first_step": max(h1, hmin)}
    r = _Run(system, method, drive, opts, bool(events))
    if r.python and drive.cols.size:  # the motions at the output times, for the outputs
        r.mo = np.zeros((tout.size, drive.cols.size, 3))
        drive.at(tout, r.mo)
    r.start(S, float(tout[0]), q_given, qd_given, float(pivot_tol), float(tol))
    r._names_before = r.fgc_names()
    bar = _Progress(progress, float(tout[0]), float(tout[-1]))
    out = _Outputs(system, tout, bool(keep), stream)
    message = ""
    wall = _time.perf_counter()
    try:
        with _interruptible() as stopped:
            stp.record(S, r.w, out.ob, 0, float(tout[0]), True)
            out.kout[0] = 1
            steps0 = 0
            while True:
                code = r.advance(S, out, min(CHUNK_STEPS, max_steps - steps0))
                out.flush()
                bar(float(r.w.st[stp.T]))
                if code == stp.REACHED:
                    break
                steps0 = int(r.w.it[stp.STEPS])
                tnow = float(r.w.st[stp.T])
                if code in (stp.CAPPED, stp.FULL) and steps0 < max_steps:
                    continue
                if code == stp.CAPPED:
                    message = (f"t = {tnow:.6g} s: {max_steps} steps taken (max_steps); raise "
                               "max_steps or loosen the tolerance")
                else:
                    tfail = float(r.w.st[stp.TFAIL])
                    tnow = tfail if math.isfinite(tfail) else tnow
                    message = f"t = {tnow:.6g} s: {r._why(int(r.w.it[stp.WHY]))}"
                break
        if stopped[0]:
            message = (f"t = {float(r.w.st[stp.T]):.6g} s: interrupted by the user (Ctrl-C); "
                       "the outputs before it are kept")
    except (AnalysisError, InputError) as exc:  # a user's motion or law failing mid-run
        message = f"t = {float(r.w.st[stp.T]):.6g} s: {exc}"
    finally:
        bar.done()
        out.flush()
        if out.stream is not None:
            out.stream.close()
    return _response(system, r, out, drive, scols, message, _time.perf_counter() - wall)


def _response(system: System, r: _Run, out: _Outputs, drive: _Drive, scols: np.ndarray,
              message: str, seconds: float) -> Trajectory:
    """The trajectory of the recorded outputs (model units out of the internal rows)."""
    t, q, qd, qdd, fgc, quality, closure, en = out.rows()
    n = t.size
    # the mobility at each output is the number of generalized coordinates (6.52)
    rank = system.nq - fgc.sum(axis=1).astype(np.int64) - scols.size
    res = Trajectory(system, q, quality, rank, fgc, np.zeros(n, np.int64),
                     list(drive.names), message, tracker=tracker(system), sgc=_sgc(system, scols))
    res.set_rates(qd, qdd, np.zeros(n))
    res.time = t
    res.closure = closure
    res.quality_ref = float(quality[0]) if n else 0.0
    e = en * system.length_scale ** 2
    res.energy = EnergyAudit(e[:, 0].copy(), e[:, 1].copy(), e[:, 2].copy(), e[:, 3].copy(),
                             e[:, 4].copy())
    # without keep only the first and last outputs remain: a switch is then at the last
    res.coordinate_switches = [CoordinateSwitch(k if out.keep else min(k, n - 1), ts, old, new)
                               for k, ts, old, new in r.switches]
    res.events = list(r.events)
    res.interrupted = "interrupted by the user" in message
    w = r.w
    res.integration = IntegrationStats(
        r.method, int(w.it[stp.STEPS]), int(w.it[stp.REJECTS]), int(w.it[stp.EVALS]),
        int(w.it[stp.CLOSES]), float(w.st[stp.SMALLEST]) if w.it[stp.STEPS] else 0.0,
        float(w.st[stp.LARGEST]), int(w.it[stp.FORCED]), len(r.events), seconds)
    return res


def _is_array(q0: Any) -> bool:
    return q0 is not None and not isinstance(q0, Mapping)


def _start_q(system: System, q0: Any) -> np.ndarray:
    if _is_array(q0):
        try:
            q = np.asarray(q0, dtype=float).reshape(-1)
        except (TypeError, ValueError):
            raise InputError(f"q0 must map joint variables to numbers or give all "
                             f"{system.nq} of them") from None
        if q.shape != (system.nq,) or not np.all(np.isfinite(q)):
            raise InputError(f"q0 must hold {system.nq} finite numbers, one per joint variable "
                             f"({', '.join(system.var_names)})")
        return system.to_internal(q).copy()
    return system.q0.copy()


def _sgc(system: System, scols: np.ndarray) -> np.ndarray:
    m = np.zeros(system.nq, bool)
    m[scols] = True
    return m
