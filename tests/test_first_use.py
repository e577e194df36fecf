"""What a new user tripped over (issue 11, item 6).

* Names that share their first four characters (all IMP reads) silently
  became one element: a located warning names both spellings.
* ``openimp check`` said OK for decks whose requests a run cannot answer: it
  now lists, in the run's own words, what will not be produced, and exits as
  the run does.
* In decks driven by DATA POSITION without DATA TIME, the first column was
  called ``Time`` (s) although it is the step number: it is ``Step``, and
  PLOT draws against the input's value.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from helpers.decks import cpu_limit
from openimp.imp.deck import load
from openimp.imp.interp import DeckError

DECKS = Path(__file__).parent / "decks"
EXAMPLES = Path(__file__).parent.parent / "examples"
FOURBAR_HEAD = (DECKS / "run_fourbar.imp").read_text().split("DATA POSITION")[0]
HEAD_LINES = FOURBAR_HEAD.count("\n")

#: run_fourbar.imp's four-bar with renamed links (lines 1-10 of every deck below)
FOURBAR_LINKS = """TITLE = NAMES
ZPIN ({base}, {crank}) = A
ZPIN ({crank}, {coupler}) = B
ZPIN ({coupler}, {rocker}) = C
ZPIN ({rocker}, BASE) = D
DATA ZPIN (A) = 0,0,0; 1,0,0; 1,0,0
DATA ZPIN (B) = 1,0,0; 2,0,0; 3,3,0
DATA ZPIN (C) = 3,3,0; 5,6,0; 4,0,0
DATA ZPIN (D) = 4,0,0; 3,3,0; 5,0,0
DATA POSITION (A) = 0, 30, 3
"""


def openimp(*args: str | Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "openimp.cli", *map(str, args)],
                          capture_output=True, text=True, preexec_fn=cpu_limit,
                          env={**os.environ, "MPLBACKEND": "Agg"})


def deck_file(tmp_path: Path, text: str, name: str = "deck.imp") -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


# =============================================================================
# names that IMP reads as one
# =============================================================================
def test_links_sharing_four_characters_are_warned_about(tmp_path) -> None:
    """CRANK1 and CRANK2 are one link for IMP (a triangle, not a four-bar): the
    deck fails to assemble, and the warning that explains why comes first."""
    p = deck_file(tmp_path, FOURBAR_LINKS.format(base="BASE", crank="CRANK1",
                                                 coupler="COUPLER", rocker="CRANK2")
                  + "EXECUTE\nEND\n")
    with pytest.raises(DeckError) as ei:
        load(p)
    warns = ei.value.warnings
    assert len(warns) == 1
    w = warns[0]
    assert w.where == (str(p), 4)  # ZPIN (COUPLER, CRANK2) = C
    text = str(w)
    assert text.startswith(f"{p}:4: warning: ")
    assert "CRANK2" in text and "CRANK1" in text and f"{p}:2" in text and "CRAN" in text
    assert "rename" in text
    # on the command line the warning precedes the error it explains (exit 2)
    r = openimp("check", p)
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert lines[0] == text and "over-specified" in r.stderr


def test_points_values_and_elements_sharing_four_characters(tmp_path) -> None:
    body = FOURBAR_LINKS.format(base="BASE", crank="CRANK", coupler="COUPLER",
                                rocker="ROCKER")
    p = deck_file(tmp_path, body + """POINT (COUPLER) = TRACE1, TRACE2, CB, CB
POINT (BASE) = QQ, QR
VALUE (SPEED1) = 1
VALUE (SPEED2) = 2
SPRING (QQ, QR) = SPRINGA
SPRING (QQ, QR) = SPRINGB
LIST POSITION (D)
EXECUTE
END
""")
    deck = load(p)
    got = [(w.where[1], str(w)) for w in deck.warnings]
    assert [line for line, _ in got] == [11, 14, 16]
    assert "point TRACE2 and point TRACE1 (the same statement)" in got[0][1]
    assert f"VALUE SPEED2 and VALUE SPEED1 ({p}:13)" in got[1][1]
    assert f"spring SPRINGB and spring SPRINGA ({p}:15)" in got[2][1]
    # the run prints them where IMP prints its messages, located
    echo: list[str] = []
    deck.run(echo=echo.append)
    assert f"*** {got[1][1]} ***" in echo


def test_no_warning_for_abbreviations_repeats_and_distinct_names(tmp_path) -> None:
    """COUP for COUPLER is an abbreviation; CB twice closes a polyline; a point
    deleted and defined again is a new point; distinct names are distinct."""
    body = FOURBAR_LINKS.format(base="BASE", crank="CRANK", coupler="COUPLER",
                                rocker="ROCKER")
    p = deck_file(tmp_path, body + """LINK (COUP)
