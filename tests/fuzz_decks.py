"""Fuzzing the ``openimp`` command with mutated and generated decks.

A seeded generator (:func:`make_case`) mutates the decks of ``examples/`` and
``tests/decks/`` (numbers replaced by hostile ones, lines dropped, repeated
and swapped, generated statements inserted, characters and encodings
broken, RECALL INPUT / TABLE / PRINT ON / STORE INPUT aimed at files outside
the deck's folder and at devices) and picks a command line.  :func:`run_case`
runs one case in-process through :func:`openimp.cli.main` in a scratch
folder with a time limit, and :func:`failures` lists what went wrong:

* ``status``: an exit status other than 0, 1 or 2;
* ``internal``: the last-resort "internal error ... please report it";
* ``traceback``: a Python traceback;
* ``warning``: a raw Python warning, or a warning turned into a note;
* ``no_location``: a stderr line (error or note) without ``file:line:``
  (or the deck's name, or the command-line option it is about);
* ``outside``: a file written outside the deck's folder and the output folder,
  a file that existed before the run changed, or a temporary file left;
* ``hang``: the case ran past its time limit; ``memory``: a MemoryError;
* ``nonfinite``: exit 0 with an undefined (``????``) position in a listing;
* with ``--sigint-every N``, every N-th case runs as a real process that gets a
  SIGINT (Ctrl-C) at a random moment: ``sigint_hang`` when it has not ended 10 s
  later (then it is killed), ``sigint_slow`` when it took over a second, ``lost``
  when it was interrupted after listing results and its ``--json`` file is missing
  or not whole.

The test suite runs a few hundred cases (``tests/test_fuzz.py``); a long run::

    python -m tests.fuzz_decks --count 20000 --seed 1 [--workers 2] [--save DIR] [--extra DIR]
        [--sigint-every 20]

runs each batch of cases in a worker process (memory capped, killed if a
case hangs past ``--hard-timeout``) and prints the count of every class.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import random
import re
import resource
import shutil
import signal
import sys
import tempfile
import time
from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numba.core import event as numba_event

ROOT = Path(__file__).resolve().parent.parent
SOURCES = sorted([*(ROOT / "examples").glob("*.imp"), *(ROOT / "tests" / "decks").glob("*.imp"),
                  *(ROOT / "tests" / "decks" / "fuzz").glob("*.imp")])
#: support files a deck of the sources reads (copied beside every deck)
SUPPORT = {"cam_profile.tab": (ROOT / "examples" / "cam_profile.tab").read_bytes()}

CLASSES = ("status", "internal", "traceback", "warning", "no_location", "outside", "hang",
           "memory", "nonfinite", "sigint_hang", "sigint_slow", "lost")

NASTY_NUMBERS = [
    "0", "-0", "1", "-1", "0.5", "360", "-360", "1E-320", "4.9E-324", "1E-300", "1E-15",
    "1E-9", "1E6", "1E12", "1E100", "1E149", "1E150", "-1E150", "1.5E150", "1E151",
    "1E154", "1E200", "1E300", "-1E300", "1.7976931348623157E308", "1E309", "1E999",
    "9223372036854775808", "2147483648", "100000", "100001", "99999", "1.2.3", "12E12E12",
    "0.0000001", "3.14159", "2.5", "-2.5", "25", "1000000000",
]
#: numbers the input checks accept but the arithmetic may not like
EDGE_NUMBERS = ["1E149", "-1E149", "1E140", "1E100", "1E75", "1E59", "-1E59", "1E60", "1E-300",
                "4.9E-324", "1E-14", "1E-13", "1E-7", "99999", "100000", "1000", "5E149",
                "1.0000001", "-1.0000001", "1E6", "1E-6", "0"]
NAMES = ["A", "B", "C", "D", "E", "R1", "R2", "S", "U", "P", "CP", "CB", "BASE", "CRANK",
         "COUPLER", "ROCKER", "G1", "G2", "M", "V", "W", "X1", "SLID", "PIN", "QQ"]
CONTROL_CHARS = ["\x00", "\x07", "\x0b", "\x0c", "\x1b", "\x1c", "\x7f", "\x85", "\u2028",
                 "\ufeff", "\r", "\t", "é", "😀", "\u202e"]
FILES = ["cam_profile.tab", "self.imp", "other.imp", "junk.bin", "sub/inner.imp",
         "../outside/victim.txt", "/dev/zero", "/dev/null", "/etc/passwd", "adir", "loop",
         "missing.tab", "big.tab", "../outside", "deck.imp", "~/x", "", "out.txt"]


@dataclass
class Case:
    """One fuzz case: files of the deck's folder, the deck's name, the command line."""

    index: int
    files: dict[str, bytes]
    deck: str
    argv: list[str]
    notes: list[str] = field(default_factory=list)

    def describe(self) -> str:
        return f"case {self.index}: {' '.join(self.argv)} ({'; '.join(self.notes)})"


# --------------------------------------------------------------------------- generation


def _num(rng: random.Random) -> str:
    if rng.random() < 0.6:
        return rng.choice(NASTY_NUMBERS)
    return f"{rng.uniform(-10, 10):.{rng.randint(0, 6)}f}"


_DECK_NAMES: list[str] = []  # joint names of the deck being mutated (set by make_case)
_DRIVEN: list[str] = []  # its joints with an input motion
_JOINT_NAME = re.compile(r"^\s*(?:[XYZ]PIN|REVOLUTE|[XYZ]SLIDE|PRISM|CYLINDER|UJOINT|SPHERE|"
                         r"GEAR|RACK|SCREW|CAM|SLOT|RIGID|FLAT|PLANE|OPEN|BEVEL)\b[^=\n]*=\s*"
                         r"([A-Z][A-Z0-9]*)", re.MULTILINE)


def _name(rng: random.Random) -> str:
    if _DECK_NAMES and rng.random() < 0.7:
        return rng.choice(_DECK_NAMES)
    return rng.choice(NAMES)


def _edge_statements(rng: random.Random) -> list[str]:
    """Statements that pass the input checks with numbers at the edge of the limits."""
    e = rng.choice(EDGE_NUMBERS)
    j = rng.choice(_DRIVEN) if _DRIVEN and rng.random() < 0.8 else _name(rng)
    p = _name(rng)
    return rng.choice([
        [f"VALUE (VV) = {_expr(rng)}", f"DATA MOTION ({j}) = VV"],
        [f"VALUE (VV) = T*{e}", f"DATA MOTION ({j}) = VV"],
        [f"VALUE (VV) = EXP(T*{rng.choice(['700', '709', '710', '1E3'])})",
         f"DATA MOTION ({j}) = VV"],
        [f"VALUE (VV) = {e}@T", f"DATA MOTION ({j}) = VV", "DATA TIME = 3, 0, 0.5"],
        [f"DATA POSITION ({j}) = 0, {e}, 3", f"DATA VELOCITY ({j}) = {e}"],
        [f"DATA ACCEL ({j}) = {e}"],
        [f"DATA POINT ({p}, ABS) = {e}, 0, {rng.choice(EDGE_NUMBERS)}"],
        [f"DATA TIME = {e}, 0, {rng.choice(EDGE_NUMBERS)}"],
        [f"ZERO (POSITION) = {rng.choice(EDGE_NUMBERS)}, {rng.choice(['1', '1000', '5'])}"],
        [f"ZERO (SYSTEM) = {rng.choice(EDGE_NUMBERS)}"],
        [f"VALUE (VV) = TABLE(T*{e}): cam_profile.tab", "LIST VALUE (VV)"],
        [f"DATA GEAR ({j}) = {rng.choice(['1E6', '-0.999999', '1E-6', '-1.000001'])}, 2"],
    ])


def _expr(rng: random.Random, depth: int = 0) -> str:
    if depth > 3 or rng.random() < 0.3:
        return rng.choice(["T", "PI", _num(rng), _name(rng), "RETURN", "END"])
    k = rng.randint(0, 9)
    a, b = _expr(rng, depth + 1), _expr(rng, depth + 1)
    if k < 4:
        return f"{a}{rng.choice('+-*/@')}{b}"
    if k == 4:
        return f"IF({a}: {b}, {_expr(rng, depth + 1)}, {_expr(rng, depth + 1)})"
    if k == 5:
        return f"{rng.choice(['SIN', 'COS', 'TAN', 'EXP', 'LOG', 'SQRT', 'ABS', 'ASIN'])}({a})"
    if k == 6:
        return f"{rng.choice(['POSITION', 'VELOCITY', 'ACCEL'])}({_name(rng)}, {rng.randint(0, 4)})"
    if k == 7:
        return f"TABLE({a}): {rng.choice(FILES)}"
    if k == 8:
        return f"ATAN2({a}, {b})"
    return "(" * 45 + "T" + ")" * 45 if rng.random() < 0.1 else f"({a})"


def _statement(rng: random.Random) -> str:
    """A generated statement, valid or nearly so."""
    n, x = _name, _num
    forms = [
        lambda: f"DATA TIME = {x(rng)}, {x(rng)}, {x(rng)}",
        lambda: f"DATA POSITION ({n(rng)}) = {x(rng)}, {x(rng)}, {x(rng)}",
        lambda: f"DATA VELOCITY ({n(rng)}) = {x(rng)}",
        lambda: f"DATA ACCEL ({n(rng)}) = {x(rng)}",
        lambda: f"DATA MOTION ({n(rng)}) = {rng.choice([n(rng), x(rng), 'NONE'])}",
        lambda: f"ZERO ({rng.choice(['POSITION', 'SYSTEM', 'DATA', 'EQUILIB'])}) = "
                f"{x(rng)}, {x(rng)}",
        lambda: f"VALUE ({n(rng)}) = {_expr(rng)}",
        lambda: f"RECALL INPUT = {rng.choice(FILES)}",
        lambda: "RECALL INPUT",
        lambda: f"PRINT ON = {rng.choice(FILES)}",
        lambda: f"STORE INPUT = {rng.choice(FILES)}",
        lambda: "PRINT OFF",
        lambda: "PRINT INPUT",
        lambda: rng.choice(["EXECUTE", "EXECUTE HOLD", "END", "RETURN", "RESET", "CLEAR"]),
        lambda: f"{rng.choice(['LIST', 'PRINT', 'STORE', 'PLOT'])} "
                f"{rng.choice(['POSITION', 'VELOCITY', 'ACCEL', 'VALUE', 'HEADING'])} "
                f"({n(rng)}, {n(rng)})",
        lambda: f"{rng.choice(['LIST', 'PRINT', 'STORE', 'PLOT'])} POSITION (ALL)",
        lambda: rng.choice(["DRAW", "ANIMATE", "SHOW RED = ALL", f"AXES 0.5 = {n(rng)}",
                            "ERASE", "DEVICE GRAPHIC", "ZOOM 2"]),
        lambda: f"DATA POINT ({n(rng)}, ABS) = {x(rng)}, {x(rng)}, {x(rng)}",
        lambda: f"POINT ({n(rng)}) = {n(rng)}, {n(rng)}",
        lambda: f"DATA ZPIN ({n(rng)}) = {x(rng)},{x(rng)},0; {x(rng)},{x(rng)},0; 1,0,0",
        lambda: f"DATA LINK ({n(rng)}, {n(rng)}) = {x(rng)},0,0; 0,0,{x(rng)}; 1,{x(rng)},0",
        lambda: f"{rng.choice(['ZPIN', 'REVOLUTE', 'XSLIDE', 'SPHERE', 'UJOINT', 'GEAR'])} "
                f"({n(rng)}, {n(rng)}) = {n(rng)}",
        lambda: f"DATA GEAR ({n(rng)}) = {x(rng)}, {x(rng)}",
        lambda: f"DATA RACK ({n(rng)}) = {x(rng)}",
        lambda: f"DATA VIEW = {x(rng)}, {x(rng)}, {x(rng)}; {x(rng)}, {x(rng)}, {x(rng)}",
        lambda: f"TITLE = {rng.choice(['X', 'Y' * 90])}{rng.choice(CONTROL_CHARS)}Z",
        lambda: "FIND EQUILIB" if rng.random() < 0.5 else "FIND DYNAMICS",
        lambda: "PRINT FREQUENCY",
        lambda: f"{rng.choice(['PRINT', 'STORE'])} DYNAMICS "
                f"({rng.choice(['FORCE', 'MOTION', 'X'])}, {n(rng)}, {x(rng)}) = "
                f"{rng.choice(['POSITION', 'VELOCITY', 'ACCEL', 'Q'])}, {n(rng)}; "
                f"{rng.choice(['POSITION', 'ACCEL'])}, {n(rng)}",
        lambda: f"{rng.choice(['LIST', 'PLOT'])} DYNAMICS ({x(rng)}, {x(rng)}, {x(rng)} "
                f"{rng.choice(['/', ';'])} {rng.choice(['FORCE', 'MOTION'])}, {n(rng)}, "
                f"{x(rng)}) = {rng.choice(['POSITION', 'VELOCITY'])}, {n(rng)}",
        lambda: f"DELETE {rng.choice(['INPUT ALL', 'POINT (P)', 'JOINT (A)', 'EQUILIB'])}",
        lambda: f"UNIT (MASS) = {x(rng)}",
        lambda: f"SOLID READ (S1) = {rng.choice(FILES)}",
        lambda: "REMARK " + "".join(rng.choice(CONTROL_CHARS) for _ in range(3)),
        lambda: "DATA ZPIN (A) = 1,2,3; 4,5,6 $\n ; 7,8,9",
        lambda: x(rng) + ", " + x(rng),
    ]
    return rng.choice(forms)()


_NUMBER = re.compile(r"(?<![A-Za-z0-9_.])[-+]?\d+\.?\d*(?:[eE][-+]?\d+)?")


def _mutate(rng: random.Random, lines: list[str], notes: list[str]) -> list[str]:
    """One mutation of the deck's lines."""
    k = rng.randint(0, 9)
    i = rng.randrange(len(lines)) if lines else 0
    if k <= 2 and lines:  # a number replaced
        nums = list(_NUMBER.finditer(lines[i]))
        if nums:
            m = rng.choice(nums)
            new = _num(rng)
            lines[i] = lines[i][:m.start()] + new + lines[i][m.end():]
            notes.append(f"number at line {i + 1} -> {new}")
            return lines
    if k <= 5:  # a generated statement inserted
        st = _statement(rng)
        lines.insert(i, st)
        notes.append(f"insert at line {i + 1}: {st[:40]!r}")
    elif k == 6 and lines:
        notes.append(f"delete line {i + 1}")
        del lines[i]
    elif k == 7 and lines:
        notes.append(f"repeat line {i + 1}")
        lines.insert(i, lines[i])
    elif k == 8 and len(lines) > 1:
        j = rng.randrange(len(lines))
        lines[i], lines[j] = lines[j], lines[i]
        notes.append(f"swap lines {i + 1}, {j + 1}")
    elif lines:  # characters
        pos = rng.randint(0, len(lines[i]))
        ch = rng.choice([*CONTROL_CHARS, "$", "$$", ",,", "(", ")", "=", "'", "\""])
        lines[i] = lines[i][:pos] + ch + lines[i][pos:]
        notes.append(f"char {ch!r} at line {i + 1}")
    return lines


