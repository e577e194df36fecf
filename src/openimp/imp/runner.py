"""Running the EXECUTEs of a deck: drivers, posture sweeps, requests, output.

For every EXECUTE (:class:`~openimp.imp.interp.RunSpec`) :func:`validate`
builds and compiles the model and checks its inputs; :func:`execute_run`
then

1. prints the run banner (reference §2.2) and IMP's messages;
2. builds the time grid: ``DATA TIME = final, minstep, printstep`` gives the
   output times ``0, printstep, ... final``; without it IMP's assumption
   ``final = number of SGC steps, printstep 1`` is reported and used;
3. builds the SGC values at every output time: a ``DATA POSITION`` joint moves
   one increment per output step (``start + increment * min(k, nsteps)``) at
   the constant DATA VELOCITY / ACCEL; a ``DATA MOTION`` entry is a constant
   (degrees or lengths, zero rates) or a VALUE evaluated with its two time
   derivatives (radians); a VALUE that reads the model (``POSITION(...)`` ...)
   is evaluated step by step from the last solved posture, as IMP did;
4. solves the postures, velocities and accelerations in chunks
   (:meth:`openimp.system.System.sweep`, free coordinates held as IMP's
   kinematic mode does);
5. produces every PRINT / LIST / STORE / PLOT table, the PRINT text per
   position (§2.4), the listings (§2.3), plots and animations.

A posture that cannot be reached stops the run; everything computed before
is kept and listed, and the failure names the step, the time and the last
good posture.
"""

from __future__ import annotations

import math
import os
import time as _time
import warnings
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from openimp import io
from openimp.errors import InputError, OutputError
from openimp.files import OutputFolder, printable
from openimp.imp.expr import Expression, SimulationStop
from openimp.imp.interp import (
    DEFAULT_TITLE,
    Built,
    InputDef,
    Request,
    RunSpec,
    State,
    Where,
    build_model,
    compile_built,
)
from openimp.imp.jointmap import ImpJoint, imp_variables, to_degrees
from openimp.kinematics import check_drivers, free_coordinate, sweep
from openimp.limits import MAX_NUMBER, MAX_RATE, MAX_RESULT_BYTES, MAX_STEPS, number_text
from openimp.system import make_state

__all__ = ["Prepared", "Solution", "execute_run", "not_produced", "run_deck",
           "trailing_requests", "validate"]

#: steps solved per call of the sweep (progress is reported between chunks)
CHUNK = 2000
_NAN = math.nan


# =============================================================================
# Validation
# =============================================================================
@dataclass
class Driver:
    """One SGC: an IMP joint variable and the openimp column it drives."""

    joint: str
    var: int  # IMP variable index (0-based)
    column: int  # openimp column in q
    sign: float
    kind: str  # angle or length
    inp: InputDef


@dataclass
class Item:
    """One item of one request: what to tabulate."""

    request: Request
    kind: str  # joint, point, link, spring, damper, value, heading
    name: str


@dataclass
class Prepared:
    """A validated run: built model, compiled system, drivers, request items."""

    spec: RunSpec
    built: Built
    system: Any
    drivers: list[Driver]
    items: list[Item]
    unsupported: list[Request]


def _request_items(state: State, built: Built) -> tuple[list[Item], list[Request]]:
    items: list[Item] = []
    unsupported: list[Request] = []
    seen: set[tuple[str, str, str, str]] = set()
    springs = state.extras.get("springs", {})
    dampers = state.extras.get("dampers", {})
    model = built.model
    for req in state.requests:
        q = req.quantity
        if q in ("FORCE", "FREQUENCY", "DYNAMICS"):
            unsupported.append(req)
            continue
        if q == "HEADING":
            key = (req.family, q, "heading", "")
            if key not in seen:
                seen.add(key)
                items.append(Item(req, "heading", ""))
            continue
        if q == "VALUE":
            names = list(state.values) if req.all else []
            names += req.names
            for n in names:
                if n not in state.values:
                    raise InputError(f"{req.keyword} statement: VALUE {n} is not defined by "
                                     "EXECUTE", req.where)
                key = (req.family, q, "value", n)
                if key not in seen:
                    seen.add(key)
                    items.append(Item(req, "value", n))
            continue
        names = []
        if req.all:
            names += list(model.joints) + list(model.points) + list(springs) + list(dampers)
        names += req.names
        for n in names:
            if n in model.joints:
                kind = "joint"
            elif n in model.points:
                kind = "point"
            elif n in springs:
                kind = "spring"
            elif n in dampers:
                kind = "damper"
            elif n in model.body_frames:
                kind = "link"
                if req.family == "PLOT":
                    raise InputError(f"{req.keyword} statement: links cannot be plotted "
                                     f"({n}); plot its points or joints", req.where)
            elif n in state.points:
                raise InputError(f"{req.keyword} statement: point {n} is on a link that is in "
                                 "no joint, so it was deleted at EXECUTE", req.where)
            else:
                raise InputError(f"{req.keyword} statement: {n} is not a joint, point, link, "
                                 "spring or damper defined by EXECUTE", req.where)
            if kind in ("spring", "damper"):
                pts = (springs if kind == "spring" else dampers)[n]["points"]
                for p in pts:
                    if p not in model.points:
                        raise InputError(f"{req.keyword} statement: {kind} {n} ends at point "
                                         f"{p}, which was deleted at EXECUTE", req.where)
            key = (req.family, q, kind, n)
            if key not in seen:
                seen.add(key)
                items.append(Item(req, kind, n))
    return items, unsupported


def _drivers(state: State, built: Built, system: Any) -> list[Driver]:
    out: list[Driver] = []
    for name, inp in state.inputs.items():
        if name not in built.joints:
            continue
        ij = built.joints[name][0]
        sl = system.joint_vars(name)
        if inp.kind == "POSITION":
            vars_ = [0]
        else:
            vars_ = [k for k, m in enumerate(inp.motions) if m is not None]
            for k in vars_:
                m = inp.motions[k]
                if isinstance(m, str) and m not in state.values:
                    raise InputError(f"DATA MOTION statement: VALUE {m} is not defined by "
                                     "EXECUTE", inp.where)
        for k in vars_:
            d = ij.drive[k]
            if d is None:  # pragma: no cover - refused when the statement was read
                raise InputError(f"joint {name}: variable {k + 1} cannot be driven", inp.where)
            out.append(Driver(name, k, sl.start + d[0], d[1], ij.var_kinds[k], inp))
    return out


def validate(spec: RunSpec) -> Prepared:
    """Build, compile and check one EXECUTE's model (cached on the spec)."""
    cached = getattr(spec, "_prepared", None)
    if cached is not None:
        return cached  # type: ignore[no-any-return]
    state = spec.state
    for ex in state.values.values():
        ex.load_tables()  # a TABLE file that cannot be read is an input error
    built = build_model(state, spec.where)
    system = compile_built(built, state, spec.where)
    items, unsupported = _request_items(state, built)
    drivers = _drivers(state, built, system) if spec.mode == "kinematic" else []
    if drivers:
        cols = np.array([d.column for d in drivers], np.int64)
        if len(set(cols.tolist())) != len(cols):  # pragma: no cover - one input per joint
            raise InputError("EXECUTE: a joint variable is driven twice", spec.where)
        start = make_state(system)
        start.sgc[cols] = True
        try:
            check_drivers(system, start, cols, state.tolerance("SYSTEM")[0], True)
        except InputError as exc:
            where = drivers[-1].inp.where
            raise InputError(f"EXECUTE: {exc} (the input motions are given by DATA POSITION / "
                             "DATA MOTION statements)", where) from None
    prep = Prepared(spec, built, system, drivers, items, unsupported)
    if spec.mode == "kinematic":
        _check_size(prep)
    spec._prepared = prep  # type: ignore[attr-defined]
    return prep


