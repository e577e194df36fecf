"""The ``openimp`` command, run as a subprocess (exit codes, messages, files).

Exit status: 0 success, 2 input errors (``file:line: message`` on stderr,
never a traceback), 1 analysis failure (what was computed is still written).
"""

from __future__ import annotations

import csv
import json
import math
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from helpers.decks import cpu_limit

DECKS = Path(__file__).parent / "decks"
EXAMPLES = Path(__file__).parent.parent / "examples"
FOURBAR_HEAD = (DECKS / "run_fourbar.imp").read_text().split("DATA POSITION")[0]
HEAD_LINES = FOURBAR_HEAD.count("\n")


def openimp(*args: str | Path, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "openimp.cli", *map(str, args)],
                          capture_output=True, text=True, cwd=cwd, preexec_fn=cpu_limit,
                          env={**__import__("os").environ, "MPLBACKEND": "Agg"})


def no_traceback(p: subprocess.CompletedProcess[str]) -> None:
    assert "Traceback" not in p.stderr and "Traceback" not in p.stdout, p.stderr


def test_version_and_usage() -> None:
    p = openimp("--version")
    assert p.returncode == 0 and p.stdout.startswith("openimp ")
    p = openimp()
    assert p.returncode == 2 and "usage" in p.stderr
    p = openimp("run")
    assert p.returncode == 2 and "usage" in p.stderr
    no_traceback(p)


def test_console_script() -> None:
    exe = shutil.which("openimp")
    if exe is None:
        pytest.skip("the openimp console script is not installed (pip install -e .)")
    p = subprocess.run([exe, "--version"], capture_output=True, text=True,
                       preexec_fn=cpu_limit)
    assert p.returncode == 0 and "openimp" in p.stdout


def test_run_fourbar_example_prints_listings(tmp_path) -> None:
    p = openimp("run", EXAMPLES / "fourbar.imp", cwd=tmp_path)
    no_traceback(p)
    assert p.returncode == 0, p.stderr
    out = p.stdout
    assert "CRANK-ROCKER FOUR-BAR LINKAGE" in out and "Kinematic Mode" in out
    assert "Listing of position of joint A" in out
    assert "Listing of position of joint D" in out
    lines = out.splitlines()
    i = lines.index("Listing of position of joint D")
    # no DATA TIME: the first column is the step, not a time in seconds
    assert lines[i + 1].split()[:3] == ["Step", "JVar", "1"]
    assert lines[i + 2].split() == ["0", "-108.435"]
    # graphics were asked for but --out was not given: one note
    assert p.stderr.count("not rendered") == 1


def test_json_and_csv(tmp_path) -> None:
    js = tmp_path / "out.json"
    cs = tmp_path / "csv"
    p = openimp("run", DECKS / "run_fourbar.imp", "--json", js, "--csv", cs, "--quiet")
    no_traceback(p)
    assert p.returncode == 0, p.stderr
    assert p.stdout == ""
    doc = json.loads(js.read_text())
    assert list(doc) == ["runs"] and len(doc["runs"]) == 1
    run = doc["runs"][0]
    assert run["title"] == "FOUR-BAR FOR TESTS" and run["mode"] == "kinematic"
    tables = {(t["request"], t["item"]): t for t in run["tables"]}
    t = tables[("LIST POSITION", "joint A")]
    assert t["columns"] == ["Step", "JVar 1"] and t["units"] == ["", "deg"]
    assert len(t["rows"]) == 25 and t["rows"][2] == [2.0, pytest.approx(30.0, abs=1e-9)]
    assert tables[("LIST POSITION", "point CP")]["columns"] == ["Step", "X", "Y", "Z"]
    assert tables[("LIST VELOCITY", "link COUP")]["units"][1] == "rad/s"
    files = sorted(cs.glob("*.csv"))
    assert len(files) == len(run["tables"])
    f = cs / "run1_list_position_joint_a.csv"
    rows = list(csv.reader(f.open()))
    assert rows[0] == ["Step", "JVar 1 [deg]"]
    assert float(rows[3][1]) == pytest.approx(30.0, abs=1e-9)
    assert len(rows) == 26


def test_check_command(tmp_path) -> None:
    p = openimp("check", DECKS / "run_rsur.imp")
    no_traceback(p)
    assert p.returncode == 0, p.stderr
    assert "OK" in p.stdout and "4 joints" in p.stdout and "1 input motion" in p.stdout
    bad = tmp_path / "bad.imp"
    bad.write_text(FOURBAR_HEAD + "DATA POSITION (A) = 0, 10, 3\nDATA POSITION (D) = 0, 5, 3\n"
                   "EXECUTE\n")
    p = openimp("check", bad)
    no_traceback(p)
    # over-specified inputs: IMP assembled them where they agree (checked at every position)
    at = f"{bad}:{HEAD_LINES + 2}:"
    assert p.returncode == 0 and f"{at} DATA POSITION: over-specified input" in p.stderr
    p = openimp("check", "--strict", bad)
    assert p.returncode == 2 and at in p.stderr and "over-specified" in p.stderr