def _encode(rng: random.Random, text: str, notes: list[str]) -> bytes:
    r = rng.random()
    if r < 0.02:
        notes.append("utf-16")
        return text.encode("utf-16")
    if r < 0.05:
        notes.append("bom")
        return b"\xef\xbb\xbf" + text.encode("utf-8")
    if r < 0.07:
        notes.append("latin-1")
        return text.encode("latin-1", errors="replace")
    if r < 0.09:
        data = text.encode("utf-8")
        cut = rng.randint(0, len(data))
        notes.append(f"truncated at byte {cut}")
        return data[:cut]
    if r < 0.10:
        notes.append("binary junk")
        return bytes(rng.randrange(256) for _ in range(rng.randint(0, 400)))
    return text.encode("utf-8")


def _argv(rng: random.Random, deck: str) -> list[str]:
    r = rng.random()
    if r < 0.15:
        return ["check", deck]
    argv = ["run", deck]
    if rng.random() < 0.5:
        argv.append("--quiet")
    if rng.random() < 0.5:
        argv += ["--json", rng.choice(["{out}/r.json"] * 30 + ["{out}/adir", "{out}"])]
    if rng.random() < 0.3:
        argv += ["--csv", rng.choice(["{out}/csv"] * 30 + ["{out}/r.txt", "{deck}"])]
    if rng.random() < 0.3:
        argv += ["--out", rng.choice(["{out}/pics"] * 30 + ["{out}/r.txt", "{deck}"])]
    if rng.random() < 0.1:
        argv.append("--overwrite")
    if rng.random() < 0.05:
        argv += ["--allow-read", "{outside}"]
    return argv