def not_produced(spec: RunSpec) -> tuple[str | None, list[str]]:
    """What one EXECUTE will not produce, found before anything is solved.

    Returns the reason why the whole run produces nothing (an EXECUTE in a mode
    openimp has not built), or None, and one located message per request that
    the run cannot answer (FORCE, FREQUENCY, DYNAMICS).  The run reports
    exactly these (``Run.failure``, ``Run.unsupported``) and ``openimp check``
    lists them, so the two never disagree.  Raises :class:`InputError` as
    :func:`validate` does.
    """
    state = spec.state
    if spec.mode != "kinematic":
        fw = state.find_where
        what = "static equilibrium" if spec.mode == "static" else "dynamic (time response)"
        return (f"{spec.where[0]}:{spec.where[1]}: EXECUTE in {spec.mode} mode "
                f"(FIND {state.find}" + (f" at {fw[0]}:{fw[1]}" if fw else "")
                + f"): {what} analysis is not built yet in openimp; this run "
                "produces no results"), []
    texts = []
    for req in validate(spec).unsupported:
        texts.append(f"{req.where[0]}:{req.where[1]}: {req.keyword} is not produced: "
                     + ("force analysis" if req.quantity == "FORCE" else
                        "linearized vibration analysis" if req.quantity == "FREQUENCY" else
                        "transfer-function analysis")
                     + " is not built yet in openimp (the other requests are)")
    return None, texts


def trailing_requests(deck: Any) -> list[str]:
    """Requests that no EXECUTE runs: those given after the last EXECUTE (or in a
    deck without one), one located message each."""
    final = deck.interp.state.requests
    specs = deck.specs
    ran = {id(r.statement) for r in specs[-1].state.requests} if specs else set()
    out = []
    for req in final:
        if id(req.statement) in ran:
            continue
        if specs:
            w = specs[-1].where
            out.append(f"{req.where[0]}:{req.where[1]}: {req.keyword} comes after the last "
                       f"EXECUTE ({w[0]}:{w[1]}), so no run produces it; move it before an "
                       "EXECUTE or add an EXECUTE after it")
        else:
            out.append(f"{req.where[0]}:{req.where[1]}: {req.keyword} is not produced: the "
                       "deck has no EXECUTE statement; add EXECUTE after the requests")
    return out


def _check_size(prep: Prepared) -> None:
    """Refuse a run whose results would exceed ``MAX_RESULT_BYTES``."""
    state = prep.spec.state
    n = len(time_grid(state, 0.0)[0])
    need = result_bytes(prep, n)
    if need > MAX_RESULT_BYTES:
        bodies, points = _needs(prep, n)
        raise InputError(f"EXECUTE: the run would hold {need / 2**20:.0f} MB of results ({n} "
                         f"steps of {len(bodies)} links and {len(points)} points), more than "
                         f"{MAX_RESULT_BYTES / 2**20:.0f} MB (limit MAX_RESULT_BYTES); use "
                         "fewer steps (DATA TIME, DATA POSITION) or request fewer items",
                         prep.spec.where)


# =============================================================================
# Solution
# =============================================================================
@dataclass
class Solution:
    """Postures, rates and derived quantities of a run, step by step (model units)."""

    times: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    quality: np.ndarray
    iterations: np.ndarray
    mobility: np.ndarray
    fgc: list[list[str]]
    bodies: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]
    points: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]
    message: str = ""
    #: the user interrupted the solution (Ctrl-C); ``message`` says where
    interrupted: bool = False
    #: a DATA MOTION VALUE evaluated RETURN or END: what IMP says about it
    stop: str = ""
    #: END was evaluated: no further EXECUTE runs
    end: bool = False

    @property
    def n(self) -> int:
        """Number of solved steps."""
        return int(self.q.shape[0])


class _Accumulator:
    def __init__(self, bodies: list[str], points: list[str]) -> None:
        self.bodies = bodies
        self.points = points
        self.parts: dict[str, list[np.ndarray]] = {}
        self.fgc: list[list[str]] = []

    def add(self, key: str, a: np.ndarray) -> None:
        self.parts.setdefault(key, []).append(a)

    def take(self, res: Any) -> None:
        if res.nsteps == 0:
            return
        self.add("q", res.q)
        self.add("qd", res.qd)
        self.add("qdd", res.qdd)
        self.add("quality", res.quality)
        self.add("iterations", res.iterations)
        self.add("mobility", res.mobility)
        self.fgc.extend(res.fgc)
        for b in self.bodies:
            self.add(f"T:{b}", res.posture(b))
            self.add(f"W:{b}", res.velocity_operator(b))
            self.add(f"A:{b}", res.acceleration_operator(b))
        for p in self.points:
            self.add(f"p:{p}", res.point(p))
            self.add(f"v:{p}", res.point_velocity(p))
            self.add(f"a:{p}", res.point_acceleration(p))

    def count(self) -> int:
        """Steps held by every part (a chunk cut short by Ctrl-C is not counted)."""
        sizes = [sum(len(a) for a in parts) for parts in self.parts.values()]
        return min([*sizes, len(self.fgc)]) if sizes else 0

    def get(self, key: str, shape: tuple[int, ...], n: int) -> np.ndarray:
        parts = self.parts.get(key)
        if not parts:
            return np.zeros((0, *shape))
        return np.concatenate(parts, axis=0)[:n]

    def solution(self, times: np.ndarray, nq: int, message: str) -> Solution:
        n = self.count()
        get = self.get
        return Solution(
            times=times[:n], q=get("q", (nq,), n), qd=get("qd", (nq,), n),
            qdd=get("qdd", (nq,), n), quality=get("quality", (), n),
            iterations=get("iterations", (), n), mobility=get("mobility", (), n),
            fgc=self.fgc[:n],
            bodies={b: (get(f"T:{b}", (4, 4), n), get(f"W:{b}", (4, 4), n),
                        get(f"A:{b}", (4, 4), n)) for b in self.bodies},
            points={p: (get(f"p:{p}", (3,), n), get(f"v:{p}", (3,), n),
                        get(f"a:{p}", (3,), n)) for p in self.points},
            message=message,
        )


# =============================================================================
# Time grid and input motions
# =============================================================================
def stepped(state: State) -> bool:
    """True when no DATA TIME gives real times: IMP's assumed time is the step
    number (counted on after EXECUTE HOLD, back to 0 at RESET), so tables are
    labelled ``Step``; the rates stay per second."""
    return state.time is None


def plot_driver(prep: Prepared) -> Driver | None:
    """The input that PLOT draws against in a stepped run: the first DATA
    POSITION input that moves (None: the step is the abscissa)."""
    if not stepped(prep.spec.state):
        return None
    for d in prep.drivers:
        if d.inp.kind == "POSITION" and d.inp.increment != 0 and d.inp.nsteps > 0:
            return d
    return None


def time_grid(state: State, t0: float) -> tuple[np.ndarray, str | None]:
    """Output times of a run, and IMP's message when DATA TIME is assumed."""
    if state.time is not None:
        final, _, pstep = state.time
        ratio = final / pstep
        if not ratio <= MAX_STEPS:  # refused at DATA TIME; NaN too
            raise InputError(f"DATA TIME: {number_text(ratio)} output steps are more than "
                             f"{MAX_STEPS} (limit MAX_STEPS)", state.time_where)
        n = math.floor(ratio + 1e-9) + 1
        return t0 + pstep * np.arange(n), None
    final = max([i.nsteps for i in state.inputs.values() if i.kind == "POSITION"] or [0])
    if final > MAX_STEPS:  # refused at DATA POSITION
        raise InputError(f"DATA POSITION: {final} steps are more than {MAX_STEPS} (limit "
                         "MAX_STEPS)")
    msg = f"'DATA TIME = {float(final):.5f}, 0.00000, 1.00000' is assumed."
    return t0 + np.arange(final + 1, dtype=float), msg


def _value_reads_model(name: str, values: dict[str, Expression], seen: set[str]) -> bool:
    if name in seen or name not in values:
        return False
    seen.add(name)
    ex = values[name]
    if any(kind in ("POSITION", "VELOCITY", "ACCEL", "FORCE") for kind, _ in ex.references()):
        return True
    return any(_value_reads_model(v, values, seen) for v in ex.value_names())


