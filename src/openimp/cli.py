"""The ``openimp`` command.

::

    openimp run DECK [--json FILE] [--csv DIR] [--out DIR] [--overwrite]
                     [--allow-read DIR]... [--quiet]
    openimp check DECK [--allow-read DIR]...
    openimp --version

``run`` reads an IMP deck, runs every EXECUTE in order and prints IMP-style
output (banners, messages, PRINT output per position, LIST listings) on
stdout; ``--json`` writes every table at full precision (the JSON document
described in docs/imp.md, "Requests and output"), ``--csv`` one CSV file per
table, ``--out`` receives the deck's files (STORE, PRINT ON, STORE INPUT),
plots and animations; without it the deck's files go to the deck's folder and
graphics are not rendered.  A
file that exists from before the run is not replaced without
``--overwrite`` (the JSON and CSV targets, named on the command line, are).
RECALL INPUT, TABLE and SOLID READ read only inside the deck's folder and
the ``--allow-read`` folders.  ``check`` parses the deck, builds and
validates every model, and runs no analysis; it lists on stderr, in the
run's own words, every request or run that ``run`` would not produce, and
then exits with status 1 as ``run`` would.  Warnings about the deck
(``file:line: warning: ...``) go to stderr.

Exit status: 0 success; 2 input errors (each printed as ``file:line:
message`` on stderr, and nothing is run); 1 an analysis failed, a request
could not be produced or a file could not be written (what was computed is
still printed and written); 130 interrupted by Ctrl-C (what was computed is
still printed and written).  No Python traceback or raw Python warning is
ever shown: unexpected problems are reported as internal errors with exit
status 1, warnings as located notes.
"""

from __future__ import annotations

import argparse
import logging
import os
import signal
import sys
import time
import warnings
from collections.abc import Sequence
from typing import Any, TextIO

__all__ = ["entry", "main"]

EXIT_OK = 0
EXIT_FAILURE = 1
EXIT_INPUT = 2
EXIT_INTERRUPTED = 130


class _ArgumentParser(argparse.ArgumentParser):
    """argparse that exits with status 2 and a one-line usage hint."""

    def error(self, message: str) -> None:  # type: ignore[override]
        self.print_usage(sys.stderr)
        self.exit(EXIT_INPUT, f"openimp: error: {message}\n")


_STRICT = ("refuse the deck for a statement IMP answered with a message and passed over "
           "(FIND in the wrong mode, a missing SOLID READ file, a request naming a deleted "
           "item ...) and for an EXECUTE that cannot run; by default they are warnings and "
           "the rest runs")


def _parser() -> argparse.ArgumentParser:
    from openimp import __version__

    p = _ArgumentParser(
        prog="openimp",
        description="Mechanism analysis by the 4x4 matrix method: run IMP decks.",
    )
    p.add_argument("--version", action="version", version=f"openimp {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")
    r = sub.add_parser("run", help="run an IMP deck (every EXECUTE) and print its listings")
    r.add_argument("deck", help="the IMP deck file")
    r.add_argument("--json", metavar="FILE", help="write every table, full precision, as JSON")
    r.add_argument("--csv", metavar="DIR", help="write one CSV file per table into DIR")
    r.add_argument("--out", metavar="DIR",
                   help="folder for STORE, PRINT ON and STORE INPUT files, plots and "
                        "animations (default: the deck's folder; graphics only with --out)")
    r.add_argument("--overwrite", action="store_true",
                   help="let the deck's files replace files that exist from before the run")
    r.add_argument("--allow-read", metavar="DIR", action="append",
                   help="let RECALL INPUT, TABLE and SOLID READ read from DIR too (repeatable; "
                        "default: only the deck's folder)")
    r.add_argument("--quiet", action="store_true",
                   help="print nothing on stdout (errors and failures still go to stderr)")
    r.add_argument("--strict", action="store_true", help=_STRICT)
    r.add_argument("--user", metavar="FILE.py",
                   help="a Python file whose dict USER = {'NAME': f, ...} supplies the deck's "
                        "USER(NAME) functions, f(t, nderiv) -> value or time derivative")
    r.add_argument("--imp-listing", action="store_true",
                   help="IMP's printout: a run without DATA TIME lists a Time column and "
                        "prints 'time =' lines, as IMP did (default: Step, 'step =')")
    c = sub.add_parser("check", help="read and validate a deck without running it")
    c.add_argument("deck", help="the IMP deck file")
    c.add_argument("--allow-read", metavar="DIR", action="append",
                   help="let RECALL INPUT, TABLE and SOLID READ read from DIR too")
    c.add_argument("--strict", action="store_true", help=_STRICT)
    return p


