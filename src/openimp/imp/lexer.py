"""Lexer of the IMP problem-oriented language (docs/imp-language.md §3).

Three layers, each usable on its own:

1. :func:`split_statements` turns physical lines into :class:`SourceStatement`
   objects: columns past 72 dropped, ``$`` continuations joined, ``$`` / ``$$``
   remarks cut off.  Every character of the joined text keeps its file line and
   column.
2. :class:`Scanner` reads :class:`Token` objects (names, numbers, separators,
   ``)``) from a source statement, lazily, so that a caller can stop and take
   the rest of the line as raw text (file names, titles, remarks).
3. :func:`reduce_items` applies the rules that hold *outside* VALUE
   expressions: every separator is equivalent, ``)`` is ignored, a ``+``/``-``
   directly in front of a number is its sign, and two non-blank separators in
   a row imply a zero between them (with a warning, as IMP printed one).
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field

from openimp.errors import InputError
from openimp.files import printable, quote

__all__ = [
    "BLANKS",
    "COLUMNS",
    "NUMBER_RE",
    "SEPARATORS",
    "Item",
    "Scanner",
    "SourceStatement",
    "Token",
    "keyword_key",
    "reduce_items",
    "split_lines",
    "split_statements",
    "tokenize",
]

#: Useful columns of a line.  IMP read 80-column card images and ignored
#: columns 73-80 (the card sequence field); docs/imp-language.md §3 "Lines".
COLUMNS = 72

#: The non-blank separators of docs/imp-language.md §3 (``:`` added, as the manual uses it).
SEPARATORS = frozenset(",+;-*(/=@:")

#: Characters read as a blank separator (tabs are expanded to 8-column stops first).
BLANKS = frozenset(" \t\r\f\v")

# characters that end the junk skipped after a number
_NUMBER_STOP = SEPARATORS | BLANKS | {")"}

_NAME_RE = re.compile(r"[A-Za-z][A-Za-z0-9_]*")
# digits with an optional point, or a point and digits; then an optional exponent
NUMBER_RE = re.compile(r"(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?")


def keyword_key(word: str) -> str:
    """Return the significant form of a keyword: its first 4 letters, upper case.

    IMP matches keywords on their first 4 characters only (docs/imp-language.md
    §3), so ``EXEC``, ``EXECUTE`` and ``execute`` are one keyword.
    """
    return word[:4].upper()


@dataclass
class SourceStatement:
    """One logical statement as read from the deck, before tokenizing.

    ``text`` is the useful part of the statement: the lines joined at their
    ``$`` continuation marks, remarks and columns past 72 removed.  ``lines``
    and ``cols`` give, for each character of ``text``, its line number and its
    1-based column in the file.  ``source`` is the original text of all the
    physical lines of the statement, joined with newlines.
    """

    file: str
    line: int
    end_line: int
    text: str
    lines: list[int]
    cols: list[int]
    source: str
    remarks: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)

    def line_at(self, pos: int) -> int:
        """Line number of the character at offset ``pos`` of ``text``."""
        if not self.lines:
            return self.line
        return self.lines[min(max(pos, 0), len(self.lines) - 1)]

    def col_at(self, pos: int) -> int:
        """1-based column of the character at offset ``pos`` of ``text``."""
        if not self.cols:
            return 1
        if pos >= len(self.cols):
            return self.cols[-1] + 1
        return self.cols[max(pos, 0)]

    def where(self, pos: int | None = None) -> tuple[str, int]:
        """``(file, line)`` of offset ``pos``, or of the statement's first line."""
        return (self.file, self.line if pos is None else self.line_at(pos))


def split_lines(text: str) -> list[str]:
    """Split ``text`` into physical lines on ``\\n`` only, dropping ``\\r``.

    Unlike :meth:`str.splitlines`, form feeds and other separators do not start
    a new line, so line numbers agree with what an editor shows.
    """
    return [ln.rstrip("\r") for ln in text.split("\n")]


