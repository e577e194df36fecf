"""Time response (book ch 14): :func:`simulate`, the Python entry.

The mechanism is released from initial conditions, its specified coordinates
(SGCs) held or driven as functions of time, and the equations of motion
integrated in its free generalized coordinates (FGCs) with the loops closed at
every stage (:mod:`~openimp.dynamics.stepping`, compiled).  Outputs come at the
requested times, hit exactly, with the energy audit, the loop-closure residual
and the quality index at each; a failure keeps every output before it.

Two integrators (``method``):

* ``"rk"`` (default): adaptive Dormand-Prince 5(4), error per step against
  ``atol + rtol |y|`` on the FGC positions and rates: the accurate one for
  smooth problems;
* ``"book"``: the book's locally linearized exact-exponential step (ch 14),
  controlled by the force error of IMP's ZERO (FORCE) (``force_error``): the one
  for stiff problems (springs far stiffer than the motion needs), whose high
  frequencies do not set its step.

The run is compiled calls of up to :data:`CHUNK_STEPS` steps each; motions of
time, load laws and their switching functions (Python callables) are called
from inside the compiled step (:mod:`~openimp.dynamics.integration`).  The
works of the energy audit are integrated with the motion but not
error-controlled: with drives or loads, a smaller ``max_step`` tightens them.
"""

from __future__ import annotations

import contextlib
import math
import time as _time
import warnings
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from openimp._interrupt import caused_by_interrupt, deferred_interrupt
from openimp.dynamics import stepping as stp
from openimp.dynamics.integration import Drive, Held, Run, column, motions, why
from openimp.dynamics.outputs import OutputBuffer, Progress, output_times, positive
from openimp.dynamics.stepping import RunEnd
from openimp.errors import AnalysisError, InputError
from openimp.kinematics import singular as sing
from openimp.kinematics.ballrates import spin_rates
from openimp.kinematics.inputs import finite
from openimp.kinematics.track import tracker
from openimp.limits import MAX_NUMBER, MAX_RATE, MAX_RUN_STEPS, number_text
from openimp.results import (
    CoordinateSwitch,
    EnergyAudit,
    IntegrationStats,
    Singularity,
    Trajectory,
)
from openimp.system import State, System, make_state

#: methods of :func:`simulate`
METHODS = ("rk", "book")
#: steps per compiled call between progress reports (and chances for Ctrl-C)
CHUNK_STEPS = 2000
#: without a smallest step, a run stops with a located failure when the error control
#: asks for a step below this fraction of the output spacing (MSC Adams' default HMIN
#: of 1e-6 HMAX): a pole of a load, a motion that grows without bound, a rate far too
#: high for the outputs asked for; a smallest step given (min_step, DATA TIME's second
#: number) replaces it, and steps there are kept whatever their error
STEP_FLOOR = 1e-6


@dataclass(frozen=True)
class SimOptions:
    """The integration options of :func:`simulate`, checked (:func:`sim_options`).

    ``rtol``, ``atol``: integration tolerances (rk); ``force_error``: IMP's ZERO
    (FORCE) pair (force in model units, percent) of the book's step; step lengths
    in seconds; ``tol``: loop closure; ``pivot_tol``: the elimination's;
    ``mass_tol``: the singularity test of M_FF (ZERO (INERTIA)); ``max_steps``: a
    cap on the steps of the run; ``floor``: without ``min_step``, the step below
    which the run stops (:data:`STEP_FLOOR` of the output spacing), else 0."""

    method: str
    rtol: float
    atol: float
    force_error: tuple[float, float]
    min_step: float
    max_step: float
    first_step: float
    tol: float
    pivot_tol: float
    mass_tol: float
    max_steps: int
    events: bool
    floor: float