POINT (COUP) = CB, CP1, CB
DELETE POINT (CP1)
POINT (COUPLER) = CP2
VALUE (SPEED) = 1
VALUE (SPEE) = 2
EXECUTE
END
""")
    deck = load(p)
    assert deck.warnings == []


def test_a_link_spelled_like_base_is_the_fixed_link(tmp_path) -> None:
    body = FOURBAR_LINKS.format(base="BASEPLATE", crank="CRANK", coupler="COUPLER",
                                rocker="ROCKER")
    deck = load(deck_file(tmp_path, body + "EXECUTE\nEND\n"))
    assert len(deck.warnings) == 1
    assert "link BASEPLATE is read as BASE, the fixed link" in str(deck.warnings[0])
    assert deck.warnings[0].where[1] == 2
    # named as the fixed link by GROUND, the same spelling is no surprise
    deck = load(deck_file(tmp_path, "GROUND = BASEPLATE\n" + body + "EXECUTE\nEND\n", "g.imp"))
    assert deck.warnings == []


# =============================================================================
# openimp check says what a run will not produce
# =============================================================================
def test_check_lists_what_the_run_does_not_produce(tmp_path) -> None:
    p = deck_file(tmp_path, FOURBAR_HEAD + """DATA POSITION (A) = 0, 30, 2