def reads_model(state: State, drivers: list[Driver]) -> bool:
    """True when a DATA MOTION VALUE reads model quantities (step-by-step driving)."""
    for d in drivers:
        if d.inp.kind == "MOTION":
            m = d.inp.motions[d.var]
            if isinstance(m, str) and _value_reads_model(m, state.values, set()):
                return True
    return False


def _const(kind: str, v: float) -> float:
    return math.radians(v) if kind == "angle" else float(v)


@dataclass
class Halt:
    """Why the input motions end before the last output step: a VALUE evaluated
    RETURN or END (a stop the language asks for) or gave a value beyond the
    limits (a failure)."""

    step: int
    text: str
    kind: str  # "RETURN", "END" or "LIMIT"


class Motions:
    """Values, rates and accelerations of the SGCs (openimp units, signed).

    :attr:`halt` is set when a DATA MOTION VALUE stops the run at some step
    (RETURN or END evaluated, or a value beyond ``MAX_NUMBER`` / a rate beyond
    ``MAX_RATE``); the steps from there on are not filled.
    """

    def __init__(self, prep: Prepared, times: np.ndarray, notes: list[str]) -> None:
        self.prep = prep
        self.times = times
        self.notes = notes
        self.state = prep.spec.state
        n, nd = len(times), len(prep.drivers)
        self.p = np.zeros((n, nd))
        self.v = np.zeros((n, nd))
        self.a = np.zeros((n, nd))
        self.undefined: set[str] = set()
        self.halt: Halt | None = None

    def fill(self, k0: int, k1: int, resolver: Callable[[int], Any] | None) -> None:
        """Fill steps k0..k1-1 (``resolver(k)`` gives the resolve function at step k)."""
        for j, d in enumerate(self.prep.drivers):
            inp = d.inp
            if inp.kind == "POSITION":
                k = np.arange(k0, k1)
                val = inp.start + inp.increment * np.minimum(k, inp.nsteps)
                self.p[k0:k1, j] = np.radians(val) if d.kind == "angle" else val
                self.v[k0:k1, j] = inp.velocity
                self.a[k0:k1, j] = inp.accel
                continue
            m = inp.motions[d.var]
            if not isinstance(m, str):
                self.p[k0:k1, j] = _const(d.kind, float(m))
                continue
            for k in range(k0, k1):
                if self.halt is not None and k >= self.halt.step:
                    break
                vals = self._jet(d, m, k, resolver)
                if vals is not None:
                    self.p[k, j], self.v[k, j], self.a[k, j] = vals
        s = np.array([d.sign for d in self.prep.drivers])
        if len(s):
            self.p[k0:k1] *= s
            self.v[k0:k1] *= s
            self.a[k0:k1] *= s

    def _jet(self, d: Driver, m: str, k: int, resolver: Callable[[int], Any] | None
             ) -> list[float] | None:
        """Value, rate and acceleration of VALUE ``m`` at step ``k`` (None: halted)."""
        resolve = resolver(k) if resolver is not None else _time_only(self.times[k])
        try:
            jet = self.state.values[m].derivatives(self.state.values, resolve)
        except SimulationStop as stop:
            self._halt(k, stop.kind, f"{stop.where[0]}:{stop.where[1]}: VALUE {m} (DATA MOTION "
                       f"of joint {d.joint}) evaluated {stop.kind} at time "
                       f"{self.times[k]:.6f}")
            return None
        vals = []
        for i, x in enumerate(jet):
            if not math.isfinite(x):
                if m not in self.undefined:
                    self.undefined.add(m)
                    self.notes.append(
                        f"{d.inp.where[0]}:{d.inp.where[1]}: VALUE {m} (DATA MOTION of joint "
                        f"{d.joint}) is undefined at time {self.times[k]:.6f}; IMP uses 0 "
                        "for it")
                x = 0.0
            top, name = (MAX_NUMBER, "MAX_NUMBER") if i == 0 else (MAX_RATE, "MAX_RATE")
            if abs(x) > top:
                what = ("value", "rate", "acceleration")[i]
                self._halt(k, "LIMIT", f"{d.inp.where[0]}:{d.inp.where[1]}: DATA MOTION of "
                           f"joint {d.joint}: the {what} of VALUE {m} at time "
                           f"{self.times[k]:.6f} is {number_text(x)}, beyond "
                           f"±{number_text(top)} (limit {name})")
                return None
            vals.append(x)
        return vals

    def _halt(self, k: int, kind: str, text: str) -> None:
        """Record the first step at which the motions stop."""
        if self.halt is None or k < self.halt.step:
            self.halt = Halt(k, text, kind)


def _time_only(t: float) -> Callable[[str, str | None, int], float]:
    def resolve(kind: str, name: str | None, comp: int) -> float:
        return t if kind == "TIME" else _NAN

    return resolve


# =============================================================================
# Solving
# =============================================================================
#: every point of the model is kept (for VALUEs and graphics) while points x steps stay below
ALL_POINTS_BUDGET = 2_000_000
#: bytes of results per step: q, rates (3 nq), per body T, W, A (48), per point p, v, a (9)
_FLOATS_PER_BODY, _FLOATS_PER_POINT = 48, 9


def _needs(prep: Prepared, nsteps: int = 1) -> tuple[list[str], list[str]]:
    """Bodies and points whose motion the requests, VALUEs and graphics need (every
    point of the model while points x steps stay within ``ALL_POINTS_BUDGET``)."""
    st = prep.spec.state
    model = prep.built.model
    bodies: set[str] = set()
    every = len(model.points) <= 200 and len(model.points) * nsteps <= ALL_POINTS_BUDGET
    points: set[str] = set(model.points) if every else set()
    for it in prep.items:
        if it.kind == "link":
            bodies.add(it.name)
        elif it.kind == "joint":
            bodies.add(model.joints[it.name].body1)
        elif it.kind == "point":
            points.add(it.name)
        elif it.kind in ("spring", "damper"):
            points.update(st.extras[it.kind + "s"][it.name]["points"])
    g = st.graphics
    for j in list(g.axes) + (list(model.joints) if g.axes_all else []):
        if j in model.joints:
            bodies.add(model.joints[j].body1)
    for _, pts in st.polylines:
        points.update(p for p in pts if p in model.points)
    for ex in st.values.values():  # VALUEs may read the motion of any point
        for _kind, name in ex.references():
            if name in model.points:
                points.add(name)
    return sorted(bodies), sorted(points)


def result_bytes(prep: Prepared, nsteps: int) -> int:
    """Bytes of results a run of ``nsteps`` output steps holds."""
    bodies, points = _needs(prep, nsteps)
    per_step = (3 * prep.system.nq + 4 + _FLOATS_PER_BODY * len(bodies)
                + _FLOATS_PER_POINT * len(points))
    per_table = sum(8 for _ in prep.items)  # a few columns per request item
    return 8 * nsteps * (per_step + per_table)