class _Progress:
    """A progress bar on stderr, shown only for long runs on a terminal."""

    def __init__(self, stream: TextIO) -> None:
        self.stream = stream
        self.start = time.monotonic()
        self.shown = False

    def __call__(self, run: int, done: int, total: int) -> None:
        if total < 4000 and not self.shown:
            return
        width = 30
        filled = int(width * done / max(total, 1))
        self.stream.write(f"\rrun {run}: [{'#' * filled}{'.' * (width - filled)}] "
                          f"{done}/{total} positions")
        if done >= total:
            self.stream.write("\n")
            self.shown = False
        else:
            self.shown = True
        self.stream.flush()


def _errors(exc: Exception) -> list[str]:
    from openimp.imp.interp import DeckError

    if isinstance(exc, DeckError):
        return [str(e) for e in exc.errors]
    return [str(exc)]


def _err(line: str) -> None:
    """One line on stderr, control characters escaped."""
    from openimp.files import printable

    print(printable(line), file=sys.stderr)


def _print_errors(exc: Exception, deck: str) -> None:
    """The input errors of ``exc``, at most MAX_ERRORS_SHOWN of them."""
    from openimp.limits import MAX_ERRORS_SHOWN

    lines = _errors(exc)
    for line in lines[:MAX_ERRORS_SHOWN]:
        _err(line)
    if len(lines) > MAX_ERRORS_SHOWN:
        _err(f"{deck}: {len(lines) - MAX_ERRORS_SHOWN} more input errors are not shown "
             f"(limit MAX_ERRORS_SHOWN); correct the ones above first")


def _load(path: str, allow_read: Sequence[str] = (), strict: bool = False,
          imp_listing: bool = False) -> object | None:
    """The parsed deck, or None after its input errors are printed on stderr."""
    from openimp.errors import InputError
    from openimp.imp.deck import load

    try:
        deck = load(path, allow_read=allow_read, strict=strict, imp_listing=imp_listing)
    except InputError as exc:
        for w in getattr(exc, "warnings", []):  # they may explain the errors
            _err(str(w))
        _print_errors(exc, path)
        return None
    for w in deck.warnings:
        _err(str(w))
    return deck


def _user_functions(path: str) -> bool:
    """Register the USER functions of ``path`` (its dict ``USER``); False after saying
    why they cannot be (the file does not run, has no USER dict, a bad entry)."""
    import runpy

    from openimp.errors import InputError
    from openimp.files import quote_path
    from openimp.imp import register_user

    where = f"openimp: error: --user {quote_path(path)}"
    try:
        names = runpy.run_path(path)
    except Exception as exc:  # the user's file: said, never a traceback
        _err(f"{where}: the file does not run ({type(exc).__name__}: {exc})")
        return False
    table = names.get("USER")
    if not isinstance(table, dict) or not table:
        _err(f"{where}: define a dict USER = {{'NAME': f, ...}} in it, f(t, nderiv) returning "
             "the value (nderiv 0) or its first or second time derivative")
        return False
    try:
        for name, fn in table.items():
            register_user(str(name), fn)
    except InputError as exc:
        _err(f"{where}: {exc}")
        return False
    return True


