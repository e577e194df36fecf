"""Safe files: bounded reads inside allowed folders, atomic writes, printable messages.

Reading (decks, RECALL INPUT files, TABLE files, SOLID READ files):

* :func:`read_text` reads a regular file of at most
  :data:`~openimp.limits.MAX_FILE_BYTES`, refusing directories, devices,
  fifos and sockets (it never blocks on them), and, when ``roots`` are
  given, files outside those folders (symbolic links resolved);
* :func:`decode_text` accepts UTF-8 (with or without a byte-order mark) and
  8-bit text without control characters (read as Latin-1, as old decks
  are); UTF-16 and binary data are refused with a message that says so.

Writing: :func:`atomic_write` (and :func:`atomic_write_with` for writers that
need a file name, such as matplotlib) writes a temporary file beside the
target and renames it over the target, so a file is written whole or not at
all and no temporary file is left behind; the file gets the permissions
``open()`` would give it (``0666`` less the umask).  A symbolic link is written
through (its target replaced, the link kept); a FIFO or a character device
(``/dev/stdout``, a pipe a reader waits on) is written into directly, never
replaced; any other special file is refused.  Within :func:`inputs_of_run`
every file :func:`read_text` reads is an input of the run, and no write
replaces one (a deck's listing never overwrites the deck or a TABLE it reads).
:class:`OutputFolder` is where a run writes the files a deck asks for: names stay inside the
folder, and a file that the run did not create is not replaced unless the
user allows it.

Messages: :func:`printable` escapes control characters and line
separators, :func:`quote` quotes at most a few characters of a text (a file
name or a word read from a file) in a message.
"""

from __future__ import annotations

import os
import re
import secrets
import stat
from collections.abc import Callable, Iterable, Iterator, Sequence
from contextlib import contextmanager
from contextvars import ContextVar
from pathlib import Path

from openimp.errors import InputError, OutputError
from openimp.limits import MAX_FILE_BYTES

__all__ = [
    "OutputFolder",
    "atomic_write",
    "atomic_write_with",
    "check_readable",
    "decode_text",
    "input_problem",
    "inputs_of_run",
    "inside",
    "printable",
    "quote",
    "quote_path",
    "read_text",
    "real_roots",
]

Where = tuple[str, int]

# characters str.splitlines() breaks on, besides the C0/C1 control characters
_LINE_BREAKS = frozenset("\u2028\u2029")

#: the real paths of the files read by the run in progress (inputs_of_run)
_INPUTS: ContextVar[set[str] | None] = ContextVar("openimp_run_inputs", default=None)


@contextmanager
def inputs_of_run(paths: set[str]) -> Iterator[set[str]]:
    """Within the block, every file :func:`read_text` reads is added to ``paths`` (real
    paths) and no write of this module replaces one of them (:func:`input_problem`).
    Scoped to the calling thread or task (a context variable)."""
    token = _INPUTS.set(paths)
    try:
        yield paths
    finally:
        _INPUTS.reset(token)


def input_problem(path: str | os.PathLike[str]) -> str | None:
    """Why ``path`` must not be written: it is an input of the run in progress (None
    when it is not, or outside :func:`inputs_of_run`)."""
    inputs = _INPUTS.get()
    if inputs and os.path.realpath(path) in inputs:
        return (f"the file {quote_path(os.fspath(path))} is an input of this run (the deck, a "
                "recalled file or a TABLE it reads), so it is kept; give the output another "
                "name")
    return None


def printable(text: str, limit: int | None = None) -> str:
    """``text`` with control characters and line separators escaped (``\\x07``,
    ``\\u2028``), tabs kept; cut to ``limit`` characters (then ``...``)."""
    cut = limit is not None and len(text) > limit
    if cut:
        text = text[:limit]
    elif text.isprintable():  # the common case, checked at C speed (line separators and
        return text          # other Z*/C* characters are not "printable")
    out = []
    for ch in text:
        if ch == "\t" or (ch.isprintable() and ch not in _LINE_BREAKS):
            out.append(ch)
        else:
            code = ord(ch)
            out.append(f"\\x{code:02x}" if code < 0x100 else f"\\u{code:04x}")
    return "".join(out) + ("..." if cut else "")