def split_statements(
    lines: Iterable[str] | str,
    file: str = "<text>",
    first_line: int = 1,
    columns: int | None = COLUMNS,
) -> Iterator[SourceStatement]:
    """Yield the logical statements of ``lines`` (a text or a sequence of lines).

    Rules (docs/imp-language.md §3): only columns 1-``columns`` are read (pass ``None`` to
    read whole lines); a ``$`` ends the useful part of a line and continues the
    statement on the next line, joined as if the two lines were one (so ``$``
    may split a word); ``$$`` ends the statement; the text after ``$`` or
    ``$$`` is a remark.  Blank and remark-only lines yield nothing.
    ``first_line`` is the line number of the first element of ``lines``.
    """
    if isinstance(lines, str):
        lines = split_lines(lines)
    chars: list[str] = []
    line_of: list[int] = []
    col_of: list[int] = []
    source: list[str] = []
    remarks: list[str] = []
    warnings: list[str] = []
    start = 0
    pending = False
    lineno = first_line - 1
    for physical in lines:
        lineno += 1
        physical = physical.rstrip("\r\n")
        expanded = physical.expandtabs(8)
        body, cut = (expanded, "") if columns is None else (expanded[:columns], expanded[columns:])
        dollar = body.find("$")
        if dollar < 0:
            useful, remark, cont = body, None, False
        elif body.startswith("$$", dollar):
            useful, remark, cont = body[:dollar], body[dollar + 2 :], False
        else:
            useful, remark, cont = body[:dollar], body[dollar + 1 :], True
        if not pending and not useful.strip():
            if cont:  # a statement may begin on the line after a lone "$ remark"
                pending, start = True, lineno
                source.append(physical)
                if remark and remark.strip():
                    remarks.append(remark.strip())
            continue
        if not pending:
            start = lineno
        pending = True
        source.append(physical)
        if remark is not None and remark.strip():
            remarks.append(remark.strip())
        if cut.strip() and dollar < 0:  # text cut from a remark is no loss
            warnings.append(
                f"Warning: text past column {columns} is ignored on line {lineno}: "
                f"{quote(cut.strip())} (IMP read columns 1-{columns} only)."
            )
        for i, ch in enumerate(useful):
            chars.append(ch)
            line_of.append(lineno)
            col_of.append(i + 1)
        if cont:
            continue
        if "".join(chars).strip():
            yield _make(file, start, lineno, chars, line_of, col_of, source, remarks, warnings)
        chars, line_of, col_of, source, remarks, warnings = [], [], [], [], [], []
        pending = False
    if pending and "".join(chars).strip():
        yield _make(file, start, lineno, chars, line_of, col_of, source, remarks, warnings)


def _make(
    file: str,
    start: int,
    end: int,
    chars: list[str],
    line_of: list[int],
    col_of: list[int],
    source: list[str],
    remarks: list[str],
    warnings: list[str],
) -> SourceStatement:
    text = "".join(chars)
    # the statement starts on the line of its first non-blank character
    first = next((line_of[i] for i, ch in enumerate(text) if ch not in BLANKS), start)
    skip = first - start
    return SourceStatement(
        file=file,
        line=first,
        end_line=end,
        text=text,
        lines=line_of,
        cols=col_of,
        source="\n".join(source[skip:]),
        remarks=remarks,
        warnings=warnings,
    )


@dataclass(frozen=True)
class Token:
    """A lexical token of a statement.

    ``kind`` is ``'NAME'``, ``'NUMBER'`` (unsigned; ``value`` holds the float),
    ``'SEP'`` (one non-blank separator character) or ``'RPAREN'``.
    ``pos``/``end`` are offsets in the statement text; ``space_before`` tells
    whether a blank precedes the token.
    """

    kind: str
    text: str
    value: float | None
    pos: int
    end: int
    line: int
    col: int
    space_before: bool

    def describe(self) -> str:
        """A short phrase naming the token for error messages."""
        text = printable(self.text, 24)
        if self.kind == "NAME":
            return f"the name {text}"
        if self.kind == "NUMBER":
            return f"the number {text}"
        return f"'{text}'"


