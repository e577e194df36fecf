"""The kinematic runner: input motions, postures, velocities and accelerations.

For every EXECUTE in kinematic mode (no FIND statement):

1. the SGC values at every output time: a ``DATA POSITION`` joint moves one
   increment per output step (``start + increment * min(k, nsteps)``) at the
   constant DATA VELOCITY / ACCEL; a ``DATA MOTION`` entry is a constant
   (degrees or lengths, zero rates) or a VALUE evaluated with its two time
   derivatives (radians); a VALUE that reads the model (``POSITION(...)`` ...)
   is evaluated step by step from the last solved posture, as IMP did;
2. the postures, velocities and accelerations, solved in chunks
   (:func:`openimp.kinematics.sweep`, free coordinates held as IMP's
   kinematic mode does), gathered in one trajectory.

A posture that cannot be reached is skipped, as IMP skipped it (a sweep
through a limit of travel): a message names the step, the time, the inputs
asked for and why, the run goes on from the next step with the last good
posture as its guess, and the solution records the output times missing
(:attr:`Solution.missing`, ``Run.missing``).  A run none of whose positions can
be reached, an input error or Ctrl-C stop it; everything computed before is
kept.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from openimp.errors import InputError
from openimp.imp.expr import SimulationStop
from openimp.imp.run.prepare import Driver, Prepared, reads_model, redundancy_notes
from openimp.imp.run.quantities import value_resolver
from openimp.imp.run.solution import Solution
from openimp.kinematics import free_coordinate, sweep
from openimp.kinematics.track import tracker
from openimp.limits import MAX_NUMBER, MAX_RATE, number_text
from openimp.results import Trajectory

_NAN = math.nan




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
        #: the SGCs, then the over-specified inputs checked against them (prep.checks)
        self.inputs = [*prep.drivers, *prep.checks]
        n, nd = len(times), len(self.inputs)
        self.p = np.zeros((n, nd))
        self.v = np.zeros((n, nd))
        self.a = np.zeros((n, nd))
        self.undefined: set[str] = set()
        self.halt: Halt | None = None

    def fill(self, k0: int, k1: int, resolver: Callable[[int], Any] | None) -> None:
        """Fill steps k0..k1-1 (``resolver(k)`` gives the resolve function at step k)."""
        for j, d in enumerate(self.inputs):
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
        s = np.array([d.sign for d in self.inputs])
        if len(s):
            self.p[k0:k1] *= s
            self.v[k0:k1] *= s
            self.a[k0:k1] *= s

    def _jet(self, d: Driver, m: str, k: int, resolver: Callable[[int], Any] | None
             ) -> list[float] | None:
        """Value, rate and acceleration of VALUE ``m`` at step ``k`` (None: halted)."""
        resolve = resolver(k) if resolver is not None else time_only(self.times[k])
        why: list[str] = []
        try:
            jet = self.state.values[m].derivatives(self.state.values, resolve, notes=why)
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
                        "for it" + (f" ({why[0].split(': ', 1)[-1]})" if why else ""))
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


def time_only(t: float) -> Callable[[str, str | None, int], float]:
    """resolve(kind, name, comp) that knows only TIME (``t``): every other
    quantity is NaN (undefined)."""
    def resolve(kind: str, name: str | None, comp: int) -> float:
        return t if kind == "TIME" else _NAN

    return resolve


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
    parts: list[Trajectory] = []
    empty = Trajectory.empty(system, tracker(system))
    motions = Motions(prep, times, notes)
    n = len(times)
    tol, maxit = st.tolerance("POSITION")
    tol = tol if "POSITION" in st.zero else 1e-10
    maxit = int(maxit or 25) if "POSITION" in st.zero else 25
    ptol = st.tolerance("SYSTEM")[0] if "SYSTEM" in st.zero else 1e-10
    lagged = reads_model(st, drivers)
    notes.extend(redundancy_notes(prep))
    cur = None if start is None else np.array(start, float)
    if not drivers:
        notes.append("No input motion is given (DATA POSITION or DATA MOTION): every free "
                      "coordinate is held at its value.")
        col = _free_column(system, cur)
        if col is None:
            return _structure(prep, times, cur)
        drv_cols = [col]
        q0 = system.modeling_q if cur is None else cur
        fixed = np.full((n, 1), q0[col])
        motions.p, motions.v, motions.a = fixed, np.zeros((n, 1)), np.zeros((n, 1))
    else:
        drv_cols = [d.column for d in drivers]
        if not lagged:
            motions.fill(0, n, None)
    names = [system.var_names[c] for c in drv_cols]
    opts = {"tol": tol, "pivot_tol": ptol, "maxit": maxit, "hold_free": True,
            "branch": st.branch, "at_limit": st.at_limit}
    message = ""
    interrupted = False
    last: Solution | None = None
    solved: list[int] = []  # the output steps reached, in order
    missing: list[int] = []
    why: list[str] = []  # why each missing position cannot be reached
    starts: list[int] = []  # the output step of each part's first step
    k = 0
    try:
        if lagged:  # the values at the start posture: a sweep that holds every driver
            last = _start_values(system, cur, drv_cols, names, times, opts)
        while k < n:
            m = 1 if lagged else n - k
            if lagged:
                ref = last if last is not None and last.n else None
                motions.fill(k, k + 1, lambda kk, s=ref: value_resolver(
                    prep, s if s is not None else Solution(empty, times[:0]),
                    0 if s is not None else -1, times[kk], motions, kk, notes))
            if motions.halt is not None:
                m = min(m, motions.halt.step - k)
                if m <= 0:
                    break
            sl = slice(k, k + m)
            told = None
            if progress is not None and not lagged:
                def told(done: float, total: float, k0: int = k) -> None:
                    progress(k0 + int(done), n)
            try:
                res = sweep(system, {c: motions.p[sl, j] for j, c in enumerate(names)},
                            rates={c: motions.v[sl, j] for j, c in enumerate(names)},
                            accels={c: motions.a[sl, j] for j, c in enumerate(names)},
                            q=cur, progress=told, warn=False, **opts)
            except InputError as exc:
                message = _stop_message(prep, times, k, motions, f"{exc}")
                break
            bad = _disagreement(prep, motions, k, res)
            if bad is not None:  # an over-specified input disagrees: skipped, as IMP did
                r, text = bad
                if r:
                    parts.append(res.steps(0, r))
                    starts.append(k)
                    solved.extend(range(k, k + r))
                missing.append(k + r)
                why.append(text)
                cur = res.q[r]
                k += r + 1
                if res.interrupted:
                    raise KeyboardInterrupt
                continue
            parts.append(res)
            starts.append(k)
            solved.extend(range(k, k + res.nsteps))
            if lagged and res.nsteps:
                last = Solution(res, times[k:k + 1])
            if res.interrupted:
                raise KeyboardInterrupt
            if res.nsteps:
                cur = res.q[-1]
            if res.message:  # this position cannot be reached: skipped, as IMP did
                bad = k + res.nsteps
                missing.append(bad)
                why.append(_why(res.message))
                k = bad + 1
                continue
            k += m
            if progress is not None and lagged:
                progress(k, n)
    except KeyboardInterrupt:
        interrupted = True
        k = (solved[-1] + 1) if solved else 0
        message = _stop_message(prep, times, min(k, n - 1), motions,
                                "interrupted by the user (Ctrl-C)", want=False)
    if missing and not solved and not message:
        message = (f"no position of the run can be reached (the first, step {missing[0]}, "
                   f"time {times[missing[0]]:.6f}: see its message)")
    sol = Solution.of(parts, empty, times, message, solved)
    sol.interrupted = interrupted
    sol.missing = [float(times[j]) for j in missing]
    notes.extend(_skip_messages(prep, times, motions, missing, why))
    if missing:  # singular postures and switches numbered by output step, not by row
        _number_by_output_step(sol, parts, starts)
        sol.grid = times
    if motions.halt is not None and not message:
        record_halt(sol, prep, times, motions)
    return sol


#: how closely an over-specified input must agree with the posture the other inputs give
#: (radians, or lengths relative to max(1, |value|); its rate relative to max(1, |rate|))
CONSISTENT = 1e-6


def _disagreement(prep: Prepared, motions: Motions, k: int, res: Trajectory
                  ) -> tuple[int, str] | None:
    """The first row of ``res`` (solved for output steps k, k+1, ...) at which an
    over-specified input (``prep.checks``) is not where, or not as fast as, the other
    inputs and the loops put it, and what it disagrees by; None when all agree."""
    if not prep.checks or not res.nsteps:
        return None
    q, qd, _ = res.internal()
    n = res.nsteps
    first, text = n, ""
    for j, d in enumerate(motions.inputs[len(prep.drivers):], start=len(prep.drivers)):
        given, got = motions.p[k:k + n, j], q[:, d.column]
        err = np.abs(given - got)
        if d.kind == "angle":  # the same angle a turn apart agrees
            err = np.abs((given - got + math.pi) % (2 * math.pi) - math.pi)
        else:
            err = err / np.maximum(1.0, np.maximum(np.abs(given), np.abs(got)))
        bad = err > CONSISTENT
        what, a, b = "position", given, got
        if qd is not None:
            vg, vs = motions.v[k:k + n, j], qd[:, d.column]
            slow = np.abs(vg - vs) > CONSISTENT * np.maximum(1.0, np.abs(vs))
            if np.any(slow) and (not np.any(bad) or np.argmax(slow) < np.argmax(bad)):
                bad, what, a, b = slow, "velocity", vg, vs
        if np.any(bad) and int(np.argmax(bad)) < first:
            first = int(np.argmax(bad))
            x, y = a[first] * d.sign, b[first] * d.sign
            unit = ""
            if d.kind == "angle" and what == "position":
                x, y, unit = math.degrees(x), math.degrees(y), " deg"
            elif d.kind == "angle":
                unit = " rad/s"
            text = (f"the over-specified input {d.joint} {d.var + 1} is given the {what} "
                    f"{x:.6g}{unit}, but the other inputs and the loops make it {y:.6g}{unit}")
    return (first, text) if first < n else None


def _start_values(system: Any, cur: np.ndarray | None, drv_cols: list[int], names: list[str],
                  times: np.ndarray, opts: dict[str, Any]) -> Solution | None:
    """The start posture solved with every driver held (for VALUEs that read the model)."""
    q0 = system.modeling_q if cur is None else cur
    try:
        pre = sweep(system, {c: [q0[drv_cols[j]]] for j, c in enumerate(names)},
                    rates={c: [0.0] for c in names}, q=cur, warn=False, **opts)
    except InputError:
        return None
    return Solution(pre, times[:1])


def record_halt(sol: Solution, prep: Prepared, times: np.ndarray, motions: Motions) -> None:
    """Record on ``sol`` why the motions ended at their halt step."""
    halt = motions.halt
    assert halt is not None
    k = halt.step
    listed = (f"the {k} position(s) before it are listed" if k > 0 else
              "no position was solved")
    if halt.kind == "LIMIT":
        sol.message = _stop_message(prep, times, k, motions, halt.text, want=False)
    else:
        value_stop(sol, halt.kind, halt.text, listed)


def value_stop(sol: Solution, kind: str, text: str, listed: str) -> None:
    """RETURN or END (``kind``) evaluated by a VALUE (``text``: where and when): the run
    stops there, not as a failure; END also ends the deck.  ``listed``: what is kept."""
    if kind == "END":
        sol.stop = (f"{text}: the run stops there and no further EXECUTE runs (END in a VALUE "
                    f"leaves IMP); {listed}")
        sol.end = True
    else:
        sol.stop = f"{text}: the run stops there (RETURN in a VALUE); {listed}"


def _why(msg: str) -> str:
    """The reason part of a sweep failure message (without its own step numbers)."""
    if ": " in msg:
        msg = msg.split(": ", 1)[1]
    return msg.split(" The last good posture")[0].rstrip(" .")


def _free_column(system: Any, q: np.ndarray | None) -> int | None:
    """A free joint variable to hold when a run has no input motion (None for a structure)."""
    return free_coordinate(system, None if q is None else system.to_internal(q))


def _structure(prep: Prepared, times: np.ndarray, cur: np.ndarray | None) -> Solution:
    """A structure (mobility 0, no input): its one posture at every output time."""
    st = prep.spec.state
    tol = st.tolerance("POSITION")[0] if "POSITION" in st.zero else 1e-10
    ptol = st.tolerance("SYSTEM")[0] if "SYSTEM" in st.zero else 1e-10
    res = sweep(prep.system, {}, rates={}, steps=len(times), tol=tol, pivot_tol=ptol,
                            hold_free=True, q=cur, warn=False)
    return Solution(res, times[:res.nsteps], res.message)


def _number_by_output_step(sol: Solution, parts: list[Trajectory], starts: list[int]) -> None:
    """Number the singular postures and input switches of ``sol`` by output step (a part
    starting at output step k numbers its own from k): skipped steps leave gaps."""
    sing, sw = [], []
    for p, k in zip(parts, starts, strict=True):
        if not p.nsteps:  # a position skipped alone: its message says why
            continue
        sing += [replace(r, step=r.step + k, position=r.position + k) for r in p.singularities]
        sw += [replace(w, step=w.step + k) for w in p.switches]
    sol.traj.singularities, sol.traj.switches = sing, sw


def _skip_messages(prep: Prepared, times: np.ndarray, motions: Motions, missing: list[int],
                   why: list[str]) -> list[str]:
    """One message per run of consecutive positions that cannot be reached: the steps,
    their times, the inputs asked for and why the first cannot be."""
    w = prep.spec.where
    out = []
    i = 0
    while i < len(missing):
        j = i
        while j + 1 < len(missing) and missing[j + 1] == missing[j] + 1:
            j += 1
        a, b = missing[i], missing[j]
        asked = _asked(prep, motions, a)
        if a == b:
            out.append(f"{w[0]}:{w[1]}: EXECUTE: step {a} (time {times[a]:.6f}; {asked}) "
                       f"cannot be reached: {why[i]}; it is skipped and the run goes on")
        else:
            out.append(f"{w[0]}:{w[1]}: EXECUTE: steps {a} to {b} (time {times[a]:.6f} to "
                       f"{times[b]:.6f}; {asked} to {_asked(prep, motions, b)}) cannot be "
                       f"reached: the first because {why[i]}; they are skipped and the run "
                       "goes on")
        i = j + 1
    return out


def _asked(prep: Prepared, motions: Motions, step: int) -> str:
    """The input motions asked for at ``step`` (``A 1 = 30 deg, ...`` or ``no input``)."""
    parts = []
    for j, d in enumerate(motions.inputs):
        v = motions.p[step, j] * d.sign
        v = math.degrees(v) if d.kind == "angle" else v
        parts.append(f"{d.joint} {d.var + 1} = {v:.6g}" + (" deg" if d.kind == "angle" else ""))
    return ", ".join(parts) or "no input"


def _stop_message(prep: Prepared, times: np.ndarray, k: int, motions: Motions, why: str,
                  want: bool = True) -> str:
    """Why the run stopped at step ``k`` and what it kept; ``want`` shows the
    input posture asked for at ``k``."""
    at = min(k, len(times) - 1)
    asked = f"; {_asked(prep, motions, at)}" if want else ""
    out = f"the run stopped at step {k} (time {times[at]:.6f}{asked}): {why}"
    if k > 0:
        out += f". The last good posture is step {k - 1} (time {times[k - 1]:.6f}; " \
               f"{_asked(prep, motions, k - 1)}); the {k} position(s) solved are listed"
    else:
        out += ". No position was solved"
    return out