def sim_options(tout: np.ndarray, method: str, rtol: Any, atol: Any, force_error: Any,
                min_step: Any, max_step: Any, first_step: Any, tol: Any, pivot_tol: Any,
                mass_tol: Any, max_steps: Any, events: Any) -> SimOptions:
    """The options of :func:`simulate` checked, with their defaults from the output
    times ``tout``; an input error naming the first bad one."""
    if method not in METHODS:
        raise InputError(f"method must be one of {', '.join(METHODS)}, got {method!r}")
    rt = positive("rtol", rtol)
    at = rt if atol is None else positive("atol", atol)
    try:
        fa, fp = (float(x) for x in force_error)
    except (TypeError, ValueError):
        raise InputError(f"force_error must be (force, percent), got {force_error!r}") from None
    if not (fa > 0 and fp > 0 and math.isfinite(fa) and math.isfinite(fp)):
        raise InputError(f"force_error: both the force and the percent must be > 0, got "
                         f"{force_error!r} (IMP's ZERO (FORCE))")
    hmin = positive("min_step", min_step, allow_zero=True)
    spacing = float(np.min(np.diff(tout)))
    span = float(tout[-1] - tout[0])
    # the book's step is at most the output interval (section 14.5); Dormand-Prince steps
    # over outputs (they are interpolated and closed there)
    hmax = (spacing if method == "book" else span) if max_step is None else \
        positive("max_step", max_step)
    if hmin <= hmax * (1 + 1e-9):  # an output spacing a rounding under min_step
        hmin = min(hmin, hmax)
    if hmin > hmax:
        raise InputError(f"min_step {hmin:g} s exceeds the largest step {hmax:g} s (the output "
                         "spacing or max_step)")
    h1 = (min(hmax, 1e-3 * span) if method == "rk" else hmax) \
        if first_step is None else positive("first_step", first_step)
    tols = [positive(name, v) for name, v in (("tol", tol), ("pivot_tol", pivot_tol),
                                               ("mass_tol", mass_tol))]
    if isinstance(max_steps, np.integer):
        max_steps = int(max_steps)
    if not isinstance(max_steps, int) or isinstance(max_steps, bool) or \
            not 1 <= max_steps <= MAX_RUN_STEPS:
        raise InputError(f"max_steps must be an integer in 1 ... {MAX_RUN_STEPS} (limit "
                         f"MAX_RUN_STEPS), got {max_steps!r}")
    floor = 0.0 if hmin > 0.0 else STEP_FLOOR * spacing
    return SimOptions(method, rt, at, (fa, fp), hmin, hmax, max(h1, hmin), *tols, max_steps,
                      bool(events), floor)


def _renamed(new: Any, old: Any, new_name: str, old_name: str, default: Any) -> Any:
    """A keyword renamed this release: the old name still works with a warning."""
    if old is None:
        return default if new is None else new
    if new is not None:
        raise InputError(f"give {new_name} (the new name of {old_name}), not both")
    warnings.warn(f"simulate: {old_name} is deprecated, use {new_name}", DeprecationWarning,
                  stacklevel=3)
    return old


