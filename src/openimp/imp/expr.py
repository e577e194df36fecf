"""VALUE expressions of the IMP language (docs/imp-language.md §5): parser and safe evaluator.

An expression is parsed into a small tree of nodes (never Python code: nothing
here calls ``eval`` or ``exec``) and evaluated against

* an *environment*: a mapping from VALUE names (in their significant 4-letter
  form) to :class:`Expression` objects, numbers, or ``(value, d/dt, d2/dt2)``
  triples;
* a *resolver* callback ``resolve(kind, name, comp) -> float`` supplied by the
  caller for everything that depends on the model: ``kind`` is ``'TIME'``
  (``name`` None, ``comp`` 0), ``'POSITION'``, ``'VELOCITY'``, ``'ACCEL'``,
  ``'FORCE'`` (``name`` the element, ``comp`` the rounded component).
  Returning ``nan`` (or ``None``) means "undefined".  ``USER(name)`` calls the
  function registered for it (:func:`register_user`) at the resolver's TIME.

Every value carries its first and second time derivatives
(:meth:`Expression.derivatives`), propagated in forward mode: TIME is
``(t, 1, 0)``, POSITION(n, c) is ``(POSITION, VELOCITY, ACCEL)``,
VELOCITY(n, c) is ``(VELOCITY, ACCEL, undefined)``, ACCEL and FORCE have
undefined derivatives.  "Undefined" is ``nan``; with ``strict=True`` the
evaluator raises :class:`~openimp.errors.InputError` instead, naming the VALUE
and its ``file:line``.

Operator priority, highest first (docs/imp-language.md §5): function
references, ``@`` (power, via logarithms, base > 0), ``/``, ``*``, ``-``,
``+``; every level runs left to right.  The only unary minus is the sign of a bare number.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from openimp import limits
from openimp.errors import InputError, OpenIMPError
from openimp.files import printable, quote, quote_path, read_text
from openimp.imp.lexer import (
    NUMBER_RE,
    Scanner,
    Token,
    keyword_key,
    split_statements,
)

__all__ = [
    "FUNCTIONS",
    "BinOp",
    "Call",
    "Expression",
    "FourierTable",
    "If",
    "Jet",
    "Node",
    "Num",
    "Ref",
    "Resolver",
    "SimulationStop",
    "Stop",
    "Table",
    "Time",
    "User",
    "ValueRef",
    "load_table",
    "parse_expression",
]

#: ``(value, first time derivative, second time derivative)``
Jet = tuple[float, float, float]

#: ``resolve(kind, name, comp) -> float``; see the module docstring.
Resolver = Callable[[str, str | None, int], float | None]

NAN = math.nan
_UNDEF: Jet = (NAN, NAN, NAN)

#: The function keywords of docs/imp-language.md §5, keyed by their 4-letter significant form.
FUNCTIONS: dict[str, str] = {
    keyword_key(k): k
    for k in (
        "TIME", "T", "PI", "ABS", "SIN", "COS", "TAN", "ASIN", "ACOS", "ATAN2", "EXP",
        "LOG", "LOG10", "SQRT", "POSITION", "VELOCITY", "ACCEL", "FORCE", "IF", "TABLE",
        "USER", "RETURN", "END",
    )
}
_ONE_ARG = frozenset({"ABS", "SIN", "COS", "TAN", "ASIN", "ACOS", "EXP", "LOG", "LOG10", "SQRT"})
_REFS = frozenset({"POSITION", "VELOCITY", "ACCEL", "FORCE"})
_LEVELS = ("+", "-", "*", "/", "@")  # lowest priority first
MAX_NESTING = limits.MAX_NESTING  # parentheses and function calls inside one another
MAX_DEPTH = limits.MAX_EXPRESSION_DEPTH  # depth of the tree (chains of operators included)
MAX_CHAIN = limits.MAX_VALUE_CHAIN  # VALUEs using VALUEs using VALUEs ...


class SimulationStop(OpenIMPError):  # noqa: N818 - a signal, not an error
    """Raised when an expression evaluates ``RETURN`` or ``END`` (docs/imp-language.md §5).

    ``kind`` is ``'RETURN'`` (stop the run, back to the interpreter) or
    ``'END'`` (leave IMP); ``where`` is ``(file, line)`` of the VALUE.
    """

    def __init__(self, kind: str, where: tuple[str, int]) -> None:
        super().__init__(f"{where[0]}:{where[1]}: {kind} evaluated in a VALUE expression")
        self.kind = kind
        self.where = where


# --------------------------------------------------------------------------- nodes


@dataclass(frozen=True)
class Node:
    """Base class of expression nodes; ``line`` is the file line of the node."""

    line: int


@dataclass(frozen=True)
class Num(Node):
    """A number (a signed bare number, or PI)."""

    value: float


@dataclass(frozen=True)
class ValueRef(Node):
    """A reference to another VALUE by its (significant) name."""

    name: str


@dataclass(frozen=True)
class Time(Node):
    """``TIME`` or ``T``."""


@dataclass(frozen=True)
class BinOp(Node):
    """A binary operation; ``op`` is one of ``+ - * / @``."""

    op: str
    left: Node
    right: Node


@dataclass(frozen=True)
class Call(Node):
    """A mathematical function: ABS SIN COS TAN ASIN ACOS ATAN2 EXP LOG LOG10 SQRT."""

    func: str
    args: tuple[Node, ...]


@dataclass(frozen=True)
class Ref(Node):
    """POSITION, VELOCITY, ACCEL or FORCE of a model element (``kind``)."""

    kind: str
    element: str
    comp: Node


@dataclass(frozen=True)
class If(Node):
    """``IF(v0: v1, v2, v3)``: v1 if v0 < 0, v2 if v0 = 0, v3 if v0 > 0."""

    cond: Node
    neg: Node
    zero: Node
    pos: Node


@dataclass(frozen=True)
class Table(Node):
    """``TABLE(x): filename`` (Fourier-series interpolation of a file's ordinates)."""

    arg: Node
    filename: str


@dataclass(frozen=True)
class User(Node):
    """``USER(name)``: a user function (:func:`register_user`)."""

    name: str


#: the functions of USER(name), by the name's significant (first four) characters:
#: f(t, nderiv) -> the value (nderiv 0) or its first or second time derivative, IMP's
#: ``real user(Word name, real t, int nderiv)``
USER_FUNCTIONS: dict[str, Callable[[float, int], float]] = {}


def register_user(name: str, function: Callable[[float, int], float] | None) -> None:
    """Supply ``USER(name)`` of IMP decks: ``function(t, nderiv)`` returns the value at
    time ``t`` (nderiv 0) or its first or second time derivative (nderiv 1, 2), as
    IMP's C function did.  IMP reads the first four characters of a name (case
    counts, as for every user name); ``None``
    removes the function.  Each evaluation calls it (with the derivatives where the
    VALUE needs them: a DATA MOTION, a rate); an exception or a value that is not a
    finite number makes the VALUE undefined, with a message naming the function.
    """
    key = str(name)[:4]  # user names are case-sensitive
    if not key or not key.isalnum():
        raise InputError(f"register_user: {name!r} is not an IMP name (letters and digits)")
    if function is None:
        USER_FUNCTIONS.pop(key, None)
    elif not callable(function):
        raise InputError(f"register_user({name!r}, ...): give a function f(t, nderiv), got "
                         f"{type(function).__name__}")
    else:
        USER_FUNCTIONS[key] = function


@dataclass(frozen=True)
class Stop(Node):
    """``RETURN`` or ``END``: stops the simulation when evaluated."""

    kind: str


# --------------------------------------------------------------------------- parser


class _Parser:
    """Recursive-descent parser over a :class:`Scanner` (one token of look-ahead,
    taken only on demand so that TABLE file names can be read raw)."""

    def __init__(self, sc: Scanner, label: str, significant: int | None) -> None:
        self.sc = sc
        self.label = label
        self.sig = significant
        self.nest = 0

    def error(self, msg: str, tok: Token | None = None) -> InputError:
        where = self.sc.stmt.where(tok.pos if tok is not None else len(self.sc.text))
        return InputError(f"{self.label}: {msg}", where)

    def name(self, text: str) -> str:
        return text if self.sig is None else text[: self.sig]

    def parse(self) -> Node:
        first = self.sc.peek()
        if first is None:
            raise self.error("the expression is empty; write VALUE (name) = expression")
        node = self.level(0)
        tok = self.sc.peek()
        depth = _depth(node)
        if depth > MAX_DEPTH:
            raise self.error(f"the expression is too long: its tree is {depth} levels deep "
                             f"(at most {MAX_DEPTH}, limit MAX_EXPRESSION_DEPTH); split it into "
                             "several VALUEs", first)
        if tok is not None:
            if tok.kind == "RPAREN":
                raise self.error(f"unbalanced ')' at column {tok.col}: parentheses do not "
                                 "balance; remove it or add the matching '('", tok)
            raise self.error(f"unexpected {tok.describe()} at column {tok.col} after a complete "
                             "expression; an operator (+ - * / @) is missing", tok)
        return node

    def level(self, i: int) -> Node:
        if i == len(_LEVELS):
            return self.operand()
        left = self.level(i + 1)
        while True:
            tok = self.sc.peek()
            if tok is None or tok.kind != "SEP" or tok.text != _LEVELS[i]:
                return left
            self.sc.next()
            right = self.level(i + 1)
            left = BinOp(tok.line, tok.text, left, right)

    def expect(self, chars: str, what: str, opener: Token | None = None) -> Token:
        tok = self.sc.next()
        ok = tok is not None and (
            (tok.kind == "RPAREN" and ")" in chars) or (tok.kind == "SEP" and tok.text in chars)
        )
        if ok:
            assert tok is not None
            if tok.kind == "RPAREN":
                self.nest -= 1
            return tok
        found = "the end of the expression" if tok is None else tok.describe()
        if ")" in chars and opener is not None:
            raise self.error(f"expected ')' to close the '(' at column {opener.col}, found "
                             f"{found}: parentheses do not balance", tok or opener)
        raise self.error(f"expected {what}, found {found}", tok)

    def operand(self) -> Node:
        tok = self.sc.next()
        if tok is None:
            raise self.error("the expression ends where a number, name or '(' is expected")
        if tok.kind == "NUMBER":
            return Num(tok.line, float(tok.value or 0.0))
        if tok.kind == "SEP" and tok.text in "+-":
            nxt = self.sc.peek()
            if nxt is not None and nxt.kind == "NUMBER":
                self.sc.next()
                value = float(nxt.value or 0.0)
                return Num(tok.line, -value if tok.text == "-" else value)
            raise self.error(f"'{tok.text}' at column {tok.col} is not followed by a number: IMP "
                             "has no unary minus except on a bare number; write 0-PI or "
                             "-1*(...) instead", tok)
        if tok.kind == "SEP" and tok.text == "(":
            self.enter(tok)
            inner = self.level(0)
            self.expect(")", "')'", opener=tok)
            return inner
        if tok.kind == "NAME":
            func = FUNCTIONS.get(keyword_key(tok.text))
            if func is None:
                return ValueRef(tok.line, self.name(tok.text))
            return self.function(func, tok)
        if tok.kind == "RPAREN":
            raise self.error(f"unbalanced ')' at column {tok.col} where an operand is expected: "
                             "parentheses do not balance", tok)
        raise self.error(f"expected a number, name or '(' at column {tok.col}, found "
                         f"{tok.describe()}", tok)

    def open_paren(self, func: str, tok: Token, form: str) -> Token:
        nxt = self.sc.next()
        if nxt is None or nxt.kind != "SEP" or nxt.text != "(":
            found = "the end of the expression" if nxt is None else nxt.describe()
            raise self.error(f"{func} at column {tok.col} needs its arguments in parentheses: "
                             f"{form} (found {found})", nxt or tok)
        self.enter(nxt)
        return nxt

    def enter(self, tok: Token) -> None:
        """Count one more level of parentheses (bounded, to keep recursion shallow)."""
        self.nest += 1
        if self.nest > MAX_NESTING:
            raise self.error(f"parentheses are nested more than {MAX_NESTING} deep at column "
                             f"{tok.col} (limit MAX_NESTING); split the expression into several "
                             "VALUEs", tok)

    def element(self, func: str) -> str:
        tok = self.sc.next()
        if tok is None or tok.kind != "NAME":
            found = "the end of the expression" if tok is None else tok.describe()
            raise self.error(f"{func} needs an element name as its first argument, found {found}",
                             tok)
        return self.name(tok.text)

    def function(self, func: str, tok: Token) -> Node:
        line = tok.line
        if func == "PI":
            return Num(line, math.pi)
        if func in ("TIME", "T"):
            return Time(line)
        if func in ("RETURN", "END"):
            return Stop(line, func)
        if func in _ONE_ARG:
            op = self.open_paren(func, tok, f"{func}(expression)")
            arg = self.level(0)
            self.expect(")", "')'", opener=op)
            return Call(line, func, (arg,))
        if func == "ATAN2":
            op = self.open_paren(func, tok, "ATAN2(numerator, denominator)")
            num = self.level(0)
            sep = self.sc.peek()
            if sep is not None and sep.kind == "RPAREN":
                raise self.error("ATAN2 takes two arguments (numerator, denominator); there is no "
                                 "one-argument ATAN (ATAN and ATAN2 share their 4 letters)", sep)
            self.expect(",;", "',' between the two arguments of ATAN2")
            den = self.level(0)
            self.expect(")", "')'", opener=op)
            return Call(line, func, (num, den))
        if func in _REFS:
            op = self.open_paren(func, tok, f"{func}(name, component)")
            elem = self.element(func)
            self.expect(",;", f"',' and a component number after the name in {func}(name, "
                              "component)")
            comp = self.level(0)
            self.expect(")", "')'", opener=op)
            return Ref(line, func, elem, comp)
        if func == "USER":
            op = self.open_paren(func, tok, "USER(name)")
            elem = self.element(func)
            self.expect(")", "')'", opener=op)
            return User(line, elem)
        if func == "IF":
            op = self.open_paren(func, tok, "IF(v0: v1, v2, v3)")
            cond = self.level(0)
            self.expect(":,;", "':' after the test value of IF(v0: v1, v2, v3)")
            neg = self.level(0)
            self.expect(",;", "',' between the values of IF(v0: v1, v2, v3)")
            zero = self.level(0)
            self.expect(",;", "',' between the values of IF(v0: v1, v2, v3)")
            pos = self.level(0)
            self.expect(")", "')'", opener=op)
            return If(line, cond, neg, zero, pos)
        # TABLE(x): filename
        op = self.open_paren(func, tok, "TABLE(x): filename")
        arg = self.level(0)
        self.expect(")", "')'", opener=op)
        self.expect(":", "':' and a file name after TABLE(x)")
        filename, start = self.sc.raw_word()
        if not filename:
            raise self.error("TABLE(x): needs a file name after the ':'")
        return Table(self.sc.stmt.line_at(start), arg, filename)


def _children(node: Node) -> list[Node]:
    """The sub-nodes of ``node``."""
    if isinstance(node, Call):
        return list(node.args)
    out = []
    for f in ("left", "right", "comp", "cond", "neg", "zero", "pos", "arg"):
        child = getattr(node, f, None)
        if isinstance(child, Node):
            out.append(child)
    return out


def _depth(root: Node) -> int:
    """Depth of the tree under ``root`` (computed without recursion)."""
    best = 0
    stack = [(root, 1)]
    while stack:
        node, d = stack.pop()
        best = max(best, d)
        stack.extend((c, d + 1) for c in _children(node))
    return best


def parse_expression_at(
    sc: Scanner, label: str, *, significant: int | None = 4
) -> Node:
    """Parse the rest of the statement read by ``sc`` as an expression tree.

    ``label`` prefixes error messages (e.g. ``'VALUE (DRIV)'``).
    """
    return _Parser(sc, label, significant).parse()


def parse_expression(
    text: str,
    *,
    name: str = "",
    file: str = "<expression>",
    line: int = 1,
    base_dir: str | None = None,
    significant: int | None = 4,
) -> Expression:
    """Parse ``text`` (one expression, possibly with ``$`` continuations).

    ``name`` is the VALUE name used in messages; ``file``/``line`` locate the
    text; ``base_dir`` is where TABLE files are looked for.
    """
    stmts = list(split_statements(text, file, line, columns=None))
    label = f"VALUE ({name})" if name else "expression"
    if not stmts:
        raise InputError(f"{label}: the expression is empty", (file, line))
    if len(stmts) > 1:
        raise InputError(f"{label}: the expression runs over several statements; end each line "
                         "but the last with '$'", (file, stmts[1].line))
    src = stmts[0]
    root = parse_expression_at(Scanner(src, what="expression"), label, significant=significant)
    return Expression(name, src.text.strip(), root, file, src.line, base_dir)


# --------------------------------------------------------------------------- tables


@dataclass(frozen=True)
class FourierTable:
    """Tabulated function of docs/imp-language.md §5 ``TABLE(x): filename``.

    The ordinates are taken equally spaced over one period ``P = xmax - xmin``
    at ``x_k = xmin + k P / N`` (k = 0 .. N-1; the last ordinate is *not* at
    xmax, which is the same point of the period as xmin), and interpolated by
    the trigonometric (Fourier) series through them, so the function is
    periodic outside ``[xmin, xmax)``.
    """

    xmin: float
    xmax: float
    ordinates: tuple[float, ...]
    source: str = ""
    _a: Any = field(default=None, repr=False, compare=False)
    _b: Any = field(default=None, repr=False, compare=False)

    def __post_init__(self) -> None:
        if not self.ordinates:
            raise InputError(f"TABLE {self.source}: the table has no ordinates")
        if not (math.isfinite(self.xmin) and math.isfinite(self.xmax)):
            raise InputError(f"TABLE {self.source}: min x and max x must be finite numbers")
        if not self.xmax > self.xmin:
            raise InputError(f"TABLE {self.source}: max x ({self.xmax:g}) must be greater than "
                             f"min x ({self.xmin:g}) (lines 1 and 2 of the file)")
        y = np.asarray(self.ordinates, dtype=float)
        n = len(y)
        c = np.fft.rfft(y) / n
        a = 2.0 * c.real
        b = -2.0 * c.imag
        a[0] = c[0].real
        if n % 2 == 0:
            a[-1] = c[-1].real
            b[-1] = 0.0
        top = float(max(np.max(np.abs(a)), np.max(np.abs(b))))
        if top > 0.0 and len(a) > 1:
            # the second derivative scales as (j 2 pi / period)^2 times a coefficient
            size = 2.0 * math.log10((len(a) - 1) * 2.0 * math.pi) - 2.0 * math.log10(
                self.period) + math.log10(top)
            if size > 300.0:
                raise InputError(f"TABLE {self.source}: the period (max x - min x = "
                                 f"{self.period:g}) is too short for {n} ordinates of this "
                                 "size: the derivatives of the table overflow; give x in "
                                 "other units")
        object.__setattr__(self, "_a", a)
        object.__setattr__(self, "_b", b)

    @property
    def period(self) -> float:
        """The period ``xmax - xmin``."""
        return self.xmax - self.xmin

    def sample_points(self) -> list[float]:
        """The abscissae of the ordinates."""
        n = len(self.ordinates)
        return [self.xmin + k * self.period / n for k in range(n)]

    def derivatives(self, x: float) -> tuple[float, float, float]:
        """Value and first and second derivatives with respect to ``x``."""
        if not math.isfinite(x):
            return _UNDEF
        w = 2.0 * math.pi / self.period
        u = (x - self.xmin) / self.period  # periods from xmin
        if not math.isfinite(u):
            return _UNDEF
        s = 2.0 * math.pi * (u - math.floor(u))  # the same phase, reduced to one period
        j = np.arange(len(self._a))
        cos, sin = np.cos(j * s), np.sin(j * s)
        f = float(np.dot(self._a, cos) + np.dot(self._b, sin))
        f1 = float(np.dot(j * w, -self._a * sin + self._b * cos))
        f2 = float(np.dot(-((j * w) ** 2), self._a * cos + self._b * sin))
        return (f, f1, f2)

    def __call__(self, x: float) -> float:
        """The interpolated value at ``x``."""
        return self.derivatives(x)[0]


_TABLE_CACHE: dict[str, tuple[float, FourierTable]] = {}
#: (path, roots) pairs already checked to lie inside their roots
_TABLE_ALLOWED: set[tuple[str, tuple[str, ...]]] = set()
_SIGNED_NUMBER = f"[+-]?{NUMBER_RE.pattern}"


def load_table(path: str | os.PathLike[str], where: tuple[str, int] | None = None,
               roots: tuple[str, ...] | None = None) -> FourierTable:
    """Read a TABLE file: min x, max x, then the ordinates, one number per line.

    Blank lines are skipped.  The file is a regular text file of at most
    ``MAX_FILE_BYTES`` inside ``roots`` (when given) with at most
    ``MAX_TABLE_ORDINATES`` ordinates, each within ``±MAX_NUMBER``.  Problems
    raise :class:`InputError` located in the table file (or at ``where`` when
    the file cannot be read).
    """
    p = os.fspath(path)
    try:
        mtime = os.path.getmtime(p)
    except OSError:
        mtime = None
    cached = _TABLE_CACHE.get(p)
    if cached is not None and mtime is not None and cached[0] == mtime and (
            roots is None or (p, roots) in _TABLE_ALLOWED):
        return cached[1]
    text = read_text(p, "TABLE", where, roots)
    table = _parse_table(text, p)
    if mtime is not None:
        _TABLE_CACHE[p] = (mtime, table)
    if roots is not None:
        _TABLE_ALLOWED.add((p, roots))
    return table


def _parse_table(text: str, p: str) -> FourierTable:
    """The table in the text of file ``p`` (see :func:`load_table`)."""
    numbers: list[float] = []
    most = limits.MAX_TABLE_ORDINATES + 2
    for lineno, raw in enumerate(text.split("\n"), start=1):
        for word in raw.replace(",", " ").split():
            m = NUMBER_RE.fullmatch(word.lstrip("+-")) if word[:1] in "+-" else \
                NUMBER_RE.fullmatch(word)
            if m is None or not math.isfinite(float(word)):
                raise InputError(f"TABLE file: {quote(word, 20)} is not a number; the file holds "
                                 "min x, max x and then the ordinates, one number per line",
                                 (p, lineno))
            value = float(word)
            if abs(value) > limits.MAX_NUMBER:
                raise InputError(f"TABLE file: the number {quote(word, 20)} is beyond "
                                 f"±{limits.number_text(limits.MAX_NUMBER)} (limit MAX_NUMBER)",
                                 (p, lineno))
            numbers.append(value)
            if len(numbers) > most:
                raise InputError(f"TABLE file: more than {limits.MAX_TABLE_ORDINATES} ordinates "
                                 "(limit MAX_TABLE_ORDINATES)", (p, lineno))
    if len(numbers) < 3:
        raise InputError(f"TABLE file {quote_path(p)} holds {len(numbers)} numbers; it needs min "
                         "x, max x and at least one ordinate", (p, 1))
    try:
        return FourierTable(numbers[0], numbers[1], tuple(numbers[2:]), p)
    except InputError as exc:
        if exc.where is None:
            exc.where = (p, 1)
        raise


# --------------------------------------------------------------------------- expression


@dataclass
class Expression:
    """A parsed VALUE expression.

    ``name`` is the VALUE name (significant form), ``source`` the expression
    text, ``root`` the tree, ``file``/``line`` its location, ``base_dir`` the
    directory TABLE file names are relative to, ``read_roots`` (when given)
    the only folders TABLE files may be read from.
    """

    name: str
    source: str
    root: Node
    file: str
    line: int
    base_dir: str | None = None
    read_roots: tuple[str, ...] | None = field(default=None, compare=False)

    @property
    def label(self) -> str:
        """``VALUE (name)`` or ``expression``, for messages."""
        return f"VALUE ({self.name})" if self.name else "expression"

    def evaluate(
        self,
        env: Mapping[str, Any] | None = None,
        resolve: Resolver | None = None,
        *,
        strict: bool = False,
        notes: list[str] | None = None,
    ) -> float:
        """The value of the expression as a float (``nan`` when undefined).

        With ``strict=True`` an undefined result raises :class:`InputError`
        saying why; otherwise the reason is appended to ``notes`` (if given).
        Raises :class:`SimulationStop` if RETURN or END is evaluated.
        """
        return _Evaluator(env, resolve, strict, notes, order=0).run(self)[0]

    def derivatives(
        self,
        env: Mapping[str, Any] | None = None,
        resolve: Resolver | None = None,
        *,
        strict: bool = False,
        notes: list[str] | None = None,
    ) -> Jet:
        """``(value, d/dt, d2/dt2)``; undefined parts are ``nan``.

        ``strict`` raises only for an undefined *value*; undefined derivatives
        (of VELOCITY, ACCEL, FORCE) are ``nan`` without a message.
        """
        return _Evaluator(env, resolve, strict, notes, order=2).run(self)

    def nodes(self) -> list[Node]:
        """Every node of the tree, depth first."""
        out: list[Node] = []
        stack = [self.root]
        while stack:
            node = stack.pop()
            out.append(node)
            stack.extend(_children(node))
        return out

    def value_names(self) -> list[str]:
        """The VALUE names the expression uses (sorted, without repeats)."""
        return sorted({n.name for n in self.nodes() if isinstance(n, ValueRef)})

    def references(self) -> list[tuple[str, str]]:
        """``(kind, name)`` of every model reference: POSITION/VELOCITY/ACCEL/FORCE
        elements and USER names (sorted, without repeats)."""
        refs = {(n.kind, n.element) for n in self.nodes() if isinstance(n, Ref)}
        refs |= {("USER", n.name) for n in self.nodes() if isinstance(n, User)}
        return sorted(refs)

    def evaluate_at(self, node: Node, env: Mapping[str, Any] | None,
                    resolve: Resolver | None) -> float:
        """The value of one node of this expression's tree (``nan`` when undefined or
        when it evaluates RETURN or END): the test value of an IF as a switching
        function (:func:`if_tests`)."""
        ev = _Evaluator(env, resolve, False, None, order=0)
        ev.expr = self
        try:
            return float(ev.ev(node)[0])
        except SimulationStop:
            return NAN

    def uses_time(self) -> bool:
        """True if TIME (or T) appears in the expression itself."""
        return any(isinstance(n, Time) for n in self.nodes())

    def table_path(self, filename: str) -> str:
        """The path of a TABLE file name, relative to ``base_dir``."""
        if self.base_dir and not os.path.isabs(filename):
            return os.path.join(self.base_dir, filename)
        return filename

    def load_tables(self) -> list[FourierTable]:
        """Read every TABLE file of the expression now (raises InputError on problems)."""
        return [load_table(self.table_path(n.filename), (self.file, n.line), self.read_roots)
                for n in self.nodes() if isinstance(n, Table)]

    def table(self) -> FourierTable | None:
        """The table if the whole expression is exactly one ``TABLE(x): file``
        (as DATA CAM and DATA SLOT require), else ``None``."""
        if isinstance(self.root, Table):
            return load_table(self.table_path(self.root.filename), (self.file, self.root.line),
                              self.read_roots)
        return None


def reached(names: Iterable[str], env: Mapping[str, Any]) -> list[Expression]:
    """The expressions of the VALUEs ``names`` and of every VALUE they use, through any
    depth, each once, depth first in the order written (names that are not
    expressions of ``env`` are passed over)."""
    out: list[Expression] = []
    seen: set[str] = set()
    stack = list(reversed(list(names)))
    while stack:
        name = stack.pop()
        if name in seen:
            continue
        seen.add(name)
        item = env.get(name)
        if isinstance(item, Expression):
            out.append(item)
            stack.extend(reversed(item.value_names()))
    return out


def reads(names: Iterable[str], env: Mapping[str, Any], kinds: Iterable[str]) -> bool:
    """True when the VALUEs ``names``, or a VALUE they use, read a model quantity of one
    of ``kinds`` (``"POSITION"``, ``"FORCE"`` ...)."""
    kinds = set(kinds)
    return any(kind in kinds for ex in reached(names, env) for kind, _ in ex.references())


def if_tests(names: Iterable[str], env: Mapping[str, Any]) -> list[tuple[Expression, Node]]:
    """The test value of every IF that the VALUEs ``names`` reach, through the VALUEs
    they use, each once and in a fixed order: (its expression, the test node).  A load
    given by such VALUEs switches where one of them crosses zero."""
    return [(ex, n.cond) for ex in reached(names, env) for n in ex.nodes() if isinstance(n, If)]


# --------------------------------------------------------------------------- evaluator


def _m(f: Callable[..., float], *args: float) -> float:
    """Call a math function, mapping domain and range errors to nan."""
    try:
        return f(*args)
    except (ValueError, OverflowError, ZeroDivisionError):
        return NAN


def _div(a: float, b: float) -> float:
    return a / b if b != 0.0 else NAN


def _round_comp(x: float) -> int:
    """Round half away from zero (a component number)."""
    return int(math.copysign(math.floor(abs(x) + 0.5), x))


class _Evaluator:
    def __init__(
        self,
        env: Mapping[str, Any] | None,
        resolve: Resolver | None,
        strict: bool,
        notes: list[str] | None,
        order: int,
    ) -> None:
        self.env = env if env is not None else {}
        self.resolve = resolve
        self.strict = strict
        self.notes = notes
        self.order = order
        self.memo: dict[str, Jet] = {}
        self.stack: list[str] = []
        self.expr: Expression | None = None
        self.depth = 0

    def run(self, expr: Expression) -> Jet:
        outer, self.expr = self.expr, expr
        try:
            return self.ev(expr.root)
        finally:
            self.expr = outer

    def where(self, node: Node) -> tuple[str, int]:
        assert self.expr is not None
        return (self.expr.file, node.line)

    def undefined(self, msg: str, node: Node) -> Jet:
        assert self.expr is not None
        text = f"{self.expr.label}: {msg}"
        if self.strict:
            raise InputError(text, self.where(node))
        if self.notes is not None:
            self.notes.append(f"{self.where(node)[0]}:{node.line}: {text}")
        return _UNDEF

    def call(self, node: Node, kind: str, name: str | None, comp: int) -> float:
        if self.resolve is None:
            return NAN
        try:
            v = self.resolve(kind, name, comp)
        except InputError as exc:
            if exc.where is None:
                raise InputError(str(exc), self.where(node)) from None
            raise
        return NAN if v is None else float(v)

    def ev(self, node: Node) -> Jet:
        self.depth += 1
        try:
            if self.depth > limits.MAX_EVAL_DEPTH:
                assert self.expr is not None
                raise InputError(f"{self.expr.label}: the evaluation descends more than "
                                 f"{limits.MAX_EVAL_DEPTH} levels through expressions and the "
                                 "VALUEs they use (limit MAX_EVAL_DEPTH); write the chain of "
                                 "VALUEs with fewer, shallower expressions", self.where(node))
            return self.node(node)
        finally:
            self.depth -= 1

    def node(self, node: Node) -> Jet:
        """The jet of one node (see :meth:`ev`)."""
        if isinstance(node, Num):
            return (node.value, 0.0, 0.0)
        if isinstance(node, BinOp):
            return self.binop(node)
        if isinstance(node, Call):
            return self.func(node)
        if isinstance(node, ValueRef):
            return self.value(node)
        if isinstance(node, Time):
            if self.resolve is None:
                return self.undefined("TIME is not available here (no resolver given)", node)
            return (self.call(node, "TIME", None, 0), 1.0, 0.0)
        if isinstance(node, Ref):
            return self.ref(node)
        if isinstance(node, If):
            c = self.ev(node.cond)[0]
            if math.isnan(c):
                return self.undefined("the test value of IF is undefined", node)
            return self.ev(node.neg if c < 0 else node.zero if c == 0 else node.pos)
        if isinstance(node, Table):
            assert self.expr is not None
            table = load_table(self.expr.table_path(node.filename), self.where(node),
                               self.expr.read_roots)
            x0, x1, x2 = self.ev(node.arg)
            f, f1, f2 = table.derivatives(x0)
            return (f, f1 * x1, f2 * x1 * x1 + f1 * x2)
        if isinstance(node, User):
            return self.user(node)
        if isinstance(node, Stop):
            raise SimulationStop(node.kind, self.where(node))
        raise InputError(f"unknown expression node {type(node).__name__}")  # pragma: no cover

    def user(self, node: User) -> Jet:
        """USER(name) at the current time: the registered function and, where the VALUE
        needs them, its two time derivatives (:func:`register_user`)."""
        fn = USER_FUNCTIONS.get(node.name[:4])
        if fn is None:
            return self.undefined(f"USER({node.name}) is not supplied: register it with "
                                  f"openimp.imp.register_user('{node.name}', f) or run with "
                                  "openimp run --user FILE.py", node)
        t = self.call(node, "TIME", None, 0)
        if math.isnan(t):
            return self.undefined(f"USER({node.name}) needs the time, undefined here", node)
        out = [0.0, 0.0, 0.0]
        for k in range(3 if self.order else 1):
            try:
                v = float(fn(t, k))
            except Exception as exc:  # the user's code: said, never a traceback
                return self.undefined(f"USER({node.name}) failed at t = {t:.6g} with nderiv "
                                      f"{k} ({type(exc).__name__}: {printable(str(exc), 120)})",
                                      node)
            if not math.isfinite(v):
                return self.undefined(f"USER({node.name}) returned {v} at t = {t:.6g} with "
                                      f"nderiv {k}", node)
            out[k] = v
        return (out[0], out[1], out[2])

    def value(self, node: ValueRef) -> Jet:
        name = node.name
        if name in self.memo:
            return self.memo[name]
        if name in self.stack:
            chain = " -> ".join([*self.stack[self.stack.index(name):], name])
            return self.undefined(f"VALUE {name} refers to itself ({chain})", node)
        if name not in self.env:
            return self.undefined(f"{name} is not a defined VALUE", node)
        if len(self.stack) >= MAX_CHAIN:
            return self.undefined(f"VALUEs refer to one another more than {MAX_CHAIN} deep", node)
        item = self.env[name]
        if isinstance(item, Expression):
            self.stack.append(name)
            try:
                jet = self.run(item)
            finally:
                self.stack.pop()
        elif isinstance(item, tuple):
            jet = (float(item[0]), float(item[1]), float(item[2]))
        else:
            jet = (float(item), 0.0, 0.0)
        self.memo[name] = jet
        return jet

    def ref(self, node: Ref) -> Jet:
        c = self.ev(node.comp)[0]
        if not math.isfinite(c):
            return self.undefined(f"the component of {node.kind}({node.element}, ...) is undefined",
                                  node)
        comp = _round_comp(c)
        if self.resolve is None:
            return self.undefined(f"{node.kind}({node.element}, {comp}) needs the model (no "
                                  "resolver given)", node)
        chain = ("POSITION", "VELOCITY", "ACCEL")
        if node.kind == "FORCE":
            return (self.call(node, "FORCE", node.element, comp), NAN, NAN)
        first = chain.index(node.kind)
        out = [NAN, NAN, NAN]
        for k in range(3 if self.order else 1):
            if first + k < 3:
                out[k] = self.call(node, chain[first + k], node.element, comp)
        if not self.order:
            out[1] = out[2] = 0.0
        return (out[0], out[1], out[2])

    def binop(self, node: BinOp) -> Jet:
        a0, a1, a2 = self.ev(node.left)
        b0, b1, b2 = self.ev(node.right)
        op = node.op
        if op == "+":
            out = (a0 + b0, a1 + b1, a2 + b2)
        elif op == "-":
            out = (a0 - b0, a1 - b1, a2 - b2)
        elif op == "*":
            out = (a0 * b0, a1 * b0 + a0 * b1, a2 * b0 + 2.0 * a1 * b1 + a0 * b2)
        elif op == "/":
            if b0 == 0.0:
                return self.undefined("division by zero", node)
            q = a0 / b0
            q1 = (a1 - q * b1) / b0
            out = (q, q1, (a2 - 2.0 * q1 * b1 - q * b2) / b0)
        else:
            return self.power(node, (a0, a1, a2), (b0, b1, b2))
        if not math.isfinite(out[0]) and math.isfinite(a0) and math.isfinite(b0):
            # finite operands, a result beyond the arithmetic: said, as '@' says it
            return self.undefined(f"'{op}' overflows ({a0:g} {op} {b0:g})", node)
        return out

    def power(self, node: BinOp, a: Jet, b: Jet) -> Jet:
        """``a @ b`` with its derivatives."""
        a0, a1, a2 = a
        b0, b1, b2 = b
        # "@": a ** b computed with logarithms, as IMP did: the base must be > 0
        if a0 <= 0.0:
            return self.undefined(f"the base of '@' is {a0:g}; it must be > 0 (IMP computes "
                                  "powers with logarithms)", node)
        la = _m(math.log, a0)
        f = _m(math.exp, b0 * la)
        if math.isnan(f) and not math.isnan(b0 * la):
            return self.undefined("'@' overflows", node)
        r1 = a1 / a0
        u1 = b1 * la + b0 * r1
        u2 = b2 * la + 2.0 * b1 * r1 + b0 * (a2 / a0 - r1 * r1)
        return (f, f * u1, f * (u1 * u1 + u2))

    def func(self, node: Call) -> Jet:
        name = node.func
        x0, x1, x2 = self.ev(node.args[0])
        if name == "ATAN2":
            y0, y1, y2 = x0, x1, x2
            d0, d1, d2 = self.ev(node.args[1])
            if y0 == 0.0 and d0 == 0.0:
                return self.undefined("ATAN2(0, 0) is undefined", node)
            th = math.atan2(y0, d0)
            if th == -math.pi:
                th = math.pi  # range (-pi, pi]
            r2 = d0 * d0 + y0 * y0
            n = d0 * y1 - y0 * d1
            n1 = d0 * y2 - y0 * d2
            r21 = 2.0 * (d0 * d1 + y0 * y1)
            return (th, _div(n, r2), _div(n1 * r2 - n * r21, r2 * r2))
        if math.isnan(x0):
            return _UNDEF
        if name == "ABS":
            s = math.copysign(1.0, x0) if x0 != 0.0 else 0.0
            return (abs(x0), s * x1, s * x2)
        if name == "SIN":
            s, c = _m(math.sin, x0), _m(math.cos, x0)
            return (s, c * x1, -s * x1 * x1 + c * x2)
        if name == "COS":
            s, c = _m(math.sin, x0), _m(math.cos, x0)
            return (c, -s * x1, -c * x1 * x1 - s * x2)
        if name == "TAN":
            c = _m(math.cos, x0)
            if c == 0.0 or math.isnan(c):
                return self.undefined(f"TAN({x0:g}) is undefined", node)
            t = math.sin(x0) / c
            sec2 = 1.0 + t * t
            return (t, sec2 * x1, 2.0 * t * sec2 * x1 * x1 + sec2 * x2)
        if name in ("ASIN", "ACOS"):
            if abs(x0) > 1.0:
                return self.undefined(f"{name}({x0:g}) is undefined: the argument must lie in "
                                      "[-1, 1]", node)
            r = math.sqrt(1.0 - x0 * x0)
            d1 = _div(x1, r)
            d2 = _div(x2, r) + _div(x0 * x1 * x1, r * r * r)
            if name == "ASIN":
                return (math.asin(x0), d1, d2)
            return (math.acos(x0), -d1, -d2)
        if name == "EXP":
            e = _m(math.exp, x0)
            if math.isnan(e):
                return self.undefined(f"EXP({x0:g}) overflows", node)
            return (e, e * x1, e * (x1 * x1 + x2))
        if name in ("LOG", "LOG10"):
            if x0 <= 0.0:
                return self.undefined(f"{name}({x0:g}) is undefined: the argument must be > 0",
                                      node)
            k = 1.0 if name == "LOG" else 1.0 / math.log(10.0)
            r = x1 / x0
            return (k * math.log(x0), k * r, k * (x2 / x0 - r * r))
        # SQRT
        if x0 < 0.0:
            return self.undefined(f"SQRT({x0:g}) is undefined: the argument must be >= 0", node)
        s = math.sqrt(x0)
        return (s, _div(x1, 2.0 * s), _div(x2, 2.0 * s) - _div(x1 * x1, 4.0 * s * s * s))