def solve(prep: Prepared, times: np.ndarray, start: np.ndarray | None,
          notes: list[str], progress: Callable[[int, int], None] | None = None) -> Solution:
    """Solve every step of a run (see the module docstring).

    Ctrl-C (KeyboardInterrupt) while solving ends the run with what was solved
    (:attr:`Solution.interrupted`); a DATA MOTION VALUE that evaluates RETURN or
    END ends it at that step (:attr:`Solution.stop`).
    """
    system = prep.system
    st = prep.spec.state
    drivers = prep.drivers
    bodies, points = _needs(prep, len(times))
    acc = _Accumulator(bodies, points)
    motions = Motions(prep, times, notes)
    n = len(times)
    tol, maxit = st.tolerance("POSITION")
    tol = tol if "POSITION" in st.zero else 1e-10
    maxit = int(maxit or 25) if "POSITION" in st.zero else 25
    ptol = st.tolerance("SYSTEM")[0] if "SYSTEM" in st.zero else 1e-10
    lagged = reads_model(st, drivers)
    cur = None if start is None else np.array(start, float)
    if not drivers:
        notes.append("No input motion is given (DATA POSITION or DATA MOTION): every free "
                      "coordinate is held at its value.")
        col = _free_column(system, cur)
        if col is None:
            return _structure(prep, times, cur, acc, notes)
        drv_cols = [col]
        q0 = system.modeling_q if cur is None else cur
        fixed = np.full((n, 1), q0[col])
        motions.p, motions.v, motions.a = fixed, np.zeros((n, 1)), np.zeros((n, 1))
    else:
        drv_cols = [d.column for d in drivers]
        if not lagged:
            motions.fill(0, n, None)
    names = [system.var_names[c] for c in drv_cols]
    opts = {"tol": tol, "pivot_tol": ptol, "maxit": maxit, "hold_free": True}
    message = ""
    interrupted = False
    last: Solution | None = None
    k = 0
    try:
        if lagged:  # the values at the start posture: a sweep that holds every driver
            last = _start_values(prep, system, cur, drv_cols, names, bodies, points, times,
                                 opts)
        while k < n:
            m = 1 if lagged else min(CHUNK, n - k)
            if lagged:
                ref = last if last is not None and last.n else None
                motions.fill(k, k + 1, lambda kk, s=ref: _resolver(
                    prep, s if s is not None else acc.solution(times[:0], system.nq, ""),
                    0 if s is not None else -1, times[kk], motions, kk, notes))
            if motions.halt is not None:
                m = min(m, motions.halt.step - k)
                if m <= 0:
                    break
            sl = slice(k, k + m)
            try:
                res = sweep(system, {c: motions.p[sl, j] for j, c in enumerate(names)},
                            rates={c: motions.v[sl, j] for j, c in enumerate(names)},
                            accels={c: motions.a[sl, j] for j, c in enumerate(names)},
                            start=cur, **opts)
            except InputError as exc:
                message = _stop_message(prep, times, k, motions, acc, f"{exc}")
                break
            acc.take(res)
            if lagged and res.nsteps:
                one = _Accumulator(bodies, points)
                one.take(res)
                last = one.solution(times[k:k + 1], system.nq, "")
            if res.message:
                message = _stop_message(prep, times, k + res.nsteps, motions, acc,
                                        _why(res.message))
                break
            cur = res.q[-1]
            k += m
            if progress is not None:
                progress(k, n)
    except KeyboardInterrupt:
        interrupted = True
        k = acc.count()
        message = _stop_message(prep, times, min(k, n - 1), motions, acc,
                                "interrupted by the user (Ctrl-C)", want=False)
    sol = acc.solution(times, system.nq, message)
    sol.interrupted = interrupted
    if motions.halt is not None and not message:
        _halted(sol, prep, times, motions, acc)
    return sol


def _start_values(prep: Prepared, system: Any, cur: np.ndarray | None, drv_cols: list[int],
                  names: list[str], bodies: list[str], points: list[str], times: np.ndarray,
                  opts: dict[str, Any]) -> Solution | None:
    """The start posture solved with every driver held (for VALUEs that read the model)."""
    q0 = system.modeling_q if cur is None else cur
    try:
        pre = sweep(system, {c: [q0[drv_cols[j]]] for j, c in enumerate(names)},
                    rates={c: [0.0] for c in names}, start=cur, **opts)
    except InputError:
        return None
    pacc = _Accumulator(bodies, points)
    pacc.take(pre)
    return pacc.solution(times[:1], system.nq, "")


def _halted(sol: Solution, prep: Prepared, times: np.ndarray, motions: Motions,
            acc: _Accumulator) -> None:
    """Record on ``sol`` why the motions ended at their halt step."""
    halt = motions.halt
    assert halt is not None
    k = halt.step
    listed = (f"the {k} position(s) before it are listed" if k > 0 else
              "no position was solved")
    if halt.kind == "LIMIT":
        sol.message = _stop_message(prep, times, k, motions, acc, halt.text, want=False)
    elif halt.kind == "END":
        sol.stop = (f"{halt.text}: the run stops there and no further EXECUTE runs (END in a "
                    f"VALUE leaves IMP); {listed}")
        sol.end = True
    else:
        sol.stop = f"{halt.text}: the run stops there (RETURN in a VALUE); {listed}"


def _why(msg: str) -> str:
    """The reason part of a sweep failure message (without its own step numbers)."""
    if ": " in msg:
        msg = msg.split(": ", 1)[1]
    return msg.split(" The last good posture")[0].rstrip(" .")


def _free_column(system: Any, q: np.ndarray | None) -> int | None:
    """A free joint variable to hold when a run has no input motion (None for a structure)."""
    return free_coordinate(system, None if q is None else system.to_internal(q))


def _structure(prep: Prepared, times: np.ndarray, cur: np.ndarray | None, acc: _Accumulator,
               notes: list[str]) -> Solution:
    """A structure (mobility 0, no input): its one posture at every output time."""
    st = prep.spec.state
    tol = st.tolerance("POSITION")[0] if "POSITION" in st.zero else 1e-10
    ptol = st.tolerance("SYSTEM")[0] if "SYSTEM" in st.zero else 1e-10
    res = sweep(prep.system, {}, rates={}, steps=len(times), tol=tol, pivot_tol=ptol,
                            hold_free=True, start=cur)
    acc.take(res)
    return acc.solution(times[:res.nsteps], prep.system.nq, res.message)


def _stop_message(prep: Prepared, times: np.ndarray, k: int, motions: Motions,
                  acc: _Accumulator, why: str, want: bool = True) -> str:
    """Why the run stopped at step ``k`` and what it kept; ``want`` shows the
    input posture asked for at ``k``."""
    drivers = prep.drivers

    def sgc_text(step: int) -> str:
        parts = []
        for j, d in enumerate(drivers):
            v = motions.p[step, j] * d.sign
            v = math.degrees(v) if d.kind == "angle" else v
            parts.append(f"{d.joint} {d.var + 1} = {v:.6g}" + (" deg" if d.kind == "angle"
                                                                 else ""))
        return ", ".join(parts) or "no input"

    at = min(k, len(times) - 1)
    asked = f"; {sgc_text(at)}" if want else ""
    out = f"the run stopped at step {k} (time {times[at]:.6f}{asked}): {why}"
    if k > 0:
        out += f". The last good posture is step {k - 1} (time {times[k - 1]:.6f}; " \
               f"{sgc_text(k - 1)}); the {k} position(s) solved are listed"
    else:
        out += ". No position was solved"
    return out


# =============================================================================
# Quantities
# =============================================================================
def _joint_vars(prep: Prepared, sol: Solution, name: str
                ) -> tuple[ImpJoint, np.ndarray, np.ndarray, np.ndarray]:
    ij = prep.built.joints[name][0]
    sl = prep.system.joint_vars(name)
    p, v, a = imp_variables(ij, sol.q[:, sl], sol.qd[:, sl], sol.qdd[:, sl])
    assert v is not None and a is not None
    return ij, p, v, a


def _joint_origin(prep: Prepared, sol: Solution, name: str) -> np.ndarray:
    _, _jd, L1, _ = prep.built.joints[name]
    T = sol.bodies[prep.built.model.joints[name].body1][0]
    return np.einsum("sij,j->si", T, L1[:, 3])[:, :3]


def _joint_frames(prep: Prepared, sol: Solution, name: str) -> np.ndarray:
    _, _, L1, _ = prep.built.joints[name]
    T = sol.bodies[prep.built.model.joints[name].body1][0]
    return T @ L1


