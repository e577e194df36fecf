"""A deck read, checked and ready to run: :func:`load` and :class:`Deck`.

Reading goes through the lexer, the parser and the interpreter
(:mod:`openimp.imp.interp`, which builds the model and the run
specifications); checking and running go through the runners
(:mod:`openimp.imp.run`).  This module sits below both, so neither imports
the other.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable
from typing import Any

from openimp.errors import InputError, PassedOverError
from openimp.files import inputs_of_run, real_roots
from openimp.imp.interp import (
    DEFAULT_TITLE,
    Built,
    DeckError,
    DeckWarning,
    Interpreter,
    Request,
    RunSpec,
    State,
    build_model,
)
from openimp.imp.parser import Statement, parse_file
from openimp.imp.run import run_deck, validate
from openimp.model import Model


# =============================================================================
# Deck
# =============================================================================
class Deck:
    """A deck read and checked: its statements, model snapshots, requests and runs.

    Built by :func:`load`.  ``model`` is the Model at the first EXECUTE (or at
    the end of the deck); ``requests`` the requests standing then.
    """

    def __init__(self, path: str, interp: Interpreter) -> None:
        self.path = path
        self.interp = interp
        self.statements: list[Statement] = interp.statements
        self.events = interp.events
        self.specs: list[RunSpec] = interp.runs
        #: warnings about statements carried out but probably not as meant
        self.warnings: list[DeckWarning] = interp.warnings
        first = interp.runs[0] if interp.runs else None
        self._state = first.state if first is not None else interp.state
        self._where = first.where if first is not None else (path, len(self.statements) and
                                                              self.statements[-1].line)
        self._built: Built | None = None
        #: real paths of the files the deck read (itself, RECALL INPUT, TABLE): no output
        #: of its runs replaces one of them
        self.inputs: set[str] = {os.path.realpath(path)}

    @property
    def state(self) -> State:
        """The interpreter state at the first EXECUTE (or at the end)."""
        return self._state

    @property
    def built(self) -> Built:
        """The built model of :attr:`state` (built on first use)."""
        if self._built is None:
            self._built = build_model(self._state, self._where)
        return self._built

    @property
    def model(self) -> Model:
        """The openimp Model at the first EXECUTE (or at the end of the deck)."""
        return self.built.model

    @property
    def requests(self) -> list[Request]:
        """The requests standing at the first EXECUTE (or at the end)."""
        return list(self._state.requests)

    @property
    def title(self) -> str:
        """The deck's title at the first EXECUTE."""
        return self._state.title or DEFAULT_TITLE

    def check(self) -> list[InputError]:
        """Build, compile and validate every EXECUTE's model (no analysis); the errors."""
        errors: list[InputError] = []
        for spec in self.specs:
            try:
                prep = validate(spec)
            except InputError as exc:
                errors.append(exc)
                continue
            if spec.state.strict and prep.checks:  # IMP accepted them; strict does not
                d = prep.checks[0]
                errors.append(InputError(
                    f"EXECUTE: over-specified motion: joint {d.joint} variable {d.var + 1} is "
                    "determined by the other inputs and the loops; remove its input or drive "
                    "another joint", d.inp.where))
        if not self.specs and self._state.joints:  # no EXECUTE: check what stands at the end
            try:
                build_model(self._state, self._where)
            except InputError as exc:
                errors.append(exc)
        return errors

    def run(self, out_dir: str | os.PathLike[str] | None = None,
            echo: Callable[[str], None] | None = None,
            progress: Callable[[int, int, int], None] | None = None,
            notes: Callable[[str], None] | None = None,
            overwrite: bool = False,
            problems: Callable[[str], None] | None = None) -> list[Any]:
        """Run every EXECUTE in order; returns the list of :class:`~openimp.results.Run`.

        ``echo`` receives every printed line (messages, banners, PRINT output,
        listings) in order; ``out_dir`` receives STORE, PRINT ON and STORE INPUT
        files, plots and animations (without it the files go to the deck's
        folder and graphics are not rendered); a file that exists and was not
        written by this run is replaced only with ``overwrite``;
        ``progress(run, done, total)`` is called while solving; ``notes``
        receives notes for stderr and ``problems`` (default: ``notes``) one
        message per file refused or not written.
        """
        with inputs_of_run(self.inputs):
            return run_deck(self, out_dir=out_dir, echo=echo, progress=progress, notes=notes,
                            overwrite=overwrite, problems=problems)

    def __repr__(self) -> str:
        return (f"Deck({self.path!r}: {len(self.statements)} statements, "
                f"{len(self.specs)} EXECUTE)")