def simulate(
    system: System,
    t_final: float | None = None,
    *,
    print_step: float | None = None,
    times: Sequence[float] | np.ndarray | None = None,
    q: Any = None,
    rates: Mapping[Any, float] | None = None,
    state: State | None = None,
    specified: Sequence[Any] | None = None,
    motion: Mapping[Any, Any] | None = None,
    method: str = "rk",
    rtol: float = 1e-8,
    atol: float | None = None,
    force_error: tuple[float, float] | None = None,
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
    max_steps: int = MAX_RUN_STEPS,
    q0: Any = None,
    force_tol: tuple[float, float] | None = None,
) -> Trajectory:
    """The time response of ``system`` (book ch 14): released from its initial
    conditions, its specified coordinates held or driven by ``motion``, integrated to
    the output times with the loops closed at every stage.

    Output times: ``t_final`` with ``print_step`` (0, print_step, ..., t_final), or
    ``times`` (increasing; the first is the start).  Initial conditions: ``q`` maps
    joint variables (``"joint"`` or ``"joint.var"``) to positions (model units,
    radians for angles; the others from the modeling posture, the loops closed with
    the given ones held) or gives all nq variables; ``rates`` maps coordinates to
    initial rates: they become free coordinates, the other free coordinates start at
    rest (IMP's DATA IC); ``"joint.w": (wx, wy, wz)`` gives a ball joint's (SPHERE,
    OPEN) angular velocity, its second body's relative to its first in the first
    body's joint frame u v w (:func:`~openimp.kinematics.ballrates.ball_rates`: three
    of its parameters' rates).  ``state``: a :class:`~openimp.system.State` (internal
    units) to start from instead, its joint variables and rates.  ``specified``
    names the specified coordinates (SGCs): held at their start position unless
    ``motion`` drives them; ``motion`` maps SGCs to motions of time
    (:mod:`openimp.motion`, a callable ``t -> (position, velocity, acceleration)``,
    or a number: held there).

    ``method``: ``"rk"`` (Dormand-Prince 5(4), the integration tolerances
    ``rtol``/``atol`` per step on the free coordinates' positions and rates,
    internal units, atol = rtol by default) or ``"book"`` (the book's linearized
    exponential step with the force error ``force_error`` = (force in model units,
    percent), IMP's ZERO (FORCE), default (0.1, 1.0)).  Steps are never longer than
    ``max_step`` (default: the whole run for ``rk``, whose outputs are interpolated
    inside its steps and closed there; the output spacing for ``book``, the book's
    rule) nor shorter than ``min_step`` (IMP's DATA TIME minimum); ``max_steps``
    caps the steps.  ``tol``: loop closure; ``mass_tol``: the singularity test of
    the mass matrix (IMP's ZERO (INERTIA)).  Load laws with a ``switch`` function
    are switched at the located instant (``events``).  ``progress``: a bar on a
    terminal (None: when stderr is one), False, or a callable ``progress(done,
    total)`` with done the time reached and total the final time.  ``stream``: a
    .csv path receiving every output as it is computed; with ``keep=False`` only
    the first and the last outputs stay in memory.  ``q0`` and ``force_tol`` are
    the old names of ``q`` and ``force_error`` (deprecated).

    Returns a :class:`~openimp.results.Trajectory` at the output times with rates,
    ``energy`` (:class:`~openimp.results.EnergyAudit`), ``closure``, ``quality``,
    ``coordinate_switches``, ``events`` and ``integration``.  When the run cannot go
    on, ``message`` says when and why and every output before is kept.
    """
    if not isinstance(system, System):
        raise InputError(f"simulate takes a compiled System, got {type(system).__name__}")
    q = _renamed(q, q0, "q", "q0", None)
    if isinstance(q, State):  # a State as q: the old way of state=
        state = _renamed(state, q, "state=", "a State as q", None)
        q = None
    force_error = _renamed(force_error, force_tol, "force_error", "force_tol", (0.1, 1.0))
    tout = output_times(t_final, print_step, times)
    opts = sim_options(tout, method, rtol, atol, force_error, min_step, max_step, first_step,
                       tol, pivot_tol, mass_tol, max_steps, events)
    if stream is None and not keep:
        raise InputError("keep=False needs stream= (the outputs must go somewhere)")
    S, q_given, qd_given, balls = _initial(system, q, rates, state, float(tout[0]))
    drive = _drive(system, motion, specified, S, q_given)
    if drive.timed:  # the motions over the run checked before it starts
        drive.at(tout, np.zeros((tout.size, drive.cols.size, 3)))
    r = Run(system, method, drive, opts, opts.events)
    # Ctrl-C is deferred while Python is called back from the compiled step (an exception
    # there would surface as a SystemError): the step stops at its next hook or tick
    with deferred_interrupt() as r.interrupt:
        try:
            r.start(S, float(tout[0]), q_given, qd_given, None if state is None else state.qd)
            if r.interrupt[0]:
                raise KeyboardInterrupt
            for joint, (cols, e) in balls.items():
                if not np.allclose(S.q[cols], e, rtol=0.0, atol=1e-9):
                    raise InputError(f"rates: the angular velocity of {joint!r} was given at "
                                     "a posture that closing the loops changes: give the "
                                     "posture of the ball in q (or the rates of its "
                                     "parameters)")
            r.names_before = r.fgc_names()
            out = OutputBuffer(system, tout, bool(keep), stream)
            bar = Progress(progress, float(tout[0]), float(tout[-1]))
            wall = _time.perf_counter()
            message = _integrate(r, out, bar, opts.max_steps)
        finally:
            r.close()
    return _response(system, r, out, drive, message, _time.perf_counter() - wall)