def _before_execute(lines: list[str]) -> int:
    """The index of the first EXECUTE line (the end when there is none)."""
    for i, ln in enumerate(lines):
        if ln.strip().upper().startswith("EXEC"):
            return i
    return len(lines)


def make_case(seed: int, index: int) -> Case:
    """The case ``index`` of the run with ``seed`` (the same arguments give the same case)."""
    rng = random.Random(f"{seed}:{index}")
    notes: list[str] = []
    src = rng.choice(SOURCES)
    notes.append(src.name)
    text = src.read_text(errors="replace")
    _DECK_NAMES[:] = sorted(set(_JOINT_NAME.findall(text)))
    _DRIVEN[:] = sorted(set(re.findall(r"DATA (?:POSITION|MOTION) \((\w+)\)", text)))
    r = rng.random()
    if r < 0.45 and src.parent.name == "fuzz":  # the reproducers are broken already
        r = 0.5
    if r < 0.1:
        lines = [_statement(rng) for _ in range(rng.randint(1, 12))]
        notes.append("generated")
    elif r < 0.45:  # the deck kept whole, but for statements at the edge of the limits
        lines = text.split("\n")
        at = _before_execute(lines)
        new = _edge_statements(rng)
        lines[at:at] = new
        notes.append(f"edge at line {at + 1}: {' / '.join(new)[:80]!r}")
    else:
        lines = text.split("\n")
        for _ in range(rng.choice([1, 1, 1, 2, 3, 5])):
            lines = _mutate(rng, lines, notes)
    files = dict(SUPPORT)
    files["deck.imp"] = _encode(rng, "\n".join(lines), notes)
    files["other.imp"] = "\n".join(_statement(rng) for _ in range(3)).encode()
    files["self.imp"] = b"RECALL INPUT = self.imp\nRECALL INPUT = other.imp\n"
    files["sub/inner.imp"] = b"RECALL INPUT = ../other.imp\nRETURN\n"
    files["junk.bin"] = bytes(rng.randrange(256) for _ in range(300))
    files["big.tab"] = ("0\n1\n" + "\n".join(str(k % 7) for k in range(12000))).encode()
    return Case(index, files, "deck.imp", _argv(rng, "deck.imp"), notes)


