"""Preparing a run, whatever its mode: the model built and compiled, the inputs
checked, the request items listed, what will not be produced said before
anything is solved, and the output times.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from openimp.errors import InputError
from openimp.imp.expr import reads
from openimp.imp.interp import (
    Built,
    InputDef,
    Request,
    RunSpec,
    State,
    build_model,
    compile_built,
)
from openimp.kinematics import check_drivers, redundant_drivers
from openimp.limits import MAX_RESULT_BYTES, MAX_STEPS, number_text
from openimp.system import make_state


@dataclass
class Driver:
    """One SGC: an IMP joint variable and the openimp column it drives."""

    joint: str
    var: int  # IMP variable index (0-based)
    column: int  # openimp column in q
    sign: float
    kind: str  # angle or length
    inp: InputDef


@dataclass(frozen=True)
class DynInput:
    """The input of a DYNAMICS request, named as :func:`openimp.transfer_function` takes it."""

    kind: str  # force, load or motion
    key: str  # the System's element name or joint variable name
    label: str  # in IMP's words: force PUSH, load on joint A 1, motion of joint A 1
    unit: str  # the unit of the input as the deck gives it
    gain: float  # model-unit input per unit of the IMP input (sign, degrees)


@dataclass(frozen=True)
class DynOutput:
    """One output of a DYNAMICS request: a joint variable or a point component."""

    kind: str  # position, velocity or accel
    key: str  # the System's joint variable name or "point.x"
    label: str  # POSITION A 1, VELOCITY TIP X
    unit: str  # as the listings print it: deg for an angle's position
    gain: float  # IMP output per model-unit output (sign, degrees)


@dataclass
class DynSpec:
    """A checked DYNAMICS request: its input, outputs and (LIST, PLOT) frequencies."""

    input: DynInput
    outputs: list[DynOutput]
    w: np.ndarray | None = None  # rad/s


@dataclass
class Item:
    """One item of one request: what to tabulate."""

    request: Request
    kind: str  # joint, point, link, spring, damper, value, heading, modes, dynamics
    name: str
    dyn: DynSpec | None = None  # the input and outputs of a DYNAMICS request


@dataclass
class Prepared:
    """A validated run: built model, compiled system, drivers, request items."""

    spec: RunSpec
    built: Built
    system: Any
    drivers: list[Driver]
    items: list[Item]
    unsupported: list[Request]
    #: located messages of request items that are not produced (a FORCE request naming
    #: a spring or damper deleted at EXECUTE)
    skipped: list[str] = field(default_factory=list)
    #: kinematic mode: inputs the other inputs and the loops determine (consistent
    #: over-specification, which IMP accepted): not driven, checked at every position
    checks: list[Driver] = field(default_factory=list)


def _force_items(req: Request, state: State, built: Built, items: list[Item],
                 skipped: list[str], seen: set[tuple[str, str, str, str]]) -> None:
    """The items of a FORCE request: joints, springs and dampers (docs/imp-language.md §9)."""
    springs = state.extras.get("springs", {})
    dampers = state.extras.get("dampers", {})
    model = built.model
    deleted = built.dyn.deleted
    names: list[str] = []
    if req.all:
        names += list(model.joints)
        names += [n for n in springs if ("spring", n) not in deleted]
        names += [n for n in dampers if ("damper", n) not in deleted]
    names += req.names
    for n in names:
        if n in model.joints:
            kind = "joint"
        elif n in springs:
            kind = "spring"
        elif n in dampers:
            kind = "damper"
        else:
            what = ("a point" if n in state.points else "a link" if n in state.links else
                    "a force element" if n in state.extras.get("forces", {}) else
                    "a torque element" if n in state.extras.get("torques", {}) else
                    "not defined by EXECUTE")
            raise InputError(f"{req.keyword} statement: {n} is {what}; {req.family} FORCE "
                             "takes joints, springs and dampers", req.where)
        if (kind, n) in deleted:
            skipped.append(f"{req.where[0]}:{req.where[1]}: {req.keyword} ({n}) is not "
                           f"produced: {deleted[(kind, n)]}")
            continue
        key = (req.family, req.quantity, kind, n)
        if key not in seen:
            seen.add(key)
            items.append(Item(req, kind, n))


def _request_items(state: State, built: Built
                   ) -> tuple[list[Item], list[Request], list[str]]:
    items: list[Item] = []
    unsupported: list[Request] = []
    skipped: list[str] = []
    seen: set[tuple[str, str, str, str]] = set()
    springs = state.extras.get("springs", {})
    dampers = state.extras.get("dampers", {})
    model = built.model
    for req in state.requests:
        q = req.quantity
        if q == "DYNAMICS":  # checked once the input motions are known (dynamics_items)
            continue
        if q == "FREQUENCY":
            key = (req.family, q, "modes", "")
            if key not in seen:
                seen.add(key)
                items.append(Item(req, "modes", "modes"))
            continue
        if q == "FORCE":
            _force_items(req, state, built, items, skipped, seen)
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
            else:
                why = (f"point {n} is on a link that is in no joint, so it was deleted at "
                       "EXECUTE" if n in state.points else
                       f"{n} is not a joint, point, link, spring or damper defined by EXECUTE")
                if state.strict:
                    raise InputError(f"{req.keyword} statement: {why}", req.where)
                # IMP said so and listed the rest (an item deleted earlier, a typo)
                skipped.append(f"{req.where[0]}:{req.where[1]}: {req.keyword} ({n}) is not "
                               f"produced: {why} (openimp check --strict refuses it)")
                continue
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
    return items, unsupported, skipped


# ----------------------------------------------------------------- FREQUENCY, DYNAMICS
class _IgnoredError(Exception):
    """Why a DYNAMICS request is ignored (IMP: msg, and the request is skipped)."""


#: what a DYNAMICS output kind is called by openimp.transfer_function
_OUT_KIND = {"POSITION": "position", "VELOCITY": "velocity", "ACCEL": "accel"}
#: the units listings print (docs/imp-language.md §2.3): degrees for an angle's position only
_OUT_UNIT = {("angle", "POSITION"): "deg", ("angle", "VELOCITY"): "rad/s",
             ("angle", "ACCEL"): "rad/s^2", ("length", "POSITION"): "length",
             ("length", "VELOCITY"): "length/s", ("length", "ACCEL"): "length/s^2"}


def frequency_grid(w0: float, wf: float, winc: float) -> np.ndarray:
    """The frequencies (rad/s) of LIST and PLOT DYNAMICS (docs/imp-language.md §9): w0, then
    w0 + winc, then logarithmic steps of the same ratio (w0 + winc) / w0 while
    they stay below wf, and wf as the last one.  Raises ``_IgnoredError`` unless
    w0, wf, winc > 0 and wf > w0, or when the grid would exceed ``MAX_STEPS`` rows."""
    if not (w0 > 0 and wf > 0 and winc > 0):
        raise _IgnoredError(f"the frequencies w0, wf, winc must all be > 0 rad/s; they are "
                       f"{number_text(w0)}, {number_text(wf)}, {number_text(winc)}")
    if not wf > w0:
        raise _IgnoredError(f"the final frequency wf = {number_text(wf)} must be greater than the "
                       f"first w0 = {number_text(w0)}")
    count = math.log(wf / w0) / math.log1p(winc / w0)
    if not count <= MAX_STEPS - 2:  # also a ratio that rounds to 1
        raise _IgnoredError(f"w0 = {number_text(w0)} to wf = {number_text(wf)} in steps of ratio "
                       f"(w0 + winc) / w0 = 1 + {number_text(winc / w0)} is more than "
                       f"{MAX_STEPS} frequencies (limit MAX_STEPS); give a larger winc")
    n = math.floor(count + 1e-9)
    w = w0 * ((w0 + winc) / w0) ** np.arange(n + 1)
    if w[-1] < wf * (1.0 - 1e-9):
        return np.append(w, wf)
    w[-1] = wf
    return w


def _no_fgc(freedom: tuple[int, int], ndrivers: int) -> str:
    return (f"the run has no free generalized coordinate (mobility {freedom[0]} at the "
            f"starting posture, {ndrivers} input motion(s)): every coordinate is specified, "
            "so nothing can vibrate")


def _dyn_input(fields: dict[str, Any], state: State, built: Built, system: Any,
               drivers: list[Driver]) -> DynInput:
    """The input of a DYNAMICS request (FORCE element; FORCE, joint, variable; MOTION,
    joint, variable), or ``_IgnoredError``."""
    kind, name, nin = fields["input"], fields["namein"], int(fields["nin"])
    ex = state.extras
    element = ("force" if name in ex.get("forces", {}) else
               "torque" if name in ex.get("torques", {}) else None)
    if kind == "FORCE" and element is not None and (nin == 0 or name not in built.joints):
        if nin != 0:
            raise _IgnoredError(f"{element.upper()} element {name} takes nin = 0, not {nin}")
        if (element, name) in built.dyn.deleted:
            raise _IgnoredError(built.dyn.deleted[(element, name)])
        return DynInput("force", built.dyn.names[(element, name)], f"{element} {name}",
                        "force" if element == "force" else "force*length", 1.0)
    if name not in built.joints:
        what = ("a FORCE or TORQUE element or a joint" if kind == "FORCE" else
                "a joint with an input motion")
        raise _IgnoredError(f"the input {kind} {name}: {name} is not {what} defined by EXECUTE")
    ij = built.joints[name][0]
    if not 1 <= nin <= ij.nvar:
        raise _IgnoredError(f"the input {kind} {name} {nin}: joint {name} ({ij.keyword}) has "
                       + (f"variables 1 to {ij.nvar}" if ij.nvar > 1 else
                          "variable 1" if ij.nvar else "no variable")
                       + "; nin gives the joint variable")
    d = ij.drive[nin - 1]
    if d is None:
        raise _IgnoredError(f"the input {kind} {name} {nin}: variable {nin} of a {ij.keyword} "
                       "joint cannot be an input (openimp has no load or motion on it)")
    key = system.var_names[system.joint_vars(name).start + d[0]]
    angle = ij.var_kinds[nin - 1] == "angle"
    driven = any(dr.joint == name and dr.var == nin - 1 for dr in drivers)
    if kind == "FORCE":
        if driven:
            raise _IgnoredError(f"joint {name} {nin} is an input motion (SGC) of this run, locked, "
                           f"so a load on it moves nothing; use MOTION, {name}, {nin}")
        return DynInput("load", key, f"load on joint {name} {nin}",
                        "force*length" if angle else "force", d[1])
    if not driven:
        raise _IgnoredError(f"the input MOTION {name} {nin}: joint {name} {nin} is not an input "
                       "motion (SGC) of this run; give it DATA POSITION or DATA MOTION, or "
                       "use a FORCE input")
    return DynInput("motion", key, f"motion of joint {name} {nin}",
                    "deg" if angle else "length", d[1] * (math.pi / 180.0 if angle else 1.0))


def _dyn_outputs(kind: str, name: str, state: State, built: Built, system: Any
                 ) -> tuple[list[DynOutput], list[str]]:
    """The outputs of one pair ``kind, name`` (every variable of a joint, X Y Z of a
    point) and why some or all of it is dropped."""
    okind = _OUT_KIND[kind]
    if name in built.joints:
        ij = built.joints[name][0]
        start = system.joint_vars(name).start
        outs, why = [], []
        for k, d in enumerate(ij.drive):
            if d is None:
                why.append(f"the output {kind} {name} {k + 1} is dropped: variable {k + 1} of "
                           f"a {ij.keyword} joint is not available as an output")
                continue
            vk = ij.var_kinds[k]
            gain = d[1] * (180.0 / math.pi if vk == "angle" and kind == "POSITION" else 1.0)
            outs.append(DynOutput(okind, system.var_names[start + d[0]], f"{kind} {name} {k + 1}",
                                  _OUT_UNIT[(vk, kind)], gain))
        if not ij.nvar:
            why.append(f"the output {kind} {name} is dropped: joint {name} (RIGID) has no "
                       "variable")
        return outs, why
    if name in built.model.points:
        return [DynOutput(okind, f"{name}.{ax.lower()}", f"{kind} {name} {ax}",
                          _OUT_UNIT[("length", kind)], 1.0) for ax in "XYZ"], []
    what = ("a point on a link that is in no joint (deleted at EXECUTE)" if name in state.points
            else "not a joint or point defined by EXECUTE")
    return [], [f"the output {kind} {name} is dropped: {name} is {what}"]


def dynamics_items(state: State, built: Built, system: Any, drivers: list[Driver],
                   freedom: tuple[int, int], items: list[Item], skipped: list[str]) -> None:
    """The items of the DYNAMICS requests of a kinematic run, checked as IMP does
    (docs/imp-language.md §9): a bad frequency range, input, namein or nin, or no free
    generalized coordinate, ignores the request with a message; a bad output
    pair is dropped with a message.  A FREQUENCY request with no FGC is kept
    (IMP says so at each position) and reported."""
    nd = len(drivers)
    for it in items:
        if it.kind == "modes" and freedom[1] == 0:
            w = it.request.where
            skipped.append(f"{w[0]}:{w[1]}: {it.request.keyword} is not produced: "
                           + _no_fgc(freedom, nd))
    for req in state.requests:
        if req.quantity != "DYNAMICS":
            continue
        f = req.statement.fields
        loc = f"{req.where[0]}:{req.where[1]}: {req.keyword}"
        try:
            w = frequency_grid(f["w0"], f["wf"], f["winc"]) if "w0" in f else None
            inp = _dyn_input(f, state, built, system, drivers)
            if freedom[1] == 0:
                raise _IgnoredError(_no_fgc(freedom, nd))
        except _IgnoredError as why:
            skipped.append(f"{loc} is not produced: {why}")
            continue
        outputs: list[DynOutput] = []
        for kind, name in f["pairs"]:
            outs, why = _dyn_outputs(kind, name, state, built, system)
            outputs += outs
            skipped.extend(f"{loc}: {text}" for text in why)
        if outputs:
            items.append(Item(req, "dynamics", inp.label, DynSpec(inp, outputs, w)))
        else:
            skipped.append(f"{loc} is not produced: none of its output pairs can be computed")


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
    items, unsupported, skipped = _request_items(state, built)
    posed = spec.mode in ("kinematic", "static", "dynamic")
    drivers = _drivers(state, built, system) if posed else []
    if spec.mode == "dynamic":
        _check_dynamic_inputs(state, built, drivers)
    freedom = (0, 0)
    checks: list[Driver] = []
    if drivers:
        cols = np.array([d.column for d in drivers], np.int64)
        if len(set(cols.tolist())) != len(cols):  # pragma: no cover - one input per joint
            raise InputError("EXECUTE: a joint variable is driven twice", spec.where)
        ptol = state.tolerance("SYSTEM")[0]
        drop = redundant_drivers(system, cols, ptol) if spec.mode == "kinematic" else []
        if drop and len(drop) < len(drivers):  # IMP assembled consistent ones: checked
            checks = [drivers[i] for i in drop]
            drivers = [d for i, d in enumerate(drivers) if i not in drop]
            cols = np.array([d.column for d in drivers], np.int64)
        try:
            freedom = _freedom(system, cols, ptol)
        except InputError as exc:
            where = drivers[-1].inp.where
            raise InputError(f"EXECUTE: {exc} (the input motions are given by DATA POSITION / "
                             "DATA MOTION statements)", where) from None
    elif posed:
        freedom = _freedom(system, np.zeros(0, np.int64), state.tolerance("SYSTEM")[0])
    if posed:
        dynamics_items(state, built, system, drivers, freedom, items, skipped)
    prep = Prepared(spec, built, system, drivers, items, unsupported, skipped, checks)
    if posed:
        _check_size(prep)
    spec._prepared = prep  # type: ignore[attr-defined]
    return prep



#: the quantities of the model a VALUE may read
_MODEL = ("POSITION", "VELOCITY", "ACCEL", "FORCE")


def reads_model(state: State, drivers: list[Driver]) -> bool:
    """True when a DATA MOTION VALUE reads model quantities (step-by-step driving)."""
    for d in drivers:
        if d.inp.kind == "MOTION":
            m = d.inp.motions[d.var]
            if isinstance(m, str) and reads([m], state.values, _MODEL):
                return True
    return False


def _check_dynamic_inputs(state: State, built: Built, drivers: list[Driver]) -> None:
    """The inputs of a dynamic run that only the run's model can check: a DATA MOTION
    VALUE must be a function of time (the integrator is given the motions in advance),
    and every VALUE of a DATA IC must be defined by EXECUTE."""
    for d in drivers:
        if reads_model(state, [d]):
            raise InputError(f"DATA MOTION statement: VALUE {d.inp.motions[d.var]} of joint "
                             f"{d.joint} reads the model (POSITION, VELOCITY, ACCEL or FORCE); "
                             "in dynamic mode an input motion is a function of time only "
                             "(T), which openimp integrates with", d.inp.where)
    for joint, ic in state.extras.get("ics", {}).items():
        if joint not in built.joints:
            continue
        for pair in ic["pairs"]:
            for x in pair:
                if isinstance(x, str) and x not in state.values:
                    raise InputError(f"DATA IC statement: VALUE {x} is not defined by EXECUTE; "
                                     f"define it with VALUE ({x}) = ... before EXECUTE",
                                     ic["where"])


def _freedom(system: Any, cols: np.ndarray, pivot_tol: float) -> tuple[int, int]:
    """(mobility, number of FGCs) at the starting posture with the joint variables
    ``cols`` specified (raises InputError as :func:`check_drivers` does)."""
    start = make_state(system)
    start.sgc[cols] = True
    free, rank, _ = check_drivers(system, start, cols, pivot_tol, True)
    return system.nq - rank, len(free)


def redundancy_notes(prep: Prepared) -> list[str]:
    """One located message per over-specified input of a kinematic run (``prep.checks``):
    what is done with it.  ``openimp check`` and the run say the same."""
    out = []
    for d in prep.checks:
        w = d.inp.where
        stmt = "DATA POSITION" if d.inp.kind == "POSITION" else "DATA MOTION"
        out.append(f"{w[0]}:{w[1]}: {stmt}: over-specified input: joint {d.joint} variable "
                   f"{d.var + 1} is determined by the other inputs and the loops; it is not "
                   "driven but checked at every position, and a position where it disagrees "
                   "is skipped (IMP's assembly failed there)")
    return out


def not_produced(spec: RunSpec) -> tuple[str | None, list[str]]:
    """What one EXECUTE will not produce, found before anything is solved.

    Returns the reason why the whole run produces nothing (None: every mode is
    built), and one located message per request that
    the run cannot answer (FORCE of a spring or damper deleted at EXECUTE; a
    FREQUENCY or DYNAMICS request with no free generalized coordinate, a bad
    input, output pair or frequency range).  The run reports
    exactly these (``Run.failure``, ``Run.unsupported``) and ``openimp check``
    lists them, so the two never disagree.  Raises :class:`InputError` as
    :func:`validate` does.
    """
    prep = validate(spec)
    return None, list(prep.skipped)


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
        bodies, points = needs(prep, n)
        raise InputError(f"EXECUTE: the run would hold {need / 2**20:.0f} MB of results ({n} "
                         f"steps of {len(bodies)} links and {len(points)} points), more than "
                         f"{MAX_RESULT_BYTES / 2**20:.0f} MB (limit MAX_RESULT_BYTES); use "
                         "fewer steps (DATA TIME, DATA POSITION) or request fewer items",
                         prep.spec.where)


def stepped(state: State) -> bool:
    """True when no DATA TIME gives real times: IMP's assumed time is the step
    number (counted on after EXECUTE HOLD, back to 0 at RESET), so tables are
    labelled ``Step``; the rates stay per second.  False with IMP's listing
    (``REMARK OPENIMP LISTING = IMP``): IMP labelled the step number Time."""
    return state.time is None and not state.imp_listing


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


#: every point of the model is kept (for VALUEs and graphics) while points x steps stay below
ALL_POINTS_BUDGET = 2_000_000


#: bytes of results per step: q, rates (3 nq), per body T, W, A (48), per point p, v, a (9)
_FLOATS_PER_BODY, _FLOATS_PER_POINT = 48, 9


def needs(prep: Prepared, nsteps: int = 1) -> tuple[list[str], list[str]]:
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
            if it.request.quantity in ("FORCE", "POSITION"):  # (PRINT: the second origin)
                bodies.add(model.joints[it.name].body2)
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
    bodies, points = needs(prep, nsteps)
    per_step = (3 * prep.system.nq + 4 + _FLOATS_PER_BODY * len(bodies)
                + _FLOATS_PER_POINT * len(points))
    per_table = sum(8 for _ in prep.items)  # a few columns per request item
    return 8 * nsteps * (per_step + per_table)