def _integrate(r: Run, out: OutputBuffer, bar: Progress, max_steps: int) -> str:
    """The run to the last output in compiled chunks (progress between them); the
    message of how it ended ("" when complete)."""
    w = r.w
    message = ""
    try:
        with _interruptible() as stopped:
            stp.record(r.S, r.W, out.rows_, 0, float(out.tout[0]), True)
            out.k[0] = 1
            steps0 = 0
            while True:
                code = r.advance(out, min(CHUNK_STEPS, max_steps - steps0))
                out.flush()
                bar(float(w.t[0]))
                if r.interrupt[0]:  # deferred at a tick or a hook: the outputs are whole
                    raise KeyboardInterrupt
                if code == RunEnd.REACHED:
                    break
                steps0 = int(w.steps[0])
                tnow = float(w.t[0])
                if code == RunEnd.PAUSED or (code in (RunEnd.CAPPED, RunEnd.FULL)
                                             and steps0 < max_steps):
                    continue
                if code == RunEnd.CAPPED:
                    message = (f"t = {tnow:.6g} s: {max_steps} steps taken (max_steps); raise "
                               "max_steps or loosen the tolerance")
                else:
                    tfail = float(w.tfail[0])
                    tnow = tfail if math.isfinite(tfail) else tnow
                    code = int(w.why[0])
                    text = why(code, float(w.hfloor[0]))
                    cause = _floor_cause(r) if code == stp.TINY_STEP else code
                    if cause != code:  # the step shrank as it neared a singular posture
                        text = (f"{why(cause)} (ahead: the step fell below "
                                f"{float(w.hfloor[0]):.3g} s, 1e-6 of the output step, as "
                                "it neared it)")
                    message = f"t = {tnow:.6g} s: {text}"
                break
        if stopped[0]:
            message = (f"t = {float(w.t[0]):.6g} s: interrupted by the user (Ctrl-C); "
                       "the outputs before it are kept")
    except (AnalysisError, InputError) as exc:  # a user's motion or law failing mid-run
        message = f"t = {float(w.t[0]):.6g} s: {exc}"
    finally:
        bar.done()
        out.flush()
        if out.stream is not None:
            out.stream.close()
    return message


#: a step floor reached with the free coordinates' mass matrix or the quality index
#: fallen below this fraction of their size at the start is a singular posture ahead
SINGULAR_DIP = 1e-3


def _floor_cause(r: Run) -> int:
    """Why the step fell below its floor: a singular mass matrix ahead (its smallest
    pivot, or a diagonal entry against the largest at the start, below SINGULAR_DIP), a
    singular posture ahead, a limit of travel (the quality index below SINGULAR_DIP of its
    reference: NO_CLOSURE, whose message names both), or
    neither (TINY_STEP)."""
    w = r.w
    nF = int(w.nF[0])
    if nF and (float(w.mnow[0]) < SINGULAR_DIP
               or float(np.min(w.mdiag[:nF])) < SINGULAR_DIP * float(w.mscale[0])):
        return stp.SINGULAR_MASS
    if float(w.qref[0]) > 0.0 and float(w.qual0[0]) < SINGULAR_DIP * float(w.qref[0]):
        return stp.NO_CLOSURE  # its message names a limit of travel and a singular posture
    return stp.TINY_STEP