# Each malformed deck: (lines appended to the four-bar head, line of the error
# counted from the first appended line, a word of the message).  Run with --strict:
# a statement IMP passed over is then refused too (its default, a warning and the
# rest run, is test_imp_tolerance's).
MALFORMED = [
    ("FOO (A) = 1", 1, "unknown statement keyword"),
    ("ZPIN (BASE) = A2", 1, "joint name is missing"),
    ("ZPIN (BASE, BASE) = J9", 1, "to itself"),
    ("DATA ZPIN (NOPE) = 0,0,0", 1, "joint NOPE is not defined"),
    ("DATA REVOLUTE (A) = 0,0,0; 0,0,1", 1, "is a ZPIN, not a REVOLUTE"),
    ("DATA ZPIN (A) = 0,0,0; 0,0,0; XX", 1, "point XX is not defined"),
    ("DATA POSITION (A) = 0, 10, 3\nDATA POSITION (QQ) = 1", 2, "joint QQ is not defined"),
    ("DATA VELOCITY (B) = 3", 1, "has no DATA POSITION"),
    ("DATA TIME = 1, 0, 0", 1, "print step"),
    ("DATA TIME = 1, 0", 1, ""),
    ("VALUE (X) = 2 * (3", 1, "VALUE"),
    ("TORQUE (NOLINK, A, B) = T9", 1, "link NOLI is not defined"),
    ("DATA POINT (P9, ABS) = 1, 2, 3", 1, "point P9 is not defined"),
    ("DATA MOTION (A) = 1, 2", 1, "1 variable(s) but 2 motions"),
    ("ZERO POSITION = -1", 1, "positive"),
    ("UNIT (MASS) = 0", 1, "positive"),
    ("DATA INERTIA (CRANK, LINK) = 1, 2, 3", 1, "no DATA MASS"),
    ("DATA POSITION (A) = 0, 10, 3\nFIND DYNAMICS", 2, "FIND DYNAMICS"),
    ("DELETE EQUILIB", 1, "no FIND EQUILIB"),
    ("DATA POSITION (A) = 0, 10, 3\nLIST POSITION (NOPE)\nEXECUTE", 2, "NOPE is not"),
    ("DATA POSITION (A) = 0, 10, 3\nDATA POSITION (D) = 0, 10, 3\nEXECUTE", 2,
     "over-specified"),
    ("SPHERE (COUPLER, BASE) = S\nDATA POSITION (S) = 0", 2, "single-variable"),
    ("DATA GEAR (A) = 2, 1", 1, "not a GEAR"),
    ("DATA GEAR (A) = 0, 1", 1, "must not be 0"),
    ("LIST POSITION", 1, "at least one name"),
    ("EXECUTE HOLD NOW", 1, "one item too many"),
    ("DATA LINK (CRANK, C) = 0,0,0; 0,0,1; 1,0,0", 1, "link CRAN is not in joint C"),
    ("SHOW RED\nEXECUTE", 1, "name what to show"),
]


@pytest.mark.parametrize("body,line,word", MALFORMED, ids=[m[0].split("\n")[-1][:24]
                                                          for m in MALFORMED])
def test_malformed_statements_exit_2(tmp_path, body: str, line: int, word: str) -> None:
    deck = tmp_path / "bad.imp"
    deck.write_text(FOURBAR_HEAD + body + "\nEND\n")
    p = openimp("run", "--strict", deck)
    no_traceback(p)
    assert p.returncode == 2, (p.returncode, p.stdout, p.stderr)
    assert f"{deck}:{HEAD_LINES + line}: " in p.stderr, p.stderr
    assert word in p.stderr, p.stderr
    assert p.stdout == ""


def test_placement_errors_are_located(tmp_path) -> None:
    """Frames that break a joint's rules are reported at the DATA statement."""
    deck = tmp_path / "bad.imp"
    deck.write_text(FOURBAR_HEAD + "DATA LINK (CRANK, B) = 1,0,0; 1,0,1; 2,0,0\n"
                    "DATA LINK (COUPLER, B) = 1.5,0,0; 1.5,0,1; 2,0,0\n"
                    "DATA POSITION (A) = 0, 10, 3\nEXECUTE\n")
    p = openimp("run", deck)
    no_traceback(p)
    assert p.returncode == 2
    assert f"{deck}:{HEAD_LINES + 2}: ZPIN joint B (openimp revolute): its two frames" in p.stderr
    assert "do not conform" in p.stderr


