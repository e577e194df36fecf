"""Hostile input: the reproducers of the fuzzing campaign, and a bounded fuzz run.

``tests/decks/fuzz/`` holds the minimal reproducers of every failure the
fuzzing of the ``openimp`` command found (each once reached the "internal
error" handler, hung, exhausted memory, printed raw numpy warnings, wrote
outside its folder or gave unlocated messages).  Each must now end in exit
0, 1 or 2 with a located message.  :func:`test_generated_decks` runs a few
hundred cases of the seeded generator of ``tests/fuzz_decks.py`` in-process
(``python -m tests.fuzz_decks --count 20000`` is the long local run).
"""

from __future__ import annotations

import contextlib
import io
import os
import re
import shutil
import time
from pathlib import Path

import pytest

import fuzz_decks
from helpers.decks import CPU_LIMIT
from openimp import cli

FUZZ = Path(__file__).parent / "decks" / "fuzz"

# deck -> (exit status, words of the message, its location: "line" for file:line:, "file"
# for the deck's name alone)
REPRODUCERS = {
    "blank.imp": (2, "the deck holds no statement", "file"),
    "empty.imp": (2, "the deck holds no statement", "file"),
    "comments.imp": (2, "holds only REMARK and TITLE statements", "file"),
    "only_end.imp": (2, "holds only REMARK and TITLE statements before END", "file"),
    "only_execute.imp": (2, "EXECUTE: the model has no joints", "line"),
    "bom.imp": (0, "", ""),
    "utf16.imp": (2, "the file is UTF-16 text; save it as UTF-8", "file"),
    "printon_bashrc.imp": (2, "PRINT ON statement: the file name '../home/.bashrc' leaves the "
                              "output folder", "line"),
    "r_gear_ratio.imp": (2, "DATA GEAR statement: the ratio 1e308 is beyond", "line"),
    "r_pos_1e12.imp": (2, "1000000000000 steps are more than 100000 (limit MAX_STEPS)", "line"),
    "r_pos_incinf.imp": (2, "the increment 1E308 is beyond", "line"),
    "r_pos_int64.imp": (2, "9223372036854775808 steps are more than 100000", "line"),
    "r_recall_fanout.imp": (2, "recalls itself", "line"),
    "r_return.imp": (0, "", ""),
    "r_table_devzero.imp": (2, "TABLE: the file '/dev/zero' is outside the folders a deck may "
                               "read", "line"),
    "r_time_denormal.imp": (2, "gives inf output steps, more than 100000 (limit MAX_STEPS)",
                            "line"),
    "r_time_huge.imp": (2, "the final time 1e300 is beyond", "line"),
    "r_warn_dot.imp": (2, "the point P2 x -1e300 is beyond", "line"),
    "r_warn_point.imp": (2, "the coordinates y 1e308 is beyond", "line"),
    "r_zero_default_iter.imp": (2, "ZERO POSITION statement: the tolerance 1E-300 is below "
                                   "1E-14 (limit MIN_TOLERANCE)", "line"),
    "r_zero_hang.imp": (2, "the tolerance 1E-300 is below", "line"),
}


@pytest.fixture(scope="module", autouse=True)
def _warm() -> None:
    """Compile the kernels once, before any case is timed."""
    fuzz_decks.warm_up()


