"""The IMP interpreter: statements -> a model, its inputs, requests and runs.

:func:`load` reads a deck (:func:`openimp.imp.parse_file`), carries out every
statement in order as IMP did (the manual's chapters 3-8, docs/imp-language.md
§7-12: definitions, DATA, requests, control, DELETE and graphics statements)
and records, at every ``EXECUTE``, a snapshot of the model as it stands then.
The result is a :class:`Deck`:

* ``deck.model`` - the :class:`~openimp.model.Model` at the first EXECUTE (or at
  the end of the deck when it has none);
* ``deck.statements``, ``deck.requests``;
* ``deck.run()`` - every EXECUTE run in order (:mod:`openimp.imp.run`),
  returning a list of :class:`~openimp.io.Run`.

Input errors never stop the reading: every statement is checked and all the
errors are gathered; if there are any, :func:`load` raises :class:`DeckError`
(an :class:`~openimp.errors.InputError` holding the list, each located at
``file:line``) and nothing is run.  What IMP merely warned about (a redefined
joint, a replaced input motion, zero-filled data) is printed as an IMP message
``*** ... ***`` in the output, in the place IMP printed it.

Decisions where IMP ignored a statement "with msg": when ignoring it would
silently lose what the user asked for (data for an unknown joint, a DATA
VELOCITY without DATA POSITION, a FIND statement in the wrong mode), it is an
input error here; when the statement only replaces or re-deletes something,
it is a message.
"""

from __future__ import annotations

import copy
import math
import os
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from openimp import limits
from openimp.errors import InputError, PassedOverError
from openimp.files import check_readable, printable, quote_path
from openimp.imp.dyndata import UNIT_MASS_DEFAULT, DynamicData, add_dynamic_data, joint_data
from openimp.imp.expr import Expression
from openimp.imp.jointmap import (
    IMP_DIRECT,
    IMP_JOINTS,
    bevel_frames,
    drivable,
    placement_frames,
)
from openimp.imp.parser import JOINT_DOF, Statement
from openimp.massprops import mass_value
from openimp.model import Model
from openimp.spatial import inverse as _rigid_inverse
from openimp.system import compile_model
from openimp.topology import misspelt_bodies

__all__ = [
    "DeckError",
    "DeckWarning",
    "Interpreter",
    "JointDef",
    "LinkDef",
    "PointDef",
    "Request",
    "RunSpec",
    "State",
    "build_model",
]

Where = tuple[str, int]

#: IMP's tolerances (docs/imp-language.md §10) and their defaults: (value, count).
ZERO_DEFAULTS: dict[str, tuple[float, float | None]] = {
    "DATA": (1e-4, None), "POSITION": (1e-4, 20), "EQUILIB": (1e-3, 25),
    "SYSTEM": (1e-7, None), "INERTIA": (1e-5, None), "SPRING": (1e-5, None),
    "INDETERM": (1e-4, None), "ZERO": (1e-6, None), "FORCE": (0.1, 1.0),
}

#: Default title of the run banner (ch9).
DEFAULT_TITLE = "JML Research, Inc."


class DeckError(InputError):
    """Input errors of a deck; ``errors`` lists every one (each with ``where``);
    ``warnings`` the deck's warnings (:class:`DeckWarning`), which may explain them."""

    def __init__(self, errors: list[InputError], warnings: list[Any] | None = None) -> None:
        first = errors[0]
        super().__init__(str(first.args[0]) if first.args else str(first), first.where)
        self.errors = list(errors)
        self.warnings = list(warnings or [])

    def __str__(self) -> str:
        return "\n".join(str(e) for e in self.errors)


@dataclass(frozen=True)
class DeckWarning:
    """A warning about a statement that is carried out but probably not as meant."""

    message: str
    where: Where | None = None

    def __str__(self) -> str:
        loc = f"{self.where[0]}:{self.where[1]}: " if self.where is not None else ""
        return f"{loc}warning: {self.message}"


# =============================================================================
# State
# =============================================================================
@dataclass
class LinkDef:
    """A link: its body frame (global 4x4 at the modeling posture)."""

    name: str
    where: Where
    frame: np.ndarray = field(default_factory=lambda: np.eye(4))
    explicit: bool = False


@dataclass
class JointDef:
    """A joint as the deck defines it; frames are IMP frames in the link's body frame."""

    name: str
    keyword: str
    link1: str
    link2: str
    where: Where
    local1: np.ndarray | None = None
    local2: np.ndarray | None = None
    placed: Where | None = None
    params: dict[str, Any] = field(default_factory=dict)
    params_where: Where | None = None


@dataclass
class PointDef:
    """A point on a link: body-frame coordinates (None: the global origin)."""

    name: str
    link: str
    where: Where
    local: np.ndarray | None = None
    placed: Where | None = None


@dataclass
class InputDef:
    """The SGC data of one joint: DATA POSITION (+VELOCITY, ACCEL) or DATA MOTION."""

    joint: str
    kind: str  # "POSITION" or "MOTION"
    where: Where
    start: float = 0.0
    increment: float = 0.0
    nsteps: int = 0
    velocity: float = 0.0
    accel: float = 0.0
    motions: list[Any] = field(default_factory=list)
    has_velocity: bool = False
    has_accel: bool = False


@dataclass
class Request:
    """One PRINT / LIST / STORE / PLOT request statement."""

    family: str
    quantity: str
    names: list[str]
    all: bool
    where: Where
    statement: Statement

    @property
    def keyword(self) -> str:
        """``LIST POSITION`` etc."""
        return f"{self.family} {self.quantity}"


@dataclass
class Graphics:
    """Graphics statements: colours, erased items, view, axes, DRAW/ANIMATE state."""

    colors: dict[str, str] = field(default_factory=dict)
    all_color: str | None = None
    erased: set[str] = field(default_factory=set)
    view: Any = "FRONT"
    axes: dict[str, float] = field(default_factory=dict)
    axes_all: float = 0.0
    animate: bool = False
    perspective: float = 0.0
    used: bool = False
    interactive: list[Where] = field(default_factory=list)


@dataclass
class State:
    """Everything the deck has defined so far."""

    title: str | None = None
    ground: str = "BASE"
    ground_where: Where | None = None
    links: dict[str, LinkDef] = field(default_factory=dict)
    joints: dict[str, JointDef] = field(default_factory=dict)
    points: dict[str, PointDef] = field(default_factory=dict)
    polylines: list[tuple[str, list[str]]] = field(default_factory=list)
    values: dict[str, Expression] = field(default_factory=dict)
    inputs: dict[str, InputDef] = field(default_factory=dict)
    time: tuple[float, float, float] | None = None
    time_where: Where | None = None
    zero: dict[str, tuple[float, float | None]] = field(default_factory=dict)
    find: str | None = None
    find_where: Where | None = None
    kinematic: bool = False
    requests: list[Request] = field(default_factory=list)
    graphics: Graphics = field(default_factory=Graphics)
    extras: dict[str, Any] = field(default_factory=dict)
    #: UNIT (MASS): one user mass unit in force s^2/length (IMP's default: lbm, 1/386.088)
    unit_mass: float = UNIT_MASS_DEFAULT
    #: the cap on the steps of a time response (ZERO (FORCE)'s third number; None: the
    #: default of :func:`openimp.simulate`)
    max_steps: int | None = None
    #: statements IMP passed over (:class:`~openimp.errors.PassedOverError`) are input errors
    strict: bool = False
    #: IMP's printout in a run without DATA TIME: a Time column and ``time =`` lines
    #: (REMARK OPENIMP LISTING = IMP; openimp run --imp-listing), not openimp's Step
    imp_listing: bool = False
    #: at a change point: the smooth branch or the other (REMARK OPENIMP BRANCH = ...)
    branch: str = "smooth"
    #: at a dead point of an input: stop or switch (REMARK OPENIMP DEAD POINT = ...)
    at_limit: str = "stop"
    #: the integrator of the time responses: ("book", None), IMP's step, or ("rk",
    #: rtol), Dormand-Prince 5(4) (REMARK OPENIMP INTEGRATOR = BOOK | RK, rtol)
    integrator: tuple[str, float | None] = ("book", None)
    #: (category, significant name) -> (the name as first written, where)
    spelled: dict[tuple[str, str], tuple[str, Where]] = field(default_factory=dict)

    def snapshot(self) -> State:
        """A deep copy (VALUE expressions and statements are shared: they are immutable)."""
        memo: dict[int, Any] = {id(v): v for v in self.values.values()}
        for r in self.requests:
            memo[id(r.statement)] = r.statement
        return copy.deepcopy(self, memo)

    @property
    def mode(self) -> str:
        """``kinematic``, ``static`` or ``dynamic`` (what an EXECUTE now runs)."""
        return {"EQUILIB": "static", "DYNAMICS": "dynamic"}.get(self.find or "", "kinematic")

    def tolerance(self, kind: str) -> tuple[float, float | None]:
        """A ZERO tolerance: the deck's value or IMP's default."""
        return self.zero.get(kind, ZERO_DEFAULTS[kind])