# --------------------------------------------------------------------------- running


class CaseTimeout(BaseException):  # not an Exception: nothing may catch it
    """Raised by the alarm when a case runs past its time limit."""


@contextlib.contextmanager
def _time_limit(seconds: float) -> Iterator[None]:
    """At most ``seconds`` of this process's CPU time outside numba's compiles: a hang
    check that neither a busy machine (CPU, not wall time) nor a cold kernel cache
    (the timer stops while a kernel compiles) can trip."""
    def alarm(signum: int, frame: object) -> None:
        raise CaseTimeout()

    old = signal.signal(signal.SIGPROF, alarm)
    signal.setitimer(signal.ITIMER_PROF, seconds)
    paused: list[float] = []  # the time left when the outermost compile began

    class Pause(numba_event.Listener):
        def on_start(self, event: object) -> None:
            left = signal.setitimer(signal.ITIMER_PROF, 0)[0]
            paused.append(left)

        def on_end(self, event: object) -> None:
            left = paused.pop() if paused else 0.0
            if not paused and left > 0:
                signal.setitimer(signal.ITIMER_PROF, left)

    try:
        with numba_event.install_listener("numba:compile", Pause()):
            yield
    finally:
        signal.setitimer(signal.ITIMER_PROF, 0)
        signal.signal(signal.SIGPROF, old)


