"""IMP's tolerance of odd lines (issue 25 item 3): a statement IMP answered with a
message and passed over is a located warning and the deck goes on; an EXECUTE
that cannot be built fails alone while the others run; ``--strict`` (and
``load(strict=True)``) keeps the refusal.
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from helpers.decks import FOUR_LOOP, cpu_limit, line_of, run_deck, write
from openimp.imp.deck import load
from openimp.imp.interp import DeckError

REF = Path(__file__).resolve().parents[2] / "shared" / "reference"

FOUR = FOUR_LOOP + """POINT (CPLR) = P
DATA POINT (P, ABS) = 2, 1, 0
"""
RUN = "DATA POSITION (A) = 0, 10, 3\nLIST POSITION (A)\nEXECUTE\nEND\n"

#: (the odd lines, which of them is warned about (0-based), words of its message): each
#: case of the issue's audit list
CASES = [
    ("DELETE POINT (P)\nLIST POSITION (P)\n", 1,
     "P is not a joint, point, link, spring or damper defined by EXECUTE"),
    ("FIND EQUILIBRIUM\nFIND DYNAMICS\nDELETE EQUILIBRIUM\n", 1,
     "FIND DYNAMICS after FIND EQUILIB"),
    ("DATA IC (A) = 10, 0\n", 0, "DATA IC needs FIND DYNAMICS first"),
    ("SOLID READ S1 = nofile.geo\nSHAPE (CRNK) = S1\n", 0,
     "the file 'nofile.geo' does not exist"),
    ("DATA SHAPE (CRNK) = S\n", 0, "DATA SHAPE is mentioned by the manual"),
]
IDS = ["deleted-item", "find-wrong-mode", "ic-before-find", "solid-file-missing", "data-shape"]
#: the line number of the first odd line
FIRST = FOUR.count("\n") + 1


@pytest.mark.parametrize(("odd", "k", "words"), CASES, ids=IDS)
def test_odd_line_is_a_located_message_and_the_deck_runs(tmp_path, odd, k, words) -> None:
    p = write(tmp_path, FOUR + odd + RUN)
    runs, echo = run_deck(p)
    where = f"{p}:{FIRST + k}:"
    said = [ln for ln in echo if where in ln and words in ln]
    assert said, (where, echo)
    assert len(runs) == 1 and not runs[0].failure, runs[0].failure
    np.testing.assert_allclose(runs[0].table("LIST POSITION", "joint A").rows[:, 1],
                               [0, 10, 20, 30], atol=1e-12)


@pytest.mark.parametrize(("odd", "k", "words"), CASES, ids=IDS)
def test_strict_refuses_the_odd_line(tmp_path, odd, k, words) -> None:
    p = write(tmp_path, FOUR + odd + RUN)
    with pytest.raises(DeckError) as info:
        load(p, strict=True)
    assert any(e.where == (str(p), FIRST + k) and words in str(e)
               for e in info.value.errors), [(e.where, str(e)) for e in info.value.errors]


def test_an_execute_that_cannot_run_fails_alone(tmp_path) -> None:
    """A DATA MOTION whose VALUE is not defined by EXECUTE stops that EXECUTE (its
    message, exit status 1); the next EXECUTE runs; ``check --strict`` refuses the deck
    (exit 2)."""
    text = FOUR + ("DATA MOTION (A) = RAMP\nLIST POSITION (A)\nEXECUTE\n"
                   "VALUE (RAMP) = 0.1 * T\nEXECUTE\nEND\n")
    p = write(tmp_path, text)
    runs, _echo = run_deck(p)
    n = line_of(text, "DATA MOTION (A)")  # the statement to change
    assert len(runs) == 2 and not runs[0].ok and runs[1].ok
    assert runs[0].failure.startswith(f"{p}:{n}: DATA MOTION statement: VALUE RAMP is not "
                                      "defined by EXECUTE"), runs[0].failure
    a = runs[1].table("LIST POSITION", "joint A").rows
    np.testing.assert_allclose(a[:, 1], np.degrees(0.1 * a[:, 0]), atol=1e-9)
    cmd = [sys.executable, "-m", "openimp.cli"]
    r = subprocess.run([*cmd, "check", str(p)], capture_output=True, text=True,
                       preexec_fn=cpu_limit)
    assert r.returncode == 1 and f"{p}:{n}: warning: DATA MOTION statement: VALUE RAMP" \
        in r.stderr
    assert "will not run" in r.stdout
    r = subprocess.run([*cmd, "check", "--strict", str(p)], capture_output=True, text=True,
                       preexec_fn=cpu_limit)
    assert r.returncode == 2 and f"{p}:{n}: DATA MOTION statement: VALUE RAMP" in r.stderr


def test_every_execute_failing_still_refuses_the_deck(tmp_path) -> None:
    text = FOUR + "DATA MOTION (A) = RAMP\nEXECUTE\nEND\n"
    with pytest.raises(DeckError, match="VALUE RAMP is not defined by EXECUTE"):
        load(write(tmp_path, text))


#: a parallelogram: the rocker turns with the crank, so that joint D's angle is -A's and
#: joint B's is -A's too (B joins the crank to a coupler that stays parallel to the base)
PARA = """ZPIN (BASE, CRNK) = A
DATA ZPIN (A) = 0,0,0; 1,0,0; 1,0,0
ZPIN (CRNK, CPLR) = B
DATA ZPIN (B) = 0,1,0; 1,1,0; 1,1,0
ZPIN (CPLR, ROCK) = C
DATA ZPIN (C) = 2,1,0; 3,1,0; 3,1,0
ZPIN (ROCK, BASE) = D
DATA ZPIN (D) = 2,0,0; 3,0,0; 3,0,0
DATA POSITION (A) = 0, 10, 3
"""


def test_consistent_over_specified_inputs_run(tmp_path) -> None:
    """IMP assembled over-specified inputs that agree (issue 25): the later input is
    checked, not driven, at every position; the run says so, ``check`` says so and
    passes, ``--strict`` refuses it."""
    text = PARA + "DATA POSITION (D) = 0, -10, 3\nLIST POSITION (A, D, B)\nEXECUTE\nEND\n"
    p = write(tmp_path, text)
    runs, echo = run_deck(p)
    n = line_of(text, "DATA POSITION (D)")
    assert runs[0].ok and not runs[0].missing, runs[0].failure
    a = runs[0].table("LIST POSITION", "joint A").rows[:, 1]
    np.testing.assert_allclose(a, [0, 10, 20, 30], atol=1e-12)
    for joint in ("D", "B"):  # the parallelogram's closed form
        np.testing.assert_allclose(runs[0].table("LIST POSITION", f"joint {joint}").rows[:, 1],
                                   -a, atol=1e-9)
    said = [ln for ln in echo if "over-specified input: joint D variable 1" in ln]
    assert len(said) == 1 and f"{p}:{n}: DATA POSITION" in said[0]
    cmd = [sys.executable, "-m", "openimp.cli"]
    r = subprocess.run([*cmd, "check", str(p)], capture_output=True, text=True,
                       preexec_fn=cpu_limit)
    assert r.returncode == 0 and f"{p}:{n}: DATA POSITION: over-specified input" in r.stderr
    r = subprocess.run([*cmd, "check", "--strict", str(p)], capture_output=True, text=True,
                       preexec_fn=cpu_limit)
    assert r.returncode == 2 and f"{p}:{n}: EXECUTE: over-specified motion" in r.stderr


def test_over_specified_inputs_that_disagree_are_skipped(tmp_path) -> None:
    """Where the checked input disagrees with the posture the others give, the position
    is skipped with both values named, as IMP's assembly failed there; where it agrees
    again the run goes on.  A turns at 10 deg/s; D is given -A up to 10 deg, then held
    at -10 deg."""
    text = PARA.replace("DATA POSITION (A) = 0, 10, 3", "DATA MOTION (A) = AANG") + (
        "VALUE (AANG) = T * PI / 18\nDATA MOTION (D) = DANG\n"
        "VALUE (DANG) = IF(T - 1.5: 0 - T * PI / 18, 0, 0 - PI / 18)\nDATA TIME = 3, 0, 1\n"
        "LIST POSITION (A, D)\nEXECUTE\nEND\n")
    p = write(tmp_path, text)
    runs, _echo = run_deck(p)
    r = runs[0]
    assert not r.failure and r.missing == [2.0, 3.0], (r.failure, r.missing)
    np.testing.assert_allclose(r.table("LIST POSITION", "joint D").rows[:, 1], [0, -10],
                               atol=1e-9)
    skip = [m for m in r.messages if "cannot be reached" in m]
    assert len(skip) == 1 and "steps 2 to 3" in skip[0]
    assert "the over-specified input D 1 is given the position -10 deg, but the other " \
           "inputs and the loops make it -20 deg" in skip[0], skip[0]


# =============================================================================
# IMP's printout of a run without DATA TIME (issue 25 item 8)
# =============================================================================
@pytest.mark.parametrize("how", ["remark", "cli"])
def test_imp_listing_labels_the_step_as_time(tmp_path, how) -> None:
    """IMP printed ``time = %.6f`` per output and a ``Time`` column holding the step
    number, with no units in the titles; openimp's default says Step
    (test_first_use)."""
    head = "REMARK OPENIMP LISTING = IMP\n" if how == "remark" else ""
    p = write(tmp_path, head + FOUR + "DATA POSITION (A) = 0, 10, 2\nPRINT POSITION (A)\n"
              "LIST POSITION (A)\nEXECUTE\nEND\n")
    r = subprocess.run([sys.executable, "-m", "openimp.cli", "run", str(p),
                        *(["--imp-listing"] if how == "cli" else [])],
                       capture_output=True, text=True, preexec_fn=cpu_limit)
    assert r.returncode == 0, r.stderr
    lines = [ln.strip() for ln in r.stdout.splitlines()]
    assert [ln for ln in lines if ln.startswith(("time =", "step ="))] == [
        "time = 0.000000", "time = 1.000000", "time = 2.000000"]
    i = lines.index("Listing of position of joint A")
    assert lines[i + 1].split() == ["Time", "JVar", "1"]
    assert [ln.split() for ln in lines[i + 2:i + 5]] == [
        ["0.000000", "0.000"], ["1.000000", "10.000"], ["2.000000", "20.000"]]


# =============================================================================
# positions that cannot be reached are skipped (issue 25 item 5)
# =============================================================================
#: the four-bar FOUR: crank A-B (1), coupler B-C (sqrt 8), rocker D-C (sqrt 5), ground 4
A0, B0, C0, D0 = (np.array(v, float) for v in ((0, 0), (1, 0), (3, 2), (4, 0)))


def _turn(v: np.ndarray, a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1]])


def crank_angles(rocker: float) -> list[float]:
    """The crank angles (deg, from the drawing) that close the loop at a rocker turn
    (rad, from the drawing): B on the unit circle about A at sqrt(8) from C."""
    C = D0 + _turn(C0 - D0, rocker)
    d = np.linalg.norm(C - A0)
    a = (1 + d * d - 8.0) / (2 * d)  # along AC from A to the chord of intersection
    h = np.sqrt(max(1 - a * a, 0.0))
    u = (C - A0) / d
    n = np.array([-u[1], u[0]])
    return [float(np.degrees(np.arctan2(*(a * u + s * h * n)[::-1]))) for s in (1, -1)]


def test_a_sweep_through_a_limit_of_travel_skips_and_goes_on(tmp_path) -> None:
    """The rocker driven by 0.5 sin(t) rad swings beyond its limit of travel (where crank
    and coupler line up, |AC| = 1 + sqrt 8) and back: the positions beyond are
    skipped, each with a located message, the run records their times and lists
    every other position, each a closure of the loop."""
    text = FOUR + ("VALUE (V) = 0.5*SIN(T)\nDATA MOTION (D) = V\nDATA TIME = 6, 0, 0.25\n"
                   "LIST POSITION (A, D)\nEXECUTE\nEND\n")
    p = write(tmp_path, text)
    runs, echo = run_deck(p)
    r = runs[0]
    t = np.arange(25) * 0.25
    rocker = 0.5 * np.sin(t)  # D's variable: BASE turned from ROCK, so the rocker turns -D
    C = np.array([D0 + _turn(C0 - D0, -x) for x in rocker])
    beyond = np.linalg.norm(C - A0, axis=1) > 1 + np.sqrt(8.0)
    assert 0 < beyond.sum() < len(t)
    np.testing.assert_allclose(r.missing, t[beyond], atol=1e-12)
    assert not r.failure, r.failure
    rows = r.table("LIST POSITION", "joint A").rows
    np.testing.assert_allclose(rows[:, 0], t[~beyond], atol=1e-12)
    np.testing.assert_allclose(r.table("LIST POSITION", "joint D").rows[:, 1],
                               np.degrees(rocker[~beyond]), atol=1e-9)
    for x, a in zip(rocker[~beyond], rows[:, 1], strict=True):
        assert min(abs((a - c + 180) % 360 - 180) for c in crank_angles(-x)) < 1e-8
    where = f"{p}:{line_of(text, 'EXECUTE')}: EXECUTE: step"
    said = set()  # the steps the messages name: one message per run of them
    for ln in echo:
        m = re.search(r"EXECUTE: steps? (\d+)(?: to (\d+))? \(.*cannot be reached", ln)
        if m and where in ln:
            said |= set(range(int(m[1]), int(m[2] or m[1]) + 1))
    assert said == set(np.flatnonzero(beyond)), echo


def test_statements_accepted_but_unused_say_so(tmp_path) -> None:
    """CONTACT and IMPACT (the contact issue simulates them), ZERO (DATA) and ZERO (ZERO)
    (openimp's own tolerances) are accepted with a message at their line, not in
    silence."""
    for name in ("hex", "tri"):
        src = REF / f"imp-solids-example-{name}.geo"
        if not src.exists():
            pytest.skip("shared/reference is not beside the checkout")
        (tmp_path / f"{name}.geo").write_text(src.read_text())
    odd = ("SOLID READ S1 = hex.geo\nSOLID READ S2 = tri.geo\nSHAPE (CRNK) = S1\n"
           "SHAPE (ROCK) = S2\nCONTACT (S1, S2) = K1\nIMPACT = 1, 0, 0\n"
           "ZERO (DATA) = 1E-5\nZERO (ZERO) = 1E-7\n")
    p = write(tmp_path, FOUR + odd + RUN)
    runs, echo = run_deck(p)
    assert not runs[0].failure
    for k, words in ((4, "Contact K1 is accepted but not simulated"),
                     (5, "IMPACT is accepted but not simulated"),
                     (6, "ZERO (DATA) is accepted and not used"),
                     (7, "ZERO (ZERO) is accepted and not used")):
        assert any(f"{p}:{FIRST + k}: {words}" in ln for ln in echo), (words, echo)


def test_over_specified_rates_are_checked_too(tmp_path) -> None:
    """Positions that agree with rates that do not (A turns at 1 rad/s, D is given no
    velocity): the velocity of the checked input is compared as its position is."""
    text = PARA + ("DATA VELOCITY (A) = 1\nDATA POSITION (D) = 0, -10, 3\n"
                   "LIST POSITION (A)\nEXECUTE\nEND\n")
    r = run_deck(write(tmp_path, text))[0][0]
    assert r.missing == [0.0, 1.0, 2.0, 3.0]
    assert "the over-specified input D 1 is given the velocity 0 rad/s, but the other " \
           "inputs and the loops make it -1 rad/s" in r.failure + " ".join(r.messages)