@dataclass
class RunSpec:
    """One EXECUTE: the state as it stood then, and where the statement is."""

    index: int
    state: State
    where: Where
    hold: bool
    statement: Statement
    mode: str


# =============================================================================
# Interpreter
# =============================================================================
def _xyz(v: Any) -> np.ndarray:
    return np.asarray(v, dtype=float).reshape(3)


def _direction(v: Any) -> np.ndarray | None:
    """``v`` scaled to unit length without overflow (None for the zero vector)."""
    a = np.asarray(v, dtype=float)
    big = float(np.max(np.abs(a)))
    if big == 0.0:
        return None
    a = a / big
    return a / float(np.linalg.norm(a))


class Interpreter:
    """Carries out IMP statements one by one (see the module docstring).

    ``events`` records, in order, what the batch run prints and does:
    ``("text", str)`` lines, ``("run", RunSpec)``, ``("draw", State, Where)``,
    ``("reset", None)``, ``("print_on", (filename, where) or None)``,
    ``("store_input", (filename, lines, where))``.  File names never leave
    the output folder (absolute names and ``..`` are input errors).
    """

    def __init__(self, base_dir: str | None = None,
                 read_roots: tuple[str, ...] | None = None, strict: bool = False,
                 imp_listing: bool = False) -> None:
        self.state = State(strict=strict, imp_listing=imp_listing)
        self.base_dir = base_dir
        self.read_roots = read_roots
        self.events: list[tuple[str, Any]] = []
        self.errors: list[InputError] = []
        self.warnings: list[DeckWarning] = []
        self._warned: set[tuple[str, str, str]] = set()
        self.runs: list[RunSpec] = []
        self.echo = False
        self.ended = False
        self.store_input: tuple[str, list[str], Where] | None = None
        self.statements: list[Statement] = []
        self._stmt: Statement | None = None

    # ------------------------------------------------------------------ output
    def text(self, line: str) -> None:
        """Print a line (in order with the runs)."""
        self.events.append(("text", line))

    def msg(self, message: str) -> None:
        """Print an IMP message ``*** file:line: message ***`` (located at the
        statement being carried out, if any)."""
        stmt = self._stmt
        loc = f"{stmt.file}:{stmt.line}: " if stmt is not None and stmt.line > 0 else ""
        self.text(f"*** {loc}{message} ***")

    def warn(self, message: str, where: Where | None = None) -> None:
        """A located warning: kept in :attr:`warnings` and printed as an IMP message."""
        stmt = self._stmt
        loc = where if where is not None else (stmt.where if stmt is not None else None)
        w = DeckWarning(message, loc)
        self.warnings.append(w)
        self.text(f"*** {w} ***")  # already located: not through msg()

    def _written(self, first: int, last: int | None = None) -> list[tuple[str, str]]:
        """(significant, written) forms of the current statement's names ``[first:last]``."""
        stmt = self._stmt
        if stmt is None:
            return []
        names = stmt.names[first:last]
        written = stmt.written[first:last] if len(stmt.written) == len(stmt.names) else names
        return list(zip(names, written))

    def _spelling(self, category: str, defined: Iterable[tuple[str, str]],
                  pool: Iterable[str]) -> None:
        """Warn when a name defined now shares its significant (first four) characters
        with another name of its ``category`` (``pool``: the names defined so far) but
        is spelled otherwise: IMP reads both as one element.  ``defined`` holds the
        (significant, written) forms.  A name written with four characters or fewer
        is an abbreviation and never warned about; each spelling is warned about once.
        """
        stmt = self._stmt
        if stmt is None:
            return
        existing = set(pool)
        reg = self.state.spelled
        for name, written in defined:
            old = reg.get((category, name))
            if old is None or name not in existing:
                reg[(category, name)] = (written, stmt.where)
                existing.add(name)
                if (category == "link" and name == "BASE" and len(written) > 4
                        and self.state.ground_where is None):
                    self.warn(f"link {written} is read as BASE, the fixed link: IMP reads only "
                              "the first four characters of a name; rename the link if it is "
                              "meant to move")
                continue
            first, where = old
            key = (category, first, written)
            if first == written or len(first) <= 4 or len(written) <= 4 or key in self._warned:
                continue
            self._warned.add(key)
            at = "the same statement" if where == stmt.where else f"{where[0]}:{where[1]}"
            self.warn(f"{category} {written} and {category} {first} ({at}) share their first "
                      f"four characters, {name}, and IMP reads only those: they are one "
                      f"{category}; rename one of them so that the first four characters "
                      "differ")

    def error(self, message: str, where: Where | None = None) -> InputError:
        """An InputError about the current statement."""
        stmt = self._stmt
        loc = where if where is not None else (stmt.where if stmt is not None else None)
        prefix = f"{stmt.keyword} statement: " if stmt is not None and where is None else ""
        return InputError(prefix + message, loc)

    def passed(self, message: str) -> PassedOverError:
        """A :class:`~openimp.errors.PassedOverError` about the current statement: IMP answered it
        with a message and went on."""
        e = self.error(message)
        return PassedOverError(str(e.args[0]), e.where)

    def pass_over(self, exc: PassedOverError) -> None:
        """A statement IMP passed over: ignored with a located warning, or an input error
        when the deck is read strictly."""
        if self.state.strict:
            self.errors.append(exc)
        else:
            self.warn(f"{exc.args[0]}; the statement is ignored, as IMP ignored it "
                      "(openimp check --strict refuses it)", exc.where)

    # ------------------------------------------------------------------ driver
    def feed(self, statements: Iterable[Statement]) -> None:
        """Carry out statements in order; errors are gathered in :attr:`errors`."""
        for stmt in statements:
            if self.ended:
                break
            self.statements.append(stmt)
            self._stmt = stmt
            echo = self.echo and not (stmt.keyword == "PRINT INPUT")
            if echo:
                for line in stmt.text.split("\n") or [""]:
                    self.text(line)
            if self.store_input is not None and stmt.keyword not in ("STORE INPUT",):
                self.store_input[1].append(stmt.text)
            for w in stmt.warnings:
                self.msg(w)
            try:
                self.execute(stmt)
            except PassedOverError as exc:
                self.pass_over(exc)
            except InputError as exc:
                if exc.where is None:
                    exc.where = stmt.where
                self.errors.append(exc)
            finally:
                self._stmt = None

    def execute(self, stmt: Statement) -> None:
        """Carry out one statement."""
        kw = stmt.keyword
        if kw in JOINT_DOF:
            self._joint(stmt)
        elif stmt.kind == "DEFINE":
            getattr(self, "_def_" + kw.replace(" ", "_").lower())(stmt)
        elif stmt.kind == "VALUE":
            self._value(stmt)
        elif stmt.kind == "DATA":
            self._data(stmt)
        elif stmt.kind == "REQUEST":
            self._request(stmt)
        elif stmt.kind == "DELETE":
            self._delete(stmt)
        elif stmt.kind == "GRAPHICS":
            self._graphics(stmt)
        else:
            self._control(stmt)

    # ------------------------------------------------------------------ lookups
    def _link(self, name: str, what: str = "link", create: bool = False) -> LinkDef:
        """The link ``name``; ``create``: a link not yet named in a joint comes into being
        here, as IMP-2000's SHAPE, POINT and DATA LINK made it (the solid-model decks of
        chapter 9 shape and frame each link before its joints)."""
        if create and name not in self.state.links and self._stmt is not None:
            self.state.links[name] = LinkDef(name, self._stmt.where)
        if name not in self.state.links:
            known = ", ".join(self.state.links) or "none yet"
            raise self.error(f"{what} {name} is not defined (links: {known}); links come into "
                             "being in joint statements or LINK statements")
        return self.state.links[name]

    def _jdef(self, name: str) -> JointDef:
        if name not in self.state.joints:
            known = ", ".join(self.state.joints) or "none yet"
            raise self.error(f"joint {name} is not defined (joints: {known})")
        return self.state.joints[name]

    def _pdef(self, name: str) -> PointDef:
        if name not in self.state.points:
            known = ", ".join(self.state.points) or "none yet"
            raise self.error(f"point {name} is not defined (points: {known}); name it in a "
                             "POINT (link) = ... statement first")
        return self.state.points[name]

    def point_global(self, name: str) -> np.ndarray:
        """Global coordinates of a point at the modeling posture."""
        p = self._pdef(name)
        if p.local is None:
            return np.zeros(3)
        T = self.state.links[p.link].frame if p.link in self.state.links else np.eye(4)
        return (T @ np.append(p.local, 1.0))[:3]

    def _resolve_point(self, slot: Any, what: str) -> np.ndarray:
        if isinstance(slot, str):
            p = self._pdef(slot)
            if p.local is None:
                raise self.error(f"{what}: point {slot} has no DATA POINT yet; place it first "
                                 "or give x,y,z")
            return self.point_global(slot)
        return _xyz(slot)

    # ------------------------------------------------------------------ definitions
    def _joint(self, stmt: Statement) -> None:
        f = stmt.fields
        kw, l1, l2, name = f["type"], f["link1"], f["link2"], f["joint"]
        if l1 == l2:
            raise self.error(f"joint {name} joins link {l1} to itself; a joint connects two "
                             "different links")
        ij = IMP_JOINTS[kw]
        if not ij.available:
            raise self.error(f"{kw} joints are not available yet: openimp's joint catalogue has "
                             f"no '{ij.kind}' kind in this installation, so joint {name} cannot "
                             "be built")
        st = self.state
        self._spelling("link", self._written(0, 2), st.links)
        self._spelling("joint", self._written(2, 3), st.joints)
        if name in st.joints:
            self.msg(f"Joint {name} is redefined; the old joint and its data are deleted.")
            self._delete_joint(name)
        for link in (l1, l2):
            if link not in st.links:
                st.links[link] = LinkDef(link, stmt.where)
        st.joints[name] = JointDef(name, kw, l1, l2, stmt.where)

    def _def_link(self, stmt: Statement) -> None:
        name = stmt.fields["link"]
        self._spelling("link", self._written(0, 1), self.state.links)
        if name in self.state.links:
            self.msg(f"Link {name} is already defined; this LINK statement is ignored.")
            return
        self.state.links[name] = LinkDef(name, stmt.where, explicit=True)

    def _def_ground(self, stmt: Statement) -> None:
        self.state.ground = stmt.fields["link"]
        self.state.ground_where = stmt.where
        self.msg("The fixed link is redefined.")

    def _def_solid_read(self, stmt: Statement) -> None:
        name = stmt.fields["filename"]
        path = name if os.path.isabs(name) or not self.base_dir else os.path.join(
            self.base_dir, name)
        if not os.path.lexists(path):  # IMP said so and went on; the solid is not defined
            raise self.passed(f"the file '{printable(name, 80)}' does not exist (it is "
                              "relative to the deck's folder); solid "
                              f"{stmt.fields['solid']} is not defined")
        check_readable(path, f"{stmt.keyword} statement", stmt.where, self.read_roots)
        self._spelling("solid", self._written(0, 1), self.state.extras.get("solids", {}))
        self.state.extras.setdefault("solids", {})[stmt.fields["solid"]] = {
            "file": path, "where": stmt.where}
        self.text(f"Solid '{stmt.fields['solid']}' was read from file.")

    def _def_shape(self, stmt: Statement) -> None:
        link = stmt.fields["link"]
        self._link(link, create=True)
        solids = self.state.extras.get("solids", {})
        for s in stmt.fields["solids"]:
            if s not in solids:
                raise self.passed(f"solid {s} is not defined; read it with SOLID READ first")
        self.state.extras.setdefault("shapes", {})[link] = list(stmt.fields["solids"])

    def _def_contact(self, stmt: Statement) -> None:
        f = stmt.fields
        solids = self.state.extras.get("solids", {})
        for s in (f["solid1"], f["solid2"]):
            if s not in solids:
                raise self.passed(f"solid {s} is not defined; read it with SOLID READ first")
        if f["solid1"] == f["solid2"]:
            raise self.error("a contact needs two different solids")
        contacts = self.state.extras.setdefault("contacts", {})
        self._spelling("contact", self._written(2, 3), contacts)
        if f["contact"] in contacts:
            self.msg(f"Contact {f['contact']} is redefined.")
        contacts[f["contact"]] = {"solids": (f["solid1"], f["solid2"]), "where": stmt.where}
        self.msg(f"Contact {f['contact']} is accepted but not simulated: openimp does not "
                 "detect collisions or apply impacts yet, so a dynamic run goes on as if "
                 "the solids passed through each other.")

    def _def_impact(self, stmt: Statement) -> None:
        f = stmt.fields
        self.msg("IMPACT is accepted but not simulated: openimp does not apply impacts yet.")
        self.state.extras["impact"] = tuple(
            v if v in (0, 1, 2, 3) else 0 for v in (f["tangent"], f["moment"], f["torsion"]))

    def _def_point(self, stmt: Statement) -> None:
        link = stmt.fields["link"]
        self._link(link, create=True)
        names = stmt.fields["points"]
        self._spelling("point", self._written(1), self.state.points)
        for n in names:
            if n not in self.state.points:
                self.state.points[n] = PointDef(n, link, stmt.where)
        if len(names) > 1:
            self.state.polylines.append((link, list(names)))

    def _element(self, stmt: Statement, kind: str, points: list[str]) -> None:
        for p in points:
            self._pdef(p)
        store = self.state.extras.setdefault(kind, {})
        name = stmt.fields["name"]
        label = {"springs": "Spring", "dampers": "Damper", "forces": "Force",
                 "torques": "Torque"}[kind]
        self._spelling(label.lower(), self._written(-1), store)
        if name in store:
            self.msg(f"{label} {name} is redefined.")
        store[name] = {"points": list(points), "where": stmt.where, "data": None,
                       **{k: v for k, v in stmt.fields.items() if k != "name"}}

    def _def_spring(self, stmt: Statement) -> None:
        f = stmt.fields
        if f["point1"] == f["point2"]:
            raise self.error(f"a spring needs two different points, got {f['point1']} twice")
        self._element(stmt, "springs", [f["point1"], f["point2"]])

    def _def_damper(self, stmt: Statement) -> None:
        f = stmt.fields
        if f["point1"] == f["point2"]:
            raise self.error(f"a damper needs two different points, got {f['point1']} twice")
        self._element(stmt, "dampers", [f["point1"], f["point2"]])

    def _def_force(self, stmt: Statement) -> None:
        f = stmt.fields
        if f["point_a"] == f["point_b"]:
            raise self.error("the direction points of a force must differ")
        self._element(stmt, "forces", [f["point"], f["point_a"], f["point_b"]])

    def _def_torque(self, stmt: Statement) -> None:
        f = stmt.fields
        self._link(f["link"])
        if f["point_a"] == f["point_b"]:
            raise self.error("the direction points of a torque must differ")
        self._element(stmt, "torques", [f["point_a"], f["point_b"]])

    def _value(self, stmt: Statement) -> None:
        name = stmt.fields["name"]
        self._spelling("VALUE", self._written(0, 1), self.state.values)
        if name in self.state.values:
            self.msg(f"VALUE {name} is redefined.")
        self.state.values[name] = stmt.fields["expression"]

    # ------------------------------------------------------------------ DATA
    def _data(self, stmt: Statement) -> None:
        what = stmt.keyword[5:]
        handler = getattr(self, "_data_" + what.lower(), None)
        if handler is None:
            self._data_placement(stmt, what)
        else:
            handler(stmt)

    def _side(self, jd: JointDef, link: str) -> int:
        if link == jd.link1:
            return 1
        if link == jd.link2:
            return 2
        raise self.error(f"link {link} is not in joint {jd.name}, which joins {jd.link1} and "
                         f"{jd.link2}")

    def _data_link(self, stmt: Statement) -> None:
        f = stmt.fields
        link = self._link(f["link"], create=f["frame"] == "LINK")
        pts = [None if filled else self._resolve_point(p, f"point P{k + 1}")
               for k, (p, filled) in enumerate(zip(f["points"], f["filled"]))]
        if pts[0] is None:
            pts[0] = np.zeros(3)
        what = f"DATA LINK ({f['link']}, {f['joint'] or 'LINK'})"
        from openimp.imp.jointmap import frame_w

        F = frame_w(pts[0], pts[1], pts[2], what)
        if f["frame"] == "LINK":
            link.frame = F
            return
        jd = self._jdef(f["joint"])
        side = self._side(jd, link.name)
        local = _rigid_inverse(link.frame) @ F
        if side == 1:
            jd.local1 = local
        else:
            jd.local2 = local
        jd.placed = stmt.where

    def _data_placement(self, stmt: Statement, what: str) -> None:
        f = stmt.fields
        jd = self._jdef(f["joint"])
        if jd.keyword != what:
            raise self.error(f"joint {jd.name} is a {jd.keyword}, not a {what}; place it with "
                             + (f"DATA {jd.keyword} or " if IMP_JOINTS[jd.keyword].data_form
                                else "") + "two DATA LINK (link, joint) statements")
        pts: list[np.ndarray | None] = []
        for k, (p, filled) in enumerate(zip(f["points"], f["filled"])):
            if filled:
                pts.append(None)
                continue
            v = self._resolve_point(p, f"point P{k + 1}")
            if what in ("XPIN", "YPIN", "ZPIN") and k > 0 and not isinstance(p, str) \
                    and not np.any(v):
                pts.append(None)  # a 0,0,0 direction point counts as missing (ch9)
            else:
                pts.append(v)
        F1, F2 = placement_frames(what, pts, f"DATA {what} ({jd.name})")
        st = self.state
        jd.local1 = _rigid_inverse(st.links[jd.link1].frame) @ F1
        jd.local2 = _rigid_inverse(st.links[jd.link2].frame) @ F2
        jd.placed = stmt.where

    def _params(self, stmt: Statement, kw: str, params: dict[str, Any]) -> None:
        jd = self._jdef(stmt.fields["joint"])
        if jd.keyword != kw:
            raise self.error(f"joint {jd.name} is a {jd.keyword}, not a {kw}")
        if jd.params:
            self.msg(f"{stmt.keyword} for joint {jd.name} is redefined.")
        jd.params = params
        jd.params_where = stmt.where

    def _data_gear(self, stmt: Statement) -> None:
        f = stmt.fields
        if f["ratio"] == 0.0:
            raise self.error("the gear ratio must not be 0 (a gear meshing with a rack is a "
                             "RACK joint)")
        if f["ratio"] == -1.0:
            raise self.error("ratio -1 (an internal gear of the same size) has no centre "
                             "distance")
        self._ratio_bound(f["ratio"], "gear")
        d = f.get("distance")
        if d is not None and d < 0:
            raise self.error("the centre distance must be positive")
        p = {"ratio": f["ratio"]}
        if d:
            p["distance"] = d
        self._params(stmt, "GEAR", p)

    def _data_bevel(self, stmt: Statement) -> None:
        f = stmt.fields
        if f["ratio"] <= 0.0:
            raise self.error("the bevel ratio (teeth of the first / teeth of the second) must "
                             "be positive")
        self._ratio_bound(f["ratio"], "bevel")
        p: dict[str, Any] = {"ratio": f["ratio"]}
        if f["radius"]:
            p["radius"] = f["radius"]
        self._params(stmt, "BEVEL", p)

    def _ratio_bound(self, ratio: float, what: str) -> None:
        """Refuse a gear ratio beyond MAX_GEAR_RATIO (or below its inverse)."""
        top = limits.MAX_GEAR_RATIO
        if not 1.0 / top <= abs(ratio) <= top or abs(1.0 + ratio) < 1.0 / top:
            raise self.error(f"the {what} ratio {limits.number_text(ratio)} is out of range: "
                             f"|ratio| must lie between {limits.number_text(1.0 / top)} and "
                             f"{limits.number_text(top)} and |1 + ratio| be at least "
                             f"{limits.number_text(1.0 / top)} (limit MAX_GEAR_RATIO)")

    def _data_rack(self, stmt: Statement) -> None:
        if stmt.fields["radius"] == 0.0:
            raise self.error("the pinion pitch radius must not be 0")
        self._params(stmt, "RACK", {"radius": stmt.fields["radius"]})

    def _data_screw(self, stmt: Statement) -> None:
        if stmt.fields["lead"] == 0.0:
            raise self.error("the lead must not be 0 (a screw of zero lead is a REVOLUTE)")
        self._params(stmt, "SCREW", {"lead": stmt.fields["lead"]})

    def _table_value(self, stmt: Statement) -> Any:
        name = stmt.fields["value"]
        if name not in self.state.values:
            raise self.error(f"VALUE {name} is not defined; define it as VALUE ({name}) = "
                             "TABLE(x): filename first")
        table = self.state.values[name].table()
        if table is None:
            raise self.error(f"VALUE {name} must be exactly a TABLE function, "
                             f"VALUE ({name}) = TABLE(x): filename")
        return table

    def _data_cam(self, stmt: Statement) -> None:
        table = self._table_value(stmt)
        self._params(stmt, "CAM", {"table": list(table.ordinates), "interpolation": "fourier"})

    def _data_slot(self, stmt: Statement) -> None:
        table = self._table_value(stmt)
        if len(table.ordinates) < 4:
            raise self.error("a SLOT table needs at least 4 ordinates")
        self._params(stmt, "SLOT", {"table": list(table.ordinates),
                                    "range": (table.xmin, table.xmax)})

    def _data_point(self, stmt: Statement) -> None:
        f = stmt.fields
        p = self._pdef(f["point"])
        link = self.state.links.get(p.link)
        T = link.frame if link is not None else np.eye(4)
        if f["frame"] == "ABS":
            g = self._resolve_point(f["coords"], "coordinates")
            local = (_rigid_inverse(T) @ np.append(g, 1.0))[:3]
        elif f["frame"] == "LINK":
            local = _xyz(f["coords"])
        else:
            jd = self._jdef(f["joint"])
            side = self._side(jd, p.link)
            F = jd.local1 if side == 1 else jd.local2
            F = np.eye(4) if F is None else F
            local = (F @ np.append(_xyz(f["coords"]), 1.0))[:3]
        if p.placed is not None:
            self.msg(f"Data for point {p.name} is redefined.")
        p.local = local
        p.placed = stmt.where

    def _extra_data(self, stmt: Statement, store: str, key: str, value: Any,
                    label: str) -> None:
        d = self.state.extras.setdefault(store, {})
        if key in d:
            self.msg(f"{label} is redefined.")
        d[key] = value

    def _data_gravity(self, stmt: Statement) -> None:
        if "gravity" in self.state.extras:
            self.msg("DATA GRAVITY is redefined.")
        self.state.extras["gravity"] = {"vector": tuple(stmt.fields["vector"]),
                                        "where": stmt.where}

    def _data_density(self, stmt: Statement) -> None:
        f = stmt.fields
        shaped = {s for v in self.state.extras.get("shapes", {}).values() for s in v}
        if f["solid"] not in shaped:
            raise self.passed(f"solid {f['solid']} is in no SHAPE statement yet")
        if f["density"] < 0:
            raise self.error("the density must not be negative")
        self.state.extras.setdefault("densities", []).append(
            {"solid": f["solid"], "density": f["density"] * self.state.unit_mass,
             "where": stmt.where})
        link = next(lk for lk, v in self.state.extras.get("shapes", {}).items()
                    if f["solid"] in v)
        self.warn(f"the mass properties of solid {f['solid']} are not computed: it is read "
                  "from a solid file (SOLID READ), and openimp does not integrate solid files "
                  f"yet; link {link} gets no mass from it.  Give its mass with DATA MASS and "
                  f"DATA INERTIA ({link}, ...) instead")

    def _mass_frame(self, f: dict[str, Any]) -> None:
        self._link(f["link"])
        if f["frame"] == "JOINT":
            self._side(self._jdef(f["joint"]), f["link"])

    def _data_mass(self, stmt: Statement) -> None:
        f = stmt.fields
        self._mass_frame(f)
        try:  # refused where the statement is read, so that the message has its line
            mass_value(f["mass"], f"the mass of link {f['link']}")
        except InputError as exc:
            raise self.error(str(exc)) from None
        if self.state.extras.get("inertias", {}).pop(f["link"], None) is not None:
            self.msg(f"The inertia data of link {f['link']} are discarded: DATA MASS replaces "
                     "the mass data with a point mass; give DATA INERTIA again after it.")
        self._extra_data(stmt, "masses", f["link"], {
            "frame": f["joint"] or "LINK", "mass": f["mass"] * self.state.unit_mass,
            "center": tuple(f["center"]), "where": stmt.where}, f"Mass data of link {f['link']}")

    def _data_inertia(self, stmt: Statement) -> None:
        f = stmt.fields
        self._mass_frame(f)
        if f["link"] not in self.state.extras.get("masses", {}):
            raise self.error(f"link {f['link']} has no DATA MASS yet; give DATA MASS first")
        um = self.state.unit_mass
        self._extra_data(stmt, "inertias", f["link"], {
            "frame": f["joint"] or "LINK", "inertia": tuple(x * um for x in f["inertia"]),
            "where": stmt.where}, f"Inertia data of link {f['link']}")

    def _load_target(self, stmt: Statement, kinds: tuple[str, ...]) -> str:
        name = stmt.fields["name"]
        ex = self.state.extras
        if name in self.state.joints or any(name in ex.get(k, {}) for k in kinds):
            return name
        what = " or ".join(k[:-1] for k in kinds)
        raise self.error(f"{name} is neither a joint nor a {what}")

    def _data_spring(self, stmt: Statement) -> None:
        name = self._load_target(stmt, ("springs",))
        self._extra_data(stmt, "spring_data", name, {"pairs": stmt.fields["pairs"],
                                                     "where": stmt.where},
                         f"Spring data of {name}")

    def _data_damper(self, stmt: Statement) -> None:
        name = self._load_target(stmt, ("dampers",))
        self._extra_data(stmt, "damper_data", name, {
            "coefficients": stmt.fields["coefficients"], "where": stmt.where},
            f"Damper data of {name}")

    def _data_force(self, stmt: Statement) -> None:
        name = self._load_target(stmt, ("forces", "torques"))
        self._extra_data(stmt, "load_data", name, {"loads": stmt.fields["loads"],
                                                   "where": stmt.where},
                         f"Load data of {name}")

    _data_torque = _data_force

    def _data_contact(self, stmt: Statement) -> None:
        f = stmt.fields
        if f["contact"] not in self.state.extras.get("contacts", {}):
            raise self.passed(f"contact {f['contact']} is not defined")
        self.state.extras.setdefault("contact_data", {})[f["contact"]] = {
            k: f[k] for k in ("en", "et", "eb", "er", "mu")}

    def _data_position(self, stmt: Statement) -> None:
        f = stmt.fields
        st = self.state
        if st.find == "DYNAMICS":
            raise self.error("DATA POSITION is not allowed after FIND DYNAMICS (drive dynamic "
                             "runs with DATA MOTION); cancel with DELETE DYNAMICS")
        jd = self._jdef(f["joint"])
        ij = IMP_JOINTS[jd.keyword]
        if ij.nvar != 1 or ij.drive[0] is None:
            raise self.error(f"joint {jd.name} is a {jd.keyword} with {ij.nvar} variables; "
                             "DATA POSITION drives single-variable joints only: use DATA MOTION")
        nsteps = int(f["nsteps"])
        if nsteps < 0:
            raise self.error(f"the number of steps ({nsteps}) must not be negative")
        if nsteps > limits.MAX_STEPS:
            raise self.error(f"{nsteps} steps are more than {limits.MAX_STEPS} (limit "
                             "MAX_STEPS); use fewer, larger steps")
        end = abs(f["start"]) + abs(f["increment"]) * nsteps
        if end > limits.MAX_NUMBER:
            raise self.error(f"the joint would travel to {limits.number_text(end)} (start + "
                             f"increment x steps), beyond ±{limits.number_text(limits.MAX_NUMBER)}"
                             " (limit MAX_NUMBER)")
        if jd.name in st.inputs:
            self.msg(f"Input motion for joint {jd.name} 1 is redefined.")
        st.inputs[jd.name] = InputDef(jd.name, "POSITION", stmt.where, start=f["start"],
                                      increment=f["increment"], nsteps=nsteps)

    def _rate(self, stmt: Statement, key: str, label: str) -> None:
        st = self.state
        if st.find is not None:
            raise self.error(f"DATA {label} is not allowed after FIND {st.find} (kinematic mode "
                             "only)")
        jd = self._jdef(stmt.fields["joint"])
        inp = st.inputs.get(jd.name)
        if inp is None or inp.kind != "POSITION":
            raise self.error(f"joint {jd.name} has no DATA POSITION; DATA {label} applies to a "
                             "DATA POSITION input, so give DATA POSITION first")
        value = stmt.fields["velocity" if key == "velocity" else "acceleration"]
        if abs(value) > limits.MAX_RATE:
            raise self.error(f"the {label.lower()} {limits.number_text(value)} is beyond "
                             f"±{limits.number_text(limits.MAX_RATE)} (limit MAX_RATE): "
                             "accelerations grow as its square and would overflow")
        if getattr(inp, "has_" + key):
            self.msg(f"Input {label.lower()} for joint {jd.name} is redefined.")
        setattr(inp, key, value)
        setattr(inp, "has_" + key, True)
        st.extras["rates_given"] = True

    def _data_velocity(self, stmt: Statement) -> None:
        self._rate(stmt, "velocity", "VELOCITY")

    def _data_accel(self, stmt: Statement) -> None:
        self._rate(stmt, "accel", "ACCEL")

    def _data_motion(self, stmt: Statement) -> None:
        f = stmt.fields
        jd = self._jdef(f["joint"])
        ij = IMP_JOINTS[jd.keyword]
        motions = list(f["motions"])
        if len(motions) > ij.nvar:
            raise self.error(f"joint {jd.name} ({jd.keyword}) has {ij.nvar} variable(s) but "
                             f"{len(motions)} motions are given")
        if len(motions) < ij.nvar:
            self.msg(f"Warning: {ij.nvar - len(motions)} motion(s) of joint {jd.name} are not "
                     "given; those variables are not input motions (NONE).")
            motions += [None] * (ij.nvar - len(motions))
        for k, m in enumerate(motions):
            if m is not None and not drivable(jd.keyword, k):
                raise self.error(f"variable {k + 1} of {jd.keyword} joint {jd.name} cannot be an "
                                 "input motion; give NONE for it")
        if all(m is None for m in motions):
            raise self.error("every motion is NONE: the statement drives nothing")
        old = self.state.inputs.get(jd.name)
        if old is not None:
            old_vars = [1] if old.kind == "POSITION" else [
                k + 1 for k, m in enumerate(old.motions) if m is not None]
            for k in old_vars:
                self.msg(f"Input motion for joint {jd.name} {k} is redefined.")
        self.state.inputs[jd.name] = InputDef(jd.name, "MOTION", stmt.where, motions=motions)

    def _data_ic(self, stmt: Statement) -> None:
        if self.state.find != "DYNAMICS":
            raise self.passed("DATA IC needs FIND DYNAMICS first (initial conditions are for "
                              "dynamic mode)")
        jd = self._jdef(stmt.fields["joint"])
        ij = IMP_JOINTS[jd.keyword]
        pairs = stmt.fields["pairs"]
        if len(pairs) > ij.nvar:
            raise self.error(f"joint {jd.name} ({jd.keyword}) has {ij.nvar} variable(s) but "
                             f"{len(pairs)} position, velocity pairs are given")
        for k, (pos, vel) in enumerate(pairs):
            if (pos is not None or vel is not None) and not drivable(jd.keyword, k):
                raise self.error(f"variable {k + 1} of {jd.keyword} joint {jd.name} cannot take "
                                 "an initial condition; give NONE, NONE for it")
            if isinstance(vel, float) and not abs(vel) <= limits.MAX_RATE:
                raise self.error(f"the initial velocity {limits.number_text(vel)} of joint "
                                 f"{jd.name} {k + 1} is beyond "
                                 f"±{limits.number_text(limits.MAX_RATE)} (limit MAX_RATE)")
        self._extra_data(stmt, "ics", jd.name, {"pairs": stmt.fields["pairs"],
                                                "where": stmt.where},
                         f"Initial conditions of joint {jd.name}")

    def _data_time(self, stmt: Statement) -> None:
        f = stmt.fields
        if min(f["final"], f["minstep"], f["printstep"]) < 0:
            raise self.error("times must not be negative")
        if f["printstep"] <= 0:
            raise self.error("the print step (third number) must be positive")
        steps = f["final"] / f["printstep"]
        if steps > limits.MAX_STEPS:
            raise self.error(f"the final time {limits.number_text(f['final'])} in print steps of "
                             f"{limits.number_text(f['printstep'])} gives "
                             f"{limits.number_text(steps)} output steps, more than "
                             f"{limits.MAX_STEPS} (limit MAX_STEPS); use a larger print step "
                             "or a shorter final time")
        self.state.time = (f["final"], f["minstep"], f["printstep"])
        self.state.time_where = stmt.where

    def _data_view(self, stmt: Statement) -> None:
        f = stmt.fields
        g = self.state.graphics
        g.used = True
        if f["view"] is not None:
            g.view = f["view"]
        else:
            eye, up = _direction(f["eye"]), _direction(f["up"])
            if eye is None or up is None or np.linalg.norm(np.cross(eye, up)) < 1e-12:
                raise self.error("the eye position and the up-vector must not be parallel")
            g.view = (tuple(f["eye"]), tuple(f["up"]))

    def _data_draw(self, stmt: Statement) -> None:
        self.state.graphics.perspective = stmt.fields["distance"]
        self.state.graphics.used = True
        self.state.graphics.interactive.append(stmt.where)

    # ------------------------------------------------------------------ requests
    def _request(self, stmt: Statement) -> None:
        f = stmt.fields
        self.state.requests.append(Request(f["family"], f["quantity"], list(f.get("names", [])),
                                           bool(f.get("all", False)), stmt.where, stmt))
        if f["family"] == "PLOT":
            self.state.graphics.used = True

    # ------------------------------------------------------------------ control
    def _directive(self, text: str) -> None:
        """``REMARK OPENIMP ...``: an openimp choice IMP itself reads as a remark.

        ``REMARK OPENIMP BRANCH = SMOOTH | OTHER`` (at a change point: the branch
        whose tangent continues the motion, or the other one), ``REMARK OPENIMP
        DEAD POINT = STOP | SWITCH`` (at a limit of travel of an input: stop, or
        drive the joint variable that moves most from there on) and ``REMARK
        OPENIMP INTEGRATOR = BOOK | RK, rtol`` (the time response with IMP's step
        and ZERO (FORCE), or with Dormand-Prince 5(4) at the relative tolerance
        rtol, default 1E-8) and ``REMARK OPENIMP LISTING = IMP | OPENIMP`` (a run
        without DATA TIME lists a Time column and prints ``time =`` lines as IMP
        did, or a Step column and ``step =`` lines).  They hold for the EXECUTEs
        that follow.
        """
        words = text.upper().replace("=", " = ").replace(",", " ").split()
        if not words or words[0].rstrip(":") != "OPENIMP":
            return
        rest = " ".join(w for w in words[1:] if w != "=")
        if rest.split()[:1] == ["INTEGRATOR"]:
            self._integrator(rest.split()[1:])
            return
        known = {"BRANCH SMOOTH": ("branch", "smooth"), "BRANCH OTHER": ("branch", "other"),
                 "DEAD POINT STOP": ("at_limit", "stop"),
                 "DEAD POINT SWITCH": ("at_limit", "switch"),
                 "LISTING IMP": ("imp_listing", True), "LISTING OPENIMP": ("imp_listing", False)}
        if rest not in known:
            raise self.error("unknown openimp directive in a REMARK: give REMARK OPENIMP "
                             "BRANCH = SMOOTH or OTHER, REMARK OPENIMP DEAD POINT = STOP or "
                             "SWITCH, REMARK OPENIMP INTEGRATOR = BOOK or RK, rtol, or REMARK "
                             "OPENIMP LISTING = IMP or OPENIMP (got "
                             f"'{' '.join(words[1:])[:40]}')")
        name, value = known[rest]
        setattr(self.state, name, value)

    def _integrator(self, args: list[str]) -> None:
        """``REMARK OPENIMP INTEGRATOR = BOOK`` or ``= RK[, rtol]`` (its words after
        INTEGRATOR, upper case)."""
        if args == ["BOOK"]:
            self.state.integrator = ("book", None)
            return
        if args[:1] == ["RK"] and len(args) <= 2:
            rtol = 1e-8
            if len(args) == 2:
                try:
                    rtol = float(args[1].replace("D", "E"))
                except ValueError:
                    rtol = math.nan
                if not (math.isfinite(rtol) and 1e-14 <= rtol <= 0.1):
                    raise self.error("REMARK OPENIMP INTEGRATOR = RK, rtol: rtol must be a "
                                     f"number from 1E-14 to 0.1, got '{args[1][:20]}'")
            self.state.integrator = ("rk", rtol)
            return
        raise self.error("REMARK OPENIMP INTEGRATOR: give BOOK (IMP's step and ZERO (FORCE)) "
                         f"or RK, rtol (Dormand-Prince; got '{' '.join(args)[:40]}')")

    def _control(self, stmt: Statement) -> None:
        kw = stmt.keyword
        st = self.state
        f = stmt.fields
        if kw == "TITLE":
            st.title = f["title"]
        elif kw == "REMARK":
            self._directive(f.get("text", ""))
        elif kw in ("RETURN", "RECALL INPUT", "PAUSE ON", "PAUSE OFF", "ERASE ON",
                    "ERASE OFF"):
            pass  # no effect in a batch run (RECALL INPUT is expanded by the parser)
        elif kw in ("EXECUTE", "EXECUTE HOLD"):
            self._execute(stmt)
        elif kw == "FIND EQUILIB":
            if st.find == "DYNAMICS":
                raise self.passed("FIND EQUILIB after FIND DYNAMICS; cancel with DELETE "
                                  "DYNAMICS")
            if st.kinematic or st.extras.get("rates_given"):
                raise self.passed("FIND EQUILIB in kinematic mode (after DATA VELOCITY, DATA "
                                  "ACCEL or a kinematic EXECUTE); cancel with DELETE INPUT (ALL)")
            st.find, st.find_where = "EQUILIB", stmt.where
        elif kw == "FIND DYNAMICS":
            if st.find == "EQUILIB":
                raise self.passed("FIND DYNAMICS after FIND EQUILIB; cancel with DELETE "
                                  "EQUILIB")
            if st.kinematic or any(i.kind == "POSITION" for i in st.inputs.values()):
                raise self.passed("FIND DYNAMICS after DATA POSITION or a kinematic EXECUTE; "
                                  "cancel with DELETE INPUT (ALL)")
            st.find, st.find_where = "DYNAMICS", stmt.where
        elif kw == "UNIT MASS":
            if f["value"] <= 0:
                raise self.error("the mass unit must be positive")
            st.unit_mass = f["value"]
        elif kw == "IDENTIFY":
            self._identify(f["types"])
        elif kw.startswith("ZERO "):
            self._zero(stmt)
        elif kw == "PRINT INPUT":
            self.echo = True
        elif kw == "PRINT ON":
            name = self._output_name(f.get("filename") or "prt.dat")
            self.events.append(("print_on", (name, stmt.where)))
        elif kw == "PRINT OFF":
            self.events.append(("print_on", None))
        elif kw == "STORE INPUT":
            self._end_store_input()
            self.store_input = (self._output_name(f.get("filename") or "input.dat"), [],
                                stmt.where)
            self.echo = False
        elif kw == "CLEAR":
            self._end_store_input()
            graphics_used = st.graphics.used
            self.state = State()
            self.state.graphics.used = graphics_used
        elif kw == "RESET":
            self.events.append(("reset", None))
        elif kw == "END":
            self._end_store_input()
            self.ended = True
        else:  # pragma: no cover - every control keyword of the parser is above
            raise self.error(f"{kw} is not handled")

    def _output_name(self, name: str) -> str:
        """A PRINT ON / STORE INPUT file name, refused when it would leave the output
        folder (an absolute path, a ``..`` component) or is not a plain name."""
        parts = name.replace("\\", "/").split("/")
        if os.path.isabs(name) or name.startswith(("/", "\\", "~")) or ".." in parts:
            raise self.error(f"the file name {quote_path(name)} leaves the output folder: files "
                             "are written only inside the --out folder (or the deck's folder); "
                             "give a name relative to it, without '..'")
        if any(not ch.isprintable() for ch in name) or not name.strip():
            raise self.error(f"the file name {quote_path(name)} holds control characters; give "
                             "a plain file name")
        return name

    def _end_store_input(self) -> None:
        if self.store_input is not None:
            self.events.append(("store_input", self.store_input))
            self.store_input = None

    def _zero(self, stmt: Statement) -> None:
        what = stmt.keyword[5:]
        f = stmt.fields
        if what == "FORCE":
            if f["force_error"] <= 0 or f["percent_error"] <= 0:
                raise self.error("both limits must be positive")
            n = f.get("nsteps")
            if n is not None and not 1 <= n <= limits.MAX_RUN_STEPS:
                raise self.error(f"the step cap (third number) must lie in 1 ... "
                                 f"{limits.MAX_RUN_STEPS} (limit MAX_RUN_STEPS), got {n}")
            if "FORCE" in self.state.zero:
                self.msg("ZERO (FORCE) is redefined.")
            self.state.zero["FORCE"] = (f["force_error"], f["percent_error"])
            self.state.max_steps = n  # a repeat without it restores the default
            return
        try:
            tol = limits.check_tolerance(f["tolerance"], "the tolerance")
        except InputError as exc:
            raise self.error(str(exc)) from None
        n = f.get("nsteps")
        old = self.state.tolerance(what)
        if n is None or n <= 0:
            n = old[1]
        elif n > limits.MAX_ITERATIONS:
            raise self.error(f"{n} iterations are more than {limits.MAX_ITERATIONS} (limit "
                             "MAX_ITERATIONS); Newton's method converges in a few, or not at "
                             "all")
        self.state.zero[what] = (tol, n)
        if what in ("DATA", "ZERO"):  # IMP's own tests; openimp's are stated per check
            self.msg(f"ZERO ({what}) is accepted and not used: openimp's data checks and "
                     "zero tests have their own stated tolerances (docs/imp.md, Limits).")

    def _identify(self, types: list[str]) -> None:
        st = self.state
        lists: dict[str, list[str]] = {
            "VALUES": list(st.values), "LINKS": list(st.links), "JOINTS": list(st.joints),
            "POINTS": list(st.points), "AXES": list(st.graphics.axes),
            "SPRINGS": list(st.extras.get("springs", {})),
            "DAMPERS": list(st.extras.get("dampers", {})),
            "FORCES": list(st.extras.get("forces", {})),
            "TORQUES": list(st.extras.get("torques", {})),
            "CONTACTS": list(st.extras.get("contacts", {})),
            "INPUTS": list(st.inputs), "IC": list(st.extras.get("ics", {})),
        }
        for t in types:
            if t == "ALL":
                for k, v in lists.items():
                    self.text(f"{k.capitalize()}: {' '.join(v) or '(none)'}")
            elif t == "ZEROES":
                for k in ZERO_DEFAULTS:
                    v, n = st.tolerance(k)
                    self.text(f"Zero ({k}) = {v:g}" + (f", {n:g}" if n is not None else ""))
            elif t == "LOOPS":
                self.text(f"Loops: {len(st.joints) - len(st.links) + 1} independent loop(s) "
                          f"from {len(st.joints)} joints and {len(st.links)} links")
            else:
                self.text(f"{t.capitalize()}: {' '.join(lists.get(t, [])) or '(none)'}")

    def _execute(self, stmt: Statement) -> None:
        self._end_store_input()
        st = self.state
        if st.mode == "dynamic" and st.time is None:
            fw = st.find_where
            raise self.error("EXECUTE in dynamic mode (FIND DYNAMICS"
                             + (f" at {fw[0]}:{fw[1]}" if fw else "") + ") needs DATA TIME = "
                             "final, minstep, printstep before it (IMP interrupts the run "
                             "without it); give DATA TIME, or cancel dynamic mode with DELETE "
                             "DYNAMICS")
        self._check_joints()
        spec = RunSpec(len(self.runs) + 1, st.snapshot(), stmt.where,
                       stmt.keyword == "EXECUTE HOLD", stmt, st.mode)
        self.runs.append(spec)
        self.events.append(("run", spec))
        if st.find is None:
            st.kinematic = True

    def _check_joints(self) -> None:
        """At EXECUTE, what a new user trips over, each warned about once, located: a joint
        with no placement on a link (no DATA <joint> nor DATA LINK statement: its frame
        there would be the link's own frame), and a link named in one joint only whose
        name is one letter from another link's (a misspelling makes a new link)."""
        st = self.state
        for name, jd in st.joints.items():
            missing = [lk for lk, L in ((jd.link1, jd.local1), (jd.link2, jd.local2))
                       if L is None]
            key = ("unplaced", name, tuple(missing))
            if not missing or key in self._warned:
                continue
            self._warned.add(key)
            form = (f"DATA {jd.keyword} ({name}) = ... or " if IMP_JOINTS[jd.keyword].data_form
                    else "")
            self.warn(f"{jd.keyword} joint {name} is not placed on link(s) "
                      f"{', '.join(missing)}: no DATA statement gives its frame there, so the "
                      "link's own frame is used, which is rarely what is meant; place it with "
                      f"{form}DATA LINK (link, {name}) = ...", jd.where)
        triples = [(n, jd.link1, jd.link2) for n, jd in st.joints.items()]
        for b, j, o, ojs in misspelt_bodies(triples, st.ground):
            key = ("misspelt", b, o)
            if key in self._warned:
                continue
            self._warned.add(key)
            other = st.joints[ojs[0]].where
            self.warn(f"link {b} is named in joint {j} only, and its name is one letter from "
                      f"link {o} (joint {ojs[0]} at {other[0]}:{other[1]}): a misspelt link "
                      "name makes a new link; give one link one name", st.joints[j].where)

    # ------------------------------------------------------------------ DELETE
    def _delete_joint(self, name: str) -> None:
        st = self.state
        st.joints.pop(name, None)
        st.inputs.pop(name, None)
        st.graphics.axes.pop(name, None)
        for key in ("spring_data", "damper_data", "load_data", "ics"):
            st.extras.get(key, {}).pop(name, None)

    def _delete_point(self, name: str) -> None:
        st = self.state
        st.points.pop(name, None)
        for kind in ("springs", "dampers", "forces", "torques"):
            d = st.extras.get(kind, {})
            for el in [k for k, v in d.items() if name in v["points"]]:
                self.msg(f"{kind[:-1].capitalize()} {el} depends on point {name} and is "
                         "deleted.")
                del d[el]
        st.polylines = [(lk, [p for p in pts if p != name]) for lk, pts in st.polylines]

    def _delete(self, stmt: Statement) -> None:
        kw = stmt.keyword[7:]
        st = self.state
        f = stmt.fields
        names: list[str] = f.get("names", [])
        every = bool(f.get("all"))

        def targets(pool: Iterable[str], label: str) -> list[str]:
            pool = list(pool)
            if every:
                return pool
            out = []
            for n in names:
                if n in pool:
                    out.append(n)
                else:
                    self.msg(f"{label} {n} is not defined; it is skipped.")
            return out

        if kw == "TITLE":
            st.title = None
        elif kw == "VALUE":
            for n in targets(st.values, "VALUE"):
                del st.values[n]
        elif kw == "JOINT":
            for n in targets(st.joints, "Joint"):
                self._delete_joint(n)
        elif kw == "LINK":
            for n in targets(st.links, "Link"):
                for j in [j for j, d in st.joints.items() if n in (d.link1, d.link2)]:
                    self._delete_joint(j)
                for p in [p for p, d in st.points.items() if d.link == n]:
                    self._delete_point(p)
                del st.links[n]
                st.extras.get("masses", {}).pop(n, None)
                st.extras.get("inertias", {}).pop(n, None)
        elif kw == "POINT":
            for n in targets(st.points, "Point"):
                self._delete_point(n)
        elif kw == "GRAVITY":
            st.extras.pop("gravity", None)
        elif kw == "MASS":
            for n in targets(st.extras.get("masses", {}), "Mass of link"):
                st.extras["masses"].pop(n, None)
                st.extras.get("inertias", {}).pop(n, None)
        elif kw in ("SPRING", "DAMPER", "FORCE", "TORQUE", "SOLID", "CONTACT", "IC"):
            store = {"SPRING": ("springs", "spring_data"), "DAMPER": ("dampers", "damper_data"),
                     "FORCE": ("forces", "torques", "load_data"),
                     "TORQUE": ("forces", "torques", "load_data"), "SOLID": ("solids",),
                     "CONTACT": ("contacts", "contact_data"), "IC": ("ics",)}[kw]
            pool = {n for s in store for n in st.extras.get(s, {})}
            for n in targets(sorted(pool), kw.capitalize()):
                for s in store:
                    st.extras.get(s, {}).pop(n, None)
        elif kw in ("INPUT", "MOTION"):
            if kw == "INPUT" and every:
                st.inputs.clear()
                st.kinematic = False
                st.extras.pop("rates_given", None)
                if st.find is None:
                    pass
            else:
                for n in targets(st.inputs, "Input of joint"):
                    del st.inputs[n]
        elif kw in ("PRINT", "LIST", "STORE", "PLOT"):
            kinds = f["kinds"]
            if "INPUT" in kinds:
                if kw == "PRINT":
                    self.echo = False
                else:
                    self._end_store_input()
                kinds = [k for k in kinds if k != "INPUT"]
            if kinds:
                st.requests = [r for r in st.requests if not (
                    r.family == kw and ("ALL" in kinds or r.quantity in kinds))]
        elif kw == "VIEW":
            st.graphics.view = "FRONT"
        elif kw == "EQUILIB":
            if st.find != "EQUILIB":
                raise self.error("there is no FIND EQUILIB to cancel")
            st.find = None
            st.inputs.clear()
        elif kw == "DYNAMICS":
            if st.find != "DYNAMICS":
                raise self.error("there is no FIND DYNAMICS to cancel")
            st.find = None
            st.inputs = {k: v for k, v in st.inputs.items() if v.kind != "MOTION"}
            st.time = None
            st.time_where = None
        else:  # pragma: no cover
            raise self.error(f"DELETE {kw} is not handled")

    # ------------------------------------------------------------------ graphics
    def _graphics(self, stmt: Statement) -> None:
        kw = stmt.keyword
        f = stmt.fields
        g = self.state.graphics
        g.used = True
        if kw == "SHOW":
            if f["all"]:
                g.all_color = f["color"]
                g.erased.clear()
            for n in f["names"]:
                g.colors[n] = f["color"]
                g.erased.discard(n)
            if f["loops"]:
                g.interactive.append(stmt.where)
        elif kw == "ERASE":
            if f["all"]:
                g.erased.add("*")
            g.erased.update(f["names"])
        elif kw == "AXES":
            length = f["length"]
            if f["all"]:
                g.axes_all = length
                if length == 0:
                    g.axes.clear()
            for n in f["names"]:
                self._jdef(n)
                if length == 0:
                    g.axes.pop(n, None)
                else:
                    g.axes[n] = length
        elif kw == "DRAW":
            g.animate = False
            self.events.append(("draw", (self.state.snapshot(), stmt.where)))
        elif kw == "ANIMATE":
            g.animate = True
        else:  # DEVICE, ZOOM, SLIDE, TURN, STORE VIEW, RECALL VIEW
            g.interactive.append(stmt.where)