def _spring(prep: Prepared, sol: Solution, kind: str, name: str
            ) -> tuple[np.ndarray, ...]:
    p1, p2 = prep.spec.state.extras[kind + "s"][name]["points"][:2]
    r1, v1, a1 = sol.points[p1]
    r2, v2, a2 = sol.points[p2]
    d, dd, ddd = r2 - r1, v2 - v1, a2 - a1
    L = np.linalg.norm(d, axis=1)
    Ls = np.where(L > 0, L, np.nan)
    Ld = np.einsum("si,si->s", d, dd) / Ls
    Ldd = (np.einsum("si,si->s", dd, dd) + np.einsum("si,si->s", d, ddd) - Ld**2) / Ls
    return L, Ld, Ldd, d, dd, ddd


def _axial(M: np.ndarray) -> np.ndarray:
    return np.stack([M[:, 2, 1], M[:, 0, 2], M[:, 1, 0]], axis=1)


_LEN = "length"
_ANG_UNITS = {"POSITION": "deg", "VELOCITY": "rad/s", "ACCEL": "rad/s^2"}
_LEN_UNITS = {"POSITION": _LEN, "VELOCITY": "length/s", "ACCEL": "length/s^2"}


def _resolver(prep: Prepared, sol: Solution, k: int, t: float, motions: Motions | None,
              step: int, notes: list[str]) -> Callable[[str, str | None, int], float]:
    """resolve(kind, name, comp) for VALUE expressions at solved step ``k``.

    ``k = -1`` means before the first step: the start posture is not solved
    yet, so model quantities are undefined there except SGCs of DATA POSITION.
    """
    model = prep.built.model
    st = prep.spec.state

    def resolve(kind: str, name: str | None, comp: int) -> float:
        if kind == "TIME":
            return t
        if kind in ("FORCE", "USER"):
            label = "FORCE(...)" if kind == "FORCE" else f"USER({name})"
            note = (f"{label} in a VALUE is undefined: force analysis is not built yet"
                    if kind == "FORCE" else f"{label} is undefined: no USER function is linked")
            if note not in notes:
                notes.append(note)
            return _NAN
        assert name is not None
        which = {"POSITION": 0, "VELOCITY": 1, "ACCEL": 2}[kind]
        if motions is not None:  # an SGC set before the VALUE is evaluated (no lag)
            for j, d in enumerate(prep.drivers):
                if d.joint == name and d.var == comp - 1 and d.inp.kind == "POSITION":
                    arr = (motions.p, motions.v, motions.a)[which]
                    return float(arr[step, j] * d.sign)
        if k < 0 or k >= sol.n:
            return _NAN
        if name in model.joints:
            _, p, v, a = _joint_vars(prep, _rows(sol, k), name)
            arr = (p, v, a)[which]
            return float(arr[0, comp - 1]) if 1 <= comp <= arr.shape[1] else _NAN
        if name in sol.points and 1 <= comp <= 3:
            return float(sol.points[name][which][k, comp - 1])
        for el in ("springs", "dampers"):
            if name in st.extras.get(el, {}) and 1 <= comp <= 3:
                _, _, _, d, dd, ddd = _spring(prep, _rows(sol, k), el[:-1], name)
                return float((d, dd, ddd)[which][0, comp - 1])
        return _NAN

    return resolve


def _rows(sol: Solution, k: int, stop: int | None = None) -> Solution:
    """The solution of steps ``k`` to ``stop`` (default: step ``k`` alone)."""
    sl = slice(k, k + 1 if stop is None else stop)
    return Solution(
        times=sol.times[sl], q=sol.q[sl], qd=sol.qd[sl], qdd=sol.qdd[sl],
        quality=sol.quality[sl], iterations=sol.iterations[sl], mobility=sol.mobility[sl],
        fgc=sol.fgc[sl],
        bodies={b: tuple(x[sl] for x in v) for b, v in sol.bodies.items()},  # type: ignore
        points={p: tuple(x[sl] for x in v) for p, v in sol.points.items()},  # type: ignore
    )


def _value_stop(prep: Prepared, sol: Solution, notes: list[str]) -> Solution:
    """``sol`` cut before the first step at which a VALUE of the run's requests
    evaluates RETURN or END: IMP stops the simulation there (reference §5)."""
    st = prep.spec.state
    first: tuple[int, str, SimulationStop] | None = None
    for it in prep.items:
        if it.kind != "value":
            continue
        ex = st.values[it.name]
        for k in range(sol.n if first is None else first[0]):
            try:
                ex.derivatives(st.values, _resolver(prep, sol, k, sol.times[k], None, k, []))
            except SimulationStop as stop:
                first = (k, it.name, stop)
                break
    if first is None:
        return sol
    k, name, stop = first
    cut = _rows(sol, 0, k)
    cut.message = ""
    listed = f"the {k} position(s) before it are listed" if k else "no position is listed"
    text = (f"{stop.where[0]}:{stop.where[1]}: VALUE {name} evaluated {stop.kind} at time "
            f"{sol.times[k]:.6f}: the run stops there ")
    if stop.kind == "END":
        cut.stop = text + f"and no further EXECUTE runs (END in a VALUE leaves IMP); {listed}"
        cut.end = True
    else:
        cut.stop = text + f"(RETURN in a VALUE); {listed}"
    return cut


def _values(prep: Prepared, sol: Solution, name: str, notes: list[str]) -> np.ndarray:
    st = prep.spec.state
    ex = st.values[name]
    out = np.full((sol.n, 3), _NAN)
    for k in range(sol.n):
        vnotes: list[str] = []
        try:
            out[k] = ex.derivatives(st.values, _resolver(prep, sol, k, sol.times[k], None, k,
                                                         notes), notes=vnotes)
        except SimulationStop as stop:
            notes.append(f"{stop.where[0]}:{stop.where[1]}: VALUE {name} evaluated {stop.kind} "
                         f"at time {sol.times[k]:.6f}; IMP would stop the run there (the "
                         "values after it are left undefined)")
            break
        for v in vnotes:
            if v not in notes:
                notes.append(v)
    return out


