"""Parser of the IMP problem-oriented language (docs/imp-language.md §§3, 5-12).

A deck (a file or a text) becomes a list of :class:`Statement` objects, one per
statement, in order.  Parsing is positional, as in IMP: outside VALUE
expressions the parentheses, ``=`` and commas are mere separators, so
``ZPIN (BASE, LKBD) = D`` and ``ZPIN BASE LKBD = D`` are the same statement.

Every statement has a ``kind`` (``DEFINE``, ``VALUE``, ``DATA``, ``REQUEST``,
``CONTROL``, ``DELETE``, ``GRAPHICS``), a normalised ``keyword`` (``'ZPIN'``,
``'DATA LINK'``, ``'LIST POSITION'``, ``'ZERO POSITION'`` ...), the user
``names`` and the ``numbers`` in the order they appear (after implied zeros
and the trailing zero fill), and ``fields``: the same data under the names
docs/imp-language.md gives them (see :data:`FIELDS`).

Malformed statements raise :class:`~openimp.errors.InputError` located at
``file:line``; parsing raises nothing else.  Pass ``on_error`` to collect the
errors and go on with the next statement, as IMP did interactively.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Generator, Iterable, Iterator
from dataclasses import dataclass, field
from typing import Any

from openimp.errors import InputError, PassedOverError
from openimp.files import quote, quote_path, read_text, real_roots
from openimp.imp.expr import (
    FUNCTIONS,
    Call,
    Expression,
    If,
    Node,
    Num,
    Ref,
    Stop,
    Table,
    Time,
    User,
    ValueRef,
    parse_expression_at,
)
from openimp.imp.lexer import (
    COLUMNS,
    Item,
    Scanner,
    SourceStatement,
    Token,
    keyword_key,
    reduce_items,
    split_lines,
    split_statements,
    tokenize,
)
from openimp.limits import (
    MAX_INPUT_ERRORS,
    MAX_NUMBER,
    MAX_READ_BYTES,
    MAX_RECALL_DEPTH,
    MAX_STATEMENTS,
    number_text,
)

__all__ = [
    "DATA_KEYWORDS",
    "FIELDS",
    "JOINT_DOF",
    "KINDS",
    "LEADING_KEYWORDS",
    "MAX_NAMES",
    "MAX_WORDS",
    "Datum",
    "Statement",
    "iter_statements",
    "parse",
    "parse_file",
    "parse_statement",
    "parse_text",
]

#: Statement kinds (the six categories of docs/imp-language.md §3, with VALUE apart).
KINDS = ("DEFINE", "VALUE", "DATA", "REQUEST", "CONTROL", "DELETE", "GRAPHICS")

#: IMP's limit on the words and numbers of one statement (docs/imp-language.md §3); only warned.
MAX_WORDS = 35
#: IMP's limit on the names of one list statement (docs/imp-language.md §6); only warned.
MAX_NAMES = 33

#: Joint keyword -> number of joint variables (docs/imp-language.md §7.2).
JOINT_DOF: dict[str, int] = {
    "RIGID": 0, "XPIN": 1, "YPIN": 1, "ZPIN": 1, "REVOLUTE": 1, "XSLIDE": 1, "YSLIDE": 1,
    "ZSLIDE": 1, "PRISM": 1, "GEAR": 1, "BEVEL": 1, "RACK": 1, "SCREW": 1, "CAM": 2,
    "SLOT": 2, "CYLINDER": 2, "UJOINT": 2, "FLAT": 3, "PLANE": 3, "SPHERE": 3, "OPEN": 6,
}

#: A datum that may be a number, a VALUE name, or ``None`` for ``NONE``.
Datum = float | str | None


def _kw(*words: str) -> dict[str, str]:
    """Map the 4-letter keys of ``words`` to the words."""
    return {keyword_key(w): w for w in words}


#: The 61 leading keywords (docs/imp-language.md §16), keyed by their 4-letter form.
LEADING_KEYWORDS = _kw(
    *JOINT_DOF, "LINK", "GROUND", "SOLID", "SHAPE", "CONTACT", "IMPACT", "POINT", "SPRING",
    "DAMPER", "FORCE", "TORQUE", "VALUE", "DATA", "PRINT", "LIST", "STORE", "PLOT", "REMARK",
    "CLEAR", "TITLE", "EXECUTE", "RESET", "FIND", "ZERO", "END", "RETURN", "RECALL", "UNIT",
    "PAUSE", "ERASE", "IDENTIFY", "DELETE", "DEVICE", "DRAW", "ANIMATE", "SHOW", "AXES", "ZOOM",
    "SLIDE", "TURN",
)

#: The 37 second keywords of DATA statements (docs/imp-language.md §8).
DATA_KEYWORDS = _kw(
    "LINK", "RIGID", "XPIN", "YPIN", "ZPIN", "REVOLUTE", "XSLIDE", "YSLIDE", "ZSLIDE", "PRISM",
    "CYLINDER", "UJOINT", "SPHERE", "GEAR", "BEVEL", "RACK", "SCREW", "CAM", "SLOT", "POINT",
    "GRAVITY", "DENSITY", "MASS", "INERTIA", "SPRING", "DAMPER", "FORCE", "TORQUE", "CONTACT",
    "POSITION", "VELOCITY", "ACCEL", "MOTION", "IC", "TIME", "VIEW", "DRAW",
)

# number of point slots (a triple or a point name each) of the frame-placement forms
_SLOTS = {"LINK": 3, "RIGID": 3, "XPIN": 3, "YPIN": 3, "ZPIN": 3, "REVOLUTE": 4, "XSLIDE": 1,
          "YSLIDE": 1, "ZSLIDE": 1, "PRISM": 3, "CYLINDER": 3, "UJOINT": 3, "SPHERE": 1}

_QUANTITIES = _kw("VALUE", "HEADING", "POSITION", "VELOCITY", "ACCEL", "FORCE", "FREQUENCY",
                  "DYNAMICS")
_FLOW = ("POSITION", "VELOCITY", "ACCEL", "FORCE")
_REQUESTS = {
    "PRINT": ("VALUE", "HEADING", *_FLOW, "FREQUENCY", "DYNAMICS"),
    "LIST": ("VALUE", *_FLOW, "DYNAMICS"),
    "STORE": ("VALUE", "HEADING", *_FLOW, "DYNAMICS"),
    "PLOT": ("VALUE", *_FLOW, "DYNAMICS"),
}
_DELETE_KINDS = {
    "PRINT": (*_REQUESTS["PRINT"], "ALL", "INPUT"),
    "LIST": (*_REQUESTS["LIST"], "ALL"),
    "STORE": (*_REQUESTS["STORE"], "ALL", "INPUT"),
    "PLOT": (*_REQUESTS["PLOT"], "ALL"),
}
_ZERO = _kw("DATA", "POSITION", "EQUILIB", "SYSTEM", "INERTIA", "SPRING", "INDETERM", "ZERO",
            "FORCE")
_DELETE = _kw("TITLE", "VALUE", "SOLID", "CONTACT", "LINK", "JOINT", "POINT", "GRAVITY", "MASS",
              "SPRING", "DAMPER", "FORCE", "TORQUE", "INPUT", "MOTION", "IC", "PRINT", "LIST",
              "STORE", "PLOT", "VIEW", "EQUILIB", "DYNAMICS")
_DELETE_BARE = ("TITLE", "GRAVITY", "VIEW", "EQUILIB", "DYNAMICS")
_COLOURS = {"BLAC": "BLACK", "RED": "RED", "ORAN": "ORANGE", "YELL": "YELLOW", "GREE": "GREEN",
            "AQUA": "CYAN", "CYAN": "CYAN", "BLUE": "BLUE", "VIOL": "MAGENTA",
            "MAGE": "MAGENTA", "WHIT": "WHITE"}
_VIEWS = _kw("FRONT", "BACK", "TOP", "BOTTOM", "LEFT", "RIGHT", "ISOMETRIC")
_IDENTIFY = {"VALU": "VALUES", "LINK": "LINKS", "CONT": "CONTACTS", "JOIN": "JOINTS",
             "AXES": "AXES", "AXIS": "AXES", "POIN": "POINTS", "SPRI": "SPRINGS",
             "DAMP": "DAMPERS", "FORC": "FORCES", "TORQ": "TORQUES", "INPU": "INPUTS",
             "IC": "IC", "ALL": "ALL", "LOOP": "LOOPS", "ZERO": "ZEROES"}
_AXES = _kw("X", "Y", "Z")
_ON_OFF = _kw("ON", "OFF")
_ALL = "ALL"
_NONE = "NONE"

# hints for words that are not IMP keywords but look like they were meant as one
_HINTS = {
    "PIN": "there is no PIN joint: use XPIN, YPIN, ZPIN or REVOLUTE",
    "BALL": "a ball-and-socket joint is SPHERE",
    "UNIV": "a universal (Hooke) joint is UJOINT",
    "HOOK": "a Hooke (universal) joint is UJOINT",
    "TABL": "TABLE is a VALUE function: VALUE (name) = TABLE(x): filename",
    "INER": "inertia data is DATA INERTIA (link, joint) = Ixx, Iyy, Izz, Ixy, Ixz, Iyz",
    "MASS": "mass data is DATA MASS (link, joint) = m; u, v, w",
    "GRAV": "gravity is DATA GRAVITY = gx, gy, gz",
}

#: The form of each statement keyword, as shown in error messages.
USAGE: dict[str, str] = {
    "LINK": "LINK = link",
    "GROUND": "GROUND = link",
    "SOLID READ": "SOLID READ (solid) = filename",
    "SHAPE": "SHAPE (link) = solid1, solid2, ...",
    "CONTACT": "CONTACT (solid1, solid2) = contact",
    "IMPACT": "IMPACT = ktangent, kmoment, ktorsion",
    "VALUE": "VALUE (name) = expression",
    "POINT": "POINT (link) = point1, point2, ...",
    "SPRING": "SPRING (point1, point2) = spring",
    "DAMPER": "DAMPER (point1, point2) = damper",
    "FORCE": "FORCE (point / point_a, point_b) = force",
    "TORQUE": "TORQUE (link / point_a, point_b) = torque",
    "DATA LINK": "DATA LINK (link, joint) = x1,y1,z1; x2,y2,z2; x3,y3,z3  or  "
                 "DATA LINK (link, LINK) = ...",
    "DATA REVOLUTE": "DATA REVOLUTE (joint) = x1,y1,z1; x2,y2,z2; x3,y3,z3; x4,y4,z4",
    "DATA XSLIDE": "DATA XSLIDE (joint) = x,y,z",
    "DATA YSLIDE": "DATA YSLIDE (joint) = x,y,z",
    "DATA ZSLIDE": "DATA ZSLIDE (joint) = x,y,z",
    "DATA SPHERE": "DATA SPHERE (joint) = x,y,z",
    "DATA GEAR": "DATA GEAR (joint) = ratio, distance",
    "DATA BEVEL": "DATA BEVEL (joint) = ratio, radius",
    "DATA RACK": "DATA RACK (joint) = radius",
    "DATA SCREW": "DATA SCREW (joint) = lead",
    "DATA CAM": "DATA CAM (joint) = valuename",
    "DATA SLOT": "DATA SLOT (joint) = valuename",
    "DATA POINT": "DATA POINT (point, joint|LINK|ABS) = x,y,z",
    "DATA GRAVITY": "DATA GRAVITY = gx, gy, gz",
    "DATA DENSITY": "DATA DENSITY (solid) = density",
    "DATA MASS": "DATA MASS (link, joint|LINK) = mass; u,v,w",
    "DATA INERTIA": "DATA INERTIA (link, joint|LINK) = Ixx, Iyy, Izz, Ixy, Ixz, Iyz",
    "DATA SPRING": "DATA SPRING (name) = rate, free; rate, free; ...",
    "DATA DAMPER": "DATA DAMPER (name) = c, c, ...",
    "DATA FORCE": "DATA FORCE (name) = f, f, ...",
    "DATA TORQUE": "DATA TORQUE (name) = t, t, ...",
    "DATA CONTACT": "DATA CONTACT (contact) = e_n, e_t, e_b, e_r, mu",
    "DATA POSITION": "DATA POSITION (joint) = start, increment, nsteps",
    "DATA VELOCITY": "DATA VELOCITY (joint) = velocity",
    "DATA ACCEL": "DATA ACCEL (joint) = acceleration",
    "DATA MOTION": "DATA MOTION (joint) = p1, p2, ...",
    "DATA IC": "DATA IC (joint) = position, velocity; position, velocity; ...",
    "DATA TIME": "DATA TIME = final, minstep, printstep",
    "DATA VIEW": "DATA VIEW = xe,ye,ze; xv,yv,zv  or  DATA VIEW = FRONT|BACK|TOP|BOTTOM|LEFT|"
                 "RIGHT|ISOMETRIC",
    "DATA DRAW": "DATA DRAW = distance",
    "REMARK": "REMARK text",
    "TITLE": "TITLE = text",
    "CLEAR": "CLEAR",
    "EXECUTE": "EXECUTE  or  EXECUTE HOLD",
    "RESET": "RESET",
    "END": "END",
    "RETURN": "RETURN",
    "FIND": "FIND EQUILIB  or  FIND DYNAMICS",
    "PRINT INPUT": "PRINT INPUT",
    "STORE INPUT": "STORE INPUT = filename",
    "RECALL INPUT": "RECALL INPUT = filename",
    "UNIT MASS": "UNIT (MASS) = value",
    "UNIT": "UNIT (MASS) = value",
    "PRINT ON": "PRINT ON = filename",
    "PRINT OFF": "PRINT OFF",
    "PAUSE": "PAUSE ON  or  PAUSE OFF",
    "IDENTIFY": "IDENTIFY type, type, ...",
    "ZERO": "ZERO (DATA|POSITION|EQUILIB|SYSTEM|INERTIA|SPRING|INDETERM|ZERO|FORCE) = value",
    "ZERO POSITION": "ZERO (POSITION) = value, nsteps",
    "ZERO EQUILIB": "ZERO (EQUILIB) = value, nsteps",
    "ZERO FORCE": "ZERO (FORCE) = force error, percent error",
    "DELETE": "DELETE kind (name, ...)",
    "DATA": "DATA keyword (name, ...) = numbers",
    "PRINT": "PRINT VALUE|HEADING|POSITION|VELOCITY|ACCEL|FORCE|FREQUENCY|DYNAMICS (name, ...)",
    "LIST": "LIST VALUE|POSITION|VELOCITY|ACCEL|FORCE|DYNAMICS (name, ...)",
    "STORE": "STORE VALUE|HEADING|POSITION|VELOCITY|ACCEL|FORCE|DYNAMICS (name, ...)",
    "PLOT": "PLOT VALUE|POSITION|VELOCITY|ACCEL|FORCE|DYNAMICS (name, ...)",
    "RECALL": "RECALL INPUT = filename  or  RECALL VIEW",
    "DEVICE": "DEVICE = ALPHA  or  DEVICE = GRAPHIC",
    "DRAW": "DRAW",
    "ANIMATE": "ANIMATE",
    "SHOW": "SHOW (colour) = name, ...",
    "ERASE": "ERASE (name, ...)  or  ERASE ON|OFF",
    "AXES": "AXES (length) = joint, ...",
    "ZOOM": "ZOOM (power) = xc, yc, zc",
    "SLIDE": "SLIDE (X|Y|Z) = distance",
    "TURN": "TURN (X|Y|Z) = angle",
    "STORE VIEW": "STORE VIEW",
    "RECALL VIEW": "RECALL VIEW",
    "PRINT DYNAMICS": "PRINT DYNAMICS (FORCE|MOTION, name, nin) = kind, name; ...",
    "STORE DYNAMICS": "STORE DYNAMICS (FORCE|MOTION, name, nin) = kind, name; ...",
    "LIST DYNAMICS": "LIST DYNAMICS (w0, wf, winc / FORCE|MOTION, name, nin) = kind, name; ...",
    "PLOT DYNAMICS": "PLOT DYNAMICS (w0, wf, winc; FORCE|MOTION, name, nin) = kind, name; ...",
}

#: The ``fields`` keys of each statement keyword (``<joint>`` stands for the
#: 21 joint keywords, ``<family>`` for PRINT/LIST/STORE/PLOT).
FIELDS: dict[str, tuple[str, ...]] = {
    "<joint>": ("type", "link1", "link2", "joint", "dof"),
    "LINK": ("link",), "GROUND": ("link",), "SOLID READ": ("solid", "filename"),
    "SHAPE": ("link", "solids"), "CONTACT": ("solid1", "solid2", "contact"),
    "IMPACT": ("tangent", "moment", "torsion"),
    "VALUE": ("name", "expression", "source"),
    "POINT": ("link", "points"), "SPRING": ("point1", "point2", "name"),
    "DAMPER": ("point1", "point2", "name"),
    "FORCE": ("point", "point_a", "point_b", "name"),
    "TORQUE": ("link", "point_a", "point_b", "name"),
    "DATA LINK": ("link", "joint", "frame", "points", "filled"),
    "DATA <placement>": ("joint", "points", "filled"),
    "DATA GEAR": ("joint", "ratio", "distance"), "DATA BEVEL": ("joint", "ratio", "radius"),
    "DATA RACK": ("joint", "radius"), "DATA SCREW": ("joint", "lead"),
    "DATA CAM": ("joint", "value"), "DATA SLOT": ("joint", "value"),
    "DATA POINT": ("point", "frame", "joint", "coords"),
    "DATA GRAVITY": ("vector",), "DATA DENSITY": ("solid", "density"),
    "DATA MASS": ("link", "frame", "joint", "mass", "center"),
    "DATA INERTIA": ("link", "frame", "joint", "inertia"),
    "DATA SPRING": ("name", "pairs"), "DATA DAMPER": ("name", "coefficients"),
    "DATA FORCE": ("name", "loads"), "DATA TORQUE": ("name", "loads"),
    "DATA CONTACT": ("contact", "en", "et", "eb", "er", "mu"),
    "DATA POSITION": ("joint", "start", "increment", "nsteps"),
    "DATA VELOCITY": ("joint", "velocity"), "DATA ACCEL": ("joint", "acceleration"),
    "DATA MOTION": ("joint", "motions"), "DATA IC": ("joint", "pairs"),
    "DATA TIME": ("final", "minstep", "printstep"),
    "DATA VIEW": ("view", "eye", "up"), "DATA DRAW": ("distance",),
    "<family> VALUE|POSITION|VELOCITY|ACCEL|FORCE": ("family", "quantity", "names", "all"),
    "PRINT|STORE HEADING, PRINT FREQUENCY": ("family", "quantity"),
    "PRINT|STORE DYNAMICS": ("family", "quantity", "input", "namein", "nin", "pairs"),
    "LIST|PLOT DYNAMICS": ("family", "quantity", "w0", "wf", "winc", "input", "namein", "nin",
                           "pairs"),
    "REMARK": ("text",), "TITLE": ("title",), "EXECUTE": ("hold",),
    "EXECUTE HOLD": ("hold",), "RETURN": ("ends_recall", "simulated"),
    "STORE INPUT": ("filename",), "RECALL INPUT": ("filename", "path"),
    "UNIT MASS": ("value",), "PRINT ON": ("filename",), "IDENTIFY": ("types",),
    "ZERO DATA|SYSTEM|INERTIA|SPRING|INDETERM|ZERO": ("tolerance",),
    "ZERO POSITION|EQUILIB": ("tolerance", "nsteps"),
    "ZERO FORCE": ("force_error", "percent_error", "nsteps"),
    "DELETE <names>": ("names", "all"), "DELETE PRINT|LIST|STORE|PLOT": ("kinds", "all"),
    "DEVICE": ("device",), "SHOW": ("color", "names", "all", "loops"),
    "ERASE": ("names", "all", "loops", "clear"), "AXES": ("length", "names", "all"),
    "ZOOM": ("power", "center"), "SLIDE": ("axis", "distance"), "TURN": ("axis", "angle"),
    "STORE VIEW": ("number",), "RECALL VIEW": ("number",),
}


@dataclass
class Statement:
    """One parsed IMP statement.

    Attributes:
        kind: ``DEFINE``, ``VALUE``, ``DATA``, ``REQUEST``, ``CONTROL``,
            ``DELETE`` or ``GRAPHICS``.
        keyword: the normalised keyword, e.g. ``'ZPIN'``, ``'DATA LINK'``,
            ``'LIST POSITION'``, ``'ZERO POSITION'``, ``'EXECUTE HOLD'``.
        names: the user names in order of appearance (significant form).
        written: the same names as the deck spells them (all their characters).
        numbers: the numbers in order of appearance, implied and filled zeros
            included.
        fields: the data under the names of docs/imp-language.md (see :data:`FIELDS`).
        file, line, end_line: where the statement is (first and last line).
        text: the original source lines of the statement.
        warnings: IMP-style messages, printable as ``*** {warning} ***``.
        remarks: the embedded remarks (text after ``$`` or ``$$``).
    """

    kind: str
    keyword: str
    names: list[str] = field(default_factory=list)
    written: list[str] = field(default_factory=list)
    numbers: list[float] = field(default_factory=list)
    fields: dict[str, Any] = field(default_factory=dict)
    file: str = "<text>"
    line: int = 0
    end_line: int = 0
    text: str = ""
    warnings: list[str] = field(default_factory=list)
    remarks: list[str] = field(default_factory=list)

    @property
    def where(self) -> tuple[str, int]:
        """``(file, line)`` of the statement."""
        return (self.file, self.line)

    def get(self, key: str, default: Any = None) -> Any:
        """``fields.get(key, default)``."""
        return self.fields.get(key, default)

    def error(self, message: str) -> InputError:
        """An :class:`InputError` about this statement, located at its line."""
        return InputError(f"{self.keyword} statement: {message}", self.where)


# --------------------------------------------------------------------------- building


class _Ctx:
    """State of the statement being built."""

    def __init__(self, src: SourceStatement, significant: int | None, base_dir: str | None,
                 roots: tuple[str, ...] | None = None):
        self.src = src
        self.sig_len = significant
        self.base_dir = base_dir
        self.roots = roots
        self.stmt = Statement(kind="", keyword="", file=src.file, line=src.line,
                              end_line=src.end_line, text=src.source,
                              warnings=src.warnings, remarks=list(src.remarks))

    def sig(self, name: str) -> str:
        return name if self.sig_len is None else name[: self.sig_len]

    def set(self, kind: str, keyword: str) -> None:
        self.stmt.kind, self.stmt.keyword = kind, keyword

    def usage(self) -> str:
        kw = self.stmt.keyword
        if kw in USAGE:
            return USAGE[kw]
        if kw in JOINT_DOF:
            first, second = {"RACK": ("rack", "pinion"), "CAM": ("cam", "follower"),
                             "SLOT": ("slotted link", "follower")}.get(kw, ("link1", "link2"))
            return f"{kw} ({first}, {second}) = joint"
        if kw.startswith("DATA ") and kw[5:] in _SLOTS:
            return f"{kw} (joint) = x1,y1,z1; x2,y2,z2; x3,y3,z3"
        head = kw.split(" ")[0]
        if head in _REQUESTS:
            return f"{kw} (name, ...)  or  {kw} (ALL)"
        if kw.startswith("ZERO "):
            return f"ZERO ({kw[5:]}) = value"
        if kw.startswith("DELETE "):
            return f"{kw} (name, ...)  or  {kw} (ALL)"
        return USAGE.get(head, kw)

    def error(self, msg: str, line: int | None = None) -> InputError:
        kw = self.stmt.keyword or "this"
        return InputError(f"{kw} statement: {msg}. Form: {self.usage()}",
                          (self.src.file, line if line is not None else self.src.line))

    def warn(self, msg: str) -> None:
        self.stmt.warnings.append(msg)


class _Cursor:
    """Positional reader of the items (words and numbers) of a statement."""

    def __init__(self, ctx: _Ctx, items: list[Item]) -> None:
        self.ctx = ctx
        self.stmt = ctx.stmt
        self.items = items
        self.i = 0
        self.filled = 0

    def error(self, msg: str, item: Item | None = None) -> InputError:
        return self.ctx.error(msg, item.line if item is not None else None)

    def peek(self) -> Item | None:
        return self.items[self.i] if self.i < len(self.items) else None

    def at_end(self) -> bool:
        return self.i >= len(self.items)

    def take(self) -> Item:
        item = self.items[self.i]
        self.i += 1
        return item

    def peek_keyword(self, table: dict[str, str]) -> str | None:
        item = self.peek()
        if item is None or item.kind != "WORD":
            return None
        return table.get(item.key)

    def keyword(self, table: dict[str, str], what: str) -> str:
        kw = self.peek_keyword(table)
        if kw is None:
            item = self.peek()
            found = "nothing" if item is None else item.describe()
            raise self.error(f"expected {what}, found {found}", item)
        self.take()
        return kw

    def name(self, what: str) -> str:
        item = self.peek()
        if item is None:
            raise self.error(f"the {what} is missing")
        if item.kind != "WORD":
            raise self.error(f"expected the {what}, found {item.describe()}", item)
        self.take()
        name = self.ctx.sig(item.text)
        self.stmt.names.append(name)
        self.stmt.written.append(item.text)
        return name

    def number(self, what: str, fill: bool = True) -> float:
        item = self.peek()
        if item is None:
            if not fill:
                raise self.error(f"the {what} is missing")
            self.filled += 1
            self.stmt.numbers.append(0.0)
            return 0.0
        if item.kind != "NUMBER":
            raise self.error(f"expected a number for the {what}, found {item.describe()}", item)
        self.take()
        value = float(item.value or 0.0)
        if abs(value) > MAX_NUMBER:
            raise self.error(f"the {what} {item.text} is beyond ±{number_text(MAX_NUMBER)} "
                             "(limit MAX_NUMBER): numbers that large overflow the 4x4 matrix "
                             "arithmetic; use other units", item)
        self.stmt.numbers.append(value)
        return value

    def opt_number(self, what: str = "value") -> float | None:
        item = self.peek()
        if item is None or item.kind != "NUMBER":
            return None
        return self.number(what)

    def datum(self, what: str) -> Datum:
        item = self.peek()
        if item is not None and item.kind == "WORD":
            if item.key == _NONE:
                self.take()
                return None
            return self.name(f"{what} (VALUE name)")
        return self.number(what)

    def data(self, what: str) -> list[Datum]:
        out: list[Datum] = []
        while not self.at_end():
            out.append(self.datum(f"{what} {len(out) + 1}"))
        if not out:
            raise self.error(f"at least one {what} is needed")
        return out

    def point(self, what: str, allow_name: bool = True) -> tuple[float, float, float] | str:
        item = self.peek()
        if item is not None and item.kind == "WORD":
            if not allow_name:
                raise self.error(f"expected x,y,z numbers for the {what}, found {item.describe()}",
                                 item)
            return self.name(f"{what} point")
        return (self.number(f"{what} x"), self.number(f"{what} y"), self.number(f"{what} z"))

    def names_list(
        self, what: str, allow_all: bool = True, loops: list[int] | None = None
    ) -> tuple[list[str], bool]:
        """Names up to the end; ``ALL`` sets the flag; ``LOOP n`` goes to ``loops``."""
        names: list[str] = []
        all_ = False
        while not self.at_end():
            item = self.peek()
            assert item is not None
            if item.kind == "WORD" and allow_all and item.key == _ALL:
                self.take()
                all_ = True
            elif item.kind == "WORD" and loops is not None and item.key == "LOOP":
                self.take()
                n = self.opt_number()
                loops.append(0 if n is None else round(n))
            else:
                names.append(self.name(what))
        if len(names) > MAX_NAMES:
            self.ctx.warn(f"Warning: IMP took at most {MAX_NAMES} names in one statement; this "
                          f"one has {len(names)} (all are kept).")
        return names, all_

    def finish(self) -> None:
        item = self.peek()
        if item is not None:
            raise self.error(f"{item.describe()} is one item too many: the statement's data "
                             "ended before it", item)
        if self.filled:
            self.ctx.warn(f"Warning: {self.filled} zeroes are added to complete statement.")


# --------------------------------------------------------------------------- handlers


def _h_joint(ctx: _Ctx, cur: _Cursor, jtype: str) -> None:
    ctx.set("DEFINE", jtype)
    first, second = {"RACK": ("rack link", "pinion link"), "CAM": ("cam link", "follower link"),
                     "SLOT": ("slotted link", "follower link")}.get(jtype,
                                                                    ("first link", "second link"))
    l1 = cur.name(first)
    l2 = cur.name(second)
    joint = cur.name("joint name")
    cur.finish()
    ctx.stmt.fields.update(type=jtype, link1=l1, link2=l2, joint=joint, dof=JOINT_DOF[jtype])


def _h_define(ctx: _Ctx, cur: _Cursor, lead: str) -> None:
    ctx.set("DEFINE", lead)
    f = ctx.stmt.fields
    if lead in ("LINK", "GROUND"):
        f["link"] = cur.name("link name")
    elif lead == "SHAPE":
        f["link"] = cur.name("link name")
        f["solids"], _ = cur.names_list("solid name", allow_all=False)
        if not f["solids"]:
            raise cur.error("at least one solid name is needed after the link")
    elif lead == "CONTACT":
        f["solid1"] = cur.name("first solid")
        f["solid2"] = cur.name("second solid")
        f["contact"] = cur.name("contact name")
    elif lead == "IMPACT":
        for key in ("tangent", "moment", "torsion"):
            f[key] = round(cur.number(f"{key} model"))
    elif lead == "POINT":
        f["link"] = cur.name("link name")
        f["points"], _ = cur.names_list("point name", allow_all=False)
        if not f["points"]:
            raise cur.error("at least one point name is needed after the link")
    elif lead in ("SPRING", "DAMPER"):
        f["point1"] = cur.name("first point")
        f["point2"] = cur.name("second point")
        f["name"] = cur.name(f"{lead.lower()} name")
    elif lead == "FORCE":
        f["point"] = cur.name("point of application")
        f["point_a"] = cur.name("first direction point")
        f["point_b"] = cur.name("second direction point")
        f["name"] = cur.name("force name")
    else:  # TORQUE
        f["link"] = cur.name("link the torque acts on")
        f["point_a"] = cur.name("first direction point")
        f["point_b"] = cur.name("second direction point")
        f["name"] = cur.name("torque name")
    cur.finish()


def _h_data(ctx: _Ctx, cur: _Cursor) -> None:
    ctx.set("DATA", "DATA")
    item = cur.peek()
    what = cur.peek_keyword(DATA_KEYWORDS)
    if what is None:
        if item is not None and item.kind == "WORD":
            key = item.key
            if key == "SHAP":  # IMP passed over it: PassedOverError, a warning unless strict
                e = cur.error("DATA SHAPE is mentioned by the manual but never documented; "
                              "attach solids with SHAPE (link) = solid, ... and place them "
                              "with DATA LINK (link, LINK)", item)
                raise PassedOverError(str(e.args[0]), e.where)
            if key == "ZERO":
                raise cur.error("there is no DATA ZERO statement; tolerances are set with "
                                "ZERO (POSITION) = value, nsteps and the other ZERO forms", item)
            if key in ("FLAT", "PLAN", "OPEN"):
                raise cur.error(f"there is no DATA {item.text.upper()}: place {item.text.upper()} "
                                "joints with two DATA LINK (link, joint) statements", item)
        valid = ", ".join(sorted(DATA_KEYWORDS.values()))
        found = "nothing" if item is None else item.describe()
        raise cur.error(f"unknown DATA form: found {found}; DATA is followed by one of {valid}",
                        item)
    cur.take()
    ctx.stmt.keyword = f"DATA {what}"
    f = ctx.stmt.fields
    if what in _SLOTS:
        _data_placement(ctx, cur, what)
        return
    if what in ("GEAR", "BEVEL"):
        f["joint"] = cur.name("joint name")
        f["ratio"] = cur.number("ratio")
        if what == "GEAR":
            f["distance"] = cur.opt_number("centre distance")  # optional: from the frames
        else:
            f["radius"] = cur.number("pitch radius of the second gear")
    elif what in ("RACK", "SCREW"):
        f["joint"] = cur.name("joint name")
        key = "radius" if what == "RACK" else "lead"
        f[key] = cur.number("pinion pitch radius" if what == "RACK" else "lead")
    elif what in ("CAM", "SLOT"):
        f["joint"] = cur.name("joint name")
        f["value"] = cur.name("VALUE name of the TABLE")
    elif what == "POINT":
        f["point"] = cur.name("point name")
        frame = cur.peek_keyword({"LINK": "LINK", "ABS": "ABS", "ABSO": "ABS"})
        if frame is not None:
            cur.take()
            f["frame"], f["joint"] = frame, None
        else:
            f["frame"], f["joint"] = "JOINT", cur.name("joint name (or LINK or ABS)")
        f["coords"] = cur.point("coordinates", allow_name=frame == "ABS")
    elif what == "GRAVITY":
        f["vector"] = tuple(cur.number(f"g{c}") for c in "xyz")
    elif what == "DENSITY":
        f["solid"] = cur.name("solid name")
        f["density"] = cur.number("density")
    elif what in ("MASS", "INERTIA"):
        f["link"] = cur.name("link name")
        if cur.peek_keyword({"LINK": "LINK"}):
            cur.take()
            f["frame"], f["joint"] = "LINK", None
        else:
            f["frame"], f["joint"] = "JOINT", cur.name("joint name (or LINK)")
        if what == "MASS":
            f["mass"] = cur.number("mass")
            f["center"] = tuple(cur.number(f"centre of mass {c}") for c in "uvw")
        else:
            f["inertia"] = tuple(cur.number(c) for c in ("Ixx", "Iyy", "Izz", "Ixy", "Ixz", "Iyz"))
    elif what == "SPRING":
        f["name"] = cur.name("spring or joint name")
        f["pairs"] = _pairs(cur, cur.data("spring datum"), none_pairs=True)
    elif what == "DAMPER":
        f["name"] = cur.name("damper or joint name")
        f["coefficients"] = cur.data("damping coefficient")
    elif what in ("FORCE", "TORQUE"):
        f["name"] = cur.name(f"{what.lower()} or joint name")
        f["loads"] = cur.data(what.lower())
    elif what == "CONTACT":
        f["contact"] = cur.name("contact name")
        for key in ("en", "et", "eb", "er", "mu"):
            f[key] = cur.number(key)
    elif what == "POSITION":
        f["joint"] = cur.name("joint name")
        f["start"] = cur.number("start position")
        inc = cur.opt_number("increment")
        steps = cur.opt_number("number of steps")
        f["increment"] = 0.0 if inc is None else inc
        # increment 0 holds the joint, forcing nsteps = 0 (docs/imp-language.md §8.6)
        f["nsteps"] = 0 if steps is None or f["increment"] == 0.0 else round(steps)
    elif what in ("VELOCITY", "ACCEL"):
        f["joint"] = cur.name("joint name")
        key = "velocity" if what == "VELOCITY" else "acceleration"
        f[key] = cur.number(key)
    elif what == "MOTION":
        f["joint"] = cur.name("joint name")
        f["motions"] = cur.data("motion")
    elif what == "IC":
        f["joint"] = cur.name("joint name")
        f["pairs"] = _pairs(cur, cur.data("initial condition"), none_pairs=False)
    elif what == "TIME":
        for key in ("final", "minstep", "printstep"):
            f[key] = cur.number(f"{key} time")
    elif what == "VIEW":
        view = cur.peek_keyword(_VIEWS)
        if view is not None:
            cur.take()
            f.update(view=view, eye=None, up=None)
        else:
            f["view"] = None
            f["eye"] = tuple(cur.number(f"eye {c}") for c in "xyz")
            f["up"] = tuple(cur.number(f"up-vector {c}") for c in "xyz")
    else:  # DRAW
        f["distance"] = cur.number("eye distance")
    cur.finish()


def _pairs(cur: _Cursor, data: list[Datum], none_pairs: bool) -> list[tuple[Datum, Datum]]:
    """Group data in pairs; an odd count gets a filled 0; with ``none_pairs``
    a NONE in either member makes both NONE (DATA SPRING)."""
    if len(data) % 2:
        cur.filled += 1
        cur.stmt.numbers.append(0.0)
        data = [*data, 0.0]
    out: list[tuple[Datum, Datum]] = []
    for a, b in zip(data[::2], data[1::2]):
        if none_pairs and (a is None or b is None):
            a = b = None
        out.append((a, b))
    return out


def _data_placement(ctx: _Ctx, cur: _Cursor, what: str) -> None:
    f = ctx.stmt.fields
    if what == "LINK":
        f["link"] = cur.name("link name")
        if cur.peek_keyword({"LINK": "LINK"}):
            cur.take()
            f["joint"], f["frame"] = None, "LINK"
        else:
            f["joint"], f["frame"] = cur.name("joint name (or LINK)"), "JOINT"
    else:
        f["joint"] = cur.name("joint name")
    points: list[tuple[float, float, float] | str] = []
    filled: list[bool] = []
    for k in range(_SLOTS[what]):
        before = cur.filled
        points.append(cur.point(f"point P{k + 1}"))
        filled.append(cur.filled > before)
    f["points"], f["filled"] = points, filled
    cur.finish()


def _h_request(ctx: _Ctx, cur: _Cursor, family: str) -> None:
    ctx.set("REQUEST", family)
    allowed = _REQUESTS[family]
    q = cur.keyword(_QUANTITIES, f"what to {family.lower()}: one of {', '.join(allowed)}")
    ctx.stmt.keyword = f"{family} {q}"
    if q not in allowed:
        raise cur.error(f"there is no {family} {q}; {family} takes {', '.join(allowed)}")
    f = ctx.stmt.fields
    f.update(family=family, quantity=q)
    if q == "DYNAMICS":
        _dynamics(ctx, cur, family)
    elif q in ("HEADING", "FREQUENCY"):
        cur.finish()
    else:
        f["names"], f["all"] = cur.names_list("name")
        if not f["names"] and not f["all"]:
            raise cur.error("at least one name (or ALL) is needed")
        cur.finish()


def _dynamics(ctx: _Ctx, cur: _Cursor, family: str) -> None:
    f = ctx.stmt.fields
    if family in ("LIST", "PLOT"):
        for key in ("w0", "wf", "winc"):
            f[key] = cur.number(f"frequency {key} (rad/s)", fill=False)
    f["input"] = cur.keyword(_kw("FORCE", "MOTION"), "the input kind FORCE or MOTION")
    f["namein"] = cur.name("input name")
    nin = cur.opt_number()
    if nin is None and f["input"] == "MOTION":
        raise cur.error("a MOTION input needs the joint variable index after the joint name")
    f["nin"] = 0 if nin is None else round(nin)
    pairs: list[tuple[str, str]] = []
    while not cur.at_end():
        kind = cur.keyword(_kw("POSITION", "VELOCITY", "ACCEL"),
                           "an output kind POSITION, VELOCITY or ACCEL")
        pairs.append((kind, cur.name("output joint or point name")))
    if not pairs:
        raise cur.error("at least one output pair (kind, name) is needed after '='")
    limit = 15 if family in ("PRINT", "STORE") else 14
    if len(pairs) > limit:
        ctx.warn(f"Warning: IMP took at most {limit} output pairs in {family} DYNAMICS; this "
                 f"one has {len(pairs)} (all are kept).")
    f["pairs"] = pairs
    cur.finish()


def _h_delete(ctx: _Ctx, cur: _Cursor) -> None:
    ctx.set("DELETE", "DELETE")
    what = cur.keyword(_DELETE, "what to delete: one of " + ", ".join(_DELETE.values()))
    ctx.stmt.keyword = f"DELETE {what}"
    f = ctx.stmt.fields
    if what in _DELETE_BARE:
        cur.finish()
        return
    if what in _DELETE_KINDS:
        allowed = _DELETE_KINDS[what]
        table = {keyword_key(k): k for k in allowed}
        kinds: list[str] = []
        while not cur.at_end():
            kinds.append(cur.keyword(table, f"a {what} kind: one of {', '.join(allowed)}"))
        if not kinds:
            raise cur.error(f"name the kinds of {what} request to delete, or ALL")
        f["kinds"], f["all"] = kinds, "ALL" in kinds
    else:
        f["names"], f["all"] = cur.names_list("name")
        if not f["names"] and not f["all"]:
            raise cur.error("at least one name (or ALL) is needed")
    cur.finish()


def _h_control(ctx: _Ctx, cur: _Cursor, lead: str) -> None:
    ctx.set("CONTROL", lead)
    f = ctx.stmt.fields
    if lead == "EXECUTE":
        hold = cur.peek_keyword({"HOLD": "HOLD"}) is not None
        if hold:
            cur.take()
            ctx.stmt.keyword = "EXECUTE HOLD"
        f["hold"] = hold
    elif lead == "RETURN":
        f.update(ends_recall=False, simulated=False)
    elif lead == "FIND":
        mode = cur.keyword(_kw("EQUILIB", "DYNAMICS"), "EQUILIB or DYNAMICS")
        ctx.stmt.keyword = f"FIND {mode}"
    elif lead in ("PAUSE", "ERASE"):
        ctx.stmt.keyword = f"{lead} {cur.keyword(_ON_OFF, 'ON or OFF')}"
    elif lead == "UNIT":
        cur.keyword({"MASS": "MASS"}, "MASS (the only UNIT statement is UNIT (MASS) = value)")
        ctx.stmt.keyword = "UNIT MASS"
        f["value"] = cur.number("mass conversion factor")
    elif lead == "IDENTIFY":
        types: list[str] = []
        while not cur.at_end():
            item = cur.take()
            kind = _IDENTIFY.get(item.key) if item.kind == "WORD" else None
            if kind is None:
                ctx.warn(f"Warning: IDENTIFY type {item.text} is unknown and skipped.")
            else:
                types.append(kind)
        if not types:
            raise cur.error("name at least one type: " + ", ".join(sorted(set(_IDENTIFY.values()))))
        f["types"] = types
    elif lead == "ZERO":
        what = cur.keyword(_ZERO, "the tolerance kind: one of " + ", ".join(_ZERO.values()))
        ctx.stmt.keyword = f"ZERO {what}"
        if what == "FORCE":
            f["force_error"] = cur.number("force error")
            f["percent_error"] = cur.number("percent error")
            n = cur.opt_number()  # openimp: the cap on the steps of one run
            f["nsteps"] = None if n is None else round(n)
        else:
            f["tolerance"] = cur.number("tolerance")
            if what in ("POSITION", "EQUILIB"):
                n = cur.opt_number()
                f["nsteps"] = None if n is None else round(n)  # None keeps the old count
    elif lead == "PRINT":  # PRINT INPUT / PRINT OFF (PRINT ON is read raw)
        ctx.stmt.keyword = f"PRINT {cur.keyword(_kw('INPUT', 'OFF'), 'INPUT or OFF')}"
    # CLEAR, RESET, END take nothing
    cur.finish()


def _h_graphics(ctx: _Ctx, cur: _Cursor, lead: str) -> None:
    ctx.set("GRAPHICS", lead)
    f = ctx.stmt.fields
    if lead == "DEVICE":
        f["device"] = cur.keyword(_kw("ALPHA", "GRAPHIC"), "ALPHA or GRAPHIC")
    elif lead == "SHOW":
        item = cur.peek()
        if item is None:
            raise cur.error("the colour and the names are missing")
        colour = _COLOURS.get(item.key) if item.kind == "WORD" else None
        cur.take()
        if colour is None:
            ctx.warn(f"Warning: unknown colour {item.text} is taken as WHITE.")
            colour = "WHITE"
        loops: list[int] = []
        names, all_ = cur.names_list("name", loops=loops)
        if not names and not all_ and not loops:
            raise cur.error("name what to show (names, ALL or LOOP n) after the colour")
        f.update(color=colour, names=names, all=all_, loops=loops)
    elif lead == "ERASE":
        loops = []
        names, all_ = cur.names_list("name", loops=loops)
        f.update(names=names, all=all_, loops=loops, clear=not (names or all_ or loops))
    elif lead == "AXES":
        length = cur.opt_number()
        names, all_ = cur.names_list("joint name")
        f.update(length=0.0 if length is None else length, names=names,
                 all=all_ or not names)
    elif lead == "ZOOM":
        power = cur.opt_number()
        f["power"] = 0.0 if power is None else power
        f["center"] = None
        if not cur.at_end():
            f["center"] = tuple(cur.number(f"centre {c}") for c in "xyz")
    elif lead in ("SLIDE", "TURN"):
        item = cur.peek()
        if cur.peek_keyword(_AXES) is None and item is not None and item.kind == "WORD":
            raise cur.error(f"the screen axis must be X, Y or Z, found {item.describe()}"
                            + (" (a sliding joint is XSLIDE, YSLIDE, ZSLIDE or PRISM)"
                               if lead == "SLIDE" else ""), item)
        f["axis"] = cur.keyword(_AXES, "the screen axis X, Y or Z")
        key = "distance" if lead == "SLIDE" else "angle"
        f[key] = cur.number(key)
    elif lead in ("STORE", "RECALL"):
        cur.keyword({"VIEW": "VIEW"}, "VIEW")
        ctx.stmt.keyword = f"{lead} VIEW"
        n = cur.opt_number()
        f["number"] = None if n is None else round(n)
    # DRAW and ANIMATE take nothing
    cur.finish()


# --------------------------------------------------------------------------- raw forms


def _raw_after(text: str) -> str:
    """Strip the blanks, one ``)`` and one ``=``/``:``/``,`` in front of raw text."""
    s = text.strip()
    if s.startswith(")"):
        s = s[1:].lstrip()
    if s[:1] in ("=", ":", ","):
        s = s[1:].lstrip()
    return s.rstrip()


def _filename(text: str) -> str | None:
    """A raw file name: quotes or enclosing parentheses removed; None if empty."""
    s = _raw_after(text)
    if len(s) >= 2 and s[0] == s[-1] and s[0] in "'\"":
        s = s[1:-1]
    elif s.startswith("(") and s.endswith(")"):
        s = s[1:-1].strip()
    return s or None


def _next_word(sc: Scanner) -> Token | None:
    """The next name or number token, skipping separators and ')'."""
    while (tok := sc.next()) is not None:
        if tok.kind in ("NAME", "NUMBER"):
            return tok
    return None


def _count_words(node: Node) -> int:
    """Words and numbers of an expression tree (for the 35-word limit)."""
    if isinstance(node, (Num, ValueRef, Time, Stop)):
        return 1
    if isinstance(node, Call):
        return 1 + sum(_count_words(a) for a in node.args)
    if isinstance(node, Ref):
        return 2 + _count_words(node.comp)
    if isinstance(node, If):
        return 1 + sum(_count_words(n) for n in (node.cond, node.neg, node.zero, node.pos))
    if isinstance(node, Table):
        return 2 + _count_words(node.arg)
    if isinstance(node, User):
        return 2
    left, right = getattr(node, "left", None), getattr(node, "right", None)
    return sum(_count_words(n) for n in (left, right) if isinstance(n, Node))


def _value(ctx: _Ctx, sc: Scanner) -> None:
    ctx.set("VALUE", "VALUE")
    tok = _next_word(sc)
    if tok is None or tok.kind != "NAME":
        found = "nothing" if tok is None else tok.describe()
        raise ctx.error(f"expected the VALUE name, found {found}",
                        tok.line if tok is not None else None)
    name = ctx.sig(tok.text)
    if keyword_key(tok.text) in FUNCTIONS:
        ctx.warn(f"Warning: VALUE name {tok.text} is also the function "
                 f"{FUNCTIONS[keyword_key(tok.text)]}; expressions will read it as the function.")
    nxt = sc.next()
    if nxt is not None and nxt.kind == "RPAREN":
        nxt = sc.next()
    if nxt is None or nxt.kind != "SEP" or nxt.text != "=":
        found = "the end of the statement" if nxt is None else nxt.describe()
        raise ctx.error(f"'=' is missing between the name {tok.text} and the expression "
                        f"(found {found})", nxt.line if nxt is not None else tok.line)
    start = nxt.end
    sc.what = "expression"
    root = parse_expression_at(sc, f"VALUE ({name}) statement", significant=ctx.sig_len)
    expr = Expression(name, ctx.src.text[start:].strip(), root, ctx.src.file,
                      ctx.src.line_at(start), ctx.base_dir, ctx.roots)
    ctx.stmt.names.append(name)
    ctx.stmt.written.append(tok.text)
    ctx.stmt.fields.update(name=name, expression=expr, source=expr.source)
    words = 2 + _count_words(root)
    if words > MAX_WORDS:
        ctx.warn(f"Warning: IMP took at most {MAX_WORDS} words and numbers in one statement; "
                 f"this one has {words} (all are read).")


def _build(src: SourceStatement, significant: int | None, base_dir: str | None,
           roots: tuple[str, ...] | None = None) -> Statement | None:
    """Parse one source statement (``None`` if it holds nothing); TABLE files of its
    VALUE expression are read only inside ``roots`` (when given)."""
    ctx = _Ctx(src, significant, base_dir, roots)
    sc = Scanner(src)
    first = sc.next()
    if first is None:
        return None
    if first.kind != "NAME":
        raise InputError(f"a statement starts with a keyword, found {first.describe()} at column "
                         f"{first.col}; see the list of statements in the IMP reference",
                         (src.file, first.line))
    lead = LEADING_KEYWORDS.get(keyword_key(first.text))
    if lead is None:
        raise _unknown(first, src)
    f = ctx.stmt.fields
    if lead in ("TITLE", "REMARK"):
        ctx.set("CONTROL", lead)
        text = _raw_after(sc.rest())
        if lead == "TITLE":
            if src.end_line > src.line:
                ctx.warn(f"Warning: the TITLE is continued over {src.end_line - src.line + 1} "
                         "lines by '$'; a title cannot hold '$' or remarks.")
            if len(text) > 63:
                ctx.warn(f"Warning: the title has {len(text)} characters; IMP keeps the "
                         "first 63.")
                text = text[:63].rstrip()
            f["title"] = text
        else:
            f["text"] = text
        return ctx.stmt
    if lead == "VALUE":
        _value(ctx, sc)
        return ctx.stmt
    if lead in ("PRINT", "STORE", "RECALL", "SOLID"):
        second = _next_word(sc)
        key = keyword_key(second.text) if second is not None and second.kind == "NAME" else ""
        if lead == "SOLID":
            ctx.set("DEFINE", "SOLID READ")
            if key != "READ":
                raise ctx.error("SOLID must be followed by READ", first.line)
            solid = _next_word(sc)
            if solid is None or solid.kind != "NAME":
                raise ctx.error("the solid name is missing after SOLID READ", first.line)
            f["solid"] = ctx.sig(solid.text)
            ctx.stmt.names.append(f["solid"])
            ctx.stmt.written.append(solid.text)
            f["filename"] = _filename(sc.rest())
            if f["filename"] is None:
                raise ctx.error("the file name is missing", first.line)
            return ctx.stmt
        raw = {("PRINT", "ON"): "PRINT ON", ("STORE", "INPU"): "STORE INPUT",
               ("RECALL", "INPU"): "RECALL INPUT"}.get((lead, key))
        if raw is not None:
            ctx.set("CONTROL", raw)
            f["filename"] = _filename(sc.rest())
            if raw == "RECALL INPUT":
                f["path"] = None
            return ctx.stmt
    tokens = tokenize(src)
    items = reduce_items(tokens, src)
    if len(items) > MAX_WORDS:
        ctx.warn(f"Warning: IMP took at most {MAX_WORDS} words and numbers in one statement; "
                 f"this one has {len(items)} (all are read).")
    cur = _Cursor(ctx, items)
    cur.take()  # the leading keyword
    _dispatch(ctx, cur, lead)
    return ctx.stmt


def _dispatch(ctx: _Ctx, cur: _Cursor, lead: str) -> None:
    if lead in JOINT_DOF:
        _h_joint(ctx, cur, lead)
    elif lead in ("LINK", "GROUND", "SHAPE", "CONTACT", "IMPACT", "POINT", "SPRING", "DAMPER",
                  "FORCE", "TORQUE"):
        _h_define(ctx, cur, lead)
    elif lead == "DATA":
        _h_data(ctx, cur)
    elif lead in ("LIST", "PLOT"):
        _h_request(ctx, cur, lead)
    elif lead in ("PRINT", "STORE"):
        second = cur.peek_keyword(_kw("INPUT", "OFF", "VIEW"))
        if lead == "PRINT" and second in ("INPUT", "OFF"):
            _h_control(ctx, cur, "PRINT")
        elif lead == "STORE" and second == "VIEW":
            _h_graphics(ctx, cur, "STORE")
        else:
            _h_request(ctx, cur, lead)
    elif lead == "RECALL":
        if cur.peek_keyword({"VIEW": "VIEW"}) is None:
            ctx.set("CONTROL", "RECALL INPUT")
            item = cur.peek()
            raise cur.error("RECALL is followed by INPUT or VIEW, found "
                            + ("nothing" if item is None else item.describe()), item)
        _h_graphics(ctx, cur, "RECALL")
    elif lead == "DELETE":
        _h_delete(ctx, cur)
    elif lead == "ERASE" and cur.peek_keyword(_ON_OFF) is not None:
        _h_control(ctx, cur, "ERASE")
    elif lead in ("DEVICE", "DRAW", "ANIMATE", "SHOW", "ERASE", "AXES", "ZOOM", "SLIDE", "TURN"):
        _h_graphics(ctx, cur, lead)
    else:
        _h_control(ctx, cur, lead)


def _unknown(tok: Token, src: SourceStatement) -> InputError:
    import difflib

    key = keyword_key(tok.text)
    hint = _HINTS.get(key) or ""
    if not hint:
        close = difflib.get_close_matches(tok.text.upper(), sorted(set(LEADING_KEYWORDS.values())),
                                          n=3, cutoff=0.6)
        if close:
            hint = "did you mean " + " or ".join(close) + "?"
    return InputError(
        f"unknown statement keyword {quote(tok.text)}" + (f": {hint}" if hint else "")
        + ". Statements start with a definition keyword (LINK, ZPIN, POINT, ...), DATA, PRINT, "
        "LIST, STORE, PLOT, a control word (TITLE, EXECUTE, END, ...), DELETE or a graphics "
        "word; only the first 4 letters count",
        (src.file, tok.line),
    )


# --------------------------------------------------------------------------- decks


OnError = Callable[[InputError], None]


def _read_deck(path: str, where: tuple[str, int] | None, what: str,
               roots: tuple[str, ...] | None = None) -> list[str]:
    """The lines of a deck or recalled file (regular, bounded, decodable; inside
    ``roots`` when given)."""
    return split_lines(read_text(path, what, where, roots))


class _Reader:
    """Reads statements, expanding RECALL INPUT (docs/imp-language.md §10).

    Limits: RECALL INPUT nests at most ``MAX_RECALL_DEPTH`` deep, a file never
    recalls itself (directly or through others), and the deck with every
    recalled file holds at most ``MAX_STATEMENTS`` statements and
    ``MAX_READ_BYTES`` bytes; reads stay inside ``roots`` when given.
    """

    MAX_DEPTH = MAX_RECALL_DEPTH

    def __init__(self, significant: int | None, columns: int | None, expand: bool,
                 on_error: OnError | None, roots: tuple[str, ...] | None = None) -> None:
        self.significant = significant
        self.columns = columns
        self.expand = expand
        self.on_error = on_error
        self.roots = roots
        self.resume: dict[str, int] = {}
        self.last_path: str | None = None
        self.depth = 0
        self.ended = False
        self.count = 0
        self.errors = 0
        self.read_bytes = 0
        self.active: list[str] = []  # real paths of the files being read

    def report(self, exc: InputError) -> None:
        if self.on_error is None:
            raise exc
        self.errors += 1
        if self.errors > MAX_INPUT_ERRORS:
            raise InputError(f"more than {MAX_INPUT_ERRORS} input errors (limit "
                             "MAX_INPUT_ERRORS); reading stops here", exc.where)
        self.on_error(exc)

    def counted(self, stmt: Statement) -> Statement:
        """``stmt`` after counting it against MAX_STATEMENTS (InputError beyond)."""
        self.count += 1
        if self.count > MAX_STATEMENTS:
            raise InputError(f"the deck and the files it recalls hold more than {MAX_STATEMENTS} "
                             "statements (limit MAX_STATEMENTS); reading stops here", stmt.where)
        return stmt

    def read(self, lines: Iterable[str], file: str, base_dir: str | None, first_line: int = 1,
             recalled: bool = False) -> Generator[Statement, None, bool]:
        """Yield the statements of ``lines``; return True if a RETURN ended a
        recalled file."""
        for src in split_statements(lines, file, first_line, self.columns):
            try:
                stmt = _build(src, self.significant, base_dir, self.roots)
            except InputError as exc:
                self.report(exc)
                continue
            if stmt is None:
                continue
            self.counted(stmt)
            if recalled and stmt.keyword == "RETURN":
                stmt.fields["ends_recall"] = True
                self.resume[file] = stmt.end_line
                yield stmt
                return True
            yield stmt
            if stmt.keyword == "END":
                self.ended = True
            elif stmt.keyword == "RECALL INPUT" and self.expand:
                try:
                    yield from self.recall(stmt, base_dir)
                except InputError as exc:
                    if self.count > MAX_STATEMENTS or self.errors > MAX_INPUT_ERRORS:
                        raise
                    self.report(exc)
            if self.ended:
                return False
        return False

    def _check_recall(self, stmt: Statement, path: str) -> None:
        """Refuse a RECALL INPUT that nests too deep or recalls a file being read."""
        real = os.path.realpath(path)
        if real in self.active:
            chain = " -> ".join(quote_path(os.path.basename(p), 40) for p in
                                [*self.active[self.active.index(real):], real])
            raise stmt.error(f"the file {quote_path(path)} recalls itself ({chain}); a file "
                             "cannot be recalled while it is being read")
        if self.depth >= self.MAX_DEPTH:
            raise stmt.error(f"RECALL INPUT files are nested more than {self.MAX_DEPTH} deep "
                             "(limit MAX_RECALL_DEPTH)")

    def recall(self, stmt: Statement, base_dir: str | None) -> Iterator[Statement]:
        name = stmt.fields.get("filename")
        if name:
            path = name if os.path.isabs(name) or not base_dir else os.path.join(base_dir, name)
            start = 0
        else:
            if self.last_path is None:
                raise stmt.error("without a file name RECALL INPUT continues the file recalled "
                                 "last, but none was recalled yet; write RECALL INPUT = filename")
            path = self.last_path
            start = self.resume.get(path, 0)
        stmt.fields["path"] = path
        self._check_recall(stmt, path)
        text = read_text(path, "RECALL INPUT statement", stmt.where, self.roots)
        self.read_bytes += len(text)
        if self.read_bytes > MAX_READ_BYTES:
            raise stmt.error(f"the deck's RECALL INPUT files hold more than {MAX_READ_BYTES} "
                             "bytes in all (limit MAX_READ_BYTES)")
        lines = split_lines(text)
        self.last_path = path
        self.depth += 1
        self.active.append(os.path.realpath(path))
        try:
            returned = yield from self.read(lines[start:], path, os.path.dirname(path) or None,
                                            first_line=start + 1, recalled=True)
        finally:
            self.depth -= 1
            self.active.pop()
        if not returned and not self.ended:
            self.resume[path] = len(lines)
            last = len(lines) - (1 if lines and not lines[-1] else 0)  # the last line of text
            yield self.counted(Statement(
                kind="CONTROL", keyword="RETURN", fields={"ends_recall": True, "simulated": True},
                file=path, line=last, end_line=last, text="",
                warnings=["RETURN statement simulated at end of file."],
            ))


def iter_statements(
    text: str | Iterable[str],
    file: str = "<text>",
    *,
    base_dir: str | None = None,
    expand_recall: bool = True,
    on_error: OnError | None = None,
    significant: int | None = 4,
    columns: int | None = COLUMNS,
    read_roots: Iterable[str] | None = None,
) -> Iterator[Statement]:
    """Yield the statements of a deck text (or of its lines) one by one.

    ``file`` names the text in messages; ``base_dir`` is where RECALL INPUT and
    TABLE file names are looked for (default: the current directory).
    ``expand_recall`` replaces each RECALL INPUT by the statements read from
    its file (the RECALL statement itself comes first, then the recalled
    statements with their own file and line, then the RETURN that ended the
    file with ``fields['ends_recall']`` True, simulated with a warning at end of
    file).  Reading stops after END.  ``on_error``, if given, receives each
    :class:`InputError` and the statement is skipped; otherwise it is raised.
    ``significant`` is the number of significant characters of user names
    (IMP: 4; ``None`` keeps whole names); ``columns`` the useful columns of a
    line (IMP: 72; ``None`` for no limit).  ``read_roots``, when given, are
    the only folders RECALL INPUT and TABLE may read from.
    """
    roots = None if read_roots is None else real_roots(read_roots)
    reader = _Reader(significant, columns, expand_recall, on_error, roots)
    if os.path.isfile(file):  # the deck itself is being read: it cannot be recalled
        reader.active.append(os.path.realpath(file))
    lines = split_lines(text) if isinstance(text, str) else list(text)
    yield from reader.read(lines, file, base_dir)


def parse_text(
    text: str | Iterable[str],
    file: str = "<text>",
    *,
    base_dir: str | None = None,
    expand_recall: bool = True,
    on_error: OnError | None = None,
    significant: int | None = 4,
    columns: int | None = COLUMNS,
    read_roots: Iterable[str] | None = None,
) -> list[Statement]:
    """Parse a deck given as text; see :func:`iter_statements` for the options."""
    return list(iter_statements(text, file, base_dir=base_dir, expand_recall=expand_recall,
                                on_error=on_error, significant=significant, columns=columns,
                                read_roots=read_roots))


def parse_file(
    path: str | os.PathLike[str],
    *,
    expand_recall: bool = True,
    on_error: OnError | None = None,
    significant: int | None = 4,
    columns: int | None = COLUMNS,
    allow_read: Iterable[str | os.PathLike[str]] = (),
) -> list[Statement]:
    """Parse a deck file; names in RECALL INPUT and TABLE are relative to its folder.

    RECALL INPUT and TABLE read only inside the deck's folder and the folders
    of ``allow_read``.
    """
    p = os.fspath(path)
    lines = _read_deck(p, (p, 0), "the deck cannot be read")
    roots = [os.path.dirname(os.path.abspath(p)), *map(os.fspath, allow_read)]
    return parse_text(lines, p, base_dir=os.path.dirname(p) or None,
                      expand_recall=expand_recall, on_error=on_error,
                      significant=significant, columns=columns, read_roots=roots)


def parse(source: str | os.PathLike[str], **options: Any) -> list[Statement]:
    """Parse a deck from a path or from text.

    A :class:`os.PathLike`, or a one-line string naming an existing file, is
    read as a file; any other string is the deck text.  ``options`` are those
    of :func:`parse_file` / :func:`parse_text`.
    """
    if not isinstance(source, str):
        return parse_file(source, **options)
    if "\n" not in source and os.path.isfile(source):
        return parse_file(source, **options)
    return parse_text(source, **options)


def parse_statement(
    text: str,
    file: str = "<text>",
    line: int = 1,
    *,
    base_dir: str | None = None,
    significant: int | None = 4,
    columns: int | None = COLUMNS,
) -> Statement | None:
    """Parse the first statement of ``text`` (``None`` if it holds only blanks
    or remarks); RECALL INPUT is not expanded.  Meant for interactive input."""
    for src in split_statements(text, file, line, columns):
        stmt = _build(src, significant, base_dir)
        if stmt is not None:
            return stmt
    return None