@dataclass
class Outcome:
    """What one case did."""

    status: int | None
    stdout: str
    stderr: str
    seconds: float
    failures: list[str]


def _snapshot(root: Path) -> dict[str, bytes]:
    out: dict[str, bytes] = {}
    for dirpath, _dirs, names in os.walk(root):
        for nm in names:
            p = Path(dirpath) / nm
            if p.is_symlink() or not p.is_file():
                out[str(p.relative_to(root))] = b"<special>"
                continue
            out[str(p.relative_to(root))] = p.read_bytes()
    return out


def _layout(case: Case, root: Path) -> dict[str, str]:
    """Write the case's folders under ``root``; the placeholders of its command line."""
    deck_dir, out, outside, cwd = (root / "deck", root / "out", root / "outside", root / "cwd")
    for d in (deck_dir, out, outside, cwd, out / "adir", deck_dir / "adir"):
        d.mkdir(parents=True, exist_ok=True)
    for name, data in case.files.items():
        p = deck_dir / name
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_bytes(data)
    (out / "r.txt").write_text("precious\n")
    (outside / "victim.txt").write_text("precious\n")
    (deck_dir / "out.txt").write_text("precious\n")
    with contextlib.suppress(OSError):
        os.symlink("loop", deck_dir / "loop")
    return {"out": str(out), "deck": str(deck_dir / case.deck), "outside": str(outside)}