def _initial(system: System, q: Any, rates: Any, state: State | None, t0: float
             ) -> tuple[State, dict[int, float], dict[int, float],
                        dict[str, tuple[np.ndarray, np.ndarray]]]:
    """The start state (internal units), the positions given (held while the loops are
    closed) and the rates given, by column; the balls given an angular velocity, with
    their columns and parameters the rates were made at
    (:func:`~openimp.kinematics.ballrates.spin_rates`)."""
    if state is not None:
        if q is not None or rates is not None:
            raise InputError("give either state= or q/rates, not both")
        if not isinstance(state, State) or state.q.shape != (system.nq,):
            raise InputError(f"state must be a State of this system ({system.nq} joint "
                             "variables), e.g. from openimp.system.make_state")
        if not (np.all(np.isfinite(state.q)) and np.all(np.isfinite(state.qd))):
            raise InputError("state: its joint variables and rates must be finite")
        return make_state(system, state.q, t0), {}, {}, {}
    q_given = _mapping(system, q, "q") if not _is_array(q) else {}
    S = make_state(system, _start_q(system, q), t0)
    qs = S.q.copy()  # the start posture with the given positions: the balls' rates there
    for c, v in q_given.items():
        qs[c] = v
    rates, balls = spin_rates(system, rates, system.to_model(qs))
    qd_given = _mapping(system, rates, "rates")
    return S, q_given, qd_given, balls


def _drive(system: System, motion: Any, specified: Any, S: State,
           q_given: dict[int, float]) -> Drive:
    """The SGCs: the driven ones of ``motion`` and the ``specified`` ones held at their
    start position."""
    cols, mos = motions(system, motion)
    rows = {int(c): m for c, m in zip(cols, mos, strict=True)}
    if specified is not None:
        names = [specified] if isinstance(specified, str) else list(specified)
        for key in names:
            c = column(system, key, "specified")
            if c not in rows:
                x = q_given.get(c, float(S.q[c]))
                rows[c] = Held(x * float(system.var_scale[c]))
    scols = np.array(sorted(rows), np.int64)
    driven = set(int(c) for c in cols)
    for c in q_given:
        if c in driven:
            raise InputError(f"q: {system.var_names[c]} is driven by its motion; its position "
                             "comes from there")
    return Drive(system, scols, [rows[int(c)] for c in scols])


def _mapping(system: System, values: Any, what: str) -> dict[int, float]:
    """A mapping key -> number as {column: internal value}."""
    if values is None:
        return {}
    if not isinstance(values, Mapping):
        raise InputError(f"{what} must map joint variables to numbers, e.g. {{'A': 0.5}}")
    out: dict[int, float] = {}
    for key, v in values.items():
        c = column(system, key, what)
        x = finite(v, f"{what}: the value of {key!r}")
        top, limit = (MAX_RATE, "MAX_RATE") if what == "rates" else (MAX_NUMBER, "MAX_NUMBER")
        if abs(x) > top:
            raise InputError(f"{what}: the value of {key!r} is {number_text(x)}, beyond "
                             f"±{number_text(top)} (limit {limit})")
        out[c] = x / system.var_scale[c]
    return out


def _is_array(q: Any) -> bool:
    return q is not None and not isinstance(q, Mapping)


def _start_q(system: System, q: Any) -> np.ndarray:
    if _is_array(q):
        try:
            qa = np.asarray(q, dtype=float).reshape(-1)
        except (TypeError, ValueError):
            raise InputError(f"q must map joint variables to numbers or give all "
                             f"{system.nq} of them") from None
        if qa.shape != (system.nq,) or not np.all(np.isfinite(qa)):
            raise InputError(f"q must hold {system.nq} finite numbers, one per joint variable "
                             f"({', '.join(system.var_names)})")
        return system.to_internal(qa).copy()
    return system.q0.copy()


