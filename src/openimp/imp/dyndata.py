"""IMP's mass, gravity, spring, damper and load data put on the openimp model.

At EXECUTE the interpreter builds a :class:`~openimp.model.Model` from what the
deck defined (:func:`openimp.imp.interp.build_model`); this module adds what a
force analysis needs (docs/imp-language.md §7.3, §8.4, §8.5, §13; the mass
data: docs/imp.md, "Mass data"):

* ``DATA MASS (link, joint|LINK) = m; u,v,w``: a point mass at its centre, given
  in the joint frame on that link (or the body frame); ``DATA INERTIA (link,
  joint|LINK) = Ixx, Iyy, Izz, Ixy, Ixz, Iyz``: the second moments about the
  *origin* of the named frame, on its axes, products ``+integral(x y dm)``.  It
  replaces the point-mass second moments of DATA MASS and keeps the mass and
  the first moments (docs/imp-language.md §2.4, settled).  Both were
  multiplied by UNIT (MASS) when read (default exactly 1/386.088: lbm with lbf, in, s);
* ``DATA GRAVITY``: the gravity vector, global axes;
* ``SPRING``, ``DAMPER``, ``FORCE``, ``TORQUE`` elements with their DATA
  statements; an element without data is deleted with IMP's message;
* ``DATA SPRING / DAMPER / FORCE / TORQUE`` on joints: one entry per IMP joint
  variable, NONE for none.  A rotational rate given as a number is per
  *degree* with the free angle in degrees (converted here to radians); a rate
  or free position given by a VALUE is per radian / in radians;
* ``DATA DENSITY``: IMP solids come from solid files (SOLID READ), which
  openimp does not read yet, so their mass is not computed (a message says
  so when the statement is read).

A VALUE name in place of a number becomes a load law (:data:`openimp.model.Law`)
evaluated at every step of the run by :class:`ValueLaws`: the runner hands it
the resolver of the solved step (:attr:`ValueLaws.resolve_at`).  A VALUE that
is undefined at a step counts as 0, with a located message.

Every problem is reported at the statement to change: input errors (a
negative mass, an unknown VALUE, more entries than the joint has variables, a
negative free length) as :class:`~openimp.errors.InputError` located at
``file:line``; what IMP only warned about or did without complaint (an
element without data, mass data no rigid body has, coincident direction
points) and what openimp cannot do yet (a spring on a SPHERE, FLAT or OPEN
angle: left out) as ``file:line:`` messages of the run, which goes on.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from openimp import massprops
from openimp.errors import AnalysisError, InputError
from openimp.imp.expr import SimulationStop, if_tests, reads
from openimp.model import Model

__all__ = ["UNIT_MASS_DEFAULT", "DynamicData", "ValueLaws", "add_dynamic_data",
           "inertia_tensor", "joint_data"]

#: IMP's default UNIT (MASS): one lbm in lbf s^2/in, exactly 1/386.088
#: (docs/imp-language.md §2.4)
UNIT_MASS_DEFAULT = 1.0 / 386.088

Where = tuple[str, int]
Datum = float | str | None

#: per kind: the label of messages, the DATA statement, the store of the element data
_KINDS = {
    "springs": ("Spring", "DATA SPRING", "spring_data"),
    "dampers": ("Damper", "DATA DAMPER", "damper_data"),
    "forces": ("Force", "DATA FORCE", "load_data"),
    "torques": ("Torque", "DATA TORQUE", "load_data"),
}


def _loc(where: Where | None) -> str:
    return f"{where[0]}:{where[1]}: " if where is not None and where[1] > 0 else ""


def inertia_tensor(inertia: tuple[float, ...]) -> np.ndarray:
    """The engineering inertia tensor (off-diagonals minus the products) of IMP's
    ``Ixx, Iyy, Izz, Ixy, Ixz, Iyz`` (products given as ``+integral(x y dm)``)."""
    ixx, iyy, izz, ixy, ixz, iyz = (float(x) for x in inertia)
    return np.array([[ixx, -ixy, -ixz], [-ixy, iyy, -iyz], [-ixz, -iyz, izz]])


@dataclass
class ValueLaws:
    """VALUE expressions used as element data, evaluated per step during a run.

    The runner sets :attr:`resolve_at` (step -> the VALUE resolver of that solved
    step) and :attr:`times` before the force analysis; messages about undefined
    values go to :attr:`notes` (each once).  While a time response is integrated
    the dynamic runner sets :attr:`resolve_state` instead (the load state of the
    moment -> its resolver), so that a VALUE may read the posture.
    """

    values: dict[str, Any]
    resolve_at: Callable[[int], Any] | None = None
    times: np.ndarray | None = None
    resolve_state: Callable[[Any], Any] | None = None
    notes: list[str] = field(default_factory=list)
    #: while integrating: (RETURN or END, where and when) of the first VALUE that
    #: evaluated one; the run stops there (:func:`openimp.imp.run.dynamic.solve`)
    halted: tuple[str, str] | None = None
    #: while integrating: ACCEL(...) and FORCE(...) read a step behind, as IMP read its
    #: stored current values: (kind, name, comp) -> (value at the last accepted state,
    #: its slope from the one before, that state's time) (0 before the first); the
    #: keys are those the VALUEs have read
    held: dict[tuple[str, str, int], tuple[float, float, float]] = field(default_factory=dict)
    #: set by the dynamic runner: the held values at an accepted state (a one-step
    #: trajectory with accelerations) into :attr:`held`; returns the longest next step
    on_accept: Callable[[Any], float] | None = None
    _told: set[tuple[str, str]] = field(default_factory=set)

    def accept(self, trajectory: Any) -> float:
        """A time response accepted a state (the ``accepted`` hook of the laws whose
        VALUEs read ACCEL or FORCE): the held values are updated there; the longest
        next step their extrapolation allows."""
        return math.inf if self.on_accept is None else self.on_accept(trajectory)

    def value(self, name: str, step: int, label: str, where: Where,
              t: float | None = None, state: Any = None) -> float:
        """The VALUE ``name`` at ``step`` (0 when undefined, with a message).  Without
        :attr:`resolve_at` (a search, not a solved motion) only TIME is known: ``t``;
        with :attr:`resolve_state`, what the load ``state`` knows."""
        resolve = self.resolver(step, t, state)
        why: list[str] = []
        try:
            v = float(self.values[name].evaluate(self.values, resolve, notes=why))
        except SimulationStop as stop:
            if self.resolve_state is not None and state is not None:
                # a time response: RETURN (END) stops it there, as in a motion
                text = (f"{stop.where[0]}:{stop.where[1]}: VALUE {name} ({label}) evaluated "
                        f"{stop.kind} at time {t or 0.0:.6f}")
                if self.halted is None:
                    self.halted = (stop.kind, text)
                raise AnalysisError(text) from None
            v = math.nan
            why.append(f"{stop.where[0]}:{stop.where[1]}: it evaluates {stop.kind}, which "
                       "stops nothing here (the data of a load is not a motion)")
        if math.isfinite(v):
            return v
        key = (name, label)
        if key not in self._told:
            self._told.add(key)
            if t is None:
                t = self.times[step] if self.times is not None and step < len(self.times) \
                    else step
            self.notes.append(f"{_loc(where)}VALUE {name} ({label}) is undefined at time "
                              f"{t:.6f}; 0 is used for it there" + (f" ({why[0]})" if why
                                                                    else ""))
        return 0.0

    def switched(self, law: Callable[[Any], float], data: list[Datum]) -> Callable[[Any], float]:
        """``law`` with the switching functions of the IFs its VALUE ``data`` reach
        (:func:`~openimp.imp.expr.if_tests`): the time response locates the instant
        one of them crosses zero, as a BumpStop's contact (a tyre that lands and lifts
        off, a damper whose rate changes with its direction).  ``law`` itself when they
        have no IF."""
        names = [d for d in data if isinstance(d, str)]
        tests = if_tests(names, self.values)
        lagged = reads(names, self.values, ("ACCEL", "FORCE"))
        if not tests and not lagged:
            return law
        out = SwitchedLaw(law, self, tests)
        if lagged:  # told of every accepted state, to hold ACCEL and FORCE a step behind
            out.accepted = self.accept
        return out

    def resolver(self, step: int, t: float | None, state: Any) -> Any:
        """The VALUE resolver at ``step``: the solved motion's (:attr:`resolve_at`),
        else what the load ``state`` knows (:attr:`resolve_state`), else the time ``t``
        alone; None without any."""
        if self.resolve_at is not None:
            return self.resolve_at(step)
        if self.resolve_state is not None and state is not None:
            return self.resolve_state(state)
        if t is None:
            return None

        def resolve(kind: str, _name: str | None, _comp: int, t: float = t) -> float:
            return t if kind == "TIME" else math.nan

        return resolve

    def term(self, datum: Datum, scale: float, label: str, where: Where
             ) -> Callable[[Any], float]:
        """A function of the load state: the number ``datum * scale`` or the VALUE
        ``datum`` (already per radian / in radians: not scaled)."""
        if isinstance(datum, str):
            return lambda s, n=datum: self.value(n, s.step, label, where, s.t, s)
        c = 0.0 if datum is None else float(datum) * scale
        return lambda s: c


class SwitchedLaw:
    """A load law of VALUE data and the switching functions of their IFs' test values
    (``switch(state)`` -> (nswitch,); an undefined test counts as positive)."""

    accepted: Callable[[Any], float] | None = None

    def __init__(self, law: Callable[[Any], float], laws: ValueLaws,
                 tests: list[tuple[Any, Any]]) -> None:
        self.law = law
        self.laws = laws
        self.tests = tests
        self.nswitch = len(tests)

    def __call__(self, state: Any) -> float:
        return self.law(state)

    def switch(self, state: Any) -> np.ndarray:
        resolve = self.laws.resolver(state.step, state.t, state)
        out = np.empty(self.nswitch)
        for i, (expr, node) in enumerate(self.tests):
            v = expr.evaluate_at(node, self.laws.values, resolve)
            out[i] = v if math.isfinite(v) else 1.0
        return out


@dataclass
class DynamicData:
    """What :func:`add_dynamic_data` put on a model, for the runner and requests.

    ``laws``: the VALUE laws (None when no datum is a VALUE); ``deleted``: the
    springs, dampers, forces and torques deleted at EXECUTE, (kind, name) ->
    why; ``names``: (kind, name) -> the model's element name (a spring and a
    damper may share a name in IMP; the model's elements may not).
    """

    laws: ValueLaws | None = None
    deleted: dict[tuple[str, str], str] = field(default_factory=dict)
    names: dict[tuple[str, str], str] = field(default_factory=dict)


def _value_names(data: list[Any], values: dict[str, Any], what: str, where: Where) -> bool:
    """True when a datum is a VALUE name; an undefined one is an input error."""
    used = False
    for d in data:
        if isinstance(d, str):
            if d not in values:
                raise InputError(f"{what}: VALUE {d} is not defined by EXECUTE; define it "
                                 f"with VALUE ({d}) = ... before EXECUTE", where)
            used = True
    return used


def _frame(state: Any, link: str, joint: str | None, what: str, where: Where) -> np.ndarray:
    """Global 4x4 of the frame a mass datum is given in: the IMP joint frame on
    ``link`` (or its body frame when ``joint`` is None), at the modeling posture."""
    T = state.links[link].frame
    if joint is None:
        return np.asarray(T, float)
    jd = state.joints.get(joint)
    if jd is None:
        raise InputError(f"{what}: joint {joint} no longer exists at EXECUTE (it was "
                         "deleted or redefined); give the data in a joint frame that exists "
                         "or in the link frame (LINK)", where)
    L = jd.local1 if link == jd.link1 else jd.local2
    return np.asarray(T @ (np.eye(4) if L is None else L), float)


def _masses(state: Any, model: Model, messages: list[str]) -> None:
    masses = state.extras.get("masses", {})
    inertias = state.extras.get("inertias", {})
    for link, md in masses.items():
        if link not in model.body_frames:
            continue  # a link in no joint: deleted at EXECUTE with its data
        where = md["where"]
        joint = None if md["frame"] == "LINK" else md["frame"]
        G = _frame(state, link, joint, f"DATA MASS ({link})", where)
        c = (G @ np.append(np.asarray(md["center"], float), 1.0))[:3]
        inert = inertias.get(link)
        if inert is None:  # a point mass: nothing to check
            model.add_mass(link, md["mass"], center=c)
            continue
        at = inert["where"]
        ij = None if inert["frame"] == "LINK" else inert["frame"]
        H = _frame(state, link, ij, f"DATA INERTIA ({link})", at)
        I = inertia_tensor(inert["inertia"])
        try:
            model.add_mass(link, md["mass"], center=c, inertia=I, axes=H[:3, :3],
                           about="origin", origin=H[:3, 3])
        except InputError as exc:
            raise InputError(f"DATA INERTIA ({link}): {exc}", at) from None
        scale = float(np.max(np.abs(I))) + md["mass"] * float(np.sum((c - H[:3, 3]) ** 2))
        for text in _implausible(model.masses[link], scale):
            messages.append(f"{_loc(at)}warning: DATA INERTIA ({link}): {text}; IMP uses such "
                            "data as given, and so does openimp")


def _implausible(J: np.ndarray, scale: float) -> list[str]:
    """What no rigid body has in the pseudo-inertia ``J``: centroidal principal moments
    that are negative or break the triangle inequality (tolerance 1e-9 of ``scale``,
    the size of the data given)."""
    m, _c, Ic = massprops.centroidal(J)
    if m <= 0.0:
        return ([] if scale == 0.0 else
                ["the link has moments of inertia but no mass"])
    p = np.sort(np.linalg.eigvalsh(Ic))
    tol = 1e-9 * max(scale, 1e-300)
    shown = ", ".join(f"{float(x):.6g}" for x in p)
    out = []
    if p[0] < -tol:
        out.append(f"the principal moments about the centre of mass are {shown}: one is "
                   "negative, which no rigid body has (the inertia is about the origin of the "
                   "named frame, products +integral(x y dm); check the frame, the signs and "
                   "UNIT (MASS))")
    elif p[0] + p[1] < p[2] - tol:
        out.append(f"the principal moments about the centre of mass are {shown}: they break "
                   "the triangle inequality I1 + I2 >= I3, which every rigid body satisfies "
                   "(the inertia is about the origin of the named frame, products "
                   "+integral(x y dm))")
    return out


def _element_name(model: Model, kind: str, name: str, names: dict[tuple[str, str], str]
                  ) -> str:
    label = kind[:-1]
    key = name if name not in model.elements else f"{label} {name}"
    names[(label, name)] = key
    return key


def _negative_damper(c: Any, what: str, where: Where, messages: list[str]) -> None:
    """A located warning for a negative damper coefficient (kept: a self-excited model
    may mean it), which feeds energy into the motion."""
    if c is not None and float(c) < 0.0:
        messages.append(f"{_loc(where)}warning: {what}: the coefficient {float(c):g} is "
                        "negative: the damper feeds energy in and the motion grows; a time "
                        "response stops when its steps fall below 1e-6 of the print step")


def _one(data: list[Any], label: str, stmt: str, name: str, where: Where) -> Any:
    if len(data) > 1:
        raise InputError(f"{stmt} ({name}): {label.lower()} {name} takes one "
                         + ("pair (rate, free length)" if stmt == "DATA SPRING" else "value")
                         + f"; {len(data)} are given", where)
    return data[0]


def _elements(state: Any, model: Model, laws: ValueLaws, dd: DynamicData,
              messages: list[str]) -> bool:
    used_values = False
    values = state.values
    ex = state.extras
    for kind, (label, stmt, store) in _KINDS.items():
        for name, el in ex.get(kind, {}).items():
            ewhere = el["where"]
            missing = [p for p in el["points"] if p not in model.points]
            if missing:
                why = (f"{label} {name} uses point {missing[0]}, which is on a link in no "
                       "joint (deleted at EXECUTE); it is deleted.")
                dd.deleted[(kind[:-1], name)] = why
                messages.append(_loc(ewhere) + why)
                continue
            if kind == "torques" and el["link"] not in model.body_frames:
                why = f"{label} {name} acts on link {el['link']}, which is in no joint; it is " \
                      "deleted."
                dd.deleted[(kind[:-1], name)] = why
                messages.append(_loc(ewhere) + why)
                continue
            data = ex.get(store, {}).get(name)
            if data is None:
                why = f"{label} {name} has no {stmt}; it is deleted."
                dd.deleted[(kind[:-1], name)] = why
                messages.append(_loc(ewhere) + why)
                continue
            where = data["where"]
            key = _element_name(model, kind, name, dd.names)
            what = f"{stmt} ({name})"
            lab = f"{stmt} of {label.lower()} {name}"
            try:
                if kind == "springs":
                    rate, free = _one(data["pairs"], label, stmt, name, where)
                    p1, p2 = el["points"]
                    if _value_names([rate, free], values, what, where):
                        used_values = True
                        k = laws.term(rate, 1.0, lab, where)
                        f0 = laws.term(free, 1.0, lab, where)
                        model.add_spring(key, p1, p2, law=laws.switched(
                            lambda s, k=k, f0=f0: k(s) * (s.x - f0(s)), [rate, free]))
                    elif rate is None:  # NONE: no stiffness
                        model.add_spring(key, p1, p2, 0.0)
                    else:
                        model.add_spring(key, p1, p2, float(rate), float(free))
                elif kind == "dampers":
                    c = _one(data["coefficients"], label, stmt, name, where)
                    p1, p2 = el["points"]
                    if _value_names([c], values, what, where):
                        used_values = True
                        cc = laws.term(c, 1.0, lab, where)
                        model.add_damper(key, p1, p2, law=laws.switched(
                            lambda s, cc=cc: cc(s) * s.xd, [c]))
                    else:
                        _negative_damper(c, what, where, messages)
                        model.add_damper(key, p1, p2, 0.0 if c is None else float(c))
                else:
                    f = _one(data["loads"], label, stmt, name, where)
                    law = None
                    if _value_names([f], values, what, where):
                        used_values = True
                        law = laws.switched(laws.term(f, 1.0, lab, where), [f])
                    mag = 0.0 if f is None or law is not None else float(f)
                    pa, pb = el["points"][-2:]
                    if kind == "forces":
                        model.add_force(key, el["points"][0], mag, along=(pa, pb), law=law)
                    else:
                        model.add_torque(key, el["link"], mag, along=(pa, pb), law=law)
                    gap = float(np.linalg.norm(model.points[pa].xyz - model.points[pb].xyz))
                    if gap < 1e-12:
                        messages.append(f"{_loc(ewhere)}warning: the direction points {pa} and "
                                        f"{pb} of {label.lower()} {name} coincide at the design "
                                        "position: the load has no direction there and is "
                                        "skipped wherever they coincide")
            except InputError as exc:
                if exc.where is not None:
                    raise
                msg = str(exc)
                if ": " in msg and msg.split(": ", 1)[0].startswith(kind[:-1]):
                    msg = msg.split(": ", 1)[1]
                raise InputError(f"{what}: {msg}", where) from None
    return used_values


#: kinds whose angles are measured from a rotation, so a free angle means itself modulo
#: a turn (IMP's Cardan and polar angles: -180 and 180 deg are one posture; the
#: compiled model takes the turn nearest the drawing, JointLoad.periodic)
_TURNED = ("gimbal", "open_cardan", "flat_polar")


#: the DATA statements that load joint variables: (their store in the interpreter's
#: extras, the statement, the key of their entries, the elements that take a datum
#: of the same name instead)
_JOINT_DATA = (("spring_data", "DATA SPRING", "pairs", ("springs",)),
               ("damper_data", "DATA DAMPER", "coefficients", ("dampers",)),
               ("load_data", "DATA FORCE", "loads", ("forces", "torques")))


def joint_data(extras: dict[str, Any]
               ) -> Iterator[tuple[str, str, str, dict[str, Any], list[list[Datum]]]]:
    """Every DATA SPRING, DAMPER and FORCE whose name is no element of its kind, so that
    it loads the variables of the joint of that name: (store, statement, name, its
    data, one list per variable: (rate, free) of a spring, (c,) or (f,), NONE as None).
    One source for the loads put on the model and for the joint kind they need
    (:func:`openimp.imp.interp.imp_joint`)."""
    for store, stmt, key, kinds in _JOINT_DATA:
        for name, data in extras.get(store, {}).items():
            if not any(name in extras.get(k, {}) for k in kinds):
                yield store, stmt, name, data, [
                    list(e) if store == "spring_data" else [e] for e in data.get(key) or ()]


def _joint_loads(state: Any, model: Model, joints: dict[str, Any], laws: ValueLaws,
                 messages: list[str]) -> bool:
    """The joint springs, dampers and loads of the deck on ``model``.  Each entry's
    variable is a coordinate: a joint whose default kind lacks it was built as its
    :data:`~openimp.imp.jointmap.IMP_DIRECT` kind from the same :func:`joint_data`."""
    used_values = False
    values = state.values
    for store, stmt, name, data, entries in joint_data(state.extras):
        if name not in joints:
            continue
        ij = joints[name][0]
        jd = joints[name][1]
        where = data["where"]
        what = f"{stmt} ({name})"
        if len(entries) > ij.nvar:
            raise InputError(f"{what}: {jd.keyword} joint {name} has {ij.nvar} variable(s) "
                             f"but {len(entries)} entries are given", where)
        for k, parts in enumerate(entries):
            if all(p is None for p in parts):
                continue  # NONE
            col, sign = ij.drive[k]
            angle = ij.var_kinds[k] == "angle"
            lab = f"{stmt} of joint {name} variable {k + 1}"
            is_value = _value_names(parts, values, what, where)
            used_values = used_values or is_value
            try:
                if store == "spring_data":
                    rate, free = parts
                    # numbers: torque/degree and degrees; VALUEs: per radian and radians
                    kdeg = 180.0 / math.pi if angle else 1.0
                    fdeg = math.pi / 180.0 if angle else 1.0
                    if is_value:
                        kk = laws.term(rate, kdeg, lab, where)
                        f0 = laws.term(free, fdeg, lab, where)
                        model.set_joint_spring(name, var=col, law=laws.switched(
                            lambda s, kk=kk, f0=f0, sg=sign: kk(s) * (s.x - sg * f0(s)),
                            [rate, free]))
                    else:
                        model.set_joint_spring(name, float(rate) * kdeg,
                                               sign * float(free) * fdeg, var=col,
                                               periodic=ij.kind in _TURNED)
                elif store == "damper_data":
                    c = parts[0]
                    if is_value:
                        cc = laws.term(c, 1.0, lab, where)
                        model.set_joint_damper(name, var=col, law=laws.switched(
                            lambda s, cc=cc: cc(s) * s.xd, [c]))
                    else:
                        _negative_damper(c, what, where, messages)
                        model.set_joint_damper(name, float(c), var=col)
                else:
                    f = parts[0]
                    if is_value:
                        ff = laws.term(f, 1.0, lab, where)
                        model.set_joint_force(name, var=col, law=laws.switched(
                            lambda s, ff=ff, sg=sign: sg * ff(s), [f]))
                    else:
                        model.set_joint_force(name, sign * float(f), var=col)
            except InputError as exc:
                if exc.where is not None:
                    raise
                raise InputError(f"{what}: {exc}", where) from None
    return used_values


def add_dynamic_data(state: Any, model: Model, joints: dict[str, Any],
                     messages: list[str]) -> DynamicData:
    """Put the mass, gravity, element and joint-load data of ``state`` on ``model``.

    ``joints``: joint name -> (ImpJoint, JointDef, ...) as built; ``messages``
    receives the run's located messages.  Raises :class:`InputError` located at
    the statement to change.
    """
    dd = DynamicData()
    _masses(state, model, messages)
    g = state.extras.get("gravity")
    if g is not None:
        model.set_gravity(g["vector"])
    laws = ValueLaws(state.values)
    used = _elements(state, model, laws, dd, messages)
    used = _joint_loads(state, model, joints, laws, messages) or used
    dd.laws = laws if used else None
    return dd