def test_missing_gear_data_and_missing_file(tmp_path) -> None:
    deck = tmp_path / "gear.imp"
    deck.write_text("ZPIN (BASE, G1) = A\nZPIN (BASE, G2) = B\nGEAR (G1, G2) = M\n"
                    "DATA POSITION (A) = 0, 10, 2\nEXECUTE\n")
    p = openimp("run", deck)
    no_traceback(p)
    assert p.returncode == 2 and f"{deck}:3: " in p.stderr and "DATA GEAR" in p.stderr
    p = openimp("run", tmp_path / "nope.imp")
    no_traceback(p)
    assert p.returncode == 2 and "does not exist" in p.stderr


def test_all_errors_are_listed(tmp_path) -> None:
    deck = tmp_path / "bad.imp"
    deck.write_text(FOURBAR_HEAD + "DATA ZPIN (NOPE) = 0,0,0\nFOO\nDATA VELOCITY (A) = 1\n")
    p = openimp("run", deck)
    assert p.returncode == 2
    lines = p.stderr.strip().splitlines()
    assert [ln.split(": ")[0] for ln in lines] == [f"{deck}:{HEAD_LINES + k}" for k in (1, 2, 3)]


def test_analysis_failure_exit_1_partial_output(tmp_path) -> None:
    js = tmp_path / "out.json"
    cs = tmp_path / "csv"
    p = openimp("run", DECKS / "run_fail.imp", "--json", js, "--csv", cs)
    no_traceback(p)
    assert p.returncode == 1  # the crank cannot pass 90 deg: those positions are skipped
    assert "28 position(s) could not be reached and were skipped" in p.stderr
    assert "steps 9 to 36 (time 9.000000 to 36.000000; R1 1 = 90 deg to R1 1 = 360 deg) " \
           "cannot be reached" in p.stdout
    assert "Listing of position of joint R1" in p.stdout
    doc = json.loads(js.read_text())
    run = doc["runs"][0]
    assert "failure" not in run and run["missing"] == [float(k) for k in range(9, 37)]
    t = {t["item"]: t for t in run["tables"] if t["request"] == "LIST POSITION"}
    assert len(t["joint R1"]["rows"]) == 9
    assert (cs / "run1_list_position_joint_r1.csv").exists()


def test_unbuilt_analyses_exit_1_but_everything_else_runs(tmp_path) -> None:
    deck = tmp_path / "modes.imp"
    deck.write_text(FOURBAR_HEAD + "DATA POSITION (A) = 0, 30, 2\nLIST POSITION (D)\n"
                    "LIST FORCE (A)\nEXECUTE\nDELETE INPUT ALL\nFIND DYNAMICS\n"
                    "DATA TIME = 1, 0.1, 0.1\nEXECUTE\nDELETE DYNAMICS\n"
                    "DATA POSITION (A) = 0, 30, 2\nEXECUTE\nEND\n")
    js = tmp_path / "o.json"
    p = openimp("run", deck, "--json", js)
    no_traceback(p)
    assert p.returncode == 1
    assert "LIST FORCE is not produced" not in p.stderr  # kinematic force analysis is built
    # the dynamic run is built: this massless four-bar cannot move (singular mass matrix)
    assert "EXECUTE: t = 0 s: the mass matrix" in p.stderr
    runs = json.loads(js.read_text())["runs"]
    assert [r["mode"] for r in runs] == ["kinematic", "dynamic", "kinematic"]
    assert len(runs[0]["tables"]) == 2 and "unsupported" not in runs[0]
    assert runs[0]["tables"][1]["request"] == "LIST FORCE"
    assert all(t["rows"] == [] for t in runs[1]["tables"]) and "failure" in runs[1]
    assert len(runs[2]["tables"]) == 2 and "failure" not in runs[2]
    assert p.stdout.count("Listing of position of joint D") == 3  # the dynamic one empty


def test_long_run_10000_steps(tmp_path) -> None:
    deck = tmp_path / "long.imp"
    deck.write_text(FOURBAR_HEAD + "DATA POSITION (A) = 0, 0.036, 10000\n"
                    "DATA VELOCITY (A) = 1\nLIST POSITION (D, CP)\nLIST VELOCITY (D)\n"
                    "EXECUTE\nEND\n")
    js = tmp_path / "long.json"
    p = openimp("run", deck, "--json", js, "--quiet")
    no_traceback(p)
    assert p.returncode == 0, p.stderr
    doc = json.loads(js.read_text())
    tables = {t["item"]: t for t in doc["runs"][0]["tables"] if t["request"] == "LIST POSITION"}
    rows = np.array(tables["joint D"]["rows"])
    assert rows.shape == (10001, 2)
    assert rows[-1, 0] == 10000.0
    assert rows[-1, 1] == pytest.approx(rows[0, 1], abs=1e-7)  # one full turn
    assert np.all(np.isfinite(np.array(tables["point CP"]["rows"])))