@contextlib.contextmanager
def _interruptible() -> Iterator[list[bool]]:
    flag = [False]
    try:
        yield flag
    except KeyboardInterrupt:
        flag[0] = True
    except SystemError as exc:  # a second Ctrl-C inside a callback of compiled code
        if not caused_by_interrupt(exc):
            raise
        flag[0] = True


def _response(system: System, r: Run, out: OutputBuffer, drive: Drive, message: str,
              seconds: float) -> Trajectory:
    """The trajectory of the recorded outputs (model units out of the internal rows)."""
    rows = out.rows()
    n = rows.t.size
    scols = drive.cols
    # the mobility at each output is the number of generalized coordinates (6.52)
    rank = system.nq - rows.fgc.sum(axis=1).astype(np.int64) - scols.size
    res = Trajectory(system, rows.q, rows.quality, rank, rows.fgc, np.zeros(n, np.int64),
                     list(drive.names), message, tracker=tracker(system), sgc=_sgc(system, scols))
    res.set_rates(rows.qd, rows.qdd, np.zeros(n))
    res.time = rows.t
    res.closure = rows.closure
    res.quality_ref = float(rows.quality[0]) if n else 0.0
    e = rows.energy * system.length_scale ** 2
    res.energy = EnergyAudit(e[:, 0].copy(), e[:, 1].copy(), e[:, 2].copy(), e[:, 3].copy(),
                             e[:, 4].copy())
    # without keep only the first and last outputs remain: a switch is then at the last
    res.coordinate_switches = [CoordinateSwitch(k if out.keep else min(k, n - 1), ts, old, new)
                               for k, ts, old, new in r.switches]
    res.events = list(r.events)
    res.singularities = _change_points(system, r, rows)
    res.interrupted = "interrupted by the user" in message
    w = r.w
    res.integration = IntegrationStats(
        r.method, int(w.steps[0]), int(w.rejects[0]), int(w.evals[0]), int(w.closes[0]),
        float(w.smallest[0]) if w.steps[0] else 0.0, float(w.largest[0]), int(w.forced[0]),
        len(r.events), seconds)
    return res


def _change_points(system: System, r: Run, rows: stp.OutputRows) -> list[Singularity]:
    """The change points the run passed (:func:`~openimp.dynamics.stepping.crossing`) as
    :class:`~openimp.results.Singularity` records, classified at their postures
    against the start's whole Jacobian."""
    if not r.crossings or rows.t.size == 0:
        return []
    ptol = float(r.w.ptol[0])
    sgc = _sgc(system, r.drive.cols)
    full_ref = sing.full_quality(system, rows.q[0], ptol)
    regular = int(rows.fgc[0].sum()) + r.drive.cols.size
    t = rows.t
    out = []
    for tc, q, _ in r.crossings:
        kind, mob, free = sing.classify(system, q, sgc, ptol, full_ref, regular)
        quality = sing.full_quality(system, q, ptol, full_ref[0])[1]
        k = int(min(np.searchsorted(t, tc, side="right"), t.size - 1))
        pos = float(k) if k == 0 or t[k] <= tc else k - 1 + (tc - t[k - 1]) / (t[k] - t[k - 1])
        fgc = rows.fgc[min(k, t.size - 1)]
        at = {system.var_names[c]: float(q[c] * system.var_scale[c]) for c in np.flatnonzero(fgc)}
        branch = ("continued on the branch whose tangent continues the motion"
                  if kind == sing.CHANGE_POINT else "")
        out.append(Singularity(k, False, pos, at, kind, mob, regular, free, branch, quality,
                               time=tc))
    return out


def _sgc(system: System, scols: np.ndarray) -> np.ndarray:
    m = np.zeros(system.nq, bool)
    m[scols] = True
    return m