def quote(text: str, limit: int = 24) -> str:
    """``'text'`` for a message: escaped and cut to ``limit`` characters."""
    return "'" + printable(text, limit) + "'"


def quote_path(path: str, limit: int = 160) -> str:
    """``'path'`` for a message: escaped, and long paths cut at the front (``'...tail'``)
    so that the file's own name shows."""
    if len(path) > limit:
        return "'..." + printable(path[-limit:]) + "'"
    return "'" + printable(path) + "'"


# --------------------------------------------------------------------------- reading


def real_roots(dirs: Iterable[str | os.PathLike[str]]) -> tuple[str, ...]:
    """The folders ``dirs`` as absolute paths with symbolic links resolved."""
    return tuple(os.path.realpath(os.fspath(d) or ".") for d in dirs)


def inside(path: str | os.PathLike[str], roots: Sequence[str]) -> bool:
    """True when ``path`` (links resolved) is one of ``roots`` or lies below one."""
    rp = os.path.realpath(os.fspath(path))
    for r in roots:
        try:
            if os.path.commonpath([rp, r]) == r:
                return True
        except ValueError:  # different drives
            continue
    return False


def _outside(shown: str, roots: Sequence[str]) -> str:
    folders = ", ".join(quote_path(r) for r in roots) or "none"
    return (f"the file {shown} is outside the folders a deck may read ({folders}); "
            "move it into the deck's folder or allow its folder with --allow-read DIR "
            "(Python: allow_read=[...])")


def check_readable(path: str, what: str, where: Where | None,
                   roots: Sequence[str] | None = None,
                   max_bytes: int = MAX_FILE_BYTES) -> None:
    """Raise InputError (``what: ...`` at ``where``) unless ``path`` is a regular
    file of at most ``max_bytes`` inside ``roots`` (when given)."""
    shown = quote_path(path)
    if roots is not None and not inside(path, roots):
        raise InputError(f"{what}: {_outside(shown, roots)}", where)
    try:
        st = os.stat(path)
    except OSError as exc:
        raise InputError(f"{what}: the file {shown} cannot be read ({_reason(exc)}); check the "
                         "name (it is relative to the deck's folder)", where) from None
    _check_stat(st, shown, what, where, max_bytes)


def _reason(exc: OSError) -> str:
    return exc.strerror or type(exc).__name__


def _kind(mode: int) -> str:
    if stat.S_ISDIR(mode):
        return "a directory"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    if stat.S_ISFIFO(mode):
        return "a pipe (fifo)"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return "not a regular file"


def _check_stat(st: os.stat_result, shown: str, what: str, where: Where | None,
                max_bytes: int) -> None:
    if not stat.S_ISREG(st.st_mode):
        raise InputError(f"{what}: {shown} is {_kind(st.st_mode)}, not a file; give the name "
                         "of a text file", where)
    if st.st_size > max_bytes:
        raise InputError(f"{what}: the file {shown} holds {st.st_size} bytes, more than "
                         f"{max_bytes} (limit MAX_FILE_BYTES)", where)


def read_text(path: str | os.PathLike[str], what: str, where: Where | None = None,
              roots: Sequence[str] | None = None, max_bytes: int = MAX_FILE_BYTES) -> str:
    """The text of a regular file (see the module docstring for the rules).

    Problems raise :class:`InputError` starting with ``what`` and located at
    ``where`` (give ``(path, 0)`` for the deck itself); decoding problems are
    located in the file itself.
    """
    p = os.fspath(path)
    shown = quote_path(p)
    if roots is not None and not inside(p, roots):
        raise InputError(f"{what}: {_outside(shown, roots)}", where)
    try:
        fd = os.open(p, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0))
    except OSError as exc:
        raise InputError(f"{what}: the file {shown} cannot be read ({_reason(exc)}); check the "
                         "name (it is relative to the deck's folder)", where) from None
    try:
        _check_stat(os.fstat(fd), shown, what, where, max_bytes)
        chunks: list[bytes] = []
        size = 0
        while size <= max_bytes:
            b = os.read(fd, min(1 << 20, max_bytes + 1 - size))
            if not b:
                break
            chunks.append(b)
            size += len(b)
    except OSError as exc:
        raise InputError(f"{what}: the file {shown} cannot be read ({_reason(exc)})",
                         where) from None
    finally:
        os.close(fd)
    if size > max_bytes:
        raise InputError(f"{what}: the file {shown} holds more than {max_bytes} bytes "
                         "(limit MAX_FILE_BYTES)", where)
    inputs = _INPUTS.get()
    if inputs is not None:
        inputs.add(os.path.realpath(p))
    return decode_text(b"".join(chunks), p)