def run_cli(*argv: str | Path) -> tuple[int, str, str]:
    """``openimp`` in-process: exit status, stdout, stderr."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        status = cli.main([str(a) for a in argv])
    return status, out.getvalue(), err.getvalue()


def test_every_reproducer_is_listed() -> None:
    assert sorted(REPRODUCERS) == sorted(p.name for p in FUZZ.glob("*.imp"))


@pytest.mark.parametrize("name", sorted(REPRODUCERS))
def test_reproducer(tmp_path: Path, name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("OPENIMP_NO_WARMUP", "1")
    status, words, where = REPRODUCERS[name]
    deck_dir = tmp_path / "decks"
    shutil.copytree(FUZZ, deck_dir)
    home = tmp_path / "home"
    home.mkdir()
    (home / ".bashrc").write_text("# precious\n")
    monkeypatch.chdir(deck_dir)
    deck = deck_dir / name
    t0 = time.process_time()
    got, out, err = run_cli("run", deck)
    # no endless loop: CPU seconds, which a busy machine does not inflate (compiles included)
    assert time.process_time() - t0 < CPU_LIMIT
    assert got == status, err
    assert fuzz_decks.failures_of(got, out, err, str(deck)) == [], err
    assert words in err
    if where == "line":
        assert re.match(rf"{re.escape(str(deck_dir))}/\S+:\d+: ", err), err
    elif where == "file":
        assert err.startswith(f"{deck}: "), err
    assert (home / ".bashrc").read_text() == "# precious\n"
    assert not (tmp_path / "home" / ".bashrc.tmp").exists()


def test_return_in_a_value_stops_the_run_with_a_message(tmp_path: Path) -> None:
    shutil.copy(FUZZ / "r_return.imp", tmp_path)
    status, out, err = run_cli("run", tmp_path / "r_return.imp")
    assert status == 0, err
    assert (f"*** {tmp_path / 'r_return.imp'}:2: VALUE V (DATA MOTION of joint A) evaluated "
            "RETURN at time 0.750000: the run stops there (RETURN in a VALUE); the 3 "
            "position(s) before it are listed ***") in out
    rows = out.split("Listing of position of joint A")[1].strip().splitlines()[1:]
    assert [r.split()[0] for r in rows] == ["0.000000", "0.250000", "0.500000"]


def test_return_in_a_listed_value_stops_the_run_too(tmp_path: Path) -> None:
    deck = tmp_path / "v.imp"
    deck.write_text("ZPIN (BASE, CRANK) = A\nVALUE (V) = IF(T-2: T, T, RETURN)\n"
                    "DATA POSITION (A) = 0, 10, 5\nLIST POSITION (A)\nLIST VALUE (V)\n"
                    "EXECUTE\nEND\n")
    status, out, err = run_cli("run", deck)
    assert status == 0, err
    assert (f"*** {deck}:2: VALUE V evaluated RETURN at time 3.000000: the run stops there "
            "(RETURN in a VALUE); the 3 position(s) before it are listed ***") in out
    rows = out.split("Listing of position of joint A")[1].split("Listing")[0].split("\n")
    # no DATA TIME: the first column numbers the steps
    assert [r.split()[0] for r in rows[2:] if r.strip()] == ["0", "1", "2"]


def test_end_in_a_value_also_ends_the_deck(tmp_path: Path) -> None:
    deck = tmp_path / "end.imp"
    deck.write_text((FUZZ / "r_return.imp").read_text().replace("RETURN", "END")
                    .replace("EXECUTE\nEND", "EXECUTE\nEXECUTE\nEND"))
    status, out, err = run_cli("run", deck, "--json", tmp_path / "r.json")
    assert status == 0, err
    assert "evaluated END at time 0.750000: the run stops there and no further EXECUTE " \
           "runs" in out
    assert out.count("Kinematic Mode") == 1  # the second EXECUTE does not run


def test_generated_decks(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """300 generated cases, each within 30 s of CPU outside compiles, well under a minute
    of CPU in all once the kernels are compiled (CPU time: a busy machine cannot trip it)."""
    monkeypatch.setenv("OPENIMP_NO_WARMUP", "1")
    t0 = time.process_time()
    bad = []
    statuses: dict[int | None, int] = {}
    for k in range(300):
        case = fuzz_decks.make_case(20240611, k)
        root = tmp_path / f"c{k}"
        res = fuzz_decks.run_case(case, root, time_limit=30.0)
        statuses[res.status] = statuses.get(res.status, 0) + 1
        if res.failures:
            bad.append((case.describe(), res.failures, res.stderr[-600:]))
        shutil.rmtree(root, ignore_errors=True)
    assert bad == []
    assert time.process_time() - t0 < CPU_LIMIT
    # the generator reaches the analyses, not only the input checks
    assert statuses.get(0, 0) >= 30 and statuses.get(2, 0) >= 30
    assert os.listdir(tmp_path) == []