class Scanner:
    """Reads tokens from a :class:`SourceStatement`, one at a time.

    Numbers follow docs/imp-language.md §3: digits, an optional point, an optional
    exponent; once a number has started, characters up to the next separator
    are skipped (``3.8.0`` reads 3.8) with a warning added to the statement.
    Any character that is neither a letter, digit, separator, blank nor ``)``
    raises :class:`~openimp.errors.InputError`.
    """

    def __init__(self, stmt: SourceStatement, pos: int = 0, what: str = "statement") -> None:
        self.stmt = stmt
        self.text = stmt.text
        self.pos = pos
        self.what = what
        self._peeked: Token | None = None

    def error(self, message: str, pos: int | None = None) -> InputError:
        """An :class:`InputError` located at offset ``pos`` (default: current)."""
        return InputError(message, self.stmt.where(self.pos if pos is None else pos))

    def peek(self) -> Token | None:
        """The next token without consuming it (``None`` at the end)."""
        if self._peeked is None:
            self._peeked = self._read()
        return self._peeked

    def next(self) -> Token | None:
        """Consume and return the next token (``None`` at the end)."""
        tok = self.peek()
        self._peeked = None
        return tok

    def rest(self) -> str:
        """The raw text from the current position to the end of the statement."""
        if self._peeked is not None:
            self.pos, self._peeked = self._peeked.pos, None
        return self.text[self.pos :]

    def raw_word(self) -> tuple[str, int]:
        """Read a raw word (a file name): blanks skipped, then up to a blank, ``,``,
        ``;``, ``)`` or the end; a word in quotes may hold any of those.

        Returns the word and its start offset (the word is empty at the end).
        """
        if self._peeked is not None:
            self.pos, self._peeked = self._peeked.pos, None
        text, n = self.text, len(self.text)
        while self.pos < n and text[self.pos] in BLANKS:
            self.pos += 1
        start = self.pos
        if self.pos < n and text[self.pos] in "'\"":
            close = text.find(text[self.pos], self.pos + 1)
            if close < 0:
                raise self.error(f"the quoted name starting at column {self.stmt.col_at(start)} "
                                 "has no closing quote")
            self.pos = close + 1
            return text[start + 1 : close], start
        while self.pos < n and text[self.pos] not in BLANKS and text[self.pos] not in ",;)":
            self.pos += 1
        return text[start : self.pos], start

    def _read(self) -> Token | None:
        text, n = self.text, len(self.text)
        pos = self.pos
        space = False
        while pos < n and text[pos] in BLANKS:
            pos += 1
            space = True
        if pos >= n:
            self.pos = pos
            return None
        ch = text[pos]
        line, col = self.stmt.line_at(pos), self.stmt.col_at(pos)
        m = _NAME_RE.match(text, pos)
        if m:
            self.pos = m.end()
            return Token("NAME", m.group(), None, pos, m.end(), line, col, space)
        m = NUMBER_RE.match(text, pos)
        if m:
            end = m.end()
            junk_end = end
            while junk_end < n and text[junk_end] not in _NUMBER_STOP:
                junk_end += 1
            num = m.group()
            value = float(num)
            if value in (float("inf"), float("-inf")):
                raise self.error(f"the number {num} is out of range (the largest is about "
                                 "1.8E308)", pos)
            if junk_end > end:
                self.stmt.warnings.append(
                    f"Warning: characters {quote(text[end:junk_end])} after the number "
                    f"{printable(num, 24)} "
                    f"(line {line}, column {col}) are ignored."
                )
            self.pos = junk_end
            return Token("NUMBER", num, value, pos, junk_end, line, col, space)
        if ch in SEPARATORS:
            self.pos = pos + 1
            return Token("SEP", ch, None, pos, pos + 1, line, col, space)
        if ch == ")":
            self.pos = pos + 1
            return Token("RPAREN", ch, None, pos, pos + 1, line, col, space)
        raise self.error(
            f"unexpected character {quote(ch)} at column {col} in this {self.what}: names are "
            "letters and digits starting with a letter, numbers look like -1.5E-3, and "
            "separators are blank , ; / : = ( + - * @",
            pos,
        )


def tokenize(stmt: SourceStatement, pos: int = 0) -> list[Token]:
    """All tokens of ``stmt`` from offset ``pos`` on."""
    sc = Scanner(stmt, pos)
    out: list[Token] = []
    while (tok := sc.next()) is not None:
        out.append(tok)
    return out


@dataclass(frozen=True)
class Item:
    """A word or a number of a statement, as read outside VALUE expressions.

    ``kind`` is ``'WORD'`` or ``'NUMBER'``.  ``implied`` marks a zero that was
    implied by two consecutive separators.
    """

    kind: str
    text: str
    value: float | None
    line: int
    col: int
    implied: bool = False

    @property
    def key(self) -> str:
        """The keyword key of a word (first 4 letters, upper case); '' for numbers."""
        return keyword_key(self.text) if self.kind == "WORD" else ""

    def describe(self) -> str:
        """A short phrase naming the item for error messages."""
        if self.implied:
            return "a 0 implied by two separators in a row"
        if self.kind == "WORD":
            return f"the name {printable(self.text, 24)}"
        return f"the number {printable(self.text, 24)}"


def reduce_items(tokens: list[Token], stmt: SourceStatement | None = None) -> list[Item]:
    """Apply the outside-VALUE rules of docs/imp-language.md §3 to ``tokens``.

    All separators are equivalent and ``)`` is ignored; ``+``/``-`` directly in
    front of a number (no blank between) is its sign; two non-blank separators
    in a row mean a 0 between them.  The count of implied zeros is recorded as
    a warning on ``stmt`` (when given).
    """
    items: list[Item] = []
    implied = 0
    last_sep = False
    skip_next_sign = False
    for i, tok in enumerate(tokens):
        if tok.kind == "RPAREN":
            continue
        if tok.kind == "SEP":
            nxt = tokens[i + 1] if i + 1 < len(tokens) else None
            if tok.text in "+-" and nxt is not None and nxt.kind == "NUMBER" and nxt.pos == tok.end:
                skip_next_sign = True
                continue
            if last_sep:
                items.append(Item("NUMBER", "0", 0.0, tok.line, tok.col, implied=True))
                implied += 1
            last_sep = True
            continue
        last_sep = False
        if tok.kind == "NUMBER":
            value = tok.value if tok.value is not None else 0.0
            text = tok.text
            if skip_next_sign:
                sign = tokens[i - 1].text
                value = -value if sign == "-" else value
                text = sign + text
            items.append(Item("NUMBER", text, value, tok.line, tok.col))
        else:
            items.append(Item("WORD", tok.text, None, tok.line, tok.col))
        skip_next_sign = False
    if implied and stmt is not None:
        stmt.warnings.append(
            f"Warning: {implied} {'zero is' if implied == 1 else 'zeroes are'} implied by "
            "consecutive separators."
        )
    return items