def _cmd_check(args: argparse.Namespace) -> int:
    from openimp.errors import InputError
    from openimp.imp.interp import DEFAULT_TITLE
    from openimp.imp.run import not_produced, trailing_requests, validate
    from openimp.imp.run.prepare import redundancy_notes

    deck: Any = _load(args.deck, args.allow_read or (), args.strict)
    if deck is None:
        return EXIT_INPUT
    specs = deck.specs
    lines: list[str] = []
    missing: list[str] = []  # worded as `openimp run` words them on stderr
    checked: list[str] = []  # over-specified inputs, checked at every position
    for spec in specs:
        title = spec.state.title or DEFAULT_TITLE
        try:
            prep = validate(spec)
        except InputError as exc:  # load() let the deck's other EXECUTEs run
            missing.append(f"run {spec.index} ({title}): {exc}")
            lines.append(f"  run {spec.index} ({spec.mode}) at {spec.where[0]}:"
                         f"{spec.where[1]}: will not run")
            continue
        checked += redundancy_notes(prep)
        m = prep.built.model
        s = prep.system
        failure, unsupported = not_produced(spec)
        gaps = ([failure] if failure else []) + unsupported
        missing += [f"run {spec.index} ({title}): {text}" for text in gaps]
        lines.append(f"  run {spec.index} ({spec.mode}) at {spec.where[0]}:{spec.where[1]}: "
                     f"{len(m.bodies)} links, {len(m.joints)} joints, {len(m.points)} points, "
                     f"{s.nloops} loop(s), {len(prep.drivers)} input motion(s), "
                     f"{len(prep.items)} table(s)"
                     + ("; produces nothing" if failure else
                        f"; {len(unsupported)} request(s) not produced" if unsupported else ""))
    notes = checked + trailing_requests(deck)
    if not specs:
        notes.append(f"{args.deck}: the deck has no EXECUTE statement: nothing would be run")
    if deck.interp.state.graphics.used or any(sp.state.graphics.used for sp in specs):
        notes.append(f"{args.deck}: graphics statements (DRAW, ANIMATE, PLOT ...) are "
                     "rendered only by openimp run --out DIR")
    verdict = "OK" if not missing else \
        f"INCOMPLETE: {len(missing)} request(s) or run(s) will not be produced (see stderr)"
    print(f"{args.deck}: {len(deck.statements)} statements, {len(specs)} EXECUTE "
          f"statement(s): {verdict}")
    for line in lines:
        print(line)
    for text in missing:
        print(f"openimp: {text}", file=sys.stderr)
    for text in notes:
        print(f"openimp: note: {text}", file=sys.stderr)
    return EXIT_FAILURE if missing or not specs else EXIT_OK


def _target_problem(args: argparse.Namespace) -> str | None:
    """Why a --json, --csv or --out target cannot be used (checked before running)."""
    from openimp.files import quote_path

    if args.json and os.path.isdir(args.json):
        return f"--json {quote_path(args.json)} is a directory; give the name of a file"
    for opt in ("csv", "out"):
        target = getattr(args, opt)
        if target and os.path.lexists(target) and not os.path.isdir(target):
            return f"--{opt} {quote_path(target)} is not a directory; give a folder name"
    return None


def _write_outputs(args: argparse.Namespace, runs: list) -> bool:  # type: ignore[type-arg]
    """Write --json and --csv; each failure is told (naming the path); True if all were
    written.  A failure of one never stops the other."""
    from openimp import io
    from openimp.errors import OutputError

    ok = True
    if args.json:
        try:
            io.write_json(args.json, runs)
        except OutputError as exc:
            _err(f"openimp: error: --json: {exc}; the listings above hold the results")
            ok = False
    if args.csv:
        try:
            io.write_csv(args.csv, runs)
        except OutputError as exc:
            _err(f"openimp: error: --csv: {exc}")
            ok = False
    return ok


