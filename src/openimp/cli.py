"""The ``openimp`` command.

::

    openimp run DECK [--json FILE] [--csv DIR] [--out DIR] [--quiet]
    openimp check DECK
    openimp --version

``run`` reads an IMP deck, runs every EXECUTE in order and prints IMP-style
output (banners, messages, PRINT output per position, LIST listings) on
stdout; ``--json`` writes every table at full precision in the DESIGN.md
schema, ``--csv`` one CSV file per table, ``--out`` receives STORE files,
plots and animations (the current directory receives STORE files without
it).  ``check`` parses the deck, builds and validates every model, and runs
no analysis; it lists on stderr, in the run's own words, every request or
run that ``run`` would not produce, and then exits with status 1 as ``run``
would.  Warnings about the deck (``file:line: warning: ...``) go to stderr.

Exit status: 0 success; 2 input errors (each printed as ``file:line:
message`` on stderr, and nothing is run); 1 an analysis failed or a request
could not be produced (what was computed is still printed and written).
No Python traceback is ever shown: unexpected problems are reported as
internal errors with exit status 1.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Sequence
from typing import Any, TextIO

__all__ = ["main"]

EXIT_OK = 0
EXIT_FAILURE = 1
EXIT_INPUT = 2


class _ArgumentParser(argparse.ArgumentParser):
    """argparse that exits with status 2 and a one-line usage hint."""

    def error(self, message: str) -> None:  # type: ignore[override]
        self.print_usage(sys.stderr)
        self.exit(EXIT_INPUT, f"openimp: error: {message}\n")


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
                   help="directory for STORE files, plots and animations")
    r.add_argument("--quiet", action="store_true",
                   help="print nothing on stdout (errors and failures still go to stderr)")
    c = sub.add_parser("check", help="read and validate a deck without running it")
    c.add_argument("deck", help="the IMP deck file")
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


def _load(path: str) -> object | None:
    """The parsed deck, or None after its input errors are printed on stderr."""
    from openimp.errors import InputError
    from openimp.imp.interp import load

    try:
        deck = load(path)
    except InputError as exc:
        for w in getattr(exc, "warnings", []):  # they may explain the errors
            print(w, file=sys.stderr)
        for line in _errors(exc):
            print(line, file=sys.stderr)
        return None
    for w in deck.warnings:
        print(w, file=sys.stderr)
    return deck


def _cmd_check(args: argparse.Namespace) -> int:
    from openimp.imp.interp import DEFAULT_TITLE
    from openimp.imp.runner import not_produced, trailing_requests, validate

    deck: Any = _load(args.deck)
    if deck is None:
        return EXIT_INPUT
    specs = deck.specs
    lines: list[str] = []
    missing: list[str] = []  # worded as `openimp run` words them on stderr
    for spec in specs:
        prep = validate(spec)
        m = prep.built.model
        s = prep.system
        failure, unsupported = not_produced(spec)
        gaps = ([failure] if failure else []) + unsupported
        title = spec.state.title or DEFAULT_TITLE
        missing += [f"run {spec.index} ({title}): {text}" for text in gaps]
        lines.append(f"  run {spec.index} ({spec.mode}) at {spec.where[0]}:{spec.where[1]}: "
                     f"{len(m.bodies)} links, {len(m.joints)} joints, {len(m.points)} points, "
                     f"{s.nloops} loop(s), {len(prep.drivers)} input motion(s), "
                     f"{len(prep.items)} table(s)"
                     + ("; produces nothing" if failure else
                        f"; {len(unsupported)} request(s) not produced" if unsupported else ""))
    notes = trailing_requests(deck)
    if not specs:
        notes.append("the deck has no EXECUTE statement: nothing would be run")
    if deck.interp.state.graphics.used or any(sp.state.graphics.used for sp in specs):
        notes.append("graphics statements (DRAW, ANIMATE, PLOT ...) are rendered only by "
                     "openimp run --out DIR")
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
    return EXIT_FAILURE if missing else EXIT_OK


def _cmd_run(args: argparse.Namespace) -> int:
    from openimp import _warm, io

    _warm.start()  # on a cold kernel cache the rate kernels compile on the other core
    deck = _load(args.deck)
    if deck is None:
        return EXIT_INPUT
    out = sys.stdout

    def echo(line: str) -> None:
        if not args.quiet:
            out.write(line + "\n")

    def note(line: str) -> None:
        print(f"openimp: note: {line}", file=sys.stderr)

    progress = _Progress(sys.stderr) if sys.stderr.isatty() else None
    runs = deck.run(out_dir=args.out, echo=echo,  # type: ignore[attr-defined]
                    progress=progress, notes=note)
    out.flush()
    status = EXIT_OK
    for k, run in enumerate(runs, start=1):
        if run.failure:
            print(f"openimp: run {k} ({run.title}): {run.failure}", file=sys.stderr)
            status = EXIT_FAILURE
        for u in run.unsupported:
            print(f"openimp: run {k} ({run.title}): {u}", file=sys.stderr)
            status = EXIT_FAILURE
    if args.json:
        io.write_json(args.json, runs)
    if args.csv:
        os.makedirs(args.csv, exist_ok=True)
        io.write_csv(args.csv, runs)
    if not runs:
        note("the deck has no EXECUTE statement: nothing was run")
    return status


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``openimp`` command; returns the exit status."""
    try:
        parser = _parser()
        args = parser.parse_args(argv)
        if args.command is None:
            parser.print_help(sys.stderr)
            return EXIT_INPUT
        if args.command == "check":
            return _cmd_check(args)
        return _cmd_run(args)
    except SystemExit as exc:  # argparse --help / --version / usage errors
        code = exc.code
        return code if isinstance(code, int) else (0 if code is None else EXIT_INPUT)
    except KeyboardInterrupt:
        print("openimp: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        return EXIT_OK
    except Exception as exc:
        from openimp.errors import InputError

        if isinstance(exc, InputError):
            for line in _errors(exc):
                print(line, file=sys.stderr)
            return EXIT_INPUT
        if isinstance(exc, OSError):
            print(f"openimp: error: {exc}", file=sys.stderr)
            return EXIT_INPUT
        print(f"openimp: internal error ({type(exc).__name__}: {exc}); please report it with "
              "the deck", file=sys.stderr)
        return EXIT_FAILURE


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