def make_table(prep: Prepared, sol: Solution, it: Item, notes: list[str]) -> io.Table:
    """The table of one request item."""
    req = it.request
    fam, q = req.family, req.quantity
    t = sol.times
    request = req.keyword
    cols: list[str] = ["Time"]
    units: list[str] = ["s"]
    data: list[np.ndarray] = [t]
    if stepped(prep.spec.state):  # IMP's assumed time: the step number (goes on after HOLD)
        cols, units = ["Step"], [""]
        d = plot_driver(prep) if fam == "PLOT" else None
        if d is not None:  # the abscissa of the plot: the input's value
            pos = _joint_vars(prep, sol, d.joint)[1][:, d.var]
            cols.append(f"{d.joint} {d.var + 1}")
            units.append(_ANG_UNITS["POSITION"] if d.kind == "angle" else _LEN)
            data.append(np.degrees(pos) if d.kind == "angle" else pos)
    if it.kind == "heading":
        cols += ["DOF", "Quality index", "Iterations"]
        units += ["", "", ""]
        data += [sol.mobility.astype(float), sol.quality, sol.iterations.astype(float)]
        for d in prep.drivers:
            ij, p, v, a = _joint_vars(prep, sol, d.joint)
            pos = p[:, d.var]
            pos = np.degrees(pos) if d.kind == "angle" else pos
            u = _ANG_UNITS if d.kind == "angle" else _LEN_UNITS
            for lab, arr, key in (("", pos, "POSITION"), (" vel", v[:, d.var], "VELOCITY"),
                                  (" acc", a[:, d.var], "ACCEL")):
                cols.append(f"{d.joint} {d.var + 1}{lab}")
                units.append(u[key])
                data.append(arr)
        return io.tables_from_columns(request, "generalized coordinates", cols, units, data)
    if it.kind == "value":
        vals = _values(prep, sol, it.name, notes)
        cols += ["Value", "d/dt", "d2/dt2"]
        units += ["", "1/s", "1/s^2"]
        data += [vals[:, 0], vals[:, 1], vals[:, 2]]
        return io.tables_from_columns(request, f"value {it.name}", cols, units, data)
    which = {"POSITION": 0, "VELOCITY": 1, "ACCEL": 2}[q]
    if it.kind == "joint":
        ij, p, v, a = _joint_vars(prep, sol, it.name)
        arr = (p, v, a)[which]
        if which == 0:
            arr = to_degrees(ij, arr)
        for k, kind in enumerate(ij.var_kinds):
            cols.append(f"JVar {k + 1}")
            units.append((_ANG_UNITS if kind == "angle" else _LEN_UNITS)[q])
            data.append(arr[:, k])
        if fam == "PRINT" and which == 0:
            o = _joint_origin(prep, sol, it.name)
            cols += ["X", "Y", "Z"]
            units += [_LEN] * 3
            data += [o[:, 0], o[:, 1], o[:, 2]]
        return io.tables_from_columns(request, f"joint {it.name}", cols, units, data)
    if it.kind == "point":
        arr = sol.points[it.name][which]
        if fam == "PRINT":
            cols.append("Magnitude")
            units.append(_LEN_UNITS[q])
            data.append(np.linalg.norm(arr, axis=1))
        cols += ["X", "Y", "Z"]
        units += [_LEN_UNITS[q]] * 3
        data += [arr[:, 0], arr[:, 1], arr[:, 2]]
        return io.tables_from_columns(request, f"point {it.name}", cols, units, data)
    if it.kind == "link":
        T, W, A = sol.bodies[it.name]
        if which == 0:
            for i in range(3):
                for j in range(4):
                    cols.append(f"T{i + 1}{j + 1}")
                    units.append(_LEN if j == 3 else "")
                    data.append(T[:, i, j])
        else:
            M = W if which == 1 else A
            ang = _axial(M)
            lab = ("Omega", "V") if which == 1 else ("Alpha", "A")
            au = "rad/s" if which == 1 else "rad/s^2"
            for c in range(3):
                cols.append(f"{lab[0]}{'XYZ'[c]}")
                units.append(au)
                data.append(ang[:, c])
            for c in range(3):
                cols.append(f"{lab[1]}{'XYZ'[c]}")
                units.append(_LEN_UNITS[q])
                data.append(M[:, c, 3])
        return io.tables_from_columns(request, f"link {it.name}", cols, units, data)
    # spring / damper
    L, Ld, Ldd, d, dd, ddd = _spring(prep, sol, it.kind, it.name)
    scalar = (L, Ld, Ldd)[which]
    vec = (d, dd, ddd)[which]
    if fam != "STORE":
        cols.append({"POSITION": "Length", "VELOCITY": "Length rate",
                     "ACCEL": "Length acceleration"}[q])
        units.append(_LEN_UNITS[q])
        data.append(scalar)
    if fam in ("PRINT", "STORE"):
        cols += ["DX", "DY", "DZ"]
        units += [_LEN_UNITS[q]] * 3
        data += [vec[:, 0], vec[:, 1], vec[:, 2]]
    return io.tables_from_columns(request, f"{it.kind} {it.name}", cols, units, data)


# =============================================================================
# PRINT text (reference §2.4, kinematic part)
# =============================================================================
def _f4(x: float) -> str:
    return "????" if not math.isfinite(x) else f"{x:.4f}"


def _f3(x: float) -> str:
    return "????" if not math.isfinite(x) else f"{x:.3f}"


def print_step(prep: Prepared, sol: Solution, k: int, tables: dict[tuple[str, str, str], Any],
               items: list[Item]) -> list[str]:
    """The PRINT lines of step ``k``."""
    out: list[str] = []
    heading = [it for it in items if it.kind == "heading"]
    if heading:
        out.append("The Generalized Coordinates are:")
        out.append("Joint Set by Position Velocity Acceleration")
        for d in prep.drivers:
            _ij, p, v, a = _joint_vars(prep, _rows(sol, k), d.joint)
            pos = p[0, d.var]
            pos = math.degrees(pos) if d.kind == "angle" else pos
            out.append(f"{d.joint} {d.var + 1} user {_f4(pos)} {_f3(v[0, d.var])} "
                       f"{_f3(a[0, d.var])}")
        for vn in sol.fgc[k]:
            joint, var = vn.split(".", 1)
            c = prep.system.var_index((joint, var))
            kind = prep.system.var_kinds[c]
            pos = sol.q[k, c]
            idx = prep.system.var_names[prep.system.joint_vars(joint)].index(vn) + 1
            out.append(f"{joint} {idx} imp {_f4(math.degrees(pos) if kind == 'angle' else pos)}"
                       f" {_f3(sol.qd[k, c])} {_f3(sol.qdd[k, c])}")
        out.append(f"Degree of freedom = {int(sol.mobility[k])}. Quality index = "
                   f"{sol.quality[k]:.2e} with {int(sol.iterations[k])} iterations.")
    for q, title in (("POSITION", "Position Results:"), ("VELOCITY", "Velocity Results:"),
                     ("ACCEL", "Acceleration Results:")):
        its = [it for it in items if it.request.quantity == q and it.kind != "heading"]
        if not its:
            continue
        out.append(title)
        out.append("Item Name Magnitude X Y Z")
        for it in its:
            t = tables[("PRINT", q, f"{it.kind} {it.name}")]
            row = t.rows[k]
            if it.kind == "joint":
                nv = sum(1 for c in t.columns if c.startswith("JVar"))
                vals = [_f4(x) for x in row[1:1 + nv]]
                first = vals[0] if vals else ""
                extra = " " + " ".join(_f4(x) for x in row[1 + nv:]) if q == "POSITION" else ""
                out.append(f"Joint {it.name} {first}{extra}".rstrip())
                out.extend(vals[1:])
            elif it.kind == "point":
                out.append(f"Point {it.name} " + " ".join(_f4(x) for x in row[1:]))
            elif it.kind == "link":
                vals = row[1:]
                if q == "POSITION":
                    out.append(f"Link {it.name}")
                    for i in range(3):
                        out.append(" ".join(_f4(x) for x in vals[4 * i:4 * i + 4]))
                else:
                    w, vv = vals[:3], vals[3:]
                    out.append(f"Link {it.name} {_f4(float(np.linalg.norm(w)))} "
                               + " ".join(_f4(x) for x in w))
                    out.append(f"{_f4(float(np.linalg.norm(vv)))} " + " ".join(_f4(x) for x in vv))
            else:
                lab = "Spg." if it.kind == "spring" else "Dmp."
                out.append(f"{lab} {it.name} " + " ".join(_f4(x) for x in row[1:]))
    vals = [it for it in items if it.kind == "value"]
    if vals:
        out.append("Value Results:")
        out.append("Name Value Velocity Acceleration")
        for it in vals:
            row = tables[("PRINT", "VALUE", f"value {it.name}")].rows[k]
            out.append(f"{it.name} " + " ".join(_f4(x) for x in row[1:]))
    return out


# =============================================================================
# Runs
# =============================================================================
@dataclass
class Context:
    """State carried from run to run: reference posture, time, output sinks.

    ``folder`` receives the files the deck asks for (STORE, PRINT ON, STORE
    INPUT, graphics); ``out_dir`` is set when graphics are rendered (--out).
    ``problems`` receives a message for every file that was refused or could
    not be written.  ``stopped`` ends the deck (END in a VALUE, Ctrl-C).
    """

    out_dir: Path | None
    echo: Callable[[str], None]
    notes: Callable[[str], None]
    progress: Callable[[int, int, int], None] | None
    deck_stem: str
    folder: OutputFolder
    problems: Callable[[str], None]
    ref_q: np.ndarray | None = None
    ref_names: tuple[str, ...] | None = None
    ref_sol: tuple[Prepared, Solution] | None = None
    time0: float = 0.0
    print_on: str | None = None
    print_files: dict[str, list[str]] = field(default_factory=dict)
    files: dict[str, str] = field(default_factory=dict)
    file_where: dict[str, Where] = field(default_factory=dict)
    draws: int = 0
    graphics_note: bool = False
    interactive_note: bool = False
    viz: Any = None
    viz_error: str | None = None
    stopped: bool = False

    def say(self, line: str) -> None:
        """Print a line (and copy it to the PRINT ON file), control characters escaped."""
        line = printable(line)
        self.echo(line)
        if self.print_on is not None:
            self.print_files.setdefault(self.print_on, []).append(line)

    def get_viz(self, where: Where) -> Any:
        """The viz module, or None (with a note located at ``where``) when it cannot be
        imported."""
        if self.viz is None and self.viz_error is None:
            try:
                from openimp import viz  # type: ignore[attr-defined]

                self.viz = viz
            except Exception as exc:
                self.viz_error = f"{type(exc).__name__}: {exc}"
                self.notes(f"{where[0]}:{where[1]}: graphics were not rendered: openimp.viz "
                           f"cannot be imported ({printable(self.viz_error, 200)})")
        return self.viz

    def picture(self, name: str, where: Where, render: Callable[[str], Any]) -> None:
        """Render a graphics file ``name`` in the output folder with ``render(path)``
        (refused names and write failures go to ``problems``)."""
        path = self.folder.target(name, where)
        if path is None:
            self.problems(self.folder.refused[-1])
            return
        try:
            render(str(path))
        except OutputError as exc:
            self.problems(f"{where[0]}:{where[1]}: {exc}")
            return
        self.folder.claim(path)


