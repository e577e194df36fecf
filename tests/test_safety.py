"""Safe files and hardened input: where a deck may read and write, the limits, Ctrl-C.

Rules (docs/imp.md, "Files" and "Limits"): the deck's files (STORE, PRINT ON,
STORE INPUT, pictures) go to ``--out`` or the deck's folder and never replace
a file the run did not create without ``--overwrite``; RECALL INPUT, TABLE and
SOLID READ read regular files inside the deck's folder (or ``--allow-read``
folders); files are written atomically with ``open()``'s permissions; every
limit is an input error that names it; Ctrl-C keeps what was computed.
"""

from __future__ import annotations

import contextlib
import io
import json
import math
import os
import signal
import stat
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from helpers.decks import cpu_limit
from openimp import cli, files, limits
from openimp.errors import InputError, OutputError
from openimp.imp import expr as expr_mod
from openimp.imp import parser as parser_mod
from openimp.imp.deck import load
from openimp.imp.interp import DeckError
from openimp.imp.run import output as output_mod
from openimp.imp.run import prepare as prepare_mod

DECKS = Path(__file__).parent / "decks"
FOURBAR = (DECKS / "run_fourbar.imp").read_text()
HEAD = FOURBAR.split("DATA POSITION")[0]
HEAD_LINES = HEAD.count("\n")