def _deck_problem(p: str) -> str | None:
    """Why ``p`` cannot be read as a deck (None when it is a regular file)."""
    import stat

    if not os.path.lexists(p):
        return "the deck file does not exist"
    try:
        st = os.stat(p)
    except OSError as exc:
        return f"the deck cannot be read ({exc.strerror or type(exc).__name__})"
    if stat.S_ISDIR(st.st_mode):
        return "the deck is a directory, not a file; give the deck file's name"
    if not stat.S_ISREG(st.st_mode):
        return ("the deck is not a regular file (a device, pipe or socket); give the deck "
                "file's name")
    return None


_EMPTY_KEYWORDS = ("REMARK", "TITLE", "END")


def _empty_deck(p: str, statements: list[Statement]) -> InputError | None:
    """The error of a deck that holds nothing to build or run (None otherwise)."""
    if not statements:
        return InputError("the deck holds no statement (it is empty, blank or only remarks); a "
                          "deck defines joints (ZPIN, REVOLUTE, ...), gives their DATA and ends "
                          "with EXECUTE and END", (p, 0))
    if all(s.keyword in _EMPTY_KEYWORDS for s in statements):
        ended = statements[-1].keyword == "END" and statements[-1].file == p
        return InputError("the deck holds only REMARK and TITLE statements"
                          + (" before END" if ended else "") + ": nothing to build or run; a "
                          "deck defines joints (ZPIN, REVOLUTE, ...), gives their DATA and ends "
                          "with EXECUTE and END", (p, 0))
    return None


def load(path: str | os.PathLike[str], check: bool = True,
         allow_read: Iterable[str | os.PathLike[str]] = (), strict: bool = False,
         imp_listing: bool = False) -> Deck:
    """Read an IMP deck and carry out its statements (no analysis is run yet).

    Returns a :class:`Deck`; call ``deck.run()`` for the results.  Raises
    :class:`DeckError` listing every input error (each ``file:line: message``);
    with ``check`` (default) the model of every EXECUTE is also built, compiled
    and validated (mobility against the inputs).  RECALL INPUT, TABLE and
    SOLID READ read only inside the deck's folder and the folders of
    ``allow_read``.  A statement IMP answered with a message and passed over
    (:class:`~openimp.errors.PassedOverError`: FIND in the wrong mode, a missing SOLID READ
    file, a request naming a deleted item ...) is a located warning, and an
    EXECUTE whose model cannot be built fails alone when another can run;
    ``strict`` makes both input errors of the deck.  ``imp_listing`` starts the deck
    with IMP's printout (``REMARK OPENIMP LISTING = IMP``).
    """
    p = os.fspath(path)
    problem = _deck_problem(p)
    if problem is not None:
        raise DeckError([InputError(problem, (p, 0))])
    allow = [os.fspath(d) for d in allow_read]
    roots = real_roots([os.path.dirname(os.path.abspath(p)), *allow])
    errors: list[InputError] = []
    inputs: set[str] = set()
    with inputs_of_run(inputs):
        deck = _read(p, roots, allow, errors, check, strict=strict, imp_listing=imp_listing)
    deck.inputs |= inputs
    return deck


def _read(p: str, roots: tuple[str, ...], allow: list[str], errors: list[InputError],
          check: bool, *, strict: bool, imp_listing: bool) -> Deck:
    """:func:`load` after its checks of the path: parse, carry out, check."""
    try:
        statements = parse_file(p, on_error=errors.append, allow_read=allow)
    except InputError as exc:  # the deck cannot be read, or a limit stopped the reading
        raise DeckError([*errors, exc]) from None
    empty = _empty_deck(p, statements)
    if empty is not None and not errors:
        raise DeckError([empty])
    interp = Interpreter(os.path.dirname(p) or None, roots, strict=strict,
                         imp_listing=imp_listing)
    if not strict:  # statements the parser dropped, IMP passed over: warnings
        for e in [e for e in errors if isinstance(e, PassedOverError)]:
            errors.remove(e)
            interp.pass_over(e)
    interp.feed(statements)
    errors.extend(interp.errors)
    errors.sort(key=lambda e: (e.where or ("", 0))[1] if (e.where or ("",))[0] == p else 10**9)
    if errors:
        raise DeckError(errors, interp.warnings)
    deck = Deck(p, interp)
    if check:
        errs: list[InputError] = []
        for e in deck.check():  # the same problem seen by several EXECUTEs is told once
            if str(e) not in {str(x) for x in errs}:
                errs.append(e)
        if errs and (strict or len(errs) >= len(deck.specs)):
            raise DeckError(errs, interp.warnings)
        for e in errs:  # the other EXECUTEs run; this one fails with its message
            deck.warnings.append(DeckWarning(f"{e.args[0]}; this EXECUTE will not run (the "
                                             "others do)", e.where))
    return deck