def _report(runs: list, problems: list[str]) -> int:  # type: ignore[type-arg]
    """Print every run's failure and unproduced request and every file problem; the
    exit status they give."""
    status = EXIT_OK
    for k, run in enumerate(runs, start=1):
        if run.failure and not run.interrupted:
            _err(f"openimp: run {k} ({run.title}): {run.failure}")
            status = EXIT_FAILURE
        for u in run.unsupported:
            _err(f"openimp: run {k} ({run.title}): {u}")
            status = EXIT_FAILURE
        if run.missing:  # located by the run's first message about them
            first = next((m for m in run.messages if "cannot be reached" in m), "")
            _err(f"openimp: run {k} ({run.title}): {len(run.missing)} position(s) could not "
                 f"be reached and were skipped; the first: {first}")
            status = EXIT_FAILURE
    for p in problems:
        _err(f"openimp: error: {p}")
        status = EXIT_FAILURE
    return status


def _cmd_run(args: argparse.Namespace) -> int:
    from openimp import _warm
    from openimp._announce import Announcer, announce

    problem = _target_problem(args)
    if problem is not None:
        _err(f"openimp: error: {problem}")
        return EXIT_INPUT
    # a cold kernel cache: say so, and compile the rate kernels on an idle core
    _warm.start(_warm.deck_flavours(args.deck))
    talk = Announcer(sys.stderr, sys.stderr.isatty(), prefix=f"{args.deck}: ")
    session = announce()
    session.muted = True  # this run's announcer says it, with its progress line
    try:
        return _run_deck(args, talk)
    finally:
        session.muted = False
        talk.close()


def _run_deck(args: argparse.Namespace, talk: Any) -> int:
    from openimp._interrupt import held_interrupt
    from openimp.errors import OutputError
    from openimp.files import inputs_of_run, printable

    if args.user and not _user_functions(args.user):
        return EXIT_INPUT
    deck = _load(args.deck, args.allow_read or (), args.strict, args.imp_listing)
    if deck is None:
        return EXIT_INPUT
    out = sys.stdout

    def echo(line: str) -> None:
        if not args.quiet:
            out.write(printable(line) + "\n")

    def note(line: str) -> None:
        _err(f"openimp: note: {line}")

    problems: list[str] = []
    progress = _Progress(sys.stderr) if sys.stderr.isatty() else None
    try:
        runs = deck.run(out_dir=args.out, echo=echo,  # type: ignore[attr-defined]
                        progress=progress, notes=note, overwrite=args.overwrite,
                        problems=problems.append)
    except OutputError as exc:
        _err(f"openimp: error: --out: {exc}")
        return EXIT_INPUT
    out.flush()
    status = _report(runs, problems)
    def told() -> None:
        _err("openimp: Ctrl-C: the --json and --csv files of what was run are being written; "
             "Ctrl-C again abandons them")

    # --json DECK keeps the deck; a first Ctrl-C lets the files be written whole
    with inputs_of_run(getattr(deck, "inputs", set())), held_interrupt(told) as held:
        if not _write_outputs(args, runs):
            status = EXIT_FAILURE
    if not runs:  # nothing produced: a failure, as a run that produced nothing
        note(f"{args.deck}: the deck has no EXECUTE statement: nothing was run")
        status = max(status, EXIT_FAILURE)
    stopped = [r for r in runs if r.interrupted]
    if stopped or held[0]:
        why = stopped[0].failure if stopped else "after the runs, while their files were written"
        kept = "" if "listed" in why else "; what was computed is listed and written"
        _err(f"openimp: interrupted (Ctrl-C): {why}{kept}")
        return EXIT_INTERRUPTED
    return status