def run_case(case: Case, root: Path, time_limit: float = 30.0) -> Outcome:
    """Run ``case`` in the scratch folder ``root`` (created) and check it."""
    from openimp import cli

    places = _layout(case, root)
    argv = [a.format(**places) if "{" in a else a for a in case.argv]
    argv = [places["deck"] if a == case.deck else a for a in argv]
    before = _snapshot(root)
    out, err = io.StringIO(), io.StringIO()
    status: int | None = None
    failures: list[str] = []
    here = os.getcwd()
    t0 = time.monotonic()
    try:
        os.chdir(root / "cwd")
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err), \
                _time_limit(time_limit):
            status = cli.main(argv)
    except CaseTimeout:
        failures.append("hang")
    except MemoryError:
        failures.append("memory")
    except BaseException as exc:  # anything escaping main() is a failure of its own
        err.write(f"\nTraceback: {type(exc).__name__}: {exc}\n")
    finally:
        os.chdir(here)
    seconds = time.monotonic() - t0
    failures += failures_of(status, out.getvalue(), err.getvalue(), places["deck"])
    failures += _changes(before, _snapshot(root), argv, root)
    return Outcome(status, out.getvalue(), err.getvalue(), seconds, sorted(set(failures)))


_LOCATED = re.compile(r"(^|[\s(])[^\s:()]+:\d+: ")


def _located(line: str, deck: str) -> bool:
    """True when a stderr line says where its problem is."""
    if _LOCATED.search(line):
        return True
    if line.startswith(deck + ": ") or line.startswith("openimp: error: --"):
        return True
    return bool(re.match(r"openimp: (note|error|interrupted)[^:]*: \S+", line)) and (
        deck in line or "--" in line)


def failures_of(status: int | None, stdout: str, stderr: str, deck: str) -> list[str]:
    """The failure classes shown by a case's exit status and output."""
    out: list[str] = []
    both = stdout + stderr
    if status is not None and status not in (0, 1, 2, 130):
        out.append("status")
    if "internal error" in both or "please report it" in both:
        out.append("internal")
    if "Traceback" in both:
        out.append("traceback")
    if "MemoryError" in both:
        out.append("memory")
    if re.search(r"\w+Warning\b", stderr):
        out.append("warning")
    if status in (0, 1, 2, 130):  # every error and note on stderr says where
        for line in stderr.splitlines():
            if line.strip() and not _located(line, deck):
                out.append("no_location")
                break
    if status == 0 and _undefined_position(stdout):
        out.append("nonfinite")
    return out


def _undefined_position(stdout: str) -> bool:
    """A listing of positions with an undefined (``????``) entry."""
    section = ""
    for line in stdout.splitlines():
        text = line.strip()
        if text.startswith("Listing of "):
            section = text
        elif section.startswith("Listing of position") and "????" in text:
            return True
    return False


#: seconds after a SIGINT within which a run must end (and after which it is killed)
SIGINT_SLOW, SIGINT_KILL = 1.0, 10.0