@pytest.fixture(autouse=True)
def _no_helper(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("OPENIMP_NO_WARMUP", "1")


def run_cli(*argv: str | Path) -> tuple[int, str, str]:
    """``openimp`` in-process: exit status, stdout, stderr."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        status = cli.main([str(a) for a in argv])
    return status, out.getvalue(), err.getvalue()


def deck(tmp_path: Path, body: str, name: str = "deck.imp") -> Path:
    p = tmp_path / name
    p.write_text(HEAD + body)
    return p


def no_temp_files(folder: Path) -> None:
    left = [p for p in folder.rglob(".*") if p.is_file()]
    assert left == [], left


# --------------------------------------------------------------------------- writing


@pytest.mark.parametrize("umask", [0o022, 0o077, 0o002])
def test_atomic_write_respects_the_umask(tmp_path: Path, umask: int) -> None:
    old = os.umask(umask)
    try:
        p = files.atomic_write(tmp_path / "sub" / "a.txt", "text\n")
        q = tmp_path / "plain.txt"
        with open(q, "w") as f:
            f.write("x")
    finally:
        os.umask(old)
    assert p.read_text() == "text\n"
    assert stat.S_IMODE(p.stat().st_mode) == stat.S_IMODE(q.stat().st_mode) == 0o666 & ~umask
    no_temp_files(tmp_path)


def test_atomic_write_leaves_nothing_behind(tmp_path: Path) -> None:
    target = tmp_path / "t.bin"
    target.write_bytes(b"old")

    def fail(tmp: str) -> None:
        Path(tmp).write_bytes(b"half")
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        files.atomic_write_with(target, fail)
    assert target.read_bytes() == b"old"
    no_temp_files(tmp_path)
    (tmp_path / "adir").mkdir()
    with pytest.raises(OutputError) as info:
        files.atomic_write(tmp_path / "adir", "x")
    assert str(info.value) == f"the file '{tmp_path / 'adir'}' cannot be written (it is a " \
                              "directory)"
    assert info.value.path == str(tmp_path / "adir")
    no_temp_files(tmp_path)


def test_json_and_csv_are_written_with_normal_permissions(tmp_path: Path) -> None:
    d = deck(tmp_path, "DATA POSITION (A) = 0, 30, 2\nLIST POSITION (A)\nEXECUTE\nEND\n")
    old = os.umask(0o022)
    try:
        status, _, err = run_cli("run", d, "--quiet", "--json", tmp_path / "r.json",
                                 "--csv", tmp_path / "csv")
    finally:
        os.umask(old)
    assert status == 0, err
    for p in [tmp_path / "r.json", *(tmp_path / "csv").iterdir()]:
        assert stat.S_IMODE(p.stat().st_mode) == 0o644, p
    no_temp_files(tmp_path)


def test_a_failing_output_loses_nothing_else(tmp_path: Path) -> None:
    d = deck(tmp_path, "DATA POSITION (A) = 0, 30, 2\nLIST POSITION (A)\nEXECUTE\nEND\n")
    blocker = tmp_path / "file.txt"
    blocker.write_text("not a folder\n")
    # the JSON cannot be written: the CSV files still are, exit 1, the path is named
    status, out, err = run_cli("run", d, "--json", blocker / "r.json", "--csv", tmp_path / "c")
    assert status == 1
    assert "Listing of position of joint A" in out
    assert err.strip() == (f"openimp: error: --json: the file '{blocker / 'r.json'}' cannot be "
                           f"written ('{blocker}' is a file, not a folder); the listings above "
                           "hold the results")
    assert (tmp_path / "c" / "run1_list_position_joint_a.csv").exists()
    # the CSV files cannot be written: the JSON still is
    status, _, err = run_cli("run", d, "--quiet", "--json", tmp_path / "r.json",
                             "--csv", blocker / "c")
    assert status == 1 and f"openimp: error: --csv: the file '{blocker / 'c'}" in err
    assert json.loads((tmp_path / "r.json").read_text())["runs"][0]["tables"]
    no_temp_files(tmp_path)


@pytest.mark.parametrize("option,target,words", [
    ("--json", "adir", "is a directory; give the name of a file"),
    ("--csv", "deck.imp", "is not a directory; give a folder name"),
    ("--out", "deck.imp", "is not a directory; give a folder name"),
])
def test_unusable_targets_are_refused_before_running(tmp_path: Path, option: str, target: str,
                                                      words: str) -> None:
    d = deck(tmp_path, "DATA POSITION (A) = 0, 30, 2\nEXECUTE\n")
    (tmp_path / "adir").mkdir()
    status, out, err = run_cli("run", d, option, tmp_path / target)
    assert status == 2 and out == ""
    assert err == f"openimp: error: {option} '{tmp_path / target}' {words}\n"


def test_the_decks_files_go_to_out_or_the_decks_folder(tmp_path: Path) -> None:
    d = deck(tmp_path, "PRINT ON = listing.prt\nSTORE INPUT = sub/saved.imp\n"
             "DATA POSITION (A) = 0, 30, 2\nSTORE POSITION (A)\nEXECUTE\nEND\n")
    status, _, err = run_cli("run", d, "--quiet", "--out", tmp_path / "o")
    assert status == 0, err
    names = sorted(str(p.relative_to(tmp_path / "o")) for p in (tmp_path / "o").rglob("*")
                   if p.is_file())
    assert names == ["deck_store.txt", "listing.prt", "sub/saved.imp"]
    assert "DATA POSITION (A) = 0, 30, 2" in (tmp_path / "o" / "sub" / "saved.imp").read_text()
    assert "Kinematic Mode" in (tmp_path / "o" / "listing.prt").read_text()
    # without --out: the deck's folder, never the current directory
    work = tmp_path / "work"
    work.mkdir()
    here = os.getcwd()
    os.chdir(work)
    try:
        status, _, err = run_cli("run", d, "--quiet")
    finally:
        os.chdir(here)
    assert status == 0, err
    assert os.listdir(work) == []
    assert (tmp_path / "listing.prt").exists() and (tmp_path / "deck_store.txt").exists()


def test_existing_files_are_kept_unless_overwrite(tmp_path: Path) -> None:
    d = deck(tmp_path, "PRINT ON = listing.prt\nDATA POSITION (A) = 0, 30, 2\n"
             "STORE POSITION (A)\nEXECUTE\nEND\n")
    (tmp_path / "listing.prt").write_text("precious\n")
    status, _, err = run_cli("run", d, "--quiet", "--json", tmp_path / "r.json")
    assert status == 1
    assert (tmp_path / "listing.prt").read_text() == "precious\n"
    assert (f"openimp: error: {d}:{HEAD_LINES + 1}: the file '{tmp_path / 'listing.prt'}' "
            "exists and was not written by this run, so it is kept; give --overwrite to "
            "replace it") in err
    assert (tmp_path / "deck_store.txt").exists()  # the other files are written
    assert json.loads((tmp_path / "r.json").read_text())["runs"]
    # a second run: the STORE file of the first is not replaced either
    before = (tmp_path / "deck_store.txt").read_text()
    status, _, err = run_cli("run", d, "--quiet")
    assert status == 1
    assert f"openimp: error: {d}: the file '{tmp_path / 'deck_store.txt'}' exists" in err
    assert (tmp_path / "deck_store.txt").read_text() == before
    # --overwrite replaces both
    status, _, err = run_cli("run", d, "--quiet", "--overwrite")
    assert status == 0, err
    assert "Kinematic Mode" in (tmp_path / "listing.prt").read_text()


def test_a_run_may_replace_its_own_files(tmp_path: Path) -> None:
    folder = files.OutputFolder(tmp_path)
    assert folder.write("a.txt", "one", ("d.imp", 3)) is not None
    assert folder.write("a.txt", "two", ("d.imp", 4)) is not None
    assert (tmp_path / "a.txt").read_text() == "two"
    other = files.OutputFolder(tmp_path)
    assert other.write("a.txt", "three") is None
    assert "exists and was not written by this run" in other.refused[0]


def test_output_names_cannot_leave_the_folder(tmp_path: Path) -> None:
    outside = tmp_path / "outside"
    outside.mkdir()
    (tmp_path / "o").mkdir()
    (tmp_path / "o" / "link").symlink_to(outside)
    folder = files.OutputFolder(tmp_path / "o", overwrite=True)
    for name in ("../x.txt", str(outside / "x.txt"), "a/../../x.txt", "link/x.txt"):
        assert folder.write(name, "x", ("d.imp", 7)) is None, name
    assert len(folder.refused) == 4 and all(r.startswith("d.imp:7: ") for r in folder.refused)
    assert os.listdir(outside) == []


def test_fifos_devices_and_links_are_written_into_not_replaced(tmp_path: Path) -> None:
    """issue 30 N2: --json to a FIFO writes into it (a reader gets the JSON), to a
    character device writes into it (/dev/null; /dev/full fails with its reason and
    stays a device), through a symbolic link replaces the link's target and keeps the
    link; a socket is refused, named."""
    import socket
    import threading

    d = deck(tmp_path, "DATA POSITION (A) = 0, 30, 2\nLIST POSITION (A)\nEXECUTE\nEND\n")
    fifo = tmp_path / "p"
    os.mkfifo(fifo)
    got: list[bytes] = []
    reader = threading.Thread(target=lambda: got.append(fifo.read_bytes()), daemon=True)
    reader.start()
    status, _, err = run_cli("run", d, "--quiet", "--json", fifo)
    reader.join(timeout=300)
    assert status == 0, err
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)
    assert json.loads(got[0])["runs"][0]["tables"]
    target = tmp_path / "target.json"
    target.write_text("old")
    link = tmp_path / "s"
    link.symlink_to(target.name)
    status, _, err = run_cli("run", d, "--quiet", "--json", link)
    assert status == 0, err
    assert link.is_symlink() and json.loads(target.read_text())["runs"]
    status, _, err = run_cli("run", d, "--quiet", "--json", os.devnull)
    assert status == 0, err
    if os.path.exists("/dev/full"):
        status, _, err = run_cli("run", d, "--quiet", "--json", "/dev/full")
        assert status == 1 and "--json: the file '/dev/full' cannot be written (" in err
        assert stat.S_ISCHR(os.lstat("/dev/full").st_mode)
    sock = tmp_path / "sock"
    srv = socket.socket(socket.AF_UNIX)
    try:
        srv.bind(str(sock))
        with pytest.raises(OutputError, match="is a socket, which is not written"):
            files.atomic_write(sock, "x")
    finally:
        srv.close()
    assert stat.S_ISSOCK(os.lstat(sock).st_mode)
    no_temp_files(tmp_path)


def test_outputs_never_replace_the_runs_inputs(tmp_path: Path) -> None:
    """issue 30 N8: even with --overwrite, PRINT ON naming the deck, STORE INPUT naming a
    recalled file and --json naming the deck are refused with the statement's place;
    the inputs stay as they were and the other outputs are written."""
    (tmp_path / "part.imp").write_text("DATA POSITION (A) = 0, 30, 2\n")
    d = deck(tmp_path, "RECALL INPUT = part.imp\nPRINT ON = deck.imp\n"
             "STORE INPUT = part.imp\nLIST POSITION (A)\nEXECUTE\nEND\n")
    before = d.read_text()
    status, _, err = run_cli("run", d, "--quiet", "--overwrite", "--json", d,
                             "--csv", tmp_path / "c")
    assert status == 1
    assert d.read_text() == before
    assert (tmp_path / "part.imp").read_text() == "DATA POSITION (A) = 0, 30, 2\n"
    assert (f"{d}:{HEAD_LINES + 2}: the file '{d}' is an input of this run (the deck, a "
            "recalled file or a TABLE it reads), so it is kept") in err
    assert f"the file '{tmp_path / 'part.imp'}' is an input of this run" in err
    assert f"--json: the file '{d}' is an input of this run" in err
    assert list((tmp_path / "c").iterdir())  # the CSV is written
    # outside a run, the same paths are ordinary files
    files.atomic_write(tmp_path / "part.imp", "x")
    assert (tmp_path / "part.imp").read_text() == "x"


@pytest.mark.parametrize("statement", ["PRINT ON = ../home/.bashrc", "PRINT ON = /tmp/x.prt",
                                       "STORE INPUT = sub/../../x.imp", "STORE INPUT = ~/x"])
def test_print_on_and_store_input_outside_are_input_errors(tmp_path: Path,
                                                           statement: str) -> None:
    d = deck(tmp_path, f"{statement}\nDATA POSITION (A) = 0, 30, 2\nEXECUTE\nEND\n")
    status, out, err = run_cli("run", d)
    assert status == 2 and out == ""
    keyword = " ".join(statement.split()[:2])
    assert err.startswith(f"{d}:{HEAD_LINES + 1}: {keyword} statement: the file name ")
    assert "leaves the output folder" in err


# --------------------------------------------------------------------------- reading


def test_reads_stay_in_the_decks_folder(tmp_path: Path) -> None:
    other = tmp_path / "other"
    other.mkdir()
    (other / "part.imp").write_text("DATA POSITION (A) = 0, 30, 2\nRETURN\n")
    (other / "prof.tab").write_text("0\n1\n1\n2\n3\n")
    work = tmp_path / "work"
    work.mkdir()
    d = work / "deck.imp"
    d.write_text(HEAD + "RECALL INPUT = ../other/part.imp\nEXECUTE\nEND\n")
    status, _, err = run_cli("run", d)
    assert status == 2
    assert err.startswith(f"{d}:{HEAD_LINES + 1}: RECALL INPUT statement: the file "
                          f"'{work}/../other/part.imp' is outside the folders a deck may read "
                          f"('{work}'); move it into the deck's folder or allow its folder "
                          "with --allow-read DIR")
    status, _, err = run_cli("run", d, "--quiet", "--allow-read", other)
    assert status == 0, err
    d.write_text(HEAD + "VALUE (P) = TABLE(T): ../other/prof.tab\nDATA POSITION (A) = 0, 30, 2"
                 "\nLIST VALUE (P)\nEXECUTE\nEND\n")
    status, _, err = run_cli("run", d, "--quiet")
    assert status == 2 and "TABLE: the file" in err and "is outside the folders" in err
    assert run_cli("run", d, "--quiet", "--allow-read", other)[0] == 0
    # a symbolic link inside the folder that leads out of it is outside too
    (work / "sneaky.tab").symlink_to(other / "prof.tab")
    d.write_text(d.read_text().replace("../other/prof.tab", "sneaky.tab"))
    assert "is outside the folders" in run_cli("run", d, "--quiet")[2]


def test_devices_fifos_and_directories_are_not_read(tmp_path: Path) -> None:
    os.mkfifo(tmp_path / "pipe")
    (tmp_path / "adir").mkdir()
    for name, kind in (("pipe", "a pipe (fifo)"), ("adir", "a directory"),
                       ("/dev/zero", "a device")):
        d = deck(tmp_path, f"VALUE (P) = TABLE(T): {name}\nDATA POSITION (A) = 0, 30, 2\n"
                 "EXECUTE\nEND\n")
        t0 = time.process_time()
        status, _, err = run_cli("run", d, "--allow-read", "/dev")
        assert time.process_time() - t0 < 30  # refused before reading: no endless read
        assert status == 2, err
        assert f"TABLE: '{name if name.startswith('/') else tmp_path / name}' is {kind}, " \
               "not a file" in err, err
        d.write_text(HEAD + f"RECALL INPUT = {name}\n")
        status, _, err = run_cli("check", d, "--allow-read", "/dev")
        assert status == 2 and f"is {kind}, not a file" in err, err


def test_file_sizes_are_capped(tmp_path: Path) -> None:
    big = tmp_path / "big.imp"
    with open(big, "wb") as f:
        f.write(b"$$" + b" " * limits.MAX_FILE_BYTES)
    d = deck(tmp_path, "RECALL INPUT = big.imp\n")
    status, _, err = run_cli("check", d)
    assert status == 2
    assert f"holds {limits.MAX_FILE_BYTES + 2} bytes, more than {limits.MAX_FILE_BYTES} " \
           "(limit MAX_FILE_BYTES)" in err
    status, _, err = run_cli("check", big)
    assert status == 2 and err.startswith(f"{big}: the deck cannot be read: ")


def test_table_ordinates_are_capped(tmp_path: Path) -> None:
    n = limits.MAX_TABLE_ORDINATES + 1
    (tmp_path / "t.tab").write_text("0\n1\n" + "1\n" * n)
    with pytest.raises(InputError, match=r"more than 10000 ordinates \(limit "
                                         r"MAX_TABLE_ORDINATES\)") as info:
        expr_mod.load_table(tmp_path / "t.tab")
    assert info.value.where == (str(tmp_path / "t.tab"), limits.MAX_TABLE_ORDINATES + 3)
    (tmp_path / "w.tab").write_text("0\n1\n" + "x" * 5000 + "\n")
    with pytest.raises(InputError) as info:
        expr_mod.load_table(tmp_path / "w.tab")
    assert "'xxxxxxxxxxxxxxxxxxxx...' is not a number" in str(info.value)


@pytest.mark.parametrize("data,words", [
    (b"\xef\xbb\xbfZPIN (BASE, CRANK) = A\n", None),
    ("ZPIN (BASE, CRANK) = A\n".encode("utf-16"), "the file is UTF-16 text"),
    ("ZPIN (BASE, CRANK) = A $$ caf\xe9\n".encode("latin-1"), None),
    (b"ZPIN (BASE, CRANK) = A\n\x01\x02\xff\xfe junk\n", "the file is not text: byte 0x01"),
    (b"Z\x00P\x00I\x00N\x00", "the file holds NUL bytes"),
])
def test_deck_encodings(tmp_path: Path, data: bytes, words: str | None) -> None:
    d = tmp_path / "enc.imp"
    d.write_bytes(data + b"DATA POSITION (A) = 0, 10, 2\nEXECUTE\n" if words is None else data)
    status, _, err = run_cli("check", d)
    if words is None:
        assert status == 0, err
    else:
        assert status == 2 and err.startswith(f"{d}") and words in err, err


def test_bad_deck_arguments_are_named(tmp_path: Path) -> None:
    (tmp_path / "loop").symlink_to(tmp_path / "loop")
    (tmp_path / "adir").mkdir()
    cases = {tmp_path / "adir": "the deck is a directory, not a file",
             Path("/dev/null"): "the deck is not a regular file",
             tmp_path / "loop": "the deck cannot be read (Too many levels of symbolic links)",
             tmp_path / "nope.imp": "the deck file does not exist"}
    for path, words in cases.items():
        for command in ("run", "check"):
            status, out, err = run_cli(command, path)
            assert (status, out) == (2, ""), err
            assert err.startswith(f"{path}: {words}"), err


def test_recall_limits(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "many.imp").write_text("REMARK x\n" * 30)
    d = tmp_path / "d.imp"
    d.write_text("RECALL INPUT = many.imp\n" * 3)
    monkeypatch.setattr(parser_mod, "MAX_STATEMENTS", 50)
    status, _, err = run_cli("check", d)
    assert status == 2
    assert f"{tmp_path / 'many.imp'}:18: the deck and the files it recalls hold more than 50 " \
           "statements (limit MAX_STATEMENTS); reading stops here" in err
    monkeypatch.setattr(parser_mod, "MAX_STATEMENTS", 10**6)
    monkeypatch.setattr(parser_mod, "MAX_READ_BYTES", 500)
    status, _, err = run_cli("check", d)
    assert status == 2 and "(limit MAX_READ_BYTES)" in err


def test_many_errors_are_cut_short(tmp_path: Path) -> None:
    d = tmp_path / "d.imp"
    d.write_text("FOO\n" * 80)
    status, _, err = run_cli("check", d)
    lines = err.strip().splitlines()
    assert status == 2 and len(lines) == limits.MAX_ERRORS_SHOWN + 1
    assert lines[-1] == (f"{d}: 30 more input errors are not shown (limit MAX_ERRORS_SHOWN); "
                         "correct the ones above first")


def test_control_characters_are_escaped(tmp_path: Path) -> None:
    d = tmp_path / "d.imp"
    d.write_text("TITLE = RED\x1b[31m ALERT\u2028X\nZPIN (BASE, CRANK) = A\n"
                 "DATA POSITION (A) = 0, 10, 1\nRECALL INPUT = 'no\x07pe'\nEXECUTE\n")
    status, out, err = run_cli("run", d)
    assert status == 2
    assert "no\\x07pe' cannot be read" in err and "\x07" not in err
    d.write_text(d.read_text().replace("RECALL INPUT = 'no\x07pe'\n", ""))
    status, out, err = run_cli("run", d)
    assert status == 0, err
    assert "RED\\x1b[31m ALERT\\u2028X" in out and "\x1b" not in out and "\u2028" not in out


# --------------------------------------------------------------------------- limits


@pytest.mark.parametrize("body,words", [
    ("ZERO (POSITION) = 1E-15", "the tolerance 1E-15 is below 1E-14 (limit MIN_TOLERANCE)"),
    ("ZERO (SYSTEM) = 2", "the tolerance 2 is above 1 (limit MAX_TOLERANCE)"),
    ("ZERO (POSITION) = 1E-6, 1000000000", "1000000000 iterations are more than 1000 (limit "
                                           "MAX_ITERATIONS)"),
    ("DATA TIME = 1E6, 0, 1", "gives 1E+06 output steps, more than 100000 (limit MAX_STEPS)"),
    ("DATA POSITION (A) = 0, 1, 100001", "100001 steps are more than 100000"),
    ("DATA POSITION (A) = 0, 1, -3", "the number of steps (-3) must not be negative"),
    ("DATA POSITION (A) = 0, 1E149, 100", "the joint would travel to 1E+151"),
    ("DATA POSITION (A) = 0, 1, 3\nDATA VELOCITY (A) = 1E61", "the velocity 1E+61 is beyond "
                                                               "±1E+60 (limit MAX_RATE)"),
    ("DATA POINT (CP, ABS) = 1E151, 0, 0", "the coordinates x 1E151 is beyond ±1E+150 (limit "
                                          "MAX_NUMBER)"),
    ("GEAR (CRANK, ROCKER) = G\nDATA GEAR (G) = 1E7, 1", "the gear ratio 1E+07 is out of "
                                                         "range"),
    ("DATA VIEW = 1E150, 0, 0; 1E150, 0, 0", "must not be parallel"),
])
def test_limits_are_input_errors_naming_the_statement(tmp_path: Path, body: str,
                                                      words: str) -> None:
    d = deck(tmp_path, body + "\nEXECUTE\nEND\n")
    status, _, err = run_cli("check", d)
    assert status == 2, err
    line = HEAD_LINES + body.count("\n") + 1
    errors = [ln for ln in err.splitlines() if ": warning: " not in ln]  # a GEAR not placed
    assert errors[0].startswith(f"{d}:{line}: "), err
    assert words in err, err


def test_results_are_capped(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(prepare_mod, "MAX_RESULT_BYTES", 100_000)
    d = deck(tmp_path, "DATA POSITION (A) = 0, 1, 3000\nEXECUTE\nEND\n")
    status, _, err = run_cli("check", d)
    assert status == 2
    assert f"{d}:{HEAD_LINES + 2}: EXECUTE: the run would hold" in err
    assert "(limit MAX_RESULT_BYTES)" in err


def test_evaluation_depth_is_capped() -> None:
    lines = ["VALUE (V0) = " + "1+" * 190 + "T"]
    lines += [f"VALUE (V{k}) = V{k - 1}+1" for k in range(1, 50)]
    stmts = parser_mod.parse_text("\n".join(lines), "v.imp", columns=None, significant=None)
    env = {s.fields["name"]: s.fields["expression"] for s in stmts}
    assert env["V0"].evaluate(env, lambda k, n, c: 0.5) == pytest.approx(190.5)
    with pytest.raises(InputError, match=r"more than 220 levels .* \(limit MAX_EVAL_DEPTH\)"):
        env["V49"].evaluate(env, lambda k, n, c: 0.5)


def test_solver_options_are_checked() -> None:
    limits.check_solver_options(1e-10, 1e-10, 25, 12)
    limits.check_solver_options(np.float64(1e-8), np.float32(1e-6), np.int64(25), np.int32(0))
    bad = [((0.0, 1e-10, 25, 12), "tol must be positive"),
           ((math.nan, 1e-10, 25, 12), "tol must be a finite number"),
           ((1e-300, 1e-10, 25, 12), "limit MIN_TOLERANCE"),
           ((1e-10, -1.0, 25, 12), "pivot_tol must be positive"),
           ((1e-10, 1e-10, 0, 12), "maxit must be at least 1"),
           ((1e-10, 1e-10, 10**9, 12), "limit MAX_ITERATIONS"),
           ((1e-10, 1e-10, 2.5, 12), "maxit must be a whole number"),
           ((1e-10, 1e-10, True, 12), "maxit must be a whole number"),
           (("1e-10", 1e-10, 25, 12), "tol must be a finite number"),
           ((1e-10, 1e-10, 25, -1), "maxhalve must be at least 0"),
           ((1e-10, 1e-10, 25, 64), "limit MAX_HALVINGS")]
    for args, words in bad:
        with pytest.raises(InputError, match=words.replace("(", r"\(")):
            limits.check_solver_options(*args)


def test_gear_ratio_of_the_python_api() -> None:
    import openimp

    m = openimp.Model("g")
    with pytest.raises(InputError, match="limit MAX_GEAR_RATIO"):
        m.add_joint("gear", "G", "BASE", "B", origin=(0, 0, 0), origin2=(1, 0, 0),
                    ratio=1e308, distance=1.0)


def test_zero_fill_warnings_are_located(tmp_path: Path) -> None:
    d = deck(tmp_path, "DATA POINT (CP, ABS) = 2.5, 4\nDATA POSITION (A) = 0, 30, 2\nEXECUTE\n"
             "END\n")
    status, out, err = run_cli("run", d)
    assert status == 0, err
    assert f"*** {d}:{HEAD_LINES + 1}: Warning: 1 zeroes are added to complete statement. ***" \
        in out


# --------------------------------------------------------------------------- runs


def test_numeric_warnings_become_located_notes(tmp_path: Path,
                                               monkeypatch: pytest.MonkeyPatch) -> None:
    real = output_mod.execute_run

    def noisy(spec, ctx):  # type: ignore[no-untyped-def]
        np.float64(1e308) * 10.0  # overflows on purpose
        return real(spec, ctx)

    monkeypatch.setattr(output_mod, "execute_run", noisy)
    d = deck(tmp_path, "DATA POSITION (A) = 0, 30, 2\nEXECUTE\nEND\n")
    status, _, err = run_cli("run", d, "--quiet")
    assert status == 0
    assert err == (f"openimp: note: {d}:{HEAD_LINES + 2}: a computation gave a warning "
                   "(RuntimeWarning: overflow encountered in scalar multiply, in "
                   "test_safety.py:" + err.split("test_safety.py:")[1].split(")")[0] + "); "
                   "values that are not finite are listed as ????: check the sizes of the "
                   "input numbers\n")


def test_ctrl_c_keeps_what_was_solved(tmp_path: Path) -> None:
    d = deck(tmp_path, "DATA POSITION (A) = 0, 0.01, 9000\nLIST POSITION (D)\nSTORE POSITION "
             "(D)\nEXECUTE\nDATA POSITION (A) = 0, 10, 3\nEXECUTE\nEND\n")
    dk = load(d)
    calls = []

    def progress(run: int, done: int, total: int) -> None:
        calls.append(done)
        if done >= 4000:
            raise KeyboardInterrupt

    runs = dk.run(progress=progress)
    assert len(runs) == 1  # the deck stops after the interrupted run
    run = runs[0]
    assert run.interrupted and "interrupted by the user (Ctrl-C)" in run.failure
    assert "the 4000 position(s) solved are listed" in run.failure
    assert run.table("LIST POSITION", "joint D").rows.shape == (4000, 2)
    assert (tmp_path / "deck_store.txt").exists()  # the files of what ran are written
    assert run.to_dict()["interrupted"] is True


def test_ctrl_c_on_the_command(tmp_path: Path) -> None:
    d = deck(tmp_path, "DATA POSITION (A) = 0, 0.0036, 100000\nLIST POSITION (D)\nEXECUTE\n"
             "END\n")
    js = tmp_path / "r.json"
    env = {**os.environ, "OPENIMP_NO_WARMUP": "1", "PYTHONUNBUFFERED": "1"}
    proc = subprocess.Popen([sys.executable, "-m", "openimp.cli", "run", str(d), "--json",
                             str(js)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, env=env)
    assert proc.stdout is not None
    for line in proc.stdout:  # the banner is printed before the solution starts
        if "Kinematic Mode" in line:
            break
    time.sleep(0.5)
    proc.send_signal(signal.SIGINT)
    _out, err = proc.communicate()
    assert proc.returncode == 130, err
    lines = err.strip().splitlines()
    # interrupted while solving (one line), or once solved (the held note first)
    assert lines[-1].startswith("openimp: interrupted (Ctrl-C): "), err
    assert len(lines) == 1 or (len(lines) == 2 and "Ctrl-C: the 100001 output(s) solved are "
                               "being listed and written" in lines[0]), err
    assert "Traceback" not in err
    run = json.loads(js.read_text())["runs"][0]
    assert run["interrupted"] is True and "Ctrl-C" in run["failure"]


def _interrupt_after_solving(tmp_path: Path, presses: int) -> tuple[int, str, Path, Path]:
    """`openimp run` of a 1e5-position deck with PRINT, SIGINT sent ``presses`` times once
    the printout of the solved positions has begun (it is made after solving)."""
    d = deck(tmp_path, "DATA POSITION (A) = 0, 0.0036, 100000\nPRINT POSITION (D)\n"
             "LIST POSITION (D)\nSTORE POSITION (D)\nEXECUTE\nDATA POSITION (A) = 0, 10, 3\n"
             "EXECUTE\nEND\n")
    return _interrupt_at(tmp_path, d, "step = ", presses)


def _interrupt_at(tmp_path: Path, d: Path, marker: str, presses: int = 1
                  ) -> tuple[int, str, Path, Path]:
    """`openimp run d --json r.json --csv c` with SIGINT sent ``presses`` times once a line
    of its printout starts with ``marker``: (status, stderr, JSON path, CSV folder)."""
    js, cs = tmp_path / "r.json", tmp_path / "c"
    env = {**os.environ, "OPENIMP_NO_WARMUP": "1", "PYTHONUNBUFFERED": "1"}
    proc = subprocess.Popen([sys.executable, "-m", "openimp.cli", "run", str(d), "--json",
                             str(js), "--csv", str(cs)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env)
    assert proc.stdout is not None
    for line in proc.stdout:
        if line.startswith(marker):
            break
    for _ in range(presses):
        proc.send_signal(signal.SIGINT)
        time.sleep(0.2)
    _out, err = proc.communicate()
    return proc.returncode, err, js, cs


def test_ctrl_c_after_solving_keeps_everything(tmp_path: Path) -> None:
    """issue 30 N3: Ctrl-C once the positions are solved (while they are printed, listed
    and written) holds until the run's results and every file are made whole, says so,
    then ends the deck (exit 130): the JSON holds all 100 001 rows, the CSV and STORE
    files are written, the second EXECUTE does not run."""
    status, err, js, cs = _interrupt_after_solving(tmp_path, 1)
    assert status == 130, err
    assert "Traceback" not in err
    assert "Ctrl-C: the 100001 output(s) solved are being listed and written" in err
    runs = json.loads(js.read_text())["runs"]
    assert len(runs) == 1 and runs[0]["interrupted"] is True
    assert "after its 100001 output(s) were solved; they are listed and written" in \
        runs[0]["failure"]
    assert [len(t["rows"]) for t in runs[0]["tables"]] == [100001] * len(runs[0]["tables"])
    assert any(f.suffix == ".csv" for f in cs.iterdir())
    assert (tmp_path / "deck_store.txt").exists()
    assert err.strip().splitlines()[-1].startswith("openimp: interrupted (Ctrl-C): ")


def test_ctrl_c_twice_abandons_at_once(tmp_path: Path) -> None:
    """A second Ctrl-C abandons what was being made: exit 130, no traceback, nothing
    half-written (no temporary file left)."""
    status, err, _js, _cs = _interrupt_after_solving(tmp_path, 2)
    assert status == 130, err
    assert "Traceback" not in err and "Ctrl-C again abandons them" in err
    no_temp_files(tmp_path)


def test_empty_decks_are_refused_by_check_too(tmp_path: Path) -> None:
    d = tmp_path / "e.imp"
    d.write_text("$$ nothing\n\n")
    status, out, err = run_cli("check", d)
    assert (status, out) == (2, "")
    assert err.startswith(f"{d}: the deck holds no statement")
    with pytest.raises(DeckError):
        load(d)


def test_library_log_records_become_located_notes(monkeypatch: pytest.MonkeyPatch) -> None:
    import logging

    def check(args):  # type: ignore[no-untyped-def]
        for _ in range(2):
            logging.getLogger("matplotlib.text").warning("posx and posy should be finite")
        return 0

    monkeypatch.setattr(cli, "_cmd_check", check)
    assert run_cli("check", "x.imp") == (
        0, "", "openimp: note: x.imp: matplotlib.text: posx and posy should be finite\n")


#: the fuzz findings' N3 deck: a released four-bar, here with 20 001 outputs
N3_DECK = Path(__file__).resolve().parents[2] / "shared" / "fuzz-findings" / "new-modes" / \
    "N3_long_list.imp"


def _released_fourbar(tmp_path: Path) -> Path:
    text = N3_DECK.read_text() if N3_DECK.exists() else ""
    if not text:
        pytest.skip("shared/fuzz-findings is not beside the checkout")
    text = text.replace("DATA TIME = 1000, 0, 0.01", "DATA TIME = 200, 0, 0.01")
    text = text.replace("LIST POSITION (A, D, CP)", "PRINT POSITION (A)\nLIST POSITION (A, D, "
                        "CP)\nSTORE POSITION (A)")
    d = tmp_path / "long.imp"
    d.write_text(text)
    return d


def test_ctrl_c_while_integrating_keeps_the_outputs_reached(tmp_path: Path) -> None:
    """issue 30 N3 in dynamic mode: a real SIGINT (from a timer thread, so it lands at any
    bytecode: inside the compiled step's callbacks too) once 1000 outputs are reached
    keeps them; the run is interrupted, its tables hold the same rows, no error."""
    d = _released_fourbar(tmp_path)
    code = f"""
import json, os, signal, threading
from openimp.imp.deck import load
fired = []
def progress(run, done, total):
    if done >= 1000 and not fired:
        fired.append(done)
        threading.Timer(0.05, os.kill, (os.getpid(), signal.SIGINT)).start()
runs = load({str(d)!r}).run(progress=progress)
r = runs[0]
print(json.dumps({{"n": len(runs), "interrupted": r.interrupted, "failure": r.failure,
                  "rows": [len(t.rows) for t in r.tables],
                  "t": [float(x) for x in r.tables[0].rows[:, 0]]}}))
"""
    env = {**os.environ, "OPENIMP_NO_WARMUP": "1"}
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                       preexec_fn=cpu_limit)
    assert p.returncode == 0, p.stderr[-3000:]
    out = json.loads(p.stdout.strip().splitlines()[-1])
    assert out["n"] == 1 and out["interrupted"] is True, out["failure"]
    assert "interrupted by the user (Ctrl-C)" in out["failure"]
    assert len(set(out["rows"])) == 1 and 1000 <= out["rows"][0] < 20001, out["rows"]
    np.testing.assert_allclose(out["t"], 0.01 * np.arange(out["rows"][0]), rtol=0, atol=1e-9)


def test_ctrl_c_after_integrating_keeps_every_output(tmp_path: Path) -> None:
    """issue 30 N3 in dynamic mode (the reproducer N3_sigint.py): SIGINT once the run has
    integrated (its forces, listings and files being made) keeps all of them: the JSON
    tables, the CSV files and the STORE file are written whole, with every output."""
    d = _released_fourbar(tmp_path)
    # the printout ("time = ...") is made once every output is solved
    status, err, js, cs = _interrupt_at(tmp_path, d, "time = ")
    assert status == 130, err
    assert "Traceback" not in err and "unexpectedly" not in err
    assert any(ln.startswith("openimp: interrupted (Ctrl-C)") for ln in err.splitlines()), err
    run = json.loads(js.read_text())["runs"][0]
    assert run["interrupted"] is True
    assert "after its 20001 output(s) were solved" in run["failure"]
    assert [len(t["rows"]) for t in run["tables"]] == [20001] * len(run["tables"])
    csvs = sorted(cs.iterdir())
    assert csvs and all(len(f.read_text().splitlines()) == 20002 for f in csvs)
    times = np.array(run["tables"][0]["rows"])[:, 0]
    np.testing.assert_allclose(times, 0.01 * np.arange(20001), rtol=0, atol=1e-9)
    assert (tmp_path / "long_store.txt").exists()
    no_temp_files(tmp_path)