def _note_warnings(caught: list[warnings.WarningMessage], deck: str | None) -> None:
    """Python warnings that escaped the runs, as one located note each."""
    from openimp.files import printable

    seen: set[str] = set()
    for w in caught:
        if issubclass(w.category, ResourceWarning):
            continue  # a file the import machinery had open when a Ctrl-C landed
        text = f"{w.category.__name__}: {printable(str(w.message), 120)}"
        if text not in seen:
            seen.add(text)
            _err(f"openimp: note: {deck or 'openimp'}: a computation gave a warning ({text}, "
                 f"in {os.path.basename(w.filename)}:{w.lineno})")


class _LogNotes(logging.Handler):
    """Log records of libraries (matplotlib, numba) as located notes, once each."""

    def __init__(self, deck: str | None) -> None:
        super().__init__(logging.WARNING)
        self.deck = deck
        self.seen: set[str] = set()

    def emit(self, record: logging.LogRecord) -> None:
        from openimp.files import printable

        text = printable(f"{record.name}: {record.getMessage()}", 200)
        if text not in self.seen:
            self.seen.add(text)
            _err(f"openimp: note: {self.deck or 'openimp'}: {text}")


def _dispatch(argv: Sequence[str] | None) -> int:
    parser = _parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help(sys.stderr)
        return EXIT_INPUT
    deck = getattr(args, "deck", None)
    _STARTED["deck"] = deck
    log = logging.getLogger()
    handler = _LogNotes(deck)
    log.addHandler(handler)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            if args.command == "check":
                return _cmd_check(args)
            return _cmd_run(args)
        finally:
            log.removeHandler(handler)
            _note_warnings(caught, deck)


def _interrupted() -> int:
    deck = _STARTED["deck"]
    _err("openimp: interrupted (Ctrl-C)" + (f": {deck}: before any of its runs was solved; "
                                              "nothing was written" if deck else ""))
    return EXIT_INTERRUPTED


#: the deck of the command being run (for a Ctrl-C outside its runs)
_STARTED: dict[str, str | None] = {"deck": None}


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``openimp`` command; returns the exit status."""
    _STARTED["deck"] = None
    try:
        return _dispatch(argv)
    except SystemExit as exc:  # argparse --help / --version / usage errors
        code = exc.code
        return code if isinstance(code, int) else (0 if code is None else EXIT_INPUT)
    except KeyboardInterrupt:  # outside a run (a run keeps and says what it solved)
        return _interrupted()
    except BrokenPipeError:
        return EXIT_OK
    except Exception as exc:
        from openimp._interrupt import caused_by_interrupt
        from openimp.errors import InputError

        if caused_by_interrupt(exc):  # inside an import (RuntimeError from __set_name__)
            return _interrupted()
        if isinstance(exc, InputError):
            for line in _errors(exc):
                _err(line)
            return EXIT_INPUT
        if isinstance(exc, OSError):
            _err(f"openimp: error: {exc}")
            return EXIT_FAILURE
        _err(f"openimp: internal error ({type(exc).__name__}: {exc}); please report it with "
             "the deck")
        return EXIT_FAILURE


def _unraisable(u: Any) -> None:
    """A Ctrl-C that landed in a callback Python cannot raise from (numba's compiler
    calls back through ctypes) is kept and raised once the compile is over, instead of
    printed as an ignored exception with its traceback (raising it at once, inside the
    compiler, leaves numba's library without its compiled object)."""
    if isinstance(u.exc_value, KeyboardInterrupt):
        from openimp._interrupt import PENDING

        PENDING[0] = True  # raised when the compile is over (openimp._warm)
        return
    sys.__unraisablehook__(u)


def entry() -> None:
    """The ``openimp`` console command: :func:`main`, then exit with its status.  Once
    main has returned everything is written: a Ctrl-C then changes nothing, and the
    process ends without Python's finalization (a Ctrl-C that interrupted an import
    could otherwise end the process by SIGINT, status -2, after main returned 130)."""
    sys.unraisablehook = _unraisable
    status = main()
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a closed pipe: nothing more to say
            pass
    os._exit(status)


if __name__ == "__main__":  # pragma: no cover
    entry()