# =============================================================================
# Model building
# =============================================================================
@dataclass
class Built:
    """A model built from a state, with the maps results need."""

    model: Model
    #: joint -> (ImpJoint, JointDef, IMP frame 1 in body-1 coordinates, frame 2 in body 2)
    joints: dict[str, tuple[Any, JointDef, np.ndarray, np.ndarray]]
    messages: list[str]
    #: the mass and load data put on the model (VALUE laws, deleted elements)
    dyn: DynamicData = field(default_factory=DynamicData)


def _locate(exc: InputError, where: Where) -> InputError:
    if exc.where is None:
        exc.where = where
    return exc


def build_model(state: State, where: Where) -> Built:
    """Build the openimp :class:`Model` of a state (IMP's checks at EXECUTE).

    Raises :class:`InputError` located at the statement to change.
    """
    model = Model(state.title or DEFAULT_TITLE, ground=state.ground)
    messages: list[str] = []
    used = {lk for jd in state.joints.values() for lk in (jd.link1, jd.link2)}
    for name, _ld in state.links.items():
        if name not in used:
            messages.append(f"Link {name} is in no joint; it is deleted.")
    if not state.joints:
        raise InputError("EXECUTE: the model has no joints; define joints (ZPIN, REVOLUTE, ...) "
                         "before EXECUTE", where)
    if state.ground not in used:
        raise InputError(f"EXECUTE: the fixed link {state.ground} is in no joint; "
                         + ("name it in a joint or give GROUND = link"
                            if state.ground_where is None else
                            "connect it by a joint or name another fixed link"),
                         state.ground_where or where)
    for name in state.links:
        if name in used:
            model.add_body(name)
            model.set_body_frame(name, state.links[name].frame)
    joints: dict[str, tuple[Any, JointDef, np.ndarray, np.ndarray]] = {}
    for name, jd in state.joints.items():
        ij = imp_joint(state, jd)
        loc = jd.placed or jd.where
        if not ij.available:
            raise InputError(f"{jd.keyword} joint {name}: the openimp joint kind '{ij.kind}' is "
                             "not available in this installation", jd.where)
        if ij.params and not jd.params:
            raise InputError(f"{jd.keyword} joint {name} has no {ij.params} statement; it is "
                             f"required before EXECUTE ({ij.params} ({name}) = ...)", jd.where)
        T1 = state.links[jd.link1].frame
        T2 = state.links[jd.link2].frame
        L1 = np.eye(4) if jd.local1 is None else jd.local1
        L2 = np.eye(4) if jd.local2 is None else jd.local2
        F1 = T1 @ L1 @ ij.perm
        F2 = T2 @ L2 @ ij.perm
        try:
            if jd.keyword == "BEVEL":
                F1, F2 = bevel_frames(F1, F2, f"joint {name}")
            model.add_joint(ij.kind, name, jd.link1, jd.link2, frame1=F1, frame2=F2,
                            **jd.params)
        except InputError as exc:
            raise _locate(InputError(f"{jd.keyword} joint {name}: {exc}"),
                          jd.params_where or loc) from None
        joints[name] = (ij, jd, L1, L2)
    for name, pd in state.points.items():
        if pd.link not in used:
            messages.append(f"Point {name} is on link {pd.link}, which is in no joint; it is "
                            "deleted.")
            continue
        T = state.links[pd.link].frame
        g = np.zeros(3) if pd.local is None else (T @ np.append(pd.local, 1.0))[:3]
        model.add_point(name, pd.link, g)
    dyn = add_dynamic_data(state, model, joints, messages)
    extras = {k: copy.deepcopy(v) for k, v in state.extras.items()}
    extras["inputs"] = copy.deepcopy(state.inputs)
    extras["find"] = state.find
    extras["time"] = state.time
    extras["zero"] = dict(state.zero)
    extras["unit_mass"] = state.unit_mass
    extras["graphics"] = copy.deepcopy(state.graphics)
    model.extras = extras
    return Built(model, joints, messages, dyn)