def run_case_sigint(case: Case, root: Path, delay: float, time_limit: float = 30.0
                    ) -> tuple[Outcome, float | None]:
    """Run ``case`` as a real ``openimp`` process and send it SIGINT after ``delay``
    seconds (if it is still running); the outcome and how long it took to end after the
    SIGINT (None when it ended first)."""
    import subprocess

    places = _layout(case, root)
    argv = [a.format(**places) if "{" in a else a for a in case.argv]
    argv = [places["deck"] if a == case.deck else a for a in argv]
    before = _snapshot(root)
    env = dict(os.environ, OPENIMP_NO_WARMUP="1")
    t0 = time.monotonic()
    p = subprocess.Popen([sys.executable, "-m", "openimp.cli", *argv], cwd=root / "cwd",
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    failures: list[str] = []
    latency: float | None = None
    try:
        out_b, err_b = p.communicate(timeout=delay)
    except subprocess.TimeoutExpired:
        p.send_signal(signal.SIGINT)
        t_int = time.monotonic()
        try:
            out_b, err_b = p.communicate(timeout=SIGINT_KILL)
            latency = time.monotonic() - t_int
            if latency > SIGINT_SLOW:
                failures.append("sigint_slow")
        except subprocess.TimeoutExpired:
            p.kill()
            out_b, err_b = p.communicate()
            failures.append("sigint_hang")
            latency = SIGINT_KILL
    out, err = (b.decode("utf-8", "replace") for b in (out_b, err_b))
    status = p.returncode
    failures += failures_of(status, out, err, places["deck"])
    failures += _changes(before, _snapshot(root), argv, root)
    if latency is not None and status == 130 and "--json" in argv and "Listing of" in out:
        target = Path(argv[argv.index("--json") + 1])
        try:
            json.loads(target.read_text())
        except (OSError, ValueError):
            failures.append("lost")
    return Outcome(status, out, err, time.monotonic() - t0, sorted(set(failures))), latency


_TEMP = re.compile(r"^\..+\.[0-9a-f]{8}(\.\w+)?$")  # openimp.files' temporary names


def _changes(before: dict[str, bytes], after: dict[str, bytes], argv: list[str],
             root: Path) -> list[str]:
    """``outside`` when a file appeared outside deck/ and out/, a file that existed
    before changed (the --json and --csv targets excepted, and with --overwrite the
    files of deck/ and out/), or a temporary file was left."""
    mine: list[str] = []
    for opt in ("--json", "--csv"):
        if opt in argv:
            mine.append(os.path.relpath(argv[argv.index(opt) + 1], root))
    for name, data in after.items():
        parts = Path(name).parts
        if _TEMP.match(parts[-1]):
            return ["outside"]
        if name not in before:
            if parts[0] not in ("deck", "out"):
                return ["outside"]
        elif before[name] != data:
            if any(name == m or name.startswith(m + os.sep) for m in mine):
                continue
            if "--overwrite" in argv and parts[0] in ("deck", "out"):
                continue
            return ["outside"]
    return []


# --------------------------------------------------------------------------- long runs


#: decks whose runs compile every kernel the generated cases use
WARM_DECKS = ("examples/fourbar.imp", "examples/cam.imp", "examples/rsur.imp",
              "tests/decks/run_structure.imp", "tests/decks/run_gears.imp",
              "examples/engine.imp", "examples/counterbalanced_arm.imp", "examples/pendulum.imp",
              "examples/fourbar_released.imp")


def warm_up() -> None:
    """Run a few decks so that the kernels are compiled before time limits apply."""
    from openimp import cli

    with tempfile.TemporaryDirectory() as tmp, contextlib.redirect_stdout(io.StringIO()), \
            contextlib.redirect_stderr(io.StringIO()):
        shutil.copy(ROOT / "examples" / "cam_profile.tab", tmp)
        for rel in WARM_DECKS:
            shutil.copy(ROOT / rel, tmp)
            cli.main(["run", os.path.join(tmp, os.path.basename(rel)), "--quiet"])


def _worker(seed: int, indices: list[int], time_limit: float, memory: int, conn: object,
            sigint_every: int = 0) -> None:
    """Run cases in a child process; send one result per case through ``conn`` (every
    ``sigint_every``-th case as a real process interrupted at a random moment)."""
    resource.setrlimit(resource.RLIMIT_AS, (memory, memory))
    os.environ["OPENIMP_NO_WARMUP"] = "1"
    warm_up()
    for k in indices:
        case = make_case(seed, k)
        latency: float | None = None
        with tempfile.TemporaryDirectory(prefix="fuzz") as tmp:
            try:
                if sigint_every and k % sigint_every == 0:
                    delay = random.Random(f"sigint:{seed}:{k}").uniform(0.3, 4.0)
                    res, latency = run_case_sigint(case, Path(tmp), delay, time_limit)
                else:
                    res = run_case(case, Path(tmp), time_limit)
                msg = (k, res.status, res.failures, round(res.seconds, 3),
                       res.stderr[-2000:] if res.failures else "", latency)
            except MemoryError:
                msg = (k, None, ["memory"], 0.0, "", None)
        conn.send(msg)  # type: ignore[attr-defined]


class _Worker:
    """A child process running a list of cases, and the time of its last result."""

    def __init__(self, ctx: object, seed: int, chunk: list[int], time_limit: float,
                 memory: int, sigint_every: int = 0) -> None:
        self.chunk = list(chunk)
        self.conn, child = ctx.Pipe(duplex=False)  # type: ignore[attr-defined]
        self.proc = ctx.Process(target=_worker,  # type: ignore[attr-defined]
                                args=(seed, self.chunk, time_limit, memory, child,
                                      sigint_every),
                                daemon=True)
        self.proc.start()
        child.close()
        self.last = time.monotonic()

    def result(self) -> tuple | None:  # type: ignore[type-arg]
        """The next result if one is ready (None otherwise; raises EOFError if it died)."""
        if not self.conn.poll(0.05):
            return None
        msg = self.conn.recv()
        self.last = time.monotonic()
        self.chunk.remove(msg[0])
        return msg  # type: ignore[no-any-return]

    def stop(self) -> None:
        self.proc.kill()
        self.proc.join()


def long_run(count: int, seed: int, workers: int, time_limit: float, hard_timeout: float,
             memory: int, save: Path | None, start: int = 0, sigint_every: int = 0
             ) -> Counter[str]:
    """Run ``count`` cases; print and return the count of each failure class."""
    import multiprocessing as mp

    ctx = mp.get_context("fork")
    todo = list(range(start, start + count))
    pool = [_Worker(ctx, seed, todo[i::workers], time_limit, memory, sigint_every)
            for i in range(workers) if todo[i::workers]]
    counts: Counter[str] = Counter()
    statuses: Counter[str] = Counter()
    latencies: list[float] = []
    t0 = time.monotonic()
    done = 0

    def record(k: int, status: object, fails: list[str], tail: str,
               latency: float | None = None) -> None:
        nonlocal done
        done += 1
        statuses[str(status)] += 1
        counts.update(fails)
        if latency is not None:
            latencies.append(latency)
        if fails and save is not None:
            _save(save, seed, k, fails, tail)
        if done % 500 == 0:
            print(f"{done}/{count} cases, {time.monotonic() - t0:.0f} s, failures "
                  f"{dict(counts)}", flush=True)

    while pool:
        for w in list(pool):
            try:
                msg = w.result()
                dead = False
            except EOFError:  # the worker died (memory limit, crash): blame its case
                msg, dead = None, True
            if msg is not None:
                k, status, fails, _secs, tail, latency = msg
                record(k, status, fails, tail, latency)
            elif dead or time.monotonic() - w.last > hard_timeout:
                w.stop()
                pool.remove(w)
                if w.chunk:
                    k = w.chunk.pop(0)
                    record(k, None, ["memory" if dead else "hang"],
                           f"worker exit code {w.proc.exitcode}")
                if w.chunk:
                    pool.append(_Worker(ctx, seed, w.chunk, time_limit, memory, sigint_every))
                continue
            if not w.chunk:
                w.proc.join()
                pool.remove(w)
    secs = time.monotonic() - t0
    print(f"{count} cases in {secs:.0f} s; exit statuses {dict(statuses)}")
    if latencies:
        lat = np.sort(np.array(latencies))
        print(f"SIGINT sent to {len(lat)} running cases: ended after median {np.median(lat):.3f} "
              f"s, 99th percentile {np.quantile(lat, 0.99):.3f} s, largest {lat[-1]:.3f} s")
    print("failures: " + ", ".join(f"{c} {counts.get(c, 0)}" for c in CLASSES))
    return counts


def _save(folder: Path, seed: int, k: int, fails: list[str], tail: str) -> None:
    case = make_case(seed, k)
    d = folder / f"{seed}-{k:06d}"
    d.mkdir(parents=True, exist_ok=True)
    for name, data in case.files.items():
        p = d / name
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_bytes(data)
    (d / "case.json").write_text(json.dumps({"failures": fails, "argv": case.argv,
                                             "notes": case.notes, "stderr": tail}, indent=1))


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m tests.fuzz_decks", description=__doc__.split(
        "\n\n")[0])
    p.add_argument("--count", type=int, default=1000)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--start", type=int, default=0, help="index of the first case")
    p.add_argument("--workers", type=int, default=1)
    p.add_argument("--time-limit", type=float, default=60.0, help="seconds per case (soft)")
    p.add_argument("--hard-timeout", type=float, default=180.0,
                   help="seconds without a result before a worker is killed")
    p.add_argument("--memory", type=int, default=4096, help="MB of address space per worker")
    p.add_argument("--save", type=Path, help="folder for the decks of failing cases")
    p.add_argument("--sigint-every", type=int, default=0,
                   help="run every N-th case as a process interrupted at a random moment")
    p.add_argument("--extra", type=Path, action="append", default=[],
                   help="a folder of more decks to mutate (*.imp, searched recursively)")
    a = p.parse_args(argv)
    for folder in a.extra:
        SOURCES.extend(sorted(folder.rglob("*.imp")))
    counts = long_run(a.count, a.seed, a.workers, a.time_limit, a.hard_timeout,
                      a.memory << 20, a.save, a.start, a.sigint_every)
    return 1 if sum(counts.values()) else 0


if __name__ == "__main__":
    sys.exit(main())