_UTF8_BOM = b"\xef\xbb\xbf"
_WIDE_BOMS = ((b"\xff\xfe\x00\x00", "UTF-32"), (b"\x00\x00\xfe\xff", "UTF-32"),
              (b"\xff\xfe", "UTF-16"), (b"\xfe\xff", "UTF-16"))
# bytes that never occur in text: C0 controls but tab, newline, VT, FF, CR; and DEL
_BINARY = frozenset(set(range(0x00, 0x09)) | set(range(0x0e, 0x20)) | {0x7f})


def _line_of(data: bytes, pos: int) -> int:
    return data.count(b"\n", 0, pos) + 1


def decode_text(data: bytes, name: str) -> str:
    """Text of the bytes of file ``name``: UTF-8 (a byte-order mark is dropped),
    else 8-bit text read as Latin-1; UTF-16/32 and binary data raise InputError."""
    if data.startswith(_UTF8_BOM):
        data = data[len(_UTF8_BOM):]
    for bom, enc in _WIDE_BOMS:
        if data.startswith(bom):
            raise InputError(f"the file is {enc} text; save it as UTF-8 (or ASCII) text",
                             (name, 0))
    nul = data.find(b"\x00")
    if nul >= 0:
        raise InputError("the file holds NUL bytes, so it is not a text file (UTF-16 text "
                         "without a byte-order mark, or binary data); save it as UTF-8 text",
                         (name, _line_of(data, nul)))
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        bad = next((i for i, b in enumerate(data) if b in _BINARY), -1)
        if bad >= 0:
            raise InputError(f"the file is not text: byte 0x{data[bad]:02X} is a control "
                             "character and byte "
                             f"0x{data[exc.start]:02X} is not UTF-8; save it as UTF-8 text",
                             (name, _line_of(data, bad))) from None
        return data.decode("latin-1")


# --------------------------------------------------------------------------- writing


def _temp_beside(path: Path) -> tuple[int, str]:
    """Create a new temporary file beside ``path`` with open()'s permissions."""
    for _ in range(100):
        # the target's suffix kept: writers such as Pillow choose the format by it
        tmp = path.parent / f".{path.name}.{secrets.token_hex(4)}{path.suffix or '.tmp'}"
        try:
            fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL
                         | getattr(os, "O_CLOEXEC", 0), 0o666)
        except FileExistsError:
            continue
        return fd, str(tmp)
    raise FileExistsError(f"no free temporary name beside {path}")  # pragma: no cover


def _write_error(path: Path, exc: OSError) -> OutputError:
    if path.is_dir():
        why = "it is a directory"
    else:
        why = _reason(exc)
        blocker = _existing_ancestor(path.parent)
        if os.path.lexists(blocker) and not blocker.is_dir():
            why = f"{quote_path(str(blocker))} is a file, not a folder"
    return OutputError(f"the file {quote_path(str(path))} cannot be written ({why})", str(path))


def _direct(p: Path) -> bool | None:
    """How ``p`` (a real path) is written: False for a regular or new file (a temporary
    file renamed over it), True for a FIFO or character device (written into); None
    for what cannot be written safely (a block device, a socket)."""
    try:
        mode = os.stat(p).st_mode
    except OSError:
        return False
    if stat.S_ISREG(mode) or stat.S_ISDIR(mode):
        return False
    if stat.S_ISFIFO(mode) or stat.S_ISCHR(mode):
        return True
    return None