def test_out_dir_graphics_and_store(tmp_path) -> None:
    out = tmp_path / "out"
    deck = tmp_path / "g.imp"
    deck.write_text(FOURBAR_HEAD + "POINT (CRANK) = K1, K2\nDATA POINT (K1, ABS) = 0,0,0\n"
                    "DATA POINT (K2, ABS) = 1,0,0\nDATA POSITION (A) = 0, 30, 12\n"
                    "SHOW RED = CRANK\nAXES 0.5 = A\nDRAW\nPLOT POSITION (D)\n"
                    "STORE POSITION (D)\nANIMATE\nEXECUTE\nEND\n")
    p = openimp("run", deck, "--out", out, "--quiet")
    no_traceback(p)
    assert p.returncode == 0, p.stderr
    names = sorted(f.name for f in out.iterdir())
    assert "draw1.png" in names and "run1_animation.gif" in names
    assert "run1_animation.html" in names and "run1_plot_position_joint_d.png" in names
    assert "g_store.txt" in names
    assert (out / "draw1.png").read_bytes()[:4] == b"\x89PNG"
    store = (out / "g_store.txt").read_text().splitlines()
    assert store[1] == "# STORE POSITION joint D"
    rows = [ln for ln in store if not ln.startswith("#")]
    assert len(rows) == 13 and math.isclose(float(rows[0].split()[0]), 0.0)


def test_store_without_out_goes_to_the_decks_folder(tmp_path) -> None:
    deck = tmp_path / "s.imp"
    deck.write_text(FOURBAR_HEAD + "DATA POSITION (A) = 0, 30, 2\nSTORE VELOCITY (CP)\n"
                    "EXECUTE\nEND\n")
    work = tmp_path / "work"
    work.mkdir()
    p = openimp("run", deck, "--quiet", cwd=work)
    no_traceback(p)
    assert p.returncode == 0
    assert not (work / "s_store.txt").exists()  # not the current directory
    text = (tmp_path / "s_store.txt").read_text()
    assert "# STORE VELOCITY point CP" in text


def test_the_console_entry_exits_with_mains_status(tmp_path):
    """``openimp.cli:entry`` (the console script) ends the process with main's status,
    its output flushed (it skips Python's finalization, where a Ctrl-C that interrupted
    an import turned a 130 into a death by SIGINT)."""
    deck = tmp_path / "d.imp"
    deck.write_text("ZPIN (BASE, CRANK) = A\nDATA ZPIN (A) = 0,0,0; 1,0,0; 1,0,0\n"
                    "DATA POSITION (A) = 0, 10, 2\nLIST POSITION (A)\nEXECUTE\nEND\n")
    for argv, status in ((["run", str(deck)], 0), (["check", str(tmp_path / "no.imp")], 2)):
        p = subprocess.run([sys.executable, "-c", "import sys; from openimp.cli import entry; "
                            f"sys.argv = ['openimp'] + {argv!r}; entry()"],
                           capture_output=True, text=True)
        assert p.returncode == status, p.stderr
        if status == 0:
            assert p.stdout.rstrip().endswith("20.000")
            assert all(ln.startswith("openimp: note:") for ln in p.stderr.splitlines())


def test_a_ctrl_c_in_a_callback_is_kept_for_after_the_compile():
    """A KeyboardInterrupt Python could not raise (numba's compiler calls back through
    ctypes) is kept, not printed as an ignored traceback, and raised when the compile is
    over (the compile listener's end)."""
    import types

    from openimp import _interrupt, cli

    u = types.SimpleNamespace(exc_type=KeyboardInterrupt, exc_value=KeyboardInterrupt(),
                              exc_traceback=None, err_msg=None, object=None)
    try:
        cli._unraisable(u)
        assert _interrupt.PENDING[0] is True
    finally:
        _interrupt.PENDING[0] = False


def test_an_error_caused_by_ctrl_c_is_an_interrupt(monkeypatch, capsys):
    """A Ctrl-C inside an import can surface as another exception (a RuntimeError from a
    class's __set_name__): the command ends as interrupted (130), not as an internal
    error."""
    from openimp import cli

    def boom(argv):
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt as ki:
            raise RuntimeError("Error calling __set_name__ on 'Field' instance") from ki

    monkeypatch.setattr(cli, "_dispatch", boom)
    assert cli.main(["run", "x.imp"]) == cli.EXIT_INTERRUPTED
    err = capsys.readouterr().err
    assert err.startswith("openimp: interrupted (Ctrl-C)") and "internal error" not in err
