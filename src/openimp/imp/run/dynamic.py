"""The dynamic runner: the time response of a deck (FIND DYNAMICS, book ch 14).

For every EXECUTE in dynamic mode:

1. ``DATA TIME = final, minstep, printstep`` (required; the interpreter refuses
   an EXECUTE without it) gives the output times, as in the other modes
   (``t0, t0 + printstep, ...`` up to ``final``; ``t0`` is 0, or the time an
   EXECUTE HOLD reached) and the smallest step of the integrator;
2. ``DATA MOTION`` gives the SGCs, driven in time: a number is held (degrees or
   lengths), a VALUE is a function of time whose value and two derivatives
   are the position, velocity and acceleration (radians for angles);
3. ``DATA IC (joint) = pos, vel; ...`` gives the initial positions (degrees or
   lengths; a VALUE in radians), held while the loops are closed at the start,
   and the initial rates (rad/s or length/s); ``NONE`` leaves a member out;
   FGCs without an IC start at rest (IMP's rule);
4. :func:`openimp.simulate` integrates with :data:`METHOD`, IMP's ZERO (FORCE)
   as its step control, ZERO (INERTIA) as its mass-matrix test and ZERO
   (POSITION) / ZERO (SYSTEM) as in the other runners.  ZERO (SPRING) has
   nothing to act on: IMP only warned about a singular stiffness matrix, and
   the integrator never inverts one; the run says so when the deck gives it.

A failure of the integration (a singular mass matrix, loops that cannot be
closed) stops the run with its message; every output before it is kept.  The
trajectory then goes through the same tables, PRINT text, force analysis (in
IMP's dynamic-mode convention) and pictures as the other modes.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from openimp.errors import AnalysisError, InputError
from openimp.imp.expr import Expression, SimulationStop
from openimp.imp.jointmap import cardan_angular_velocity, cardan_to_er, imp_variables
from openimp.imp.run.kinematic import Motions, record_halt, time_only, value_stop
from openimp.imp.run.prepare import Driver, Prepared
from openimp.imp.run.quantities import imp_variable
from openimp.imp.run.solution import Solution
from openimp.kinematics.track import tracker
from openimp.results import Trajectory

_NAN = math.nan

#: the integrator of IMP decks: IMP's own, the book's locally linearized steps (ch 14)
METHOD = "book"



class ValueMotion:
    """A DATA MOTION VALUE as a motion of time: ``(p, v, a)`` over an array of times,
    in the model's units (radians, lengths) and the openimp variable's sign.

    An undefined value or derivative counts as 0 (IMP's rule), said once in
    ``notes``; a RETURN or END met between output times stops nothing here (the
    output times were checked before the integration) and counts as 0 too.
    """

    def __init__(self, prep: Prepared, driver: Driver, notes: list[str]) -> None:
        self.values: dict[str, Expression] = prep.spec.state.values
        self.name = str(driver.inp.motions[driver.var])
        self.sign = driver.sign
        self.driver = driver
        self.notes = notes
        self.told = False

    def _jet(self, t: float) -> tuple[float, float, float]:
        try:
            jet = self.values[self.name].derivatives(self.values, time_only(t))
        except SimulationStop:
            return (0.0, 0.0, 0.0)
        out = tuple(float(x) if math.isfinite(x) else math.nan for x in jet)
        if not all(math.isfinite(x) for x in out):
            self._undefined(t)
            out = tuple(x if math.isfinite(x) else 0.0 for x in out)
        return out  # type: ignore[return-value]

    def _undefined(self, t: float) -> None:
        if self.told:
            return
        self.told = True
        w = self.driver.inp.where
        self.notes.append(f"{w[0]}:{w[1]}: VALUE {self.name} (DATA MOTION of joint "
                          f"{self.driver.joint}) is undefined at time {t:.6f}; IMP uses 0 for "
                          "it")

    def __call__(self, t: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Position, velocity and acceleration at the times ``t`` (any shape)."""
        t = np.asarray(t, dtype=float)
        out = np.zeros((3, *t.shape))
        for idx, ti in np.ndenumerate(t):
            out[(slice(None), *idx)] = self._jet(float(ti))
        out *= self.sign
        return out[0], out[1], out[2]


def motions(prep: Prepared, notes: list[str]) -> dict[str, Any]:
    """The SGCs of DATA MOTION as :func:`openimp.simulate` takes them: openimp variable
    name -> a held number (model units, signed) or a :class:`ValueMotion`."""
    out: dict[str, Any] = {}
    for d in prep.drivers:
        key = prep.system.var_names[d.column]
        m = d.inp.motions[d.var]
        if isinstance(m, str):
            out[key] = ValueMotion(prep, d, notes)
        else:
            v = float(m)
            out[key] = d.sign * (math.radians(v) if d.kind == "angle" else v)
    return out


def _ic_value(prep: Prepared, x: float | str, kind: str, t0: float, where: Any,
              label: str, notes: list[str]) -> float:
    """One DATA IC member in model units: a number (degrees for an angle's position) or a
    VALUE evaluated at the start time (radians); undefined counts as 0, said."""
    if not isinstance(x, str):
        return math.radians(float(x)) if kind == "angle" else float(x)
    values = prep.spec.state.values
    try:
        v = float(values[x].evaluate(values, time_only(t0)))
    except SimulationStop:
        v = math.nan
    if not math.isfinite(v):
        notes.append(f"{where[0]}:{where[1]}: VALUE {x} ({label}) is undefined at time "
                     f"{t0:.6f}; 0 is used for it")
        v = 0.0
    return v


def initial_conditions(prep: Prepared, t0: float, notes: list[str],
                       posture: np.ndarray | None = None
                       ) -> tuple[dict[str, float], dict[str, Any]]:
    """DATA IC as :func:`openimp.simulate` takes them: (positions, rates), openimp
    variable name -> model units, signed; the Cardan angles of a SPHERE or OPEN joint
    as its Euler-Rodrigues parameters and its angular velocity ``"joint.w"``
    (:func:`_cardan_ic`, at the posture ``posture`` (nq,), model units; default the
    modeling posture).  An IC on an input motion (an SGC) is not used, with a message:
    the motion sets that variable."""
    state = prep.spec.state
    system = prep.system
    q0: dict[str, float] = {}
    rates: dict[str, Any] = {}
    driven = {(d.joint, d.var) for d in prep.drivers}
    for joint, ic in state.extras.get("ics", {}).items():
        if joint not in prep.built.joints:
            continue
        ij = prep.built.joints[joint][0]
        first = system.joint_vars(joint).start
        where = ic["where"]
        ball: dict[int, tuple[Any, Any]] = {}
        for k, (pos, vel) in enumerate(ic["pairs"]):
            if pos is None and vel is None:
                continue
            if ij.is_cardan(k):
                ball[k - ij.cardan] = (pos, vel)
                continue
            if (joint, k) in driven:
                notes.append(f"{where[0]}:{where[1]}: DATA IC of joint {joint} {k + 1} is not "
                             "used: that variable is an input motion (DATA MOTION), which "
                             "sets its position and velocity")
                continue
            drive = ij.drive[k]
            assert drive is not None  # refused when DATA IC was read
            key = system.var_names[first + drive[0]]
            kind = ij.var_kinds[k]
            if pos is not None:
                q0[key] = drive[1] * _ic_value(prep, pos, kind, t0, where,
                                               f"initial position of joint {joint} {k + 1}",
                                               notes)
            if vel is not None:
                rates[key] = drive[1] * _ic_value(prep, vel, "rate", t0, where,
                                                  f"initial velocity of joint {joint} {k + 1}",
                                                  notes)
        if ball:
            _cardan_ic(prep, joint, ball, posture, t0, where, notes, q0, rates)
    return q0, rates


def _cardan_ic(prep: Prepared, joint: str, ball: dict[int, tuple[Any, Any]],
               posture: np.ndarray | None, t0: float, where: Any, notes: list[str],
               q0: dict[str, float], rates: dict[str, Any]) -> None:
    """The DATA IC of the Cardan angles of a SPHERE or OPEN joint ``joint``, ``ball``
    {0, 1, 2: (position, velocity)}, into ``q0`` and ``rates``: the positions (IMP's
    x-y'-z'' angles, R = Rx(t1) Ry(t2) Rz(t3); NONE keeps the angle of the joint at
    ``posture`` (nq,), model units, default the modeling posture) as the joint's four
    Euler-Rodrigues parameters, held while the loops are closed; the rates (rad/s,
    NONE = 0) as the relative angular velocity in the first body's joint frame,
    omega = x t1' + Rx y t2' + Rx Ry z t3' (the inverse of the listings' conversion,
    :func:`~openimp.imp.jointmap.imp_variables`), which simulate reads as ``"joint.w"``."""
    system = prep.system
    ij = prep.built.joints[joint][0]
    sl = system.joint_vars(joint)
    qj = (system.modeling_q if posture is None else np.asarray(posture, float))[sl]
    cols = np.arange(ij.cardan, ij.cardan + 4)  # e1..e4 among the joint's variables
    ang = imp_variables(ij, qj[None, :], None, None)[0][0, ij.cardan:ij.cardan + 3].copy()
    rate = np.zeros(3)
    for i, (pos, vel) in ball.items():
        label = f"joint {joint} {ij.cardan + i + 1}"
        if pos is not None:
            ang[i] = _ic_value(prep, pos, "angle", t0, where, f"initial position of {label}",
                               notes)
        if vel is not None:
            rate[i] = _ic_value(prep, vel, "rate", t0, where, f"initial velocity of {label}",
                                notes)
    if any(pos is not None for pos, _ in ball.values()):
        e = cardan_to_er(ang, qj[cols])
        for k, c in enumerate(cols):
            q0[system.var_names[sl.start + c]] = float(e[k])
    if any(vel is not None for _, vel in ball.values()):
        rates[f"{joint}.w"] = tuple(float(x) for x in cardan_angular_velocity(ang, rate))


def _start(prep: Prepared, start: np.ndarray | None, q0: dict[str, float]) -> Any:
    """The posture ``q`` of :func:`openimp.simulate`: the IC positions, or after EXECUTE HOLD the
    posture reached with the IC positions put in."""
    if start is None:
        return q0 or None
    full = np.array(start, dtype=float)
    for key, v in q0.items():
        full[prep.system.var_index(key)] = v
    return full


def _min_step(prep: Prepared, times: np.ndarray, notes: list[str]) -> float:
    """DATA TIME's smallest step (its second number), at most the output spacing: IMP
    decks often give the print step there (ch9: 0.0075, 0.00025, 0.00025), which then
    is every step."""
    st = prep.spec.state
    minstep = float(st.time[1]) if st.time is not None else 0.0
    if len(times) < 2:
        return 0.0
    spacing = float(np.min(np.diff(times)))
    if minstep > spacing * (1.0 + 1e-9):
        w = st.time_where or prep.spec.where
        notes.append(f"{w[0]}:{w[1]}: DATA TIME: the smallest step {minstep:g} s is larger "
                     f"than the print step {spacing:g} s; the print step is used as the "
                     "smallest step")
    return min(minstep, spacing)


def options(prep: Prepared, times: np.ndarray, notes: list[str]) -> dict[str, Any]:
    """The tolerances of :func:`openimp.simulate` from the deck's ZERO statements and
    DATA TIME (the step cap: ZERO (FORCE)'s third number)."""
    st = prep.spec.state
    method, rtol = st.integrator  # (METHOD, None) unless a REMARK OPENIMP INTEGRATOR
    opts: dict[str, Any] = {
        "method": method,
        "mass_tol": float(st.tolerance("INERTIA")[0]),
        "min_step": _min_step(prep, times, notes),
        "tol": float(st.tolerance("POSITION")[0]) if "POSITION" in st.zero else 1e-10,
        "pivot_tol": float(st.tolerance("SYSTEM")[0]) if "SYSTEM" in st.zero else 1e-10,
    }
    if method == METHOD:
        opts["force_error"] = tuple(float(x) for x in st.tolerance("FORCE"))
    else:
        opts["rtol"] = rtol
    if method != METHOD and "FORCE" in st.zero:
        given = ", ".join(f"{x:g}" for x in st.tolerance("FORCE") if x is not None)
        notes.append(f"ZERO (FORCE) = {given} is not used: REMARK OPENIMP INTEGRATOR = RK "
                     f"chose Dormand-Prince at the relative tolerance {rtol:g}")
    if st.max_steps is not None:
        opts["max_steps"] = int(st.max_steps)
    if "SPRING" in st.zero:
        notes.append(f"ZERO (SPRING) = {st.tolerance('SPRING')[0]:g} is accepted and not "
                     "needed: IMP only warned about a singular stiffness matrix, and "
                     "openimp's integrator never inverts one")
    return opts


def _progress(progress: Callable[[int, int], None] | None, times: np.ndarray
              ) -> Callable[[float, float], None] | bool:
    """simulate's progress(done, total) (the time reached, the final time) as the runner's
    progress(done, total) in outputs."""
    if progress is None:
        return False
    n = len(times)
    t0, span = float(times[0]), float(times[-1] - times[0])

    def told(t: float, _t_final: float) -> None:
        done = n if span <= 0 else round((n - 1) * (t - t0) / span)
        progress(min(max(done, 0), n), n)

    return told


def _imp_coordinate(prep: Prepared, vn: str) -> str:
    """An openimp variable in IMP's words: the joint and the variable number."""
    _i, idx, _kind = imp_variable(prep, vn)
    return f"{vn.split('.', 1)[0]} {idx}"


def run_notes(prep: Prepared, res: Any) -> list[str]:
    """The run's messages about the integration: every change of the FGCs and every
    load-law switching located."""
    out = []
    for sw in getattr(res, "coordinate_switches", None) or []:
        old = ", ".join(_imp_coordinate(prep, v) for v in sw.old) or "none"
        new = ", ".join(_imp_coordinate(prep, v) for v in sw.new) or "none"
        out.append(f"time {sw.time:.6f}: the free generalized coordinates change from "
                   f"{old} to {new}")
    for ev in getattr(res, "events", None) or []:
        out.append(f"time {ev.time:.6f}: {ev.name} switches ({ev.direction})")
    # an element whose data reach one IF twice (a spring and a damper rate of one VALUE,
    # or a VALUE used twice) switches once
    return list(dict.fromkeys(out))


def _mobility(res: Any, nsgc: int) -> None:
    """The rank of the loop equations at every output, from IMP's FGC = DF - SGC, when
    the time response leaves it unset (zeros): the PRINT HEADING line and the heading
    table's DOF read the mobility n - rank."""
    free = np.asarray(getattr(res, "free", np.zeros((0, 0))), bool)
    if res.nsteps and free.shape == (res.nsteps, res.system.nq) and not np.any(res.rank):
        res.rank = (res.system.nq - free.sum(axis=1) - nsgc).astype(np.int64)
        res._cache.pop("mobility", None)


def motion_reader(prep: Prepared) -> Callable[[Any, str, str, int], float]:
    """``read(s, kind, name, comp)``: POSITION, VELOCITY or ACCEL (``kind``) at the load
    state ``s`` of a joint variable (radians or lengths, IMP's variables and signs), a
    point (X, Y, Z) or a spring or damper (its second point's less its first's: DX,
    DY, DZ); NaN for what is not one of them."""
    system = prep.system
    model = prep.built.model
    extras = prep.spec.state.extras
    ends = {name: tuple(e["points"][:2]) for kind in ("dampers", "springs")
            for name, e in extras.get(kind, {}).items()}

    def read(s: Any, kind: str, name: str, comp: int) -> float:
        which = ("POSITION", "VELOCITY", "ACCEL").index(kind)
        if name in prep.built.joints:
            ij = prep.built.joints[name][0]
            keys = system.var_names[system.joint_vars(name)]
            q = np.array([[s.var(k) for k in keys]])
            qd = np.array([[s.var_rate(k) for k in keys]])
            qdd = np.array([[s.var_accel(k) if which == 2 else 0.0 for k in keys]])
            arr = imp_variables(ij, q, qd, qdd)[which]
            return (float(arr[0, comp - 1]) if arr is not None and 1 <= comp <= arr.shape[1]
                    else _NAN)
        if not 1 <= comp <= 3:
            return _NAN
        get = (s.point, s.point_velocity, s.point_acceleration)[which]
        if name in ends and all(p in model.points for p in ends[name]):
            p1, p2 = ends[name]
            return float(np.ravel(get(p2))[comp - 1] - np.ravel(get(p1))[comp - 1])
        if name in model.points:
            return float(np.ravel(get(name))[comp - 1])
        return _NAN

    return read


def state_resolver(prep: Prepared, at_rest: bool = False
                   ) -> Callable[[Any], Callable[[str, str | None, int], float]]:
    """Load state of an instant of the integration or of a posture of the equilibrium
    search -> the VALUE resolver there: TIME, and POSITION and VELOCITY as
    :func:`motion_reader` reads them.  ACCEL and FORCE: the loads decide them, so
    ``at_rest`` (an equilibrium) ACCEL is 0 and FORCE undefined; while integrating both
    are read a step behind, as IMP read its stored current values: extrapolated from
    their values at the last two accepted states (:attr:`~openimp.imp.dyndata.ValueLaws.held`,
    kept by :func:`holder`)."""
    read = motion_reader(prep)
    laws = prep.built.dyn.laws
    held = None if at_rest or laws is None else laws.held

    def at(s: Any) -> Callable[[str, str | None, int], float]:
        def resolve(kind: str, name: str | None, comp: int) -> float:
            if kind == "TIME":
                return float(s.t)
            if name is None:
                return _NAN
            if kind in ("ACCEL", "FORCE"):
                if kind == "ACCEL" and at_rest:
                    return 0.0
                if held is None:
                    return _NAN
                v, slope, t0 = held.setdefault((kind, name, comp), (0.0, 0.0, float(s.t)))
                return v + slope * (float(s.t) - t0)
            return read(s, kind, name, comp)

        return resolve

    return at


#: the jump of a value read a step behind (its value at an accepted state less its
#: extrapolation from the two before), relative to the largest value it has had, that
#: the steps are shortened to keep below (the lag's error per step, second order in it)
LAG_TOL = 1e-5


def holder(prep: Prepared, notes: list[str]) -> Callable[[Trajectory], float]:
    """The dynamic run's :attr:`~openimp.imp.dyndata.ValueLaws.on_accept`: at an accepted
    state (a trajectory of one step with accelerations and time) the ACCEL and FORCE
    values the VALUEs have read (:attr:`~openimp.imp.dyndata.ValueLaws.held`: value,
    slope from the accepted state before, time), ACCEL by :func:`motion_reader`, FORCE
    by the force analysis of that state in IMP's dynamic-mode convention
    (:func:`openimp.imp.run.forces.compute`).  Returns the longest next step that keeps
    the extrapolation's jump within :data:`LAG_TOL` (inf when none is needed)."""
    from openimp.dynamics.laws import LoadState
    from openimp.imp.run.forces import compute

    read = motion_reader(prep)
    laws = prep.built.dyn.laws
    assert laws is not None
    scale: dict[tuple[str, str, int], float] = {}
    said: list[bool] = []

    def on_accept(tr: Trajectory) -> float:
        t = float(tr.time[0])
        s = LoadState(tr, 0, t, 0.0, 0.0)
        forces = None
        want = math.inf
        for key, (v0, slope0, t0) in list(laws.held.items()):
            kind, name, comp = key
            if kind == "ACCEL":
                v = read(s, kind, name, comp)
            else:
                if forces is None:
                    forces = compute(prep, Solution(tr, tr.time), notes)
                v = forces.value(name, comp, 0)
            if not math.isfinite(v):  # a name or component that is not there: 0, told once
                told = (f"{kind}({name}, {comp}) in a VALUE is undefined at time {t:.6f} "
                        "(no such element or component); 0 is used for it")
                if told not in notes:
                    notes.append(told)
                v = 0.0
            h = t - t0
            if h <= 0.0:  # the start again (its loads settled): no history yet
                laws.held[key] = (v, slope0, t)
                continue
            big = scale[key] = max(scale.get(key, 0.0), abs(v), abs(v0))
            jump = abs(v - (v0 + slope0 * h))
            if jump > LAG_TOL * big:
                want = min(want, 0.9 * h * math.sqrt(LAG_TOL * big / jump))
            laws.held[key] = (v, (v - v0) / h, t)
        if laws.held and not said:  # once per run, not a search of the notes per step
            said.append(True)
            notes.append("ACCEL(...) and FORCE(...) in the data of springs, dampers and loads "
                         "are read a step behind while integrating, as IMP read its stored "
                         "current values: extrapolated from the last two accepted steps, which "
                         f"are kept short enough for the extrapolation to hold to {LAG_TOL:g} "
                         "of the value")
        return want

    return on_accept


def _integrate(prep: Prepared, span: np.ndarray, start: np.ndarray | None,
               notes: list[str], progress: Callable[[int, int], None] | None) -> Any:
    """:func:`openimp.simulate` over the output times ``span`` with the deck's initial
    conditions, motions and tolerances; VALUE laws read the state of each instant."""
    from openimp.dynamics.response import simulate

    q0, rates = initial_conditions(prep, float(span[0]), notes, start)
    laws = prep.built.dyn.laws
    if laws is not None:
        laws.times = None
        laws.resolve_at = None
        laws.resolve_state = state_resolver(prep)
        laws.halted = None
        laws.held.clear()
        laws.on_accept = holder(prep, notes)
    try:
        return simulate(prep.system, times=span, q=_start(prep, start, q0),
                        rates=rates or None, motion=motions(prep, notes) or None,
                        progress=_progress(progress, span), **options(prep, span, notes))
    finally:
        if laws is not None:
            laws.resolve_state = None
            laws.on_accept = None
            for m in laws.notes:
                if m not in notes:
                    notes.append(m)
            laws.notes.clear()


def _failed(exc: Exception, t0: float, empty: Trajectory, times: np.ndarray) -> Solution:
    """The solution of a run the integrator refused or could not start."""
    why = str(exc).rstrip(". ")
    if not why.startswith("t = "):
        why = f"the run stopped at the start (time {t0:.6f}): {why}"
    return Solution(empty, times[:0], f"{why}. No position was solved")


#: the run's length when DATA TIME asks for the start alone (s)
SINGLE_SPAN = 1e-3


def solve(prep: Prepared, times: np.ndarray, start: np.ndarray | None,
          notes: list[str], progress: Callable[[int, int], None] | None = None) -> Solution:
    """Integrate a dynamic run over its output times (see the module docstring)."""
    empty = Trajectory.empty(prep.system, tracker(prep.system))
    pre = Motions(prep, times, notes)  # the motions at the output times: RETURN, END, limits
    pre.fill(0, len(times), None)
    n = len(times) if pre.halt is None else pre.halt.step
    if n == 0:
        sol = Solution(empty, times[:0])
        record_halt(sol, prep, times, pre)
        return sol
    out_times = np.asarray(times[:n], dtype=float)
    # a single output (DATA TIME final 0): the start, from a run of one print step, at
    # most SINGLE_SPAN (only the start is kept; a print step of 1e100 s is not integrated)
    dt = float(prep.spec.state.time[2])
    span = out_times if n > 1 else np.array([out_times[0], out_times[0] + (
        min(dt, SINGLE_SPAN) if dt > 0.0 else SINGLE_SPAN)])
    laws = prep.built.dyn.laws
    try:
        res = _integrate(prep, span, start, notes, progress)
    except (InputError, AnalysisError) as exc:
        if laws is not None and laws.halted is not None:  # RETURN at the start
            sol = Solution(empty, times[:0])
            _value_stop(sol, laws.halted, 0)
            return sol
        return _failed(exc, float(out_times[0]), empty, times)
    except KeyboardInterrupt:
        sol = Solution(empty, times[:0], "interrupted by the user (Ctrl-C) before the first "
                       "output time")
        sol.interrupted = True
        return sol
    if n == 1 and res.nsteps > 1:
        res = res.steps(0, 1)
    notes.extend(run_notes(prep, res))
    _mobility(res, len(prep.drivers))
    k = res.nsteps
    message = ""
    halted = laws.halted if laws is not None else None
    if res.message and halted is None:
        kept = (f"the {k} output(s) before it are listed" if k else "no output was reached")
        message = f"{res.message.rstrip('. ')}; {kept}"
    sol = Solution(res, np.asarray(out_times[:k], dtype=float), message)
    sol.response = res
    sol.interrupted = bool(getattr(res, "interrupted", False))
    if halted is not None:
        _value_stop(sol, halted, k)
    elif pre.halt is not None and not message:
        record_halt(sol, prep, times, pre)
    return sol


def _value_stop(sol: Solution, halted: tuple[str, str], k: int) -> None:
    """RETURN or END evaluated by a VALUE of element data while integrating: the run
    stops there, as it does for one in a motion (not a failure)."""
    kind, text = halted
    value_stop(sol, kind, text,
               f"the {k} output(s) before it are listed" if k else "no output was reached")