def atomic_write_with(path: str | os.PathLike[str], write: Callable[[str], None]) -> Path:
    """Call ``write(tmp)`` on a temporary file beside ``path``, then rename it over
    ``path``.  Creates the parent folders.  Raises :class:`OutputError` naming
    ``path`` (never the temporary file) when it cannot be written; no temporary
    file is left behind, even on KeyboardInterrupt.  A symbolic link is written
    through; a FIFO or character device is written into (``write(path)``); another
    special file or an input of the run (:func:`input_problem`) is refused."""
    p = Path(path)
    refused = input_problem(p)
    if refused is not None:
        raise OutputError(refused, str(p))
    if p.is_symlink():  # the user named the link: its target is written, the link kept
        p = Path(os.path.realpath(p))
    direct = _direct(p)
    if direct is None:
        raise OutputError(f"the file {quote_path(str(path))} is {_kind(os.stat(p).st_mode)}, "
                          "which is not written; give the name of a regular file, a FIFO or "
                          "a character device", str(path))
    if direct:
        try:
            write(str(p))
        except OSError as exc:
            raise _write_error(Path(path), exc) from None
        return Path(path)
    try:
        if p.is_dir():
            raise IsADirectoryError(21, "Is a directory")
        p.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = _temp_beside(p)
    except OSError as exc:
        raise _write_error(p, exc) from None
    os.close(fd)
    try:
        write(tmp)
        os.replace(tmp, p)
    except OSError as exc:
        _unlink(tmp)
        raise _write_error(p, exc) from None
    except BaseException:
        _unlink(tmp)
        raise
    return p


def _unlink(path: str) -> None:
    try:
        os.unlink(path)
    except OSError:
        pass


def atomic_write(path: str | os.PathLike[str], data: str | bytes) -> Path:
    """Write ``data`` (text as UTF-8, newlines kept) to ``path`` whole or not at all."""
    raw = data.encode("utf-8") if isinstance(data, str) else bytes(data)

    def write(tmp: str) -> None:
        with open(tmp, "wb") as f:
            f.write(raw)

    return atomic_write_with(path, write)


def _existing_ancestor(path: Path) -> Path:
    """``path`` or its nearest ancestor that exists."""
    while not os.path.lexists(path) and path != path.parent:
        path = path.parent
    return path


class OutputFolder:
    """The folder a run writes the deck's files into (STORE, PRINT ON, STORE
    INPUT, plots, animations, pictures).

    :meth:`target` gives the path of a name inside the folder, or ``None`` with
    a message in :attr:`refused` when the name leads outside the folder or
    names a file that exists and was not written by this run (unless
    ``overwrite``).  :meth:`write` writes through :func:`atomic_write` and
    remembers the file as the run's own, so the run may replace it later.
    """

    def __init__(self, base: str | os.PathLike[str], overwrite: bool = False) -> None:
        self.base = Path(base)
        self.overwrite = overwrite
        self.created: set[str] = set()
        self.refused: list[str] = []

    def target(self, name: str, where: Where | None = None) -> Path | None:
        """The path for ``name`` (relative to the folder), or None when refused."""
        loc = "" if where is None else (f"{where[0]}:{where[1]}: " if where[1] > 0 else
                                        f"{where[0]}: ")
        rel = Path(name)
        if rel.is_absolute() or ".." in rel.parts or not rel.parts:
            self.refused.append(f"{loc}the file name {quote_path(name)} leaves the output folder; "
                                "give a name inside it")
            return None
        p = self.base / rel
        if not inside(_existing_ancestor(p.parent), real_roots([self.base])):
            self.refused.append(f"{loc}the file {quote_path(str(p))} is not written: a symbolic "
                                "link leads out of the output folder")
            return None
        key = os.path.realpath(p)
        mine = input_problem(p)
        if mine is not None:
            self.refused.append(f"{loc}{mine}")
            return None
        if (os.path.lexists(p) and key not in self.created and not self.overwrite):
            self.refused.append(f"{loc}the file {quote_path(str(p))} exists and was not written "
                                "by this run, so it is kept; give --overwrite to replace it "
                                "(Python: overwrite=True), or another output folder (--out DIR)")
            return None
        return p

    def claim(self, path: Path) -> None:
        """Remember ``path`` as written by this run."""
        self.created.add(os.path.realpath(path))

    def write(self, name: str, data: str | bytes, where: Where | None = None) -> Path | None:
        """Write ``data`` to ``name`` in the folder; None when refused.  Raises
        :class:`OutputError` when the file cannot be written."""
        p = self.target(name, where)
        if p is None:
            return None
        atomic_write(p, data)
        self.claim(p)
        return p


def slug(s: str) -> str:
    """``s`` as a file-name part: letters and digits, other runs as ``_``, lower case."""
    return re.sub(r"[^A-Za-z0-9]+", "_", s).strip("_").lower() or "table"