def _ascii(text: str) -> str:
    """``text`` for a picture: printable ASCII, any other character as '?' (the fonts
    of the pictures need not have a glyph for it, and IMP titles are ASCII)."""
    return "".join(ch if " " <= ch <= "~" else "?" for ch in text)


def _title(state: State) -> str:
    return state.title or DEFAULT_TITLE


def execute_run(spec: RunSpec, ctx: Context) -> io.Run:
    """Carry out one EXECUTE (see the module docstring)."""
    state = spec.state
    run = io.Run(_title(state), spec.mode)
    when = _time.strftime("%m/%d/%Y at %H:%M:%S")
    for line in io.banner(printable(run.title), spec.mode.capitalize(), when).split("\n"):
        ctx.say(line)
    failure, unsupported = not_produced(spec)
    if failure is not None:
        run.failure = failure
        ctx.say(f"*** {run.failure} ***")
        return run
    prep = validate(spec)
    for m in prep.built.messages:
        run.messages.append(m)
        ctx.say(f"*** {m} ***")
    times, assumed = time_grid(state, ctx.time0)
    if assumed:
        run.messages.append(assumed)
        ctx.say(f"*** {assumed} ***")
    for text in unsupported:
        run.unsupported.append(text)
        ctx.say(f"*** {text} ***")
    start = None
    if ctx.ref_q is not None:
        if ctx.ref_names == prep.system.var_names:
            start = ctx.ref_q
        else:
            m = ("The model changed since EXECUTE HOLD; this run starts from the design "
                 "position.")
            run.messages.append(m)
            ctx.say(f"*** {m} ***")
    notes: list[str] = []
    prog = None
    if ctx.progress is not None:
        def prog(done: int, total: int, _i: int = spec.index) -> None:
            assert ctx.progress is not None
            ctx.progress(_i, done, total)
    sol = solve(prep, times, start, notes, prog)
    if not (sol.stop or sol.interrupted) and sol.n:
        sol = _value_stop(prep, sol, notes)
    # tables
    tables: dict[tuple[str, str, str], io.Table] = {}
    for it in prep.items:
        t = make_table(prep, sol, it, notes)
        tables[(it.request.family, it.request.quantity, t.item)] = t
        run.tables.append(t)
    # PRINT output per position
    print_items = [it for it in prep.items if it.request.family == "PRINT"]
    if print_items:
        for k in range(sol.n):
            ctx.say(f"step = {io.step_text(sol.times[k])}" if stepped(state)
                    else f"time = {sol.times[k]:.6f}")
            for line in print_step(prep, sol, k, tables, print_items):
                ctx.say(line)
    for note in notes:
        run.messages.append(note)
        ctx.say(f"*** {note} ***")
    if sol.stop:
        run.messages.append(sol.stop)
        ctx.say(f"*** {sol.stop} ***")
        ctx.stopped = ctx.stopped or sol.end
    if sol.message:
        run.failure = f"{spec.where[0]}:{spec.where[1]}: EXECUTE: {sol.message}"
    run.interrupted = sol.interrupted
    # listings
    for t in run.tables:
        if t.request.startswith("LIST"):
            ctx.say("")
            for line in io.format_listing(t).split("\n"):
                ctx.say(line)
    if run.failure:
        ctx.say("")
        ctx.say(f"*** {run.failure} ***")
    if not run.interrupted:
        _graphics(prep, sol, run, ctx)
    if spec.hold and sol.n > 0:
        ctx.ref_q = sol.q[-1].copy()
        ctx.ref_names = prep.system.var_names
        ctx.ref_sol = (prep, sol)
        ctx.time0 = float(sol.times[-1])
        m = "The current position is set as reference."
        run.messages.append(m)
        ctx.say(f"*** {m} ***")
    return run


def _scene(prep: Prepared, sol: Solution, steps: slice, title: str) -> Any:
    from openimp.viz import Scene  # type: ignore[import-not-found]

    st = prep.spec.state
    g = st.graphics
    model = prep.built.model
    links: dict[str, list[np.ndarray]] = {}
    colors: dict[str, str] = {}
    for link, pts in st.polylines:
        pts = [p for p in pts if p in sol.points]
        if len(pts) < 2 or link not in model.body_frames:
            continue
        if link in g.erased or ("*" in g.erased and link not in g.colors):
            continue
        poly = np.stack([sol.points[p][0][steps] for p in pts], axis=1)
        links.setdefault(link, []).append(poly)
        colors[link] = g.colors.get(link, g.all_color or "WHITE")
    axes = []
    for j in model.joints:
        length = g.axes.get(j, g.axes_all)
        if length:
            axes.append((j, _joint_frames(prep, sol, j)[steps], float(length)))
    view = g.view
    times = None if stepped(st) else np.asarray(sol.times[steps])  # None: "step k / n"
    return Scene(links=links, colors=colors, view=view, axes=axes, times=times,
                 title=_ascii(title))


def _graphics(prep: Prepared, sol: Solution, run: io.Run, ctx: Context) -> None:
    st = prep.spec.state
    g = st.graphics
    plots = [t for t in run.tables if t.request.startswith("PLOT")]
    wants = g.animate or plots
    if not wants:
        return
    if not _can_render(ctx, prep.spec.where):
        return
    _interactive_note(st, ctx)
    viz = ctx.get_viz(prep.spec.where)
    if viz is None or sol.n == 0:
        return
    k = prep.spec.index
    where = prep.spec.where
    try:
        if g.animate:
            scene = _scene(prep, sol, slice(None), run.title)
            ctx.picture(f"run{k}_animation.gif", where, lambda p: viz.animate_gif(scene, p))
            ctx.picture(f"run{k}_animation.html", where, lambda p: viz.animate_html(scene, p))
        for t in plots:
            name = f"run{k}_plot_{io._slug(t.request.split()[-1])}_{io._slug(t.item)}.png"
            x = 1 if plot_driver(prep) is not None else 0
            ctx.picture(name, where, lambda p, t=t, x=x: viz.plot_png(t, p, x=x))
    except Exception as exc:
        ctx.notes(f"{where[0]}:{where[1]}: run {k}: graphics failed ({type(exc).__name__}: "
                  f"{printable(str(exc), 200)}); the numeric results are not affected")


def _can_render(ctx: Context, where: Where) -> bool:
    """True with --out; otherwise say once that graphics were accepted but not rendered."""
    if ctx.out_dir is not None:
        return True
    if not ctx.graphics_note:
        ctx.graphics_note = True
        ctx.notes(f"{where[0]}:{where[1]}: graphics statements (DRAW, ANIMATE, PLOT ...) were "
                  "accepted but not rendered: give --out DIR to write plots and animations")
    return False