def _acts_beyond(state: State, jd: JointDef, ij: Any) -> bool:
    """True when the deck puts a spring, damper, load, motion or initial condition on
    a variable of joint ``jd`` that the default kind ``ij`` has not as a coordinate."""
    name, ex = jd.name, state.extras
    for _store, _stmt, jname, _data, entries in joint_data(ex):
        if jname == name and any(k < ij.nvar and ij.drive[k] is None
                                 and any(p is not None for p in parts)
                                 for k, parts in enumerate(entries)):
            return True
    inp = state.inputs.get(name)
    if inp is not None and inp.kind == "MOTION" and any(
            m is not None and ij.drive[k] is None for k, m in enumerate(inp.motions)):
        return True
    ic = ex.get("ics", {}).get(name)
    return ic is not None and any(
        (p is not None or v is not None) and ij.drive[k] is None and not ij.is_cardan(k)
        for k, (p, v) in enumerate(ic["pairs"]))


def imp_joint(state: State, jd: JointDef) -> Any:
    """The :class:`~openimp.imp.jointmap.ImpJoint` a deck's joint becomes: the keyword's
    default, or its :data:`~openimp.imp.jointmap.IMP_DIRECT` kind (IMP's own variables as
    coordinates) when the deck acts on a variable the default has not (a SPHERE's
    Cardan angle with a spring, a FLAT's radius with a motion)."""
    ij = IMP_JOINTS[jd.keyword]
    if jd.keyword in IMP_DIRECT and _acts_beyond(state, jd, ij):
        return IMP_DIRECT[jd.keyword]
    return ij


def compile_built(built: Built, state: State, where: Where) -> Any:
    """Compile a built model, locating conformity errors at the joint's placement."""
    import re

    try:
        return compile_model(built.model, log=False)  # the deck says them located
    except InputError as exc:
        msg = str(exc)
        m = re.search(r"joint '([^']+)'", msg)
        loc = where
        if m and m.group(1) in state.joints:
            jd = state.joints[m.group(1)]
            loc = jd.placed or jd.params_where or jd.where
            msg = re.sub(r"joint '([^']+)' \(([a-z_]+)\)",
                         lambda g: f"{jd.keyword} joint {g.group(1)} (openimp {g.group(2)})",
                         msg, count=1)
            if not msg.startswith(jd.keyword):
                msg = f"{jd.keyword} joint {jd.name}: {msg}"
        raise InputError(msg, loc) from None