LIST POSITION (D)
LIST FORCE (A)
PRINT FREQUENCY
LIST DYNAMICS (0, 10, 1 / FORCE, A, 1) = POSITION, D
EXECUTE
DELETE INPUT ALL
FIND EQUILIB
EXECUTE
LIST VELOCITY (D)
END
""")
    n = HEAD_LINES
    check = openimp("check", p)
    run = openimp("run", p)
    assert check.returncode == run.returncode == 1
    assert "OK" not in check.stdout
    assert "INCOMPLETE: 3 request(s) or run(s) will not be produced" in check.stdout
    # the same messages, word for word, in the same order
    missing = [ln for ln in check.stderr.splitlines() if not ln.startswith("openimp: note")]
    ran = [ln for ln in run.stderr.splitlines() if not ln.startswith("openimp: note")]
    # LIST FORCE (A) is produced; the static run's PRINT FREQUENCY meets a massless
    # linkage at its equilibrium, which only the run can find (the posture is solved)
    assert missing == ran[:3] and len(missing) == 3 and len(ran) == 4
    assert "run 2" in ran[3] and "PRINT FREQUENCY is not produced at 1 of 1" in ran[3]
    assert missing[0] == (f"openimp: run 1 (FOUR-BAR FOR TESTS): {p}:{n + 4}: PRINT FREQUENCY "
                          "is not produced: the run has no free generalized coordinate "
                          "(mobility 1 at the starting posture, 1 input motion(s)): every "
                          "coordinate is specified, so nothing can vibrate")
    assert f"{p}:{n + 5}: LIST DYNAMICS is not produced" in missing[1]
    assert f"run 2 (FOUR-BAR FOR TESTS): {p}:{n + 5}: LIST DYNAMICS is not produced" \
        in missing[2]
    # a request after the last EXECUTE is produced by no run: both say so
    late = (f"openimp: note: {p}:{n + 10}: LIST VELOCITY comes after the last EXECUTE "
            f"({p}:{n + 9}), so no run produces it")
    assert any(ln.startswith(late) for ln in check.stderr.splitlines())
    assert any(ln.startswith(late) for ln in run.stderr.splitlines())


def test_check_ok_when_everything_is_produced(tmp_path) -> None:
    p = openimp("check", EXAMPLES / "hooke.imp")
    assert p.returncode == 0, p.stderr
    assert p.stdout.splitlines()[0].endswith(": OK")
    assert "openimp run --out DIR" in p.stderr  # its PLOT and ANIMATE need --out
    p = deck_file(tmp_path, FOURBAR_HEAD + "LIST POSITION (D)\nEND\n")
    for cmd in ("check", "run"):  # nothing would be run: exit status 1, said
        r = openimp(cmd, p)
        assert r.returncode == 1, (cmd, r.stderr)
        assert "no EXECUTE statement" in r.stderr
    assert "LIST POSITION is not produced" in openimp("check", p).stderr


# =============================================================================
# DATA POSITION without DATA TIME: steps, not seconds
# =============================================================================
def test_stepped_runs_label_the_step_and_plot_against_the_input(tmp_path, monkeypatch) -> None:
    import openimp.viz as viz

    drawn: list = []
    monkeypatch.setattr(viz, "plot_png", lambda t, path, columns=None, x=0: drawn.append((t, x)))
    deck = load(EXAMPLES / "fourbar.imp")  # DATA POSITION (A) = 0, 15, 24, no DATA TIME
    echo: list[str] = []
    run = deck.run(out_dir=tmp_path, echo=echo.append)[0]
    t = run.table("LIST POSITION", "joint D")
    assert t.columns == ["Step", "JVar 1"] and t.units == ["", "deg"]
    np.testing.assert_array_equal(t.rows[:, 0], np.arange(25))
    i = echo.index("Listing of position of joint D")
    assert echo[i + 1].split() == ["Step", "JVar", "1", "(deg)"]
    assert echo[i + 3].split()[0] == "1"
    # PLOT POSITION (D): the table carries the crank angle, and it is the abscissa
    (pt, x), = drawn
    assert pt.columns == ["Step", "A 1", "JVar 1"] and pt.units == ["", "deg", "deg"]
    assert x == 1
    np.testing.assert_allclose(pt.rows[:, 1], 15.0 * np.arange(25), atol=1e-9)
    np.testing.assert_allclose(pt.rows[:, 2], t.rows[:, 1])
    fig = viz._plot_figure(pt, None, x)
    assert fig.axes[0].get_xlabel() == "A 1 (deg)"
    np.testing.assert_allclose(fig.axes[0].lines[0].get_xydata(), pt.rows[:, 1:])
    # JSON keeps the same columns
    path = tmp_path / "o.json"
    from openimp import io

    io.write_json(path, [run])
    tables = json.loads(path.read_text())["runs"][0]["tables"]
    assert tables[0]["columns"][0] == "Step" and tables[0]["units"][0] == ""


def test_runs_with_data_time_keep_time_in_seconds(tmp_path, monkeypatch) -> None:
    import openimp.viz as viz

    drawn: list = []
    monkeypatch.setattr(viz, "plot_png", lambda t, path, columns=None, x=0: drawn.append((t, x)))
    run = load(EXAMPLES / "hooke.imp").run(out_dir=tmp_path)[0]
    t = run.table("LIST POSITION", "joint JOUT")
    assert t.columns[0] == "Time" and t.units[0] == "s"
    assert t.rows[-1, 0] == pytest.approx(1.0)
    (pt, x), = drawn
    assert pt.columns == ["Time", "JVar 1"] and x == 0


def test_print_output_numbers_the_steps(tmp_path) -> None:
    p = deck_file(tmp_path, FOURBAR_HEAD + "DATA POSITION (A) = 0, 30, 2\nPRINT POSITION (D)\n"
                  "EXECUTE\nDATA TIME = 0.2, 0, 0.1\nEXECUTE\nEND\n")
    echo: list[str] = []
    runs = load(p).run(echo=echo.append)
    assert [ln for ln in echo if ln.startswith(("step =", "time ="))] == [
        "step = 0", "step = 1", "step = 2", "time = 0.000000", "time = 0.100000",
        "time = 0.200000"]
    assert runs[0].table("PRINT POSITION", "joint D").columns[0] == "Step"
    assert runs[1].table("PRINT POSITION", "joint D").columns[0] == "Time"