def _interactive_note(state: State, ctx: Context) -> None:
    if state.graphics.interactive and not ctx.interactive_note:
        ctx.interactive_note = True
        w = state.graphics.interactive[0]
        ctx.notes(f"{w[0]}:{w[1]}: interactive view statements (DEVICE, ZOOM, SLIDE, TURN, "
                  "STORE/RECALL VIEW, DATA DRAW, SHOW LOOP) have no effect on the files "
                  "written with --out")


def _draw(state: State, where: tuple[str, int], ctx: Context) -> None:
    if not _can_render(ctx, where):
        return
    _interactive_note(state, ctx)
    viz = ctx.get_viz(where)
    if viz is None:
        return
    ctx.draws += 1
    try:
        if ctx.ref_sol is not None:
            prep, sol = ctx.ref_sol
            prep = Prepared(RunSpec(prep.spec.index, state, where, False, prep.spec.statement,
                                    "kinematic"), prep.built, prep.system, prep.drivers, [], [])
            scene = _scene(prep, sol, slice(sol.n - 1, sol.n), _title(state))
        else:
            scene = _design_scene(state, where)
        if scene is None:
            return
        ctx.picture(f"draw{ctx.draws}.png", where, lambda p: viz.draw_png(scene, 0, p))
    except InputError as exc:
        ctx.notes(f"{where[0]}:{where[1]}: DRAW: the model cannot be drawn yet "
                  f"({printable(str(exc), 200)})")
    except Exception as exc:
        ctx.notes(f"{where[0]}:{where[1]}: DRAW failed ({type(exc).__name__}: "
                  f"{printable(str(exc), 200)})")


def _design_scene(state: State, where: tuple[str, int]) -> Any:
    """A one-step scene of the model at its design (modeling) posture."""
    from openimp.viz import Scene  # type: ignore[import-not-found]

    built = build_model(state, where)
    model = built.model
    g = state.graphics
    links: dict[str, list[np.ndarray]] = {}
    colors: dict[str, str] = {}
    for link, pts in state.polylines:
        pts = [p for p in pts if p in model.points]
        if len(pts) < 2 or link in g.erased or ("*" in g.erased and link not in g.colors):
            continue
        poly = np.stack([model.points[p].xyz for p in pts])[None]
        links.setdefault(link, []).append(poly)
        colors[link] = g.colors.get(link, g.all_color or "WHITE")
    axes = []
    for j, (_, jd, L1, _) in built.joints.items():
        length = g.axes.get(j, g.axes_all)
        if length:
            F = state.links[jd.link1].frame @ L1
            axes.append((j, F[None], float(length)))
    return Scene(links=links, colors=colors, view=g.view, axes=axes, times=np.zeros(1),
                 title=_ascii(_title(state)))


@contextmanager
def _warnings_as_notes(ctx: Context, where: Where, messages: list[str] | None = None
                       ) -> Iterator[None]:
    """Turn the Python warnings raised inside the block (numpy overflow, matplotlib)
    into one located note each, so none reaches the terminal raw."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            yield
        finally:
            seen: set[str] = set()
            for w in caught:
                text = f"{w.category.__name__}: {printable(str(w.message), 120)}"
                if text in seen:
                    continue
                seen.add(text)
                note = (f"{where[0]}:{where[1]}: a computation gave a warning ({text}, in "
                        f"{os.path.basename(w.filename)}:{w.lineno})")
                if issubclass(w.category, RuntimeWarning):
                    note += ("; values that are not finite are listed as ????: check the sizes "
                             "of the input numbers")
                ctx.notes(note)
                if messages is not None:
                    messages.append(note)


def _one_run(spec: RunSpec, ctx: Context) -> io.Run:
    """One EXECUTE; its input errors and unexpected failures become the run's failure,
    Ctrl-C an interrupted run."""
    loc = f"{spec.where[0]}:{spec.where[1]}"
    messages: list[str] = []
    try:
        with _warnings_as_notes(ctx, spec.where, messages):
            run = execute_run(spec, ctx)
    except KeyboardInterrupt:
        run = io.Run(_title(spec.state), spec.mode, interrupted=True)
        run.failure = f"{loc}: EXECUTE: interrupted by the user (Ctrl-C) before its results"
    except InputError as exc:  # found only now (e.g. a file changed meanwhile)
        run = io.Run(_title(spec.state), spec.mode)
        run.failure = (str(exc) if exc.where is not None else f"{loc}: EXECUTE: {exc}")
    except Exception as exc:  # one run's bug must not lose the others
        run = io.Run(_title(spec.state), spec.mode)
        run.failure = (f"{loc}: EXECUTE failed unexpectedly ({type(exc).__name__}: "
                       f"{printable(str(exc), 200)}); please report it")
    else:
        run.messages.extend(messages)
        ctx.stopped = ctx.stopped or run.interrupted
        return run
    ctx.say(f"*** {run.failure} ***")
    if run.interrupted:
        ctx.stopped = True
    return run


def _event(kind: str, payload: Any, ctx: Context, runs: list[io.Run]) -> None:
    """Carry out one event of the deck (see :class:`~openimp.imp.interp.Interpreter`)."""
    if kind == "text":
        ctx.say(payload)
    elif kind == "run":
        runs.append(_one_run(payload, ctx))
    elif kind == "draw":
        with _warnings_as_notes(ctx, payload[1]):
            _draw(payload[0], payload[1], ctx)
    elif kind == "reset":
        ctx.time0 = 0.0
    elif kind == "print_on":
        if payload is None:
            ctx.print_on = None
        else:
            ctx.print_on = payload[0]
            ctx.file_where.setdefault(payload[0], payload[1])
    elif kind == "store_input":
        name, lines, where = payload
        ctx.files[name] = "\n".join([*lines, "RETURN"]) + "\n"
        ctx.file_where[name] = where


def _write_files(ctx: Context, runs: list[io.Run], deck_path: str) -> None:
    """Write the STORE, PRINT ON and STORE INPUT files into the output folder."""
    store = io.format_store(runs)
    if store:
        ctx.files[f"{ctx.deck_stem}_store.txt"] = store
    for name, lines in ctx.print_files.items():
        ctx.files[name] = "\n".join(lines) + "\n"
    for name, text in ctx.files.items():
        where = ctx.file_where.get(name, (deck_path, 0))
        try:
            if ctx.folder.write(name, text, where) is None:
                ctx.problems(ctx.folder.refused[-1])
        except OutputError as exc:
            loc = f"{where[0]}:{where[1]}: " if where[1] > 0 else f"{where[0]}: "
            ctx.problems(f"{loc}{exc}")


def run_deck(deck: Any, out_dir: str | os.PathLike[str] | None = None,
             echo: Callable[[str], None] | None = None,
             progress: Callable[[int, int, int], None] | None = None,
             notes: Callable[[str], None] | None = None,
             overwrite: bool = False,
             problems: Callable[[str], None] | None = None) -> list[io.Run]:
    """Carry out the events of a deck in order; see :meth:`Deck.run`.

    Files go to ``out_dir`` or, without it, to the deck's folder; a file the
    run did not create is replaced only with ``overwrite``.  ``problems``
    receives one message per file refused or not written (default: ``notes``).
    Ctrl-C, or END evaluated in a VALUE, ends the deck after the current run;
    the files of what was run are still written.
    """
    out = Path(out_dir) if out_dir is not None else None
    base = out if out is not None else (Path(deck.path).parent or Path("."))
    if out is not None:
        try:
            out.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise OutputError(f"the output folder {printable(str(out), 80)} cannot be created "
                              f"({exc.strerror or type(exc).__name__})", str(out)) from None
    say_note = notes or (lambda s: None)
    ctx = Context(out, echo or (lambda s: None), say_note, progress, Path(deck.path).stem,
                  OutputFolder(base, overwrite), problems or say_note)
    runs: list[io.Run] = []
    for kind, payload in deck.events:
        if ctx.stopped:
            break
        _event(kind, payload, ctx, runs)
    for text in trailing_requests(deck):
        ctx.notes(text)
    _write_files(ctx, runs, deck.path)
    return runs
